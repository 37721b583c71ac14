//! Caustic light tracing in volumetric scenes: light paths that leave a light through a delta
//! surface (glass, a mirror, a smooth dielectric or conductor) and are joined to the camera at
//! every medium collision and non-delta surface they reach. They carry the volumetric
//! caustics (light focused by a glass sphere into fog, and the light that fog scatters
//! again) that camera paths find only by chance, through a specular chain to a small light.
//!
//! # Partition (why the sum is unbiased)
//! With light tracing on, the volumetric path tracer (`volpath`) leaves out every
//! path `camera → x₁ → … → xₖ → light` whose first scattering vertex `x₁` is a medium
//! collision or a surface whose BSDF is not delta, whose last vertex `xₖ` is a surface whose
//! BSDF is delta, and whose light is a finite emitter: the emission its last ray finds is not
//! added (light sampling never reaches such a path: it ends at a delta vertex). Exactly those
//! paths are traced here from the other end: a light path leaves a finite emitter, crosses
//! media without a collision and null surfaces to a delta surface, then scatters on through
//! anything (phase functions, adjoint BSDFs), and every collision and non-delta surface `x`
//! it reaches is joined to the camera (a shadow ray that crosses null surfaces, its
//! transmittance the media's), which gives the path `camera → x → … → light`. A collision
//! or a non-delta surface before the first delta surface ends it (that path is the path
//! tracer's), and a joined path has at most the maximum depth's vertices.
//!
//! # Conventions
//! As `lighttrace` (passes, strides, splats, the camera's importance), with free
//! flights and spectral MIS as `volpath`: a hero channel per light path, the
//! contribution divided by the channel average of the path's density ratios. Delta
//! refractions carry the adjoint weight (no radiance scaling `1/η²`). A light's medium is the
//! one on its emitting side of its material's medium interface, or for a light that bounds
//! no medium, the one a ray from the eye is in where it reaches the light's point.

use crate::bsdf::Bsdf;
use crate::light::Light;
use crate::math::{offset_origin, Ray, Rgb};
use crate::medium::{hg_phase, sample_hg, MediumInterface};
use crate::sampling::sampler::{dim, Sampler};
use crate::sampling::Rng;
use crate::scene::{Scene, Surface};
use crate::vertex::flight::{average, flight, Flight, Weights};
use crate::vertex::light_path::{
    emit, emits_to, passes, project, scatter_adjoint, seen_by_camera, splat_scale, targets,
    LightPathSettings,
};
use crate::vertex::roulette;
use crate::vertex::shadow::{shadow_transmittance, ShadowRay};
use glam::Vec3;

/// Null surfaces a light path may cross in all.
const MAX_CROSSINGS: u32 = 256;

/// Whether volumetric caustic light tracing can represent every path the volumetric path
/// tracer leaves to it in `scene` through `camera`: a perspective pinhole, finite emitters
/// that are untextured area lights or spheres, some delta surface, and delta BSDFs whose
/// adjoint is known.
pub fn usable(scene: &Scene, camera: &crate::camera::Camera) -> bool {
    let adjoint_known = |b: &Bsdf| {
        !b.is_delta()
            || matches!(
                b,
                Bsdf::Mirror { .. }
                    | Bsdf::Glass { .. }
                    | Bsdf::Refraction { .. }
                    | Bsdf::Conductor(_)
                    | Bsdf::Interface(_)
            )
    };
    let delta = scene.materials.iter().any(|m| m.bsdf.is_delta());
    emits_to(scene, camera) && delta && scene.materials.iter().all(|m| adjoint_known(&m.bsdf))
}

/// The medium interface of light `j`'s material (its first primitive's), if it has one.
fn light_interface(scene: &Scene, j: usize) -> Option<MediumInterface> {
    let material = match &scene.lights[j] {
        Light::Area { tris, .. } => scene.tri_info.get(*tris.first()? as usize)?.material,
        Light::Sphere { .. } => {
            scene
                .sphere_info
                .iter()
                .find(|i| i.light as usize == j)?
                .material
        }
        _ => return None,
    };
    scene.materials.get(material as usize)?.interface
}

/// The medium at `q` of a light that bounds none: the one a ray from the eye (in the camera's
/// medium) is in when it reaches `q`, crossing every surface on the way (as a camera path's
/// medium follows its rays).
fn medium_at(scene: &Scene, eye: Vec3, q: Vec3) -> u32 {
    let mut medium = scene.camera_medium;
    if scene.media.is_empty() {
        return medium;
    }
    let mut o = eye;
    for _ in 0..MAX_CROSSINGS {
        let to = q - o;
        let len = to.length();
        if len.is_nan() || len <= 0.0 {
            break;
        }
        let mut ray = Ray::new(o, to / len);
        ray.t_max = len * (1.0 - 1e-4);
        let Some(hit) = scene.intersect(&ray) else {
            break;
        };
        let surf = scene.surface(&ray, &hit);
        if let Some(i) = scene.materials[surf.material as usize].interface {
            medium = i.toward(ray.d, surf.ng);
        }
        o = offset_origin(surf.p, surf.ng, ray.d);
    }
    medium
}

/// Bounding spheres of the scene's delta surfaces: light paths aim their first direction at
/// them (`sample_towards`).
pub fn delta_targets(scene: &Scene) -> Vec<(Vec3, f32)> {
    targets(scene, passes)
}

/// A light path's state.
struct LightPath {
    w: Weights,
    /// Product of the `(n_l/n_c)⁴` factors of refractions (undone for roulette).
    eta_scale: f32,
    ray: Ray,
    medium: u32,
    /// Numbers for tracking through grid media.
    rng: Rng,
}

/// Traces the light path of `sampler` and calls `splat(x, y, value)` where it is joined to
/// the camera, with the continuous frame position it lands at and its value `C / (W·H)` (as
/// `lighttrace::trace`). Returns the rays traced.
pub fn trace(
    scene: &Scene,
    s: &LightPathSettings,
    sampler: &Sampler,
    mut splat: impl FnMut(f32, f32, Rgb),
) -> u64 {
    let Some(mut path) = start(scene, s, sampler) else {
        return 0;
    };
    let mut rays = 0u64;
    let mut crossings = 0u32;
    let mut vertex = 1u32;
    while vertex <= s.max_depth && crossings < MAX_CROSSINGS {
        rays += 1;
        let hit = scene.intersect(&path.ray);
        let t_hit = hit.map_or(f32::INFINITY, |h| h.t);
        if let Some(medium) = scene.media.get(path.medium as usize) {
            // The first flight after a vertex draws from the sampler, later ones (after null
            // crossings) from the path's generator.
            let u = if crossings == 0 {
                sampler.get_1d(dim::light_vertex(vertex - 1, dim::DISTANCE))
            } else {
                path.rng.next_f32()
            };
            let event = flight(
                medium,
                &path.ray,
                t_hit,
                u,
                &mut path.rng,
                &mut path.w,
                None,
            );
            if let Flight::Collided(t) = event {
                // Before any delta surface this is the path tracer's path.
                if vertex == 1 || !path.w.alive() {
                    return rays;
                }
                let x = path.ray.at(t);
                let g = medium.g();
                rays += join_medium(scene, s, &mut path, x, g, &mut splat);
                let wl = -path.ray.d;
                let u = sampler.get_2d(dim::light_vertex(vertex, dim::BSDF_DIRECTION));
                let ps = sample_hg(wl, g, u);
                path.ray = Ray::new(x, ps.wi);
                if vertex == s.max_depth || !survives(&mut path, s, sampler, vertex) {
                    return rays;
                }
                vertex += 1;
                crossings = 0;
                continue;
            }
            if !path.w.alive() {
                return rays;
            }
        }
        let Some(hit) = hit else {
            return rays;
        };
        let surf = scene.surface(&path.ray, &hit);
        let material = &scene.materials[surf.material as usize];
        if material.null {
            if let Some(i) = material.interface {
                path.medium = i.toward(path.ray.d, surf.ng);
            }
            path.ray = Ray::new(offset_origin(surf.p, surf.ng, path.ray.d), path.ray.d);
            crossings += 1;
            continue;
        }
        let bsdf = scene.bsdf(&surf);
        let delta = passes(&bsdf);
        if bsdf.is_black() || (vertex == 1 && !delta) {
            return rays;
        }
        if !delta {
            rays += join_surface(scene, s, &mut path, surf, bsdf, &mut splat);
        }
        if vertex == s.max_depth
            || !scatter_at_surface(scene, &mut path, surf, bsdf, sampler, vertex)
            || !survives(&mut path, s, sampler, vertex)
        {
            return rays;
        }
        vertex += 1;
        crossings = 0;
    }
    rays
}

/// Russian roulette after light-path vertex `vertex` ([`roulette`]).
fn survives(path: &mut LightPath, s: &LightPathSettings, sampler: &Sampler, vertex: u32) -> bool {
    let effective = (path.w.beta / average(path.w.r_u) / path.eta_scale).max_element();
    let u = || sampler.get_1d(dim::light_vertex(vertex, dim::ROULETTE));
    match roulette(vertex, s.roulette_rule(), effective, u) {
        Some(q) => {
            path.w.beta /= q;
            path.w.alive()
        }
        None => false,
    }
}

/// The light path's first ray ([`emit`]), its weights and its medium; `None` where the
/// chosen light is not one it leaves.
fn start(scene: &Scene, s: &LightPathSettings, sampler: &Sampler) -> Option<LightPath> {
    let e = emit(scene, s.targets, sampler)?;
    let d = e.ray.d;
    // The medium on the side the path leaves by, from the surface's geometric normal (a
    // one-sided area light's emitting normal; a sphere's outward one).
    let medium = match light_interface(scene, e.light) {
        Some(i) => {
            let ng = match scene.lights[e.light] {
                Light::Sphere { center, .. } => (e.point - center).normalize_or_zero(),
                _ => e.normal,
            };
            i.toward(d, ng)
        }
        None => medium_at(scene, s.camera.pos, e.point),
    };
    let hero = ((sampler.get_1d(dim::light_vertex(0, dim::HERO)) * 3.0) as usize).min(2);
    let seed = (sampler.get_1d(dim::light_vertex(0, dim::SEED)) * 4_294_967_296.0) as u64;
    Some(LightPath {
        w: Weights {
            beta: e.beta,
            r_u: Vec3::ONE,
            r_l: Vec3::ONE,
            hero,
        },
        eta_scale: 1.0,
        ray: e.ray,
        medium,
        rng: Rng::new(seed, 0x11F7),
    })
}

/// Continues `path` at surface `surf` (BSDF `bsdf`) by its adjoint ([`scatter_adjoint`],
/// with the numbers of light-path vertex `vertex`): the new direction, weight and medium;
/// false when the path ends there.
fn scatter_at_surface(
    scene: &Scene,
    path: &mut LightPath,
    surf: Surface,
    bsdf: Bsdf,
    sampler: &Sampler,
    vertex: u32,
) -> bool {
    let wl = -path.ray.d;
    let Some((v, wc, weight, scale)) = scatter_adjoint(scene, surf, bsdf, wl, sampler, vertex)
    else {
        return false;
    };
    path.w.beta *= weight;
    path.eta_scale *= scale;
    if !path.w.alive() {
        return false;
    }
    if let Some(i) = scene.materials[surf.material as usize].interface {
        path.medium = i.toward(wc, surf.ng);
    }
    path.ray = v.spawn(wc);
    true
}

/// A joined vertex's view of the eye: where its ray to the eye starts and in which medium,
/// the frame position it lands at, and its contribution `c` (throughput times the vertex's
/// scattering and the camera's importance, not yet divided by the hero densities).
struct Seen {
    from: Vec3,
    medium: u32,
    px: f32,
    py: f32,
    c: Rgb,
}

/// Splats what `seen` of a joined vertex of `path` gets through to the eye; the rays traced.
fn splat_seen(
    scene: &Scene,
    s: &LightPathSettings,
    path: &mut LightPath,
    seen: Seen,
    splat: &mut impl FnMut(f32, f32, Rgb),
) -> u64 {
    let Seen {
        from,
        medium,
        px,
        py,
        c,
    } = seen;
    if !c.is_finite() || c.max_element() <= 0.0 {
        return 0;
    }
    let mut rays = 0;
    let to_eye = (s.camera.pos - from).normalize_or_zero();
    let shadow = ShadowRay {
        target: Some(s.camera.pos),
        medium,
        hero: path.w.hero,
    };
    let Some(tr) = shadow_transmittance(scene, from, to_eye, shadow, &mut path.rng, &mut rays)
    else {
        return rays;
    };
    let v = c * tr.seen_by(path.w.r_u) * splat_scale(s);
    if v.max_element() > 0.0 {
        splat(px, py, v);
    }
    rays
}

/// Joins medium collision `x` (phase asymmetry `g`) of `path` to the camera.
fn join_medium(
    scene: &Scene,
    s: &LightPathSettings,
    path: &mut LightPath,
    x: Vec3,
    g: f32,
    splat: &mut impl FnMut(f32, f32, Rgb),
) -> u64 {
    let Some((px, py, importance, wc)) = project(s, x) else {
        return 0;
    };
    let wl = -path.ray.d;
    let c = path.w.beta * (hg_phase(wc.dot(wl), g) * importance);
    let medium = path.medium;
    let seen = Seen {
        from: x,
        medium,
        px,
        py,
        c,
    };
    splat_seen(scene, s, path, seen, splat)
}

/// Joins the non-delta surface `surf` (BSDF `bsdf`) that `path` reached to the camera, with
/// Veach's shading-normal correction of the adjoint BSDF ([`seen_by_camera`]).
fn join_surface(
    scene: &Scene,
    s: &LightPathSettings,
    path: &mut LightPath,
    surf: Surface,
    bsdf: Bsdf,
    splat: &mut impl FnMut(f32, f32, Rgb),
) -> u64 {
    let Some((px, py, importance, wc)) = project(s, surf.p) else {
        return 0;
    };
    let wl = -path.ray.d;
    let Some((v, f)) = seen_by_camera(scene, surf, bsdf, wl, wc, importance) else {
        return 0;
    };
    let c = path.w.beta * f;
    let medium = scene.materials[surf.material as usize]
        .interface
        .map_or(path.medium, |i| i.toward(wc, surf.ng));
    let seen = Seen {
        from: v.origin(wc),
        medium,
        px,
        py,
        c,
    };
    splat_seen(scene, s, path, seen, splat)
}
