//! Learned environment sampling (`--env-guiding`, on by default) on a room lit by the sky
//! through one window (`tests/mitsuba/scenes/window_room.xml`, whose Mitsuba reference the
//! `mitsuba_scenes` test compares with): the same bits for any thread count, cell, sample
//! range and stopped-and-resumed render, and less noise than the map's own sampling at the
//! same number of samples; under an open sky the map's own sampling is kept.

mod common;
use common::{assert_cell_of, film_of, merged_ranges, stopped_and_resumed, CELLS_45X29};
use pathtracer::io::image::{diff, Image};
use pathtracer::light::env::EnvSampling;
use pathtracer::render::{render, RenderOptions};
use std::path::Path;

fn room() -> (pathtracer::setup::Loaded, RenderOptions) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba/scenes/window_room.xml");
    let loaded = pathtracer::setup::load(Some(&file), None, EnvSampling::Importance).unwrap();
    let opts = loaded.choices(&[]).unwrap().render_options();
    (loaded, opts)
}

#[test]
fn guided_renders_are_bit_identical_for_any_threads_cells_ranges_and_stops() {
    let (loaded, opts) = room();
    let scene = &loaded.scene;
    assert!(opts.env_guiding, "guiding is on by default");
    let base = RenderOptions {
        width: 45,
        height: 29,
        spp: 6,
        threads: Some(2),
        seed: 3,
        ..opts
    };
    let whole = film_of(scene, &base);
    let image = whole.develop();
    let off = render(
        scene,
        &RenderOptions {
            env_guiding: false,
            ..base.clone()
        },
        &|_, _| {},
    )
    .unwrap()
    .0;
    assert!(off.pixels != image.pixels, "guiding changes the samples");
    for threads in [1, 3] {
        let o = RenderOptions {
            threads: Some(threads),
            ..base.clone()
        };
        assert!(film_of(scene, &o) == whole, "{threads} threads");
    }
    for c in CELLS_45X29 {
        let o = RenderOptions {
            cell: Some(c),
            ..base.clone()
        };
        let img = render(scene, &o, &|_, _| {}).unwrap().0;
        assert_cell_of(&img, &image, c, "guided");
    }
    assert!(
        merged_ranges(scene, &base, 2) == whole,
        "merged sample ranges"
    );
    assert!(
        stopped_and_resumed(scene, &base).develop() == image,
        "stopped and resumed"
    );
}

/// At 64 samples per pixel, against a 2048-spp render of the map's own sampling (the
/// estimate both converge to), guiding's relative MSE is lower, and both agree in their
/// mean.
#[test]
fn guiding_lowers_the_noise_at_equal_samples() {
    let (loaded, opts) = room();
    let scene = &loaded.scene;
    let with = |spp: u32, env_guiding: bool, seed: u64| -> Image {
        let o = RenderOptions {
            spp,
            seed,
            env_guiding,
            ..opts.clone()
        };
        render(scene, &o, &|_, _| {}).unwrap().0
    };
    let reference = with(2048, false, 11);
    let guided = diff(&with(64, true, 1), &reference).unwrap();
    let plain = diff(&with(64, false, 1), &reference).unwrap();
    eprintln!(
        "relative MSE at 64 spp: guided {:.5}, map's own sampling {:.5}; ratio of means {:.4}",
        guided.rel_mse, plain.rel_mse, guided.ratio_of_means_all
    );
    assert!(
        guided.rel_mse < 0.8 * plain.rel_mse,
        "guided {} vs {}",
        guided.rel_mse,
        plain.rel_mse
    );
    assert!((guided.ratio_of_means_all - 1.0).abs() < 0.02);
}

/// Under an open sky (`envmap.xml`: a stage and two spheres), where most of the map's own
/// light samples reach it, no guide is kept: the image is the unguided one, bit for bit.
#[test]
fn an_open_scene_keeps_the_maps_own_sampling() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mitsuba/scenes/envmap.xml");
    let loaded = pathtracer::setup::load(Some(&file), None, EnvSampling::Importance).unwrap();
    let opts = RenderOptions {
        spp: 4,
        ..loaded.choices(&[]).unwrap().render_options()
    };
    let on = render(&loaded.scene, &opts, &|_, _| {}).unwrap().0;
    let off = RenderOptions {
        env_guiding: false,
        ..opts
    };
    let off = render(&loaded.scene, &off, &|_, _| {}).unwrap().0;
    assert!(on.pixels == off.pixels);
}
