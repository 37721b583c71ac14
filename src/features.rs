//! Feature images for denoisers, as Open Image Denoise wants them: per camera sample, the
//! albedo and the shading normal at the first non-delta surface the camera ray reaches,
//! following delta bounces (mirrors, smooth glass, smooth metal, null surfaces) the way the
//! sample's own path does, with the colours of the surfaces on the way ([`Bsdf::albedo`]: a
//! mirror's reflectance, a glass's transmittance) multiplied into the albedo.
//!
//! [`Bsdf::albedo`]: crate::bsdf::Bsdf::albedo

pub use crate::film::Features;
use crate::math::{Ray, Rgb};
use crate::sampling::sampler::Sampler;
use crate::scene::Scene;
use crate::vertex::SurfaceVertex;
use glam::Vec3;

/// Delta bounces followed at most; a longer chain gives the features of where it stops.
pub const MAX_DELTA_CHAIN: u32 = 8;

/// The [`Features`] of the camera ray `ray` of the sample whose numbers are `sampler`'s:
/// a delta bounce takes the direction the sample's path takes there (the same numbers).
/// Kept out of line: the sample loop calls it only where features are recorded.
#[inline(never)]
pub fn features(scene: &Scene, ray: Ray, sampler: &Sampler) -> Features {
    let mut ray = ray;
    let mut tint = Rgb::ONE;
    for depth in 1..=MAX_DELTA_CHAIN + 1 {
        let Some(hit) = scene.intersect(&ray) else {
            break;
        };
        let surf = scene.surface(&ray, &hit);
        let v = SurfaceVertex::new(scene, surf, scene.bsdf(&surf), -ray.d);
        let last = depth == MAX_DELTA_CHAIN + 1;
        if !v.bsdf.is_delta() || last {
            return Features {
                albedo: finite_or_zero(tint * v.bsdf.albedo()).clamp(Rgb::ZERO, Rgb::ONE),
                normal: finite_or_zero(v.frame.n),
            };
        }
        let Some((_, wi_w)) = v.sample(sampler, depth) else {
            break;
        };
        tint *= v.bsdf.albedo();
        if !tint.is_finite() || tint.max_element() <= 0.0 {
            break;
        }
        ray = v.spawn(wi_w);
    }
    Features::default()
}

/// `v` where it is finite, else zero.
fn finite_or_zero(v: Vec3) -> Vec3 {
    if v.is_finite() {
        v
    } else {
        Vec3::ZERO
    }
}
