//! Orchestration: image tiles over a thread pool, per-pixel random streams, adaptive sampling,
//! cells, progress and statistics. A render is a [`Session`] (thread pool, sampler set-up,
//! camera, splats, counters) filled by the schedule of its mode (`schedule`: uniform,
//! time-limited passes, the adaptive budget, CS184's `-a`), with the samples of a pixel taken
//! in `samples`. The result depends only on the seed, never on the thread
//! count, the schedule or the cell: every pixel draws from its own stream, indexed by its
//! position in the full frame.

mod guiding;
mod options;
mod samples;
mod schedule;
mod session;
mod splat;
pub(crate) mod tracers;

pub use session::Session;

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::{Film, FilmPixel, Tile};
use crate::io::image::Image;
use crate::sampling::sampler::{SamplerKind, SamplerSetup};
use crate::scene::Scene;
use crate::vertex::IntegratorSettings;
use glam::Vec3;
use rayon::prelude::*;
use samples::camera_ray;
use std::sync::atomic::AtomicBool;

/// CS184 adaptive sampling (`-a BATCH TOL`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// Samples between convergence checks.
    pub batch: u32,
    /// Stop when the 95% confidence half-width `1.96·σ/√n` is at most `tolerance · μ`.
    pub tolerance: f32,
}

pub use crate::film::{Cell, TILE};

/// Everything a render needs besides the scene.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Camera samples per pixel (`-s`); the maximum with adaptive sampling.
    pub spp: u32,
    /// Worker threads (`-t`); `None` = all cores.
    pub threads: Option<usize>,
    /// Seed of all random streams (`--seed`).
    pub seed: u64,
    /// Path tracing settings.
    pub integrator: IntegratorSettings,
    /// The point set camera samples draw from (`--sampler`).
    pub sampler: SamplerKind,
    /// The pixel filter camera samples are drawn from (`--filter`).
    pub filter: crate::filter::PixelFilter,
    /// CS184 adaptive sampling (`-a`), if any.
    pub adaptive: Option<Adaptive>,
    /// Adaptive budget (`--adaptive-budget`): `spp` is the mean budget, spent where it lowers
    /// the mean relative MSE (see [`allocate`]); at most [`ADAPTIVE_CAP`] × `spp` per pixel.
    pub adaptive_budget: bool,
    /// Render only this cell of the frame (the output has the cell's size).
    pub cell: Option<Cell>,
    /// Render in passes of one sample per pixel until this many seconds have passed (or `spp`
    /// passes are done); the result of N passes equals an N-spp render with the same seed.
    pub time_limit: Option<f64>,
    /// Only the samples `[first, first + count)` of every pixel's `spp` (a part of the render
    /// for another machine, or a pass): films of adjacent ranges merge into the film of their
    /// union ([`Film::merge`]). `None`: all of `[0, spp)`. Not with adaptive sampling.
    pub sample_range: Option<(u32, u32)>,
    /// Learned environment light sampling (`--env-guiding`, [`crate::guide`]): trained before
    /// the render where the scene has an importance-sampled environment map.
    pub env_guiding: bool,
    /// Record denoising features in the film (`--features`, implied by `--denoise`).
    pub features: bool,
    /// Denoise the developed image (`--denoise`; the shells do it, with [`crate::denoise`]).
    pub denoise: bool,
}

impl Default for RenderOptions {
    /// The built-in defaults of the option table ([`crate::options::OPTIONS`]).
    fn default() -> Self {
        crate::options::Choices::default().render_options()
    }
}

/// Figures of a finished render.
#[derive(Clone, Debug)]
pub struct RenderStats {
    /// Wall time of the rendering loop, seconds.
    pub seconds: f64,
    /// Camera samples taken by this call.
    pub samples: u64,
    /// Rays traced (camera, continuation, shadow).
    pub rays: u64,
    /// Samples whose radiance was NaN or infinite; they count as black.
    pub non_finite: u64,
    /// Threads used.
    pub threads: usize,
    /// Samples the film holds per pixel (row-major over the output), differing with adaptive
    /// sampling and in an interrupted render.
    pub samples_per_pixel: Vec<u32>,
    /// True when the render reached its target; false when it was stopped (or, with a time
    /// limit, ran out of time) first.
    pub complete: bool,
}

impl RenderStats {
    /// Mean samples per pixel the film holds.
    pub fn mean_spp(&self) -> f64 {
        self.samples_per_pixel
            .iter()
            .map(|&n| n as f64)
            .sum::<f64>()
            / self.samples_per_pixel.len().max(1) as f64
    }
}

/// How a caller steers a running render.
#[derive(Clone, Copy)]
pub struct Control<'a> {
    /// Set from another thread (a signal handler, a user interface) to stop the render: each
    /// thread finishes the sample it is taking, and the film keeps every finished sample.
    pub stop: &'a AtomicBool,
    /// Called from worker threads with `(done, total)` as tiles or passes finish.
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
    /// Called from worker threads with each tile of the film's cell as its pass over it
    /// finishes (a live display such as tev reads the pixels here).
    pub tile_done: Option<&'a TileFn<'a>>,
}

/// What [`Control::tile_done`] is called with: the film's cell, the tile (relative to the
/// cell) and its pixels.
pub type TileFn<'a> = dyn Fn(Cell, &Tile, &[FilmPixel]) + Sync + 'a;

impl<'a> Control<'a> {
    /// A control with a stop flag and a progress callback, and no tile callback.
    pub fn new(stop: &'a AtomicBool, progress: &'a (dyn Fn(usize, usize) + Sync)) -> Self {
        Control {
            stop,
            progress,
            tile_done: None,
        }
    }
}

/// Most samples a pixel may take with the adaptive budget, as a multiple of the mean.
pub const ADAPTIVE_CAP: u32 = 8;

/// Adaptive budget: per-pixel sample targets that minimise the expected mean relative MSE
/// for a given cost. Pixel `i` has per-sample relative variance `var[i]` (summed over
/// channels, each over `mean² + 0.01`, the relMSE's denominator) and cost `cost[i]` (rays per
/// sample); the error of its mean after `n` samples is `var/n`, so minimising `Σ var/n` with
/// `Σ n·cost` fixed gives `n ∝ √(var / cost)` (a Lagrange multiplier). Before that, each
/// variance is replaced by the largest in its 3×3 neighbourhood (so that a pixel whose pilot
/// samples missed a rare bright path next to one that found it is not starved) and floored at
/// 1% of the mean. Targets never fall below `current` and never exceed `cap`, and each
/// pixel's increment `target − current` is a multiple of `quantum` (rounded to nearest), so
/// that with `quantum` = [`crate::integrator::packet::LANES`] pixels trace their new samples in whole
/// packets of their own. The multiplier is found by bisection so that `Σ target·cost` meets
/// `budget` (in the units of `cost`).
pub fn allocate(
    var: &[f64],
    cost: &[f64],
    (w, h): (usize, usize),
    current: &[u32],
    budget: f64,
    (cap, quantum): (u32, u32),
) -> Vec<u32> {
    let q = quantum.max(1);
    let n = w * h;
    let mean = var.iter().sum::<f64>() / n.max(1) as f64;
    let floor = 0.01 * mean;
    let weight: Vec<f64> = (0..n)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut v = 0f64;
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    v = v.max(var[yy * w + xx]);
                }
            }
            (v.max(floor) / cost[i].max(1e-9)).sqrt()
        })
        .collect();
    let target = |lambda: f64, i: usize| {
        let c = current[i];
        let room = cap.saturating_sub(c) / q;
        let steps = ((lambda * weight[i] - c as f64) / q as f64).round();
        c + steps.clamp(0.0, room as f64) as u32 * q
    };
    let spent = |lambda: f64| {
        (0..n)
            .map(|i| target(lambda, i) as f64 * cost[i])
            .sum::<f64>()
    };
    let (mut lo, mut hi) = (0f64, 1f64);
    while spent(hi) < budget && hi < 1e12 {
        hi *= 2.0;
    }
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if spent(mid) <= budget {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0..n).map(|i| target(lo, i)).collect()
}

/// The CS184 stopping rule: with `n` samples of illuminance summing to `s1` (and squares to
/// `s2`), the pixel has converged when `1.96·σ/√n ≤ tolerance·μ`.
pub fn converged(n: u32, s1: f64, s2: f64, tolerance: f32) -> bool {
    if n < 2 {
        return false;
    }
    let n = n as f64;
    let mu = s1 / n;
    let var = ((s2 - s1 * s1 / n) / (n - 1.0)).max(0.0);
    1.96 * var.sqrt() / n.sqrt() <= tolerance as f64 * mu
}

/// Renders `scene` (or one cell of it) into a new film and develops it.
/// `progress(done, total)` is called from worker threads as tiles finish.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Image, RenderStats)> {
    render_camera(scene, &scene.camera, opts, progress)
}

/// [`render`] through `camera` instead of the scene's own.
pub fn render_camera(
    scene: &Scene,
    camera: &Camera,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Image, RenderStats)> {
    let mut film = new_film(opts)?;
    let stop = AtomicBool::new(false);
    let ctl = Control::new(&stop, progress);
    let stats = render_camera_into(scene, camera, opts, &mut film, ctl)?;
    Ok((film.develop(), stats))
}

/// The empty film that a render with `opts` fills.
pub fn new_film(opts: &RenderOptions) -> Result<Film> {
    let film = Film::new(
        opts.width,
        opts.height,
        opts.cell,
        opts.sample_range.map_or(0, |r| r.0),
    )?;
    Ok(film.with_features(opts.features))
}

/// Adds samples of `scene` to `film` (made by [`new_film`] with the same options, or loaded
/// from a checkpoint of them) until every pixel holds its target, the time limit passes or
/// `ctl.stop` is set. Each pixel continues its own sample sequence where the film left it,
/// so an interrupted and resumed render equals an uninterrupted one bit for bit. The scene's
/// own camera looks; see [`render_camera_into`] for another.
pub fn render_into(
    scene: &Scene,
    opts: &RenderOptions,
    film: &mut Film,
    ctl: Control,
) -> Result<RenderStats> {
    render_camera_into(scene, &scene.camera, opts, film, ctl)
}

/// [`render_into`] through `camera` instead of the scene's own (a viewer's or a Python
/// user's camera, without copying the scene and its BVH).
pub fn render_camera_into(
    scene: &Scene,
    camera: &Camera,
    opts: &RenderOptions,
    film: &mut Film,
    ctl: Control,
) -> Result<RenderStats> {
    let session = Session::new(scene, camera, opts, film, ctl)?;
    Ok(schedule::run(&session, film))
}

/// Auxiliary images of a render, for denoisers and analysis: per pixel the mean over the
/// camera samples of the render's sample range (the same sub-pixel positions and lens points
/// as its radiance samples) of what the camera ray first hits. Rays that hit nothing give 0.
#[derive(Clone, Debug)]
pub struct AuxImages {
    /// The material's colour ([`crate::bsdf::Bsdf::albedo`]) at the first hit.
    pub albedo: Image,
    /// The unit world-space shading normal at the first hit, turned to face the camera
    /// (components in [−1, 1]; the mean of unit vectors is shorter at silhouettes).
    pub normal: Image,
    /// The distance from the ray's origin on the lens to the first hit, in scene units (the
    /// same in all three channels).
    pub depth: Image,
}

/// Renders the [`AuxImages`] of the render `opts` describes (its frame, cell, sampler, seed
/// and sample range). Bit-identical for any thread count.
pub fn aux_images(scene: &Scene, camera: &Camera, opts: &RenderOptions) -> Result<AuxImages> {
    let film = new_film(opts)?;
    let cell = film.cell();
    let (first, count) = sample_range(opts)?;
    let (pool, _) = thread_pool(opts.threads)?;
    let setup = SamplerSetup::new(opts.sampler, opts.seed, opts.width, opts.height, opts.spp);
    let (w, h) = (cell.w as usize, cell.h as usize);
    let mut out = vec![[Vec3::ZERO; 3]; w * h];
    pool.install(|| {
        out.par_chunks_mut(w).enumerate().for_each(|(row, px)| {
            for (col, o) in px.iter_mut().enumerate() {
                let (x, y) = (cell.x + col as u32, cell.y + row as u32);
                let mut sum = [Vec3::ZERO; 3];
                for k in first..first + count {
                    let (ray, _, _) = camera_ray(camera, opts, &setup, x, y, k);
                    let Some(hit) = scene.intersect(&ray) else {
                        continue;
                    };
                    let s = scene.surface(&ray, &hit);
                    let n = if s.ns.dot(ray.d) > 0.0 { -s.ns } else { s.ns };
                    let albedo = scene.bsdf(&s).albedo();
                    for (acc, v) in sum.iter_mut().zip([albedo, n, Vec3::splat(hit.t)]) {
                        if v.is_finite() {
                            *acc += v;
                        }
                    }
                }
                *o = sum.map(|v| v / count as f32);
            }
        })
    });
    let image = |c: usize| Image {
        width: w,
        height: h,
        pixels: out.iter().map(|p| p[c]).collect(),
    };
    Ok(AuxImages {
        albedo: image(0),
        normal: image(1),
        depth: image(2),
    })
}

/// The sample range `[first, first + count)` of `opts` (all of `[0, spp)` without one),
/// refused when empty or beyond `spp`.
pub(super) fn sample_range(opts: &RenderOptions) -> Result<(u32, u32)> {
    let (first, count) = opts.sample_range.unwrap_or((0, opts.spp));
    if opts.spp == 0 || count == 0 || first as u64 + count as u64 > opts.spp as u64 {
        return Err(Error::Usage(format!(
            "sample_range {first}..{} is empty or beyond spp {}",
            first as u64 + count as u64,
            opts.spp
        )));
    }
    Ok((first, count))
}

/// A pool of `threads` worker threads (all cores when `None`), and its size.
pub(super) fn thread_pool(threads: Option<usize>) -> Result<(rayon::ThreadPool, usize)> {
    let threads = threads
        .unwrap_or_else(|| {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        })
        .max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Usage(format!("cannot start {threads} threads: {e}")))?;
    Ok((pool, threads))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn allocation_on_a_synthetic_image() {
        // 32×16 pixels: relative variance 1, a 4×4 block of variance 100 at (4..8, 4..8), and
        // the right half twice as costly per sample.
        let (w, h) = (32usize, 16usize);
        let var: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (4..8).contains(&x) && (4..8).contains(&y) {
                    100.0
                } else {
                    1.0
                }
            })
            .collect();
        let cost: Vec<f64> = (0..w * h)
            .map(|i| if i % w >= 16 { 4.0 } else { 1.0 })
            .collect();
        let current = vec![8u32; w * h];
        let budget = 64.0 * cost.iter().sum::<f64>();
        let t = allocate(&var, &cost, (w, h), &current, budget, (1000, 1));
        let spent: f64 = t.iter().zip(&cost).map(|(&n, &c)| n as f64 * c).sum();
        assert!(
            spent <= budget && spent > 0.99 * budget,
            "{spent} of {budget}"
        );
        let at = |x: usize, y: usize| t[y * w + x] as f64;
        // n ∝ √(var / cost): the block gets 10× a plain cheap pixel, a plain costly pixel half.
        let plain = at(12, 12);
        assert!(
            (at(5, 5) / plain - 10.0).abs() < 0.2,
            "{} vs {plain}",
            at(5, 5)
        );
        assert!(
            (at(24, 12) / plain - 0.5).abs() < 0.05,
            "{} vs {plain}",
            at(24, 12)
        );
        // Dilation: the block's neighbours get its rate, two pixels away they do not.
        assert_eq!(at(3, 5), at(5, 5));
        assert_eq!(at(8, 8), at(5, 5));
        assert_eq!(at(2, 5), plain);
        // Never below what a pixel already has, never above the cap.
        let t = allocate(
            &var,
            &cost,
            (w, h),
            &current,
            12.0 * cost.iter().sum::<f64>(),
            (20, 1),
        );
        assert!(t.iter().all(|&n| (8..=20).contains(&n)));
        assert_eq!(t[5 * w + 5], 20);
        // A flat image gets a flat allocation.
        let flat = allocate(
            &vec![1.0; 64],
            &vec![1.0; 64],
            (8, 8),
            &vec![0; 64],
            640.0,
            (100, 1),
        );
        assert!(flat.iter().all(|&n| n == 10), "{flat:?}");
        // Whole packets: increments in multiples of 8, the cap and the budget still kept,
        // and the block still ten times a plain cheap pixel, to a packet.
        let current: Vec<u32> = (0..w * h).map(|i| 8 + (i % 3) as u32).collect();
        let t = allocate(&var, &cost, (w, h), &current, budget, (1000, 8));
        let spent: f64 = t.iter().zip(&cost).map(|(&n, &c)| n as f64 * c).sum();
        // (Equal weights move together by a packet: 256 costly pixels are 10% of the budget.)
        assert!(spent <= budget && spent > 0.9 * budget, "{spent}");
        assert!(t.iter().zip(&current).all(|(&n, &c)| (n - c) % 8 == 0));
        let (block, plain) = (t[5 * w + 5] as f64, t[12 * w + 12] as f64);
        assert!(
            (block - 10.0 * plain).abs() <= 8.0 * 11.0,
            "{block} vs {plain}"
        );
        let capped = allocate(&var, &cost, (w, h), &current, budget, (20, 8));
        assert!(capped
            .iter()
            .zip(&current)
            .all(|(&n, &c)| n <= 20 && (n - c) % 8 == 0));
    }

    #[test]
    fn aux_images_of_the_built_in_box() {
        let scene = crate::scene::build::build(&crate::builtin::cornell_box());
        let opts = RenderOptions {
            width: 48,
            height: 36,
            spp: 4,
            threads: Some(1),
            ..RenderOptions::default()
        };
        let a = aux_images(&scene, &scene.camera, &opts).unwrap();
        let b = aux_images(
            &scene,
            &scene.camera,
            &RenderOptions {
                threads: Some(3),
                ..opts.clone()
            },
        )
        .unwrap();
        assert_eq!(a.depth.pixels, b.depth.pixels);
        assert_eq!(a.normal.pixels, b.normal.pixels);
        // The camera looks into the box: the centre pixel sees its back wall head on, facing
        // the camera, at a positive distance, with a colour in [0, 1].
        let c = (18 * 48 + 24) as usize;
        let (n, d, al) = (a.normal.pixels[c], a.depth.pixels[c], a.albedo.pixels[c]);
        assert!(n.dot(scene.camera.forward) < -0.9, "{n}");
        assert!(d.x > 0.0 && d.x == d.y && d.y == d.z, "{d}");
        assert!(al.min_element() >= 0.0 && al.max_element() <= 1.0 && al.max_element() > 0.0);
        for p in a
            .normal
            .pixels
            .iter()
            .chain(&a.albedo.pixels)
            .chain(&a.depth.pixels)
        {
            assert!(p.is_finite());
        }
        // A cell gives the same pixels as that part of the frame.
        let cell = Cell {
            x: 8,
            y: 4,
            w: 10,
            h: 6,
        };
        let part = aux_images(
            &scene,
            &scene.camera,
            &RenderOptions {
                cell: Some(cell),
                ..opts.clone()
            },
        )
        .unwrap();
        for y in 0..6 {
            for x in 0..10 {
                assert_eq!(part.depth.get(x, y), a.depth.get(x + 8, y + 4));
            }
        }
    }

    #[test]
    fn stopping_rule_on_synthetic_streams() {
        // A constant stream converges at the first check.
        let (mut s1, mut s2) = (0.0, 0.0);
        for n in 1..=64u32 {
            s1 += 0.5;
            s2 += 0.25;
            if n == 64 {
                assert!(converged(n, s1, s2, 0.01));
            }
        }
        // Alternating 0 and 2: μ = 1, σ ≈ 1, so 1.96/√n ≤ tol ⇔ n ≥ (1.96/tol)². For tol 0.05
        // that is n ≥ 1537: with batches of 64 the first passing check is at n = 1600.
        let (mut s1, mut s2) = (0.0, 0.0);
        let mut stop = None;
        for n in 1..=4096u32 {
            let x = if n % 2 == 0 { 2.0 } else { 0.0 };
            s1 += x;
            s2 += x * x;
            if n % 64 == 0 && converged(n, s1, s2, 0.05) {
                stop = Some(n);
                break;
            }
        }
        assert_eq!(stop, Some(1600));
        // A black pixel (μ = 0, σ = 0) stops too; fewer than 2 samples never do.
        assert!(converged(64, 0.0, 0.0, 0.05));
        assert!(!converged(1, 1.0, 1.0, 0.05));
    }
}
