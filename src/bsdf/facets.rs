//! The microfacet distributions of a rough dielectric `interface::Interface`:
//! pbrt-v4's anisotropic Trowbridge-Reitz ([`TrowbridgeReitz`]) or the anisotropic Beckmann
//! distribution of Mitsuba's `roughdielectric` (its default), with the same interface.
//!
//! - Beckmann: `D(m) = exp(−(m.x²/αx² + m.y²/αy²) / cos²θm) / (π αx αy cos⁴θm)`,
//!   `Λ(w) = (erf(a) − 1)/2 + exp(−a²) / (2a√π)` with `a = 1 / (α(φ) tan θ)` and
//!   `α(φ)² = αx² cos²φ + αy² sin²φ`; `G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))`.
//! - The density of normals visible from `w` is `D_w(m) = G1(w) · |w·m| · D(m) / |cos θw|`;
//!   [`Beckmann::sample_visible`] draws it by Jakob's (2014) inversion of the slope
//!   distribution, for `w` on either side.

use super::microfacet::{beckmann_visible_normal, erf, Distribution};
use super::tr::{TrowbridgeReitz, SMOOTH_ALPHA};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// An anisotropic Beckmann distribution: roughness `αx` along the local +X, `αy` along +Y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beckmann {
    /// Roughness along +X.
    pub alpha_x: f32,
    /// Roughness along +Y.
    pub alpha_y: f32,
}

impl Beckmann {
    /// A distribution with roughness `alpha_x`, `alpha_y` (negative or non-finite values are 0).
    pub fn new(alpha_x: f32, alpha_y: f32) -> Self {
        let tr = TrowbridgeReitz::new(alpha_x, alpha_y);
        Beckmann {
            alpha_x: tr.alpha_x,
            alpha_y: tr.alpha_y,
        }
    }

    /// `D(m)` for a unit normal `m` (0 below the surface).
    pub fn d(&self, m: Vec3) -> f32 {
        let cos2 = m.z * m.z;
        if m.z <= 0.0 || cos2 * cos2 < 1e-16 {
            return 0.0;
        }
        let e = ((m.x / self.alpha_x).powi(2) + (m.y / self.alpha_y).powi(2)) / cos2;
        (-e).exp() / (PI * self.alpha_x * self.alpha_y * cos2 * cos2)
    }

    /// Smith's `Λ(w)`.
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos = w.z.abs().min(1.0);
        let r2 = w.x * w.x + w.y * w.y;
        if r2 <= 0.0 {
            return 0.0;
        }
        if cos == 0.0 {
            return f32::INFINITY;
        }
        let alpha = ((w.x * w.x * self.alpha_x * self.alpha_x
            + w.y * w.y * self.alpha_y * self.alpha_y)
            / r2)
            .sqrt();
        let a = cos / (alpha * (1.0 - cos * cos).max(0.0).sqrt());
        (erf(a) - 1.0) * 0.5 + (-a * a).exp() / (2.0 * a * PI.sqrt())
    }

    /// The density of visible normals `D_w(m)`, as [`TrowbridgeReitz::visible_pdf`].
    pub fn visible_pdf(&self, w: Vec3, m: Vec3) -> f32 {
        let facing = w.dot(m) * w.z.signum();
        if w.z == 0.0 || facing <= 0.0 {
            return 0.0;
        }
        self.d(m) * facing / ((1.0 + self.lambda(w)) * w.z.abs())
    }

    /// A normal (with `m.z > 0`) drawn from `D_w` with uniform `u`; `w` may lie on either side.
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let w = if w.z < 0.0 { -w } else { w };
        let ws = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize_or(Vec3::Z);
        let ws = Vec3::new(ws.x, ws.y, ws.z.max(1e-6));
        beckmann_visible_normal(self.alpha_x, self.alpha_y, ws, u).normalize_or(Vec3::Z)
    }
}

/// The distribution of an interface's microfacets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Facets {
    /// Trowbridge-Reitz ("GGX"): pbrt-v4's, and Mitsuba's `ggx`.
    Ggx(TrowbridgeReitz),
    /// Beckmann: Mitsuba's `beckmann`.
    Beckmann(Beckmann),
}

impl From<TrowbridgeReitz> for Facets {
    fn from(tr: TrowbridgeReitz) -> Self {
        Facets::Ggx(tr)
    }
}

impl Facets {
    /// The roughness along +X and +Y.
    #[inline]
    pub fn alphas(&self) -> (f32, f32) {
        match self {
            Facets::Ggx(d) => (d.alpha_x, d.alpha_y),
            Facets::Beckmann(d) => (d.alpha_x, d.alpha_y),
        }
    }

    /// The distribution `distribution` of roughness `alpha_x`, `alpha_y`.
    pub fn new(distribution: Distribution, alpha_x: f32, alpha_y: f32) -> Facets {
        match distribution {
            Distribution::Ggx => TrowbridgeReitz::new(alpha_x, alpha_y).into(),
            Distribution::Beckmann => Facets::Beckmann(Beckmann::new(alpha_x, alpha_y)),
        }
    }

    /// The same distribution with roughness `alpha_x`, `alpha_y`.
    pub fn with_alphas(&self, alpha_x: f32, alpha_y: f32) -> Facets {
        let distribution = match self {
            Facets::Ggx(_) => Distribution::Ggx,
            Facets::Beckmann(_) => Distribution::Beckmann,
        };
        Facets::new(distribution, alpha_x, alpha_y)
    }

    /// True when the surface is treated as perfectly smooth (delta lobes).
    #[inline]
    pub fn is_smooth(&self) -> bool {
        let (x, y) = self.alphas();
        x.max(y) < SMOOTH_ALPHA
    }

    /// True when the roughness depends on the direction.
    #[inline]
    pub fn is_anisotropic(&self) -> bool {
        let (x, y) = self.alphas();
        x != y
    }

    /// `D(m)`.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        match self {
            Facets::Ggx(d) => d.d(m),
            Facets::Beckmann(d) => d.d(m),
        }
    }

    /// Height-correlated Smith `G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))`.
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Facets::Ggx(d) => d.g(wo, wi),
            Facets::Beckmann(d) => 1.0 / (1.0 + d.lambda(wo) + d.lambda(wi)),
        }
    }

    /// The density of normals visible from `w`.
    #[inline]
    pub fn visible_pdf(&self, w: Vec3, m: Vec3) -> f32 {
        match self {
            Facets::Ggx(d) => d.visible_pdf(w, m),
            Facets::Beckmann(d) => d.visible_pdf(w, m),
        }
    }

    /// A normal drawn from the density of normals visible from `w`.
    #[inline]
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        match self {
            Facets::Ggx(d) => d.sample_visible(w, u),
            Facets::Beckmann(d) => d.sample_visible(w, u),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere_equatorial, Chi2Config};
    use crate::sampling::Rng;

    /// Both distributions of roughness `(ax, ay)`.
    fn both(ax: f32, ay: f32) -> [Facets; 2] {
        [
            TrowbridgeReitz::new(ax, ay).into(),
            Facets::Beckmann(Beckmann::new(ax, ay)),
        ]
    }

    /// ∫ D(m) cos θm dm = 1 and ∫ D_w(m) dm = 1 (for `w` above and below), estimated by
    /// uniform hemisphere sampling.
    #[test]
    fn distributions_and_visible_normals_are_normalised() {
        let mut rng = Rng::new(7, 8);
        for (ax, ay) in [(0.3f32, 0.3f32), (0.1, 0.5), (0.6, 0.2)] {
            for d in both(ax, ay) {
                for w in [
                    Vec3::new(0.5, -0.3, 0.81).normalize(),
                    Vec3::new(-0.7, 0.2, -0.3).normalize(),
                ] {
                    let n = 400_000;
                    let (mut a, mut b) = (0.0f64, 0.0f64);
                    for _ in 0..n {
                        let m = crate::sampling::uniform_hemisphere(rng.next_2d());
                        let inv_pdf = 2.0 * PI as f64;
                        a += (d.d(m) * m.z) as f64 * inv_pdf;
                        b += d.visible_pdf(w, m) as f64 * inv_pdf;
                    }
                    let (a, b) = (a / n as f64, b / n as f64);
                    assert!((a - 1.0).abs() < 0.03, "{d:?}: ∫D cos = {a}");
                    assert!((b - 1.0).abs() < 0.03, "{d:?} w {w}: ∫D_w = {b}");
                }
            }
        }
    }

    /// Chi-square of both visible-normal samplers against `D_w`, anisotropic, at several
    /// incidences, from above and below; 1% over all tests (Šidák).
    #[test]
    fn chi2_of_visible_normals() {
        let cases: Vec<(Facets, f32)> = [(0.2f32, 0.2f32), (0.1, 0.6), (0.5, 0.15)]
            .iter()
            .flat_map(|&(ax, ay)| both(ax, ay))
            .flat_map(|d| [0.0f32, 50.0, 80.0, 130.0].map(move |t| (d, t)))
            .collect();
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / cases.len() as f64);
        for (d, theta) in cases {
            let t = theta.to_radians();
            let w = Vec3::new(t.sin() * 0.8, t.sin() * 0.6, t.cos());
            let cfg = Chi2Config::fine(significance, 11);
            chi2_test_sphere_equatorial(
                &cfg,
                |u| Some(d.sample_visible(w, u)),
                |m| d.visible_pdf(w, m),
            )
            .unwrap_or_else(|e| panic!("{d:?}, θ {theta}: {e}"));
        }
    }
}
