//! Rough conductor: a microfacet distribution (Beckmann, CS184's; or Trowbridge-Reitz, "GGX"),
//! Smith shadowing-masking and the conductor Fresnel term, in the local frame of
//! [`crate::bsdf`] (reflection only, `wo.z > 0`).
//!
//! - Beckmann: `D(h) = exp(−tan²θh / α²) / (π α² cos⁴θh)`,
//!   `Λ(ω) = (erf(a) − 1)/2 + exp(−a²) / (2a√π)` with `a = 1 / (α tan θ)`
//!   (CS184's version has π where √π belongs; this is the correct one).
//! - GGX: `D(h) = 1 / (π α² cos⁴θh (1 + tan²θh / α²)²)`,
//!   `Λ(ω) = (√(1 + α² tan²θ) − 1) / 2`.
//! - `G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))`.
//! - `F` is the exact unpolarised conductor reflectance for the complex index `eta + i·k`
//!   (per RGB channel), evaluated at `cos = wi·h`, which keeps the BSDF reciprocal.
//! - `f = F · G · D / (4 · wo.z · wi.z)`.
//! - Sampling draws `h` from the distribution of normals visible from `wo`,
//!   `D_wo(h) = G1(wo)·max(0, wo·h)·D(h) / wo.z` (Heitz & d'Eon 2014), by Jakob's (2014)
//!   improved numerical inversion of the slope distribution of the stretched configuration, and
//!   reflects `wo` about it: `pdf(wi) = G1(wo)·D(h) / (4·wo.z)` with `G1 = 1 / (1 + Λ)`, and the
//!   sample weight is `F·G / G1(wo)`, at most 1 per channel. Normals whose reflection falls below
//!   the horizon are lost (the sample is `None`). GGX's visible normals are sampled exactly by
//!   Heitz's (2018) construction: a uniform point on the disk seen from the stretched `wo`,
//!   warped onto the projected hemisphere and unstretched.

use crate::bsdf::BsdfSample;
use crate::math::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Inverse error function (Giles 2010, single-precision polynomial fits; relative error about
/// 10⁻⁷ away from ±1).
pub fn erf_inv(x: f32) -> f32 {
    let x = x.clamp(-1.0 + 1e-7, 1.0 - 1e-7);
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        let w = w - 2.5;
        [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            2.185_808_7e-4,
            -1.253_725e-3,
            -4.177_681_6e-3,
            2.466_407_3e-1,
            1.501_409_4,
        ]
        .iter()
        .fold(2.810_226_4e-8f32, |p, &c| c + p * w)
    } else {
        let w = w.sqrt() - 3.0;
        [
            1.009_505_6e-4,
            1.349_343_2e-3,
            -3.673_428_4e-3,
            5.739_507_7e-3,
            -7.622_461_3e-3,
            9.438_870_5e-3,
            1.001_674,
            2.832_976_8,
        ]
        .iter()
        .fold(-2.002_142_6e-4f32, |p, &c| c + p * w)
    };
    p * x
}

/// Slopes `(x̃, ỹ)` of a normal visible from a direction at `cos θ` (in the xz-plane) on the
/// Beckmann surface of roughness 1, from uniform `u`: `ỹ` is normal-distributed; `x̃` inverts
/// the CDF `(1 + erf x̃ + tan θ·e^(−x̃²)/√π) / (1 + erf(cot θ) + tan θ·e^(−cot²θ)/√π)`, solved
/// for `b = erf x̃` by Newton steps kept inside a bisection bracket, from a fitted first guess
/// (Jakob 2014), which keeps the map continuous in `u`.
fn visible_slopes(cos_t: f32, u: Vec2) -> (f32, f32) {
    if cos_t > 0.9999 {
        let r = (-(1.0 - u.x).max(1e-12).ln()).sqrt();
        let (s, c) = (2.0 * PI * u.y).sin_cos();
        return (r * c, r * s);
    }
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let tan_t = sin_t / cos_t;
    let cot_t = cos_t / sin_t;
    let inv_sqrt_pi = 1.0 / PI.sqrt();
    let (mut lo, mut hi) = (-1.0f32, erf(cot_t));
    let target = u.x.max(1e-6);
    let theta = cos_t.acos();
    let fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    let mut b = hi - (1.0 + hi) * (1.0 - target).powf(fit);
    let norm = 1.0 / (1.0 + hi + inv_sqrt_pi * tan_t * (-cot_t * cot_t).exp());
    for _ in 0..10 {
        if !(lo..=hi).contains(&b) {
            b = 0.5 * (lo + hi);
        }
        let x = erf_inv(b);
        let value = norm * (1.0 + b + inv_sqrt_pi * tan_t * (-x * x).exp()) - target;
        if value.abs() < 1e-5 {
            break;
        }
        if value > 0.0 {
            hi = b;
        } else {
            lo = b;
        }
        let derivative = norm * (1.0 - x * tan_t);
        b -= value / derivative;
    }
    (erf_inv(b), erf_inv(2.0 * u.y.max(1e-6) - 1.0))
}

/// An unnormalised Beckmann normal of roughness `(alpha_x, alpha_y)` visible from the
/// stretched direction `ws = normalize(αx·w.x, αy·w.y, w.z)` (`ws.z > 0`), from uniform `u`:
/// slopes sampled at roughness 1 with `ws` rotated into the xz-plane, rotated back and
/// unstretched.
pub(crate) fn beckmann_visible_normal(alpha_x: f32, alpha_y: f32, ws: Vec3, u: Vec2) -> Vec3 {
    let r = (ws.x * ws.x + ws.y * ws.y).sqrt();
    let (cos_p, sin_p) = if r > 0.0 {
        (ws.x / r, ws.y / r)
    } else {
        (1.0, 0.0)
    };
    let (sx, sy) = visible_slopes(ws.z, u);
    let (sx, sy) = (cos_p * sx - sin_p * sy, sin_p * sx + cos_p * sy);
    Vec3::new(-alpha_x * sx, -alpha_y * sy, 1.0)
}

/// Which microfacet normal distribution a [`Microfacet`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Distribution {
    /// Beckmann (CS184's microfacet material).
    #[default]
    Beckmann,
    /// Trowbridge-Reitz, "GGX" (glTF's and most exporters').
    Ggx,
}

/// Parameters of the rough conductor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// Roughness α (> 0); along the tangent (u) when [`Microfacet::alpha_v`] differs.
    pub alpha: f32,
    /// Roughness along the bitangent (v): equal to `alpha` for an isotropic surface.
    pub alpha_v: f32,
    /// Real part of the index of refraction, per channel.
    pub eta: Rgb,
    /// Absorption coefficient (imaginary part), per channel.
    pub k: Rgb,
    /// The normal distribution.
    pub dist: Distribution,
    /// A factor on the reflection (Mitsuba's `specular_reflectance`; 1 for CS184's).
    pub tint: Rgb,
}

/// The error function (Abramowitz & Stegun 7.1.26; absolute error below 1.5·10⁻⁷).
pub fn erf(x: f32) -> f32 {
    erf64(x as f64) as f32
}

/// [`erf`] in double precision (the same approximation).
pub fn erf64(x: f64) -> f64 {
    let sign = x.signum();
    let x = x.abs();
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    sign * y
}

/// Exact unpolarised Fresnel reflectance of a conductor with index `eta + i·k` at `cos θ`.
pub fn fresnel_conductor(cos: f32, eta: Rgb, k: Rgb) -> Rgb {
    let c = cos.clamp(0.0, 1.0);
    let (c2, s2) = (c * c, 1.0 - c * c);
    let one = |eta: f32, k: f32| {
        let t0 = eta * eta - k * k - s2;
        let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).max(0.0).sqrt();
        let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
        let rs_num = a2b2 + c2 - 2.0 * a * c;
        let rs_den = a2b2 + c2 + 2.0 * a * c;
        let rs = if rs_den > 0.0 { rs_num / rs_den } else { 1.0 };
        let rp_num = a2b2 * c2 + s2 * s2 - 2.0 * a * c * s2;
        let rp_den = a2b2 * c2 + s2 * s2 + 2.0 * a * c * s2;
        let rp = if rp_den > 0.0 {
            rs * rp_num / rp_den
        } else {
            rs
        };
        (0.5 * (rs + rp)).clamp(0.0, 1.0)
    };
    Vec3::new(one(eta.x, k.x), one(eta.y, k.y), one(eta.z, k.z))
}

impl Microfacet {
    /// A conductor with roughness `alpha` (clamped to at least 10⁻⁴) and index `eta + i·k`.
    pub fn new(alpha: f32, eta: Rgb, k: Rgb) -> Self {
        Microfacet {
            alpha: alpha.max(1e-4),
            alpha_v: alpha.max(1e-4),
            eta,
            k,
            dist: Distribution::Beckmann,
            tint: Vec3::ONE,
        }
    }

    /// The same conductor with the GGX distribution.
    pub fn ggx(alpha: f32, eta: Rgb, k: Rgb) -> Self {
        Microfacet {
            dist: Distribution::Ggx,
            ..Microfacet::new(alpha, eta, k)
        }
    }

    /// The normal distribution `D(h)` for a unit half vector `h`.
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let c2 = h.z * h.z;
        if self.alpha != self.alpha_v {
            return self.d_anisotropic(h);
        }
        let tan2 = (1.0 - c2).max(0.0) / c2;
        let a2 = self.alpha * self.alpha;
        match self.dist {
            Distribution::Beckmann => (-tan2 / a2).exp() / (PI * a2 * c2 * c2),
            Distribution::Ggx => {
                let e = 1.0 + tan2 / a2;
                1.0 / (PI * a2 * c2 * c2 * e * e)
            }
        }
    }

    /// [`Microfacet::d`] of an anisotropic surface: `tan²θ/α²` becomes
    /// `(h.x²/α_u² + h.y²/α_v²) / cos²θ`, `α²` in the normalisation `α_u α_v`.
    fn d_anisotropic(&self, h: Vec3) -> f32 {
        let c2 = h.z * h.z;
        let e = ((h.x / self.alpha).powi(2) + (h.y / self.alpha_v).powi(2)) / c2;
        let a2 = self.alpha * self.alpha_v;
        match self.dist {
            Distribution::Beckmann => (-e).exp() / (PI * a2 * c2 * c2),
            Distribution::Ggx => 1.0 / (PI * a2 * c2 * c2 * (1.0 + e) * (1.0 + e)),
        }
    }

    /// The roughness seen along `w`: `α`, or `√(cos²φ α_u² + sin²φ α_v²)` when anisotropic.
    #[inline]
    fn alpha_along(&self, w: Vec3) -> f32 {
        if self.alpha == self.alpha_v {
            return self.alpha;
        }
        let r2 = w.x * w.x + w.y * w.y;
        if r2 <= 0.0 {
            return self.alpha;
        }
        ((w.x * w.x * self.alpha * self.alpha + w.y * w.y * self.alpha_v * self.alpha_v) / r2)
            .sqrt()
    }

    /// Smith's `Λ(ω)` of the distribution.
    pub fn lambda(&self, w: Vec3) -> f32 {
        let c = w.z.abs().min(1.0);
        let s = (1.0 - c * c).max(0.0).sqrt();
        if s == 0.0 {
            return 0.0;
        }
        if c == 0.0 {
            return f32::INFINITY;
        }
        let alpha = self.alpha_along(w);
        match self.dist {
            Distribution::Beckmann => {
                let a = c / (alpha * s);
                (erf(a) - 1.0) * 0.5 + (-a * a).exp() / (2.0 * a * PI.sqrt())
            }
            Distribution::Ggx => {
                let at = alpha * s / c;
                ((1.0 + at * at).sqrt() - 1.0) * 0.5
            }
        }
    }

    /// A normal visible from `wo` (`wo.z > 0`), drawn from `D_wo` with uniform `u`.
    pub(crate) fn visible_normal(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let (a, b) = (self.alpha, self.alpha_v);
        let ws = Vec3::new(a * wo.x, b * wo.y, wo.z).normalize_or_zero();
        if ws.z <= 0.0 {
            return None;
        }
        let h = match self.dist {
            Distribution::Beckmann => beckmann_visible_normal(a, b, ws, u),
            Distribution::Ggx => {
                // Heitz 2018: a uniform point of the disk orthogonal to the stretched view,
                // its far half squeezed onto the visible part of the projected hemisphere.
                let len2 = ws.x * ws.x + ws.y * ws.y;
                let t1 = if len2 > 0.0 {
                    Vec3::new(-ws.y, ws.x, 0.0) / len2.sqrt()
                } else {
                    Vec3::X
                };
                let t2 = ws.cross(t1);
                let r = u.x.sqrt();
                let (sin, cos) = (2.0 * PI * u.y).sin_cos();
                let (p1, p2) = (r * cos, r * sin);
                let s = 0.5 * (1.0 + ws.z);
                let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
                let n = t1 * p1 + t2 * p2 + ws * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                Vec3::new(a * n.x, b * n.y, n.z.max(1e-7))
            }
        };
        let h = h.normalize_or_zero();
        (h.is_finite() && h != Vec3::ZERO).then_some(h)
    }

    /// Smith shadowing-masking `G = 1 / (1 + Λ(wo) + Λ(wi))`.
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// `f(wo, wi)` without the cosine.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let f = fresnel_conductor(wi.dot(h), self.eta, self.k);
        f * self.tint * (self.g(wo, wi) * self.d(h) / (4.0 * wo.z * wi.z))
    }

    /// Solid-angle pdf of [`Microfacet::sample`] choosing `wi`: `G1(wo)·D(h) / (4·wo.z)`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize_or_zero();
        let woh = wo.dot(h);
        if h == Vec3::ZERO || woh <= 0.0 {
            return 0.0;
        }
        self.d(h) / ((1.0 + self.lambda(wo)) * 4.0 * wo.z)
    }

    /// Samples a normal visible from `wo` and reflects `wo` about it.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let h = self.visible_normal(wo, u)?;
        let woh = wo.dot(h);
        if woh <= 0.0 {
            return None;
        }
        let wi = (2.0 * woh * h - wo).normalize();
        if wi.z <= 0.0 {
            return None;
        }
        let (f, pdf) = self.eval_pdf(wo, wi);
        BsdfSample::glossy(wi, f, pdf)
    }

    /// [`Microfacet::eval`] and [`Microfacet::pdf`] at once, bit for bit, with `D(h)` and
    /// `Λ(wo)` computed once.
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return (Vec3::ZERO, 0.0);
        }
        let d = self.d(h);
        let lambda_o = self.lambda(wo);
        let g = 1.0 / (1.0 + lambda_o + self.lambda(wi));
        let f = fresnel_conductor(wi.dot(h), self.eta, self.k);
        let value = f * self.tint * (g * d / (4.0 * wo.z * wi.z));
        let pdf = if wo.dot(h) <= 0.0 {
            0.0
        } else {
            d / ((1.0 + lambda_o) * 4.0 * wo.z)
        };
        (value, pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere, Chi2Config};

    #[test]
    fn eval_pdf_is_eval_and_pdf_bit_for_bit() {
        let mut rng = crate::sampling::Rng::new(9, 10);
        for (alpha, alpha_v) in [(0.05, 0.05), (0.3, 0.3), (0.2, 0.6)] {
            let m = Microfacet {
                alpha_v,
                ..Microfacet::new(alpha, Vec3::new(0.2, 0.9, 1.1), Vec3::new(3.9, 2.4, 2.1))
            };
            for _ in 0..2000 {
                let wo = crate::sampling::uniform_sphere(rng.next_2d());
                let wi = crate::sampling::uniform_sphere(rng.next_2d());
                let (f, pdf) = m.eval_pdf(wo, wi);
                assert_eq!(
                    f.to_array().map(f32::to_bits),
                    m.eval(wo, wi).to_array().map(f32::to_bits)
                );
                assert_eq!(pdf.to_bits(), m.pdf(wo, wi).to_bits());
            }
        }
    }

    #[test]
    fn erf_matches_known_values() {
        for (x, v) in [
            (0.0f32, 0.0f32),
            (0.5, 0.520_499_9),
            (1.0, 0.842_700_8),
            (2.0, 0.995_322_3),
            (-1.0, -0.842_700_8),
        ] {
            assert!((erf(x) - v).abs() < 2e-7, "erf({x})");
        }
    }

    #[test]
    fn erf_inv_inverts_erf() {
        for i in 1..400 {
            let x = -2.5 + i as f32 * 0.0125;
            let y = erf(x);
            assert!((erf_inv(y) - x).abs() < 2e-4 * (1.0 + x.abs()), "x {x}");
        }
    }

    #[test]
    fn visible_normal_weights_are_bounded() {
        // The VNDF estimator's weight is F·G/G1(wo) ≤ 1 (here F = 1): no fireflies from
        // sampling, at every roughness and incidence.
        let mut rng = crate::sampling::Rng::new(4, 1);
        for (alpha, ggx) in [0.05f32, 0.2, 0.5]
            .into_iter()
            .flat_map(|a| [(a, false), (a, true)])
        {
            let m = if ggx {
                Microfacet::ggx(alpha, Vec3::ZERO, Vec3::ZERO)
            } else {
                Microfacet::new(alpha, Vec3::ZERO, Vec3::ZERO)
            };
            for theta in [0.0f32, 45.0, 80.0, 89.0] {
                let t = theta.to_radians();
                let wo = Vec3::new(t.sin(), 0.0, t.cos());
                for _ in 0..2000 {
                    if let Some(s) = m.sample(wo, rng.next_2d()) {
                        assert!(
                            s.weight.max_element() <= 1.0 + 1e-3,
                            "α {alpha} θ {theta}: {}",
                            s.weight
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn distribution_is_normalised() {
        // ∫ D(h) cos θh dω = 1, numerically over the hemisphere.
        for m in [0.05f32, 0.2, 0.5].into_iter().flat_map(|a| {
            [
                Microfacet::new(a, Vec3::ONE, Vec3::ONE),
                Microfacet::ggx(a, Vec3::ONE, Vec3::ONE),
            ]
        }) {
            let alpha = m.alpha;
            // Midpoint rule in θ, fine enough for the sharpest lobe.
            let n = 200_000;
            let dt = std::f64::consts::FRAC_PI_2 / n as f64;
            let mut sum = 0.0f64;
            for i in 0..n {
                let t = (i as f64 + 0.5) * dt;
                let h = Vec3::new(t.sin() as f32, 0.0, t.cos() as f32);
                sum += m.d(h) as f64 * t.cos() * t.sin() * 2.0 * std::f64::consts::PI * dt;
            }
            assert!((sum - 1.0).abs() < 2e-3, "alpha {alpha}: {sum}");
        }
    }

    #[test]
    fn fresnel_limits() {
        // Normal incidence: ((η−1)² + k²) / ((η+1)² + k²); η = k = 0 reflects everything.
        let (eta, k) = (Vec3::new(0.2, 1.0, 1.5), Vec3::new(3.0, 2.0, 0.0));
        let f = fresnel_conductor(1.0, eta, k);
        for c in 0..3 {
            let e = ((eta[c] - 1.0).powi(2) + k[c] * k[c]) / ((eta[c] + 1.0).powi(2) + k[c] * k[c]);
            assert!((f[c] - e).abs() < 1e-5);
        }
        for cos in [0.0, 0.3, 1.0] {
            assert_eq!(fresnel_conductor(cos, Vec3::ZERO, Vec3::ZERO), Vec3::ONE);
        }
        assert!(
            (fresnel_conductor(0.0, eta, k) - Vec3::ONE)
                .abs()
                .max_element()
                < 1e-5,
            "grazing reflects everything"
        );
    }

    /// Chi-square test of the sampler of distribution `dist` at roughness `alpha` for incidence
    /// from normal to grazing. Significance: 1% over all 40 tests of the four α and two
    /// distributions, Šidák-corrected.
    fn chi2_at(alpha: f32, dist: Distribution) {
        let thetas = [0.0f32, 30.0, 60.0, 80.0, 89.0];
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / 40.0);
        for theta in thetas {
            let m = Microfacet {
                dist,
                ..Microfacet::new(alpha, Vec3::splat(0.2), Vec3::splat(3.0))
            };
            let t = theta.to_radians();
            let wo = Vec3::new(t.sin(), 0.0, t.cos());
            // Cells and the pdf-integration sub-grid follow the lobe: its width is about 2α in
            // the plane of incidence and 2α·cos θo out of it, and the pdf is cut off at the horizon.
            // Sharp lobes (α < 0.2) are rotated so that the mirror direction lies on the equator,
            // where the cells are finest; the horizon cut then crosses cells, so grazing cases
            // need a fine sub-grid. Broad lobes stay unrotated, where the horizon is the cell
            // boundary z = 0 and needs no resolving.
            let sharp = alpha < 0.2;
            let (tb, pb, res) = match (sharp, theta > 85.0) {
                (true, false) => (80, 160, 16),
                (true, true) => (40, 80, 200),
                (false, _) => (40, 80, 16),
            };
            let cfg = Chi2Config {
                samples: 1_000_000,
                theta_bins: tb,
                phi_bins: pb,
                resolution: res,
                significance,
                seed: 9,
            };
            let rot = sharp.then(|| crate::math::Frame::from_normal(crate::bsdf::reflect(wo)));
            let to = |v: Vec3| rot.map_or(v, |f| Vec3::new(v.dot(f.n), v.dot(f.s), v.dot(f.t)));
            let back = |w: Vec3| rot.map_or(w, |f| f.n * w.x + f.s * w.y + f.t * w.z);
            let r = chi2_test_sphere(
                &cfg,
                |u| m.sample(wo, u).map(|s| to(s.wi)),
                |w| m.pdf(wo, back(w)),
            );
            assert!(
                r.is_ok(),
                "{dist:?} alpha {alpha}, θo {theta}°: {:?}",
                r.err()
            );
        }
    }

    #[test]
    fn chi2_alpha_005() {
        chi2_at(0.05, Distribution::Beckmann);
    }

    #[test]
    fn chi2_ggx_alpha_005() {
        chi2_at(0.05, Distribution::Ggx);
    }

    #[test]
    fn chi2_alpha_01() {
        chi2_at(0.1, Distribution::Beckmann);
    }

    #[test]
    fn chi2_ggx_alpha_01() {
        chi2_at(0.1, Distribution::Ggx);
    }

    #[test]
    fn chi2_alpha_025() {
        chi2_at(0.25, Distribution::Beckmann);
    }

    #[test]
    fn chi2_ggx_alpha_025() {
        chi2_at(0.25, Distribution::Ggx);
    }

    #[test]
    fn chi2_alpha_05() {
        chi2_at(0.5, Distribution::Beckmann);
    }

    #[test]
    fn chi2_ggx_alpha_05() {
        chi2_at(0.5, Distribution::Ggx);
    }

    /// Chi-square of the anisotropic samplers (Mitsuba's `roughconductor` with `alpha_u` and
    /// `alpha_v`) against their pdf, for both distributions; 1% over all cases.
    #[test]
    fn chi2_anisotropic() {
        use crate::sampling::chi2::chi2_test_sphere_equatorial;
        let cases: Vec<(Distribution, f32, f32, f32)> = [Distribution::Beckmann, Distribution::Ggx]
            .iter()
            .flat_map(|&d| {
                [(0.3f32, 0.1f32), (0.05, 0.4)]
                    .iter()
                    .flat_map(move |&(au, av)| [0.0f32, 50.0, 80.0].map(move |t| (d, au, av, t)))
                    .collect::<Vec<_>>()
            })
            .collect();
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / cases.len() as f64);
        for (dist, au, av, theta) in cases {
            let m = Microfacet {
                dist,
                alpha_v: av,
                ..Microfacet::new(au, Vec3::splat(0.2), Vec3::splat(3.0))
            };
            let t = theta.to_radians();
            let wo = Vec3::new(t.sin() * 0.6, t.sin() * 0.8, t.cos());
            let cfg = Chi2Config::fine(significance, 23);
            chi2_test_sphere_equatorial(
                &cfg,
                |u| m.sample(wo, u).map(|s| s.wi),
                |wi| m.pdf(wo, wi),
            )
            .unwrap_or_else(|e| panic!("{dist:?} α ({au}, {av}), θ {theta}: {e}"));
        }
    }

    /// The anisotropic distribution is normalised: `∫ D(h) cos θh dh = 1`.
    #[test]
    fn anisotropic_distribution_is_normalised() {
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            let m = Microfacet {
                dist,
                alpha_v: 0.45,
                ..Microfacet::new(0.15, Vec3::ZERO, Vec3::ZERO)
            };
            let n = 1000;
            let mut sum = 0.0f64;
            for i in 0..n {
                for j in 0..n {
                    let ct = (i as f64 + 0.5) / n as f64;
                    let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n as f64;
                    let st = (1.0 - ct * ct).sqrt();
                    let h = Vec3::new((st * phi.cos()) as f32, (st * phi.sin()) as f32, ct as f32);
                    sum += m.d(h) as f64 * ct;
                }
            }
            let integral = sum * 2.0 * std::f64::consts::PI / (n * n) as f64;
            assert!((integral - 1.0).abs() < 0.01, "{dist:?}: {integral}");
        }
    }
}
