//! The render thread: previews while the camera is dragged, otherwise passes of one sample per
//! pixel into a film until the target, a new film on every change that needs one.

use super::denoise_loop::Input;
use super::display::Figures;
use super::{Shared, PREVIEW_DEPTH, PREVIEW_FRAME, PREVIEW_MAX_SCALE, REFRESH};
use crate::camera::Camera;
use crate::film::{Cell, Film, FilmPixel, Tile};
use crate::io::image::Image;
use crate::render::{new_film, render_camera, render_camera_into, Control, RenderOptions};
use crate::scene::Scene;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// The frame-sized image of `film` over `backdrop` (what the frame showed before a cell was
/// chosen; black without one), with its per-pixel figures.
fn compose(film: &Film, backdrop: Option<&Image>, (w, h): (u32, u32)) -> (Image, Figures) {
    let (w, h) = (w as usize, h as usize);
    let cell = film.cell();
    let mut img = backdrop
        .filter(|b| (b.width, b.height) == (w, h))
        .cloned()
        .unwrap_or_else(|| Image::new(w, h));
    let mut fig = Figures {
        rate: vec![0; w * h],
        variance: vec![0.0; w * h],
    };
    for (p, px) in film.row_major() {
        let (x, y) = (
            cell.x as usize + p % cell.w as usize,
            cell.y as usize + p / cell.w as usize,
        );
        let q = y * w + x;
        img.pixels[q] = px.mean() + film.light_mean(p);
        fig.rate[q] = px.n;
        fig.variance[q] = if px.n > 0 {
            (px.rel_variance() / px.n as f64) as f32
        } else {
            0.0
        };
    }
    (img, fig)
}

/// What the render thread does next, read from the published state.
struct Job {
    settings: super::Settings,
    generation: u64,
    camera: Camera,
    previewing: bool,
}

/// The render thread's own state between jobs.
struct Loop {
    scene: Arc<Scene>,
    /// The camera of the current film.
    camera: Camera,
    /// The command line's options, which the settings apply to.
    base: RenderOptions,
    /// The options of the current film.
    opts: RenderOptions,
    film: Option<Film>,
    /// The generation of the current film, and of the latest preview.
    seen: u64,
    preview_seen: u64,
    /// The factor the preview resolution is divided by.
    scale: u32,
    /// The latest whole-frame image, shown around a cell.
    backdrop: Option<Arc<Image>>,
}

/// The render thread: previews while the camera is dragged, otherwise passes into a film
/// until the target, a new film on every change that needs one.
pub(super) fn render_loop(scene: Arc<Scene>, base: RenderOptions, shared: &Shared) {
    let mut l = Loop {
        camera: scene.camera.clone(),
        scene,
        opts: base.clone(),
        base,
        film: None,
        seen: u64::MAX,
        preview_seen: u64::MAX,
        scale: 4,
        backdrop: None,
    };
    while let Some(job) = l.next_job(shared) {
        let mut cam = job.camera.clone();
        cam.lens_radius = job.settings.lens_radius;
        cam.focal_distance = job.settings.focal_distance;
        let ok = if job.previewing {
            l.preview(&job, cam, shared)
        } else {
            l.pass(&job, cam, shared)
        };
        if !ok {
            return;
        }
    }
}

impl Loop {
    /// Waits until there is something to render (a preview while dragging, a changed
    /// generation, or passes below the target); `None` when the viewer quits.
    fn next_job(&self, shared: &Shared) -> Option<Job> {
        let mut st = shared.lock();
        loop {
            if st.quit {
                return None;
            }
            let now = Instant::now();
            if let Some(until) = st.preview_until.filter(|&t| t > now) {
                if st.generation != self.preview_seen {
                    break;
                }
                st = shared
                    .wake
                    .wait_timeout(st, until - now)
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
                continue;
            }
            // A film without features is not done once denoising is asked for.
            let done = self.film.as_ref().is_some_and(|f| {
                st.generation == self.seen
                    && st.passes >= st.settings.spp
                    && f.samples() > 0
                    && (f.has_features() || !st.settings.denoise)
            });
            if !done {
                break;
            }
            st = shared.wake.wait(st).unwrap_or_else(|e| e.into_inner());
        }
        Some(Job {
            settings: st.settings.clone(),
            generation: st.generation,
            camera: st.camera.clone(),
            previewing: st.preview_until.is_some_and(|t| t > Instant::now()),
        })
    }

    /// A preview: the whole frame at 1/scale of the resolution (the same view: the image
    /// plane's distance in pixels scales with it), one sample, short paths; the scale adapts
    /// so that a preview takes about [`PREVIEW_FRAME`]. False when rendering failed.
    fn preview(&mut self, job: &Job, mut cam: Camera, shared: &Shared) -> bool {
        self.preview_seen = job.generation;
        let base = &self.base;
        let mut p = job.settings.options(base);
        p.cell = None;
        p.width = base.width.div_ceil(self.scale).max(1);
        p.height = base.height.div_ceil(self.scale).max(1);
        p.spp = 1;
        p.integrator.max_depth = p.integrator.max_depth.min(PREVIEW_DEPTH);
        p.integrator.light_samples = 1;
        cam.focal_px *= p.width as f32 / base.width as f32;
        let t0 = Instant::now();
        let Ok((img, _)) = render_camera(&self.scene, &cam, &p, &|_, _| {}) else {
            return false;
        };
        let took = t0.elapsed();
        if took > PREVIEW_FRAME && self.scale < PREVIEW_MAX_SCALE {
            self.scale *= 2;
        } else if took * 5 < PREVIEW_FRAME && self.scale > 1 {
            self.scale /= 2;
        }
        // Shown even if the camera has moved on meanwhile (it is the latest preview; the
        // next one follows at once), but not over a full pass of a later release.
        let mut st = shared.lock();
        if st.generation == job.generation || st.preview_until.is_some() {
            st.image = Some(Arc::new(img));
            st.figures = None;
            st.preview = true;
            st.passes = 0;
            st.frame += 1;
            let f = st.frame;
            drop(st);
            shared.frames.send_replace(f);
        }
        true
    }

    /// One pass of one sample per pixel into the film (a new film when the generation
    /// changed), shown as its tiles finish and published when it ends. False when rendering
    /// failed.
    fn pass(&mut self, job: &Job, cam: Camera, shared: &Shared) -> bool {
        if job.generation != self.seen || self.film.is_none() {
            self.seen = job.generation;
            shared.stop.store(false, Ordering::SeqCst);
            self.opts = job.settings.options(&self.base);
            if self.opts.cell.is_none() {
                self.backdrop = None;
            }
            self.camera = cam;
            self.film = new_film(&self.opts).ok().map(|mut f| {
                f.set_identity(self.opts.identity());
                f
            });
            shared.lock().started = Instant::now();
        }
        // Denoising needs features over all of the film's samples: a film without them
        // starts again.
        if job.settings.denoise && self.film.as_ref().is_some_and(|f| !f.has_features()) {
            let mut st = shared.lock();
            if st.generation == job.generation {
                super::server::restart(shared, &mut st);
            }
            return true;
        }
        // Only the target (or the denoise setting) may have changed since the film was
        // started (raising the target keeps the film: each pixel's samples do not depend on
        // it with these samplers).
        self.opts.spp = job.settings.spp;
        let seen = self.seen;
        let Some(f) = self.film.as_mut() else {
            return false;
        };
        // The shortest time limit stops after the first pass of one sample per pixel.
        let mut pass = self.opts.clone();
        pass.time_limit = Some(f64::MIN_POSITIVE);
        let live = Mutex::new((
            pass_backdrop(f, self.backdrop.as_deref(), shared, seen),
            Instant::now(),
        ));
        let on_tile =
            |c: Cell, t: &Tile, px: &[FilmPixel]| show_tile(&live, shared, seen, c, t, px);
        let ctl = Control {
            tile_done: Some(&on_tile),
            ..Control::new(&shared.stop, &|_, _| {})
        };
        let Ok(stats) = render_camera_into(&self.scene, &self.camera, &pass, f, ctl) else {
            return false;
        };
        let passes = f.pixels().iter().map(|p| p.n).min().unwrap_or(0);
        let (img, fig) = compose(f, self.backdrop.as_deref(), shared.size);
        let img = Arc::new(img);
        let to_denoise = f.feature_images().map(|features| {
            Arc::new(Input {
                generation: seen,
                passes,
                image: img.clone(),
                cell: f.cell(),
                features,
            })
        });
        if self.opts.cell.is_none() {
            self.backdrop = Some(img.clone());
            if let Some(t) = &shared.tev {
                t.image(&img);
            }
        }
        let mut st = shared.lock();
        if st.generation == seen {
            st.image = Some(img);
            st.figures = Some(Arc::new(fig));
            st.preview = false;
            st.passes = passes;
            st.frame += 1;
            st.samples_per_sec = stats.samples as f64 / stats.seconds.max(1e-9);
            if to_denoise.is_some() {
                st.to_denoise = to_denoise;
                shared.denoise_wake.notify_all();
            }
            let f = st.frame;
            drop(st);
            shared.frames.send_replace(f);
        }
        true
    }
}

/// What a pass in progress is drawn over: the image of the passes before (a long pass still
/// refreshes the display), or the film composed over the backdrop.
fn pass_backdrop(film: &Film, backdrop: Option<&Image>, shared: &Shared, seen: u64) -> Image {
    let before = {
        let st = shared.lock();
        st.image
            .clone()
            .filter(|_| st.generation == seen && !st.preview)
    };
    match before {
        Some(img)
            if (img.width, img.height) == (shared.size.0 as usize, shared.size.1 as usize) =>
        {
            (*img).clone()
        }
        _ => compose(film, backdrop, shared.size).0,
    }
}

/// Draws a finished tile into the live image and publishes it every [`REFRESH`].
fn show_tile(
    live: &Mutex<(Image, Instant)>,
    shared: &Shared,
    seen: u64,
    c: Cell,
    t: &Tile,
    px: &[FilmPixel],
) {
    let mut g = live.lock().unwrap_or_else(|e| e.into_inner());
    let w = shared.size.0 as usize;
    for (i, p) in px.iter().enumerate().take((t.w * t.h) as usize) {
        let (x, y) = t.frame_xy(c, i);
        if let Some(q) = g.0.pixels.get_mut(y as usize * w + x as usize) {
            *q = p.mean();
        }
    }
    if g.1.elapsed() >= REFRESH {
        g.1 = Instant::now();
        let img = Arc::new(g.0.clone());
        drop(g);
        let mut st = shared.lock();
        if st.generation == seen {
            st.image = Some(img);
            st.preview = false;
            st.frame += 1;
            let f = st.frame;
            drop(st);
            shared.frames.send_replace(f);
        }
    }
}
