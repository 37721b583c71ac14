//! Scattering functions.
//!
//! # Conventions (all BSDFs)
//! - Directions are in the local shading frame: +Z is the shading normal, flipped to the side
//!   the path arrives from, so `wo.z ≥ 0` for any visible surface.
//! - Both `wo` (towards the viewer / previous vertex) and `wi` (towards the light / next
//!   vertex) point away from the surface and are unit vectors.
//! - [`Bsdf::eval`] returns `f(wo, wi)` without the cosine factor.
//! - [`Bsdf::pdf`] and [`BsdfSample::pdf`] are densities in solid angle over `wi`.
//! - [`BsdfSample::f`] is `eval(wo, wi)`; the Monte Carlo weight of a sample is
//!   `f · |wi.z| / pdf`.

use crate::math::Rgb;
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// A BSDF, held by value (no allocation per hit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflection, `f = albedo / π` on the side of `wo`.
    Diffuse {
        /// Reflectance in [0, 1] per channel.
        albedo: Rgb,
    },
    /// Scatters nothing (pure emitters, the back of area lights).
    Black,
}

/// One sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled incident direction, local frame.
    pub wi: Vec3,
    /// `eval(wo, wi)`.
    pub f: Rgb,
    /// Solid-angle pdf of `wi`.
    pub pdf: f32,
}

impl Bsdf {
    /// `f(wo, wi)`, no cosine.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match *self {
            Bsdf::Diffuse { albedo } if wo.z > 0.0 && wi.z > 0.0 => albedo * FRAC_1_PI,
            _ => Vec3::ZERO,
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] picks `wi`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match *self {
            Bsdf::Diffuse { .. } if wo.z > 0.0 => cosine_hemisphere_pdf(wi),
            _ => 0.0,
        }
    }

    /// Samples `wi` for `wo` from the uniform point `u`; `None` when nothing is scattered.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        match *self {
            Bsdf::Diffuse { albedo } if wo.z > 0.0 => {
                let wi = cosine_hemisphere(u);
                let pdf = cosine_hemisphere_pdf(wi);
                (pdf > 0.0).then(|| BsdfSample {
                    wi,
                    f: albedo * FRAC_1_PI,
                    pdf,
                })
            }
            _ => None,
        }
    }

    /// True when the BSDF never scatters.
    pub fn is_black(&self) -> bool {
        match *self {
            Bsdf::Diffuse { albedo } => albedo == Vec3::ZERO,
            Bsdf::Black => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere, Chi2Config};
    use crate::sampling::Rng;

    #[test]
    fn diffuse_sample_matches_eval_and_pdf() {
        let b = Bsdf::Diffuse {
            albedo: Vec3::new(0.2, 0.5, 0.8),
        };
        let wo = Vec3::new(0.3, -0.2, 0.93).normalize();
        let mut rng = Rng::new(1, 1);
        for _ in 0..1000 {
            let s = b.sample(wo, rng.next_2d()).unwrap();
            assert!((s.pdf - b.pdf(wo, s.wi)).abs() < 1e-5);
            assert_eq!(s.f, b.eval(wo, s.wi));
            // Reciprocity.
            assert_eq!(b.eval(wo, s.wi), b.eval(s.wi, wo));
        }
        let cfg = Chi2Config {
            samples: 200_000,
            ..Default::default()
        };
        chi2_test_sphere(&cfg, |u| b.sample(wo, u).map(|s| s.wi), |wi| b.pdf(wo, wi)).unwrap();
    }

    #[test]
    fn diffuse_albedo_is_its_reflectance() {
        // ∫ f cos dω estimated by sampling equals the albedo (energy check, albedo ≤ 1).
        let albedo = Vec3::new(0.2, 0.5, 0.8);
        let b = Bsdf::Diffuse { albedo };
        let mut rng = Rng::new(2, 3);
        let wo = Vec3::Z;
        let mut acc = Vec3::ZERO;
        let n = 10_000;
        for _ in 0..n {
            let s = b.sample(wo, rng.next_2d()).unwrap();
            acc += s.f * s.wi.z / s.pdf;
        }
        assert!(((acc / n as f32) - albedo).abs().max_element() < 1e-4);
        assert!(
            b.sample(-wo, rng.next_2d()).is_none(),
            "no scattering from below"
        );
    }
}
