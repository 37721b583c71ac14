//! Long renders lose nothing: the signal handler (the first Ctrl-C or SIGTERM stops the
//! render and keeps what it has), renders in rounds with periodic checkpoints, and resuming.

use super::progress::Progress;
use pathtracer::error::{Error, Result};
use pathtracer::film::Film;
use pathtracer::render::{render_into, Control, RenderOptions, RenderStats};
use pathtracer::scene;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::Instant;

/// The film a render continues: the checkpoint `resume` (refused when its identity differs
/// from `identity`, naming each difference) or a new film with that identity.
pub fn film_for(
    opts: &RenderOptions,
    resume: Option<&Path>,
    identity: Vec<(String, String)>,
) -> Result<Film> {
    let Some(path) = resume else {
        let mut film = pathtracer::render::new_film(opts)?;
        film.set_identity(identity);
        return Ok(film);
    };
    let film = Film::load(path)?;
    if let Some(d) = film.identity_mismatch(&identity) {
        return Err(Error::Usage(format!(
            "{}: the checkpoint belongs to another render: {d}",
            path.display()
        )));
    }
    eprintln!(
        "resuming {} with {:.1} samples per pixel done",
        path.display(),
        film.samples() as f64 / film.pixels().len() as f64
    );
    Ok(film)
}

/// Signals received (SIGINT, SIGTERM, SIGHUP) since the handler was installed.
static SIGNALS: AtomicU32 = AtomicU32::new(0);
/// Set by the first signal: the render stops and keeps what it has.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the handler of Ctrl-C and SIGTERM: the first stops the render (which then writes
/// its image and checkpoint), a second ends the process at once (status 130; every file is
/// written under a temporary name and renamed, so none is left half-written).
pub fn install_signal_handler() -> &'static AtomicBool {
    let result = ctrlc::set_handler(|| {
        if SIGNALS.fetch_add(1, Ordering::SeqCst) > 0 {
            #[cfg(target_os = "linux")]
            // SAFETY: _exit ends the process without running any user-space code; it is
            // async-signal-safe and has no preconditions.
            unsafe {
                libc::_exit(130)
            };
            #[cfg(not(target_os = "linux"))]
            std::process::exit(130);
        }
        INTERRUPTED.store(true, Ordering::SeqCst);
        eprintln!("\ninterrupted: stopping and saving (interrupt again to quit at once)");
    });
    if let Err(e) = result {
        eprintln!("warning: cannot handle Ctrl-C ({e}); an interrupted render will be lost");
    }
    &INTERRUPTED
}

/// Renders `film` to its target in rounds: a round ends when the render completes, runs out
/// of time, is interrupted, or (with `--checkpoint-every`) when a checkpoint is due, which is
/// then written and the next round continues. Returns the figures of all rounds together.
pub fn render_rounds(
    scene: &scene::Scene,
    opts: &RenderOptions,
    film: &mut Film,
    every: Option<f64>,
    checkpoint: &Path,
    progress: &Progress,
    tile_done: Option<&pathtracer::render::TileFn<'_>>,
) -> Result<RenderStats> {
    let start = Instant::now();
    let mut total: Option<RenderStats> = None;
    loop {
        let mut round = opts.clone();
        if let Some(limit) = opts.time_limit {
            let left = limit - start.elapsed().as_secs_f64();
            if left <= 0.0 {
                if let Some(t) = total.take() {
                    return Ok(t);
                }
            }
            round.time_limit = Some(left.max(f64::MIN_POSITIVE));
        }
        let stop = AtomicBool::new(false);
        // (At most a year between checkpoints: a larger interval means "never".)
        let due = every.and_then(|s| {
            Instant::now().checked_add(std::time::Duration::from_secs_f64(s.min(365.0 * 86400.0)))
        });
        let finished = AtomicBool::new(false);
        /// Tells the watcher to end however the render ends (a panic included).
        struct Finish<'a>(&'a AtomicBool);
        impl Drop for Finish<'_> {
            fn drop(&mut self) {
                self.0.store(true, Ordering::SeqCst);
            }
        }
        let stats = std::thread::scope(|sc| {
            sc.spawn(|| {
                while !finished.load(Ordering::SeqCst) {
                    if INTERRUPTED.load(Ordering::SeqCst)
                        || due.is_some_and(|d| Instant::now() >= d)
                    {
                        stop.store(true, Ordering::SeqCst);
                        break;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(20));
                }
            });
            let report = |d, n| progress.update(d, n);
            let ctl = Control {
                tile_done,
                ..Control::new(&stop, &report)
            };
            let _finish = Finish(&finished);
            render_into(scene, &round, film, ctl)
        })?;
        let periodic = stop.load(Ordering::SeqCst) && !INTERRUPTED.load(Ordering::SeqCst);
        let stats = match total.take() {
            None => stats,
            Some(t) => RenderStats {
                seconds: t.seconds + stats.seconds,
                samples: t.samples + stats.samples,
                rays: t.rays + stats.rays,
                non_finite: t.non_finite + stats.non_finite,
                ..stats
            },
        };
        if stats.complete || !periodic {
            return Ok(stats);
        }
        film.save(checkpoint)?;
        total = Some(stats);
    }
}
