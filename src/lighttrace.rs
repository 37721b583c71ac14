//! Caustic light tracing: paths that leave a light through specular or near-specular
//! surfaces, connected to the camera from the diffuse and glossy surfaces they reach.
//!
//! # Partition (why the sum is unbiased)
//! A *caustic* surface is one whose BSDF is a delta lobe (mirror, glass, refraction) or a
//! conductor rougher than nothing but smoother than [`CAUSTIC_ALPHA`] ([`is_caustic`]). With
//! light tracing on, the path tracer ([`crate::integrator::radiance`]) leaves out every path
//! `camera → x1 → … → xk → light` whose first hit `x1` is *not* caustic and whose last
//! surface `xk` *is* caustic, with a finite emitter (area light or emissive sphere) at its
//! end: it neither adds the light found by light sampling at `xk` nor the emission its
//! continuation ray finds. Exactly those paths are what this module traces from the other
//! end: a light path starts on a finite emitter, must meet a caustic surface first, then goes
//! on through any surfaces, and every non-caustic, non-delta vertex `x` it reaches is joined
//! to the camera (a shadow ray), which gives the path `camera → x → … → light`. Both sides
//! evaluate the same measurement, so the image is the sum of the two estimates.
//!
//! # Conventions
//! - A light pass `k` traces one light path for one frame pixel `(x, y)` in [`STRIDE`]
//!   ([`starts_path`]), drawing from the numbers of camera sample `k` of that pixel
//!   ([`crate::sampling::sampler::Sampler`], slots [`dim::light_vertex`]); so light paths, like
//!   camera samples, are pure functions of the seed, pixel and sample index, and a sample
//!   range `[a, b)` holds light passes `[a, b)`.
//! - A light path's first direction is sampled uniformly within the cones towards the
//!   bounding spheres of the caustic surfaces ([`caustic_targets`], [`sample_towards`]), so
//!   it meets a caustic surface first far more often; from a point inside one of them it is
//!   cosine-distributed over the hemisphere.
//! - A joined vertex adds `C · STRIDE / (W·H)` to the pixel it projects to, where `W × H` is the frame
//!   and `C` the path's contribution with the pinhole's importance (`1 / (A_pixel · cos³ θ)`
//!   for a box pixel of area `A_pixel` on the plane at distance 1); the film divides the sums
//!   by the number of light passes ([`crate::film::Film::light_passes`]). Splats are added as
//!   fixed-point integers, so their sums do not depend on thread count or order.
//! - Light paths use the adjoint BSDFs: diffuse and conductor BSDFs are symmetric; a delta
//!   refraction carries `T · (n_l / n_c)⁴ · (1 − R_c) / (1 − R_l)` (the path tracer's
//!   CS184 weight `T · (n_l / n_c)²` times the Jacobian `(n_l / n_c)²` of refraction), where
//!   `l` is the light's side, `c` the camera's and `R` Schlick's reflectance at each side's
//!   angle; shading normals are corrected as Veach (1997, §5.3) describes.
//! - Light tracing is used only where it can represent every such path: a pinhole camera,
//!   not CS184's `-a` (the adaptive budget takes one light pass per level of its rounds, as
//!   a uniform render of its mean budget would), and scenes whose emitters
//!   are untextured area lights or spheres (point, spot and infinite lights stay with the path
//!   tracer) and whose BSDFs are diffuse, mirror, glass, refraction or conductors ([`usable`]).

use crate::bsdf::Bsdf;
use crate::math::Rgb;
use crate::sampling::sampler::{dim, Sampler};
use crate::scene::{Scene, Surface};
use crate::vertex::light_path::{emit, emits_to, project, scatter_adjoint, seen_by_camera};
use crate::vertex::light_path::{splat_scale, targets, Emission};
use crate::vertex::roulette;
use crate::vertex::shadow::reaches_eye;
use glam::Vec3;

pub use crate::vertex::light_path::{
    is_caustic, pdf_towards, sample_towards, starts_path, LightPathSettings, CAUSTIC_ALPHA, STRIDE,
};

/// True when light tracing can represent every path the path tracer leaves to it in `scene`
/// seen through its camera: a perspective pinhole, finite emitters that are untextured area lights or
/// spheres, BSDFs that light paths can sample (see the module documentation), and at least
/// one caustic surface and one finite emitter (else it would add nothing). Volumetric scenes
/// have light paths of their own (`vollight::usable`).
pub fn usable(scene: &Scene, camera: &crate::camera::Camera) -> bool {
    let supported = |b: &Bsdf| {
        matches!(
            b,
            Bsdf::Diffuse { .. }
                | Bsdf::Mirror { .. }
                | Bsdf::Glass { .. }
                | Bsdf::Refraction { .. }
                | Bsdf::Microfacet(_)
                | Bsdf::Black
        )
    };
    let caustic = scene.materials.iter().any(|m| is_caustic(&m.bsdf));
    emits_to(scene, camera) && caustic && scene.materials.iter().all(|m| supported(&m.bsdf))
}

/// Bounding spheres `(centre, radius)` of the scene's caustic surfaces: each caustic sphere,
/// and one sphere around all caustic triangles. A light path's first hit must be a caustic
/// surface, so its first direction is sampled only towards these ([`sample_towards`]).
/// Volumetric scenes aim at their delta surfaces instead (`vollight::delta_targets`).
pub fn caustic_targets(scene: &Scene) -> Vec<(Vec3, f32)> {
    targets(scene, is_caustic)
}

/// Traces the light path of `sampler` (a camera sample's numbers) and calls
/// `splat(x, y, value)` for each camera connection with the continuous frame position it
/// lands at and its value `C / (W·H)`. Returns the rays traced. Surface scenes only:
/// volumetric scenes have `vollight::trace`.
pub fn trace(
    scene: &Scene,
    s: &LightPathSettings,
    sampler: &Sampler,
    mut splat: impl FnMut(f32, f32, Rgb),
) -> u64 {
    if s.max_depth < 2 {
        return 0;
    }
    let Some(Emission { beta, ray, .. }) = emit(scene, s.targets, sampler) else {
        return 0;
    };
    let (mut beta, mut ray) = (beta, ray);
    // Product of the (n_l/n_c)⁴ factors of refractions (undone for roulette).
    let mut eta_scale = 1.0f32;
    let mut rays = 0u64;
    for vertex in 1..=s.max_depth {
        rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            break;
        };
        let surf = scene.surface(&ray, &hit);
        let bsdf = scene.bsdf(&surf);
        if bsdf.is_black() {
            break;
        }
        let caustic = is_caustic(&bsdf);
        if vertex == 1 && !caustic {
            break; // the path tracer's own path
        }
        let wl = -ray.d;
        if !caustic && !bsdf.is_delta() && (s.accumulate || vertex == s.max_depth) {
            rays += connect(scene, s, surf, bsdf, wl, beta, &mut splat);
        }
        if vertex == s.max_depth {
            break;
        }
        let Some((v, wc, weight, scale)) = scatter_adjoint(scene, surf, bsdf, wl, sampler, vertex)
        else {
            break;
        };
        beta *= weight;
        eta_scale *= scale;
        let u = || sampler.get_1d(dim::light_vertex(vertex, dim::ROULETTE));
        let effective = beta.max_element() / eta_scale;
        let Some(q) = roulette(vertex, s.roulette_rule(), effective, u) else {
            break;
        };
        beta /= q;
        if beta.max_element() <= 0.0 || !beta.is_finite() {
            break;
        }
        ray = v.spawn(wc);
    }
    rays
}

/// Joins light-path vertex `surf` (reached along `-wl`, throughput `beta`) to the camera:
/// splats the contribution into the pixel it projects to when nothing blocks the view.
/// Returns the rays traced (0 or 1).
fn connect(
    scene: &Scene,
    s: &LightPathSettings,
    surf: Surface,
    bsdf: Bsdf,
    wl: Vec3,
    beta: Rgb,
    splat: &mut impl FnMut(f32, f32, Rgb),
) -> u64 {
    let Some((px, py, importance, wc)) = project(s, surf.p) else {
        return 0;
    };
    let Some((v, f)) = seen_by_camera(scene, surf, bsdf, wl, wc, importance) else {
        return 0;
    };
    let c = beta * f;
    if !c.is_finite() || c.max_element() <= 0.0 {
        return 0;
    }
    let mut rays = 0;
    if reaches_eye(scene, v.origin(wc), wc, s.camera.pos, &mut rays) {
        splat(px, py, c * splat_scale(s));
    }
    rays
}
