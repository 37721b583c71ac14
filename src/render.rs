//! Orchestration: image tiles over a thread pool, per-pixel random streams, adaptive sampling,
//! cells, progress and statistics. The result depends only on the seed, never on the thread
//! count, the schedule or the cell: every pixel draws from its own stream, indexed by its
//! position in the full frame.

use crate::error::{Error, Result};
use crate::film::{splat_fixed, Film, FilmPixel, Tile};
use crate::integrator::{radiance, IntegratorSettings};
use crate::io::image::Image;
use crate::lighttrace::LightPathSettings;
use crate::math::luminance;
use crate::packet::LANES;
use crate::sampling::sampler::{dim, SamplerKind, SamplerSetup};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

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

/// Passes per round of the adaptive budget under a time limit.
const SUB_PASSES: u64 = 16;

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
/// that with `quantum` = [`crate::packet::LANES`] pixels trace their new samples in whole
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
    let mut film = new_film(opts)?;
    let stop = AtomicBool::new(false);
    let stats = render_into(scene, opts, &mut film, Control::new(&stop, progress))?;
    Ok((film.develop(), stats))
}

/// The empty film that a render with `opts` fills.
pub fn new_film(opts: &RenderOptions) -> Result<Film> {
    Film::new(
        opts.width,
        opts.height,
        opts.cell,
        opts.sample_range.map_or(0, |r| r.0),
    )
}

/// Adds samples of `scene` to `film` (made by [`new_film`] with the same options, or loaded
/// from a checkpoint of them) until every pixel holds its target, the time limit passes or
/// `ctl.stop` is set. Each pixel continues its own sample sequence where the film left it,
/// so an interrupted and resumed render equals an uninterrupted one bit for bit.
pub fn render_into(
    scene: &Scene,
    opts: &RenderOptions,
    film: &mut Film,
    ctl: Control,
) -> Result<RenderStats> {
    let (fw, fh) = (opts.width, opts.height);
    if fw == 0 || fh == 0 || opts.spp == 0 {
        return Err(Error::Usage(
            "image size and sample count must be positive".into(),
        ));
    }
    let (first, count) = sample_range(opts)?;
    let expected = new_film(opts)?;
    if film.frame() != expected.frame() || film.cell() != expected.cell() || film.first() != first {
        return Err(Error::Usage(
            "the film was made for another frame, cell or sample range".into(),
        ));
    }
    if let Some(a) = opts.adaptive {
        if a.batch == 0 || !(a.tolerance > 0.0 && a.tolerance.is_finite()) {
            return Err(Error::Usage(
                "adaptive sampling needs a positive batch size and tolerance".into(),
            ));
        }
    }
    if (opts.adaptive.is_some() || opts.adaptive_budget) && count != opts.spp {
        return Err(Error::Usage(
            "adaptive sampling cannot render a part of the sample range".into(),
        ));
    }
    let (pool, threads) = thread_pool(opts.threads)?;
    // Caustic light tracing where it can be used (not with CS184's `-a`, whose stopping rule
    // sees only camera samples; see `lighttrace::usable`). Its passes do not depend on how
    // camera samples are spread, so the adaptive budget takes one per level of its rounds.
    let lt = opts.integrator.light_tracing
        && opts.adaptive.is_none()
        && crate::lighttrace::usable(scene);
    let effective = RenderOptions {
        integrator: IntegratorSettings {
            light_tracing: lt,
            ..opts.integrator
        },
        ..opts.clone()
    };
    let opts = &effective;
    if opts.adaptive.is_some() && opts.time_limit.is_some() {
        return Err(Error::Usage(
            "adaptive sampling (-a) and --time-limit cannot be combined".into(),
        ));
    }
    if opts.adaptive_budget && (opts.adaptive.is_some() || opts.spp < 2) {
        return Err(Error::Usage(
            "the adaptive budget needs -s of at least 2 and cannot be combined with -a".into(),
        ));
    }
    let cell = film.cell();
    let (w, h) = (cell.w, cell.h);
    let ntiles = film.tiles().len();
    // The adaptive budget starts from a uniform pilot of n0 samples per pixel.
    let cap = if opts.adaptive_budget {
        opts.spp.saturating_mul(ADAPTIVE_CAP)
    } else {
        opts.spp
    };
    let n0 = if opts.adaptive_budget {
        (opts.spp / 8).clamp(2, 16)
    } else {
        count
    };
    if !opts.adaptive_budget {
        for p in film.pixels_mut() {
            p.target = count;
        }
    } else if film.level == 0 {
        for p in film.pixels_mut() {
            p.target = n0;
        }
        film.level = n0;
    }
    let setup = SamplerSetup::new(opts.sampler, opts.seed, fw, fh, cap);
    let packets = opts.adaptive.is_none() && crate::packet::supported(scene, &opts.integrator);
    let rays = AtomicU64::new(0);
    let bad = AtomicU64::new(0);
    let taken = AtomicU64::new(0);
    let stopped = || ctl.stop.load(Ordering::Relaxed);
    let start = Instant::now();
    // Every pixel takes samples up to min(j1, its target) (counted from `first`).
    let run_pass = |film: &mut Film, j1: u32, per_tile: bool| {
        let done = AtomicUsize::new(0);
        let mut tiles = film.tiles_mut();
        pool.install(|| {
            tiles.par_iter_mut().for_each(|(t, px)| {
                // The pixels of `ps`, from pixel `base` of the tile on.
                let run = |base: usize, ps: &mut [FilmPixel]| {
                    let (mut nrays, mut nbad) = (0u64, 0u64);
                    let n: u64 = ps.iter().map(|p| p.n as u64).sum();
                    let at = |i: usize| {
                        let (x, y) = t.frame_xy(cell, base + i);
                        Pixel { x, y, first }
                    };
                    samples(
                        scene, opts, &setup, packets, at, j1, ps, ctl.stop, &mut nrays, &mut nbad,
                    );
                    rays.fetch_add(nrays, Ordering::Relaxed);
                    bad.fetch_add(nbad, Ordering::Relaxed);
                    let m: u64 = ps.iter().map(|p| p.n as u64).sum();
                    taken.fetch_add(m - n, Ordering::Relaxed);
                };
                if opts.adaptive_budget {
                    // Targets differ from pixel to pixel: split tiles too, so that no thread
                    // is left alone with a tile of costly pixels at the end of a round.
                    px.par_chunks_mut(SPLIT)
                        .enumerate()
                        .for_each(|(c, ps)| run(c * SPLIT, ps));
                } else {
                    run(0, px);
                }
                if let Some(f) = ctl.tile_done {
                    f(cell, t, px);
                }
                if per_tile {
                    (ctl.progress)(done.fetch_add(1, Ordering::Relaxed) + 1, ntiles);
                }
            })
        });
    };
    let targets = if lt {
        crate::lighttrace::caustic_targets(scene)
    } else {
        Vec::new()
    };
    let light_settings = LightPathSettings {
        targets: &targets,
        stride: crate::lighttrace::STRIDE,
        width: fw,
        height: fh,
        max_depth: opts.integrator.max_depth,
        accumulate: opts.integrator.accumulate,
        rr_depth: opts.integrator.rr_depth,
    };
    let splats: Vec<[AtomicI64; 3]> = if lt {
        (0..w as usize * h as usize)
            .map(|_| Default::default())
            .collect()
    } else {
        Vec::new()
    };
    // Brings the film's light passes up to `j` (counted from `first`), one whole pass at a
    // time (the stop flag is checked between passes); false when stopped first.
    let light_to = |film: &mut Film, j: u32| -> bool {
        if !lt {
            return true;
        }
        let mut passes = 0u32;
        let fold = |film: &mut Film, passes: u32| {
            let sums: Vec<[i64; 3]> = splats
                .iter()
                .map(|a| a.each_ref().map(|v| v.swap(0, Ordering::Relaxed)))
                .collect();
            film.add_light_passes(passes, &sums);
        };
        while film.light_passes + passes < j && !stopped() {
            let k = first + film.light_passes + passes;
            pool.install(|| {
                (0..fh).into_par_iter().for_each(|y| {
                    let mut nrays = 0u64;
                    for x in 0..fw {
                        if !crate::lighttrace::starts_path(&light_settings, x, y, k) {
                            continue;
                        }
                        let sampler = setup.sample(x, y, k);
                        nrays += crate::lighttrace::trace(
                            scene,
                            &light_settings,
                            &sampler,
                            |px, py, v| {
                                let (cx, cy) = (px.wrapping_sub(cell.x), py.wrapping_sub(cell.y));
                                if cx < w && cy < h {
                                    let a = &splats[(cy * w + cx) as usize];
                                    for c in 0..3 {
                                        a[c].fetch_add(splat_fixed(v[c]), Ordering::Relaxed);
                                    }
                                }
                            },
                        );
                    }
                    rays.fetch_add(nrays, Ordering::Relaxed);
                })
            });
            passes += 1;
            if passes == 64 {
                fold(film, passes);
                passes = 0;
            }
        }
        if passes > 0 {
            fold(film, passes);
        }
        film.light_passes >= j
    };
    // Every pixel at its target and, with light tracing, `j` light passes held.
    let reached_to = |film: &Film, j: u32| reached(film) && (!lt || film.light_passes >= j);
    let reached_all = |film: &Film| reached_to(film, count);
    let out_of_time = || {
        opts.time_limit
            .is_some_and(|limit| start.elapsed().as_secs_f64() >= limit)
    };
    // Brings every pixel to its target: one pass without a time limit. With one, uniform
    // renders take passes of one sample per pixel (checking the time after each), adaptive
    // rounds SUB_PASSES passes that each take every pixel that fraction of the way to its
    // target (in whole packets); an adaptive render cuts a pass that would end past the limit
    // (judged by the last pass) to the part that fits, so it ends at the limit rather than
    // up to a pass before or after it.
    // Returns false when time ran out or the render was stopped.
    let run_to_targets = |film: &mut Film| -> bool {
        // Light passes to hold at the end of this call: the budget's level (mean samples
        // per pixel) with the adaptive budget, all of them otherwise.
        let light_target = if opts.adaptive_budget {
            film.level.min(count)
        } else {
            count
        };
        if opts.time_limit.is_none() {
            run_pass(film, u32::MAX, !opts.adaptive_budget);
            light_to(film, light_target);
            return !stopped() || reached_to(film, light_target);
        }
        if opts.adaptive_budget {
            let from: Vec<u32> = film.pixels().iter().map(|p| p.n).collect();
            let target: Vec<u32> = film.pixels().iter().map(|p| p.target).collect();
            let light_from = film.light_passes.min(light_target);
            // Pixel `i`'s target after `f` of the round's SUB_PASSES passes (f may be
            // fractional): its share of the increment so far, to the nearest whole packet, so
            // that every pixel is about the same fraction of the way whenever time runs out.
            let part = |i: usize, f: f64| -> u32 {
                let (s0, t) = (from[i], target[i]);
                if f >= SUB_PASSES as f64 {
                    return t.max(s0);
                }
                let inc = t.saturating_sub(s0) as f64 * f / SUB_PASSES as f64;
                let packets = (inc / LANES as f64).round() as u32;
                s0 + t.saturating_sub(s0).min(packets * LANES as u32)
            };
            let mut last = 0f64;
            for j in 1..=SUB_PASSES {
                // A pass that would end past the limit (judged by the last pass) is cut to
                // the part that fits; less than a tenth of a pass is not started.
                let t0 = start.elapsed().as_secs_f64();
                let left = opts.time_limit.map_or(f64::INFINITY, |limit| limit - t0);
                let f = if last > left { left / last } else { 1.0 };
                if f < 0.1 {
                    restore(film, &target);
                    return false;
                }
                let at = (j - 1) as f64 + f;
                for (i, p) in film.pixels_mut().iter_mut().enumerate() {
                    p.target = part(i, at);
                }
                run_pass(film, u32::MAX, false);
                let step = (light_target - light_from) as f64 * at / SUB_PASSES as f64;
                light_to(film, light_from + step.ceil() as u32);
                last = start.elapsed().as_secs_f64() - t0;
                if f < 1.0 || out_of_time() || stopped() {
                    // Back to the round's targets, which a resumed render continues.
                    restore(film, &target);
                    return reached(film);
                }
            }
            return true;
        }
        let done = film.pixels().iter().map(|p| p.n).min().unwrap_or(0);
        for k in done..count {
            run_pass(film, k + 1, false);
            light_to(film, k + 1);
            (ctl.progress)(k as usize + 1, count as usize);
            if out_of_time() || stopped() {
                return reached_all(film);
            }
        }
        light_to(film, count)
    };
    // The adaptive budget's rounds: film.level is the level (mean samples per pixel) whose
    // targets the pixels hold, so a resumed render finishes the round it was stopped in.
    let mut more = run_to_targets(film);
    while opts.adaptive_budget && more && film.level < opts.spp {
        (ctl.progress)(film.level as usize, opts.spp as usize);
        let level = film.level.saturating_mul(2).min(opts.spp);
        let n = (w * h) as usize;
        let (mut var, mut cost, mut current) = (vec![0f64; n], vec![1f64; n], vec![0u32; n]);
        for (i, p) in film.pixels().iter().enumerate() {
            let q = film.pixel_index(i);
            let other = film.light_mean(q);
            (var[q], cost[q], current[q]) = (p.rel_variance_beside(other), p.cost(), p.n);
        }
        let budget = level as f64 * cost.iter().sum::<f64>();
        // Whole packets per pixel once the round's mean increment (film.level) allows.
        let quantum = (film.level / 4).clamp(1, LANES as u32);
        let targets = allocate(
            &var,
            &cost,
            (w as usize, h as usize),
            &current,
            budget,
            (cap, quantum),
        );
        for i in 0..n {
            let q = film.pixel_index(i);
            film.pixels_mut()[i].target = targets[q];
        }
        film.level = level;
        more = run_to_targets(film);
    }
    if opts.adaptive_budget && more {
        (ctl.progress)(opts.spp as usize, opts.spp as usize);
    }
    let complete = more && reached_all(film);
    Ok(RenderStats {
        seconds: start.elapsed().as_secs_f64(),
        samples: taken.into_inner(),
        rays: rays.into_inner(),
        non_finite: bad.into_inner(),
        threads,
        samples_per_pixel: film.counts(),
        complete,
    })
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
pub fn aux_images(scene: &Scene, opts: &RenderOptions) -> Result<AuxImages> {
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
                    let (ray, _) = camera_ray(scene, opts, &setup, x, y, k);
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

/// True when every pixel of `film` has reached its target (or CS184's rule stopped it).
fn reached(film: &Film) -> bool {
    film.pixels().iter().all(|p| p.done || p.n >= p.target)
}

/// Puts back the targets of an adaptive round (sub-passes lower them temporarily), so that
/// the film records the round a resumed render has to finish.
fn restore(film: &mut Film, target: &[u32]) {
    for (p, &t) in film.pixels_mut().iter_mut().zip(target) {
        p.target = t;
    }
}

/// The sample range `[first, first + count)` of `opts` (all of `[0, spp)` without one),
/// refused when empty or beyond `spp`.
fn sample_range(opts: &RenderOptions) -> Result<(u32, u32)> {
    let (first, count) = opts.sample_range.unwrap_or((0, opts.spp));
    if opts.spp == 0 || count == 0 || first as u64 + count as u64 > opts.spp as u64 {
        return Err(Error::Usage(format!(
            "sample range {first}..{} is empty or beyond -s {}",
            first as u64 + count as u64,
            opts.spp
        )));
    }
    Ok((first, count))
}

/// A pool of `threads` worker threads (all cores when `None`), and its size.
fn thread_pool(threads: Option<usize>) -> Result<(rayon::ThreadPool, usize)> {
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

/// The camera ray of sample `k` of frame pixel `(x, y)` (its sub-pixel position and lens
/// point), and the sample's numbers for the rest of the path.
#[inline]
fn camera_ray(
    scene: &Scene,
    opts: &RenderOptions,
    setup: &SamplerSetup,
    x: u32,
    y: u32,
    k: u32,
) -> (crate::math::Ray, crate::sampling::sampler::Sampler) {
    let sampler = setup.sample(x, y, k);
    let j = sampler.get_2d(dim::PIXEL);
    let u = if scene.camera.lens_radius > 0.0 {
        sampler.get_2d(dim::LENS)
    } else {
        Vec2::ZERO
    };
    let ray = scene
        .camera
        .ray(x as f32 + j.x, y as f32 + j.y, opts.width, opts.height, u);
    (ray, sampler)
}

/// A frame pixel and the first sample of its range.
#[derive(Clone, Copy)]
struct Pixel {
    x: u32,
    y: u32,
    first: u32,
}

/// Pixels per piece when the adaptive budget splits a tile among threads (enough to fill
/// packets with the samples that pixels leave over).
const SPLIT: usize = 16;

/// Where sample radiance goes: the pixels of one run of [`samples`], with the rays traced
/// and the non-finite samples counted.
struct Taker<'a> {
    rays: &'a mut u64,
    bad: &'a mut u64,
}

impl Taker<'_> {
    /// Adds one sample's radiance `l` (traced with `nrays` rays) to `p` and returns what it
    /// added: a non-finite value counts as bad and adds black.
    #[inline]
    fn take(&mut self, p: &mut FilmPixel, l: Vec3, nrays: u64) -> Vec3 {
        *self.rays += nrays;
        let l = if l.is_finite() {
            l
        } else {
            *self.bad += 1;
            Vec3::ZERO
        };
        p.add(l, nrays);
        l
    }
}

/// Takes the samples from `p.n` up to `min(j1, p.target)` (counted from the pixel's first
/// sample) of each pixel `p = ps[i]` at frame pixel `at(i)` (fewer when CS184 adaptive
/// sampling stops the pixel or `stop` is set). Sample `k` draws from its own numbers, and the
/// film sums are exact (fixed point), so the result does not depend on how samples are split
/// into passes, calls or machines, nor on the order they are added in.
///
/// With `packets` (the scene and settings suit [`crate::packet`]), each pixel's samples are
/// traced eight at a time; those left over (fewer than eight per pixel, as in passes of one
/// sample per pixel) are gathered across the pixels of `ps` into packets of eight, and the
/// last few are traced alone. Each sample gives the bits the scalar integrator would.
#[allow(clippy::too_many_arguments)]
fn samples(
    scene: &Scene,
    opts: &RenderOptions,
    setup: &SamplerSetup,
    packets: bool,
    at: impl Fn(usize) -> Pixel,
    j1: u32,
    ps: &mut [FilmPixel],
    stop: &AtomicBool,
    rays: &mut u64,
    bad: &mut u64,
) {
    use crate::packet::radiance8;
    let mut t = Taker { rays, bad };
    let stopped = || stop.load(Ordering::Relaxed);
    if !packets {
        for (i, p) in ps.iter_mut().enumerate() {
            scalar_samples(scene, opts, setup, at(i), j1, p, stop, &mut t);
        }
        return;
    }
    // Eight samples, each `(pixel index in ps, sample number from the pixel's first)`.
    let trace = |ps: &mut [FilmPixel], lanes: &[(usize, u32); LANES], t: &mut Taker| {
        let cams: [_; LANES] = std::array::from_fn(|l| {
            let (i, k) = lanes[l];
            let a = at(i);
            camera_ray(scene, opts, setup, a.x, a.y, a.first + k)
        });
        let rays8 = cams.map(|c| c.0);
        let samplers = cams.map(|c| c.1);
        let mut n8 = [0u64; LANES];
        let ls = radiance8(scene, &rays8, &samplers, &opts.integrator, &mut n8);
        for l in 0..LANES {
            t.take(&mut ps[lanes[l].0], ls[l], n8[l]);
        }
    };
    // Samples left over by their pixels' runs of eight, waiting for a packet.
    let mut rest = [(0usize, 0u32); LANES];
    let mut waiting = 0;
    for i in 0..ps.len() {
        let end = j1.min(ps[i].target);
        while ps[i].n + LANES as u32 <= end && !stopped() {
            let k0 = ps[i].n;
            trace(ps, &std::array::from_fn(|l| (i, k0 + l as u32)), &mut t);
        }
        // A pixel's leftovers follow its own samples; `n` moves when they are traced.
        for k in ps[i].n..end {
            rest[waiting] = (i, k);
            waiting += 1;
            if waiting == LANES {
                if stopped() {
                    return;
                }
                trace(ps, &rest, &mut t);
                waiting = 0;
            }
        }
    }
    for &(i, k) in &rest[..waiting] {
        if stopped() {
            return;
        }
        debug_assert_eq!(ps[i].n, k);
        scalar_samples(scene, opts, setup, at(i), k + 1, &mut ps[i], stop, &mut t);
    }
}

/// The samples of pixel `p` at `at` from `p.n` up to `min(j1, p.target)`, one at a time with
/// the scalar integrator, with CS184 adaptive sampling's stopping rule where it is on.
#[allow(clippy::too_many_arguments)]
fn scalar_samples(
    scene: &Scene,
    opts: &RenderOptions,
    setup: &SamplerSetup,
    at: Pixel,
    j1: u32,
    p: &mut FilmPixel,
    stop: &AtomicBool,
    t: &mut Taker,
) {
    while p.n < j1.min(p.target) && !p.done && !stop.load(Ordering::Relaxed) {
        let (ray, sampler) = camera_ray(scene, opts, setup, at.x, at.y, at.first + p.n);
        let mut nrays = 0u64;
        let l = radiance(scene, ray, &sampler, &opts.integrator, &mut nrays);
        let l = t.take(p, l, nrays);
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
        let a = aux_images(&scene, &opts).unwrap();
        let b = aux_images(
            &scene,
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
