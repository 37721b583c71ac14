//! The one place where a render chooses its tracers: the surface path tracer
//! ([`crate::integrator`]) or the volumetric one ([`crate::volpath`]) for camera paths, and
//! the matching light tracer ([`crate::lighttrace`], [`crate::vollight`]) for caustic light
//! paths. The tracers themselves never call each other.

use crate::camera::Camera;
use crate::lighttrace::LightPathSettings;
use crate::math::{Ray, Rgb};
use crate::sampling::sampler::Sampler;
use crate::scene::Scene;
use crate::vertex::{Guiding, IntegratorSettings};
use glam::Vec3;

/// Radiance along camera ray `ray` by the tracer of `scene`; `rays` counts every ray traced.
#[inline]
pub(crate) fn radiance(
    scene: &Scene,
    ray: Ray,
    sampler: &Sampler,
    s: &IntegratorSettings,
    g: Guiding,
    rays: &mut u64,
) -> Rgb {
    if scene.volumetric {
        crate::volpath::radiance(scene, ray, sampler, s, g, rays)
    } else {
        crate::integrator::radiance(scene, ray, sampler, s, g, rays)
    }
}

/// Whether caustic light tracing can represent every path the camera tracer of `scene` leaves
/// to it, seen through `camera`.
pub(crate) fn light_tracing_usable(scene: &Scene, camera: &Camera) -> bool {
    if scene.volumetric {
        crate::vollight::usable(scene, camera)
    } else {
        crate::lighttrace::usable(scene, camera)
    }
}

/// Bounding spheres `(centre, radius)` that light paths of `scene` aim their first direction at.
pub(crate) fn light_targets(scene: &Scene) -> Vec<(Vec3, f32)> {
    if scene.volumetric {
        crate::vollight::delta_targets(scene)
    } else {
        crate::lighttrace::caustic_targets(scene)
    }
}

/// Traces the light path of `sampler` by the light tracer of `scene`, calling `splat(x, y,
/// value)` where it is joined to the camera; the rays traced.
pub(crate) fn trace_light_path(
    scene: &Scene,
    s: &LightPathSettings,
    sampler: &Sampler,
    splat: impl FnMut(f32, f32, Rgb),
) -> u64 {
    if s.max_depth < 2 {
        return 0;
    }
    if scene.volumetric {
        crate::vollight::trace(scene, s, sampler, splat)
    } else {
        crate::lighttrace::trace(scene, s, sampler, splat)
    }
}
