//! Training the environment guide ([`crate::guide`]) before a render: fixed paths from every
//! [`stride`]-th pixel of every [`stride`]-th row of the whole frame, in runs of [`RUNS`]
//! samples per pixel, the first unguided and each later one guided by the guide its
//! predecessors trained. The paths depend on the frame, the camera, the options and the seed
//! alone, and their records are combined in pixel order, so every cell, pass, sample range
//! and thread count of a render gets the same guide.

use super::samples::camera_ray;
use super::tracers::radiance;
use super::RenderOptions;
use crate::camera::Camera;
use crate::guide::{EnvGuide, Record, Recorder};
use crate::light::Light;
use crate::sampling::sampler::SamplerSetup;
use crate::scene::Scene;
use crate::vertex::{Guiding, IntegratorSettings};
use rayon::prelude::*;
use std::cell::RefCell;

/// About how many pixels of a large frame train the guide (every second pixel of every second
/// row of a smaller one), which bounds the training's time and memory.
pub const TRAINING_PIXELS: u32 = 16_384;
/// Samples per training pixel in each run.
pub const RUNS: [u32; 2] = [1, 2];
/// Mixed into the render's seed for the training paths' numbers.
const SEED: u64 = 0x6775_6964_6520_7472;
/// The share of the unguided run's light samples that reached the map above which the map's
/// own sampling is kept: it already finds the light, and a guide would cost more than it
/// gains (an open scene under the sky: 43% for CS184's bunny under sunrise.exr, against 2.5%
/// in the classroom).
pub const MAX_SEEN_SHARE: f64 = 0.2;
/// Training pixels per piece of work.
const CHUNK: usize = 256;

/// The guide of `scene`'s environment light for a render through `camera` with `opts`, run on
/// `pool`; `None` where guiding is off, the scene has no importance-sampled environment map,
/// the map's own samples reach it often enough ([`MAX_SEEN_SHARE`]) or no region sees it, and
/// in volumetric scenes (whose paths record no training samples).
pub(super) fn train(
    scene: &Scene,
    camera: &Camera,
    opts: &RenderOptions,
    pool: &rayon::ThreadPool,
) -> Option<EnvGuide> {
    if !opts.env_guiding || scene.volumetric {
        return None;
    }
    let (light, env) = scene.lights.iter().enumerate().find_map(|(j, l)| match l {
        Light::Environment(e) => Some((j, e)),
        _ => None,
    })?;
    // Guiding reweights the map's blocks: a map sampled uniformly has none.
    env.blocks()?;
    let total: u32 = RUNS.iter().sum();
    let setup = SamplerSetup::new(
        opts.sampler,
        opts.seed ^ SEED,
        opts.width,
        opts.height,
        total,
    );
    let step = stride(opts.width, opts.height) as usize;
    let pixels: Vec<(u32, u32)> = (0..opts.height)
        .step_by(step)
        .flat_map(|y| (0..opts.width).step_by(step).map(move |x| (x, y)))
        .collect();
    let settings = IntegratorSettings {
        light_tracing: false,
        ..opts.integrator
    };
    let mut records: Vec<Record> = Vec::new();
    let mut guide: Option<EnvGuide> = None;
    let mut first = 0;
    for &spp in &RUNS {
        let run = |chunk: &[(u32, u32)]| {
            let recorder = Recorder {
                light,
                env,
                records: RefCell::new(Vec::new()),
            };
            let g = Guiding {
                guide: guide.as_ref(),
                record: Some(&recorder),
            };
            for &(x, y) in chunk {
                for k in first..first + spp {
                    let (ray, sampler, _) = camera_ray(camera, opts, &setup, x, y, k);
                    radiance(scene, ray, &sampler, &settings, g, &mut 0);
                }
            }
            recorder.records.into_inner()
        };
        let pieces: Vec<Vec<Record>> = pool.install(|| pixels.par_chunks(CHUNK).map(run).collect());
        records.extend(pieces.into_iter().flatten());
        if guide.is_none() && seen_share(&records) >= MAX_SEEN_SHARE {
            return None;
        }
        first += spp;
        guide = Some(match &guide {
            None => EnvGuide::build(light, env, &records)?,
            Some(g) => g.refit(&records),
        });
    }
    guide
}

/// The share of `records` that reached the map.
fn seen_share(records: &[Record]) -> f64 {
    let seen = records.iter().filter(|r| r.value > 0.0).count();
    seen as f64 / records.len().max(1) as f64
}

/// Pixels between training pixels along each axis for a `width × height` frame: 2, or more
/// where that would train on over [`TRAINING_PIXELS`] pixels.
pub fn stride(width: u32, height: u32) -> u32 {
    let n = width as f64 * height as f64 / TRAINING_PIXELS as f64;
    (n.sqrt().ceil() as u32).max(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_frames_train_on_a_bounded_number_of_pixels() {
        assert_eq!(stride(48, 48), 2);
        assert_eq!(stride(320, 180), 2);
        for (w, h) in [(480, 360), (1920, 1080), (3840, 2160), (8000, 10)] {
            let s = stride(w, h);
            let n = w.div_ceil(s) * h.div_ceil(s);
            assert!(
                n <= TRAINING_PIXELS + w + h,
                "{w}×{h}: {n} pixels at stride {s}"
            );
            assert!(
                n * 8 >= TRAINING_PIXELS.min(w * h / 4),
                "{w}×{h}: {n} pixels"
            );
        }
    }
}
