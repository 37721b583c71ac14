//! The volumetric path tracer: paths through participating media and across the surfaces
//! that bound them, for scenes that have media or null surfaces ([`Scene::volumetric`]).
//!
//! It follows pbrt-v4's `VolPathIntegrator` in RGB:
//! - **Free flights** sample a collision distance from the extinction of one *hero* channel,
//!   chosen uniformly per path. A collision always scatters, its weight the albedo
//!   (`σs·T / (σt,h·T_h)`, Mitsuba's choice; pbrt-v4 kills the path with the absorption
//!   probability instead, same expectation). A flight that reaches the next surface
//!   weighs `T / T_h`. Grid media are delta-tracked against their majorant grid
//!   (`flight.rs`), and emission from media is gathered along every flight.
//! - **Spectral MIS**: `r_u` holds, per channel λ, the density of the path so far with λ as
//!   the hero over its density with the hero actually used, so every estimate divides by
//!   the channel average of `r_u` (the balance heuristic over the three heroes: chromatic
//!   media without bias or fireflies). `r_l` holds the same ratio for light sampling ending
//!   the path at the next emitter; the two combine by the balance heuristic.
//! - **Next-event estimation** at every non-delta surface vertex and every medium collision:
//!   one light chosen by power, its shadow ray crossing null surfaces, its transmittance the
//!   exact Beer-Lambert product of the homogeneous media it crosses and ratio tracking's
//!   estimate through grids. Light sampling's density has no transmittance (through grids,
//!   the density of its tracking decisions); phase or BSDF sampling's has the probability
//!   that its flight passes; the weights use exactly these (`flight::Transmission`).
//! - **Null surfaces** (pbrt-v4's `interface`, Mitsuba's `null`) change the medium and count
//!   as no bounce; any surface with a [`crate::medium::MediumInterface`] sets the medium on
//!   the side a path leaves it by. A surface without one keeps the ray's medium.
//! - **Bounces** count scattering events, surface or medium, as the surface path tracer
//!   counts hits ([`crate::integrator`]): max depth `m` lights `m` vertices. Russian roulette
//!   from [`IntegratorSettings::rr_depth`] on, on the throughput over the average of `r_u`.
//!
//! Random numbers: per vertex the camera paths' block of sampler dimensions ([`dim::bounce`],
//! vertex 0 the camera); the flights that a null crossing restarts draw from a per-path
//! generator seeded by the sampler.

use crate::math::{offset_origin, Ray, Rgb};
use crate::medium::sample_hg;
use crate::sampling::sampler::dim;
use crate::sampling::Rng;
use crate::scene::{Scene, Surface, NO_LIGHT};
use crate::vertex::flight::{average, flight, Flight, Weights};
use crate::vertex::light_path::passes;
use crate::vertex::shadow::{shadow_transmittance, ShadowRay, MAX_CROSSINGS};
use crate::vertex::{
    choose_light, roulette, sample_direct, Direct, Guiding, IntegratorSettings, PathContext,
    Scatterer, SurfaceVertex,
};
use glam::Vec3;

/// Radiance along camera ray `ray` in `scene` (see the module); `rays` counts every ray
/// traced.
pub fn radiance(
    scene: &Scene,
    ray: Ray,
    sampler: &crate::sampling::sampler::Sampler,
    s: &IntegratorSettings,
    g: Guiding,
    rays: &mut u64,
) -> Rgb {
    let hero = ((sampler.get_1d(dim::bounce(0, dim::HERO)) * 3.0) as usize).min(2);
    let seed = (sampler.get_1d(dim::bounce(0, dim::SEED)) * 4_294_967_296.0) as u64;
    let mut path = Path {
        w: Weights {
            beta: Vec3::ONE,
            r_u: Vec3::ONE,
            r_l: Vec3::ONE,
            hero,
        },
        l: Vec3::ZERO,
        ray,
        medium: scene.camera_medium,
        depth: 0,
        specular: true,
        prev: ray.o,
        eta_scale: 1.0,
        rng: Rng::new(seed, 0x0F11),
        flights: 0,
        left: false,
        last_delta: false,
    };
    let c = PathContext {
        scene,
        sampler,
        settings: s,
        guiding: g,
    };
    path.trace(&c, rays);
    path.l
}

/// The state of one path.
struct Path {
    w: Weights,
    /// Radiance gathered.
    l: Rgb,
    /// The ray the path travels along.
    ray: Ray,
    /// The medium `ray` travels in.
    medium: u32,
    /// Scattering vertices so far.
    depth: u32,
    /// The last vertex scattered through a delta lobe (or is the camera): emission found
    /// next is not weighed against light sampling.
    specular: bool,
    /// The last vertex's position, where light sampling would have sampled from.
    prev: Vec3,
    /// Product of the radiance scalings of the refractions so far (undone for roulette).
    eta_scale: f32,
    /// Numbers for the flights after null crossings.
    rng: Rng,
    /// Flights since the last vertex (the first draws from the sampler).
    flights: u32,
    /// Light tracing carries this path where it ends at a finite emitter right after a delta
    /// surface (`vollight`): its first vertex is a medium collision or a non-delta
    /// surface.
    left: bool,
    /// The last vertex was a surface whose BSDF is delta ([`passes`]).
    last_delta: bool,
}

impl Path {
    fn trace(&mut self, c: &PathContext, rays: &mut u64) {
        let (scene, s) = (c.scene, c.settings);
        for _ in 0..MAX_CROSSINGS.saturating_mul(s.max_depth.max(1) + 1) {
            *rays += 1;
            let hit = scene.intersect(&self.ray);
            let t_hit = hit.map_or(f32::INFINITY, |h| h.t);
            match self.fly(c, t_hit, rays) {
                Some(true) => continue,
                Some(false) => return,
                None => {}
            }
            let Some(hit) = hit else {
                self.escape(c);
                return;
            };
            let surf = scene.surface(&self.ray, &hit);
            if surf.light != NO_LIGHT && s.max_depth >= self.depth {
                self.found_emitter(scene, s, &surf);
            }
            let material = &scene.materials[surf.material as usize];
            if material.null {
                self.cross(surf, material.interface);
                continue;
            }
            if !self.scatter_at_surface(c, surf, rays) {
                return;
            }
        }
    }

    /// The free flight through the current medium up to `t_hit`, where there is one:
    /// `Some(true)` where it collided and the path goes on from the collision, `Some(false)`
    /// where the path ended, `None` where it reaches `t_hit` (or there is no medium).
    fn fly(&mut self, c: &PathContext, t_hit: f32, rays: &mut u64) -> Option<bool> {
        let medium = c.scene.media.get(self.medium as usize)?;
        let u = if self.flights == 0 {
            c.sampler.get_1d(dim::bounce(self.depth, dim::DISTANCE))
        } else {
            self.rng.next_f32()
        };
        self.flights += 1;
        let mut emitted = Vec3::ZERO;
        let gather = (self.depth < c.settings.max_depth && medium.emits()).then_some(&mut emitted);
        let event = flight(
            medium,
            &self.ray,
            t_hit,
            u,
            &mut self.rng,
            &mut self.w,
            gather,
        );
        self.l += emitted;
        match event {
            Flight::Collided(t) => {
                let p = self.ray.at(t);
                Some(self.scatter_in_medium(c, p, medium.g(), rays))
            }
            Flight::Passed => (!self.w.alive()).then_some(false),
        }
    }

    /// Moves the path through null surface `surf` along its ray, into the medium beyond.
    fn cross(&mut self, surf: Surface, interface: Option<crate::medium::MediumInterface>) {
        let d = self.ray.d;
        if let Some(i) = interface {
            self.medium = i.toward(d, surf.ng);
        }
        self.ray = Ray::new(offset_origin(surf.p, surf.ng, d), d);
    }

    /// Adds the emission of the light at `surf` that the path's ray found.
    fn found_emitter(&mut self, scene: &Scene, s: &IntegratorSettings, surf: &Surface) {
        let j = surf.light as usize;
        if self.left && self.last_delta && scene.lights[j].is_finite_emitter() {
            return;
        }
        let le = scene.emitted(surf, -self.ray.d);
        if le.max_element() <= 0.0 {
            return;
        }
        let pdf = || scene.lights[j].pdf_point(self.prev, surf.p, surf.ng) * scene.light_pmf(j);
        self.l += self.found(s.direct, le, pdf);
    }

    /// The share of radiance `le` found by the path's ray that this strategy keeps: all of it
    /// after a delta vertex or with BSDF sampling alone, none with light sampling alone, else
    /// its balance-heuristic weight against light sampling of density `light_pdf` (solid
    /// angle, light choice included).
    fn found(&self, direct: Direct, le: Rgb, light_pdf: impl FnOnce() -> f32) -> Rgb {
        let w = &self.w;
        match direct {
            _ if self.specular => w.beta * le / average(w.r_u),
            Direct::Mis => w.beta * le / average(w.r_u + w.r_l * light_pdf()),
            Direct::Light => Vec3::ZERO,
            Direct::Bsdf | Direct::Hemisphere => w.beta * le / average(w.r_u),
        }
    }

    /// Adds the infinite lights' radiance that the escaping ray finds.
    fn escape(&mut self, c: &PathContext) {
        let (scene, s) = (c.scene, c.settings);
        if s.max_depth < self.depth {
            return;
        }
        let d = self.ray.d;
        for (j, light) in scene.lights.iter().enumerate() {
            if !light.is_infinite() {
                continue;
            }
            let (le, pdf) = scene.escaped_pdf(j, self.prev, d, c.guiding.guide);
            self.l += self.found(s.direct, le, || pdf * scene.light_pmf(j));
        }
    }

    /// Counts a new scattering vertex; false when it lies beyond the maximum depth.
    fn next_vertex(&mut self, s: &IntegratorSettings) -> bool {
        self.depth += 1;
        self.flights = 0;
        self.depth <= s.max_depth
    }

    /// Russian roulette after vertex `depth` has set the throughput of its continuation.
    fn survives(&mut self, c: &PathContext) -> bool {
        if !self.w.alive() {
            return false;
        }
        let effective = (self.w.beta / average(self.w.r_u) / self.eta_scale).max_element();
        let u = || c.sampler.get_1d(dim::bounce(self.depth, dim::ROULETTE));
        let s = c.settings;
        match roulette(self.depth, s.roulette_rule(), effective, u) {
            Some(q) => {
                self.w.beta /= q;
                true
            }
            None => false,
        }
    }

    /// A collision at `p` in the current medium (phase asymmetry `g`): light sampling, then
    /// a new direction from the phase function. False when the path ends.
    fn scatter_in_medium(&mut self, c: &PathContext, p: Vec3, g: f32, rays: &mut u64) -> bool {
        if !self.w.alive() || !self.next_vertex(c.settings) {
            return false;
        }
        if self.depth == 1 {
            self.left = c.settings.light_tracing;
        }
        self.last_delta = false;
        let wo = -self.ray.d;
        let ld = self.direct(c, &Scatterer::Phase { p, wo, g }, rays);
        self.l += ld;
        let u = c
            .sampler
            .get_2d(dim::bounce(self.depth, dim::BSDF_DIRECTION));
        let ps = sample_hg(wo, g, u);
        // The sample's weight is 1 (its density is the phase function's value).
        self.w.r_l = self.w.r_u / ps.pdf;
        self.specular = false;
        self.prev = p;
        self.ray = Ray::new(p, ps.wi);
        self.survives(c)
    }

    /// Scattering at surface `surf` (not null): light sampling at a non-delta BSDF, then a
    /// new direction from the BSDF. False when the path ends.
    fn scatter_at_surface(&mut self, c: &PathContext, surf: Surface, rays: &mut u64) -> bool {
        if !self.next_vertex(c.settings) {
            return false;
        }
        let scene = c.scene;
        let bsdf = scene.bsdf(&surf);
        if bsdf.is_black() {
            return false;
        }
        self.last_delta = passes(&bsdf);
        if self.depth == 1 {
            self.left = c.settings.light_tracing && !self.last_delta;
        }
        let v = SurfaceVertex::new(scene, surf, bsdf, -self.ray.d);
        let interface = scene.materials[surf.material as usize].interface;
        if !v.bsdf.is_delta() {
            let ld = self.direct(c, &Scatterer::Surface { v, interface }, rays);
            self.l += ld;
        }
        let Some((bs, wi_w)) = v.sample(c.sampler, self.depth) else {
            return false;
        };
        self.w.beta *= bs.weight * scene.shadowing(&surf, wi_w);
        if bs.wi.z < 0.0 {
            self.eta_scale *= v.bsdf.radiance_scale(v.front);
        }
        self.specular = bs.delta;
        if !bs.delta {
            self.w.r_l = self.w.r_u / bs.pdf;
        }
        self.prev = surf.p;
        if let Some(i) = interface {
            self.medium = i.toward(wi_w, surf.ng);
        }
        self.ray = v.spawn(wi_w);
        self.survives(c)
    }

    /// Light sampling at vertex `v` ([`sample_direct`]): one light chosen by power, its
    /// shadow ray through media and null surfaces, its contribution weighed against the
    /// vertex's own sampling by the balance heuristic over strategies and heroes.
    fn direct(&mut self, c: &PathContext, v: &Scatterer, rays: &mut u64) -> Rgb {
        let (scene, s) = (c.scene, c.settings);
        if scene.light_selection.total() <= 0.0 || !matches!(s.direct, Direct::Mis | Direct::Light)
        {
            return Vec3::ZERO;
        }
        let depth = self.depth;
        let (j, pmf) = choose_light(scene, || {
            c.sampler.get_1d(dim::bounce(depth, dim::LIGHT_CHOICE))
        });
        let u = c.sampler.get_2d(dim::bounce(depth, dim::LIGHT_POINT));
        let (w, rng) = (&self.w, &mut self.rng);
        let shadow = |o, d, target, medium| {
            let ray = ShadowRay {
                target,
                medium,
                hero: w.hero,
            };
            shadow_transmittance(scene, o, d, ray, rng, rays)
        };
        let Some((ls, Some((t, tr)))) = sample_direct(c, v, self.medium, (j, u), shadow) else {
            return Vec3::ZERO;
        };
        let contribution = w.beta * t.f * tr.tr * ls.li;
        let r_l = w.r_u * tr.r_l * (pmf * ls.pdf);
        if scene.lights[j].is_delta() || s.direct == Direct::Light {
            contribution / average(r_l)
        } else {
            let r_u = w.r_u * tr.r_u * v.pdf(&t);
            contribution / average(r_l + r_u)
        }
    }
}
