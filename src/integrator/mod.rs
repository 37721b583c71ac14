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
use crate::math::{luminance, Ray, Rgb};
use crate::sampling::sampler::{dim, Sampler};
use crate::sampling::{uniform_hemisphere, UNIFORM_HEMISPHERE_PDF};
use crate::scene::{Scene, Surface, NO_LIGHT};
use crate::vertex::light_path::is_caustic;
use crate::vertex::shadow::reaches_light;
use crate::vertex::{
    choose_light, emission_found, escape_found, light_density, roulette, sample_direct, Found,
    PathContext, Scatterer, SurfaceVertex,
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
    let c = PathContext {
        scene,
        sampler,
        settings: s,
        guiding: g,
    };
    // `depth` is the index of the current hit: light arriving at hit `depth`, by light
    // sampling or through a delta bounce, belongs to bounce `depth`.
    for depth in 1..=s.max_depth {
        let bsdf = scene.bsdf(&p.surf);
        if bsdf.is_black() || !bounce(&c, &mut p, bsdf, depth, rays) {
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
#[inline]
pub(crate) fn bounce(
    c: &PathContext,
    p: &mut PathState,
    bsdf: Bsdf,
    depth: u32,
    rays: &mut u64,
) -> bool {
    let s = c.settings;
    let counts = |depth: u32| s.accumulate || depth == s.max_depth;
    let caustic = s.light_tracing && is_caustic(&bsdf);
    if depth == 1 {
        p.plain_first = s.light_tracing && !caustic;
    }
    let left = p.plain_first && caustic;
    let v = SurfaceVertex::new(c.scene, p.surf, bsdf, -p.ray.d);
    let delta = v.bsdf.is_delta();
    let samples_lights = matches!(s.direct, Direct::Mis | Direct::Light | Direct::Hemisphere);
    // Whether the continuation ray's emission counts (besides after delta lobes).
    let bsdf_finds = matches!(s.direct, Direct::Mis | Direct::Bsdf);
    if !delta && counts(depth) && samples_lights {
        let ld = if s.direct == Direct::Hemisphere {
            direct_hemisphere(c, &v, left, depth, rays)
        } else {
            let scatterer = Scatterer::Surface { v, interface: None };
            direct_lights(c, &scatterer, left, depth, rays)
        };
        p.l += p.beta * ld;
    }
    // The last bounce needs no continuation, except through a delta lobe or with MIS,
    // where the emission the continuation ray finds is (part of) this bounce's direct light.
    if depth == s.max_depth && !((delta || bsdf_finds) && counts(depth)) {
        return false;
    }
    let Some((bs, wi_w)) = v.sample(c.sampler, depth) else {
        return false;
    };
    p.beta *= bs.weight * c.scene.shadowing(&v.surf, wi_w);
    if bs.wi.z < 0.0 {
        p.eta_scale *= v.bsdf.radiance_scale(v.front);
    }
    let u = || c.sampler.get_1d(dim::bounce(depth, dim::ROULETTE));
    let effective = p.beta.max_element() / p.eta_scale;
    let Some(q) = roulette(depth, s.roulette_rule(), effective, u) else {
        return false;
    };
    p.beta /= q;
    if p.beta.max_element() <= 0.0 || !p.beta.is_finite() {
        return false;
    }
    p.ray = v.spawn(wi_w);
    let found = Found {
        from: v.surf.p,
        bsdf_pdf: bs.pdf,
        mis: s.direct == Direct::Mis && !bs.delta,
        beta: p.beta,
    };
    // Emission found by the continuation ray: all of it after a delta lobe, its
    // BSDF-sampling share with MIS, nothing otherwise (light sampling counted it).
    let counted = counts(depth) && (bs.delta || bsdf_finds);
    continue_path(c, p, found, counted && !left, counted, rays)
}

/// Traces path `p`'s continuation ray: moves it to the surface it finds (adding the emission
/// there where `at_surface`) or adds what the infinite lights give it where it leaves the
/// scene (where `escaping`). False when it leaves.
#[inline]
pub(crate) fn continue_path(
    c: &PathContext,
    p: &mut PathState,
    found: Found,
    at_surface: bool,
    escaping: bool,
    rays: &mut u64,
) -> bool {
    *rays += 1;
    let wi_w = p.ray.d;
    let (hit, passed_blocker) = c.scene.intersect_continuation(&p.ray);
    // Light sampling cannot reach what lies beyond a cut-out that blocks it.
    let found = Found {
        mis: found.mis && !passed_blocker,
        ..found
    };
    match hit {
        Some(h) => {
            p.surf = c.scene.surface(&p.ray, &h);
            if at_surface && p.surf.light != NO_LIGHT {
                p.l += emission_found(c.scene, c.settings, found, &p.surf, wi_w);
            }
            true
        }
        None => {
            if escaping {
                escape_found(c.scene, c.settings, c.guiding.guide, wi_w, found, &mut p.l);
            }
            false
        }
    }
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

/// Direct light at vertex `v` (hit `depth`) by light sampling: every light (`All`) or lights
/// chosen by power; light from finite emitters is left to light tracing where `left`.
fn direct_lights(c: &PathContext, v: &Scatterer, left: bool, depth: u32, rays: &mut u64) -> Rgb {
    let (scene, s) = (c.scene, c.settings);
    let n = s.light_samples.max(1);
    let draw = |salt: u32, i: u32, n: u32| LightDraw {
        sampler: c.sampler,
        depth,
        salt,
        i,
        n,
    };
    match s.selection {
        LightSelection::All => {
            let mut total = Vec3::ZERO;
            for j in 0..scene.lights.len() {
                let k = if scene.lights[j].is_delta() { 1 } else { n };
                // A pseudo-random slot offset per light (a distinct set of points).
                let salt = (j as u32).wrapping_mul(0x9E37_79B9);
                let mut acc = Vec3::ZERO;
                for i in 0..k {
                    acc += light_sample(c, v, left, j, draw(salt, i, k), rays);
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
                let d = draw(0, i, n);
                let (j, pmf) = choose_light(scene, || d.get_1d(dim::LIGHT_CHOICE));
                acc += light_sample(c, v, left, j, d, rays) / pmf;
            }
            acc / n as f32
        }
    }
}

/// One light sample of light `j` at vertex `v` ([`sample_direct`]): `f · |cos| · Li / pdf`,
/// MIS-weighted against BSDF sampling when the estimator is [`Direct::Mis`]. A training run
/// records the samples of its environment light ([`crate::guide::Recorder`]).
fn light_sample(
    c: &PathContext,
    v: &Scatterer,
    left: bool,
    j: usize,
    draw: LightDraw,
    rays: &mut u64,
) -> Rgb {
    let (scene, s) = (c.scene, c.settings);
    let light = &scene.lights[j];
    if left && light.is_finite_emitter() {
        return Vec3::ZERO;
    }
    let u = draw.get_2d(dim::LIGHT_POINT);
    let shadow = |o, d, target, _| reaches_light(scene, o, d, target, rays).then_some(());
    let Some((ls, reached)) = sample_direct(c, v, 0, (j, u), shadow) else {
        return Vec3::ZERO;
    };
    if let Some(r) = c.guiding.record.filter(|r| r.light == j) {
        let value = match reached {
            Some(_) => luminance(ls.li) * v.cosine(ls.wi) / ls.pdf,
            None => 0.0,
        };
        r.record(v.position(), ls.wi, value);
    }
    let Some((t, ())) = reached else {
        return Vec3::ZERO;
    };
    let w = if s.direct == Direct::Mis && !light.is_delta() {
        power_heuristic(1.0, light_density(scene, s, j, ls.pdf), 1.0, v.pdf(&t))
    } else {
        1.0
    };
    t.f * ls.li * (w / ls.pdf)
}

/// Direct light at vertex `v` by uniform hemisphere sampling (`-H`): `light_samples` rays per
/// light (at least one), each adding the emission it finds (none from finite emitters where
/// `left`). Delta lights cannot be found.
fn direct_hemisphere(
    c: &PathContext,
    v: &SurfaceVertex,
    left: bool,
    depth: u32,
    rays: &mut u64,
) -> Rgb {
    let scene = c.scene;
    let n = (c.settings.light_samples.max(1) as usize * scene.lights.len().max(1)) as u32;
    let slot = dim::bounce(depth, dim::LIGHT_POINT);
    let mut acc = Vec3::ZERO;
    for i in 0..n {
        let wi = uniform_hemisphere(c.sampler.get_2d_sub(slot, i, n));
        let wi_w = v.frame.to_world(wi);
        if wi_w.dot(v.ng) <= 0.0 {
            continue;
        }
        let f = v.bsdf.eval(v.wo, wi) * scene.shadowing(&v.surf, wi_w);
        if f.max_element() <= 0.0 {
            continue;
        }
        let ray = v.spawn(wi_w);
        *rays += 1;
        let le = match scene.intersect(&ray) {
            Some(_) if left => Vec3::ZERO,
            Some(h) => scene.emitted(&scene.surface(&ray, &h), -wi_w),
            None => scene.escaped(wi_w),
        };
        acc += f * le * wi.z / UNIFORM_HEMISPHERE_PDF;
    }
    acc / n as f32
}
