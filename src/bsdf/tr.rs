//! The anisotropic Trowbridge-Reitz ("GGX") microfacet distribution of pbrt-v4's conductor,
//! dielectric and layered materials, in the local frame of [`crate::bsdf`] (+Z the normal).
//!
//! - `D(m) = 1 / (π αx αy cos⁴θm (1 + tan²θm (cos²φm/αx² + sin²φm/αy²))²)`.
//! - `Λ(w) = (√(1 + α(φ)² tan²θ) − 1) / 2` with `α(φ)² = αx² cos²φ + αy² sin²φ`;
//!   `G1 = 1 / (1 + Λ)`, `G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))` (height-correlated Smith).
//! - The density of normals visible from `w` is `D_w(m) = G1(w) · |w·m| · D(m) / |cos θw|`;
//!   [`TrowbridgeReitz::sample_visible`] draws it exactly (Heitz 2018), for `w` on either side.
//! - pbrt-v4's roughness remapping (`remaproughness`, on by default) is `α = √roughness`.
//!
//! Its normalisation and sampling are tested with the Beckmann distribution in
//! `facets`.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Below this largest α a distribution is a perfectly smooth surface (pbrt-v4's threshold).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// An anisotropic Trowbridge-Reitz distribution: roughness `αx` along the local +X (the
/// surface's u direction), `αy` along +Y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrowbridgeReitz {
    /// Roughness along +X.
    pub alpha_x: f32,
    /// Roughness along +Y.
    pub alpha_y: f32,
}

/// pbrt-v4's `RoughnessToAlpha`: the α of a user-facing roughness in [0, 1].
pub fn roughness_to_alpha(roughness: f32) -> f32 {
    roughness.max(0.0).sqrt()
}

impl TrowbridgeReitz {
    /// A distribution with roughness `alpha_x`, `alpha_y` (negative or non-finite values are 0).
    pub fn new(alpha_x: f32, alpha_y: f32) -> Self {
        let clean = |a: f32| if a.is_finite() { a.max(0.0) } else { 0.0 };
        TrowbridgeReitz {
            alpha_x: clean(alpha_x),
            alpha_y: clean(alpha_y),
        }
    }

    /// True when the roughness depends on the direction.
    #[inline]
    pub fn is_anisotropic(&self) -> bool {
        self.alpha_x != self.alpha_y
    }

    /// True when the surface is treated as perfectly smooth (delta lobes).
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    /// `D(m)` for a unit normal `m` (0 below the surface, `m.z ≤ 0`).
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let cos2 = m.z * m.z;
        let sin2 = (1.0 - cos2).max(0.0);
        if cos2 * cos2 < 1e-16 {
            return 0.0;
        }
        let tan2 = sin2 / cos2;
        let (cos_phi2, sin_phi2) = phi2(m, sin2);
        let e = tan2
            * (cos_phi2 / (self.alpha_x * self.alpha_x) + sin_phi2 / (self.alpha_y * self.alpha_y));
        1.0 / (PI * self.alpha_x * self.alpha_y * cos2 * cos2 * (1.0 + e) * (1.0 + e))
    }

    /// Smith's `Λ(w)`.
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        let sin2 = (1.0 - cos2).max(0.0);
        if cos2 == 0.0 {
            return f32::INFINITY;
        }
        let tan2 = sin2 / cos2;
        let (cos_phi2, sin_phi2) = phi2(w, sin2);
        let alpha2 =
            cos_phi2 * self.alpha_x * self.alpha_x + sin_phi2 * self.alpha_y * self.alpha_y;
        ((1.0 + alpha2 * tan2).sqrt() - 1.0) * 0.5
    }

    /// `G1(w) = 1 / (1 + Λ(w))`.
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// `G(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))`.
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// The density of visible normals `D_w(m)` (solid angle over `m`, `m.z > 0`): normals
    /// facing `w`, or `−w` when `w` lies below (as [`TrowbridgeReitz::sample_visible`] draws).
    #[inline]
    pub fn visible_pdf(&self, w: Vec3, m: Vec3) -> f32 {
        let facing = w.dot(m) * w.z.signum();
        if w.z == 0.0 || facing <= 0.0 {
            return 0.0;
        }
        self.g1(w) / w.z.abs() * self.d(m) * facing
    }

    /// A normal (with `m.z > 0`) drawn from `D_w` with uniform `u`; `w` may lie on either side.
    pub fn sample_visible(&self, w: Vec3, u: Vec2) -> Vec3 {
        let mut wh = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize_or(Vec3::Z);
        if wh.z < 0.0 {
            wh = -wh;
        }
        let t1 = if wh.z < 0.99999 {
            Vec3::Z.cross(wh).normalize()
        } else {
            Vec3::X
        };
        let t2 = wh.cross(t1);
        let r = u.x.sqrt();
        let (sin, cos) = (2.0 * PI * u.y).sin_cos();
        let (px, py) = (r * cos, r * sin);
        let h = (1.0 - px * px).max(0.0).sqrt();
        let s = 0.5 * (1.0 + wh.z);
        let py = (1.0 - s) * h + s * py;
        let pz = (1.0 - px * px - py * py).max(0.0).sqrt();
        let nh = t1 * px + t2 * py + wh * pz;
        Vec3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize()
    }
}

/// `(cos²φ, sin²φ)` of a direction with `sin²θ = sin2` (φ = 0 at the pole).
#[inline]
fn phi2(w: Vec3, sin2: f32) -> (f32, f32) {
    if sin2 <= 0.0 {
        return (1.0, 0.0);
    }
    let c = (w.x * w.x / sin2).clamp(0.0, 1.0);
    (c, 1.0 - c)
}
