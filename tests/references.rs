//! Renders compared against the converged references in `../shared/refs` by the block metric
//! (≤ 0.02) and the ratio of means (within 1.2% of 1, every channel), at the settings
//! `-s 64 -l 4`. A render that fails is written to `target/test-failures/` for inspection.

mod common;
use common::shared;
use pathtracer::integrator::IntegratorSettings;
use pathtracer::io::image::{diff, DiffStats, Image};
use pathtracer::render::{render, RenderOptions};
use std::path::Path;

fn render_scene(shared: &Path, scene: &str, m: u32, spp: u32) -> Image {
    let desc = pathtracer::io::collada::load_file(
        &shared.join("scenes/cs184/sky").join(format!("{scene}.dae")),
    )
    .unwrap();
    let scene = pathtracer::scene::build::build(&desc);
    let opts = RenderOptions {
        spp,
        seed: 1,
        integrator: IntegratorSettings {
            max_depth: m,
            accumulate: true,
            light_samples: 4,
            hemisphere: false,
            mis: true,
        },
        ..Default::default()
    };
    let (img, stats) = render(&scene, &opts, &|_, _| {}).unwrap();
    assert_eq!(stats.non_finite, 0);
    assert_eq!(img.count_non_finite(), 0);
    img
}

fn passes(d: &DiffStats) -> bool {
    d.block_max() <= 0.02 && d.ratio_of_means.iter().all(|r| (r - 1.0).abs() <= 0.012)
}

fn compare(shared: &Path, scene: &str, m: u32, ref_name: &str) -> (Image, Image) {
    let img = render_scene(shared, scene, m, 64);
    let reference = Image::load(&shared.join("refs").join(format!("{ref_name}.exr"))).unwrap();
    let d = diff(&img, &reference).unwrap();
    eprintln!(
        "{scene} m={m}: block {:.5}, ratio of means {:?}, rmse {:.5}",
        d.block_max(),
        d.ratio_of_means,
        d.rmse
    );
    if !passes(&d) {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/test-failures");
        std::fs::create_dir_all(&dir).ok();
        img.save(&dir.join(format!("{scene}_m{m}.exr"))).ok();
        panic!("{scene} m={m} differs from {ref_name}: {d:?} (render saved under target/test-failures)");
    }
    (img, reference)
}

/// The check must be able to fail: a 3% energy error is caught.
fn assert_detects_energy_error(img: &Image, reference: &Image) {
    for scale in [1.03f32, 0.97] {
        let mut wrong = img.clone();
        wrong.pixels.iter_mut().for_each(|p| *p *= scale);
        assert!(
            !passes(&diff(&wrong, reference).unwrap()),
            "a {scale}× image must fail the check"
        );
    }
}

#[test]
fn cbspheres_lambertian_m100() {
    let Some(s) = shared() else { return };
    let (img, reference) = compare(&s, "CBspheres_lambertian", 100, "CBspheres_lambertian_m100");
    assert_detects_energy_error(&img, &reference);
}

#[test]
fn cbbunny_m100() {
    let Some(s) = shared() else { return };
    let (img, reference) = compare(&s, "CBbunny", 100, "CBbunny_m100");
    assert_detects_energy_error(&img, &reference);
}

#[test]
fn cbspheres_emitters_only_m0() {
    // m = 0 is independent of the unimplemented mirror/glass BSDFs: it checks the camera and
    // the area light's placement and size.
    let Some(s) = shared() else { return };
    let img = render_scene(&s, "CBspheres", 0, 16);
    let reference = Image::load(&s.join("refs/CBspheres_m0.exr")).unwrap();
    let d = diff(&img, &reference).unwrap();
    assert!(passes(&d), "{d:?}");
}
