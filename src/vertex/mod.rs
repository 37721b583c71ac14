//! The path vertex that every tracer goes through: the settings of the tracers, sampling
//! a BSDF with the side check, choosing lights and the MIS weights of what a continuation
//! ray finds; light paths' start and adjoint scattering ([`light_path`]); free flights
//! through media ([`flight`]); shadow rays and spectral-MIS weights ([`shadow`]).
//!
//! The tracers ([`crate::integrator`], [`crate::volpath`], [`crate::lighttrace`],
//! [`crate::vollight`], [`crate::features`]) import this module and nothing of each other;
//! the render session chooses among them.

pub mod flight;
pub mod light_path;
pub mod shadow;

use crate::bsdf::{Bsdf, BsdfSample};
use crate::guide::{EnvGuide, Recorder};
use crate::light::power_heuristic;
use crate::math::Rgb;
use crate::options::{names, Choices};
use crate::sampling::sampler::{dim, Sampler};
use crate::scene::{Scene, Surface};
use glam::Vec3;

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
    /// [`radiance`] for the rule.
    pub rr_depth: u32,
    /// Caustic light tracing ([`crate::lighttrace`]): paths whose first hit is not a caustic
    /// surface and whose last is are left to light paths. The render turns it off where light
    /// tracing cannot be used ([`crate::lighttrace::usable`]); `radiance` takes it as given.
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

/// Russian roulette's survival scale: from [`IntegratorSettings::rr_depth`] on, a path
/// continues with probability `min(1, RR_SURVIVAL · max(throughput) · η²)`. Mitsuba's and
/// pbrt-v4's rule is 1; 3 keeps more paths alive for a lower error per ray on the CS184
/// scenes (the measurement is in `docs/performance.md`).
pub const RR_SURVIVAL: f32 = 3.0;

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

/// The direction sampled from `bsdf` (seen from `wo`, local, on the `front` side) at bounce
/// `depth` with the sample's own numbers (the lobe number only where the BSDF chooses
/// lobes): where a path continues, and where [`crate::features`] follows delta bounces.
#[inline(always)]
pub(crate) fn sample_bsdf(
    bsdf: &Bsdf,
    wo: Vec3,
    front: bool,
    sampler: &Sampler,
    depth: u32,
) -> Option<BsdfSample> {
    let u = sampler.get_2d(dim::bounce(depth, dim::BSDF_DIRECTION));
    let u1 = if bsdf.chooses_lobe() {
        sampler.get_1d(dim::bounce(depth, dim::BSDF_LOBE))
    } else {
        0.5
    };
    bsdf.sample(wo, u, u1, front)
}

/// Emission of light `surf.light` found at `surf` by a continuation ray from `from` along
/// `wi_w`, sampled with BSDF density `bsdf_pdf`: `beta · Le · w`, with `w` the MIS weight
/// against light sampling (1 without `mis`).
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn emission_found(
    scene: &Scene,
    s: &IntegratorSettings,
    from: Vec3,
    surf: &Surface,
    wi_w: Vec3,
    bsdf_pdf: f32,
    mis: bool,
    beta: Rgb,
) -> Rgb {
    let le = scene.emitted(surf, -wi_w);
    let w = if mis {
        let j = surf.light as usize;
        let pl = scene.lights[j].pdf_point(from, surf.p, surf.ng);
        power_heuristic(1.0, bsdf_pdf, 1.0, light_density(scene, s, j, pl))
    } else {
        1.0
    };
    beta * le * w
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
