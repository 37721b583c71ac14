//! Orchestration: image tiles over a thread pool, per-pixel random streams, adaptive sampling,
//! cells, progress and statistics. The result depends only on the seed, never on the thread
//! count, the schedule or the cell: every pixel draws from its own stream, indexed by its
//! position in the full frame.

use crate::error::{Error, Result};
use crate::integrator::{radiance, IntegratorSettings};
use crate::io::image::Image;
use crate::math::luminance;
use crate::sampling::Rng;
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
    /// Adaptive sampling, if any.
    pub adaptive: Option<Adaptive>,
    /// Render only this cell of the frame (the output has the cell's size).
    pub cell: Option<Cell>,
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
            adaptive: None,
            cell: None,
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
    let (w, h) = (cell.w, cell.h);
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let ntiles = (tx * ty) as usize;
    let done = AtomicUsize::new(0);
    let rays = AtomicU64::new(0);
    let bad = AtomicU64::new(0);
    let start = Instant::now();
    let tiles: Vec<(u32, Vec<(Vec3, u32)>)> = pool.install(|| {
        (0..ntiles as u32)
            .into_par_iter()
            .map(|t| {
                let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
                let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                let (mut nrays, mut nbad) = (0u64, 0u64);
                for y in y0..y1 {
                    for x in x0..x1 {
                        let (fx, fy) = (cell.x + x, cell.y + y);
                        out.push(pixel(scene, opts, fx, fy, &mut nrays, &mut nbad));
                    }
                }
                rays.fetch_add(nrays, Ordering::Relaxed);
                bad.fetch_add(nbad, Ordering::Relaxed);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, ntiles);
                (t, out)
            })
            .collect()
    });
    let seconds = start.elapsed().as_secs_f64();
    let mut img = Image::new(w as usize, h as usize);
    let mut counts = vec![0u32; (w * h) as usize];
    for (t, px) in tiles {
        let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
        let tw = (x0 + TILE).min(w) - x0;
        for (i, (p, n)) in px.into_iter().enumerate() {
            let (x, y) = (x0 + i as u32 % tw, y0 + i as u32 / tw);
            img.pixels[(y * w + x) as usize] = p;
            counts[(y * w + x) as usize] = n;
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

/// One pixel of the frame: its mean radiance and the number of samples taken.
fn pixel(
    scene: &Scene,
    opts: &RenderOptions,
    x: u32,
    y: u32,
    rays: &mut u64,
    bad: &mut u64,
) -> (Vec3, u32) {
    let (w, h) = (opts.width, opts.height);
    let mut rng = Rng::for_pixel(opts.seed, y as u64 * w as u64 + x as u64);
    let lens = scene.camera.lens_radius > 0.0;
    let mut sum = DVec3::ZERO;
    let (mut s1, mut s2) = (0f64, 0f64);
    let mut n = 0u32;
    while n < opts.spp {
        let j = rng.next_2d();
        let u = if lens { rng.next_2d() } else { Vec2::ZERO };
        let ray = scene.camera.ray(x as f32 + j.x, y as f32 + j.y, w, h, u);
        let mut l = radiance(scene, ray, &mut rng, &opts.integrator, rays);
        if !l.is_finite() {
            *bad += 1;
            l = Vec3::ZERO;
        }
        sum += l.as_dvec3();
        n += 1;
        if let Some(a) = opts.adaptive {
            let x = luminance(l) as f64;
            s1 += x;
            s2 += x * x;
            if n.is_multiple_of(a.batch) && converged(n, s1, s2, a.tolerance) {
                break;
            }
        }
    }
    ((sum / n as f64).as_vec3(), n)
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
