//! Rough conductor: Beckmann microfacet distribution, Smith shadowing-masking and the
//! conductor Fresnel term, in the local frame of [`crate::bsdf`] (reflection only, `wo.z > 0`).
//!
//! - `D(h) = exp(−tan²θh / α²) / (π α² cos⁴θh)`.
//! - `Λ(ω) = (erf(a) − 1)/2 + exp(−a²) / (2a√π)` with `a = 1 / (α tan θ)`
//!   (CS184's version has π where √π belongs; this is the correct one).
//! - `G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))`.
//! - `F` is the exact unpolarised conductor reflectance for the complex index `eta + i·k`
//!   (per RGB channel), evaluated at `cos = wi·h`, which keeps the BSDF reciprocal.
//! - `f = F · G · D / (4 · wo.z · wi.z)`.
//! - Sampling draws `h` from `D(h)·cos θh` (tan²θh = −α² ln(1 − u₁), φ = 2π u₂) and reflects
//!   `wo` about it: `pdf(wi) = D(h)·cos θh / (4 |wo·h|)`.

use crate::bsdf::BsdfSample;
use crate::math::Rgb;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Parameters of the rough conductor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// Beckmann roughness α (> 0).
    pub alpha: f32,
    /// Real part of the index of refraction, per channel.
    pub eta: Rgb,
    /// Absorption coefficient (imaginary part), per channel.
    pub k: Rgb,
}

/// The error function (Abramowitz & Stegun 7.1.26; absolute error below 1.5·10⁻⁷).
pub fn erf(x: f32) -> f32 {
    let sign = x.signum();
    let x = x.abs() as f64;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    sign * y as f32
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
            eta,
            k,
        }
    }

    /// Beckmann normal distribution `D(h)` for a unit half vector `h`.
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let c2 = h.z * h.z;
        let tan2 = (1.0 - c2).max(0.0) / c2;
        let a2 = self.alpha * self.alpha;
        (-tan2 / a2).exp() / (PI * a2 * c2 * c2)
    }

    /// Smith's `Λ(ω)` for the Beckmann distribution.
    pub fn lambda(&self, w: Vec3) -> f32 {
        let c = w.z.abs().min(1.0);
        let s = (1.0 - c * c).max(0.0).sqrt();
        if s == 0.0 {
            return 0.0;
        }
        if c == 0.0 {
            return f32::INFINITY;
        }
        let a = c / (self.alpha * s);
        (erf(a) - 1.0) * 0.5 + (-a * a).exp() / (2.0 * a * PI.sqrt())
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
        f * (self.g(wo, wi) * self.d(h) / (4.0 * wo.z * wi.z))
    }

    /// Solid-angle pdf of [`Microfacet::sample`] choosing `wi`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize_or_zero();
        let woh = wo.dot(h);
        if h == Vec3::ZERO || woh <= 0.0 {
            return 0.0;
        }
        self.d(h) * h.z / (4.0 * woh)
    }

    /// Samples a half vector from `D(h)·cos θh` and reflects `wo` about it.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let tan2 = -self.alpha * self.alpha * (1.0 - u.x).max(1e-12).ln();
        let cos_t = 1.0 / (1.0 + tan2).sqrt();
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let h = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
        let woh = wo.dot(h);
        if woh <= 0.0 {
            return None;
        }
        let wi = (2.0 * woh * h - wo).normalize();
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        let f = self.eval(wo, wi);
        Some(BsdfSample {
            wi,
            f,
            pdf,
            weight: f * wi.z / pdf,
            delta: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere, Chi2Config};

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
    fn distribution_is_normalised() {
        // ∫ D(h) cos θh dω = 1, numerically over the hemisphere.
        for alpha in [0.05f32, 0.2, 0.5] {
            let m = Microfacet::new(alpha, Vec3::ONE, Vec3::ONE);
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

    /// Chi-square test of the sampler at roughness `alpha` for incidence from normal to
    /// grazing. Significance: 1% over all 20 tests of the four α, Šidák-corrected.
    fn chi2_at(alpha: f32) {
        let thetas = [0.0f32, 30.0, 60.0, 80.0, 89.0];
        let significance = 1.0 - (1.0f64 - 0.01).powf(1.0 / 20.0);
        for theta in thetas {
            let m = Microfacet::new(alpha, Vec3::splat(0.2), Vec3::splat(3.0));
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
            assert!(r.is_ok(), "alpha {alpha}, θo {theta}°: {:?}", r.err());
        }
    }

    #[test]
    fn chi2_alpha_005() {
        chi2_at(0.05);
    }

    #[test]
    fn chi2_alpha_01() {
        chi2_at(0.1);
    }

    #[test]
    fn chi2_alpha_025() {
        chi2_at(0.25);
    }

    #[test]
    fn chi2_alpha_05() {
        chi2_at(0.5);
    }
}
