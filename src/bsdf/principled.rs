//! Mitsuba 3's `principled` BSDF (Disney's 2015 model as Mitsuba defines it), evaluated in
//! Mitsuba's frame: `+Z` the outward shading normal, so `wo.z < 0` when the path arrives from
//! inside ([`Principled::front`] false; only a transmitting surface is seen from there).
//!
//! With `brdf = (1 − metallic)(1 − spec_trans)`, `bsdf = (1 − metallic)·spec_trans`, the
//! GGX distribution of `α = max(0.001, roughness²)` (stretched by
//! `aspect = √(1 − 0.9·anisotropic)`: `αx = α/aspect`, `αy = α·aspect`), separable Smith `G`,
//! the exact dielectric Fresnel `F` of `eta` at `wo·h` and Schlick's weight
//! `S(c) = (1 − c)⁵`, `f·|cos θi|` is the sum of
//! - the main specular reflection `Fp·D·G / (4|cos θo|)`, where on the outside
//!   `Fp = (1 − metallic)(1 − spec_tint)·F + metallic·Schlick(base) +
//!   (1 − metallic)·spec_tint·Schlick(tint·R0(η))` (`tint = base / luminance(base)`) and on
//!   the inside `Fp = bsdf·F`;
//! - the main specular transmission `√base · bsdf · (1 − F)·D·G·|wo·h wi·h| /
//!   (|cos θo|·(wo·h + η'·wi·h)²)` (radiance form, η' the relative index of the side entered);
//! - on the outside only, the clearcoat `clearcoat/4 · Schlick(0.04)·D₁·G₁₄·|cos θi|` with
//!   Burley's GTR1 distribution of `α = lerp(0.1, 0.001, clearcoat_gloss)` and separable GGX
//!   shadowing of α ¼ (Mitsuba omits a microfacet lobe's `1/(4 cos θo cos θi)` here); the
//!   diffuse `brdf·base/π·|cos θi|·lerp(fd + fr, fss, flatness)` with
//!   `fd = (1 − S(cos θi)/2)(1 − S(cos θo)/2)`, retro-reflection `fr = R(So + Si + So·Si(R − 1))`,
//!   `R = 2·roughness·(h·wi)²`, and Hanrahan-Krueger's `fss`; and the sheen
//!   `sheen·(1 − metallic)·S(h·wi)·lerp(1, tint, sheen_tint)·|cos θi|`.
//!
//! Sampling chooses among the diffuse (cosine-weighted), clearcoat (GTR1 normals), specular
//! transmission and reflection (GGX visible normals) in proportion to `brdf`, `clearcoat/4`,
//! `bsdf·(1 − F)` and `1 − bsdf·(1 − F)` (inside: `1 − F` and `F`), as Mitsuba does with its
//! sampling rates at 1. The rates change only the noise, never the image.

use super::interface::{fresnel, refract};
use super::tr::TrowbridgeReitz;
use super::{BsdfSample, Param};
use crate::math::Rgb;
use crate::sampling::cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Mitsuba's `principled` parameters at one point, each in [0, 1] but `base` (a colour) and
/// `eta`; [`Principled::default`] holds Mitsuba's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principled {
    /// Base colour.
    pub base: Rgb,
    /// Roughness (α = roughness²).
    pub roughness: f32,
    /// Anisotropy of the specular lobes.
    pub anisotropic: f32,
    /// Metalness.
    pub metallic: f32,
    /// Weight of the specular transmission.
    pub spec_trans: f32,
    /// Tint of the dielectric reflection towards the base colour.
    pub spec_tint: f32,
    /// Weight of the sheen.
    pub sheen: f32,
    /// Tint of the sheen towards the base colour.
    pub sheen_tint: f32,
    /// Blend from the diffuse lobe to the fake subsurface one.
    pub flatness: f32,
    /// Weight of the clearcoat.
    pub clearcoat: f32,
    /// Glossiness of the clearcoat.
    pub clearcoat_gloss: f32,
    /// Index of refraction of the inside over the outside.
    pub eta: f32,
    /// The path arrives from the outside (see [`crate::bsdf::Bsdf::facing`]).
    pub front: bool,
}

impl Default for Principled {
    fn default() -> Self {
        Principled {
            base: Rgb::splat(0.5),
            roughness: 0.5,
            anisotropic: 0.0,
            metallic: 0.0,
            spec_trans: 0.0,
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            flatness: 0.0,
            clearcoat: 0.0,
            clearcoat_gloss: 0.0,
            eta: 1.5,
            front: true,
        }
    }
}

/// Schlick's weight `(1 − c)⁵`, `c` clamped to [0, 1].
#[inline]
fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    m * m * m * m * m
}

/// Mitsuba's `calc_schlick`: Schlick's reflectance of normal reflectance `r0` at `cos` (the
/// side given by its sign), taken at the transmitted angle when leaving the denser side.
fn schlick(r0: Rgb, cos: f32, eta: f32) -> Rgb {
    let eta_it = if cos >= 0.0 { eta } else { 1.0 / eta };
    let weight = if eta_it > 1.0 {
        schlick_weight(cos.abs())
    } else {
        let cos_t2 = 1.0 - (1.0 - cos * cos) / (eta_it * eta_it);
        schlick_weight(cos_t2.max(0.0).sqrt())
    };
    r0 + (Rgb::ONE - r0) * weight
}

/// Separable GGX shadowing of one direction for the clearcoat (Mitsuba's `smith_ggx1`).
fn smith_ggx1(v: Vec3, h: Vec3, alpha: f32) -> f32 {
    if v.dot(h) * v.z <= 0.0 {
        return 0.0;
    }
    let cos2 = v.z * v.z;
    if cos2 >= 1.0 {
        return 1.0;
    }
    let tan2 = (1.0 - cos2) / cos2;
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// Burley's GTR1 distribution of the clearcoat, `D(h) = (α² − 1) / (π ln α² (1 + (α² − 1) cos²θh))`.
fn gtr1(alpha: f32, h: Vec3) -> f32 {
    let a2 = alpha * alpha;
    let d = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * h.z * h.z));
    if d * h.z > 1e-20 {
        d
    } else {
        0.0
    }
}

/// A GTR1 normal drawn with density `D(h)·cos θh`.
fn sample_gtr1(alpha: f32, u: Vec2) -> Vec3 {
    let (sin_phi, cos_phi) = (2.0 * PI * u.x).sin_cos();
    let a2 = alpha * alpha;
    let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
    let sin = (1.0 - cos2).max(0.0).sqrt();
    Vec3::new(cos_phi * sin, sin_phi * sin, cos2.max(0.0).sqrt())
}

/// Mirror reflection of `w` about `m`.
#[inline]
fn reflect_about(w: Vec3, m: Vec3) -> Vec3 {
    2.0 * w.dot(m) * m - w
}

/// Rec. 709 luminance, Mitsuba's `luminance` of an RGB colour.
#[inline]
fn luminance(c: Rgb) -> f32 {
    0.212_671 * c.x + 0.715_160 * c.y + 0.072_169 * c.z
}

/// The half vector of a pair and its geometry, in Mitsuba's frame.
struct Pair {
    /// `+1` outside, `−1` inside (the sign of `cos θo`).
    side: f32,
    /// Both directions on the same side.
    reflect: bool,
    /// The half vector, turned to `+Z`.
    h: Vec3,
    /// The relative index of the side `wi` lies in, seen from `wo`'s (1 for reflection).
    eta_path: f32,
    /// `h` faces both directions as a reflecting microfacet does.
    reflect_ok: bool,
    /// `h` faces both directions as a refracting microfacet does.
    refract_ok: bool,
    /// Fresnel reflectance of the dielectric at `wo·h`.
    fresnel: f32,
}

impl Principled {
    /// The parameters with `param` set to `value`, clamped to [0, 1] (unchanged for
    /// parameters that are not its own).
    pub fn with(self, param: Param, value: f32) -> Principled {
        let mut p = self;
        let v = value.clamp(0.0, 1.0);
        match param {
            Param::Roughness => p.roughness = v,
            Param::Anisotropic => p.anisotropic = v,
            Param::Metallic => p.metallic = v,
            Param::SpecTrans => p.spec_trans = v,
            Param::SpecTint => p.spec_tint = v,
            Param::Sheen => p.sheen = v,
            Param::SheenTint => p.sheen_tint = v,
            Param::Flatness => p.flatness = v,
            Param::Clearcoat => p.clearcoat = v,
            Param::ClearcoatGloss => p.clearcoat_gloss = v,
            Param::Alpha | Param::AlphaU | Param::AlphaV | Param::Weight => {}
        }
        p
    }

    /// The weights of the dielectric BRDF and BSDF lobes: `(brdf, bsdf)`.
    #[inline]
    fn weights(&self) -> (f32, f32) {
        let dielectric = 1.0 - self.metallic;
        (
            dielectric * (1.0 - self.spec_trans),
            dielectric * self.spec_trans,
        )
    }

    /// The base colour's hue: divided by its luminance (white when black), the colour that
    /// `spec_tint` and `sheen_tint` tint towards.
    #[inline]
    fn tint(&self) -> Rgb {
        let lum = luminance(self.base);
        if lum > 0.0 {
            self.base / lum
        } else {
            Rgb::ONE
        }
    }

    /// The main specular distribution.
    fn specular(&self) -> TrowbridgeReitz {
        let alpha = self.roughness * self.roughness;
        let aspect = (1.0 - 0.9 * self.anisotropic).max(0.0).sqrt();
        if self.anisotropic <= 0.0 || aspect <= 0.0 {
            return TrowbridgeReitz::new(alpha.max(1e-3), alpha.max(1e-3));
        }
        TrowbridgeReitz::new((alpha / aspect).max(1e-3), (alpha * aspect).max(1e-3))
    }

    /// The clearcoat's GTR1 α.
    #[inline]
    fn clearcoat_alpha(&self) -> f32 {
        0.1 + (0.001 - 0.1) * self.clearcoat_gloss
    }

    /// A direction of [`crate::bsdf`]'s frame in Mitsuba's (and back).
    #[inline]
    fn mitsuba(&self, w: Vec3) -> Vec3 {
        if self.front {
            w
        } else {
            Vec3::new(w.x, w.y, -w.z)
        }
    }

    /// The half vector of `(wo, wi)` in Mitsuba's frame; `None` when it is undefined.
    fn pair(&self, wo: Vec3, wi: Vec3) -> Option<Pair> {
        if wo.z == 0.0 {
            return None;
        }
        let side = wo.z.signum();
        let reflect = wo.z * wi.z > 0.0;
        let eta_path = match (reflect, side > 0.0) {
            (true, _) => 1.0,
            (false, true) => self.eta,
            (false, false) => 1.0 / self.eta,
        };
        let h = (wo + wi * eta_path).normalize_or_zero();
        if h == Vec3::ZERO || !h.is_finite() {
            return None;
        }
        let h = if h.z < 0.0 { -h } else { h };
        let (oh, ih) = (wo.dot(h) * side, wi.dot(h) * side);
        Some(Pair {
            side,
            reflect,
            h,
            eta_path,
            reflect_ok: oh > 0.0 && ih > 0.0,
            refract_ok: oh > 0.0 && ih < 0.0,
            fresnel: fresnel(wo.dot(h), self.eta),
        })
    }

    /// The probabilities of the diffuse, clearcoat, transmission and reflection lobes for
    /// dielectric reflectance `f` on side `side` (normalised; `None` when all are 0).
    fn lobe_probabilities(&self, side: f32, f: f32) -> Option<[f32; 4]> {
        let (brdf, bsdf) = self.weights();
        let p = if side > 0.0 {
            [
                brdf,
                0.25 * self.clearcoat,
                bsdf * (1.0 - f),
                1.0 - bsdf * (1.0 - f),
            ]
        } else if self.spec_trans > 0.0 {
            [0.0, 0.0, 1.0 - f, f]
        } else {
            [0.0, 0.0, 0.0, f]
        };
        let total: f32 = p.iter().sum();
        (total > 0.0 && total.is_finite()).then(|| p.map(|x| x / total))
    }

    /// The reflectance of the main specular lobe (Mitsuba's `principled_fresnel`).
    fn specular_fresnel(&self, f: f32, cos: f32, side: f32) -> Rgb {
        let (_, bsdf) = self.weights();
        if side < 0.0 {
            return Rgb::splat(bsdf * f);
        }
        let mut schlick_part = self.metallic * schlick(self.base, cos, self.eta);
        if self.spec_tint > 0.0 {
            let tint = self.tint();
            let eta_it = if cos >= 0.0 { self.eta } else { 1.0 / self.eta };
            let r0 = ((eta_it - 1.0) / (eta_it + 1.0)).powi(2);
            schlick_part +=
                (1.0 - self.metallic) * self.spec_tint * schlick(tint * r0, cos, self.eta);
        }
        Rgb::splat((1.0 - self.metallic) * (1.0 - self.spec_tint) * f) + schlick_part
    }

    /// Mitsuba's `f·|cos θi|` for `wo`, `wi` in its frame.
    fn eval_cos(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let Some(p) = self.pair(wo, wi) else {
            return Rgb::ZERO;
        };
        let (_, bsdf) = self.weights();
        let dist = self.specular();
        let d = dist.d(p.h);
        let g = || {
            let g1 = |w: Vec3| {
                if w.dot(p.h) * w.z > 0.0 {
                    dist.g1(w)
                } else {
                    0.0
                }
            };
            g1(wo) * g1(wi)
        };
        let mut value = Rgb::ZERO;
        if p.reflect && p.reflect_ok && p.fresnel > 0.0 {
            let fp = self.specular_fresnel(p.fresnel, wo.dot(p.h), p.side);
            value += fp * (d * g() / (4.0 * wo.z.abs()));
        }
        if bsdf > 0.0 && !p.reflect && p.refract_ok && p.fresnel < 1.0 {
            let (oh, ih) = (wo.dot(p.h), wi.dot(p.h));
            let denom = wo.z * (oh + p.eta_path * ih).powi(2);
            let t = bsdf * ((1.0 - p.fresnel) * d * g() * oh * ih / denom).abs();
            value += self.base.max(Rgb::ZERO).powf(0.5) * t;
        }
        if p.side > 0.0 && p.reflect {
            value += self.outside_lobes(wo, wi, p.h, p.reflect_ok);
        }
        value
    }

    /// The clearcoat, diffuse and sheen lobes' `f·|cos θi|` (outside, reflection).
    fn outside_lobes(&self, wo: Vec3, wi: Vec3, h: Vec3, reflect_ok: bool) -> Rgb {
        let (brdf, _) = self.weights();
        let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
        let mut value = Rgb::ZERO;
        if self.clearcoat > 0.0 && reflect_ok {
            let fresnel = schlick(Rgb::splat(0.04), wo.dot(h), self.eta).x;
            let d = gtr1(self.clearcoat_alpha(), h);
            let g = smith_ggx1(wo, h, 0.25) * smith_ggx1(wi, h, 0.25);
            value += Rgb::splat(self.clearcoat * 0.25 * fresnel * d * g * cos_i);
        }
        let cos_d = h.dot(wi);
        if brdf > 0.0 {
            let (fo, fi) = (schlick_weight(cos_o), schlick_weight(cos_i));
            let diffuse = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
            let rr = 2.0 * self.roughness * cos_d * cos_d;
            let retro = rr * (fo + fi + fo * fi * (rr - 1.0));
            let subsurface = {
                let fss = (1.0 + (0.5 * rr - 1.0) * fo) * (1.0 + (0.5 * rr - 1.0) * fi);
                1.25 * (fss * (1.0 / (cos_o + cos_i) - 0.5) + 0.5)
            };
            let lobe = diffuse + retro + self.flatness * (subsurface - diffuse - retro);
            value += self.base * (brdf * cos_i * FRAC_1_PI * lobe);
        }
        if self.sheen > 0.0 && self.metallic < 1.0 {
            let colour = Rgb::ONE + self.sheen_tint * (self.tint() - Rgb::ONE);
            value +=
                colour * (self.sheen * (1.0 - self.metallic) * schlick_weight(cos_d.abs()) * cos_i);
        }
        value
    }

    /// Mitsuba's density of `wi` for `wo`, in its frame.
    fn pdf_mitsuba(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(p) = self.pair(wo, wi) else {
            return 0.0;
        };
        let Some([diffuse, clearcoat, transmit, reflect]) =
            self.lobe_probabilities(p.side, p.fresnel)
        else {
            return 0.0;
        };
        let (oh, ih) = (wo.dot(p.h), wi.dot(p.h));
        let dh_dwi = if p.reflect {
            1.0 / (4.0 * ih)
        } else {
            p.eta_path * p.eta_path * ih / (oh + p.eta_path * ih).powi(2)
        }
        .abs();
        let visible = || self.specular().visible_pdf(wo * p.side, p.h);
        let mut pdf = 0.0;
        if p.reflect {
            pdf += diffuse * wi.z.max(0.0) * FRAC_1_PI;
            if p.reflect_ok {
                pdf += reflect * visible() * dh_dwi;
                if clearcoat > 0.0 {
                    pdf += clearcoat * gtr1(self.clearcoat_alpha(), p.h) * p.h.z * dh_dwi;
                }
            }
        } else if p.refract_ok && transmit > 0.0 {
            pdf += transmit * visible() * dh_dwi;
        }
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// `f(wo, wi)` without the cosine.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wi.z == 0.0 {
            return Rgb::ZERO;
        }
        let f = self.eval_cos(self.mitsuba(wo), self.mitsuba(wi)) / wi.z.abs();
        if f.is_finite() {
            f
        } else {
            Rgb::ZERO
        }
    }

    /// The density with which [`Principled::sample`] picks `wi`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.pdf_mitsuba(self.mitsuba(wo), self.mitsuba(wi))
    }

    /// A lobe chosen with `u1`, then a direction from it with `u`.
    pub fn sample(&self, wo: Vec3, u: Vec2, u1: f32) -> Option<BsdfSample> {
        let w = self.mitsuba(wo);
        let side = w.z.signum();
        if side < 0.0 && !self.transmits() {
            return None;
        }
        let m = self.specular().sample_visible(w * side, u);
        let [diffuse, clearcoat, transmit, _] =
            self.lobe_probabilities(side, fresnel(w.dot(m), self.eta))?;
        // Each lobe's direction must lie where its density is counted: on its side, with
        // the microfacet facing both directions.
        let faces = |wi: Vec3, m: Vec3, reflect: bool| {
            let same_side = w.z * wi.z > 0.0;
            w.dot(m) * side > 0.0 && (wi.dot(m) * side > 0.0) == reflect && same_side == reflect
        };
        let wi = if u1 < diffuse {
            cosine_hemisphere(u)
        } else if u1 < diffuse + clearcoat {
            let m = sample_gtr1(self.clearcoat_alpha(), u);
            Some(reflect_about(w, m)).filter(|&wi| faces(wi, m, true))?
        } else if u1 < diffuse + clearcoat + transmit {
            let wi = refract(w, m, self.eta)?.0.normalize_or_zero();
            Some(wi).filter(|&wi| faces(wi, m, false))?
        } else {
            Some(reflect_about(w, m)).filter(|&wi| faces(wi, m, true))?
        };
        let wi = self.mitsuba(wi);
        BsdfSample::glossy(wi, self.eval(wo, wi), self.pdf(wo, wi))
    }

    /// The surface's colour for albedo images.
    pub fn albedo(&self) -> Rgb {
        self.base.clamp(Rgb::ZERO, Rgb::ONE)
    }

    /// True when a transmission lobe is present.
    #[inline]
    pub fn transmits(&self) -> bool {
        self.spec_trans > 0.0 && self.metallic < 1.0
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere_equatorial, Chi2Config};
    use crate::sampling::Rng;

    /// Materials exercising every lobe.
    pub(crate) fn cases() -> Vec<Principled> {
        let base = Rgb::new(0.8, 0.4, 0.2);
        let p = Principled {
            base,
            ..Default::default()
        };
        vec![
            p,
            Principled {
                roughness: 0.3,
                metallic: 0.6,
                spec_tint: 0.5,
                anisotropic: 0.7,
                ..p
            },
            Principled {
                roughness: 0.8,
                sheen: 1.0,
                sheen_tint: 0.5,
                flatness: 0.7,
                clearcoat: 1.0,
                clearcoat_gloss: 0.6,
                ..p
            },
            Principled {
                roughness: 0.4,
                spec_trans: 0.7,
                eta: 1.4,
                clearcoat: 0.5,
                ..p
            },
            Principled {
                roughness: 0.25,
                spec_trans: 1.0,
                anisotropic: 0.4,
                front: false,
                ..p
            },
        ]
    }

    /// Chi-square of the sampler against [`Principled::pdf`] at several incidences, from
    /// outside and (when transmitting) inside; 1% over all tests (Šidák).
    #[test]
    fn chi2_of_principled() {
        let mut all = Vec::new();
        for p in cases() {
            for theta in [5.0f32, 45.0, 80.0] {
                all.push((p, theta));
            }
        }
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / all.len() as f64);
        for (p, theta) in all {
            let t = theta.to_radians();
            let wo = Vec3::new(t.sin() * 0.8, t.sin() * 0.6, t.cos());
            let mut rng = Rng::new(5, 11);
            let cfg = Chi2Config::fine(significance, 11);
            chi2_test_sphere_equatorial(
                &cfg,
                |u| p.sample(wo, u, rng.next_f32()).map(|s| s.wi),
                |wi| p.pdf(wo, wi),
            )
            .unwrap_or_else(|e| panic!("{p:?}, θ {theta}: {e}"));
        }
    }

    /// Mitsuba 3.9.1's own values and densities (llvm_ad_rgb) at 336 direction pairs of
    /// seven parameter sets, written by `tests/mitsuba/principled_values.py`: equal within
    /// float precision.
    #[test]
    fn values_and_densities_are_mitsubas() {
        let table = include_str!("../../tests/mitsuba/principled_values.csv");
        let mut compared = 0;
        for line in table.lines().skip(1) {
            let v: Vec<f32> = line.split(',').map(|x| x.parse().unwrap()).collect();
            let [r, g, b, roughness, anisotropic, metallic, spec_trans, spec_tint, sheen, sheen_tint, flatness, clearcoat, clearcoat_gloss, eta, vx, vy, vz, lx, ly, lz, fr, fg, fb, pdf] =
                v[..]
            else {
                panic!("row {line}");
            };
            let p = Principled {
                base: Rgb::new(r, g, b),
                roughness,
                anisotropic,
                metallic,
                spec_trans,
                spec_tint,
                sheen,
                sheen_tint,
                flatness,
                clearcoat,
                clearcoat_gloss,
                eta,
                front: vz > 0.0,
            };
            // Mitsuba's frame to ours: +Z towards the viewer.
            let side = vz.signum();
            let (wo, wi) = (Vec3::new(vx, vy, side * vz), Vec3::new(lx, ly, side * lz));
            let (f, theirs) = (p.eval(wo, wi) * wi.z.abs(), Rgb::new(fr, fg, fb));
            let close = |a: f32, b: f32| (a - b).abs() <= 2e-3 * a.abs().max(b.abs()) + 1e-6;
            assert!(
                (0..3).all(|c| close(f[c], theirs[c])),
                "{p:?} wo {wo} wi {wi}: f·cos {f} vs Mitsuba's {theirs}"
            );
            assert!(
                close(p.pdf(wo, wi), pdf),
                "{p:?} wo {wo} wi {wi}: pdf {} vs Mitsuba's {pdf}",
                p.pdf(wo, wi)
            );
            compared += (theirs.max_element() > 0.0) as u32;
        }
        assert!(compared > 150, "{compared} non-zero values");
    }
}
