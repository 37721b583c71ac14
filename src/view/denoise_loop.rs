//! The denoise thread: while the `denoise` setting is on, it denoises the latest finished
//! pass that the render thread hands over (with OIDN's interactive quality) and publishes
//! the result beside the noisy image. After each run it rests as long as the run took, so
//! that it takes at most about half the machine from the render; the film's last pass is
//! denoised without waiting.

use super::Shared;
use crate::denoise::Quality;
use crate::film::Cell;
use crate::io::image::Image;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A finished pass with the film's features, as the render thread hands it over.
pub(super) struct Input {
    /// The film's generation.
    pub generation: u64,
    /// Passes (samples per pixel) in the image.
    pub passes: u32,
    /// The frame-sized image of the pass (the film over the backdrop for a cell).
    pub image: Arc<Image>,
    /// The region of the frame the film covers; only it is denoised.
    pub cell: Cell,
    /// The film's mean albedo and normal over its cell.
    pub features: (Image, Image),
}

impl Input {
    /// The generation and passes, which say whether a pass was denoised already.
    fn key(&self) -> (u64, u32) {
        (self.generation, self.passes)
    }
}

/// The denoise thread's loop; returns when the viewer quits.
pub(super) fn denoise_loop(shared: &Shared) {
    let mut done: Option<(u64, u32)> = None;
    let mut rest_until = Instant::now();
    while let Some(job) = next_job(shared, done, rest_until) {
        done = Some(job.key());
        let t0 = Instant::now();
        let result = shared.denoiser().and_then(|d| denoised(d, &job));
        let took = t0.elapsed();
        rest_until = Instant::now() + took;
        let mut st = shared.lock();
        match result {
            Ok(img) if st.generation == job.generation && st.settings.denoise => {
                st.denoised = Some((Arc::new(img), job.passes));
                st.denoise_error = None;
                st.frame += 1;
                let f = st.frame;
                drop(st);
                shared.frames.send_replace(f);
            }
            Ok(_) => {}
            Err(e) => st.denoise_error = Some(e),
        }
    }
}

/// Waits for a pass to denoise: the setting on, a pass not yet denoised, and the rest over
/// (or the pass the film's last); `None` when the viewer quits.
fn next_job(shared: &Shared, done: Option<(u64, u32)>, rest_until: Instant) -> Option<Arc<Input>> {
    let mut st = shared.lock();
    loop {
        if st.quit {
            return None;
        }
        let waiting = st
            .to_denoise
            .clone()
            .filter(|j| st.settings.denoise && Some(j.key()) != done);
        let mut timeout = None;
        if let Some(job) = waiting {
            let now = Instant::now();
            if now >= rest_until || job.passes >= st.settings.spp {
                return Some(job);
            }
            timeout = Some(rest_until - now);
        }
        st = match timeout {
            Some(t) => {
                shared
                    .denoise_wake
                    .wait_timeout(st, t.max(Duration::from_millis(1)))
                    .unwrap_or_else(|e| e.into_inner())
                    .0
            }
            None => shared
                .denoise_wake
                .wait(st)
                .unwrap_or_else(|e| e.into_inner()),
        };
    }
}

/// The pass's image with its cell (or the whole frame) denoised.
fn denoised(d: &crate::denoise::Denoiser, job: &Input) -> Result<Image, String> {
    let frame = &job.image;
    let cell = job.cell;
    let (x0, y0, w, h) = (
        cell.x as usize,
        cell.y as usize,
        cell.w as usize,
        cell.h as usize,
    );
    if x0 + w > frame.width || y0 + h > frame.height {
        return Err("the cell is not inside the frame".into());
    }
    let mut colour = Image::new(w, h);
    for y in 0..h {
        let row = (y0 + y) * frame.width + x0;
        colour.pixels[y * w..(y + 1) * w].copy_from_slice(&frame.pixels[row..row + w]);
    }
    let clean = d.denoise_image(&colour, Some(&job.features), Quality::Interactive)?;
    let mut out = (**frame).clone();
    for y in 0..h {
        let row = (y0 + y) * frame.width + x0;
        out.pixels[row..row + w].copy_from_slice(&clean.pixels[y * w..(y + 1) * w]);
    }
    Ok(out)
}
