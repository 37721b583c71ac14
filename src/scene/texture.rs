//! Colour textures: bilinear lookup with wrap modes.
//!
//! Convention: texture coordinates (u, v) have (0, 0) at the image's top-left corner, v grows
//! downwards (glTF's); texel (i, j) covers [i, i + 1) × [j, j + 1) in units of texels, so its
//! centre is at ((i + ½) / width, (j + ½) / height). Texels are linear RGB.

use crate::io::desc::{TextureDesc, Wrap};
use crate::math::Rgb;
use glam::Vec2;

/// A texture ready for lookups.
#[derive(Clone, Debug)]
pub struct Texture {
    width: u32,
    height: u32,
    texels: Vec<Rgb>,
    wrap: [Wrap; 2],
    nearest: bool,
    uv_transform: Option<glam::Affine2>,
}

impl Texture {
    /// The texture of a description; `None` when it holds no texels or not `width × height`.
    pub fn new(d: &TextureDesc) -> Option<Texture> {
        let n = d.width as usize * d.height as usize;
        (n > 0 && d.texels.len() == n).then(|| Texture {
            width: d.width,
            height: d.height,
            texels: d.texels.clone(),
            wrap: d.wrap,
            nearest: d.nearest,
            uv_transform: d.uv_transform,
        })
    }

    /// `uv` through the texture's coordinate transform; non-finite coordinates become (0, 0).
    #[inline]
    fn coordinates(&self, uv: Vec2) -> Vec2 {
        let uv = match &self.uv_transform {
            Some(t) => t.transform_point2(uv),
            None => uv,
        };
        if uv.is_finite() {
            uv
        } else {
            Vec2::ZERO
        }
    }

    /// The four texels of a bilinear lookup at (transformed) `st`: their columns and rows
    /// (wrapped) and the weights `(fx, fy)` of the second column and row.
    #[inline]
    fn footprint(&self, st: Vec2) -> ([usize; 2], [usize; 2], f32, f32) {
        let x = st.x as f64 * self.width as f64 - 0.5;
        let y = st.y as f64 * self.height as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let ix = [
            wrap(x0, self.width, self.wrap[0]),
            wrap(x0 + 1, self.width, self.wrap[0]),
        ];
        let iy = [
            wrap(y0, self.height, self.wrap[1]),
            wrap(y0 + 1, self.height, self.wrap[1]),
        ];
        (ix, iy, fx, fy)
    }

    /// The bilinearly interpolated (or nearest) colour at `uv`, after the texture's
    /// coordinate transform; non-finite coordinates give texel (0, 0).
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let uv = self.coordinates(uv);
        if self.nearest {
            let x = (uv.x as f64 * self.width as f64).floor() as i64;
            let y = (uv.y as f64 * self.height as f64).floor() as i64;
            let (i, j) = (
                wrap(x, self.width, self.wrap[0]),
                wrap(y, self.height, self.wrap[1]),
            );
            return self.texels[j * self.width as usize + i];
        }
        let (ix, iy, fx, fy) = self.footprint(uv);
        let t = |i: usize, j: usize| self.texels[iy[j] * self.width as usize + ix[i]];
        (t(0, 0) * (1.0 - fx) + t(1, 0) * fx) * (1.0 - fy)
            + (t(0, 1) * (1.0 - fx) + t(1, 1) * fx) * fy
    }

    /// The gradient `(∂f/∂u, ∂f/∂v)` of the red channel's bilinear interpolation at `uv`
    /// (through the coordinate transform; zero for nearest lookups), as Mitsuba's
    /// `eval_1_grad`.
    pub fn gradient(&self, uv: Vec2) -> Vec2 {
        if self.nearest {
            return Vec2::ZERO;
        }
        let (ix, iy, fx, fy) = self.footprint(self.coordinates(uv));
        let f = |i: usize, j: usize| self.texels[iy[j] * self.width as usize + ix[i]].x;
        let d = Vec2::new(
            (1.0 - fy) * (f(1, 0) - f(0, 0)) + fy * (f(1, 1) - f(0, 1)),
            (1.0 - fx) * (f(0, 1) - f(0, 0)) + fx * (f(1, 1) - f(1, 0)),
        ) * Vec2::new(self.width as f32, self.height as f32);
        let linear = self
            .uv_transform
            .map_or(glam::Mat2::IDENTITY, |t| t.matrix2);
        linear.transpose() * d
    }
}

/// Texel index `i` of an axis `n` texels long, wrapped by `mode`.
fn wrap(i: i64, n: u32, mode: Wrap) -> usize {
    let n = n as i64;
    let i = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let k = i.rem_euclid(2 * n);
            if k < n {
                k
            } else {
                2 * n - 1 - k
            }
        }
    };
    i as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn tex(wrap: Wrap) -> Texture {
        // 2×2: red, green / blue, white (top row first).
        Texture::new(&TextureDesc {
            slot: crate::io::desc::TextureSlot::BaseColor,
            name: "t".into(),
            material: 0,
            width: 2,
            height: 2,
            texels: vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
            wrap: [wrap; 2],
            nearest: false,
            uv_transform: None,
        })
        .unwrap()
    }

    #[test]
    fn texel_centres_give_their_texels_and_the_top_row_is_v_0() {
        let t = tex(Wrap::Clamp);
        assert_eq!(t.eval(Vec2::new(0.25, 0.25)), Vec3::X);
        assert_eq!(t.eval(Vec2::new(0.75, 0.25)), Vec3::Y);
        assert_eq!(t.eval(Vec2::new(0.25, 0.75)), Vec3::Z);
        assert_eq!(t.eval(Vec2::new(0.75, 0.75)), Vec3::ONE);
        // Halfway between the centres of the top row: the mean of red and green.
        assert!((t.eval(Vec2::new(0.5, 0.25)) - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
        // The centre of the image: the mean of all four.
        let c = t.eval(Vec2::splat(0.5));
        assert!((c - Vec3::new(0.5, 0.5, 0.5)).length() < 1e-6, "{c}");
    }

    #[test]
    fn wrap_modes() {
        // Clamp: beyond the left edge the left column extends.
        assert_eq!(tex(Wrap::Clamp).eval(Vec2::new(-3.0, 0.25)), Vec3::X);
        // Repeat: u + 1 is u.
        let r = tex(Wrap::Repeat);
        assert_eq!(r.eval(Vec2::new(1.25, 0.25)), r.eval(Vec2::new(0.25, 0.25)));
        assert_eq!(r.eval(Vec2::new(-0.75, 1.75)), Vec3::Z);
        // At u = 0 (the left edge) repeat blends with the right column, clamp does not.
        assert!((r.eval(Vec2::new(0.0, 0.25)) - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
        // Mirror: [1, 2) is [0, 1) reversed.
        let m = tex(Wrap::Mirror);
        assert_eq!(m.eval(Vec2::new(1.25, 0.25)), Vec3::Y);
        assert_eq!(m.eval(Vec2::new(1.75, 0.25)), Vec3::X);
        // Non-finite coordinates do not panic or poison.
        assert!(m.eval(Vec2::new(f32::NAN, f32::INFINITY)).is_finite());
        assert!(Texture::new(&TextureDesc {
            slot: crate::io::desc::TextureSlot::BaseColor,
            name: "empty".into(),
            material: 0,
            width: 0,
            height: 3,
            texels: vec![],
            wrap: [Wrap::Repeat; 2],
            nearest: false,
            uv_transform: None,
        })
        .is_none());
    }
}
