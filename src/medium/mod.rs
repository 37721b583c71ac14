//! Participating media: what fills the space between surfaces, and the boundaries that say
//! which medium a ray is in.
//!
//! Conventions (pbrt-v4's and Mitsuba's): coefficients are per unit length in scene units,
//! per RGB channel; `σt = σa + σs`. A phase function takes `wo`, the unit direction back
//! towards where the path came from (`−ray.d`), and `wi`, the new direction; its value is a
//! density in solid angle over `wi`. Henyey-Greenstein's `g > 0` scatters forwards (`wi`
//! close to `−wo`). A surface's [`MediumInterface`] names the medium on each side of it:
//! `outside` is the side its geometric normal faces.

pub mod grid;

use crate::math::{Frame, Rgb};
use glam::{Vec2, Vec3};
pub use grid::GridMedium;
use std::f32::consts::PI;

/// Marks "no medium" (vacuum) in medium ids.
pub const NO_MEDIUM: u32 = u32::MAX;

/// The media on the two sides of a surface, as ids into `scene::Scene::media` or
/// [`NO_MEDIUM`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MediumInterface {
    /// Behind the geometric normal.
    pub inside: u32,
    /// Where the geometric normal points.
    pub outside: u32,
}

impl MediumInterface {
    /// The medium a ray along `d` enters when it crosses a surface of geometric normal `ng`.
    #[inline]
    pub fn toward(self, d: Vec3, ng: Vec3) -> u32 {
        if d.dot(ng) > 0.0 {
            self.outside
        } else {
            self.inside
        }
    }
}

/// A medium of constant coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homogeneous {
    /// Absorption coefficient per channel (≥ 0).
    pub sigma_a: Rgb,
    /// Scattering coefficient per channel (≥ 0).
    pub sigma_s: Rgb,
    /// Henyey-Greenstein asymmetry in (−1, 1).
    pub g: f32,
    /// Emitted radiance per channel (the source term is `σa·Le`, pbrt-v4's convention).
    pub le: Rgb,
}

impl Homogeneous {
    /// Extinction `σa + σs` per channel.
    #[inline]
    pub fn sigma_t(&self) -> Rgb {
        self.sigma_a + self.sigma_s
    }

    /// Transmittance `exp(−σt·d)` over distance `d` (1 where `σt` is 0, also for `d = ∞`).
    #[inline]
    pub fn transmittance(&self, d: f32) -> Rgb {
        transmittance(self.sigma_t(), d)
    }
}

/// `exp(−σt·d)` per channel, 1 where `σt` is 0 (also for an infinite `d`).
#[inline]
pub fn transmittance(sigma_t: Rgb, d: f32) -> Rgb {
    let one = |s: f32| if s > 0.0 { (-s * d).exp() } else { 1.0 };
    Vec3::new(one(sigma_t.x), one(sigma_t.y), one(sigma_t.z))
}

/// A participating medium.
#[derive(Clone, Debug, PartialEq)]
pub enum Medium {
    /// Constant coefficients everywhere.
    Homogeneous(Homogeneous),
    /// Coefficients from voxel grids over a box.
    Grid(Box<GridMedium>),
}

impl Medium {
    /// Its Henyey-Greenstein asymmetry.
    pub fn g(&self) -> f32 {
        match self {
            Medium::Homogeneous(h) => h.g,
            Medium::Grid(m) => m.g,
        }
    }

    /// Whether it emits light.
    pub fn emits(&self) -> bool {
        match self {
            Medium::Homogeneous(h) => h.le.max_element() > 0.0 && h.sigma_a.max_element() > 0.0,
            Medium::Grid(m) => m.emits(),
        }
    }
}

/// The Henyey-Greenstein phase function for `cos_theta = wo·wi` (see the module's
/// conventions), in 1/sr.
#[inline]
pub fn hg_phase(cos_theta: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g + 2.0 * g * cos_theta;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(0.0).sqrt()).max(f32::MIN_POSITIVE)
}

/// A Henyey-Greenstein sample: the new direction `wi` and its density (which is also the
/// phase function's value, so the sample's weight is 1).
#[derive(Clone, Copy, Debug)]
pub struct PhaseSample {
    /// The new direction, unit.
    pub wi: Vec3,
    /// Its density in solid angle.
    pub pdf: f32,
}

/// Samples Henyey-Greenstein with asymmetry `g` around `wo` (unit) by inverting its
/// distribution in `cos θ`, `u` uniform in [0, 1)².
pub fn sample_hg(wo: Vec3, g: f32, u: Vec2) -> PhaseSample {
    let cos_theta = if g.abs() < 1e-3 {
        1.0 - 2.0 * u.x
    } else {
        let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
        (-(1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let local = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
    let wi = Frame::from_normal(wo).to_world(local).normalize();
    PhaseSample {
        wi,
        pdf: hg_phase(cos_theta, g),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere, Chi2Config};

    #[test]
    fn henyey_greenstein_samples_follow_its_density() {
        // Five asymmetries from strongly backward to strongly forward, each at an oblique wo;
        // 1% significance split over the five tests.
        let wo = Vec3::new(0.3, -0.5, 0.8).normalize();
        for g in [-0.9f32, -0.3, 0.0, 0.5, 0.95] {
            let cfg = Chi2Config {
                significance: 0.01 / 5.0,
                ..Chi2Config::fine(0.01 / 5.0, 17)
            };
            let r = chi2_test_sphere(
                &cfg,
                |u| Some(sample_hg(wo, g, u).wi),
                |wi| hg_phase(wo.dot(wi), g),
            );
            let r = r.unwrap_or_else(|e| panic!("g {g}: {e}"));
            assert!((r.pdf_integral - 1.0).abs() < 2e-3, "g {g}: {r:?}");
        }
    }

    #[test]
    fn henyey_greenstein_sample_density_is_its_value_and_g_is_the_mean_cosine() {
        let wo = Vec3::Z;
        let mut rng = crate::sampling::Rng::new(3, 4);
        for g in [-0.7f32, 0.0, 0.4, 0.9] {
            let mut mean = 0.0f64;
            let n = 200_000;
            for _ in 0..n {
                let s = sample_hg(wo, g, rng.next_2d());
                let value = hg_phase(wo.dot(s.wi), g);
                assert!((s.pdf - value).abs() <= 1e-3 * value.max(1.0), "g {g}");
                // g is the mean cosine between the old direction of travel (−wo) and wi.
                mean += f64::from((-wo).dot(s.wi));
            }
            let mean = mean / n as f64;
            assert!(
                (mean - f64::from(g)).abs() < 0.01,
                "g {g}: mean cosine {mean}"
            );
        }
    }

    #[test]
    fn transmittance_is_beer_lambert() {
        let h = Homogeneous {
            sigma_a: Vec3::new(0.5, 0.0, 1.0),
            sigma_s: Vec3::new(0.5, 0.0, 1.0),
            g: 0.0,
            le: Vec3::ZERO,
        };
        let t = h.transmittance(2.0);
        assert!((t.x - (-2.0f32).exp()).abs() < 1e-6);
        assert_eq!(t.y, 1.0);
        assert!((t.z - (-4.0f32).exp()).abs() < 1e-6);
        assert_eq!(h.transmittance(f32::INFINITY), Vec3::new(0.0, 1.0, 0.0));
        let i = MediumInterface {
            inside: 0,
            outside: NO_MEDIUM,
        };
        assert_eq!(i.toward(Vec3::Z, Vec3::Z), NO_MEDIUM);
        assert_eq!(i.toward(-Vec3::Z, Vec3::Z), 0);
    }
}
