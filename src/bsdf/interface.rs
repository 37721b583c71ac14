//! pbrt-v4's `dielectric` and `thindielectric` interfaces, with `wo` on either side of the
//! local frame (the layered materials walk inside their coating and meet the interface from
//! below). `eta` is the index of the −Z side over the +Z side.
//!
//! - Smooth (see [`super::tr::SMOOTH_ALPHA`]): reflection with probability `F(cos θo)`,
//!   refraction otherwise; `f = F / |cos θi|` and `(1 − F) / |cos θi|`, the latter divided by
//!   `η'²` (the relative index of the side entered) for radiance.
//! - Rough: Walter et al. 2007 with the anisotropic `TrowbridgeReitz` distribution; the
//!   generalised half vector `m = normalize(wo + η'·wi)` turned to +Z, pairs whose `m` is
//!   back-facing to either direction have `f = 0`; reflection
//!   `D·G·F / (4·|cos θo cos θi|)`, transmission
//!   `D·G·(1 − F)·|wi·m · wo·m| / (|cos θo cos θi|·(wi·m + wo·m/η')²)`, divided by `η'²` for
//!   radiance. Sampling picks a visible normal, then reflection or transmission in proportion
//!   to `F` and `1 − F` restricted to the lobes asked for ([`Lobes`]).
//! - Thin: two parallel smooth interfaces, internal reflections summed:
//!   `R' = R + T²R / (1 − R²)`, and the rest passes straight through (`wi = −wo`).

use super::dielectric::fresnel_dielectric;
use super::facets::Facets;
use super::BsdfSample;
use crate::math::Rgb;
use glam::{Vec2, Vec3};

/// Which lobes a sample or density may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobes {
    /// Reflection and transmission.
    All,
    /// Reflection only.
    Reflection,
    /// Transmission only.
    Transmission,
}

impl Lobes {
    /// The probabilities of reflection and transmission for Fresnel reflectance `r`.
    #[inline]
    fn weigh(self, r: f32) -> (f32, f32) {
        match self {
            Lobes::All => (r, 1.0 - r),
            Lobes::Reflection => (r, 0.0),
            Lobes::Transmission => (0.0, 1.0 - r),
        }
    }
}

/// A sampled direction with pbrt's unnormalised parts: `f` (no cosine), the density `pdf`
/// (a discrete probability for delta lobes), whether the lobe is a delta and whether it
/// reflects.
#[derive(Clone, Copy, Debug)]
pub struct Lobe {
    /// The sampled direction.
    pub wi: Vec3,
    /// The BSDF's value.
    pub f: Rgb,
    /// Its density.
    pub pdf: f32,
    /// Chosen from a delta lobe.
    pub delta: bool,
    /// `wi` is on `wo`'s side.
    pub reflection: bool,
}

/// A dielectric interface of relative index `eta` (−Z side over +Z side).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interface {
    /// Index of the −Z side over the +Z side.
    pub eta: f32,
    /// Microfacet roughness (ignored when `thin`).
    pub dist: Facets,
    /// A thin sheet (two parallel smooth interfaces) rather than one interface.
    pub thin: bool,
}

/// Refraction of `w` through the normal `n` for relative index `eta` (far side over `w`'s
/// side when `w·n > 0`, inverted otherwise); the direction and the relative index of the
/// side entered, or `None` on total internal reflection.
pub fn refract(w: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let (mut cos_i, mut n, mut eta) = (w.dot(n), n, eta);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-w / eta + (cos_i / eta - cos_t) * n, eta))
}

/// Fresnel reflectance for `cos` measured on the +Z side (negative: light on the −Z side).
#[inline]
pub(crate) fn fresnel(cos: f32, eta: f32) -> f32 {
    if cos < 0.0 {
        fresnel_dielectric(-cos, 1.0 / eta)
    } else {
        fresnel_dielectric(cos, eta)
    }
}

impl Interface {
    /// True when every lobe is a delta.
    #[inline]
    pub fn is_delta(&self) -> bool {
        self.thin || self.eta == 1.0 || self.dist.is_smooth()
    }

    /// The half vector of a pair turned to +Z and the relative index `η'` (1 for reflection),
    /// or `None` for pairs no microfacet joins.
    fn half(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32)> {
        let (co, ci) = (wo.z, wi.z);
        if co == 0.0 || ci == 0.0 {
            return None;
        }
        let etap = if co * ci > 0.0 {
            1.0
        } else if co > 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        let m = (wi * etap + wo).normalize_or_zero();
        if m == Vec3::ZERO || !m.is_finite() {
            return None;
        }
        let m = if m.z < 0.0 { -m } else { m };
        (m.dot(wi) * ci >= 0.0 && m.dot(wo) * co >= 0.0).then_some((m, etap))
    }

    /// `f(wo, wi)` without the cosine (0 for delta lobes); `radiance` divides transmission
    /// by `η'²` (paths from the camera), otherwise not (paths from lights).
    pub fn f(&self, wo: Vec3, wi: Vec3, radiance: bool) -> Rgb {
        if self.is_delta() {
            return Vec3::ZERO;
        }
        let Some((m, etap)) = self.half(wo, wi) else {
            return Vec3::ZERO;
        };
        let d = &self.dist;
        let r = fresnel(wo.dot(m), self.eta);
        let value = if etap == 1.0 {
            d.d(m) * d.g(wo, wi) * r / (4.0 * wo.z * wi.z).abs()
        } else {
            let denom = (wi.dot(m) + wo.dot(m) / etap).powi(2) * wi.z * wo.z;
            let t = d.d(m) * (1.0 - r) * d.g(wo, wi) * (wi.dot(m) * wo.dot(m) / denom).abs();
            if radiance {
                t / (etap * etap)
            } else {
                t
            }
        };
        Vec3::splat(value)
    }

    /// Density of [`Interface::sample`] choosing `wi` among `lobes` (0 for delta lobes).
    pub fn pdf(&self, wo: Vec3, wi: Vec3, lobes: Lobes) -> f32 {
        if self.is_delta() {
            return 0.0;
        }
        let Some((m, etap)) = self.half(wo, wi) else {
            return 0.0;
        };
        let (pr, pt) = lobes.weigh(fresnel(wo.dot(m), self.eta));
        if pr + pt <= 0.0 {
            return 0.0;
        }
        let vis = self.dist.visible_pdf(wo, m);
        if etap == 1.0 {
            vis / (4.0 * wo.dot(m).abs()) * pr / (pr + pt)
        } else {
            let dm_dwi = wi.dot(m).abs() / (wi.dot(m) + wo.dot(m) / etap).powi(2);
            vis * dm_dwi * pt / (pr + pt)
        }
    }

    /// Samples `wi` for `wo` (either side) among `lobes` with uniform `uc` (the lobe) and `u`
    /// (the microfacet normal).
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2, radiance: bool, lobes: Lobes) -> Option<Lobe> {
        if wo.z == 0.0 {
            return None;
        }
        if self.thin {
            return self.sample_thin(wo, uc, lobes);
        }
        if self.is_delta() {
            return self.sample_smooth(wo, uc, radiance, lobes);
        }
        let d = &self.dist;
        let m = d.sample_visible(wo, u);
        let (pr, pt) = lobes.weigh(fresnel(wo.dot(m), self.eta));
        if pr + pt <= 0.0 {
            return None;
        }
        let vis = d.visible_pdf(wo, m);
        if uc < pr / (pr + pt) {
            let wi = (2.0 * wo.dot(m) * m - wo).normalize_or_zero();
            if wi.z * wo.z <= 0.0 {
                return None;
            }
            let pdf = vis / (4.0 * wo.dot(m).abs()) * pr / (pr + pt);
            let f = d.d(m) * d.g(wo, wi) * pr / (4.0 * wi.z * wo.z).abs();
            return lobe(wi, Vec3::splat(f), pdf, false, true);
        }
        let (wi, etap) = refract(wo, m, self.eta)?;
        let wi = wi.normalize_or_zero();
        if wi.z * wo.z >= 0.0 {
            return None;
        }
        let denom = (wi.dot(m) + wo.dot(m) / etap).powi(2);
        let pdf = vis * wi.dot(m).abs() / denom * pt / (pr + pt);
        let mut f =
            pt * d.d(m) * d.g(wo, wi) * (wi.dot(m) * wo.dot(m) / (wi.z * wo.z * denom)).abs();
        if radiance {
            f /= etap * etap;
        }
        lobe(wi, Vec3::splat(f), pdf, false, false)
    }

    /// A sample for a camera path ([`crate::bsdf::Bsdf::sample`]'s form, all lobes).
    pub fn sample_radiance(&self, wo: Vec3, u: Vec2, u1: f32) -> Option<BsdfSample> {
        let s = self.sample(wo, u1, u, true, Lobes::All)?;
        let weight = s.f * s.wi.z.abs() / s.pdf;
        Some(if s.delta {
            BsdfSample::delta(s.wi, weight, s.pdf)
        } else {
            BsdfSample {
                wi: s.wi,
                f: s.f,
                pdf: s.pdf,
                weight,
                delta: false,
            }
        })
    }

    fn sample_smooth(&self, wo: Vec3, uc: f32, radiance: bool, lobes: Lobes) -> Option<Lobe> {
        let r = fresnel(wo.z, self.eta);
        let (pr, pt) = lobes.weigh(r);
        if pr + pt <= 0.0 {
            return None;
        }
        if uc < pr / (pr + pt) {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return lobe(wi, Vec3::splat(r / wi.z.abs()), pr / (pr + pt), true, true);
        }
        let (wi, etap) = refract(wo, Vec3::Z, self.eta)?;
        let mut f = (1.0 - r) / wi.z.abs();
        if radiance {
            f /= etap * etap;
        }
        lobe(wi, Vec3::splat(f), pt / (pr + pt), true, false)
    }

    fn sample_thin(&self, wo: Vec3, uc: f32, lobes: Lobes) -> Option<Lobe> {
        let mut r = fresnel_dielectric(wo.z.abs(), self.eta);
        let mut t = 1.0 - r;
        if r < 1.0 {
            r += t * t * r / (1.0 - r * r);
            t = 1.0 - r;
        }
        let (pr, pt) = match lobes {
            Lobes::All => (r, t),
            Lobes::Reflection => (r, 0.0),
            Lobes::Transmission => (0.0, t),
        };
        if pr + pt <= 0.0 {
            return None;
        }
        if uc < pr / (pr + pt) {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return lobe(wi, Vec3::splat(r / wi.z.abs()), pr / (pr + pt), true, true);
        }
        let wi = -wo;
        lobe(wi, Vec3::splat(t / wi.z.abs()), pt / (pr + pt), true, false)
    }
}

/// A [`Lobe`], or `None` when its value or density is unusable.
#[inline]
fn lobe(wi: Vec3, f: Rgb, pdf: f32, delta: bool, reflection: bool) -> Option<Lobe> {
    (pdf > 0.0 && pdf.is_finite() && f.is_finite() && wi.is_finite()).then_some(Lobe {
        wi,
        f,
        pdf,
        delta,
        reflection,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::facets::Beckmann;
    use crate::bsdf::tr::TrowbridgeReitz;
    use crate::sampling::chi2::{chi2_test_sphere_equatorial, Chi2Config};

    /// Chi-square of the rough interface's sampler, GGX and Beckmann, from above and below,
    /// anisotropic, each lobe restriction; 1% over all tests.
    #[test]
    fn chi2_of_the_anisotropic_interface() {
        let mut cases = Vec::new();
        for (ax, ay) in [(0.3f32, 0.3f32), (0.1, 0.4)] {
            for beckmann in [false, true] {
                for theta in [10.0f32, 60.0, 120.0, 170.0] {
                    for lobes in [Lobes::All, Lobes::Reflection, Lobes::Transmission] {
                        cases.push((ax, ay, beckmann, theta, lobes));
                    }
                }
            }
        }
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / cases.len() as f64);
        for (ax, ay, beckmann, theta, lobes) in cases {
            let i = Interface {
                eta: 1.5,
                dist: if beckmann {
                    Facets::Beckmann(Beckmann::new(ax, ay))
                } else {
                    TrowbridgeReitz::new(ax, ay).into()
                },
                thin: false,
            };
            let t = theta.to_radians();
            let wo = Vec3::new(t.sin() * 0.8, t.sin() * 0.6, t.cos());
            let cfg = Chi2Config::fine(significance, 11);
            let mut rng = crate::sampling::Rng::new(3, 9);
            chi2_test_sphere_equatorial(
                &cfg,
                |u| i.sample(wo, rng.next_f32(), u, true, lobes).map(|s| s.wi),
                |wi| i.pdf(wo, wi, lobes),
            )
            .unwrap_or_else(|e| panic!("α ({ax}, {ay}) {:?}, θ {theta}, {lobes:?}: {e}", i.dist));
        }
    }

    #[test]
    fn sample_values_match_f_and_pdf() {
        let i = Interface {
            eta: 1.33,
            dist: TrowbridgeReitz::new(0.2, 0.35).into(),
            thin: false,
        };
        let mut rng = crate::sampling::Rng::new(4, 4);
        for theta in [20.0f32, 75.0, 110.0, 160.0] {
            let t = theta.to_radians();
            let wo = Vec3::new(t.sin(), 0.0, t.cos());
            for _ in 0..2000 {
                for radiance in [true, false] {
                    let Some(s) = i.sample(wo, rng.next_f32(), rng.next_2d(), radiance, Lobes::All)
                    else {
                        continue;
                    };
                    let (f, pdf) = (i.f(wo, s.wi, radiance), i.pdf(wo, s.wi, Lobes::All));
                    assert!(
                        (s.pdf - pdf).abs() <= 1e-3 * pdf.max(1.0),
                        "{} vs {pdf}",
                        s.pdf
                    );
                    assert!((s.f - f).abs().max_element() <= 1e-3 * f.max_element().max(1.0));
                }
            }
        }
    }
}
