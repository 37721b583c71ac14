//! The anisotropic Trowbridge-Reitz ("GGX") microfacet distribution of pbrt-v4's conductor,
//! dielectric and layered materials, in the local frame of [`crate::bsdf`] (+Z the normal).
//!
//! - `D(m) = 1 / (π αx αy cos⁴θm (1 + tan²θm (cos²φm/αx² + sin²φm/αy²))²)`.
//! - `Λ(w) = (√(1 + α(φ)² tan²θ) − 1) / 2` with `α(φ)² = αx² cos²φ + αy² sin²φ`;
//!   `G1 = 1 / (1 + Λ)`, `G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))` (height-correlated Smith).
//! - The density of normals visible from `w` is `D_w(m) = G1(w) · |w·m| · D(m) / |cos θw|`;
//!   [`TrowbridgeReitz::sample_visible`] draws it exactly (Heitz 2018), for `w` on either side.
//! - pbrt-v4's roughness remapping (`remaproughness`, on by default) is `α = √roughness`.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Below this largest α a distribution is a perfectly smooth surface (pbrt-v4's threshold).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// An anisotropic Trowbridge-Reitz distribution: roughness `αx` along the local +X (the
/// surface's u direction), `αy` along +Y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrowbridgeReitz {
    /// Roughness along +X.
    pub alpha_x: f32,
    /// Roughness along +Y.
    pub alpha_y: f32,
}

/// pbrt-v4's `RoughnessToAlpha`: the α of a user-facing roughness in [0, 1].
pub fn roughness_to_alpha(roughness: f32) -> f32 {
    roughness.max(0.0).sqrt()
}

impl TrowbridgeReitz {
    /// A distribution with roughness `alpha_x`, `alpha_y` (negative or non-finite values are 0).
    pub fn new(alpha_x: f32, alpha_y: f32) -> Self {
        let clean = |a: f32| if a.is_finite() { a.max(0.0) } else { 0.0 };
        TrowbridgeReitz {
            alpha_x: clean(alpha_x),
            alpha_y: clean(alpha_y),
        }
    }

    /// True when the surface is treated as perfectly smooth (delta lobes).
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    /// `D(m)` for a unit normal `m` (0 below the surface, `m.z ≤ 0`).
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let cos2 = m.z * m.z;
        let sin2 = (1.0 - cos2).max(0.0);
        if cos2 * cos2 < 1e-16 {
            return 0.0;
        }
        let tan2 = sin2 / cos2;
        let (cos_phi2, sin_phi2) = phi2(m, sin2);
        let e = tan2
            * (cos_phi2 / (self.alpha_x * self.alpha_x) + sin_phi2 / (self.alpha_y * self.alpha_y));
        1.0 / (PI * self.alpha_x * self.alpha_y * cos2 * cos2 * (1.0 + e) * (1.0 + e))
    }

    /// Smith's `Λ(w)`.
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        let sin2 = (1.0 - cos2).max(0.0);
        if cos2 == 0.0 {
            return f32::INFINITY;
        }
        let tan2 = sin2 / cos2;
        let (cos_phi2, sin_phi2) = phi2(w, sin2);
        let alpha2 =
            cos_phi2 * self.alpha_x * self.alpha_x + sin_phi2 * self.alpha_y * self.alpha_y;
        ((1.0 + alpha2 * tan2).sqrt() - 1.0) * 0.5
    }

    /// `G1(w) = 1 / (1 + Λ(w))`.
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// `G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))`.
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// The density of visible normals `D_w(m)` (solid angle over `m`, `m.z > 0`): normals
    /// facing `w`, or `−w` when `w` lies below (as [`TrowbridgeReitz::sample_visible`] draws).
    #[inline]
    pub fn visible_pdf(&self, w: Vec3, m: Vec3) -> f32 {
        let facing = w.dot(m) * w.z.signum();
        if w.z == 0.0 || facing <= 0.0 {
            return 0.0;
        }
        self.g1(w) / w.z.abs() * self.d(m) * facing
    }

    /// A normal (with `m.z > 0`) drawn from `D_w` with uniform `u`; `w` may lie on either side.
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let mut wh = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize_or(Vec3::Z);
        if wh.z < 0.0 {
            wh = -wh;
        }
        let t1 = if wh.z < 0.99999 {
            Vec3::Z.cross(wh).normalize()
        } else {
            Vec3::X
        };
        let t2 = wh.cross(t1);
        let r = u.x.sqrt();
        let (sin, cos) = (2.0 * PI * u.y).sin_cos();
        let (px, py) = (r * cos, r * sin);
        let h = (1.0 - px * px).max(0.0).sqrt();
        let s = 0.5 * (1.0 + wh.z);
        let py = (1.0 - s) * h + s * py;
        let pz = (1.0 - px * px - py * py).max(0.0).sqrt();
        let nh = t1 * px + t2 * py + wh * pz;
        Vec3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize()
    }
}

/// `(cos²φ, sin²φ)` of a direction with `sin²θ = sin2` (φ = 0 at the pole).
#[inline]
fn phi2(w: Vec3, sin2: f32) -> (f32, f32) {
    if sin2 <= 0.0 {
        return (1.0, 0.0);
    }
    let c = (w.x * w.x / sin2).clamp(0.0, 1.0);
    (c, 1.0 - c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere_equatorial, Chi2Config};
    use crate::sampling::Rng;

    /// ∫ D(m) cos θm dm = 1 and ∫ D_w(m) dm = 1, estimated by uniform hemisphere sampling.
    #[test]
    fn distribution_and_visible_normals_are_normalised() {
        let mut rng = Rng::new(7, 7);
        for (ax, ay) in [(0.3f32, 0.3f32), (0.1, 0.5), (0.6, 0.2)] {
            let tr = TrowbridgeReitz::new(ax, ay);
            let w = Vec3::new(0.5, -0.3, 0.81).normalize();
            let n = 400_000;
            let (mut a, mut b) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let m = crate::sampling::uniform_hemisphere(rng.next_2d());
                let inv_pdf = 2.0 * PI as f64;
                a += (tr.d(m) * m.z) as f64 * inv_pdf;
                b += tr.visible_pdf(w, m) as f64 * inv_pdf;
            }
            let (a, b) = (a / n as f64, b / n as f64);
            assert!((a - 1.0).abs() < 0.03, "({ax}, {ay}): ∫D cos = {a}");
            assert!((b - 1.0).abs() < 0.03, "({ax}, {ay}): ∫D_w = {b}");
        }
    }

    /// Chi-square of the visible-normal sampler against `D_w`, anisotropic, at several
    /// incidences, from above and below; 1% over all tests (Šidák).
    #[test]
    fn chi2_of_visible_normals() {
        let cases: Vec<(f32, f32, f32)> = [(0.2f32, 0.2f32), (0.1, 0.6), (0.5, 0.15)]
            .iter()
            .flat_map(|&(ax, ay)| [0.0f32, 50.0, 80.0, 130.0].map(move |t| (ax, ay, t)))
            .collect();
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / cases.len() as f64);
        for (ax, ay, theta) in cases {
            let tr = TrowbridgeReitz::new(ax, ay);
            let t = theta.to_radians();
            let w = Vec3::new(t.sin() * 0.8, t.sin() * 0.6, t.cos());
            let cfg = Chi2Config::fine(significance, 11);
            chi2_test_sphere_equatorial(
                &cfg,
                |u| Some(tr.sample_visible(w, u)),
                |m| tr.visible_pdf(w, m),
            )
            .unwrap_or_else(|e| panic!("α ({ax}, {ay}), θ {theta}: {e}"));
        }
    }
}
