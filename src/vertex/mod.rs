//! The path vertex that every tracer goes through: the settings of the tracers, sampling
//! a BSDF with the side check, choosing lights and the MIS weights of what a continuation
//! ray finds; light paths' start and adjoint scattering ([`light_path`]); free flights
//! through media ([`flight`]); shadow rays and spectral-MIS weights ([`shadow`]).
//!
//! The tracers (`integrator`, `volpath`, `lighttrace`, `vollight`, `features`) import this
//! module and nothing of each other; the render session chooses among them.

pub mod flight;
pub mod light_path;
pub mod shadow;

use crate::bsdf::{Bsdf, BsdfSample};
use crate::guide::{EnvGuide, Recorder};
use crate::lanes::Lane;
use crate::light::{power_heuristic, LightSample};
use crate::math::{offset_origin, Frame, Ray, Rgb};
use crate::medium::{hg_phase, MediumInterface};
pub use crate::options::RR_SURVIVAL;
use crate::options::{names, Choices};
use crate::sampling::sampler::{dim, Sampler};
use crate::scene::{Scene, Surface};
use glam::{Vec2, Vec3};

/// How direct light (light reaching a non-delta vertex from emitters) is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direct {
    /// Light sampling and BSDF sampling combined by multiple importance sampling (power
    /// heuristic): the default.
    Mis,
    /// Light sampling only (CS184's `-l` estimator).
    Light,
    /// BSDF sampling only: emission found by the continuation ray, in full.
    Bsdf,
    /// Uniform hemisphere sampling (CS184's `-H`).
    Hemisphere,
}

/// Which lights a vertex samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightSelection {
    /// `light_samples` samples per vertex, each from one light chosen in proportion to its
    /// emitted power.
    Power,
    /// Every light: `light_samples` samples per non-delta light, one per delta light (CS184).
    All,
}

/// How paths are traced.
#[derive(Clone, Copy, Debug)]
pub struct IntegratorSettings {
    /// CS184 `max_ray_depth` (`-m`).
    pub max_depth: u32,
    /// `true`: sum all bounces up to `max_depth` (`-o 1`); `false`: only bounce `max_depth` (`-o 0`).
    pub accumulate: bool,
    /// Light samples (`-l`): per vertex with power selection, per light with `All`.
    pub light_samples: u32,
    /// The direct-light estimator.
    pub direct: Direct,
    /// How lights are chosen for light sampling.
    pub selection: LightSelection,
    /// Hit index from which Russian roulette may end a path (`--rr-depth`); see
    /// `radiance` for the rule.
    pub rr_depth: u32,
    /// Russian roulette's survival scale (`--rr-survival`, [`RR_SURVIVAL`] by default).
    pub rr_survival: f32,
    /// Caustic light tracing (`lighttrace`): paths whose first hit is not a caustic
    /// surface and whose last is are left to light paths. The render turns it off where light
    /// tracing cannot be used (`lighttrace::usable`); `radiance` takes it as given.
    pub light_tracing: bool,
}

impl Default for IntegratorSettings {
    /// The built-in defaults of the option table ([`crate::options::OPTIONS`]).
    fn default() -> Self {
        Choices::default().integrator_settings()
    }
}

impl Choices {
    /// The path tracers' settings these choices give.
    pub fn integrator_settings(&self) -> IntegratorSettings {
        let u32_of = |name: &str| self.int(name).unwrap_or(0) as u32;
        let direct = if self.flag("hemisphere") {
            Direct::Hemisphere
        } else {
            self.text("direct").parse().unwrap_or(Direct::Mis)
        };
        IntegratorSettings {
            max_depth: u32_of("max_depth"),
            accumulate: self.flag("accumulate"),
            light_samples: u32_of("light_samples"),
            direct,
            selection: self
                .text("light_selection")
                .parse()
                .unwrap_or(LightSelection::Power),
            rr_depth: u32_of("rr_depth"),
            rr_survival: self.real("rr_survival").map_or(RR_SURVIVAL, |s| s as f32),
            light_tracing: self.text("caustics") == "light",
        }
    }
}

names!(Direct, "direct", Direct::Mis => "mis", Direct::Light => "light", Direct::Bsdf => "bsdf";
    Direct::Hemisphere => "hemisphere");
names!(LightSelection, "light_selection", LightSelection::Power => "power", LightSelection::All => "all");

/// Density with which light sampling at a vertex produces a given point of light `j`, whose
/// own pdf for it is `pdf`: the number of samples spent on that light times `pdf`.
pub(crate) fn light_density(scene: &Scene, s: &IntegratorSettings, j: usize, pdf: f32) -> f32 {
    let n = s.light_samples.max(1) as f32;
    match s.selection {
        LightSelection::All => n * pdf,
        LightSelection::Power => n * scene.light_pmf(j) * pdf,
    }
}

/// Russian roulette at vertex `depth` of a path whose largest channel of throughput, with
/// the scalings that are not energy (refraction's `1/η²`, spectral MIS) undone, is
/// `effective`: `Some(1)` before `rr_depth` and at the last vertex (`max_depth`), where no
/// roulette is played (both from `rule`); else the path survives with probability `q = min(1,
/// scale · effective)` (`scale`: [`IntegratorSettings::rr_survival`]), drawn with `u()`, and
/// `Some(q)` is what its throughput is divided by. `None`: the path ends. Every tracer, camera or
/// light, on one lane or eight, plays this rule.
#[inline]
pub(crate) fn roulette(
    depth: u32,
    rule: RouletteRule,
    effective: f32,
    u: impl FnOnce() -> f32,
) -> Option<f32> {
    if !rule.plays_at(depth) {
        return Some(1.0);
    }
    let q = survival(effective, rule.scale);
    (!roulette_ends(q, u())).then_some(q)
}

/// Where [`roulette`] is played and how: from vertex `rr_depth`, not at `max_depth`, with
/// survival scale `scale`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RouletteRule {
    pub rr_depth: u32,
    pub max_depth: u32,
    pub scale: f32,
}

impl RouletteRule {
    /// Whether roulette is played at vertex `depth`: from `rr_depth` on, not at `max_depth`.
    #[inline(always)]
    pub(crate) fn plays_at(&self, depth: u32) -> bool {
        depth >= self.rr_depth && depth < self.max_depth
    }
}

impl IntegratorSettings {
    /// The camera tracers' roulette rule.
    #[inline]
    pub(crate) fn roulette_rule(&self) -> RouletteRule {
        RouletteRule {
            rr_depth: self.rr_depth,
            max_depth: self.max_depth,
            scale: self.rr_survival,
        }
    }
}

/// [`roulette`]'s survival probability `min(1, scale · effective)`, on one lane or eight.
#[inline(always)]
pub(crate) fn survival<L: Lane>(effective: L, scale: f32) -> L {
    (effective * L::splat(scale)).min(L::splat(1.0))
}

/// Whether a path with survival probability `q` ([`survival`]) ends at roulette number `u`,
/// on one lane or eight ([`roulette`] at one lane).
#[inline(always)]
pub(crate) fn roulette_ends<L: Lane>(q: L, u: L) -> L::Mask {
    q.is_nan() | q.le(L::splat(0.0)) | u.ge(q)
}

pub(crate) use crate::lanes::sides_agree;

/// A surface vertex as every tracer sees it: set up once from the surface, its BSDF and the
/// world direction `wo_w` it is seen from (towards the previous vertex of a camera path, the
/// camera of a connection, the light of a light path). The BSDF is turned to that side
/// ([`Scene::seen_from`]); the geometric normal and the shading frame are on that side, the
/// frame along the surface's tangent where the BSDF is anisotropic.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SurfaceVertex {
    pub surf: Surface,
    pub bsdf: Bsdf,
    /// `wo_w` is on the surface's outside (dielectrics need to know).
    pub front: bool,
    /// Geometric normal on `wo_w`'s side.
    pub ng: Vec3,
    /// Shading frame on `wo_w`'s side.
    pub frame: Frame,
    /// `wo_w` in the shading frame.
    pub wo: Vec3,
}

impl SurfaceVertex {
    /// The vertex of `surf` with BSDF `bsdf` (as [`Scene::bsdf`] gives it), seen from world
    /// direction `wo_w`.
    #[inline]
    pub fn new(scene: &Scene, surf: Surface, bsdf: Bsdf, wo_w: Vec3) -> SurfaceVertex {
        let (front, ng, frame) = surf.facing(wo_w);
        let bsdf = scene.seen_from(bsdf, &surf, front);
        let frame = if bsdf.is_anisotropic() {
            Frame::from_normal_tangent(frame.n, scene.tangent(&surf))
        } else {
            frame
        };
        SurfaceVertex {
            surf,
            bsdf,
            front,
            ng,
            frame,
            wo: frame.to_local(wo_w),
        }
    }

    /// What the vertex scatters towards world direction `wi_w`: the BSDF value times the
    /// shadowing of a bent normal (no cosine) and `wi_w` in the shading frame. `None` where
    /// it scatters nothing: behind a surface that does not transmit, where the shading frame
    /// puts `wi_w` on another side than the geometry does, or a zero value.
    #[inline]
    pub fn scatter(&self, scene: &Scene, wi_w: Vec3) -> Option<(Rgb, Vec3)> {
        let side = wi_w.dot(self.ng);
        if side < 0.0 && !self.bsdf.transmits() {
            return None;
        }
        let wi = self.frame.to_local(wi_w);
        if !sides_agree(side, wi.z) {
            return None;
        }
        let f = self.bsdf.eval(self.wo, wi) * scene.shadowing(&self.surf, wi_w);
        if f.max_element() <= 0.0 {
            return None;
        }
        Some((f, wi))
    }

    /// A direction sampled from the BSDF with the numbers of camera-path vertex `depth` (the
    /// lobe's only where the BSDF chooses lobes), and its world direction; `None` where
    /// nothing is sampled or the sample's side disagrees with the geometry's.
    #[inline(always)]
    pub fn sample(&self, sampler: &Sampler, depth: u32) -> Option<(BsdfSample, Vec3)> {
        let u = sampler.get_2d(dim::bounce(depth, dim::BSDF_DIRECTION));
        let u1 = if self.bsdf.chooses_lobe() {
            sampler.get_1d(dim::bounce(depth, dim::BSDF_LOBE))
        } else {
            0.5
        };
        self.sample_with(u, u1)
    }

    /// [`SurfaceVertex::sample`] with the numbers `u` (direction) and `u1` (lobe) given.
    #[inline(always)]
    pub fn sample_with(&self, u: Vec2, u1: f32) -> Option<(BsdfSample, Vec3)> {
        let bs = self.bsdf.sample(self.wo, u, u1, self.front)?;
        let wi_w = self.frame.to_world(bs.wi);
        sides_agree(wi_w.dot(self.ng), bs.wi.z).then_some((bs, wi_w))
    }

    /// Where a ray leaving the vertex along `d` starts: off the surface on `d`'s side.
    #[inline]
    pub fn origin(&self, d: Vec3) -> Vec3 {
        offset_origin(self.surf.p, self.ng, d)
    }

    /// The ray leaving the vertex along `d`.
    #[inline]
    pub fn spawn(&self, d: Vec3) -> Ray {
        Ray::new(self.origin(d), d)
    }
}

/// What light sampling draws on besides the scene: the learned environment guide
/// ([`crate::guide`]), and, while one is trained, where environment light samples are recorded.
#[derive(Clone, Copy, Default)]
pub struct Guiding<'a> {
    /// The guide of the scene's environment light, if any.
    pub guide: Option<&'a EnvGuide>,
    /// The training records of this run of paths, if training.
    pub record: Option<&'a Recorder<'a>>,
}

impl<'a> Guiding<'a> {
    /// Sampling with `guide` (if any), recording nothing.
    pub fn with(guide: Option<&'a EnvGuide>) -> Guiding<'a> {
        Guiding {
            guide,
            record: None,
        }
    }
}

/// The light a power-selected light sample uses and the probability of choosing it; `u`
/// draws the choice's number (not drawn when there is one light). The scene's selection
/// must have a positive total.
#[inline]
pub(crate) fn choose_light(scene: &Scene, u: impl FnOnce() -> f32) -> (usize, f32) {
    if scene.lights.len() == 1 {
        (0, 1.0)
    } else {
        let (j, pmf, _) = scene.light_selection.sample(u());
        (j, pmf)
    }
}

/// What one camera path draws on at every vertex: the scene, the sample's numbers, the
/// tracer's settings and the environment guide.
#[derive(Clone, Copy)]
pub(crate) struct PathContext<'a> {
    pub scene: &'a Scene,
    pub sampler: &'a Sampler,
    pub settings: &'a IntegratorSettings,
    pub guiding: Guiding<'a>,
}

/// Emission of light `surf.light` found at `surf` by continuation ray `f` along `wi_w`:
/// `beta · Le · w`, with `w` the MIS weight against light sampling (1 without `f.mis`).
#[inline]
pub(crate) fn emission_found(
    scene: &Scene,
    s: &IntegratorSettings,
    f: Found,
    surf: &Surface,
    wi_w: Vec3,
) -> Rgb {
    let le = scene.emitted(surf, -wi_w);
    let w = if f.mis {
        let j = surf.light as usize;
        let pl = scene.lights[j].pdf_point(f.from, surf.p, surf.ng);
        power_heuristic(1.0, f.bsdf_pdf, 1.0, light_density(scene, s, j, pl))
    } else {
        1.0
    };
    f.beta * le * w
}

/// A continuation ray's origin `from`, its BSDF density `bsdf_pdf`, whether its emission is
/// weighted against light sampling (`mis`) and the throughput `beta` after it.
#[derive(Clone, Copy)]
pub(crate) struct Found {
    pub from: Vec3,
    pub bsdf_pdf: f32,
    pub mis: bool,
    pub beta: Rgb,
}

/// Adds to `l` the infinite lights' radiance that a continuation ray along `wi_w` (`f`)
/// finds when it leaves the scene, MIS-weighted as [`emission_found`] against light sampling
/// (guided by `guide` where it guides the light).
#[inline]
pub(crate) fn escape_found(
    scene: &Scene,
    s: &IntegratorSettings,
    guide: Option<&EnvGuide>,
    wi_w: Vec3,
    f: Found,
    l: &mut Rgb,
) {
    for (j, light) in scene
        .lights
        .iter()
        .enumerate()
        .filter(|(_, l)| l.is_infinite())
    {
        let (le, w) = if f.mis {
            let (le, pdf) = scene.escaped_pdf(j, f.from, wi_w, guide);
            let pl = light_density(scene, s, j, pdf);
            (le, power_heuristic(1.0, f.bsdf_pdf, 1.0, pl))
        } else {
            (light.escaped(wi_w), 1.0)
        };
        *l += f.beta * le * w;
    }
}

/// How a vertex scatters light, as next-event estimation needs it.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Scatterer {
    /// A surface, with its material's medium interface (if any).
    Surface {
        v: SurfaceVertex,
        interface: Option<MediumInterface>,
    },
    /// A medium collision at `p`: the Henyey-Greenstein phase function of asymmetry `g`
    /// around `wo` (towards the previous vertex).
    Phase { p: Vec3, wo: Vec3, g: f32 },
}

/// What a vertex scatters towards a light sample and where a ray towards it starts.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Towards {
    /// The BSDF value times `|cos θ|` and the shadowing of a bent normal, or the phase
    /// function's value.
    pub f: Rgb,
    /// The direction: local to the shading frame at a surface, world at a collision.
    pub wi: Vec3,
    /// Where a ray towards it starts.
    pub origin: Vec3,
    /// The medium that ray starts in.
    pub medium: u32,
}

impl Scatterer {
    /// Where the vertex is.
    #[inline]
    pub fn position(&self) -> Vec3 {
        match self {
            Scatterer::Surface { v, .. } => v.surf.p,
            Scatterer::Phase { p, .. } => *p,
        }
    }

    /// What the vertex scatters towards world direction `wi` when the path is in medium
    /// `medium`; `None` where it scatters nothing ([`SurfaceVertex::scatter`]).
    #[inline]
    pub fn towards(&self, scene: &Scene, wi: Vec3, medium: u32) -> Option<Towards> {
        match self {
            Scatterer::Surface { v, interface } => {
                let (f, local) = v.scatter(scene, wi)?;
                Some(Towards {
                    f: f * local.z.abs(),
                    wi: local,
                    origin: v.origin(wi),
                    medium: interface.map_or(medium, |i| i.toward(wi, v.surf.ng)),
                })
            }
            Scatterer::Phase { p, wo, g } => Some(Towards {
                f: Vec3::splat(hg_phase(wo.dot(wi), *g)),
                wi,
                origin: *p,
                medium,
            }),
        }
    }

    /// `|cos θ|` of world direction `wi` with the geometric normal at a surface; 1 at a
    /// collision.
    #[inline]
    pub fn cosine(&self, wi: Vec3) -> f32 {
        match self {
            Scatterer::Surface { v, .. } => wi.dot(v.ng).abs(),
            Scatterer::Phase { .. } => 1.0,
        }
    }

    /// The density with which the vertex's own sampling (BSDF or phase) picks `t.wi`.
    #[inline]
    pub fn pdf(&self, t: &Towards) -> f32 {
        match self {
            Scatterer::Surface { v, .. } => v.bsdf.pdf(v.wo, t.wi),
            Scatterer::Phase { .. } => t.f.x,
        }
    }
}

/// Next-event estimation's one light sample, written once for every tracer: a point of light
/// `j` drawn with numbers `u` as seen from vertex `v` (in medium `medium`), what the vertex
/// scatters towards it, and what gets through to it by `shadow(origin, direction, target,
/// medium, rays)` (the tracer's shadow ray: a plain occlusion test, or transmittance through
/// media and null surfaces). `None` where the light gives no sample; the sample with `None`
/// where it contributes nothing. The tracer weighs it against its own sampling.
#[inline]
pub(crate) fn sample_direct<T>(
    c: &PathContext,
    v: &Scatterer,
    medium: u32,
    (j, u): (usize, Vec2),
    shadow: impl FnOnce(Vec3, Vec3, Option<Vec3>, u32) -> Option<T>,
) -> Option<(LightSample, Option<(Towards, T)>)> {
    let at = v.position();
    let ls = c.scene.sample_light(j, at, u, c.guiding.guide)?;
    if ls.pdf.is_nan() || ls.pdf <= 0.0 || ls.li.max_element() <= 0.0 {
        return Some((ls, None));
    }
    let Some(t) = v.towards(c.scene, ls.wi, medium) else {
        return Some((ls, None));
    };
    let target = ls.dist.is_finite().then(|| at + ls.wi * ls.dist);
    let through = shadow(t.origin, ls.wi, target, t.medium);
    Some((ls, through.map(|tr| (t, tr))))
}
