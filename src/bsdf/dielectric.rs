//! Rough and smooth dielectric interfaces (glass, water): reflection and refraction with the
//! exact Fresnel term, in the local frame of [`crate::bsdf`] (`wo.z > 0`).
//!
//! # Conventions
//! - `ior` is the index of refraction of the material's inside (the side opposite its
//!   geometric normal) over the outside. `front` says whether `wo` lies outside; then the
//!   relative index `η = n(below) / n(wo's side)` is `ior`, else `1 / ior`.
//! - `F(cos, η)` is the exact unpolarised Fresnel reflectance of the interface (1 beyond
//!   the critical angle).
//! - Rough (`alpha ≥` [`SMOOTH_ALPHA`]): Walter et al. 2007 with the GGX distribution of
//!   [`Microfacet`] and its height-correlated Smith `G`. The half vector of a pair is
//!   `wm = ±normalize(wo + η'·wi)` with `η' = 1` for reflection and `η` for transmission,
//!   turned to `+z`; pairs whose `wm` is back-facing to either direction have `f = 0`.
//!   - Reflection: `f = D·G·F / (4·wo.z·wi.z)`, untinted.
//!   - Transmission: `f = tint·D·G·(1 − F)·|wi·wm|·|wo·wm| / (|wi.z|·wo.z·(wi·wm + wo·wm/η)²) / η²`.
//!     The last `1/η²` is the radiance scaling across the interface (radiance transport), so
//!     `f(wo, wi) / n(wo)² = f(wi, wo) / n(wi)²` (generalised reciprocity).
//!   - Sampling draws `wm` from the normals visible from `wo` (exact GGX VNDF), then reflects
//!     with probability `F(wo·wm)` and refracts otherwise: `pdf = D_wo(wm)·F / (4·wo·wm)` or
//!     `D_wo(wm)·(1 − F)·|wi·wm| / (wi·wm + wo·wm/η)²`.
//! - Smooth (`alpha <` [`SMOOTH_ALPHA`]): delta lobes, reflection with probability `F(wo.z)`
//!   and weight 1, refraction otherwise with weight `tint / η²`.

use crate::bsdf::microfacet::Microfacet;
use crate::bsdf::{reflect, BsdfSample};
use crate::math::Rgb;
use glam::{Vec2, Vec3};

/// Below this GGX α the interface is treated as perfectly smooth (delta lobes).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// Exact unpolarised Fresnel reflectance of a dielectric interface for light arriving at
/// `cos` (> 0) from the side of index 1 onto the side of relative index `eta`; 1 on total
/// internal reflection.
pub fn fresnel_dielectric(cos: f32, eta: f32) -> f32 {
    let c = cos.clamp(0.0, 1.0);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parallel = (eta * c - cos_t) / (eta * c + cos_t);
    let r_perpendicular = (c - eta * cos_t) / (c + eta * cos_t);
    0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular)
}

/// An index of refraction made usable: clamped to [1.001, 10], 1.5 when not finite.
pub fn clamp_ior(ior: f32) -> f32 {
    if ior.is_finite() {
        ior.clamp(1.001, 10.0)
    } else {
        1.5
    }
}

/// Refraction of `wo` through the microfacet normal `n` (`wo·n > 0`) into the side of
/// relative index `eta`; `None` on total internal reflection.
fn refract_about(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let c = wo.dot(n);
    let sin2_t = (1.0 - c * c).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wo / eta + (c / eta - cos_t) * n).normalize_or_zero())
}

/// A dielectric interface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Index of refraction of the inside over the outside (≥ 1.001).
    pub ior: f32,
    /// GGX roughness α; below [`SMOOTH_ALPHA`] the interface is smooth.
    pub alpha: f32,
    /// Transmission tint, per channel in [0, 1].
    pub tint: Rgb,
    /// `wo` lies on the outside.
    pub front: bool,
}

impl Dielectric {
    /// An interface of index `ior` (clamped to [1.001, 10]) and GGX roughness `alpha`, seen
    /// from the outside.
    pub fn new(ior: f32, alpha: f32, tint: Rgb) -> Self {
        Dielectric {
            ior: clamp_ior(ior),
            alpha: alpha.max(0.0),
            tint: tint.clamp(Vec3::ZERO, Vec3::ONE),
            front: true,
        }
    }

    /// Relative index `n(below) / n(wo's side)`.
    #[inline]
    pub fn eta(&self) -> f32 {
        if self.front {
            self.ior
        } else {
            1.0 / self.ior
        }
    }

    /// True when the lobes are Dirac deltas.
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.alpha < SMOOTH_ALPHA
    }

    #[inline]
    fn distribution(&self) -> Microfacet {
        Microfacet::ggx(self.alpha, Vec3::ONE, Vec3::ZERO)
    }

    /// The half vector of `(wo, wi)` turned to `+z` with the relative index of its kind, or
    /// `None` when the pair cannot be joined by a front-facing microfacet.
    #[inline]
    pub(crate) fn half(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32)> {
        if wo.z <= 0.0 || wi.z == 0.0 {
            return None;
        }
        let etap = if wi.z > 0.0 { 1.0 } else { self.eta() };
        let wm = (wo + wi * etap).normalize_or_zero();
        if wm == Vec3::ZERO || !wm.is_finite() {
            return None;
        }
        let wm = if wm.z < 0.0 { -wm } else { wm };
        if wm.dot(wi) * wi.z <= 0.0 || wm.dot(wo) <= 0.0 {
            return None;
        }
        Some((wm, etap))
    }

    /// `f(wo, wi)` without the cosine; 0 when smooth.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if self.is_smooth() {
            return Vec3::ZERO;
        }
        let Some((wm, etap)) = self.half(wo, wi) else {
            return Vec3::ZERO;
        };
        let m = self.distribution();
        let f = fresnel_dielectric(wo.dot(wm), self.eta());
        let dg = m.d(wm) * m.g(wo, wi);
        if wi.z > 0.0 {
            Vec3::splat(dg * f / (4.0 * wo.z * wi.z))
        } else {
            let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2) * wi.z.abs() * wo.z;
            let ft = dg * (1.0 - f) * (wi.dot(wm) * wo.dot(wm)).abs() / denom;
            self.tint * (ft / (etap * etap))
        }
    }

    /// Solid-angle pdf of [`Dielectric::sample`] choosing `wi`; 0 when smooth.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_smooth() {
            return 0.0;
        }
        let Some((wm, etap)) = self.half(wo, wi) else {
            return 0.0;
        };
        let m = self.distribution();
        let cos_o = wo.dot(wm);
        let f = fresnel_dielectric(cos_o, self.eta());
        // Density of the visible normal wm: G1(wo)·D(wm)·(wo·wm) / wo.z.
        let vndf = m.d(wm) * cos_o / ((1.0 + m.lambda(wo)) * wo.z);
        if wi.z > 0.0 {
            vndf * f / (4.0 * cos_o)
        } else {
            let denom = (wi.dot(wm) + cos_o / etap).powi(2);
            vndf * (1.0 - f) * wi.dot(wm).abs() / denom
        }
    }

    /// Samples `wi` from uniform `u` (the microfacet normal) and `u1` (reflect or refract).
    pub fn sample(&self, wo: Vec3, u: Vec2, u1: f32) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let eta = self.eta();
        if self.is_smooth() {
            let r = fresnel_dielectric(wo.z, eta);
            if u1 < r {
                return Some(BsdfSample::delta(reflect(wo), Vec3::ONE, r));
            }
            let wi = refract_about(wo, Vec3::Z, eta)?;
            return Some(BsdfSample::delta(wi, self.tint / (eta * eta), 1.0 - r));
        }
        let wm = self.distribution().visible_normal(wo, u)?;
        let cos_o = wo.dot(wm);
        if cos_o <= 0.0 {
            return None;
        }
        let wi = if u1 < fresnel_dielectric(cos_o, eta) {
            let wi = (2.0 * cos_o * wm - wo).normalize_or_zero();
            (wi.z > 0.0).then_some(wi)?
        } else {
            let wi = refract_about(wo, wm, eta)?;
            (wi.z < 0.0).then_some(wi)?
        };
        BsdfSample::glossy(wi, self.eval(wo, wi), self.pdf(wo, wi))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere_equatorial, Chi2Config};
    use crate::sampling::{uniform_sphere, Rng};

    #[test]
    fn fresnel_matches_known_values() {
        // Normal incidence ((η−1)/(η+1))², grazing 1, total internal reflection beyond the
        // critical angle (41.8° from glass of 1.5 into air).
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-6);
        assert!(fresnel_dielectric(40f32.to_radians().cos(), 1.0 / 1.5) < 1.0);
        assert_eq!(fresnel_dielectric(43f32.to_radians().cos(), 1.0 / 1.5), 1.0);
        // Brewster's angle: the parallel part vanishes, F = r⊥²/2.
        let b = 1.5f32.atan();
        let f = fresnel_dielectric(b.cos(), 1.5);
        let cos_t = (1.0 - b.sin().powi(2) / 2.25).sqrt();
        let rs = (b.cos() - 1.5 * cos_t) / (b.cos() + 1.5 * cos_t);
        assert!((f - 0.5 * rs * rs).abs() < 1e-6);
    }

    fn settings() -> Vec<(f32, f32, bool)> {
        let mut v = Vec::new();
        for alpha in [0.1f32, 0.3, 0.6] {
            for theta in [0.0f32, 40.0, 70.0, 85.0] {
                for front in [true, false] {
                    v.push((alpha, theta, front));
                }
            }
        }
        v
    }

    /// Chi-square of the reflect-or-refract sampler over the whole sphere, entering and leaving
    /// glass of index 1.5, at α 0.1–0.6 and incidence to 85°; 1% over the 24 tests.
    #[test]
    fn chi2_of_the_rough_interface() {
        let all = settings();
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / all.len() as f64);
        for (alpha, theta, front) in all {
            let d = Dielectric {
                front,
                ..Dielectric::new(1.5, alpha, Vec3::ONE)
            };
            let t = theta.to_radians();
            let wo = Vec3::new(t.sin(), 0.0, t.cos());
            let cfg = Chi2Config::fine(significance, 21);
            let mut lobe = Rng::new(6, 1);
            let r = chi2_test_sphere_equatorial(
                &cfg,
                |u| d.sample(wo, u, lobe.next_f32()).map(|s| s.wi),
                |w| d.pdf(wo, w),
            );
            assert!(
                r.is_ok(),
                "α {alpha} θo {theta}° front {front}: {:?}",
                r.err()
            );
        }
    }

    /// True when `(wo, wi)` meets its microfacet within 0.6° of grazing on either side. The
    /// Fresnel term of the refracted side is then ill-conditioned in single precision (near
    /// the critical angle `cos θt` is the square root of a difference of nearly equal numbers),
    /// so the two directions of such a pair differ by more than rounding elsewhere.
    pub(crate) fn near_grazing(d: &Dielectric, wo: Vec3, wi: Vec3) -> bool {
        d.half(wo, wi)
            .is_some_and(|(wm, _)| wo.dot(wm).abs().min(wi.dot(wm).abs()) < 0.01)
    }

    #[test]
    fn generalised_reciprocity() {
        // f(wo, wi) / n(wo)² = f(wi, wo) / n(wi)²; the reverse pair is seen from wi's side.
        let mut rng = Rng::new(7, 2);
        let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
        for (alpha, _, front) in settings() {
            let d = Dielectric {
                front,
                ..Dielectric::new(1.33, alpha, Vec3::new(0.9, 0.8, 0.7))
            };
            let mut nonzero = 0;
            for _ in 0..4000 {
                let wo = uniform_sphere(rng.next_2d());
                let wi = uniform_sphere(rng.next_2d());
                let wo = if wo.z < 0.0 { flip(wo) } else { wo };
                let f = d.eval(wo, wi);
                let (rev, wo_r, wi_r) = if wi.z > 0.0 {
                    (d, wi, wo)
                } else {
                    (Dielectric { front: !front, ..d }, flip(wi), flip(wo))
                };
                if near_grazing(&d, wo, wi) {
                    continue;
                }
                let g = rev.eval(wo_r, wi_r);
                // n(wo) = 1, n(wi) = η for transmission (relative indices).
                let scale = if wi.z > 0.0 { 1.0 } else { d.eta() * d.eta() };
                let x = f * scale;
                assert!(
                    (x - g).abs().max_element() <= 1e-2 * x.max_element().max(g.max_element()),
                    "α {alpha} front {front} wo {wo} wi {wi}: {x} vs {g}"
                );
                nonzero += (f.max_element() > 0.0) as u32;
            }
            assert!(nonzero > 100, "α {alpha}: only {nonzero} non-zero pairs");
        }
    }

    #[test]
    fn energy_is_conserved() {
        // ∫ f |cos| dω with the radiance scaling undone (× η² for transmission) is at most 1 and
        // close to 1 for a clear interface at low roughness; the smooth interface conserves it
        // exactly.
        let mut rng = Rng::new(8, 3);
        for alpha in [0.0f32, 0.05, 0.3, 0.7] {
            for front in [true, false] {
                for theta in [0.0f32, 30.0, 60.0, 80.0] {
                    let d = Dielectric {
                        front,
                        ..Dielectric::new(1.5, alpha, Vec3::ONE)
                    };
                    let t = theta.to_radians();
                    let wo = Vec3::new(t.sin(), 0.0, t.cos());
                    let n = 100_000;
                    let mut sum = 0.0f64;
                    for _ in 0..n {
                        if let Some(s) = d.sample(wo, rng.next_2d(), rng.next_f32()) {
                            let undo = if s.wi.z < 0.0 { d.eta() * d.eta() } else { 1.0 };
                            sum += (s.weight.x * undo) as f64;
                        }
                    }
                    let e = sum / n as f64;
                    assert!(e <= 1.01, "α {alpha} front {front} θ {theta}: {e}");
                    // Single scattering loses what masking takes, more at grazing incidence.
                    if alpha <= 0.05 {
                        let lo = if theta < 70.0 { 0.97 } else { 0.93 };
                        assert!(e > lo, "α {alpha} front {front} θ {theta}: {e}");
                    }
                }
            }
        }
    }
}
