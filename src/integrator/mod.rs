//! The path tracer of one camera ray (CS184 structure).
//!
//! Bounce counting follows CS184's `max_ray_depth` (and the references, which use Mitsuba's
//! `max_depth = m + 1`): depth 0 is the emission seen directly, depth 1 adds direct light at
//! the first hit, and each further depth adds one more bounce. Light that reaches hit `k` —
//! by light sampling at a non-delta BSDF, or as emission found through a delta (specular)
//! bounce from hit `k` — belongs to bounce `k`.
//! Direct light is estimated at every vertex by sampling the lights (`-l N` samples per
//! non-delta light, one per delta light) or, with `-H`, by uniform hemisphere sampling.
//! Emission found by continuation rays from non-delta BSDFs is not added again (it is direct
//! light of the previous vertex); delta BSDFs get no light sampling, so the emission their
//! continuation ray finds is added. Paths are continued with the BSDF's own sampling; from hit
//! [`IntegratorSettings::rr_depth`] on, Russian roulette continues them with probability
//! `min(1, RR_SURVIVAL · max(throughput) · η²)` ([`RR_SURVIVAL`] = 3; η² undoes the radiance
//! scaling of refractions, as pbrt-v4 and Mitsuba do) and divides survivors by it, which
//! keeps the estimate unbiased; only paths whose throughput has fallen below 1/3 can be cut.
//! Every random number comes from a fixed dimension slot of the camera sample's
//! [`Sampler`] ([`dim`]). Light samples of an environment map follow the learned guide where
//! the render has one ([`Guiding`], [`crate::guide`]), and so do the densities that weigh them
//! against BSDF sampling.

pub mod packet;

pub use crate::vertex::{Direct, Guiding, IntegratorSettings, LightSelection, RR_SURVIVAL};

use crate::bsdf::Bsdf;
use crate::light::power_heuristic;
use crate::math::{luminance, offset_origin, Frame, Ray, Rgb};
use crate::sampling::sampler::{dim, Sampler};
use crate::sampling::{uniform_hemisphere, UNIFORM_HEMISPHERE_PDF};
use crate::scene::{Scene, Surface, NO_LIGHT};
use crate::vertex::light_path::is_caustic;
use crate::vertex::{
    choose_light, emission_found, escape_found, light_density, sample_bsdf, Found,
};
use glam::Vec3;

/// Radiance along `ray`. `rays` counts every ray traced (camera, continuation and shadow).
pub fn radiance(
    scene: &Scene,
    ray: Ray,
    sampler: &Sampler,
    s: &IntegratorSettings,
    g: Guiding,
    rays: &mut u64,
) -> Rgb {
    let Some(mut p) = start(scene, ray, s, rays) else {
        return if s.accumulate || s.max_depth == 0 {
            scene.escaped(ray.d)
        } else {
            Vec3::ZERO
        };
    };
    // `depth` is the index of the current hit: light arriving at hit `depth`, by light
    // sampling or through a delta bounce, belongs to bounce `depth`.
    for depth in 1..=s.max_depth {
        let bsdf = scene.bsdf(&p.surf);
        if bsdf.is_black() || !bounce(scene, &mut p, bsdf, depth, sampler, s, g, rays) {
            break;
        }
    }
    p.l
}

/// A path between two bounces.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathState {
    /// Radiance gathered so far.
    pub l: Rgb,
    /// Throughput.
    pub beta: Rgb,
    /// Product of the radiance scalings 1/η² of the refractions so far (undone for roulette).
    pub eta_scale: f32,
    /// Light tracing is on and the first hit is not a caustic surface: light from finite
    /// emitters at a later caustic surface belongs to light paths (set at the first bounce).
    pub plain_first: bool,
    /// The ray that reached `surf`.
    pub ray: Ray,
    /// The path's current surface.
    pub surf: Surface,
}

/// The camera ray's first hit, with the emission seen there; `None` when it leaves the
/// scene. Counts the ray.
#[inline]
pub(crate) fn start(
    scene: &Scene,
    ray: Ray,
    s: &IntegratorSettings,
    rays: &mut u64,
) -> Option<PathState> {
    *rays += 1;
    let hit = scene.intersect(&ray)?;
    let surf = scene.surface(&ray, &hit);
    let mut l = Vec3::ZERO;
    if s.accumulate || s.max_depth == 0 {
        l += scene.emitted(&surf, -ray.d);
    }
    Some(PathState {
        l,
        beta: Vec3::ONE,
        eta_scale: 1.0,
        plain_first: false,
        ray,
        surf,
    })
}

/// Bounce `depth` (the index of the current hit, from 1) of path `p` at `p.surf`, whose BSDF
/// `bsdf` is not black: adds the light this bounce gathers to `p.l` and moves the path on to
/// its next surface. False when the path ends here.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn bounce(
    scene: &Scene,
    p: &mut PathState,
    bsdf: Bsdf,
    depth: u32,
    sampler: &Sampler,
    s: &IntegratorSettings,
    g: Guiding,
    rays: &mut u64,
) -> bool {
    let m = s.max_depth;
    let counts = |depth: u32| s.accumulate || depth == m;
    let surf = p.surf;
    let wo_w = -p.ray.d;
    // Orient the frame to the side the path arrives from (two-sided surfaces); `front`
    // tells dielectrics whether that is the outside.
    let (front, ng, frame) = surf.facing(wo_w);
    let caustic = s.light_tracing && is_caustic(&bsdf);
    if depth == 1 {
        p.plain_first = s.light_tracing && !caustic;
    }
    let left = p.plain_first && caustic;
    let bsdf = scene.seen_from(bsdf, &surf, front);
    let frame = if bsdf.is_anisotropic() {
        crate::math::Frame::from_normal_tangent(frame.n, scene.tangent(&surf))
    } else {
        frame
    };
    let wo = frame.to_local(wo_w);
    let delta = bsdf.is_delta();
    let samples_lights = matches!(s.direct, Direct::Mis | Direct::Light | Direct::Hemisphere);
    // Whether the continuation ray's emission counts (besides after delta lobes).
    let bsdf_finds = matches!(s.direct, Direct::Mis | Direct::Bsdf);
    if !delta && counts(depth) && samples_lights {
        let vertex = Vertex {
            surf: &surf,
            ng,
            frame,
            wo,
            bsdf,
            finite_left: left,
        };
        let ld = if s.direct == Direct::Hemisphere {
            direct_hemisphere(scene, &vertex, sampler, depth, s, rays)
        } else {
            direct_lights(scene, &vertex, sampler, depth, s, g, rays)
        };
        p.l += p.beta * ld;
    }
    // The last bounce needs no continuation, except through a delta lobe or with MIS,
    // where the emission the continuation ray finds is (part of) this bounce's direct light.
    if depth == m && !((delta || bsdf_finds) && counts(depth)) {
        return false;
    }
    let Some(bs) = sample_bsdf(&bsdf, wo, front, sampler, depth) else {
        return false;
    };
    let wi_w = frame.to_world(bs.wi);
    // The sampled side must agree with the geometry: reflection stays on the side the path
    // arrived from, transmission crosses (no leaks at disagreeing shading normals).
    if (wi_w.dot(ng) > 0.0) != (bs.wi.z > 0.0) || wi_w.dot(ng) == 0.0 {
        return false;
    }
    p.beta *= bs.weight * scene.shadowing(&surf, wi_w);
    if bs.wi.z < 0.0 {
        p.eta_scale *= bsdf.radiance_scale(front);
    }
    if depth >= s.rr_depth && depth < m {
        let q = (p.beta.max_element() / p.eta_scale * RR_SURVIVAL).min(1.0);
        if q.is_nan() || q <= 0.0 || sampler.get_1d(dim::bounce(depth, dim::ROULETTE)) >= q {
            return false;
        }
        p.beta /= q;
    }
    if p.beta.max_element() <= 0.0 || !p.beta.is_finite() {
        return false;
    }
    let from = surf.p;
    p.ray = Ray::new(offset_origin(from, ng, wi_w), wi_w);
    *rays += 1;
    // Emission found by the continuation ray: all of it after a delta lobe, its
    // BSDF-sampling share with MIS, nothing otherwise (light sampling counted it).
    let found = counts(depth) && (bs.delta || bsdf_finds);
    let mis = s.direct == Direct::Mis && !bs.delta;
    match scene.intersect(&p.ray) {
        Some(h) => {
            p.surf = scene.surface(&p.ray, &h);
            if found && p.surf.light != NO_LIGHT && !left {
                p.l += emission_found(scene, s, from, &p.surf, wi_w, bs.pdf, mis, p.beta);
            }
            true
        }
        None => {
            if found {
                let escape = Found {
                    from,
                    bsdf_pdf: bs.pdf,
                    mis,
                    beta: p.beta,
                };
                escape_found(scene, s, g.guide, wi_w, escape, &mut p.l);
            }
            false
        }
    }
}

/// A shading point with its frame, as the direct-light estimators need it.
struct Vertex<'a> {
    surf: &'a Surface,
    /// Geometric normal flipped to the side the path arrives from.
    ng: Vec3,
    /// Shading frame on that side.
    frame: Frame,
    /// Direction to the previous vertex, local frame.
    wo: Vec3,
    bsdf: Bsdf,
    /// Light from finite emitters (area lights, emissive spheres) is left to light tracing.
    finite_left: bool,
}

/// The numbers of one light sample: sub-sample `i` of `n` of a bounce's light slots.
#[derive(Clone, Copy)]
struct LightDraw<'a> {
    sampler: &'a Sampler,
    depth: u32,
    /// Added to the slots (distinct per light when every light is sampled).
    salt: u32,
    i: u32,
    n: u32,
}

impl LightDraw<'_> {
    fn get_1d(&self, slot: u32) -> f32 {
        let slot = dim::bounce(self.depth, slot).wrapping_add(self.salt);
        self.sampler.get_1d_sub(slot, self.i, self.n)
    }

    fn get_2d(&self, slot: u32) -> glam::Vec2 {
        let slot = dim::bounce(self.depth, slot).wrapping_add(self.salt);
        self.sampler.get_2d_sub(slot, self.i, self.n)
    }
}

/// Direct light at a vertex (hit `depth`) by light sampling: every light (`All`) or lights
/// chosen by power.
fn direct_lights(
    scene: &Scene,
    v: &Vertex,
    sampler: &Sampler,
    depth: u32,
    s: &IntegratorSettings,
    g: Guiding,
    rays: &mut u64,
) -> Rgb {
    let n = s.light_samples.max(1);
    match s.selection {
        LightSelection::All => {
            let mut total = Vec3::ZERO;
            for j in 0..scene.lights.len() {
                let k = if scene.lights[j].is_delta() { 1 } else { n };
                let mut acc = Vec3::ZERO;
                for i in 0..k {
                    let draw = LightDraw {
                        sampler,
                        depth,
                        // A pseudo-random slot offset per light (a distinct set of points).
                        salt: (j as u32).wrapping_mul(0x9E37_79B9),
                        i,
                        n: k,
                    };
                    acc += light_sample(scene, v, j, draw, s, g, rays);
                }
                total += acc / k as f32;
            }
            total
        }
        LightSelection::Power => {
            if scene.light_selection.total() <= 0.0 {
                return Vec3::ZERO;
            }
            let mut acc = Vec3::ZERO;
            for i in 0..n {
                let draw = LightDraw {
                    sampler,
                    depth,
                    salt: 0,
                    i,
                    n,
                };
                let (j, pmf) = choose_light(scene, || draw.get_1d(dim::LIGHT_CHOICE));
                acc += light_sample(scene, v, j, draw, s, g, rays) / pmf;
            }
            acc / n as f32
        }
    }
}

/// One light sample of light `j` at a vertex: `f · Li · |cos| / pdf`, MIS-weighted against
/// BSDF sampling when the estimator is [`Direct::Mis`]. A training run records the samples
/// of its environment light ([`Recorder`]).
fn light_sample(
    scene: &Scene,
    v: &Vertex,
    j: usize,
    draw: LightDraw,
    s: &IntegratorSettings,
    g: Guiding,
    rays: &mut u64,
) -> Rgb {
    let light = &scene.lights[j];
    if v.finite_left && light.is_finite_emitter() {
        return Vec3::ZERO;
    }
    let u = draw.get_2d(dim::LIGHT_POINT);
    let Some(ls) = scene.sample_light(j, v.surf.p, u, g.guide) else {
        return Vec3::ZERO;
    };
    let reached = unoccluded_light(scene, v, &ls, rays);
    if let Some(r) = g.record.filter(|r| r.light == j) {
        let value = match reached {
            Some(_) => luminance(ls.li) * ls.wi.dot(v.ng).abs() / ls.pdf,
            None => 0.0,
        };
        r.record(v.surf.p, ls.wi, value);
    }
    let Some((f, wi)) = reached else {
        return Vec3::ZERO;
    };
    let w = if s.direct == Direct::Mis && !light.is_delta() {
        power_heuristic(
            1.0,
            light_density(scene, s, j, ls.pdf),
            1.0,
            v.bsdf.pdf(v.wo, wi),
        )
    } else {
        1.0
    };
    f * ls.li * (wi.z.abs() * w / ls.pdf)
}

/// The BSDF value (shadowing included) and local direction of light sample `ls` at a vertex,
/// where the surface scatters it and nothing blocks it (its shadow ray traced and counted).
fn unoccluded_light(
    scene: &Scene,
    v: &Vertex,
    ls: &crate::light::LightSample,
    rays: &mut u64,
) -> Option<(Rgb, Vec3)> {
    let (surf, ng) = (v.surf, v.ng);
    // Lights behind the surface count only through a transmitting lobe, and the shading
    // frame must put them on the same side as the geometry does.
    let side = ls.wi.dot(ng);
    if side == 0.0 || (side < 0.0 && !v.bsdf.transmits()) {
        return None;
    }
    let wi = v.frame.to_local(ls.wi);
    if (wi.z > 0.0) != (side > 0.0) {
        return None;
    }
    let f = v.bsdf.eval(v.wo, wi) * scene.shadowing(surf, ls.wi);
    if f.max_element() <= 0.0 {
        return None;
    }
    let o = offset_origin(surf.p, ng, ls.wi);
    let shadow = if ls.dist.is_finite() {
        // Aim from the offset origin at the sampled point and stop just short of it.
        let to = surf.p + ls.wi * ls.dist - o;
        let len = to.length();
        let mut r = Ray::new(o, to / len);
        r.t_max = len * (1.0 - 1e-4);
        r
    } else {
        Ray::new(o, ls.wi)
    };
    *rays += 1;
    (!scene.occluded(&shadow)).then_some((f, wi))
}

/// Direct light at a vertex by uniform hemisphere sampling (`-H`): `light_samples` rays per
/// light (at least one), each adding the emission it finds. Delta lights cannot be found.
fn direct_hemisphere(
    scene: &Scene,
    v: &Vertex,
    sampler: &Sampler,
    depth: u32,
    s: &IntegratorSettings,
    rays: &mut u64,
) -> Rgb {
    let (surf, ng) = (v.surf, v.ng);
    let n = (s.light_samples.max(1) as usize * scene.lights.len().max(1)) as u32;
    let mut acc = Vec3::ZERO;
    for i in 0..n {
        let wi = uniform_hemisphere(sampler.get_2d_sub(dim::bounce(depth, dim::LIGHT_POINT), i, n));
        let wi_w = v.frame.to_world(wi);
        if wi_w.dot(ng) <= 0.0 {
            continue;
        }
        let f = v.bsdf.eval(v.wo, wi) * scene.shadowing(surf, wi_w);
        if f.max_element() <= 0.0 {
            continue;
        }
        let ray = Ray::new(offset_origin(surf.p, ng, wi_w), wi_w);
        *rays += 1;
        let le = match scene.intersect(&ray) {
            Some(_) if v.finite_left => Vec3::ZERO,
            Some(h) => scene.emitted(&scene.surface(&ray, &h), -wi_w),
            None => scene.escaped(wi_w),
        };
        acc += f * le * wi.z / UNIFORM_HEMISPHERE_PDF;
    }
    acc / n as f32
}
