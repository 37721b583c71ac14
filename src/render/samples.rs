//! Taking a pixel's samples: its camera rays and their radiance, traced eight at a time
//! where the scene and settings suit packets ([`crate::integrator::packet`]), one at a time otherwise (and
//! always under CS184's adaptive stopping rule).

use super::splat::Block;
use super::tracers::radiance;
use super::{converged, RenderOptions};
use crate::camera::Camera;
use crate::features::features;
use crate::film::{add_features, FeatureSums, FilmPixel};
use crate::filter::PixelFilter;
use crate::guide::EnvGuide;
use crate::integrator::packet::LANES;
use crate::math::luminance;
use crate::sampling::sampler::{dim, SamplerSetup};
use crate::scene::Scene;
use crate::vertex::Guiding;
use glam::{Vec2, Vec3};
use std::sync::atomic::{AtomicBool, Ordering};

/// The camera ray of sample `k` of frame pixel `(x, y)` (its sub-pixel position and lens
/// point), the sample's numbers for the rest of the path, and its continuous frame position.
#[inline]
pub(super) fn camera_ray(
    camera: &Camera,
    opts: &RenderOptions,
    setup: &SamplerSetup,
    x: u32,
    y: u32,
    k: u32,
) -> (crate::math::Ray, crate::sampling::sampler::Sampler, Vec2) {
    let sampler = setup.sample(x, y, k);
    let j = opts.filter.position(sampler.get_2d(dim::PIXEL));
    let u = if camera.lens_radius > 0.0 {
        sampler.get_2d(dim::LENS)
    } else {
        Vec2::ZERO
    };
    let pos = Vec2::new(x as f32 + j.x, y as f32 + j.y);
    let ray = camera.ray(pos.x, pos.y, opts.width, opts.height, u);
    (ray, sampler, pos)
}

/// A frame pixel and the first sample of its range.
#[derive(Clone, Copy)]
pub(super) struct Pixel {
    pub(super) x: u32,
    pub(super) y: u32,
    pub(super) first: u32,
}

/// Pixels per piece when the adaptive budget splits a tile among threads (enough to fill
/// packets with the samples that pixels leave over).
pub(super) const SPLIT: usize = 16;

/// Where sample radiance goes: the pixels of one run of [`samples`] (and, where samples are
/// splatted, the run's [`Block`]), with the rays traced and the non-finite samples counted.
pub(super) struct Taker<'a> {
    pub(super) rays: u64,
    pub(super) bad: u64,
    /// The splats of the run, with the filter that weights them; `None`: each sample counts
    /// for its own pixel alone.
    pub(super) splats: Option<(&'a PixelFilter, &'a mut Block)>,
}

impl Taker<'_> {
    /// Adds one sample's radiance `l` (traced with `nrays` rays, at frame position `pos`) to
    /// `p` (and splats it) and returns what it added: a non-finite value counts as bad and
    /// adds black.
    #[inline]
    fn take(&mut self, p: &mut FilmPixel, l: Vec3, nrays: u64, pos: Vec2) -> Vec3 {
        self.rays += nrays;
        let l = if l.is_finite() {
            l
        } else {
            self.bad += 1;
            Vec3::ZERO
        };
        p.add(l, nrays);
        if let Some((filter, block)) = &mut self.splats {
            block.add(filter, pos, l);
        }
        l
    }
}

/// What every sample of one run of [`samples`] draws on: the scene, its camera and
/// environment guide, the options and sample numbers, whether samples are traced in packets,
/// and the flag that stops the run.
pub(super) struct SampleRun<'a> {
    pub(super) scene: &'a Scene,
    pub(super) camera: &'a Camera,
    pub(super) guide: Option<&'a EnvGuide>,
    pub(super) opts: &'a RenderOptions,
    pub(super) setup: &'a SamplerSetup,
    pub(super) packets: bool,
    pub(super) stop: &'a AtomicBool,
}

/// Takes the samples from `p.n` up to `min(j1, p.target)` (counted from the pixel's first
/// sample) of each pixel `p = ps[i]` at frame pixel `at(i)`, adding each sample's denoising
/// features to `fs[i]` where `fs` is not empty (fewer when CS184 adaptive
/// sampling stops the pixel or `stop` is set). Sample `k` draws from its own numbers, and the
/// film sums are exact (fixed point), so the result does not depend on how samples are split
/// into passes, calls or machines, nor on the order they are added in.
///
/// With `packets` (the scene and settings suit [`crate::integrator::packet`]), each pixel's samples are
/// traced eight at a time; those left over (fewer than eight per pixel, as in passes of one
/// sample per pixel) are gathered across the pixels of `ps` into packets of eight, and the
/// last few are traced alone. Each sample gives the bits the scalar integrator would.
///
/// Renders without features run their own copy of the loops, which has no feature code.
pub(super) fn samples(
    run: &SampleRun,
    at: impl Fn(usize) -> Pixel,
    j1: u32,
    (ps, fs): (&mut [FilmPixel], &mut [FeatureSums]),
    t: &mut Taker,
) {
    if fs.is_empty() {
        samples_of::<false>(run, at, j1, (ps, fs), t);
    } else {
        samples_of::<true>(run, at, j1, (ps, fs), t);
    }
}

/// [`samples`], recording features where `FEATURES`.
fn samples_of<const FEATURES: bool>(
    run: &SampleRun,
    at: impl Fn(usize) -> Pixel,
    j1: u32,
    (ps, fs): (&mut [FilmPixel], &mut [FeatureSums]),
    t: &mut Taker,
) {
    use crate::integrator::packet::radiance8;
    let (scene, camera, guide, opts, setup) =
        (run.scene, run.camera, run.guide, run.opts, run.setup);
    let stopped = || run.stop.load(Ordering::Relaxed);
    if !run.packets {
        for (i, p) in ps.iter_mut().enumerate() {
            let f = fs.get_mut(i);
            scalar_samples::<FEATURES>(run, at(i), j1, (p, f), t);
        }
        return;
    }
    // Eight samples, each `(pixel index in ps, sample number from the pixel's first)`.
    let trace = |(ps, fs): (&mut [FilmPixel], &mut [FeatureSums]),
                 lanes: &[(usize, u32); LANES],
                 t: &mut Taker| {
        let cams: [_; LANES] = std::array::from_fn(|l| {
            let (i, k) = lanes[l];
            let a = at(i);
            camera_ray(camera, opts, setup, a.x, a.y, a.first + k)
        });
        let rays8 = cams.map(|c| c.0);
        let samplers = cams.map(|c| c.1);
        let mut n8 = [0u64; LANES];
        let ls = radiance8(scene, &rays8, &samplers, &opts.integrator, guide, &mut n8);
        for l in 0..LANES {
            let i = lanes[l].0;
            t.take(&mut ps[i], ls[l], n8[l], cams[l].2);
            if let Some(f) = fs.get_mut(i).filter(|_| FEATURES) {
                add_features(f, features(scene, rays8[l], &samplers[l]));
            }
        }
    };
    // Samples left over by their pixels' runs of eight, waiting for a packet.
    let mut rest = [(0usize, 0u32); LANES];
    let mut waiting = 0;
    for i in 0..ps.len() {
        let end = j1.min(ps[i].target);
        while ps[i].n + LANES as u32 <= end && !stopped() {
            let k0 = ps[i].n;
            trace((ps, fs), &std::array::from_fn(|l| (i, k0 + l as u32)), t);
        }
        // A pixel's leftovers follow its own samples; `n` moves when they are traced.
        for k in ps[i].n..end {
            rest[waiting] = (i, k);
            waiting += 1;
            if waiting == LANES {
                if stopped() {
                    return;
                }
                trace((ps, fs), &rest, t);
                waiting = 0;
            }
        }
    }
    for &(i, k) in &rest[..waiting] {
        if stopped() {
            return;
        }
        debug_assert_eq!(ps[i].n, k);
        scalar_samples::<FEATURES>(run, at(i), k + 1, (&mut ps[i], fs.get_mut(i)), t);
    }
}

/// The samples of pixel `p` at `at` from `p.n` up to `min(j1, p.target)`, one at a time with
/// the scalar integrator, with CS184 adaptive sampling's stopping rule where it is on; their
/// denoising features go to `f`, if any.
fn scalar_samples<const FEATURES: bool>(
    run: &SampleRun,
    at: Pixel,
    j1: u32,
    (p, mut f): (&mut FilmPixel, Option<&mut FeatureSums>),
    t: &mut Taker,
) {
    let (scene, camera, opts, setup) = (run.scene, run.camera, run.opts, run.setup);
    while p.n < j1.min(p.target) && !p.done && !run.stop.load(Ordering::Relaxed) {
        let (ray, sampler, pos) = camera_ray(camera, opts, setup, at.x, at.y, at.first + p.n);
        let mut nrays = 0u64;
        let g = Guiding::with(run.guide);
        let l = radiance(scene, ray, &sampler, &opts.integrator, g, &mut nrays);
        let l = t.take(p, l, nrays, pos);
        if let Some(f) = f.as_deref_mut().filter(|_| FEATURES) {
            add_features(f, features(scene, ray, &sampler));
        }
        if let Some(a) = opts.adaptive {
            let v = luminance(l) as f64;
            p.s1 += v;
            p.s2 += v * v;
            if p.n.is_multiple_of(a.batch) && converged(p.n, p.s1, p.s2, a.tolerance) {
                p.done = true;
            }
        }
    }
}
