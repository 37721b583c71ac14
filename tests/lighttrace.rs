//! Caustic light tracing (`--caustics light`, the default): its guarantees of determinism
//! (thread counts, cells, sample ranges, stopped and resumed renders) on a built-in box with
//! a glass sphere and a mirror block, and its agreement with path tracing alone.

mod common;
use common::{assert_cell_of, film_of, CELLS_45X29};
use glam::Vec3;
use pathtracer::film::Film;
use pathtracer::integrator::IntegratorSettings;
use pathtracer::io::desc::MaterialKind;
use pathtracer::render::{new_film, render, render_into, Control, RenderOptions};
use pathtracer::sampling::sampler::SamplerKind;
use pathtracer::scene::build::build;
use pathtracer::scene::Scene;
use std::sync::atomic::AtomicBool;

/// The built-in Cornell box with a glass sphere and a mirror block.
fn caustic_box() -> Scene {
    let mut desc = pathtracer::builtin::cornell_box();
    for m in &mut desc.materials {
        match m.name.as_str() {
            "sphere" => {
                m.kind = MaterialKind::Glass {
                    reflectance: Vec3::ONE,
                    transmittance: Vec3::ONE,
                    roughness: 0.0,
                    ior: 1.5,
                }
            }
            "block" => {
                m.kind = MaterialKind::Mirror {
                    reflectance: Vec3::splat(0.9),
                }
            }
            _ => {}
        }
    }
    let scene = build(&desc);
    assert!(pathtracer::lighttrace::usable(&scene, &scene.camera));
    scene
}

fn opts(sampler: SamplerKind, light_tracing: bool) -> RenderOptions {
    RenderOptions {
        width: 45,
        height: 29,
        spp: 6,
        threads: Some(2),
        seed: 11,
        integrator: IntegratorSettings {
            max_depth: 8,
            light_tracing,
            ..Default::default()
        },
        sampler,
        ..Default::default()
    }
}

/// Asserts that `base` rendered on 1 and on 3 threads gives `whole` (its 2-thread film).
fn same_film_on_1_and_3_threads(scene: &Scene, base: &RenderOptions, whole: &Film, what: &str) {
    for threads in [1, 3] {
        let o = RenderOptions {
            threads: Some(threads),
            ..base.clone()
        };
        assert!(
            film_of(scene, &o) == *whole,
            "{what}: {threads} threads differ from 2"
        );
    }
}

#[test]
fn light_paths_are_bit_identical_for_any_threads_cells_ranges_and_stops() {
    let scene = caustic_box();
    for sampler in SamplerKind::ALL {
        let base = opts(sampler, true);
        let whole = film_of(&scene, &base);
        assert_eq!(whole.light_passes, base.spp, "light tracing ran");
        let image = whole.develop();
        let path_only = render(&scene, &opts(sampler, false), &|_, _| {}).unwrap().0;
        assert!(
            image != path_only,
            "{sampler:?}: light paths change the image"
        );
        same_film_on_1_and_3_threads(&scene, &base, &whole, &format!("{sampler:?}"));
        // Four cells tile the frame bit for bit.
        for c in CELLS_45X29 {
            let o = RenderOptions {
                cell: Some(c),
                ..base.clone()
            };
            let img = render(&scene, &o, &|_, _| {}).unwrap().0;
            assert_cell_of(&img, &image, c, &format!("{sampler:?}"));
        }
        // Sample ranges merge into the whole, in either order; ranges that do not join fail.
        let part = |first, count| {
            film_of(
                &scene,
                &RenderOptions {
                    sample_range: Some((first, count)),
                    ..base.clone()
                },
            )
        };
        let mut merged = part(0, 2);
        merged.merge(&part(2, 3)).unwrap();
        merged.merge(&part(5, 1)).unwrap();
        assert!(merged == whole, "{sampler:?}: merged ranges differ");
        let mut tail = part(2, 4);
        tail.merge(&part(0, 2)).unwrap();
        assert!(tail == whole, "{sampler:?}: merge order changes the film");
        part(0, 2).merge(&part(3, 3)).unwrap_err();
        // The file form keeps the light passes.
        let back = Film::from_bytes(&whole.to_bytes(), "test").unwrap();
        assert!(back == whole && back.develop() == image);
        // Stopped by time limits after some passes, then continued.
        for limit in [f64::MIN_POSITIVE, 0.002] {
            let mut o = base.clone();
            o.time_limit = Some(limit);
            let mut film = new_film(&o).unwrap();
            let stop = AtomicBool::new(false);
            let ctl = Control::new(&stop, &|_, _| {});
            let st = render_into(&scene, &o, &mut film, ctl).unwrap();
            assert!(!st.complete || limit > f64::MIN_POSITIVE);
            assert!(film.light_passes >= 1);
            o.time_limit = None;
            assert!(render_into(&scene, &o, &mut film, ctl).unwrap().complete);
            assert!(film == whole, "{sampler:?}: resumed film differs");
        }
    }
}

/// Mean of a block of pixels.
fn block_mean(img: &pathtracer::io::image::Image, x0: usize, y0: usize, b: usize) -> Vec3 {
    let mut s = Vec3::ZERO;
    for y in y0..y0 + b {
        for x in x0..x0 + b {
            s += img.get(x, y);
        }
    }
    s / (b * b) as f32
}

#[test]
fn light_and_path_tracing_agree_on_caustics() {
    // The same scene with and without light paths: the images estimate the same integral, so
    // their means agree and their 8×8 blocks agree within the path tracer's noise; and light
    // paths lower the error of the caustic-lit region against a long path-traced render.
    let scene = caustic_box();
    let o = |lt: bool, spp: u32, seed: u64| RenderOptions {
        width: 64,
        height: 48,
        spp,
        threads: None,
        seed,
        integrator: IntegratorSettings {
            max_depth: 8,
            light_tracing: lt,
            ..Default::default()
        },
        ..Default::default()
    };
    let (lt, _) = render(&scene, &o(true, 256, 1), &|_, _| {}).unwrap();
    let (pt, _) = render(&scene, &o(false, 2048, 2), &|_, _| {}).unwrap();
    let (ml, mp) = (lt.mean(), pt.mean());
    for c in 0..3 {
        let r = ml[c] as f64 / mp[c] as f64;
        assert!((r - 1.0).abs() < 0.01, "channel {c}: ratio of means {r}");
    }
    let mut worst = 0f32;
    for by in 0..6 {
        for bx in 0..8 {
            let (a, b) = (
                block_mean(&lt, bx * 8, by * 8, 8),
                block_mean(&pt, bx * 8, by * 8, 8),
            );
            let e = ((a - b).abs() / (b + Vec3::splat(0.01))).max_element();
            worst = worst.max(e);
        }
    }
    eprintln!("light vs path tracing: means {ml} and {mp}, worst 8x8 block {worst:.4}");
    assert!(worst < 0.05, "worst 8x8 block differs by {worst}");
}

#[test]
fn the_adaptive_budget_takes_the_light_passes_of_a_uniform_render() {
    // Light passes do not depend on how camera samples are spread: an adaptive render of
    // mean budget N holds the same N light passes (the same splat sums) as a uniform N-spp
    // render, for any thread count, and a render stopped by its time limit and resumed
    // ends with the same film.
    let scene = caustic_box();
    let uniform = RenderOptions {
        spp: 16,
        ..opts(SamplerKind::Sobol, true)
    };
    let base = RenderOptions {
        adaptive_budget: true,
        ..uniform.clone()
    };
    let whole = film_of(&scene, &base);
    let flat = film_of(&scene, &uniform);
    assert_eq!(whole.light_passes, base.spp);
    let counts = whole.counts();
    assert!(
        counts.iter().min() < counts.iter().max(),
        "the budget was spread unevenly"
    );
    for p in 0..counts.len() {
        assert_eq!(whole.light_mean(p), flat.light_mean(p), "pixel {p}");
    }
    same_film_on_1_and_3_threads(&scene, &base, &whole, "adaptive");
    let mut o = base.clone();
    o.time_limit = Some(f64::MIN_POSITIVE);
    let mut film = new_film(&o).unwrap();
    let stop = AtomicBool::new(false);
    let ctl = Control::new(&stop, &|_, _| {});
    assert!(!render_into(&scene, &o, &mut film, ctl).unwrap().complete);
    assert!(film.light_passes < base.spp);
    o.time_limit = None;
    assert!(render_into(&scene, &o, &mut film, ctl).unwrap().complete);
    assert!(film == whole, "resumed film differs");
}

#[test]
fn an_anisotropic_conductor_looks_the_same_to_light_and_camera_paths() {
    // The box's block, turned by 45°, an anisotropic rough conductor (α 0.005 along its
    // surface's tangent, 0.3 across it), smooth enough to be a caustic surface: its top face
    // throws a streak of the ceiling light onto the ceiling. Light paths sample it by the
    // adjoint BSDF, camera paths by the BSDF, each in the frame its own vertex sets up. Both
    // frames must lie along the tangent, or the streaks they draw differ by the angle between
    // the frames: the two renders agree in every 8×8 block within the noise (0.012 at worst
    // measured; 0.069 where light paths set up the vertex without the tangent, on the ceiling
    // around the streak).
    let mut desc = pathtracer::builtin::cornell_box();
    for m in &mut desc.materials {
        if m.name == "block" {
            m.kind = MaterialKind::Conductor {
                eta: Vec3::new(1.66, 0.88, 0.52),
                k: Vec3::new(9.2, 6.3, 4.8),
                alpha: [0.005, 0.3],
                tint: Vec3::ONE,
                distribution: pathtracer::bsdf::microfacet::Distribution::Beckmann,
            };
        }
    }
    for shape in &mut desc.shapes {
        if let pathtracer::io::desc::ShapeDesc::Mesh {
            name, transform, ..
        } = shape
        {
            if name == "block" {
                *transform = glam::Mat4::from_translation(Vec3::new(-0.4, 0.55, -0.35))
                    * glam::Mat4::from_rotation_y(std::f32::consts::FRAC_PI_4);
            }
        }
    }
    let mut scene = build(&desc);
    // The whole 800 × 600 view at 64 × 48.
    scene.camera.focal_px *= 0.16;
    assert!(pathtracer::lighttrace::usable(&scene, &scene.camera));
    let o = |lt: bool, spp: u32, seed: u64| RenderOptions {
        width: 64,
        height: 48,
        spp,
        threads: None,
        seed,
        integrator: IntegratorSettings {
            max_depth: 4,
            light_tracing: lt,
            ..Default::default()
        },
        ..Default::default()
    };
    let (lt, _) = render(&scene, &o(true, 768, 3), &|_, _| {}).unwrap();
    let (pt, _) = render(&scene, &o(false, 6144, 4), &|_, _| {}).unwrap();
    let mut worst = 0f32;
    for by in 0..6 {
        for bx in 0..8 {
            let (a, b) = (
                block_mean(&lt, bx * 8, by * 8, 8),
                block_mean(&pt, bx * 8, by * 8, 8),
            );
            let e = ((a - b).abs() / (b + Vec3::splat(0.01))).max_element();
            worst = worst.max(e);
        }
    }
    let (ml, mp) = (lt.mean(), pt.mean());
    eprintln!("anisotropic: light vs path tracing means {ml} and {mp}, worst 8x8 block {worst:.4}");
    for c in 0..3 {
        let r = ml[c] as f64 / mp[c] as f64;
        assert!((r - 1.0).abs() < 0.01, "channel {c}: ratio of means {r}");
    }
    assert!(worst < 0.03, "worst 8x8 block differs by {worst}");
}
