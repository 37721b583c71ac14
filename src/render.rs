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
    /// Adaptive sampling, if any.
    pub adaptive: Option<Adaptive>,
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
    let (w, h) = (cell.w, cell.h);
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let ntiles = (tx * ty) as usize;
    // Each tile owns the accumulators of its pixels, row-major within the tile.
    let mut tiles: Vec<(u32, Vec<PixelAcc>)> = (0..ntiles as u32)
        .map(|t| {
            let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
            let n = ((x0 + TILE).min(w) - x0) * ((y0 + TILE).min(h) - y0);
            (t, vec![PixelAcc::default(); n as usize])
        })
        .collect();
    let setup = SamplerSetup::new(opts.sampler, opts.seed, fw, fh, opts.spp);
    let rays = AtomicU64::new(0);
    let bad = AtomicU64::new(0);
    let start = Instant::now();
    let run_pass = |tiles: &mut Vec<(u32, Vec<PixelAcc>)>, k0: u32, k1: u32, per_tile: bool| {
        let done = AtomicUsize::new(0);
        pool.install(|| {
            tiles.par_iter_mut().for_each(|(t, accs)| {
                let (x0, y0) = ((*t % tx) * TILE, (*t / tx) * TILE);
                let tw = (x0 + TILE).min(w) - x0;
                let (mut nrays, mut nbad) = (0u64, 0u64);
                for (i, acc) in accs.iter_mut().enumerate() {
                    let (x, y) = (cell.x + x0 + i as u32 % tw, cell.y + y0 + i as u32 / tw);
                    samples(
                        scene, opts, &setup, x, y, k0, k1, acc, &mut nrays, &mut nbad,
                    );
                }
                rays.fetch_add(nrays, Ordering::Relaxed);
                bad.fetch_add(nbad, Ordering::Relaxed);
                if per_tile {
                    progress(done.fetch_add(1, Ordering::Relaxed) + 1, ntiles);
                }
            })
        });
    };
    match opts.time_limit {
        None => run_pass(&mut tiles, 0, opts.spp, true),
        Some(limit) => {
            for k in 0..opts.spp {
                run_pass(&mut tiles, k, k + 1, false);
                progress(k as usize + 1, opts.spp as usize);
                if start.elapsed().as_secs_f64() >= limit {
                    break;
                }
            }
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let mut img = Image::new(w as usize, h as usize);
    let mut counts = vec![0u32; (w * h) as usize];
    for (t, accs) in tiles {
        let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
        let tw = (x0 + TILE).min(w) - x0;
        for (i, acc) in accs.into_iter().enumerate() {
            let (x, y) = (x0 + i as u32 % tw, y0 + i as u32 / tw);
            img.pixels[(y * w + x) as usize] = (acc.sum / acc.n.max(1) as f64).as_vec3();
            counts[(y * w + x) as usize] = acc.n;
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
    /// Samples taken.
    n: u32,
    /// Sum of the samples' illuminance and of its square (adaptive sampling).
    s1: f64,
    s2: f64,
    /// Adaptive sampling stopped this pixel.
    done: bool,
}

/// Takes samples `k0..k1` of frame pixel `(x, y)` into `acc` (fewer when adaptive sampling
/// stops the pixel). Sample `k` draws from its own random stream.
#[allow(clippy::too_many_arguments)]
fn samples(
    scene: &Scene,
    opts: &RenderOptions,
    setup: &SamplerSetup,
    x: u32,
    y: u32,
    k0: u32,
    k1: u32,
    acc: &mut PixelAcc,
    rays: &mut u64,
    bad: &mut u64,
) {
    let (w, h) = (opts.width, opts.height);
    let lens = scene.camera.lens_radius > 0.0;
    for k in k0..k1 {
        if acc.done {
            return;
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
        acc.sum += l.as_dvec3();
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
}

#[cfg(test)]
mod tests {
    use super::*;

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
