//! Renders compared against the converged references in `../shared/refs` by the block metric
//! (≤ 0.02) and the ratio of means (within 1.2% of 1, every channel), at the issues' settings
//! `-s 64 -l 4` (with the default estimator, MIS). A render that fails is written to `target/test-failures/` for inspection.

mod common;
use common::shared;
use pathtracer::integrator::{Direct, IntegratorSettings, LightSelection};
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
            direct: Direct::Mis,
            selection: LightSelection::Power,
            ..Default::default()
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
fn cbspheres_depth_sequence() {
    // Each m against its reference, and against its neighbours' references, which must fail:
    // an off-by-one bounce is caught.
    let Some(s) = shared() else { return };
    let depths = [0u32, 1, 2, 3, 4, 5, 100];
    let refs: Vec<Image> = depths
        .iter()
        .map(|m| Image::load(&s.join(format!("refs/CBspheres_m{m}.exr"))).unwrap())
        .collect();
    for (i, &m) in depths.iter().enumerate() {
        let img = render_scene(&s, "CBspheres", m, 64);
        let d = diff(&img, &refs[i]).unwrap();
        eprintln!(
            "CBspheres m={m}: block {:.5}, ratio of means {:?}",
            d.block_max(),
            d.ratio_of_means
        );
        assert!(passes(&d), "CBspheres m={m}: {d:?}");
        for j in [i.wrapping_sub(1), i + 1] {
            if let Some(other) = refs.get(j) {
                let d = diff(&img, other).unwrap();
                assert!(
                    !passes(&d),
                    "m={m} must not pass against the m={} reference: {d:?}",
                    depths[j]
                );
            }
        }
    }
}

#[test]
fn cbspheres_microfacet_al_ag_m100() {
    let Some(s) = shared() else { return };
    let (img, reference) = compare(
        &s,
        "CBspheres_microfacet_al_ag",
        100,
        "CBspheres_microfacet_al_ag_m100",
    );
    assert_detects_energy_error(&img, &reference);
}
