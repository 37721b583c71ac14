//! Orchestration: image tiles over a thread pool, per-pixel random streams, progress and
//! statistics. The result depends only on the seed, never on the thread count or schedule.

use crate::error::{Error, Result};
use crate::integrator::{radiance, IntegratorSettings};
use crate::io::image::Image;
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

/// Everything a render needs besides the scene.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Camera samples per pixel (`-s`).
    pub spp: u32,
    /// Worker threads (`-t`); `None` = all cores.
    pub threads: Option<usize>,
    /// Seed of all random streams (`--seed`).
    pub seed: u64,
    /// Path tracing settings.
    pub integrator: IntegratorSettings,
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
    /// Samples discarded because their radiance was NaN or infinite.
    pub non_finite: u64,
    /// Threads used.
    pub threads: usize,
}

/// Side of the square tiles that threads take, in pixels.
pub const TILE: u32 = 16;

/// Renders `scene`. `progress(done, total)` is called from worker threads as tiles finish.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Image, RenderStats)> {
    let (w, h) = (opts.width, opts.height);
    if w == 0 || h == 0 || opts.spp == 0 {
        return Err(Error::Usage(
            "image size and sample count must be positive".into(),
        ));
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
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let ntiles = (tx * ty) as usize;
    let done = AtomicUsize::new(0);
    let rays = AtomicU64::new(0);
    let bad = AtomicU64::new(0);
    let start = Instant::now();
    let tiles: Vec<(u32, Vec<Vec3>)> = pool.install(|| {
        (0..ntiles as u32)
            .into_par_iter()
            .map(|t| {
                let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
                let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
                let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                let (mut nrays, mut nbad) = (0u64, 0u64);
                for y in y0..y1 {
                    for x in x0..x1 {
                        let mut rng = Rng::for_pixel(opts.seed, y as u64 * w as u64 + x as u64);
                        let mut sum = DVec3::ZERO;
                        for _ in 0..opts.spp {
                            let j = rng.next_2d();
                            let ray = scene.camera.ray(x as f32 + j.x, y as f32 + j.y, w, h);
                            let l = radiance(scene, ray, &mut rng, &opts.integrator, &mut nrays);
                            if l.is_finite() {
                                sum += l.as_dvec3();
                            } else {
                                nbad += 1;
                            }
                        }
                        out.push((sum / opts.spp as f64).as_vec3());
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
    for (t, px) in tiles {
        let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
        let tw = (x0 + TILE).min(w) - x0;
        for (i, p) in px.into_iter().enumerate() {
            let (x, y) = (x0 + i as u32 % tw, y0 + i as u32 / tw);
            img.pixels[(y * w + x) as usize] = p;
        }
    }
    let stats = RenderStats {
        seconds,
        samples: w as u64 * h as u64 * opts.spp as u64,
        rays: rays.into_inner(),
        non_finite: bad.into_inner(),
        threads,
    };
    Ok((img, stats))
}
