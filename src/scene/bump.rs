//! pbrt-v4's bump mapping (`displacement` on a material): a float texture `d(u, v)` displaces
//! the surface along its shading normal, and the shading normal becomes that of the displaced
//! surface, as pbrt-v4's `BumpMap`:
//!
//! ```text
//! ∂p/∂u' = ∂p/∂u + ∂d/∂u · n + d · ∂n/∂u      ∂p/∂v' = ∂p/∂v + ∂d/∂v · n + d · ∂n/∂v
//! n' = normalize(∂p/∂u' × ∂p/∂v'), turned to the geometric normal's side
//! ```
//!
//! with pbrt-v4's shading frame on triangles: without vertex normals, the true `∂p/∂u`,
//! `∂p/∂v` and the geometric normal (∂n = 0); with them, the interpolated normal `n`,
//! `∂p/∂u` made perpendicular to it and `∂p/∂v` replaced by `n × ∂p/∂u` (pbrt-v4's `ss`
//! and `ts`), and `∂n/∂u`, `∂n/∂v` from the vertex normals. pbrt-v4 differentiates `d` by a
//! finite step of an eighth of a pixel footprint or less; the analytic gradient of the
//! bilinear lookup ([`Texture::gradient`]) is that step's limit.
//!
//! This renderer's texture v runs down the image (pbrt's `1 − v`): `∂/∂v` changes sign, and
//! the formulas below are pbrt's with that substitution. A planar mesh whose given vertex
//! normals all agree is shaded as one without normals (its `∂p/∂v` is the true one).

use super::geometry::Triangle;
use super::texture::Texture;
use super::TriInfo;
use glam::{Vec2, Vec3};

/// The shading normal of `tri` (shading data `info`, texture coordinates `t`) at barycentric
/// coordinates `b` (weights of vertices 0, 1, 2) and texture coordinates `uv`, bump-mapped by
/// the displacement texture `d` (its red channel); on `info.ng`'s side. `None` where the
/// texture coordinates are degenerate or the result is not a direction.
pub fn bumped_normal(
    tri: &Triangle,
    info: &TriInfo,
    t: &[Vec2; 3],
    b: [f32; 3],
    uv: Vec2,
    d: &Texture,
) -> Option<Vec3> {
    let (dpdu, dpdv_down) = derivatives(tri.v, t)?;
    let displacement = d.eval(uv).x;
    let gradient = d.gradient(uv);
    // pbrt's ∂/∂v is along −v here.
    let (ddu, ddv) = (gradient.x, -gradient.y);
    let (dpdu, dpdv) = if info.flat {
        let n = info.ng;
        (dpdu + ddu * n, -dpdv_down + ddv * n)
    } else {
        let n = (info.n[0] * b[0] + info.n[1] * b[1] + info.n[2] * b[2]).try_normalize()?;
        let (dndu, dndv_down) = derivatives(info.n, t).unwrap_or((Vec3::ZERO, Vec3::ZERO));
        let ss = dpdu - n * n.dot(dpdu);
        let ts = n.cross(dpdu);
        (
            ss + ddu * n + displacement * dndu,
            ts + ddv * n - displacement * dndv_down,
        )
    };
    let bent = dpdu.cross(dpdv).try_normalize()?;
    Some(if bent.dot(info.ng) < 0.0 { -bent } else { bent })
}

/// `(∂f/∂u, ∂f/∂v)` of the linear interpolation of the vertex values `f` over texture
/// coordinates `t` (v down the image); `None` where the coordinates are degenerate.
fn derivatives(f: [Vec3; 3], t: &[Vec2; 3]) -> Option<(Vec3, Vec3)> {
    let (df1, df2) = (f[1] - f[0], f[2] - f[0]);
    let (d1, d2) = (t[1] - t[0], t[2] - t[0]);
    let det = d1.x * d2.y - d1.y * d2.x;
    if det.abs() < 1e-12 || !det.is_finite() {
        return None;
    }
    Some((
        (df1 * d2.y - df2 * d1.y) / det,
        (df2 * d1.x - df1 * d2.x) / det,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::desc::{TextureDesc, TextureSlot, Wrap};

    /// A 2×1 texture rising by `rise` from left to right texel, clamped at the edges.
    fn ramp(rise: f32) -> Texture {
        Texture::new(&TextureDesc {
            name: "ramp".into(),
            material: 0,
            slot: TextureSlot::Displacement,
            width: 2,
            height: 1,
            texels: vec![Vec3::ZERO, Vec3::splat(rise)],
            wrap: [Wrap::Clamp; 2],
            nearest: false,
            uv_transform: None,
        })
        .unwrap()
    }

    /// The unit square in the XZ plane, facing +Y, u along +X and (this renderer's) v along
    /// +Z, so pbrt's v runs along −Z.
    fn square() -> (Triangle, [Vec2; 3]) {
        let tri = Triangle {
            v: [Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0), Vec3::X],
        };
        (tri, [Vec2::ZERO, Vec2::ONE, Vec2::X])
    }

    #[test]
    fn a_slope_in_u_tilts_the_normal_against_it_with_or_without_vertex_normals() {
        let (tri, t) = square();
        let b = [0.5, 0.25, 0.25];
        let uv = Vec2::new(0.5, 0.25);
        // d rises by 0.1 over half a unit of u: slope 0.2 (texel centres 0.25 and 0.75).
        let d = ramp(0.1);
        let want = Vec3::new(-0.2, 1.0, 0.0).normalize();
        for n in [Vec3::Y, -Vec3::Y] {
            let flat = TriInfo::new([n; 3], Vec3::Y, 0, 0);
            let got = bumped_normal(&tri, &flat, &t, b, uv, &d).unwrap();
            assert!((got - want).length() < 1e-5, "{got} {want}");
        }
        // Vertex normals that differ (slightly): pbrt's interpolated frame, the same slope.
        let tilt = Vec3::new(0.0, 1.0, 1e-3).normalize();
        let smooth = TriInfo::new([Vec3::Y, Vec3::Y, tilt], Vec3::Y, 0, 0);
        let got = bumped_normal(&tri, &smooth, &t, b, uv, &d).unwrap();
        assert!((got - want).length() < 1e-2, "{got} {want}");
    }

    #[test]
    fn a_constant_displacement_leaves_a_flat_normal() {
        let (tri, t) = square();
        let flat = TriInfo::new([Vec3::Y; 3], Vec3::Y, 0, 0);
        let got = bumped_normal(
            &tri,
            &flat,
            &t,
            [0.2, 0.3, 0.5],
            Vec2::splat(0.4),
            &ramp(0.0),
        );
        assert_eq!(got, Some(Vec3::Y));
        let degenerate = [Vec2::ZERO; 3];
        assert_eq!(
            bumped_normal(
                &tri,
                &flat,
                &degenerate,
                [0.2, 0.3, 0.5],
                Vec2::ZERO,
                &ramp(1.0)
            ),
            None
        );
    }
}
