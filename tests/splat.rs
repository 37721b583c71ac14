//! Splatted camera samples (`--filter-sampling splat`, Mitsuba's reconstruction): the same
//! bits for any thread count, cell, sample range and stopped-and-resumed render; the same
//! image as drawing offsets from the filter, within noise; and less noise per pixel.

mod common;
use common::{assert_cell_of, film_of, merged_ranges, stopped_and_resumed, CELLS_45X29};
use pathtracer::film::Film;
use pathtracer::filter::{FilterKind, PixelFilter};
use pathtracer::integrator::IntegratorSettings;
use pathtracer::io::image::{diff, Image};
use pathtracer::render::{render, RenderOptions};
use pathtracer::scene::build::build;
use pathtracer::scene::Scene;

fn scene() -> Scene {
    build(&pathtracer::builtin::cornell_box())
}

fn opts(kind: FilterKind, radius: f32, splat: bool) -> RenderOptions {
    RenderOptions {
        width: 45,
        height: 29,
        spp: 6,
        threads: Some(2),
        seed: 5,
        integrator: IntegratorSettings {
            max_depth: 6,
            ..Default::default()
        },
        filter: PixelFilter {
            kind,
            radius,
            splat,
        },
        ..Default::default()
    }
}

#[test]
fn splatted_renders_are_bit_identical_for_any_threads_cells_ranges_and_stops() {
    let scene = scene();
    for (kind, radius) in [(FilterKind::Triangle, 1.0), (FilterKind::Gaussian, 2.0)] {
        let what = format!("{kind} {radius}");
        let base = opts(kind, radius, true);
        let whole = film_of(&scene, &base);
        assert!(whole.is_filtered(), "{what}: samples were splatted");
        let image = whole.develop();
        for threads in [1, 3] {
            let o = RenderOptions {
                threads: Some(threads),
                ..base.clone()
            };
            assert!(film_of(&scene, &o) == whole, "{what}: {threads} threads");
        }
        for c in CELLS_45X29 {
            let o = RenderOptions {
                cell: Some(c),
                ..base.clone()
            };
            let img = render(&scene, &o, &|_, _| {}).unwrap().0;
            assert_cell_of(&img, &image, c, &what);
        }
        let merged = merged_ranges(&scene, &base, 2);
        assert!(merged == whole, "{what}: merged ranges differ");
        let back = Film::from_bytes(&whole.to_bytes(), "test").unwrap();
        assert!(
            back == whole && back.develop() == image,
            "{what}: file form"
        );
        // Stopped by a time limit after a pass (a cell, whose ring follows it), then resumed.
        for cell in [None, Some(CELLS_45X29[3])] {
            let o = RenderOptions {
                cell,
                ..base.clone()
            };
            let film = stopped_and_resumed(&scene, &o);
            assert_cell_of(
                &film.develop(),
                &image,
                film.cell(),
                &format!("{what}: resumed"),
            );
        }
    }
}

/// Splatting and drawing offsets from the same filter estimate the same image: a tent of
/// radius 1 at 256 spp agrees with a 4096-spp render that draws offsets, in its mean and its
/// 8×8 blocks (within noise); and at 16 spp splatting's pixels are less noisy.
#[test]
fn splatting_renders_the_filtered_image_with_less_noise() {
    let scene = scene();
    let at = |splat: bool, spp: u32, seed: u64| RenderOptions {
        width: 48,
        height: 32,
        spp,
        seed,
        threads: None,
        ..opts(FilterKind::Triangle, 1.0, splat)
    };
    let reference = render(&scene, &at(false, 4096, 99), &|_, _| {}).unwrap().0;
    let relmse = |img: &Image| -> f64 {
        let mut s = 0.0;
        for (a, r) in img.pixels.iter().zip(&reference.pixels) {
            for c in 0..3 {
                let (a, r) = (a[c] as f64, r[c] as f64);
                s += (a - r).powi(2) / (r * r + 1e-2);
            }
        }
        s / (3 * img.pixels.len()) as f64
    };
    let splat = render(&scene, &at(true, 256, 1), &|_, _| {}).unwrap().0;
    let d = diff(&splat, &reference).unwrap();
    assert!(
        d.ratio_of_means.iter().all(|r| (r - 1.0).abs() < 0.01),
        "{d:?}"
    );
    assert!(d.block_max() < 0.03, "{d:?}");
    // At 16 spp (measured: 0.0022 against 0.0036).
    let (s, i) = (at(true, 16, 1), at(false, 16, 1));
    let splat = relmse(&render(&scene, &s, &|_, _| {}).unwrap().0);
    let importance = relmse(&render(&scene, &i, &|_, _| {}).unwrap().0);
    assert!(splat < 0.75 * importance, "{splat} {importance}");
}
