//! pbrt-v4's layered materials, `coateddiffuse` and `coatedconductor`: a dielectric coating
//! ([`Interface`]) of some thickness over a base (diffuse or conductor), evaluated as pbrt-v4
//! does, by a random walk between the two (Guo et al. 2018, pbrt-v4 §14.3.2).
//!
//! - The surface is two-sided: seen from either side it is the coating over the base.
//! - Between the interfaces the coating attenuates as a unit-density absorber,
//!   `exp(−thickness / |cos θ|)` per crossing (pbrt-v4 applies this with a zero albedo too).
//! - [`Layered::f`] and [`Layered::pdf`] are unbiased stochastic estimates, deterministic in
//!   `(wo, wi)` (their random numbers are seeded by a hash of the directions), with
//!   `samples` walks of at most `max_depth` scatterings each, Russian roulette after three,
//!   and next-event estimation through the coating weighted by the power heuristic.
//! - [`Layered::pdf`] mixes the estimate with a uniform density: `0.1/(4π) + 0.9·estimate`.
//! - [`Layered::sample`] follows one walk until it leaves through the coating; the sample's
//!   weight is the walk's `f·|cos θi| / pdf` and its density the [`Layered::pdf`] estimate (for
//!   multiple importance sampling), as pbrt-v4's `pdfIsProportional` samples are used.
//! - A scattering coating medium (pbrt-v4's `albedo`, `g`) is not modelled: the loader warns
//!   and uses the absorbing coating.

use super::conductor::Conductor;
use super::interface::{Interface, Lobe, Lobes};
use super::BsdfSample;
use crate::math::Rgb;
use crate::sampling::{cosine_hemisphere, mix64, Rng};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// The base under the coating.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Base {
    /// Lambertian, of this reflectance.
    Diffuse(Rgb),
    /// A conductor (its index relative to the coating's).
    Conductor(Conductor),
}

/// A coated material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layered {
    /// The coating's interface with the outside (its `eta` is the coating's index).
    pub top: Interface,
    /// The base.
    pub base: Base,
    /// The coating's thickness (optical depth of its absorption at normal incidence).
    pub thickness: f32,
    /// Most scatterings of one walk.
    pub max_depth: u32,
    /// Walks per estimate.
    pub samples: u32,
}

/// Power heuristic with exponent 2 for one sample of each strategy.
#[inline]
fn power(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else {
        0.0
    }
}

/// A generator seeded by the bits of two directions.
fn rng_of(a: Vec3, b: Vec3) -> Rng {
    let bits = |v: Vec3| {
        mix64(
            (v.x.to_bits() as u64)
                ^ ((v.y.to_bits() as u64) << 21)
                ^ ((v.z.to_bits() as u64) << 42),
        )
    };
    Rng::new(bits(a), bits(b))
}

impl Base {
    fn is_delta(&self) -> bool {
        matches!(self, Base::Conductor(c) if c.dist.is_smooth())
    }

    /// `f(wo, wi)` for `wo` on either side (the base is met from inside the coating).
    fn f(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z * wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let s = wo.z.signum();
        match self {
            Base::Diffuse(r) => *r * FRAC_1_PI,
            Base::Conductor(c) => c.eval(wo * s, wi * s),
        }
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let s = wo.z.signum();
        match self {
            Base::Diffuse(_) => wi.z.abs() * FRAC_1_PI,
            Base::Conductor(c) => c.pdf(wo * s, wi * s),
        }
    }

    fn sample(&self, wo: Vec3, u: Vec2) -> Option<Lobe> {
        if wo.z == 0.0 {
            return None;
        }
        let s = wo.z.signum();
        let (wi, f, pdf, delta) = match self {
            Base::Diffuse(r) => {
                let wi = cosine_hemisphere(u);
                (wi, *r * FRAC_1_PI, wi.z * FRAC_1_PI, false)
            }
            Base::Conductor(c) => {
                let b = c.sample(wo * s, u)?;
                (b.wi, b.f, b.pdf, b.delta)
            }
        };
        (pdf > 0.0 && f.max_element() > 0.0 && wi.z != 0.0).then_some(Lobe {
            wi: wi * s,
            f,
            pdf,
            delta,
            reflection: true,
        })
    }
}

impl Layered {
    /// Attenuation of one crossing of the coating in direction `w`.
    #[inline]
    fn tr(&self, w: Vec3) -> f32 {
        if self.thickness <= f32::MIN_POSITIVE {
            1.0
        } else {
            (-(self.thickness / w.z).abs()).exp()
        }
    }

    /// The surface's colour for denoisers: the base's reflectance.
    pub fn albedo(&self) -> Rgb {
        match self.base {
            Base::Diffuse(r) => r,
            Base::Conductor(c) => c.albedo(),
        }
    }

    /// An estimate of `f(wo, wi)` without the cosine (`wo.z > 0`; 0 for `wi` below).
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let n = self.samples.max(1);
        let mut f = self.top.f(wo, wi, true) * n as f32;
        let mut rng = rng_of(wo, wi);
        for _ in 0..n {
            f += self.walk_f(wo, wi, &mut rng);
        }
        f / n as f32
    }

    /// One walk of [`Layered::f`]: into the coating from `wo`, between the base and the
    /// coating, estimating at each base scattering the light that leaves towards `wi`.
    fn walk_f(&self, wo: Vec3, wi: Vec3, rng: &mut Rng) -> Rgb {
        let top = &self.top;
        let mut f = Vec3::ZERO;
        let Some(wos) = top.sample(wo, rng.next_f32(), rng.next_2d(), true, Lobes::Transmission)
        else {
            return f;
        };
        let Some(wis) = top.sample(
            wi,
            rng.next_f32(),
            rng.next_2d(),
            false,
            Lobes::Transmission,
        ) else {
            return f;
        };
        let mut beta = wos.f * wos.wi.z.abs() / wos.pdf;
        let mut at_top = true;
        let mut w = wos.wi;
        for depth in 0..self.max_depth {
            if depth > 3 && beta.max_element() < 0.25 {
                let q = (1.0 - beta.max_element()).max(0.0);
                if rng.next_f32() < q {
                    break;
                }
                beta /= 1.0 - q;
            }
            at_top = !at_top;
            beta *= self.tr(w);
            if at_top {
                let Some(bs) =
                    top.sample(-w, rng.next_f32(), rng.next_2d(), true, Lobes::Reflection)
                else {
                    break;
                };
                beta *= bs.f * bs.wi.z.abs() / bs.pdf;
                w = bs.wi;
                continue;
            }
            if !self.base.is_delta() {
                let wt = if top.is_delta() {
                    1.0
                } else {
                    power(wis.pdf, self.base.pdf(-w, -wis.wi))
                };
                f +=
                    beta * self.base.f(-w, -wis.wi) * wis.wi.z.abs() * wt * self.tr(wis.wi) * wis.f
                        / wis.pdf;
            }
            let Some(bs) = self.base.sample(-w, rng.next_2d()) else {
                break;
            };
            beta *= bs.f * bs.wi.z.abs() / bs.pdf;
            w = bs.wi;
            if !top.is_delta() {
                let exit = top.f(-w, wi, true);
                if exit.max_element() > 0.0 {
                    let wt = if self.base.is_delta() {
                        1.0
                    } else {
                        power(bs.pdf, top.pdf(-w, wi, Lobes::Transmission))
                    };
                    f += beta * self.tr(bs.wi) * exit * wt;
                }
            }
        }
        f
    }

    /// An estimate of the density with which [`Layered::sample`] picks `wi`, mixed with the
    /// uniform density: `0.1/(4π) + 0.9·estimate`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let top = &self.top;
        let n = self.samples.max(1);
        let mut sum = n as f32 * top.pdf(wo, wi, Lobes::Reflection);
        let mut rng = rng_of(wi, wo);
        for _ in 0..n {
            let wos = top.sample(wo, rng.next_f32(), rng.next_2d(), true, Lobes::Transmission);
            let wis = top.sample(
                wi,
                rng.next_f32(),
                rng.next_2d(),
                false,
                Lobes::Transmission,
            );
            let (Some(wos), Some(wis)) = (wos, wis) else {
                continue;
            };
            if top.is_delta() {
                sum += self.base.pdf(-wos.wi, -wis.wi);
                continue;
            }
            let Some(rs) = self.base.sample(-wos.wi, rng.next_2d()) else {
                continue;
            };
            if self.base.is_delta() {
                sum += top.pdf(-rs.wi, wi, Lobes::All);
            } else {
                let r_pdf = self.base.pdf(-wos.wi, -wis.wi);
                sum += power(wis.pdf, r_pdf) * r_pdf;
                let t_pdf = top.pdf(-rs.wi, wi, Lobes::All);
                sum += power(rs.pdf, t_pdf) * t_pdf;
            }
        }
        0.1 / (4.0 * PI) + 0.9 * sum / n as f32
    }

    /// Samples `wi` for `wo` (`wo.z > 0`) by one walk, from uniform `uc` and `u` (the
    /// first scattering) and a generator seeded by them (the rest).
    pub fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let bs = self.top.sample(wo, uc, u, true, Lobes::All)?;
        if bs.reflection {
            let weight = bs.f * bs.wi.z.abs() / bs.pdf;
            if bs.delta {
                return Some(BsdfSample::delta(bs.wi, weight, bs.pdf));
            }
            return self.proportional(wo, bs.wi, weight);
        }
        let mut rng = rng_of(wo, Vec3::new(uc, u.x, u.y));
        let mut f = bs.f * bs.wi.z.abs();
        let mut pdf = bs.pdf;
        let mut specular = bs.delta;
        let mut w = bs.wi;
        let mut at_top = true;
        for depth in 0..self.max_depth {
            let rr = f.max_element() / pdf;
            if depth > 3 && rr < 0.25 {
                let q = (1.0 - rr).max(0.0);
                if rng.next_f32() < q {
                    return None;
                }
                pdf *= 1.0 - q;
            }
            if w.z == 0.0 {
                return None;
            }
            at_top = !at_top;
            f *= self.tr(w);
            let s = if at_top {
                self.top
                    .sample(-w, rng.next_f32(), rng.next_2d(), true, Lobes::All)?
            } else {
                self.base.sample(-w, rng.next_2d())?
            };
            f *= s.f;
            pdf *= s.pdf;
            specular &= s.delta;
            w = s.wi;
            if !s.reflection {
                if w.z <= 0.0 {
                    return None;
                }
                let weight = f * w.z.abs() / pdf;
                if specular {
                    return Some(BsdfSample::delta(w, weight, pdf));
                }
                return self.proportional(wo, w, weight);
            }
            f *= s.wi.z.abs();
        }
        None
    }

    /// A non-delta sample of weight `weight` whose density is the [`Layered::pdf`] estimate.
    fn proportional(&self, wo: Vec3, wi: Vec3, weight: Rgb) -> Option<BsdfSample> {
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0 && pdf.is_finite() && weight.is_finite()).then(|| BsdfSample {
            wi,
            f: weight * pdf / wi.z.abs(),
            pdf,
            weight,
            delta: false,
        })
    }
}
