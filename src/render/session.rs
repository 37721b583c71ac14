//! A render session: what every schedule shares while it fills a film — the thread pool, the
//! sampler set-up, the camera, the light passes' splats and the counters — and its two kinds
//! of work, a pass of camera samples over the film's tiles ([`Session::pass`]) and light
//! passes ([`Session::light_to`]).

use super::samples::Taker;
use super::samples::{samples, Pixel, SampleRun, SPLIT};
use super::splat::{ring, Block, Rect};
use super::ADAPTIVE_CAP;
use super::{new_film, sample_range, thread_pool, Control, RenderOptions, RenderStats};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::film::{splat_fixed, FeatureSums, Film, FilmPixel};
use crate::lighttrace::LightPathSettings;
use crate::sampling::sampler::SamplerSetup;
use crate::scene::Scene;
use crate::vertex::IntegratorSettings;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// A pass's splatted camera samples, row-major over the cell, and the frame pixels around the
/// cell whose samples reach into it ([`super::splat::ring`]).
type Filtered = (Mutex<Vec<[i128; 4]>>, Vec<(u32, u32)>);

/// One render of a scene through a camera into a film.
pub struct Session<'a> {
    pub(super) scene: &'a Scene,
    camera: &'a Camera,
    /// The options, with light tracing turned off where it cannot be used.
    pub(super) opts: RenderOptions,
    pub(super) ctl: Control<'a>,
    pool: rayon::ThreadPool,
    threads: usize,
    setup: SamplerSetup,
    /// Whether camera samples are traced in packets of eight.
    packets: bool,
    /// The learned sampling of the scene's environment light ([`crate::guide`]), if on.
    guide: Option<crate::guide::EnvGuide>,
    /// Whether caustic light paths are traced (see [`crate::lighttrace`]).
    pub(super) light_tracing: bool,
    /// The film's sample range `[first, first + count)`.
    first: u32,
    /// The film's cell.
    cell: crate::film::Cell,
    pub(super) count: u32,
    /// Bounding spheres of the caustic surfaces, for light paths.
    targets: Vec<(Vec3, f32)>,
    /// Light-path splats of the light passes not yet folded into the film, fixed point,
    /// row-major over the cell.
    splats: Vec<[AtomicI64; 3]>,
    /// Where camera samples are splatted ([`crate::filter::PixelFilter::spreads`]): the
    /// pass's weighted sums, row-major over the cell, folded into the film after the pass
    /// ([`super::splat`]), and the frame pixels around a cell whose samples reach into it.
    filtered: Option<Filtered>,
    rays: AtomicU64,
    non_finite: AtomicU64,
    taken: AtomicU64,
    pub(super) start: Instant,
}

impl<'a> Session<'a> {
    /// A session rendering `scene` through `camera` with `opts` into `film` (made by
    /// [`new_film`] with the same options, or loaded from a checkpoint of them); the options
    /// are checked first ([`RenderOptions::validate`]).
    pub fn new(
        scene: &'a Scene,
        camera: &'a Camera,
        opts: &RenderOptions,
        film: &Film,
        ctl: Control<'a>,
    ) -> Result<Session<'a>> {
        opts.validate()?;
        let (first, count) = sample_range(opts)?;
        let expected = new_film(opts)?;
        if film.frame() != expected.frame()
            || film.cell() != expected.cell()
            || film.first() != first
        {
            return Err(Error::Usage(
                "the film was made for another frame, cell or sample range".into(),
            ));
        }
        let (pool, threads) = thread_pool(opts.threads)?;
        // Caustic light tracing where it can be used (not with CS184's `-a`, whose stopping
        // rule sees only camera samples, nor with a pixel filter other than the pixel's own box,
        // which its splats do not follow; see `lighttrace::usable`). Its passes do not depend
        // on how camera samples are spread, so the adaptive budget takes one per level.
        let light_tracing = opts.integrator.light_tracing
            && opts.adaptive.is_none()
            && (opts.filter.is_pixel_box() || !opts.filter.splat)
            && super::tracers::light_tracing_usable(scene, camera);
        let opts = RenderOptions {
            integrator: IntegratorSettings {
                light_tracing,
                ..opts.integrator
            },
            ..opts.clone()
        };
        let setup = SamplerSetup::new(opts.sampler, opts.seed, opts.width, opts.height, cap(&opts));
        let packets = opts.adaptive.is_none()
            && crate::integrator::packet::supported(scene, &opts.integrator);
        let guide = super::guiding::train(scene, camera, &opts, &pool);
        let (targets, splats) = if light_tracing {
            let cell = film.cell();
            let n = cell.w as usize * cell.h as usize;
            let splats = (0..n).map(|_| Default::default()).collect();
            (super::tracers::light_targets(scene), splats)
        } else {
            (Vec::new(), Vec::new())
        };
        let filtered = opts.filter.spreads().then(|| {
            let cell = film.cell();
            let sums = vec![[0; 4]; cell.w as usize * cell.h as usize];
            let frame = (opts.width, opts.height);
            (Mutex::new(sums), ring(cell, opts.filter.reach(), frame))
        });
        Ok(Session {
            scene,
            camera,
            filtered,
            opts,
            ctl,
            pool,
            threads,
            setup,
            packets,
            guide,
            light_tracing,
            first,
            cell: film.cell(),
            count,
            targets,
            splats,
            rays: AtomicU64::new(0),
            non_finite: AtomicU64::new(0),
            taken: AtomicU64::new(0),
            start: Instant::now(),
        })
    }

    /// Whether the caller asked the render to stop.
    pub(super) fn stopped(&self) -> bool {
        self.ctl.stop.load(Ordering::Relaxed)
    }

    /// Whether the time limit, if any, has passed.
    pub(super) fn out_of_time(&self) -> bool {
        self.opts
            .time_limit
            .is_some_and(|limit| self.elapsed() >= limit)
    }

    /// Seconds since the session started.
    pub(super) fn elapsed(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// One pass over the film's tiles: every pixel takes samples up to `min(j1, its target)`
    /// (counted from the range's first sample). With `per_tile`, progress is reported per
    /// tile.
    pub(super) fn pass(&self, film: &mut Film, j1: u32, per_tile: bool) {
        // A cell's ring follows the counts of the cell's pixels in the pass.
        let before = self
            .filtered
            .as_ref()
            .filter(|(_, ring)| !ring.is_empty())
            .map(|_| film.counts());
        self.camera_pass(film, j1, per_tile);
        if let Some((sums, ring)) = &self.filtered {
            if let Some(before) = before {
                self.ring_samples(film, ring, &before);
            }
            let mut sums = sums.lock().unwrap_or_else(|e| e.into_inner());
            film.add_filtered(&sums);
            sums.iter_mut().for_each(|s| *s = [0; 4]);
        }
    }

    /// The camera samples of a pass over the film's tiles ([`Session::pass`]).
    fn camera_pass(&self, film: &mut Film, j1: u32, per_tile: bool) {
        let cell = film.cell();
        let ntiles = film.tiles().len();
        let done = AtomicUsize::new(0);
        let mut tiles = film.tiles_mut();
        self.pool.install(|| {
            tiles.par_iter_mut().for_each(|(t, px, fs)| {
                // The pixels of `ps` (features `fs`), from pixel `base` of the tile on.
                let run = |base: usize, ps: &mut [FilmPixel], fs: &mut [FeatureSums]| {
                    let at = |i: usize| {
                        let (x, y) = t.frame_xy(cell, base + i);
                        Pixel {
                            x,
                            y,
                            first: self.first,
                        }
                    };
                    self.take(at, j1, (ps, fs));
                };
                if self.opts.adaptive_budget {
                    // Targets differ from pixel to pixel: split tiles too, so that no thread
                    // is left alone with a tile of costly pixels at the end of a round.
                    let mut feature_chunks: Vec<&mut [FeatureSums]> = if fs.is_empty() {
                        (0..px.len().div_ceil(SPLIT)).map(|_| &mut [][..]).collect()
                    } else {
                        fs.chunks_mut(SPLIT).collect()
                    };
                    px.par_chunks_mut(SPLIT)
                        .zip(feature_chunks.par_iter_mut())
                        .enumerate()
                        .for_each(|(c, (ps, fs))| run(c * SPLIT, ps, fs));
                } else {
                    run(0, px, fs);
                }
                if let Some(f) = self.ctl.tile_done {
                    f(cell, t, px);
                }
                if per_tile {
                    (self.ctl.progress)(done.fetch_add(1, Ordering::Relaxed) + 1, ntiles);
                }
            })
        });
    }

    /// The samples of the pixels `ps` (pixel `i` at frame pixel `at(i)`) up to `j1`, counted
    /// (and splatted where samples are), stopping when `stop` is set.
    fn take_until(
        &self,
        at: impl Fn(usize) -> Pixel,
        j1: u32,
        (ps, fs): (&mut [FilmPixel], &mut [FeatureSums]),
        stop: &AtomicBool,
    ) {
        let before: u64 = ps.iter().map(|p| p.n as u64).sum();
        let mut block = self.filtered.as_ref().map(|_| {
            let (mut r, frame) = (
                Rect {
                    x0: u32::MAX,
                    y0: u32::MAX,
                    x1: 0,
                    y1: 0,
                },
                self.frame(),
            );
            for i in 0..ps.len() {
                let p = at(i);
                (r.x0, r.y0, r.x1, r.y1) =
                    (r.x0.min(p.x), r.y0.min(p.y), r.x1.max(p.x), r.y1.max(p.y));
            }
            Block::around(r, self.opts.filter.reach(), frame)
        });
        let mut t = Taker {
            rays: 0,
            bad: 0,
            splats: block.as_mut().map(|b| (&self.opts.filter, b)),
        };
        let run = SampleRun {
            scene: self.scene,
            camera: self.camera,
            guide: self.guide.as_ref(),
            opts: &self.opts,
            setup: &self.setup,
            packets: self.packets,
            stop,
        };
        samples(&run, at, j1, (&mut *ps, fs), &mut t);
        self.rays.fetch_add(t.rays, Ordering::Relaxed);
        self.non_finite.fetch_add(t.bad, Ordering::Relaxed);
        if let (Some(block), Some((sums, _))) = (&block, &self.filtered) {
            let cell = self.cell;
            block.add_into(cell, &mut sums.lock().unwrap_or_else(|e| e.into_inner()));
        }
        let after: u64 = ps.iter().map(|p| p.n as u64).sum();
        self.taken.fetch_add(after - before, Ordering::Relaxed);
    }

    /// [`Session::take_until`] the caller's stop.
    fn take(
        &self,
        at: impl Fn(usize) -> Pixel,
        j1: u32,
        pixels: (&mut [FilmPixel], &mut [FeatureSums]),
    ) {
        self.take_until(at, j1, pixels, self.ctl.stop);
    }

    /// The frame's size in pixels.
    fn frame(&self) -> (u32, u32) {
        (self.opts.width, self.opts.height)
    }

    /// The samples of the frame pixels around a cell whose splats reach into it: each takes
    /// the samples its nearest cell pixel took in this pass (counts `before` it, row-major
    /// over the cell, and now), so that the cell's border pixels get what the whole frame's
    /// render gives them. They are taken whole even if the render is being stopped, so that
    /// a resumed render neither misses nor repeats one.
    fn ring_samples(&self, film: &Film, ring: &[(u32, u32)], before: &[u32]) {
        let cell = film.cell();
        let after = film.counts();
        let never = AtomicBool::new(false);
        self.pool.install(|| {
            ring.par_chunks(SPLIT).for_each(|chunk| {
                let nearest = |&(x, y): &(u32, u32)| {
                    let cx = x.clamp(cell.x, cell.x + cell.w - 1) - cell.x;
                    let cy = y.clamp(cell.y, cell.y + cell.h - 1) - cell.y;
                    (cy * cell.w + cx) as usize
                };
                let mut ps: Vec<FilmPixel> = chunk
                    .iter()
                    .map(|p| FilmPixel {
                        n: before[nearest(p)],
                        target: after[nearest(p)],
                        ..FilmPixel::default()
                    })
                    .collect();
                let at = |i: usize| Pixel {
                    x: chunk[i].0,
                    y: chunk[i].1,
                    first: self.first,
                };
                // Pixels outside the cell: their features are not the film's.
                self.take_until(at, u32::MAX, (&mut ps, &mut []), &never);
            })
        });
    }

    /// Brings the film's light passes up to `j` (counted from the range's first sample), one
    /// whole pass at a time (the stop flag is checked between passes); false when stopped
    /// first. Without light tracing there is nothing to do.
    pub(super) fn light_to(&self, film: &mut Film, j: u32) -> bool {
        if !self.light_tracing {
            return true;
        }
        let mut passes = 0u32;
        while film.light_passes + passes < j && !self.stopped() {
            self.light_pass(film, self.first + film.light_passes + passes);
            passes += 1;
            if passes == 64 {
                self.fold(film, passes);
                passes = 0;
            }
        }
        if passes > 0 {
            self.fold(film, passes);
        }
        film.light_passes >= j
    }

    /// Light pass `k`: the light paths that start in pass `k`, splatted where they reach the
    /// camera inside the film's cell.
    fn light_pass(&self, film: &Film, k: u32) {
        let cell = film.cell();
        let (fw, fh) = (self.opts.width, self.opts.height);
        let it = &self.opts.integrator;
        let filter = self.opts.filter;
        let norm = filter.integral_1d();
        let settings = LightPathSettings {
            camera: self.camera,
            targets: &self.targets,
            stride: crate::lighttrace::STRIDE,
            width: fw,
            height: fh,
            max_depth: it.max_depth,
            accumulate: it.accumulate,
            rr_depth: it.rr_depth,
            rr_survival: it.rr_survival,
        };
        self.pool.install(|| {
            (0..fh).into_par_iter().for_each(|y| {
                let mut nrays = 0u64;
                for x in 0..fw {
                    if !crate::lighttrace::starts_path(&settings, x, y, k) {
                        continue;
                    }
                    let sampler = self.setup.sample(x, y, k);
                    let add = |px: u32, py: u32, v: crate::math::Rgb| {
                        let (cx, cy) = (px.wrapping_sub(cell.x), py.wrapping_sub(cell.y));
                        if cx < cell.w && cy < cell.h {
                            let a = &self.splats[(cy * cell.w + cx) as usize];
                            for c in 0..3 {
                                a[c].fetch_add(splat_fixed(v[c]), Ordering::Relaxed);
                            }
                        }
                    };
                    nrays += super::tracers::trace_light_path(
                        self.scene,
                        &settings,
                        &sampler,
                        |px, py, v| {
                            filter.spread(norm, (px, py), (fw, fh), |x, y, w| add(x, y, v * w));
                        },
                    );
                }
                self.rays.fetch_add(nrays, Ordering::Relaxed);
            })
        });
    }

    /// Moves the splats of the last `passes` light passes into the film.
    fn fold(&self, film: &mut Film, passes: u32) {
        let sums: Vec<[i64; 3]> = self
            .splats
            .iter()
            .map(|a| a.each_ref().map(|v| v.swap(0, Ordering::Relaxed)))
            .collect();
        film.add_light_passes(passes, &sums);
    }

    /// Every pixel at its target and, with light tracing, `j` light passes held.
    pub(super) fn reached_to(&self, film: &Film, j: u32) -> bool {
        reached(film) && (!self.light_tracing || film.light_passes >= j)
    }

    /// Every pixel at its target and every light pass held: the render is complete.
    pub(super) fn reached_all(&self, film: &Film) -> bool {
        self.reached_to(film, self.count)
    }

    /// The figures of the session so far, with `complete` as the schedule found it.
    pub(super) fn stats(&self, film: &Film, complete: bool) -> RenderStats {
        RenderStats {
            seconds: self.elapsed(),
            samples: self.taken.load(Ordering::Relaxed),
            rays: self.rays.load(Ordering::Relaxed),
            non_finite: self.non_finite.load(Ordering::Relaxed),
            threads: self.threads,
            samples_per_pixel: film.counts(),
            complete,
        }
    }
}

/// Most samples a pixel takes: `spp`, or with the adaptive budget [`ADAPTIVE_CAP`] × `spp`.
pub(super) fn cap(opts: &RenderOptions) -> u32 {
    if opts.adaptive_budget {
        opts.spp.saturating_mul(ADAPTIVE_CAP)
    } else {
        opts.spp
    }
}

/// True when every pixel of `film` has reached its target (or CS184's rule stopped it).
pub(super) fn reached(film: &Film) -> bool {
    film.pixels().iter().all(|p| p.done || p.n >= p.target)
}
