//! pbrt-v4's `conductor`: a Trowbridge-Reitz microfacet conductor, anisotropic, with the exact
//! conductor Fresnel term, in the local frame of [`crate::bsdf`] (reflection only, `wo.z > 0`).
//!
//! - Rough: `f = D(m)·F(|wo·m|)·G(wo, wi) / (4·cos θo·cos θi)` with `m = normalize(wo + wi)`;
//!   sampling draws `m` from the visible normals of `wo` ([`TrowbridgeReitz::sample_visible`])
//!   and reflects `wo` about it, `pdf = D_wo(m) / (4·|wo·m|)`, weight `F·G / G1(wo)`.
//! - Smooth (largest α below [`super::tr::SMOOTH_ALPHA`]): a delta reflection of weight
//!   `F(cos θo)`.

use super::microfacet::fresnel_conductor;
use super::tr::TrowbridgeReitz;
use super::{reflect, BsdfSample};
use crate::math::Rgb;
use glam::{Vec2, Vec3};

/// A conductor of complex index `eta + i·k` (per channel) and microfacet roughness `dist`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// The microfacet distribution.
    pub dist: TrowbridgeReitz,
    /// Real part of the index of refraction, per channel.
    pub eta: Rgb,
    /// Absorption (imaginary part of the index), per channel.
    pub k: Rgb,
    /// A factor on the reflection (Mitsuba's `specular_reflectance`; 1 for pbrt-v4's).
    pub tint: Rgb,
}

impl Conductor {
    /// `f(wo, wi)` without the cosine; 0 when smooth.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if self.dist.is_smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let m = (wo + wi).normalize_or_zero();
        if m == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let f = fresnel_conductor(wo.dot(m).abs(), self.eta, self.k);
        f * self.tint * (self.dist.d(m) * self.dist.g(wo, wi) / (4.0 * wo.z * wi.z))
    }

    /// Solid-angle pdf of [`Conductor::sample`] choosing `wi`; 0 when smooth.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.dist.is_smooth() || wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let m = (wo + wi).normalize_or_zero();
        if m == Vec3::ZERO {
            return 0.0;
        }
        self.dist.visible_pdf(wo, m) / (4.0 * wo.dot(m).abs())
    }

    /// Samples `wi` for `wo` from uniform `u`.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        if self.dist.is_smooth() {
            let f = fresnel_conductor(wo.z, self.eta, self.k) * self.tint;
            return Some(BsdfSample::delta(reflect(wo), f, 1.0));
        }
        let m = self.dist.sample_visible(wo, u);
        let wi = (2.0 * wo.dot(m) * m - wo).normalize_or_zero();
        if wi.z <= 0.0 {
            return None;
        }
        BsdfSample::glossy(wi, self.eval(wo, wi), self.pdf(wo, wi))
    }

    /// Fresnel reflectance at normal incidence (the surface's colour).
    pub fn albedo(&self) -> Rgb {
        fresnel_conductor(1.0, self.eta, self.k) * self.tint
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere_equatorial, Chi2Config};

    /// Chi-square of the anisotropic conductor's sampler against its pdf; 1% over all tests.
    #[test]
    fn chi2_of_the_anisotropic_conductor() {
        let cases: Vec<(f32, f32, f32)> = [(0.3f32, 0.3f32), (0.05, 0.4), (0.5, 0.2)]
            .iter()
            .flat_map(|&(ax, ay)| [0.0f32, 45.0, 80.0].map(move |t| (ax, ay, t)))
            .collect();
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / cases.len() as f64);
        for (ax, ay, theta) in cases {
            let c = Conductor {
                dist: TrowbridgeReitz::new(ax, ay),
                eta: Vec3::new(0.2, 0.9, 1.1),
                k: Vec3::new(3.9, 2.4, 2.1),
                tint: Vec3::ONE,
            };
            let t = theta.to_radians();
            let wo = Vec3::new(t.sin() * 0.6, t.sin() * 0.8, t.cos());
            let cfg = Chi2Config::fine(significance, 11);
            chi2_test_sphere_equatorial(
                &cfg,
                |u| c.sample(wo, u).map(|s| s.wi),
                |wi| c.pdf(wo, wi),
            )
            .unwrap_or_else(|e| panic!("α ({ax}, {ay}), θ {theta}: {e}"));
        }
    }
}
