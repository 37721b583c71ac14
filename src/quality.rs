//! `pathtracer bench-quality`: noise per second. Every scene with a converged reference in
//! `shared/refs` is rendered for a fixed time budget (passes of one sample per pixel), and
//! its relative MSE against the reference is reported, so that the effect of a change on
//! noise per second is one command away.

use crate::error::Result;
use crate::integrator::IntegratorSettings;
use crate::io::image::{diff, Image};
use crate::light::env::EnvSampling;
use crate::render::{render, RenderOptions};
use std::fmt;
use std::path::Path;

/// A scene with a reference: scene file and optional environment map (relative to the shared
/// folder), CS184 max depth, reference name in `refs/`.
pub const SCENES: [(&str, Option<&str>, u32, &str); 5] = [
    (
        "scenes/cs184/sky/CBspheres.dae",
        None,
        100,
        "CBspheres_m100",
    ),
    (
        "scenes/cs184/sky/CBspheres_lambertian.dae",
        None,
        100,
        "CBspheres_lambertian_m100",
    ),
    ("scenes/cs184/sky/CBbunny.dae", None, 100, "CBbunny_m100"),
    (
        "scenes/cs184/sky/CBspheres_microfacet_al_ag.dae",
        None,
        100,
        "CBspheres_microfacet_al_ag_m100",
    ),
    (
        "scenes/cs184/sky/bunny_unlit.dae",
        Some("envmaps/sunrise.exr"),
        100,
        "bunny_unlit_sunrise_m100",
    ),
];

/// One row of the benchmark.
#[derive(Clone, Debug)]
pub struct QualityRow {
    /// Reference name.
    pub name: String,
    /// Samples per pixel reached within the budget.
    pub spp: f64,
    /// Wall time of the render loop, seconds.
    pub seconds: f64,
    /// Relative MSE against the reference.
    pub rel_mse: f64,
    /// Block metric against the reference (largest channel).
    pub block: f64,
}

/// All rows, for display.
#[derive(Clone, Debug)]
pub struct QualityReport(pub Vec<QualityRow>);

/// Runs the benchmark: each scene rendered for `budget` seconds with `settings` (its max depth
/// replaced by the scene's), on `threads` threads, with `seed`.
pub fn run(
    shared: &Path,
    budget: f64,
    threads: Option<usize>,
    settings: IntegratorSettings,
    seed: u64,
) -> Result<QualityReport> {
    let mut rows = Vec::new();
    for (scene_file, map, m, reference) in SCENES {
        let desc = crate::io::collada::load_file(&shared.join(scene_file))?;
        let mut scene = crate::scene::build::build(&desc);
        if let Some(map) = map {
            scene.add_environment(&shared.join(map), EnvSampling::Importance)?;
        }
        let opts = RenderOptions {
            spp: 1_000_000,
            threads,
            seed,
            integrator: IntegratorSettings {
                max_depth: m,
                ..settings
            },
            time_limit: Some(budget),
            ..Default::default()
        };
        let (img, stats) = render(&scene, &opts, &|_, _| {})?;
        let r = Image::load(&shared.join("refs").join(format!("{reference}.exr")))?;
        let d = diff(&img, &r)?;
        rows.push(QualityRow {
            name: reference.to_string(),
            spp: stats.mean_spp(),
            seconds: stats.seconds,
            rel_mse: d.rel_mse,
            block: d.block_max(),
        });
    }
    Ok(QualityReport(rows))
}

impl fmt::Display for QualityReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{:<34} {:>7} {:>9} {:>12} {:>9}",
            "reference", "spp", "time (s)", "relMSE", "block"
        )?;
        for r in &self.0 {
            writeln!(
                f,
                "{:<34} {:>7.0} {:>9.2} {:>12.6} {:>9.5}",
                r.name, r.spp, r.seconds, r.rel_mse, r.block
            )?;
        }
        Ok(())
    }
}
