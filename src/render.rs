//! Orchestration: image tiles over a thread pool, per-pixel random streams, adaptive sampling,
//! cells, progress and statistics. The result depends only on the seed, never on the thread
//! count, the schedule or the cell: every pixel draws from its own stream, indexed by its
//! position in the full frame.

use crate::error::{Error, Result};
use crate::integrator::{radiance, IntegratorSettings};
use crate::io::image::Image;
use crate::math::luminance;
use crate::sampling::sampler::{dim, SamplerKind, SamplerSetup};
use crate::scene::Scene;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

/// CS184 adaptive sampling (`-a BATCH TOL`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// Samples between convergence checks.
    pub batch: u32,
    /// Stop when the 95% confidence half-width `1.96·σ/√n` is at most `tolerance · μ`.
    pub tolerance: f32,
}

/// A rectangle of the frame, in pixels: top-left corner and size (`-p X Y DX DY`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cell {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width.
    pub w: u32,
    /// Height.
    pub h: u32,
}

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
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 480,
            height: 360,
            spp: 16,
            threads: None,
            seed: 0,
            integrator: IntegratorSettings::default(),
            sampler: SamplerKind::default(),
            adaptive: None,
            adaptive_budget: false,
            cell: None,
            time_limit: None,
        }
    }
}

/// Figures of a finished render.
#[derive(Clone, Debug)]
pub struct RenderStats {
    /// Wall time of the rendering loop, seconds.
    pub seconds: f64,
    /// Camera samples taken.
    pub samples: u64,
    /// Rays traced (camera, continuation, shadow).
    pub rays: u64,
    /// Samples whose radiance was NaN or infinite; they count as black.
    pub non_finite: u64,
    /// Threads used.
    pub threads: usize,
    /// Samples taken per pixel of the output (row-major), differing with adaptive sampling.
    pub samples_per_pixel: Vec<u32>,
}

impl RenderStats {
    /// Mean camera samples per pixel.
    pub fn mean_spp(&self) -> f64 {
        self.samples as f64 / self.samples_per_pixel.len().max(1) as f64
    }
}

/// Side of the square tiles that threads take, in pixels.
pub const TILE: u32 = 16;

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
/// 1% of the mean. Targets never fall below `current` and never exceed `cap`; the multiplier
/// is found by bisection so that `Σ target·cost` meets `budget` (in the units of `cost`).
pub fn allocate(
    var: &[f64],
    cost: &[f64],
    (w, h): (usize, usize),
    current: &[u32],
    budget: f64,
    cap: u32,
) -> Vec<u32> {
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
        ((lambda * weight[i]).round().min(cap as f64) as u32).max(current[i])
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

/// Renders `scene` (or one cell of it). `progress(done, total)` is called from worker threads
/// as tiles finish.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Image, RenderStats)> {
    let (fw, fh) = (opts.width, opts.height);
    if fw == 0 || fh == 0 || opts.spp == 0 {
        return Err(Error::Usage(
            "image size and sample count must be positive".into(),
        ));
    }
    let cell = opts.cell.unwrap_or(Cell {
        x: 0,
        y: 0,
        w: fw,
        h: fh,
    });
    if cell.w == 0
        || cell.h == 0
        || cell.x as u64 + cell.w as u64 > fw as u64
        || cell.y as u64 + cell.h as u64 > fh as u64
    {
        return Err(Error::Usage(format!(
            "cell {}x{} at ({}, {}) does not fit in the {fw}x{fh} frame",
            cell.w, cell.h, cell.x, cell.y
        )));
    }
    if let Some(a) = opts.adaptive {
        if a.batch == 0 || !(a.tolerance > 0.0 && a.tolerance.is_finite()) {
            return Err(Error::Usage(
                "adaptive sampling needs a positive batch size and tolerance".into(),
            ));
        }
    }
    let threads = opts
        .threads
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
    let (w, h) = (cell.w, cell.h);
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let ntiles = (tx * ty) as usize;
    // The adaptive budget starts from a uniform pilot of n0 samples per pixel.
    let cap = if opts.adaptive_budget {
        opts.spp.saturating_mul(ADAPTIVE_CAP)
    } else {
        opts.spp
    };
    let n0 = if opts.adaptive_budget {
        (opts.spp / 8).clamp(2, 16)
    } else {
        opts.spp
    };
    // Each tile owns the accumulators of its pixels, row-major within the tile.
    let mut tiles: Vec<(u32, Vec<PixelAcc>)> = (0..ntiles as u32)
        .map(|t| {
            let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
            let n = ((x0 + TILE).min(w) - x0) * ((y0 + TILE).min(h) - y0);
            let acc = PixelAcc {
                target: n0,
                ..Default::default()
            };
            (t, vec![acc; n as usize])
        })
        .collect();
    // Cell-relative pixel index of entry i of tile t.
    let pixel_of = |t: u32, i: usize| {
        let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
        let tw = (x0 + TILE).min(w) - x0;
        ((y0 + i as u32 / tw) * w + x0 + i as u32 % tw) as usize
    };
    let setup = SamplerSetup::new(opts.sampler, opts.seed, fw, fh, cap);
    let rays = AtomicU64::new(0);
    let bad = AtomicU64::new(0);
    let start = Instant::now();
    // Every pixel takes samples up to min(k1, its target).
    let run_pass = |tiles: &mut Vec<(u32, Vec<PixelAcc>)>, k1: u32, per_tile: bool| {
        let done = AtomicUsize::new(0);
        pool.install(|| {
            tiles.par_iter_mut().for_each(|(t, accs)| {
                let (x0, y0) = ((*t % tx) * TILE, (*t / tx) * TILE);
                let tw = (x0 + TILE).min(w) - x0;
                let run = |(i, acc): (usize, &mut PixelAcc)| {
                    let (x, y) = (cell.x + x0 + i as u32 % tw, cell.y + y0 + i as u32 / tw);
                    let (mut nrays, mut nbad) = (0u64, 0u64);
                    samples(scene, opts, &setup, x, y, k1, acc, &mut nrays, &mut nbad);
                    rays.fetch_add(nrays, Ordering::Relaxed);
                    bad.fetch_add(nbad, Ordering::Relaxed);
                };
                if opts.adaptive_budget {
                    // Targets differ from pixel to pixel: split tiles too, so that no thread
                    // is left alone with a tile of costly pixels at the end of a round.
                    accs.par_iter_mut().enumerate().for_each(run);
                } else {
                    accs.iter_mut().enumerate().for_each(run);
                }
                if per_tile {
                    progress(done.fetch_add(1, Ordering::Relaxed) + 1, ntiles);
                }
            })
        });
    };
    let out_of_time = || {
        opts.time_limit
            .is_some_and(|limit| start.elapsed().as_secs_f64() >= limit)
    };
    // Brings every pixel to its target: one pass without a time limit. With one, uniform
    // renders take passes of one sample per pixel (checking the time after each), adaptive
    // rounds SUB_PASSES passes that each take every pixel that fraction of the way to its
    // target; an adaptive render does not start a pass that would end past the limit (judged
    // by the last pass), so it ends before the limit rather than up to a pass after it.
    // Returns false when time ran out.
    let run_to_targets = |tiles: &mut Vec<(u32, Vec<PixelAcc>)>| -> bool {
        if opts.time_limit.is_none() {
            run_pass(tiles, u32::MAX, !opts.adaptive_budget);
            return true;
        }
        if opts.adaptive_budget {
            let from: Vec<Vec<u32>> = tiles
                .iter()
                .map(|t| t.1.iter().map(|a| a.n).collect())
                .collect();
            let target: Vec<Vec<u32>> = tiles
                .iter()
                .map(|t| t.1.iter().map(|a| a.target).collect())
                .collect();
            let mut last = 0f64;
            for j in 1..=SUB_PASSES {
                // Stop before a pass that would end past the limit (as long as the last one).
                let t0 = start.elapsed().as_secs_f64();
                if opts.time_limit.is_some_and(|limit| t0 + last > limit) {
                    return false;
                }
                for (ti, (_, accs)) in tiles.iter_mut().enumerate() {
                    for (i, acc) in accs.iter_mut().enumerate() {
                        let (s0, t) = (from[ti][i] as u64, target[ti][i] as u64);
                        acc.target = (s0 + (t.saturating_sub(s0) * j).div_ceil(SUB_PASSES)) as u32;
                    }
                }
                run_pass(tiles, u32::MAX, false);
                last = start.elapsed().as_secs_f64() - t0;
                if out_of_time() {
                    return false;
                }
            }
            return true;
        }
        for k in 0..opts.spp {
            run_pass(tiles, k + 1, false);
            progress(k as usize + 1, opts.spp as usize);
            if out_of_time() {
                return false;
            }
        }
        true
    };
    let mut level = n0;
    let mut more = run_to_targets(&mut tiles);
    while opts.adaptive_budget && more && level < opts.spp {
        progress(level as usize, opts.spp as usize);
        level = level.saturating_mul(2).min(opts.spp);
        let n = (w * h) as usize;
        let (mut var, mut cost, mut current) = (vec![0f64; n], vec![1f64; n], vec![0u32; n]);
        for (t, accs) in &tiles {
            for (i, acc) in accs.iter().enumerate() {
                let p = pixel_of(*t, i);
                (var[p], cost[p], current[p]) = (acc.rel_variance(), acc.cost(), acc.n);
            }
        }
        let budget = level as f64 * cost.iter().sum::<f64>();
        let targets = allocate(&var, &cost, (w as usize, h as usize), &current, budget, cap);
        for (t, accs) in tiles.iter_mut() {
            for (i, acc) in accs.iter_mut().enumerate() {
                acc.target = targets[pixel_of(*t, i)];
            }
        }
        more = run_to_targets(&mut tiles);
    }
    if opts.adaptive_budget {
        progress(opts.spp as usize, opts.spp as usize);
    }
    let seconds = start.elapsed().as_secs_f64();
    let mut img = Image::new(w as usize, h as usize);
    let mut counts = vec![0u32; (w * h) as usize];
    for (t, accs) in tiles {
        for (i, acc) in accs.into_iter().enumerate() {
            let p = pixel_of(t, i);
            img.pixels[p] = (acc.sum / acc.n.max(1) as f64).as_vec3();
            counts[p] = acc.n;
        }
    }
    let stats = RenderStats {
        seconds,
        samples: counts.iter().map(|&n| n as u64).sum(),
        rays: rays.into_inner(),
        non_finite: bad.into_inner(),
        threads,
        samples_per_pixel: counts,
    };
    Ok((img, stats))
}

/// Running sums of one pixel.
#[derive(Clone, Copy, Debug, Default)]
struct PixelAcc {
    /// Sum of the sample radiances.
    sum: DVec3,
    /// Sum of their squares, per channel (adaptive budget).
    sum2: DVec3,
    /// Rays traced for this pixel (adaptive budget: the cost of its samples).
    rays: u64,
    /// Samples taken.
    n: u32,
    /// Samples this pixel is to reach.
    target: u32,
    /// Sum of the samples' illuminance and of its square (adaptive sampling).
    s1: f64,
    s2: f64,
    /// Adaptive sampling stopped this pixel.
    done: bool,
}

impl PixelAcc {
    /// Relative variance of one sample: per channel, the sample variance over `mean² + 0.01`
    /// (the denominator of the relative MSE), summed over channels.
    fn rel_variance(&self) -> f64 {
        if self.n < 2 {
            return 0.0;
        }
        let n = self.n as f64;
        let mean = self.sum / n;
        let var = ((self.sum2 - self.sum * mean) / (n - 1.0)).max(DVec3::ZERO);
        (var / (mean * mean + DVec3::splat(0.01))).element_sum()
    }

    /// Rays per sample.
    fn cost(&self) -> f64 {
        (self.rays as f64 / self.n.max(1) as f64).max(1.0)
    }
}

/// Takes the samples from `acc.n` up to `min(k1, acc.target)` of frame pixel `(x, y)` into
/// `acc` (fewer when CS184 adaptive sampling stops the pixel). Sample `k` draws from its own
/// numbers, so the result does not depend on how samples are split into passes.
#[allow(clippy::too_many_arguments)]
fn samples(
    scene: &Scene,
    opts: &RenderOptions,
    setup: &SamplerSetup,
    x: u32,
    y: u32,
    k1: u32,
    acc: &mut PixelAcc,
    rays: &mut u64,
    bad: &mut u64,
) {
    let (w, h) = (opts.width, opts.height);
    let lens = scene.camera.lens_radius > 0.0;
    let rays_before = *rays;
    for k in acc.n..k1.min(acc.target) {
        if acc.done {
            break;
        }
        let sampler = setup.sample(x, y, k);
        let j = sampler.get_2d(dim::PIXEL);
        let u = if lens {
            sampler.get_2d(dim::LENS)
        } else {
            Vec2::ZERO
        };
        let ray = scene.camera.ray(x as f32 + j.x, y as f32 + j.y, w, h, u);
        let mut l = radiance(scene, ray, &sampler, &opts.integrator, rays);
        if !l.is_finite() {
            *bad += 1;
            l = Vec3::ZERO;
        }
        let ld = l.as_dvec3();
        acc.sum += ld;
        acc.sum2 += ld * ld;
        acc.n += 1;
        if let Some(a) = opts.adaptive {
            let v = luminance(l) as f64;
            acc.s1 += v;
            acc.s2 += v * v;
            if acc.n.is_multiple_of(a.batch) && converged(acc.n, acc.s1, acc.s2, a.tolerance) {
                acc.done = true;
            }
        }
    }
    acc.rays += *rays - rays_before;
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
        let t = allocate(&var, &cost, (w, h), &current, budget, 1000);
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
            20,
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
            100,
        );
        assert!(flat.iter().all(|&n| n == 10), "{flat:?}");
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
