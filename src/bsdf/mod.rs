//! Scattering functions.
//!
//! # Conventions (all BSDFs)
//! - Directions are in the local shading frame: +Z is the shading normal, flipped to the side
//!   the path arrives from, so `wo.z ≥ 0`. Whether that side is the outside of the surface
//!   (the side its geometric normal points to) is passed as `front`; dielectrics need it to
//!   know whether light enters or leaves.
//! - Both `wo` (towards the viewer / previous vertex) and `wi` (towards the light / next
//!   vertex) point away from the surface and are unit vectors. Transmitted `wi` have `wi.z < 0`.
//! - [`Bsdf::eval`] returns `f(wo, wi)` without the cosine factor; it is 0 for delta lobes.
//! - [`Bsdf::pdf`] and [`BsdfSample::pdf`] are densities in solid angle over `wi`; for a delta
//!   lobe [`BsdfSample::pdf`] is the discrete probability of choosing that lobe.
//! - [`BsdfSample::weight`] is the Monte Carlo weight `f · |wi.z| / pdf` of the sample, also
//!   for delta lobes, where `f` itself is a Dirac delta and [`BsdfSample::f`] holds
//!   `weight · pdf / |wi.z|`.
//! - Delta lobes (mirror, glass, refraction) get no light sampling; emission found by the
//!   direction they sample is counted by the integrator instead.

pub mod conductor;
pub mod dielectric;
pub mod facets;
pub mod interface;
pub mod layered;
pub mod microfacet;
pub mod pbr;
pub mod plastic;
pub mod principled;
pub mod tr;

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
    /// Perfect specular reflection tinted by `reflectance` (delta).
    Mirror {
        /// Reflection tint.
        reflectance: Rgb,
    },
    /// Smooth dielectric (delta): reflection with Schlick's Fresnel probability `R`, refraction
    /// otherwise, total internal reflection reflects. Weights as in CS184: `reflectance` for
    /// reflection, `transmittance / η²` for refraction with `η = 1/ior` entering, `ior` leaving.
    Glass {
        /// Reflection tint.
        reflectance: Rgb,
        /// Transmission tint.
        transmittance: Rgb,
        /// Index of refraction of the inside.
        ior: f32,
    },
    /// Smooth dielectric, transmission only (delta); total internal reflection absorbs.
    Refraction {
        /// Transmission tint.
        transmittance: Rgb,
        /// Index of refraction of the inside.
        ior: f32,
    },
    /// Rough conductor: Beckmann or GGX distribution, Smith shadowing-masking, conductor
    /// Fresnel.
    Microfacet(microfacet::Microfacet),
    /// glTF's metallic-roughness material: a diffuse base under a GGX specular layer, metal
    /// turning it into a conductor tinted by the base colour ([`pbr`]).
    Pbr(pbr::Pbr),
    /// pbrt-v4's `conductor`: anisotropic Trowbridge-Reitz, smooth below α 10⁻³.
    Conductor(conductor::Conductor),
    /// pbrt-v4's `dielectric` (smooth or rough) and `thindielectric`; its `eta` is the
    /// inside's index over the outside's for the material, the relative index below `wo`'s
    /// side once [`Bsdf::facing`] has turned it.
    Interface(interface::Interface),
    /// pbrt-v4's `coateddiffuse` and `coatedconductor` ([`layered`]).
    Layered(layered::Layered),
    /// pbrt-v4's `diffusetransmission`: Lambertian reflection `reflectance / π` on `wo`'s side
    /// and transmission `transmittance / π` through; each chosen in proportion to its
    /// largest channel.
    DiffuseTransmission {
        /// Reflectance per channel.
        reflectance: Rgb,
        /// Transmittance per channel.
        transmittance: Rgb,
    },
    /// Mitsuba's `plastic` and `roughplastic` ([`plastic`]).
    Plastic(plastic::Plastic),
    /// Mitsuba's `principled` ([`principled`]).
    Principled(principled::Principled),
    /// Scatters nothing (pure emitters, the back of area lights).
    Black,
}

/// A number parameter that a texture can set per shading point ([`Bsdf::with_param`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    /// Mitsuba's `alpha` of a rough conductor or dielectric (along u and v).
    Alpha,
    /// Mitsuba's `alpha_u` of a rough conductor or dielectric.
    AlphaU,
    /// Mitsuba's `alpha_v` of a rough conductor or dielectric.
    AlphaV,
    /// Mitsuba's `blendbsdf` `weight` (set on the mix, not on a BSDF).
    Weight,
    /// [`principled::Principled::roughness`].
    Roughness,
    /// [`principled::Principled::anisotropic`].
    Anisotropic,
    /// [`principled::Principled::metallic`].
    Metallic,
    /// [`principled::Principled::spec_trans`].
    SpecTrans,
    /// [`principled::Principled::spec_tint`].
    SpecTint,
    /// [`principled::Principled::sheen`].
    Sheen,
    /// [`principled::Principled::sheen_tint`].
    SheenTint,
    /// [`principled::Principled::flatness`].
    Flatness,
    /// [`principled::Principled::clearcoat`].
    Clearcoat,
    /// [`principled::Principled::clearcoat_gloss`].
    ClearcoatGloss,
}

/// One sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled incident direction, local frame.
    pub wi: Vec3,
    /// `eval(wo, wi)` (for delta lobes, the value that makes `f · |wi.z| / pdf = weight`).
    pub f: Rgb,
    /// Solid-angle pdf of `wi`, or the lobe's discrete probability for delta lobes.
    pub pdf: f32,
    /// `f · |wi.z| / pdf`.
    pub weight: Rgb,
    /// True when `wi` was chosen from a delta lobe.
    pub delta: bool,
}

impl BsdfSample {
    /// The sample of a non-delta lobe with `f = eval(wo, wi)` and density `pdf`; `None` when
    /// the density is not positive and finite.
    pub(crate) fn glossy(wi: Vec3, f: Rgb, pdf: f32) -> Option<Self> {
        (pdf > 0.0 && pdf.is_finite()).then(|| BsdfSample {
            wi,
            f,
            pdf,
            weight: f * wi.z.abs() / pdf,
            delta: false,
        })
    }

    pub(crate) fn delta(wi: Vec3, weight: Rgb, prob: f32) -> Self {
        let c = wi.z.abs().max(1e-8);
        BsdfSample {
            wi,
            f: weight * prob / c,
            pdf: prob,
            weight,
            delta: true,
        }
    }
}

/// A direction of a diffuse transmitter (cosine-distributed on `wo`'s side, or through),
/// choosing the side in proportion to the largest channel of `reflectance` and
/// `transmittance` with `u1`; `None` when both are black.
fn diffuse_transmission_direction(
    reflectance: Rgb,
    transmittance: Rgb,
    u: Vec2,
    u1: f32,
) -> Option<Vec3> {
    let (pr, pt) = (reflectance.max_element(), transmittance.max_element());
    if pr + pt <= 0.0 {
        return None;
    }
    let mut wi = cosine_hemisphere(u);
    if u1 >= pr / (pr + pt) {
        wi.z = -wi.z;
    }
    Some(wi)
}

/// Mirror reflection of `wo` about the local normal.
#[inline]
pub fn reflect(wo: Vec3) -> Vec3 {
    Vec3::new(-wo.x, -wo.y, wo.z)
}

/// Refraction of `wo` (with `wo.z > 0`) through the local normal for relative index `eta`
/// (incident medium over transmitted medium, Snell: `sin θt = eta · sin θi`); `None` on total
/// internal reflection.
#[inline]
pub fn refract(wo: Vec3, eta: f32) -> Option<Vec3> {
    let sin2_t = eta * eta * (1.0 - wo.z * wo.z).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    Some(Vec3::new(-eta * wo.x, -eta * wo.y, -(1.0 - sin2_t).sqrt()))
}

/// Schlick's approximation of the dielectric reflectance for `cos = |cos θ_o|` (CS184).
#[inline]
pub fn schlick(cos: f32, ior: f32) -> f32 {
    let r0 = ((1.0 - ior) / (1.0 + ior)).powi(2);
    r0 + (1.0 - r0) * (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

impl Bsdf {
    /// `f(wo, wi)`, no cosine; 0 for delta BSDFs.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match self {
            Bsdf::Diffuse { albedo } if wo.z > 0.0 && wi.z > 0.0 => *albedo * FRAC_1_PI,
            Bsdf::Microfacet(m) => m.eval(wo, wi),
            Bsdf::Pbr(m) => m.eval(wo, wi),
            Bsdf::Conductor(c) => c.eval(wo, wi),
            Bsdf::Interface(i) => i.f(wo, wi, true),
            Bsdf::Layered(l) => l.f(wo, wi),
            Bsdf::Plastic(p) => p.eval(wo, wi),
            Bsdf::Principled(p) => p.eval(wo, wi),
            Bsdf::DiffuseTransmission {
                reflectance,
                transmittance,
            } if wo.z > 0.0 => {
                (if wi.z > 0.0 {
                    *reflectance
                } else {
                    *transmittance
                }) * FRAC_1_PI
            }
            _ => Vec3::ZERO,
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] picks `wi`; 0 for delta BSDFs.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse { .. } if wo.z > 0.0 && wi.z > 0.0 => cosine_hemisphere_pdf(wi),
            Bsdf::Microfacet(m) => m.pdf(wo, wi),
            Bsdf::Pbr(m) => m.pdf(wo, wi),
            Bsdf::Conductor(c) => c.pdf(wo, wi),
            Bsdf::Interface(i) => i.pdf(wo, wi, interface::Lobes::All),
            Bsdf::Layered(l) => l.pdf(wo, wi),
            Bsdf::Plastic(p) => p.pdf(wo, wi),
            Bsdf::Principled(p) => p.pdf(wo, wi),
            Bsdf::DiffuseTransmission {
                reflectance,
                transmittance,
            } if wo.z > 0.0 => {
                let (pr, pt) = (reflectance.max_element(), transmittance.max_element());
                let p = if wi.z > 0.0 { pr } else { pt };
                if pr + pt > 0.0 {
                    p / (pr + pt) * wi.z.abs() * FRAC_1_PI
                } else {
                    0.0
                }
            }
            _ => 0.0,
        }
    }

    /// Samples `wi` for `wo` from uniform numbers `u` (2D) and `u1` (1D, for the choice between
    /// lobes); `front` tells dielectrics that `wo` is on the outside. `None` when nothing is
    /// scattered.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2, u1: f32, front: bool) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        match *self {
            Bsdf::Diffuse { albedo } => {
                let wi = cosine_hemisphere(u);
                let pdf = cosine_hemisphere_pdf(wi);
                (pdf > 0.0).then(|| BsdfSample {
                    wi,
                    f: albedo * FRAC_1_PI,
                    pdf,
                    weight: albedo,
                    delta: false,
                })
            }
            Bsdf::Mirror { reflectance } => Some(BsdfSample::delta(reflect(wo), reflectance, 1.0)),
            Bsdf::Glass {
                reflectance,
                transmittance,
                ior,
            } => {
                let eta = if front { 1.0 / ior } else { ior };
                match refract(wo, eta) {
                    None => Some(BsdfSample::delta(reflect(wo), reflectance, 1.0)),
                    Some(wt) => {
                        let r = schlick(wo.z, ior);
                        if u1 < r {
                            Some(BsdfSample::delta(reflect(wo), reflectance, r))
                        } else {
                            Some(BsdfSample::delta(wt, transmittance / (eta * eta), 1.0 - r))
                        }
                    }
                }
            }
            Bsdf::Refraction { transmittance, ior } => {
                let eta = if front { 1.0 / ior } else { ior };
                refract(wo, eta).map(|wt| BsdfSample::delta(wt, transmittance / (eta * eta), 1.0))
            }
            Bsdf::Microfacet(m) => m.sample(wo, u),
            Bsdf::Pbr(m) => m.sample(wo, u, u1),
            Bsdf::Conductor(c) => c.sample(wo, u),
            Bsdf::Interface(i) => i.sample_radiance(wo, u, u1),
            Bsdf::Layered(l) => l.sample(wo, u, u1),
            Bsdf::Plastic(p) => p.sample(wo, u, u1),
            Bsdf::Principled(p) => p.sample(wo, u, u1),
            Bsdf::DiffuseTransmission {
                reflectance,
                transmittance,
            } => {
                let wi = diffuse_transmission_direction(reflectance, transmittance, u, u1)?;
                BsdfSample::glossy(wi, self.eval(wo, wi), self.pdf(wo, wi))
            }
            Bsdf::Black => None,
        }
    }

    /// The factor by which a transmitted sample's weight scales radiance: `1/η²` with CS184's
    /// `η = 1/ior` entering and `ior` leaving (`front`: the path arrives from the outside), or
    /// a transmitting [`pbr::Pbr`]'s `1/η²` with its relative index (see [`Bsdf::facing`]);
    /// 1 for BSDFs that do not transmit.
    #[inline]
    pub fn radiance_scale(&self, front: bool) -> f32 {
        match *self {
            Bsdf::Glass { ior, .. } | Bsdf::Refraction { ior, .. } => {
                let eta = if front { 1.0 / ior } else { ior };
                1.0 / (eta * eta)
            }
            Bsdf::Pbr(p) if p.transmission > 0.0 => {
                let eta = p.dielectric().eta();
                1.0 / (eta * eta)
            }
            Bsdf::Interface(i) if !i.thin => 1.0 / (i.eta * i.eta),
            Bsdf::Principled(p) if p.transmits() => {
                let eta = if front { p.eta } else { 1.0 / p.eta };
                1.0 / (eta * eta)
            }
            _ => 1.0,
        }
    }

    /// The BSDF seen from the outside (`front`) or the inside. BSDFs whose `eval` and `pdf`
    /// depend on the side (transmitting [`pbr::Pbr`]) record it; the others are unchanged.
    #[inline]
    pub fn facing(self, front: bool) -> Bsdf {
        match self {
            Bsdf::Pbr(p) if p.transmission > 0.0 => Bsdf::Pbr(pbr::Pbr { front, ..p }),
            Bsdf::Interface(i) if !front && !i.thin => Bsdf::Interface(interface::Interface {
                eta: 1.0 / i.eta,
                ..i
            }),
            Bsdf::Principled(p) if p.transmits() => {
                Bsdf::Principled(principled::Principled { front, ..p })
            }
            b => b,
        }
    }

    /// True when a non-delta lobe transmits (`eval` can be non-zero for `wi.z < 0`), so light
    /// sampling must consider lights behind the surface.
    #[inline]
    pub fn transmits(&self) -> bool {
        match self {
            Bsdf::Pbr(p) => p.transmitting_share() > 0.0 && !p.dielectric().is_smooth(),
            Bsdf::Interface(i) => !i.is_delta(),
            Bsdf::DiffuseTransmission { transmittance, .. } => transmittance.max_element() > 0.0,
            Bsdf::Principled(p) => p.transmits(),
            _ => false,
        }
    }

    /// True when the BSDF depends on the direction of the surface's tangent (anisotropic
    /// roughness), so that its frame must follow the surface's `∂p/∂u`.
    #[inline]
    pub fn is_anisotropic(&self) -> bool {
        match self {
            Bsdf::Conductor(c) => c.dist.is_anisotropic(),
            Bsdf::Microfacet(m) => m.alpha != m.alpha_v,
            Bsdf::Interface(i) => !i.thin && i.dist.is_anisotropic(),
            Bsdf::Layered(l) => {
                l.top.dist.is_anisotropic()
                    || matches!(l.base, layered::Base::Conductor(c) if c.dist.is_anisotropic())
            }
            Bsdf::Principled(p) => p.anisotropic > 0.0,
            _ => false,
        }
    }

    /// True when [`Bsdf::sample`] uses its 1D number `u1` (a choice between lobes).
    #[inline]
    pub fn chooses_lobe(&self) -> bool {
        matches!(
            self,
            Bsdf::Glass { .. }
                | Bsdf::Pbr(_)
                | Bsdf::Interface(_)
                | Bsdf::Layered(_)
                | Bsdf::Plastic(_)
                | Bsdf::Principled(_)
                | Bsdf::DiffuseTransmission { .. }
        )
    }

    /// True when every lobe is a Dirac delta (no light sampling at such vertices).
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Mirror { .. } | Bsdf::Glass { .. } | Bsdf::Refraction { .. } => true,
            Bsdf::Pbr(p) => p.transmitting_share() >= 1.0 && p.dielectric().is_smooth(),
            Bsdf::Conductor(c) => c.dist.is_smooth(),
            Bsdf::Interface(i) => i.is_delta(),
            _ => false,
        }
    }

    /// The surface's colour for denoisers and analysis (an albedo image): the reflectance of
    /// diffuse and mirror surfaces, the transmittance of dielectrics, a conductor's Fresnel
    /// reflectance at normal incidence; per channel in [0, 1] for valid materials.
    pub fn albedo(&self) -> Rgb {
        match *self {
            Bsdf::Diffuse { albedo } => albedo,
            Bsdf::Mirror { reflectance } => reflectance,
            Bsdf::Glass { transmittance, .. } | Bsdf::Refraction { transmittance, .. } => {
                transmittance
            }
            Bsdf::Microfacet(m) => microfacet::fresnel_conductor(1.0, m.eta, m.k) * m.tint,
            Bsdf::Pbr(m) => m.base,
            Bsdf::Conductor(c) => c.albedo(),
            Bsdf::Interface(_) => Rgb::ONE,
            Bsdf::Layered(l) => l.albedo(),
            Bsdf::Plastic(p) => p.albedo(),
            Bsdf::Principled(p) => p.albedo(),
            Bsdf::DiffuseTransmission {
                reflectance,
                transmittance,
            } => (reflectance + transmittance).min(Rgb::ONE),
            Bsdf::Black => Rgb::ZERO,
        }
    }

    /// True when [`Bsdf::with_param`] sets `param` of this BSDF.
    pub fn takes(&self, param: Param) -> bool {
        let alpha = matches!(param, Param::Alpha | Param::AlphaU | Param::AlphaV);
        match self {
            Bsdf::Microfacet(_) | Bsdf::Conductor(_) => alpha,
            Bsdf::Interface(i) => alpha && !i.thin,
            Bsdf::Principled(_) => !alpha && param != Param::Weight,
            _ => false,
        }
    }

    /// The BSDF with `param` set to `value` at one shading point (clamped as the loaders
    /// clamp it); unchanged when it does not [`Bsdf::takes`] it.
    pub fn with_param(self, param: Param, value: f32) -> Bsdf {
        let value = if value.is_finite() { value } else { 0.0 };
        // α along u and v after setting `param` to `value`.
        let alphas = |(u, v): (f32, f32)| {
            let a = value.clamp(1e-4, 10.0);
            match param {
                Param::Alpha => (a, a),
                Param::AlphaU => (a, v),
                _ => (u, a),
            }
        };
        match self {
            Bsdf::Microfacet(m) if self.takes(param) => {
                let (alpha, alpha_v) = alphas((m.alpha, m.alpha_v));
                Bsdf::Microfacet(microfacet::Microfacet {
                    alpha,
                    alpha_v,
                    ..m
                })
            }
            Bsdf::Conductor(c) if self.takes(param) => {
                let (u, v) = alphas((c.dist.alpha_x, c.dist.alpha_y));
                Bsdf::Conductor(conductor::Conductor {
                    dist: tr::TrowbridgeReitz::new(u, v),
                    ..c
                })
            }
            Bsdf::Interface(i) if self.takes(param) => {
                let (u, v) = alphas(i.dist.alphas());
                Bsdf::Interface(interface::Interface {
                    dist: i.dist.with_alphas(u, v),
                    ..i
                })
            }
            Bsdf::Principled(p) => Bsdf::Principled(p.with(param, value)),
            b => b,
        }
    }

    /// True when the BSDF never scatters.
    pub fn is_black(&self) -> bool {
        match *self {
            Bsdf::Diffuse { albedo } => albedo == Vec3::ZERO,
            Bsdf::Black => true,
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::microfacet::Microfacet;
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere, Chi2Config};
    use crate::sampling::Rng;

    /// A BSDF is held by value at every path vertex: it stays within one cache line.
    #[test]
    fn fits_a_cache_line() {
        assert!(
            std::mem::size_of::<Bsdf>() <= 64,
            "{} bytes",
            std::mem::size_of::<Bsdf>()
        );
    }

    fn all_bsdfs() -> Vec<Bsdf> {
        vec![
            Bsdf::Diffuse {
                albedo: Vec3::new(0.2, 0.5, 0.8),
            },
            Bsdf::Mirror {
                reflectance: Vec3::new(0.9, 0.8, 0.7),
            },
            Bsdf::Glass {
                reflectance: Vec3::ONE,
                transmittance: Vec3::new(1.0, 0.9, 0.8),
                ior: 1.45,
            },
            Bsdf::Refraction {
                transmittance: Vec3::ONE,
                ior: 1.5,
            },
            Bsdf::Microfacet(Microfacet::new(
                0.25,
                Vec3::new(0.059, 0.06, 0.047),
                Vec3::new(4.1, 3.6, 2.8),
            )),
            Bsdf::Microfacet(Microfacet::new(
                0.05,
                Vec3::new(1.3, 1.0, 0.69),
                Vec3::new(7.3, 6.6, 5.6),
            )),
            Bsdf::Microfacet(Microfacet::ggx(
                0.3,
                Vec3::new(0.2, 0.9, 1.1),
                Vec3::new(3.9, 2.4, 2.2),
            )),
            Bsdf::Pbr(pbr::Pbr::new(Vec3::new(0.8, 0.5, 0.2), 0.0, 0.5)),
            Bsdf::Pbr(pbr::Pbr::new(Vec3::new(0.9, 0.7, 0.3), 1.0, 0.2)),
            Bsdf::Pbr(pbr::Pbr::new(Vec3::new(0.3, 0.9, 0.6), 0.4, 1.0)),
            Bsdf::Microfacet(Microfacet::ggx(
                0.05,
                Vec3::new(1.3, 1.0, 0.69),
                Vec3::new(7.3, 6.6, 5.6),
            )),
            Bsdf::Pbr(
                pbr::Pbr::new(Vec3::new(0.9, 0.8, 0.7), 0.0, 0.0).with_transmission(1.0, 1.5),
            ),
            Bsdf::Pbr(
                pbr::Pbr::new(Vec3::new(0.9, 0.8, 0.7), 0.0, 0.5).with_transmission(1.0, 1.33),
            ),
            Bsdf::Pbr(
                pbr::Pbr::new(Vec3::new(0.6, 0.8, 0.9), 0.2, 0.3).with_transmission(0.6, 1.7),
            ),
            Bsdf::Pbr(
                pbr::Pbr::new(Vec3::new(0.6, 0.8, 0.9), 0.0, 0.0).with_transmission(0.5, 1.5),
            ),
            Bsdf::Conductor(conductor::Conductor {
                dist: tr::TrowbridgeReitz::new(0.1, 0.4),
                eta: Vec3::new(0.2, 0.9, 1.1),
                k: Vec3::new(3.9, 2.4, 2.1),
                tint: Vec3::ONE,
            }),
            Bsdf::Conductor(conductor::Conductor {
                dist: tr::TrowbridgeReitz::new(0.0, 0.0),
                eta: Vec3::new(0.13, 0.12, 0.15),
                k: Vec3::new(4.0, 3.3, 2.4),
                tint: Vec3::ONE,
            }),
            Bsdf::Interface(interface::Interface {
                eta: 1.5,
                dist: tr::TrowbridgeReitz::new(0.3, 0.15).into(),
                thin: false,
            }),
            Bsdf::Interface(interface::Interface {
                eta: 1.33,
                dist: tr::TrowbridgeReitz::new(0.0, 0.0).into(),
                thin: false,
            }),
            Bsdf::Interface(interface::Interface {
                eta: 1.5,
                dist: tr::TrowbridgeReitz::new(0.0, 0.0).into(),
                thin: true,
            }),
            Bsdf::Interface(interface::Interface {
                eta: 1.7,
                dist: facets::Facets::Beckmann(facets::Beckmann::new(0.25, 0.1)),
                thin: false,
            }),
            Bsdf::DiffuseTransmission {
                reflectance: Vec3::new(0.3, 0.5, 0.2),
                transmittance: Vec3::new(0.6, 0.2, 0.4),
            },
        ]
        .into_iter()
        .chain(principled::tests::cases().into_iter().map(Bsdf::Principled))
        .collect()
    }

    fn directions() -> Vec<Vec3> {
        [
            (0.0f32, 0.0f32),
            (0.3, 0.1),
            (1.0, 2.0),
            (1.45, -0.7),
            (1.55, 0.4),
        ]
        .iter()
        .map(|&(theta, phi)| {
            Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            )
        })
        .collect()
    }

    #[test]
    fn sample_matches_eval_and_pdf() {
        let mut rng = Rng::new(1, 1);
        for b in all_bsdfs() {
            for wo in directions() {
                for front in [true, false] {
                    let b = b.facing(front);
                    for _ in 0..500 {
                        let Some(s) = b.sample(wo, rng.next_2d(), rng.next_f32(), front) else {
                            continue;
                        };
                        assert!(
                            (s.wi.length() - 1.0).abs() < 1e-4,
                            "{b:?}: |wi| = {}",
                            s.wi.length()
                        );
                        assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0);
                        if s.delta {
                            // A delta lobe's f is not in eval; a mixture's other lobes may
                            // still reflect into its direction.
                            assert!(b.is_delta() || b.chooses_lobe());
                            if b.is_delta() {
                                assert_eq!(b.eval(wo, s.wi), Vec3::ZERO);
                            }
                        } else {
                            let pdf = b.pdf(wo, s.wi);
                            assert!(
                                (s.pdf - pdf).abs() <= 1e-3 * pdf.max(1.0),
                                "{b:?} wo={wo}: sample pdf {} vs pdf() {pdf}",
                                s.pdf
                            );
                            let f = b.eval(wo, s.wi);
                            assert!(
                                (s.f - f).abs().max_element() <= 1e-3 * f.max_element().max(1.0),
                                "{b:?}: {} vs {f}",
                                s.f
                            );
                            assert!(
                                (s.weight - f * s.wi.z.abs() / pdf).abs().max_element()
                                    < 1e-3 * s.weight.max_element().max(1.0)
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn reciprocity() {
        let mut rng = Rng::new(2, 2);
        for b in all_bsdfs() {
            for _ in 0..2000 {
                let a = crate::sampling::uniform_hemisphere(rng.next_2d());
                let c = crate::sampling::uniform_hemisphere(rng.next_2d());
                let (x, y) = (b.eval(a, c), b.eval(c, a));
                assert!(
                    (x - y).abs().max_element() <= 1e-4 * x.max_element().max(1.0),
                    "{b:?}: {x} vs {y}"
                );
            }
        }
    }

    #[test]
    fn generalised_reciprocity_of_transmission() {
        // f(wo, wi) / n(wo)² = f(wi, wo) / n(wi)² across the interface: seen from wi's side
        // (the other `front`, both directions mirrored through the surface).
        let mut rng = Rng::new(2, 3);
        let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
        let mut tested = 0;
        for b in all_bsdfs().into_iter().filter(|b| b.transmits()) {
            for front in [true, false] {
                let (b, rev) = (b.facing(front), b.facing(!front));
                let eta2 = 1.0 / b.radiance_scale(front);
                for _ in 0..2000 {
                    let wo = crate::sampling::uniform_hemisphere(rng.next_2d());
                    let wi = flip(crate::sampling::uniform_hemisphere(rng.next_2d()));
                    if let Bsdf::Pbr(p) = b {
                        if dielectric::tests::near_grazing(&p.dielectric(), wo, wi) {
                            continue;
                        }
                    }
                    let eta = match b {
                        Bsdf::Interface(i) => Some(i.eta),
                        Bsdf::Principled(p) => Some(if front { p.eta } else { 1.0 / p.eta }),
                        _ => None,
                    };
                    if let Some(eta) = eta {
                        let m = (wo + wi * eta).normalize_or_zero();
                        if wo.dot(m).abs().min(wi.dot(m).abs()) < 0.01 {
                            continue;
                        }
                    }
                    let (x, y) = (b.eval(wo, wi) * eta2, rev.eval(flip(wi), flip(wo)));
                    assert!(
                        (x - y).abs().max_element() <= 1e-2 * x.max_element().max(y.max_element()),
                        "{b:?}: {x} vs {y}"
                    );
                    tested += (x.max_element() > 0.0) as u32;
                }
            }
        }
        assert!(tested > 1000, "{tested} non-zero pairs");
    }

    #[test]
    fn albedo_at_most_one() {
        // ∫ f |cos| dω estimated with the BSDF's own sampling, for every BSDF and direction
        // (but the principled BSDF with a sheen, which by its definition adds energy at
        // grazing angles).
        let mut rng = Rng::new(3, 3);
        let conserving = |b: &Bsdf| !matches!(b, Bsdf::Principled(p) if p.sheen > 0.0);
        for b in all_bsdfs().into_iter().filter(conserving) {
            let b = b.facing(true);
            for wo in directions() {
                let n = 20_000;
                let mut acc = Vec3::ZERO;
                for _ in 0..n {
                    if let Some(s) = b.sample(wo, rng.next_2d(), rng.next_f32(), true) {
                        // Undo the radiance scaling across the interface (η²) to get energy.
                        let scale = if s.wi.z < 0.0 {
                            1.0 / b.radiance_scale(true)
                        } else {
                            1.0
                        };
                        acc += s.weight * scale;
                    }
                }
                let albedo = acc / n as f32;
                assert!(
                    albedo.max_element() <= 1.0 + 2e-3,
                    "{b:?} wo={wo}: albedo {albedo}"
                );
            }
        }
    }

    #[test]
    fn dielectric_chooses_lobes_by_fresnel() {
        let b = Bsdf::Glass {
            reflectance: Vec3::ONE,
            transmittance: Vec3::ONE,
            ior: 1.5,
        };
        let mut rng = Rng::new(4, 4);
        for wo in directions() {
            let r = schlick(wo.z, 1.5);
            let n = 200_000;
            let mut reflected = 0;
            for _ in 0..n {
                let s = b.sample(wo, rng.next_2d(), rng.next_f32(), true).unwrap();
                if s.wi.z > 0.0 {
                    assert!((s.wi - reflect(wo)).length() < 1e-6);
                    reflected += 1;
                } else {
                    // Snell's law: sin θt = sin θi / 1.5, same plane of incidence.
                    let (si, st) = ((1.0 - wo.z * wo.z).sqrt(), (1.0 - s.wi.z * s.wi.z).sqrt());
                    assert!((st - si / 1.5).abs() < 1e-5);
                }
            }
            let frac = reflected as f64 / n as f64;
            let sigma = (r as f64 * (1.0 - r as f64) / n as f64).sqrt();
            assert!(
                (frac - r as f64).abs() < 5.0 * sigma + 1e-9,
                "wo={wo}: reflected {frac} vs Fresnel {r}"
            );
        }
        // Total internal reflection from inside beyond the critical angle (41.8° for 1.5).
        let wo = Vec3::new((50f32).to_radians().sin(), 0.0, (50f32).to_radians().cos());
        let s = b.sample(wo, Vec2::splat(0.5), 0.99, false).unwrap();
        assert!(
            s.wi.z > 0.0 && s.weight == Vec3::ONE,
            "TIR reflects everything"
        );
        assert!(
            Bsdf::Refraction {
                transmittance: Vec3::ONE,
                ior: 1.5
            }
            .sample(wo, Vec2::splat(0.5), 0.5, false)
            .is_none(),
            "refraction absorbs on TIR"
        );
    }

    /// Textures set the parameters a BSDF takes, and no others.
    #[test]
    fn textured_parameters_set_what_they_name() {
        let m = Bsdf::Microfacet(Microfacet::new(0.3, Vec3::ONE, Vec3::ONE));
        let Bsdf::Microfacet(u) = m.with_param(Param::AlphaU, 0.05) else {
            panic!("a conductor stays one");
        };
        assert_eq!((u.alpha, u.alpha_v), (0.05, 0.3));
        let Bsdf::Microfacet(a) = m.with_param(Param::Alpha, 0.5) else {
            panic!("a conductor stays one");
        };
        assert_eq!((a.alpha, a.alpha_v), (0.5, 0.5));
        assert_eq!(m.with_param(Param::Metallic, 0.5), m);
        let glass = Bsdf::Interface(interface::Interface {
            eta: 1.5,
            dist: facets::Facets::Beckmann(facets::Beckmann::new(0.2, 0.2)),
            thin: false,
        });
        let Bsdf::Interface(g) = glass.with_param(Param::AlphaV, 0.4) else {
            panic!("a dielectric stays one");
        };
        assert_eq!(
            g.dist,
            facets::Facets::Beckmann(facets::Beckmann::new(0.2, 0.4))
        );
        let p = Bsdf::Principled(principled::Principled::default());
        let Bsdf::Principled(q) = p.with_param(Param::Sheen, 2.0) else {
            panic!("a principled BSDF stays one");
        };
        assert_eq!(q.sheen, 1.0, "clamped to [0, 1]");
        assert!(!p.takes(Param::Alpha) && !p.takes(Param::Weight));
        let diffuse = Bsdf::Diffuse { albedo: Vec3::ONE };
        assert!(!diffuse.takes(Param::Alpha));
        assert_eq!(diffuse.with_param(Param::Alpha, 0.1), diffuse);
    }

    #[test]
    fn diffuse_matches_chi2() {
        let b = Bsdf::Diffuse {
            albedo: Vec3::splat(0.5),
        };
        let wo = Vec3::new(0.3, -0.2, 0.93).normalize();
        let cfg = Chi2Config {
            samples: 200_000,
            ..Default::default()
        };
        chi2_test_sphere(
            &cfg,
            |u| b.sample(wo, u, 0.5, true).map(|s| s.wi),
            |wi| b.pdf(wo, wi),
        )
        .unwrap();
    }
}
