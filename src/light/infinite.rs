//! pbrt-v4's `infinite` light: constant radiance from every direction, or an image in
//! pbrt-v4's equal-area octahedral square mapping (Clarberg 2008), with the light's own
//! transform.
//!
//! - Mapping: a light-space direction `d` and image coordinates `(u, v) ∈ [0,1]²` with `v`
//!   down the image (row 0 on top) correspond by [`square_to_sphere`] / [`sphere_to_square`];
//!   every texel covers the same solid angle `4π / (w·h)`.
//! - Radiance is the nearest texel's (pbrt-v4's lookup), times `scale`.
//! - Sampling: a texel in proportion to its luminance (piecewise constant over the square,
//!   exactly the radiance's shape), then a uniform point in it; the solid-angle pdf is
//!   `p(u, v) / (4π)`. A constant light is sampled uniformly over the sphere.

use crate::math::{luminance, Rgb};
use crate::sampling::{uniform_sphere, Distribution1D, UNIFORM_SPHERE_PDF};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::{FRAC_PI_4, PI};

/// A point of the equal-area square → the unit direction (light space).
pub fn square_to_sphere(p: Vec2) -> Vec3 {
    let (u, v) = (2.0 * p.x - 1.0, 2.0 * p.y - 1.0);
    let (up, vp) = (u.abs(), v.abs());
    let signed = 1.0 - (up + vp);
    let r = 1.0 - signed.abs();
    let phi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * FRAC_PI_4;
    let z = (1.0 - r * r).copysign(signed);
    let s = r * (2.0 - r * r).max(0.0).sqrt();
    Vec3::new(phi.cos().copysign(u) * s, phi.sin().copysign(v) * s, z)
}

/// A unit direction (light space) → its point of the equal-area square.
pub fn sphere_to_square(d: Vec3) -> Vec2 {
    let (x, y, z) = (d.x.abs(), d.y.abs(), d.z.abs());
    let r = (1.0 - z).max(0.0).sqrt();
    let a = x.max(y);
    let b = if a == 0.0 { 0.0 } else { x.min(y) / a };
    let mut phi = b.atan() * 2.0 / PI;
    if x < y {
        phi = 1.0 - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if d.z < 0.0 {
        std::mem::swap(&mut u, &mut v);
        u = 1.0 - u;
        v = 1.0 - v;
    }
    Vec2::new((u.copysign(d.x) + 1.0) * 0.5, (v.copysign(d.y) + 1.0) * 0.5)
}

/// An equal-area image with its sampling tables.
#[derive(Clone, Debug)]
struct SquareImage {
    size: usize,
    texels: Vec<Rgb>,
    /// Rows by their luminance sums.
    rows: Distribution1D,
    /// Texels of each row by luminance.
    columns: Vec<Distribution1D>,
}

/// An infinitely distant light surrounding the scene.
#[derive(Clone, Debug)]
pub struct InfiniteLight {
    /// World from light space (a rotation; the transform's scale and shear are removed).
    to_world: Mat3,
    /// Light from world space.
    to_light: Mat3,
    /// Constant radiance, or the multiplier of the image's texels.
    scale: Rgb,
    image: Option<SquareImage>,
}

impl InfiniteLight {
    /// A light of constant radiance `radiance`.
    pub fn constant(radiance: Rgb) -> Self {
        InfiniteLight {
            to_world: Mat3::IDENTITY,
            to_light: Mat3::IDENTITY,
            scale: radiance,
            image: None,
        }
    }

    /// A light of the square image `texels` (`size × size`, rows from the top), its texels
    /// times `scale`, turned by `to_world` (orthonormalised). `None` unless `texels` holds
    /// `size²` values.
    pub fn image(size: usize, texels: Vec<Rgb>, scale: Rgb, to_world: Mat3) -> Option<Self> {
        if size == 0 || texels.len() != size * size {
            return None;
        }
        let texels: Vec<Rgb> = texels
            .into_iter()
            .map(|t| {
                if t.is_finite() {
                    t.max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        let columns: Vec<Distribution1D> = texels
            .chunks(size)
            .map(|row| Distribution1D::new(&row.iter().map(|&t| luminance(t)).collect::<Vec<_>>()))
            .collect();
        let rows = Distribution1D::new(&columns.iter().map(|c| c.total()).collect::<Vec<_>>());
        let x = to_world.x_axis.normalize_or(Vec3::X);
        let y =
            (to_world.y_axis - x * x.dot(to_world.y_axis)).normalize_or(x.any_orthonormal_vector());
        let z = x.cross(y);
        // Keep the handedness of the file's transform (a mirroring transform mirrors the map).
        let z = if to_world.determinant() < 0.0 { -z } else { z };
        let rot = Mat3::from_cols(x, y, z);
        Some(InfiniteLight {
            to_world: rot,
            to_light: rot.inverse(),
            scale,
            image: Some(SquareImage {
                size,
                texels,
                rows,
                columns,
            }),
        })
    }

    /// The texel of an image light that world direction `d` falls in.
    fn texel_of(&self, img: &SquareImage, d: Vec3) -> (usize, usize) {
        let p = sphere_to_square((self.to_light * d).normalize_or(Vec3::Z));
        let n = img.size;
        let x = ((p.x * n as f32) as usize).min(n - 1);
        let y = ((p.y * n as f32) as usize).min(n - 1);
        (x, y)
    }

    /// Radiance arriving from world direction `d`.
    pub fn radiance(&self, d: Vec3) -> Rgb {
        self.radiance_pdf(d).0
    }

    /// [`InfiniteLight::radiance`] and [`InfiniteLight::pdf`] of `d`, mapped once.
    pub fn radiance_pdf(&self, d: Vec3) -> (Rgb, f32) {
        match &self.image {
            None => (self.scale, UNIFORM_SPHERE_PDF),
            Some(img) => {
                let (x, y) = self.texel_of(img, d);
                let radiance = img.texels[y * img.size + x] * self.scale;
                let pdf = if img.rows.total() > 0.0 {
                    let n = img.size;
                    img.rows.pmf(y) * img.columns[y].pmf(x) * (n * n) as f32 / (4.0 * PI)
                } else {
                    UNIFORM_SPHERE_PDF
                };
                (radiance, pdf)
            }
        }
    }

    /// Samples a world direction from uniform `u`: the direction, its radiance and its
    /// solid-angle pdf.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Rgb, f32)> {
        let Some(img) = self.image.as_ref().filter(|i| i.rows.total() > 0.0) else {
            let d = uniform_sphere(u);
            return Some((d, self.radiance(d), self.pdf(d)));
        };
        let (y, py, uy) = img.rows.sample(u.y);
        let (x, px, ux) = img.columns[y].sample(u.x);
        let n = img.size as f32;
        let p = Vec2::new((x as f32 + ux) / n, (y as f32 + uy) / n);
        let d = (self.to_world * square_to_sphere(p)).normalize();
        let pdf = py * px * n * n / (4.0 * PI);
        (pdf > 0.0).then(|| (d, img.texels[y * img.size + x] * self.scale, pdf))
    }

    /// Solid-angle pdf of [`InfiniteLight::sample`] choosing world direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.radiance_pdf(d).1
    }

    /// Mean luminance over the sphere.
    pub fn average_luminance(&self) -> f32 {
        match &self.image {
            None => luminance(self.scale),
            Some(img) => {
                let sum: f32 = img.texels.iter().map(|&t| luminance(t * self.scale)).sum();
                sum / img.texels.len() as f32
            }
        }
    }

    /// pbrt-v4's reference for `illuminance`: for a constant light `π·L`, the irradiance of
    /// a surface facing light-space +Z (in luminance); for an image, pbrt-v4's sum over the
    /// texels of the upper hemisphere of `luminance · cos θ` times `2π / texels` (half the
    /// texels' solid angle, as pbrt-v4 computes it, so that files scale as there).
    pub fn upper_illuminance(&self) -> f32 {
        match &self.image {
            None => PI * luminance(self.scale),
            Some(img) => {
                let n = img.size;
                let weight = 2.0 * PI / (n * n) as f32;
                let mut sum = 0.0;
                for y in 0..n {
                    for x in 0..n {
                        let d = square_to_sphere(Vec2::new(
                            (x as f32 + 0.5) / n as f32,
                            (y as f32 + 0.5) / n as f32,
                        ));
                        if d.z > 0.0 {
                            sum += luminance(img.texels[y * n + x] * self.scale) * d.z;
                        }
                    }
                }
                sum * weight
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere, Chi2Config};
    use crate::sampling::Rng;

    #[test]
    fn equal_area_mapping_roundtrips_and_keeps_area() {
        let mut rng = Rng::new(9, 9);
        for _ in 0..10_000 {
            let d = uniform_sphere(rng.next_2d());
            let p = sphere_to_square(d);
            assert!((square_to_sphere(p) - d).length() < 1e-4, "{d} → {p}");
        }
        // Equal area: uniform points of the square are uniform on the sphere (mean of z², 1/3).
        let n = 200_000;
        let m: f32 = (0..n)
            .map(|_| square_to_sphere(rng.next_2d()).z.powi(2))
            .sum::<f32>()
            / n as f32;
        assert!((m - 1.0 / 3.0).abs() < 0.005, "{m}");
        // pbrt's corners: the square's centre is +Z, its corners −Z.
        assert!((square_to_sphere(Vec2::splat(0.5)) - Vec3::Z).length() < 1e-6);
        assert!((square_to_sphere(Vec2::ZERO) - Vec3::NEG_Z).length() < 1e-6);
    }

    /// Chi-square of the image light's sampling against its pdf, on a map with a bright spot,
    /// turned by a transform.
    #[test]
    fn chi2_of_the_image_light() {
        let n = 16;
        let mut texels = vec![Rgb::splat(0.2); n * n];
        for (i, t) in texels.iter_mut().enumerate() {
            *t += Rgb::splat((i % 7) as f32 * 0.1);
        }
        texels[5 * n + 9] = Rgb::splat(40.0);
        let turn = Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
        let light = InfiniteLight::image(n, texels, Rgb::ONE, turn).unwrap();
        let cfg = Chi2Config {
            samples: 500_000,
            theta_bins: 40,
            phi_bins: 80,
            ..Default::default()
        };
        chi2_test_sphere(&cfg, |u| light.sample(u).map(|s| s.0), |d| light.pdf(d)).unwrap();
        // A sample's radiance is the radiance of its direction.
        let mut rng = Rng::new(3, 1);
        for _ in 0..1000 {
            let (d, l, pdf) = light.sample(rng.next_2d()).unwrap();
            assert!((light.radiance(d) - l).abs().max_element() < 1e-3 * l.max_element().max(1.0));
            assert!((light.pdf(d) - pdf).abs() < 1e-3 * pdf);
        }
    }
}
