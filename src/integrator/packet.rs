//! Eight camera samples of one pixel traced together ("packets"), for scenes with a diffuse
//! surface rendered with the default direct light estimator (MIS, one light sample per vertex
//! chosen by power) and all bounces summed.
//!
//! Each bounce has three stages. Per lane: the surface, its BSDF and (except for a lone
//! rectangle light) a light sample; a path at a non-diffuse surface takes the whole bounce
//! here, with the scalar integrator's own `bounce`. On all eight lanes at once, in SIMD
//! ([`wide::f32x8`]), for the paths at a diffuse surface: the shading frame, the rectangle
//! light's sample, the BSDF value and MIS weight, the shadow ray, the cosine-weighted
//! continuation and Russian roulette. Per lane again: their shadow and continuation rays. The
//! sample numbers of a slot are drawn for the eight lanes at once
//! ([`Sampler::get_2d_lanes`]).
//!
//! The facing, the frame, the side check, the cosine-weighted sample, the power heuristic,
//! the origin offset and the roulette rule are the scalar code's own routines at eight lanes
//! ([`crate::lanes`], [`crate::vertex`]). Every lane does the scalar
//! integrator's operations in the same order (glam's component order, the same polynomial for
//! sine and cosine, no fused multiply-adds), so each sample's
//! radiance is bit-identical to [`crate::integrator::radiance`]: images do not depend on
//! which samples went through packets (the tests below compare every lane's bits).

use super::{bounce, continue_path, start, PathState};
use crate::bsdf::Bsdf;
use crate::guide::{EnvGuide, GuidedSample};
use crate::lanes::{
    cosine_hemisphere, facing, frame_from_normal, offset_origin, power_heuristic, sides_agree,
};
use crate::light::env::{BlockSample, EnvLight};
use crate::light::{Light, LightSample};
use crate::math::{Ray, Rgb};
use crate::sampling::sampler::{dim, Sampler};
use crate::scene::{Scene, Surface};
use crate::vertex::{
    choose_light, light_density, roulette_ends, survival, Direct, Found, Guiding,
    IntegratorSettings, LightSelection, PathContext,
};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use wide::f32x8;

/// Paths per packet.
pub const LANES: usize = 8;

/// Whether [`radiance8`] can trace `scene` with settings `s`: MIS with one light sample per
/// vertex chosen by power, all bounces summed, no media and some diffuse surface (diffuse vertices are
/// shaded on eight lanes at once, the others one by one with the scalar integrator's code).
pub fn supported(scene: &Scene, s: &IntegratorSettings) -> bool {
    s.direct == Direct::Mis
        && s.selection == LightSelection::Power
        && s.light_samples == 1
        && s.accumulate
        && !scene.volumetric
        && scene
            .materials
            .iter()
            .any(|m| matches!(m.bsdf, Bsdf::Diffuse { .. }))
}

/// The scene's only light when it is a one-sided untextured parallelogram, sampled inside the
/// vector stage: corner, edges, normal, 1 / area, radiance and selection probability.
#[derive(Clone, Copy)]
struct Quad {
    o: Vec3,
    e1: Vec3,
    e2: Vec3,
    n: Vec3,
    pdf_area: f32,
    li: Rgb,
    pmf: f32,
}

impl Quad {
    /// The rectangle light of `scene`, if that is its only light.
    fn of(scene: &Scene) -> Option<Quad> {
        match scene.lights.as_slice() {
            [Light::Area {
                quad: Some(q),
                normal: Some(n),
                texture: None,
                area,
                radiance,
                ..
            }] if radiance.max_element() > 0.0 => Some(Quad {
                o: q.o,
                e1: q.e1,
                e2: q.e2,
                n: *n,
                pdf_area: 1.0 / area,
                li: *radiance,
                pmf: scene.light_pmf(0),
            }),
            _ => None,
        }
    }
}

/// Eight `Vec3`s, one per lane, component by component.
#[derive(Clone, Copy, Default)]
struct A3 {
    x: [f32; LANES],
    y: [f32; LANES],
    z: [f32; LANES],
}

impl A3 {
    fn splat(v: Vec3) -> A3 {
        A3 {
            x: [v.x; LANES],
            y: [v.y; LANES],
            z: [v.z; LANES],
        }
    }
    #[inline]
    fn set(&mut self, i: usize, v: Vec3) {
        (self.x[i], self.y[i], self.z[i]) = (v.x, v.y, v.z);
    }
    #[inline]
    fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }
    #[inline(always)]
    fn load(&self) -> V3 {
        V3 {
            x: f32x8::from(self.x),
            y: f32x8::from(self.y),
            z: f32x8::from(self.z),
        }
    }
    #[inline(always)]
    fn store(&mut self, v: V3) {
        (self.x, self.y, self.z) = (v.x.to_array(), v.y.to_array(), v.z.to_array());
    }
}

/// Eight lanes of a `Vec3`.
type V3 = crate::lanes::V3<f32x8>;

/// All bits set: a comparison's true.
#[inline(always)]
fn ones() -> f32x8 {
    f32x8::splat(f32::from_bits(u32::MAX))
}

/// Lane-wise `!m` of a mask.
#[inline(always)]
fn not(m: f32x8) -> f32x8 {
    m ^ ones()
}

/// Lanes of a mask as bits (bit `i` set where lane `i` is true).
#[inline(always)]
fn bits(m: f32x8) -> u32 {
    m.to_bitmask()
}

/// Inputs of the vector stage of one bounce.
#[derive(Clone, Copy, Default)]
struct In {
    p: A3,
    ng: A3,
    ns: A3,
    d: A3,
    albedo: A3,
    beta: A3,
    /// [`PathState::eta_scale`] per lane.
    eta: [f32; LANES],
    ul: [Vec2; LANES],
    ub: [Vec2; LANES],
    urr: [f32; LANES],
    /// A light sample drawn per lane (without a [`Quad`]): 1 where there is one, its
    /// direction, distance, radiance, pdf, density for MIS, 1 for a delta light (weight 1)
    /// and the probability of choosing its light.
    has: [f32; LANES],
    lwi: A3,
    dist: [f32; LANES],
    li: A3,
    lpdf: [f32; LANES],
    dens: [f32; LANES],
    delta: [f32; LANES],
    sel: [f32; LANES],
}

/// Outputs of the vector stage of one bounce.
#[derive(Clone, Copy, Default)]
struct Out {
    /// Light sample: lanes that trace a shadow ray (bits), and its ray.
    shadow: u32,
    so: A3,
    sd: A3,
    st: [f32; LANES],
    /// Contribution if unoccluded (already times `beta`).
    c: A3,
    /// Continuation: lanes that go on (bits), ray origin and direction, new beta, BSDF pdf.
    cont: u32,
    o: A3,
    wi: A3,
    beta: A3,
    pdf: [f32; LANES],
}

/// The vector stage: the scalar integrator's shading of a diffuse vertex, on eight lanes;
/// `rr`: the roulette's survival scale where it is played at this vertex.
#[inline(never)]
fn shade(inp: &In, out: &mut Out, quad: Option<Quad>, rr: Option<f32>) {
    let zero = f32x8::ZERO;
    let one = f32x8::splat(1.0);
    let p = inp.p.load();
    let wo_w = -inp.d.load();
    let (_, ng, ns) = facing(inp.ng.load(), inp.ns.load(), wo_w);
    let (fs, ft) = frame_from_normal(ns);
    let to_local = |v: V3| V3 {
        x: v.dot(fs),
        y: v.dot(ft),
        z: v.dot(ns),
    };
    let wo = to_local(wo_w);
    let albedo = inp.albedo.load();
    let beta = inp.beta.load();
    let u = |a: &[Vec2; LANES]| {
        (
            f32x8::from(std::array::from_fn::<f32, LANES, _>(|i| a[i].x)),
            f32x8::from(std::array::from_fn::<f32, LANES, _>(|i| a[i].y)),
        )
    };
    // The light sample: on the parallelogram here (`Light::from_point`), or as drawn.
    let (has, lwi, dist, li, lpdf, dens, delta, sel) = match quad {
        Some(q) => {
            let (ux, uy) = u(&inp.ul);
            let d = V3::splat(q.o) + V3::splat(q.e1).scale(ux) + V3::splat(q.e2).scale(uy) - p;
            let d2 = d.dot(d);
            let dist = d2.sqrt();
            let lwi = d / dist;
            let cos_l = -lwi.dot(V3::splat(q.n));
            let lpdf = f32x8::splat(q.pdf_area) * d2 / cos_l;
            let has = not(d2.simd_eq(zero)) & cos_l.simd_gt(zero);
            let dens = f32x8::splat(1.0 * q.pmf) * lpdf;
            (has, lwi, dist, V3::splat(q.li), lpdf, dens, zero, one)
        }
        None => (
            not(f32x8::from(inp.has).simd_eq(zero)),
            inp.lwi.load(),
            f32x8::from(inp.dist),
            inp.li.load(),
            f32x8::from(inp.lpdf),
            f32x8::from(inp.dens),
            not(f32x8::from(inp.delta).simd_eq(zero)),
            f32x8::from(inp.sel),
        ),
    };
    let side = lwi.dot(ng);
    let wi = to_local(lwi);
    let f_ok = wo.z.simd_gt(zero) & wi.z.simd_gt(zero);
    let f = V3::select(
        f_ok,
        albedo.scale(f32x8::splat(FRAC_1_PI)),
        V3::splat(Vec3::ZERO),
    );
    // As `light_sample`: no light behind the surface (a diffuse BSDF does not transmit),
    // shading and geometric sides agreeing, a non-zero BSDF value.
    let ok = has
        & sides_agree(side, wi.z)
        & not(side.simd_lt(zero))
        & not(f.max_element().simd_le(zero));
    let so = offset_origin(p, ng, lwi);
    let to = p + lwi.scale(dist) - so;
    let len = to.dot(to).sqrt();
    let finite = dist.is_finite();
    out.shadow = bits(ok);
    out.so.store(so);
    out.sd.store(V3::select(finite, to / len, lwi));
    out.st = finite
        .select(len * f32x8::splat(1.0 - 1e-4), f32x8::splat(f32::INFINITY))
        .to_array();
    let bpdf = f_ok.select(wi.z.max(zero) * f32x8::splat(FRAC_1_PI), zero);
    let w = delta.select(one, power_heuristic(dens, bpdf));
    let ld = (f.scale(wi.z.abs()) * li).scale(w / lpdf) / sel;
    out.c.store(beta * ld);
    // BSDF sample.
    let (bx, by) = u(&inp.ub);
    let bwi = cosine_hemisphere(bx, by);
    let pdf = bwi.z.max(zero) * f32x8::splat(FRAC_1_PI);
    let wi_w = fs.scale(bwi.x) + ft.scale(bwi.y) + ns.scale(bwi.z);
    let c = wi_w.dot(ng);
    let mut cont = not(wo.z.simd_le(zero)) & pdf.simd_gt(zero) & sides_agree(c, bwi.z);
    let mut nb = beta * albedo;
    if let Some(scale) = rr {
        let q = survival(nb.max_element() / f32x8::from(inp.eta), scale);
        cont &= not(roulette_ends(q, f32x8::from(inp.urr)));
        nb = nb / q;
    }
    cont &= not(nb.max_element().simd_le(zero) | not(nb.is_finite()));
    out.cont = bits(cont);
    out.beta.store(nb);
    out.o.store(offset_origin(p, ng, wi_w));
    out.wi.store(wi_w);
    out.pdf = pdf.to_array();
}

/// Radiance of eight camera rays (as [`crate::integrator::radiance`] on each, bit for bit);
/// `rays[i]` counts lane `i`'s rays.
pub fn radiance8(
    scene: &Scene,
    cam: &[Ray; LANES],
    samplers: &[Sampler; LANES],
    s: &IntegratorSettings,
    guide: Option<&EnvGuide>,
    rays: &mut [u64; LANES],
) -> [Rgb; LANES] {
    let packet = Packet {
        scene,
        samplers,
        settings: s,
        guide,
        guiding: Guiding::with(guide),
        quad: Quad::of(scene),
        shared: Sampler::shared_sobol(samplers),
    };
    let (m, rule) = (s.max_depth, s.roulette_rule());
    let mut lanes = packet.start_paths(cam, rays);
    let mut inp = In {
        ng: A3::splat(Vec3::Y),
        ns: A3::splat(Vec3::Y),
        beta: A3::splat(Vec3::ONE),
        eta: [1.0; LANES],
        dist: [1.0; LANES],
        lpdf: [1.0; LANES],
        sel: [1.0; LANES],
        ..In::default()
    };
    let mut out = Out::default();
    for depth in 1..=m {
        if lanes.paths.iter().all(Option::is_none) {
            break;
        }
        let rr = rule.plays_at(depth);
        let uc = packet.draw_numbers(&mut inp, depth, rr);
        let diffuse = packet.gather_diffuse(&mut lanes, &mut inp, uc, depth, rays);
        if !diffuse.iter().any(|&d| d) {
            continue;
        }
        shade(&inp, &mut out, packet.quad, rr.then_some(rule.scale));
        packet.trace_diffuse(&mut lanes, &out, diffuse, rays);
    }
    for i in 0..LANES {
        if let Some(p) = &lanes.paths[i] {
            lanes.l[i] = p.l;
        }
    }
    lanes.l
}

/// What the eight paths of a packet draw on: the scene, their samplers, the settings, the
/// environment guide, the scene's rectangle light (if that is its only light) and whether
/// the samplers share one Sobol sequence.
struct Packet<'a> {
    scene: &'a Scene,
    samplers: &'a [Sampler; LANES],
    settings: &'a IntegratorSettings,
    guide: Option<&'a EnvGuide>,
    guiding: Guiding<'a>,
    quad: Option<Quad>,
    shared: bool,
}

/// The eight paths of a packet: each one's state while it goes on, and its radiance (set
/// when it ends).
struct Lanes {
    paths: [Option<PathState>; LANES],
    l: [Rgb; LANES],
}

impl<'a> Packet<'a> {
    /// The scalar integrator's context of lane `i`'s path.
    #[inline(always)]
    fn context(&self, i: usize) -> PathContext<'a> {
        PathContext {
            scene: self.scene,
            sampler: &self.samplers[i],
            settings: self.settings,
            guiding: self.guiding,
        }
    }

    /// The paths of camera rays `cam` at their first hits; a ray that leaves the scene ends
    /// its path with the light it escapes to.
    #[inline(always)]
    fn start_paths(&self, cam: &[Ray; LANES], rays: &mut [u64; LANES]) -> Lanes {
        let scene = self.scene;
        let mut lanes = Lanes {
            paths: [None; LANES],
            l: [Vec3::ZERO; LANES],
        };
        for i in 0..LANES {
            lanes.paths[i] = start(scene, cam[i], self.settings, &mut rays[i]);
            if lanes.paths[i].is_none() {
                lanes.l[i] = scene.escaped(cam[i].d);
            }
        }
        lanes
    }

    /// Draws the lanes' numbers of bounce `depth` into `inp`: light point, BSDF direction
    /// and (where `rr`) roulette; returns the light choice numbers (0 where none is chosen).
    #[inline(always)]
    fn draw_numbers(&self, inp: &mut In, depth: u32, rr: bool) -> [f32; LANES] {
        let (samplers, shared) = (self.samplers, self.shared);
        inp.ul = Sampler::get_2d_lanes(samplers, shared, dim::bounce(depth, dim::LIGHT_POINT));
        inp.ub = Sampler::get_2d_lanes(samplers, shared, dim::bounce(depth, dim::BSDF_DIRECTION));
        if rr {
            inp.urr = Sampler::get_1d_lanes(samplers, shared, dim::bounce(depth, dim::ROULETTE));
        }
        if self.quad.is_none() && self.scene.lights.len() > 1 {
            Sampler::get_1d_lanes(samplers, shared, dim::bounce(depth, dim::LIGHT_CHOICE))
        } else {
            [0.0; LANES]
        }
    }

    /// Bounce `depth` of the paths at a non-diffuse surface, with the scalar integrator's
    /// code; the others' vertices (and light samples drawn with the light choice numbers
    /// `uc`) go into `inp`. Returns which lanes are at a diffuse vertex.
    #[inline(always)]
    fn gather_diffuse(
        &self,
        lanes: &mut Lanes,
        inp: &mut In,
        uc: [f32; LANES],
        depth: u32,
        rays: &mut [u64; LANES],
    ) -> [bool; LANES] {
        let scene = self.scene;
        // Lanes at a diffuse vertex, shaded in the vector stage.
        let mut diffuse = [false; LANES];
        for i in 0..LANES {
            let Some(p) = &mut lanes.paths[i] else {
                continue;
            };
            let albedo = match scene.plain_diffuse_albedo(&p.surf) {
                Some(albedo) => albedo,
                None => {
                    let bsdf = scene.bsdf(&p.surf);
                    let Some(albedo) = lambertian(scene, &p.surf, bsdf) else {
                        // Any other BSDF: this bounce with the scalar integrator's code.
                        let alive = !bsdf.is_black()
                            && bounce(&self.context(i), p, bsdf, depth, &mut rays[i]);
                        if !alive {
                            lanes.l[i] = p.l;
                            lanes.paths[i] = None;
                        }
                        continue;
                    };
                    albedo
                }
            };
            diffuse[i] = true;
            if depth == 1 {
                // A diffuse surface is no caustic surface (`bounce`).
                p.plain_first = self.settings.light_tracing;
            }
            inp.p.set(i, p.surf.p);
            inp.ng.set(i, p.surf.ng);
            inp.ns.set(i, p.surf.ns);
            inp.d.set(i, p.ray.d);
            inp.beta.set(i, p.beta);
            inp.eta[i] = p.eta_scale;
            inp.albedo.set(i, albedo);
        }
        if self.quad.is_none() {
            self.draw_lights(inp, diffuse, uc);
        }
        diffuse
    }

    /// The `diffuse` lanes' light samples (without a [`Quad`]) from their light choice
    /// numbers `uc` and point numbers, into `inp`. Guided environment samples are taken in
    /// steps ([`EnvStep`]), each lane's step before any lane's next, so that the lanes' reads
    /// of the map overlap.
    #[inline(always)]
    fn draw_lights(&self, inp: &mut In, diffuse: [bool; LANES], uc: [f32; LANES]) {
        let scene = self.scene;
        let mut chosen: [Option<(usize, f32)>; LANES] = [None; LANES];
        let mut steps: [Option<EnvStep>; LANES] = [None; LANES];
        for i in (0..LANES).filter(|&i| diffuse[i]) {
            inp.has[i] = 0.0;
            if scene.light_selection.total() <= 0.0 {
                continue;
            }
            let (j, pmf) = choose_light(scene, || uc[i]);
            chosen[i] = Some((j, pmf));
            steps[i] = EnvStep::start(scene, j, self.guide, inp.p.get(i), inp.ul[i]);
        }
        for _ in 0..EnvStep::STEPS {
            steps.iter_mut().flatten().for_each(EnvStep::advance);
        }
        for i in 0..LANES {
            let Some((j, pmf)) = chosen[i] else {
                continue;
            };
            let ls = match steps[i] {
                Some(step) => step.finish(),
                None => scene.sample_light(j, inp.p.get(i), inp.ul[i], self.guide),
            };
            store_light(scene, self.settings, (j, pmf), ls, inp, i);
        }
    }

    /// The diffuse lanes' shadow rays (adding the light of those unoccluded) and
    /// continuations, from the vector stage's output `out`; ends the paths that stop.
    #[inline(always)]
    fn trace_diffuse(
        &self,
        lanes: &mut Lanes,
        out: &Out,
        diffuse: [bool; LANES],
        rays: &mut [u64; LANES],
    ) {
        for i in 0..LANES {
            let Some(p) = lanes.paths[i].as_mut().filter(|_| diffuse[i]) else {
                continue;
            };
            if out.shadow >> i & 1 == 1 {
                rays[i] += 1;
                let mut r = Ray::new(out.so.get(i), out.sd.get(i));
                r.t_max = out.st[i];
                if !self.scene.light_occluded(&r) {
                    p.l += out.c.get(i);
                }
            }
            let alive = out.cont >> i & 1 == 1 && {
                let found = Found {
                    from: p.surf.p,
                    bsdf_pdf: out.pdf[i],
                    mis: true,
                    beta: out.beta.get(i),
                };
                p.beta = found.beta;
                p.ray = Ray::new(out.o.get(i), out.wi.get(i));
                continue_path(&self.context(i), p, found, true, true, &mut rays[i])
            };
            if !alive {
                lanes.l[i] = p.l;
                lanes.paths[i] = None;
            }
        }
    }
}

/// A guided environment light sample part way through its steps: at its region, or with
/// its block or its cell chosen. Each step asks for what the next one reads.
#[derive(Clone, Copy)]
enum EnvStep<'a> {
    Region(&'a EnvGuide, &'a EnvLight, GuidedSample),
    Block(&'a EnvLight, BlockSample),
    Cell(&'a EnvLight, BlockSample),
}

impl<'a> EnvStep<'a> {
    /// How many times [`EnvStep::advance`] takes every sample to its last step.
    const STEPS: usize = 2;

    /// The first step of a light sample of light `j` at `p` from numbers `u`, where `j` is
    /// the environment map `guide` guides.
    #[inline(always)]
    fn start(
        scene: &'a Scene,
        j: usize,
        guide: Option<&'a EnvGuide>,
        p: Vec3,
        u: Vec2,
    ) -> Option<EnvStep<'a>> {
        let (g, e) = scene.guided_environment(j, guide)?;
        Some(EnvStep::Region(g, e, g.start(p, u)))
    }

    /// The next step (none after the last; a sample without a block stays put).
    #[inline(always)]
    fn advance(&mut self) {
        *self = match *self {
            EnvStep::Region(g, e, s) => match s.choose_block(g, e) {
                Some(b) => EnvStep::Block(e, b),
                None => return,
            },
            EnvStep::Block(e, mut b) => {
                b.choose_cell(e);
                EnvStep::Cell(e, b)
            }
            last => last,
        }
    }

    /// The sample, after the last step (`None` where it has none).
    #[inline(always)]
    fn finish(self) -> Option<LightSample> {
        match self {
            EnvStep::Cell(e, b) => b.finish(e).map(LightSample::from),
            _ => None,
        }
    }
}

/// The albedo of a diffuse surface that the vector stage shades: Mitsuba's one- and two-sided
/// materials and normal-map shadowing are the scalar integrator's to apply.
#[inline]
fn lambertian(scene: &Scene, surf: &Surface, bsdf: Bsdf) -> Option<Rgb> {
    match bsdf {
        Bsdf::Diffuse { albedo }
            if !scene.has_scalar_only || !scene.materials[surf.material as usize].scalar_only =>
        {
            Some(albedo)
        }
        _ => None,
    }
}

/// Lane `i`'s light sample `ls` of light `j` (chosen with probability `pmf`) into `inp`,
/// where it is one that counts (a positive pdf and radiance).
fn store_light(
    scene: &Scene,
    s: &IntegratorSettings,
    (j, pmf): (usize, f32),
    ls: Option<LightSample>,
    inp: &mut In,
    i: usize,
) {
    let valid =
        |ls: &LightSample| !(ls.pdf.is_nan() || ls.pdf <= 0.0 || ls.li.max_element() <= 0.0);
    if let Some(ls) = ls.filter(valid) {
        inp.has[i] = 1.0;
        inp.lwi.set(i, ls.wi);
        inp.dist[i] = ls.dist;
        inp.li.set(i, ls.li);
        inp.lpdf[i] = ls.pdf;
        inp.delta[i] = if scene.lights[j].is_delta() { 1.0 } else { 0.0 };
        inp.dens[i] = light_density(scene, s, j, ls.pdf);
        inp.sel[i] = pmf;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builtin::cornell_box;
    use crate::error::Loc;
    use crate::io::desc::{LightDesc, LightKind, MaterialKind, ShapeDesc};
    use crate::io::image::Image;
    use crate::light::env::{EnvLight, EnvSampling};
    use crate::sampling::sampler::{SamplerKind, SamplerSetup};
    use crate::scene::build::build;
    use glam::Mat4;

    /// Compares [`radiance8`] with the scalar integrator on every lane of packets spread
    /// over a 24 × 18 frame: the radiance's bits and the ray counts.
    fn check(scene: &Scene, s: &IntegratorSettings, kind: SamplerKind) {
        assert!(supported(scene, s));
        let (w, h, spp) = (24u32, 18u32, 16u32);
        let setup = SamplerSetup::new(kind, 7, w, h, spp);
        let mut nonzero = 0;
        for y in 0..h {
            for x in 0..w {
                for k0 in (0..spp).step_by(LANES) {
                    let lanes: [(Ray, Sampler); LANES] = std::array::from_fn(|i| {
                        let sm = setup.sample(x, y, k0 + i as u32);
                        let j = sm.get_2d(dim::PIXEL);
                        let ray =
                            scene
                                .camera
                                .ray(x as f32 + j.x, y as f32 + j.y, w, h, Vec2::ZERO);
                        (ray, sm)
                    });
                    let mut n8 = [0u64; LANES];
                    let l8 = radiance8(
                        scene,
                        &lanes.map(|l| l.0),
                        &lanes.map(|l| l.1),
                        s,
                        None,
                        &mut n8,
                    );
                    for (i, (ray, sm)) in lanes.iter().enumerate() {
                        let mut n = 0u64;
                        let l = crate::integrator::radiance(
                            scene,
                            *ray,
                            sm,
                            s,
                            Guiding::default(),
                            &mut n,
                        );
                        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                        assert_eq!(
                            bits(l8[i]),
                            bits(l),
                            "pixel ({x}, {y}) sample {}: {} vs {}",
                            k0 + i as u32,
                            l8[i],
                            l
                        );
                        assert_eq!(n8[i], n);
                        nonzero += (l != Vec3::ZERO) as u32;
                    }
                }
            }
        }
        // The comparison must see light, not only black samples.
        assert!(nonzero > w * h * spp / 2, "{nonzero}");
    }

    fn settings(max_depth: u32, rr_depth: u32) -> IntegratorSettings {
        IntegratorSettings {
            max_depth,
            rr_depth,
            ..IntegratorSettings::default()
        }
    }

    #[test]
    fn packets_match_the_scalar_integrator_under_a_rectangle_light() {
        // The built-in box: one rectangle light (sampled in the vector stage), a sphere.
        let scene = build(&cornell_box());
        assert!(Quad::of(&scene).is_some());
        for kind in SamplerKind::ALL {
            check(&scene, &settings(100, 3), kind);
        }
        check(&scene, &settings(2, 5), SamplerKind::Sobol);
    }

    #[test]
    fn packets_match_the_scalar_integrator_under_every_light_type() {
        // Several lights (chosen by power per lane): delta lights, an ambient sky and an
        // environment map (shadow rays without an end, escaping continuations).
        let mut desc = cornell_box();
        let light = |kind: LightKind, t: Mat4| LightDesc {
            name: "extra".into(),
            kind,
            transform: t,
            loc: Loc::default(),
        };
        desc.lights.extend([
            light(
                LightKind::Point {
                    intensity: Vec3::new(0.5, 0.4, 0.3),
                },
                Mat4::from_translation(Vec3::new(0.3, 1.5, 0.2)),
            ),
            light(
                LightKind::Spot {
                    intensity: Vec3::splat(2.0),
                    falloff_angle_deg: 50.0,
                    falloff_exponent: 2.0,
                    falloff_start_deg: None,
                    linear_falloff: false,
                },
                Mat4::from_translation(Vec3::new(-0.4, 1.8, 0.5)) * Mat4::from_rotation_x(-1.2),
            ),
            light(
                LightKind::Directional {
                    irradiance: Vec3::splat(0.7),
                },
                Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)),
            ),
            light(
                LightKind::Ambient {
                    radiance: Vec3::splat(0.2),
                },
                Mat4::IDENTITY,
            ),
        ]);
        // An open box: drop the ceiling and the front of the room is open already.
        desc.shapes
            .retain(|s| !matches!(s, ShapeDesc::Mesh { name, .. } if name == "ceiling"));
        let mut scene = build(&desc);
        let mut img = Image::new(16, 8);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::new(1.0 + (i % 5) as f32, 0.5 + (i % 3) as f32, 2.0);
        }
        scene.add_light(Light::Environment(EnvLight::new(
            img,
            EnvSampling::Importance,
        )));
        assert!(Quad::of(&scene).is_none() && scene.lights.len() == 6);
        for kind in SamplerKind::ALL {
            check(&scene, &settings(100, 2), kind);
        }
    }

    #[test]
    fn packets_match_the_scalar_integrator_with_other_materials() {
        // Glass, mirror, microfacet and metallic-roughness vertices go through the scalar
        // code inside the packet; with light tracing on, paths leave caustic light to it.
        let mut desc = cornell_box();
        desc.materials[4].kind = MaterialKind::Glass {
            reflectance: Vec3::ONE,
            transmittance: Vec3::ONE,
            roughness: 0.0,
            ior: 1.5,
        };
        desc.materials[3].kind = MaterialKind::Mirror {
            reflectance: Vec3::splat(0.9),
        };
        desc.materials[2].kind = MaterialKind::Microfacet {
            alpha: 0.3,
            eta: Vec3::new(0.2, 0.9, 1.1),
            k: Vec3::new(3.9, 2.4, 2.2),
        };
        desc.materials[1].kind = MaterialKind::MetallicRoughness {
            base: Vec3::new(0.8, 0.2, 0.1),
            metallic: 0.3,
            roughness: 0.4,
            transmission: 0.0,
            ior: 1.5,
        };
        let scene = build(&desc);
        for lt in [false, true] {
            for kind in SamplerKind::ALL {
                let s = IntegratorSettings {
                    light_tracing: lt,
                    ..settings(100, 3)
                };
                check(&scene, &s, kind);
            }
        }
    }

    #[test]
    fn scenes_with_a_diffuse_surface_and_the_default_estimator_take_packets() {
        let scene = build(&cornell_box());
        assert!(supported(&scene, &IntegratorSettings::default()));
        for s in [
            IntegratorSettings {
                light_samples: 2,
                ..Default::default()
            },
            IntegratorSettings {
                direct: Direct::Light,
                ..Default::default()
            },
            IntegratorSettings {
                selection: LightSelection::All,
                ..Default::default()
            },
            IntegratorSettings {
                accumulate: false,
                ..Default::default()
            },
        ] {
            assert!(!supported(&scene, &s));
        }
        let mut desc = cornell_box();
        for m in &mut desc.materials {
            m.kind = MaterialKind::Mirror {
                reflectance: Vec3::ONE,
            };
        }
        assert!(!supported(&build(&desc), &IntegratorSettings::default()));
    }
}
