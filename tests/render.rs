//! Render-level properties: determinism across thread counts, no NaN/Inf on any shared scene,
//! the BVH against brute force on the shared meshes.

mod common;
use common::{dae_files, shared};
use pathtracer::bench;
use pathtracer::integrator::{Direct, IntegratorSettings};
use pathtracer::math::Aabb;
use pathtracer::render::{new_film, render, render_into, Control, RenderOptions};
use pathtracer::sampling::sampler::SamplerKind;
use pathtracer::scene::build::build;
use std::sync::atomic::AtomicBool;

#[test]
fn same_seed_same_image_for_any_thread_count() {
    // Every sampler, with and without the adaptive budget (whose per-pixel targets come from
    // the pixels' own samples, so they too are independent of the schedule).
    let scene = build(&pathtracer::builtin::cornell_box());
    for sampler in SamplerKind::ALL {
        for adaptive_budget in [false, true] {
            let opts = |threads, seed| RenderOptions {
                width: 61,
                height: 37,
                spp: if adaptive_budget { 8 } else { 3 },
                threads: Some(threads),
                seed,
                integrator: IntegratorSettings {
                    max_depth: 6,
                    ..Default::default()
                },
                sampler,
                adaptive_budget,
                ..Default::default()
            };
            let (a, sa) = render(&scene, &opts(1, 5), &|_, _| {}).unwrap();
            let (b, sb) = render(&scene, &opts(2, 5), &|_, _| {}).unwrap();
            let (c, _) = render(&scene, &opts(3, 5), &|_, _| {}).unwrap();
            assert!(
                a.pixels == b.pixels && a.pixels == c.pixels,
                "{sampler:?} (adaptive budget {adaptive_budget}): bit-identical for 1, 2, 3 threads"
            );
            assert_eq!(sa.samples_per_pixel, sb.samples_per_pixel);
            let (d, _) = render(&scene, &opts(2, 6), &|_, _| {}).unwrap();
            assert!(a.pixels != d.pixels, "another seed gives another image");
            assert!(a.mean().x > 0.01, "the built-in scene is lit");
            if adaptive_budget {
                // Samples differ between pixels, and none takes more than the cap.
                let (lo, hi) = (
                    sa.samples_per_pixel.iter().min().unwrap(),
                    sa.samples_per_pixel.iter().max().unwrap(),
                );
                assert!(lo < hi && *hi <= 8 * pathtracer::render::ADAPTIVE_CAP);
            }
        }
    }
}

#[test]
fn sample_ranges_merge_into_the_whole_render_bit_for_bit() {
    // The film of [0, 13) equals the merge of [0, 4), [4, 9) and [9, 13) rendered separately
    // (also in another merge order), for every sampler; and a render stopped part-way and
    // continued equals the uninterrupted one.
    let scene = build(&pathtracer::builtin::cornell_box());
    for sampler in SamplerKind::ALL {
        let opts = |range| RenderOptions {
            width: 45,
            height: 29,
            spp: 13,
            threads: Some(2),
            seed: 3,
            integrator: IntegratorSettings {
                max_depth: 6,
                ..Default::default()
            },
            sampler,
            sample_range: range,
            ..Default::default()
        };
        let stop = AtomicBool::new(false);
        let ctl = Control::new(&stop, &|_, _| {});
        let part = |first, count| {
            let o = opts(Some((first, count)));
            let mut film = new_film(&o).unwrap();
            let st = render_into(&scene, &o, &mut film, ctl).unwrap();
            assert!(st.complete);
            film
        };
        let whole = part(0, 13);
        let (image, _) = render(&scene, &opts(None), &|_, _| {}).unwrap();
        assert_eq!(whole.develop(), image);
        let mut merged = part(0, 4);
        merged.merge(&part(4, 5)).unwrap();
        merged.merge(&part(9, 4)).unwrap();
        assert!(
            merged == whole,
            "{sampler:?}: merged ranges differ from the whole"
        );
        let mut other = part(9, 4);
        other.merge(&part(0, 4)).unwrap_err();
        let mut tail = part(4, 5);
        tail.merge(&part(9, 4)).unwrap();
        let mut head = part(0, 4);
        head.merge(&tail).unwrap();
        assert!(head == whole, "{sampler:?}: merge order changes the film");
        // Stopped after some samples (a time limit of zero takes one pass), then continued.
        let mut o = opts(None);
        o.time_limit = Some(f64::MIN_POSITIVE);
        let mut film = new_film(&o).unwrap();
        let st = render_into(&scene, &o, &mut film, ctl).unwrap();
        assert!(!st.complete && film.samples() > 0);
        o.time_limit = None;
        assert!(render_into(&scene, &o, &mut film, ctl).unwrap().complete);
        assert!(film == whole, "{sampler:?}: resumed film differs");
    }
}

#[test]
fn an_adaptive_budget_render_resumes_exactly_from_any_stop() {
    // Stopped at any moment, or at the start of a later round (the stop flag set from the
    // progress callback), and then continued: the film equals the uninterrupted one.
    let scene = build(&pathtracer::builtin::cornell_box());
    let opts = RenderOptions {
        width: 120,
        height: 80,
        spp: 24,
        threads: Some(2),
        seed: 1,
        adaptive_budget: true,
        ..Default::default()
    };
    let stop = AtomicBool::new(false);
    let quiet = Control::new(&stop, &|_, _| {});
    let mut whole = new_film(&opts).unwrap();
    assert!(
        render_into(&scene, &opts, &mut whole, quiet)
            .unwrap()
            .complete
    );
    // Stopped by another thread at several moments (wherever that falls: the pilot, a
    // round's middle), then continued.
    let mut partial = 0;
    for delay_ms in [2u64, 10, 30, 80] {
        let stop1 = AtomicBool::new(false);
        let mut film = new_film(&opts).unwrap();
        let done = std::thread::scope(|sc| {
            sc.spawn(|| {
                std::thread::sleep(std::time::Duration::from_millis(delay_ms));
                stop1.store(true, std::sync::atomic::Ordering::SeqCst);
            });
            let ctl = Control::new(&stop1, &|_, _| {});
            render_into(&scene, &opts, &mut film, ctl).unwrap().complete
        });
        if !done {
            partial += 1;
            assert!(
                render_into(&scene, &opts, &mut film, quiet)
                    .unwrap()
                    .complete
            );
        }
        assert!(film == whole, "resumed after a stop at {delay_ms} ms");
    }
    assert!(partial > 0, "no stop fell inside the render");
    // Ended by a time limit (sub-passes of a round lower the targets for a while), then
    // continued without one.
    for limit in [0.005, 0.01, 0.02, 0.03, 0.05, 0.07, 0.1, 0.14, 0.2, 0.3] {
        let mut film = new_film(&opts).unwrap();
        let mut o = opts.clone();
        o.time_limit = Some(limit);
        render_into(&scene, &o, &mut film, quiet).unwrap();
        assert!(
            render_into(&scene, &opts, &mut film, quiet)
                .unwrap()
                .complete
        );
        assert!(film == whole, "resumed after a time limit of {limit} s");
    }
    // Stop when the second round starts.
    let stop2 = AtomicBool::new(false);
    let progress = |done: usize, _: usize| {
        if done >= 2 {
            stop2.store(true, std::sync::atomic::Ordering::SeqCst);
        }
    };
    let ctl = Control::new(&stop2, &progress);
    let mut film = new_film(&opts).unwrap();
    assert!(!render_into(&scene, &opts, &mut film, ctl).unwrap().complete);
    assert!(film.samples() < whole.samples());
    assert!(
        render_into(&scene, &opts, &mut film, quiet)
            .unwrap()
            .complete
    );
    assert!(film == whole, "resumed from a later round");
}

#[test]
fn no_nan_or_inf_on_any_shared_scene() {
    let Some(s) = shared() else { return };
    for f in dae_files(&s.join("scenes/cs184")) {
        let scene = build(&pathtracer::io::collada::load_file(&f).unwrap());
        for hemisphere in [false, true] {
            let opts = RenderOptions {
                width: 80,
                height: 60,
                spp: 2,
                seed: 3,
                integrator: IntegratorSettings {
                    max_depth: 5,
                    direct: if hemisphere {
                        Direct::Hemisphere
                    } else {
                        Direct::Mis
                    },
                    ..Default::default()
                },
                ..Default::default()
            };
            let (img, stats) = render(&scene, &opts, &|_, _| {}).unwrap();
            assert_eq!(
                stats.non_finite,
                0,
                "{}: non-finite samples (H={hemisphere})",
                f.display()
            );
            assert_eq!(img.count_non_finite(), 0, "{}", f.display());
        }
    }
}

#[test]
fn bvh_invariants_and_brute_force_on_shared_meshes() {
    use rayon::prelude::*;
    let Some(s) = shared() else { return };
    // Every mesh-only shared scene; 100,000 incoherent rays each (the first 100,000 of the
    // benchmark's set), brute force in parallel over rays.
    for name in [
        "sky/CBbunny.dae",
        "meshedit/beetle.dae",
        "meshedit/teapot.dae",
        "meshedit/cow.dae",
        "meshedit/bean.dae",
        "meshedit/quadball.dae",
        "basic/plane16384.dae",
    ] {
        let desc = pathtracer::io::collada::load_file(&s.join("scenes/cs184").join(name)).unwrap();
        let tris = bench::triangles(&desc);
        let bounds: Vec<Aabb> = tris.iter().map(|t| t.bounds()).collect();
        let bvh = pathtracer::accel::bvh::Bvh::build(&bounds);
        bvh.check_invariants(&bounds)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let wide = pathtracer::accel::tribvh::TriangleBvh::from_binary(&bvh, &tris);
        wide.check_invariants(&tris)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let all = bounds.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let rays = bench::incoherent_rays(&all);
        let hits: usize = rays[..100_000]
            .par_iter()
            .map(|r| {
                let rt = pathtracer::geometry::RayTri::new(r);
                let mut best = f32::INFINITY;
                for t in &tris {
                    if let Some((d, _, _)) =
                        pathtracer::geometry::intersect_triangle(r, &rt, t, best)
                    {
                        best = d;
                    }
                }
                let got = bench::closest(&wide, r);
                assert!(
                    got.to_bits() == best.to_bits(),
                    "{name}: closest hit {got} differs from brute force {best}"
                );
                assert!(
                    bench::any_hit(&wide, r) == best.is_finite(),
                    "{name}: any-hit disagrees"
                );
                usize::from(best.is_finite())
            })
            .sum();
        assert!(
            hits > 1000,
            "{name}: the ray set must hit something ({hits})"
        );
    }
}

#[test]
fn scene_intersect_matches_brute_force_over_triangles_and_spheres() {
    use pathtracer::geometry::{intersect_triangle, RayTri};
    use pathtracer::math::Ray;
    use pathtracer::sampling::{uniform_sphere, Rng};
    let scene = build(&pathtracer::builtin::cornell_box());
    assert!(!scene.spheres.is_empty() && !scene.tris.is_empty());
    let b = scene.bounds;
    let mut rng = Rng::new(12, 5);
    let ntri = scene.tris.len() as u32;
    let mut sphere_hits = 0;
    for i in 0..20_000 {
        let o =
            b.min + b.extent() * glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut ray = Ray::new(o, uniform_sphere(rng.next_2d()));
        if i % 3 == 0 {
            ray.t_max = rng.next_f32() * b.extent().length();
        }
        let rt = RayTri::new(&ray);
        let mut best: Option<(f32, u32)> = None;
        for (j, t) in scene.tris.iter().enumerate() {
            let t_max = best.map_or(ray.t_max, |h| h.0);
            if let Some((d, _, _)) = intersect_triangle(&ray, &rt, t, t_max) {
                best = Some((d, j as u32));
            }
        }
        for (j, s) in scene.spheres.iter().enumerate() {
            let t_max = best.map_or(ray.t_max, |h| h.0);
            if let Some(d) = s.intersect(&ray, t_max) {
                best = Some((d, ntri + j as u32));
            }
        }
        let got = scene.intersect(&ray);
        assert_eq!(
            got.map(|h| h.t.to_bits()),
            best.map(|h| h.0.to_bits()),
            "ray {i}"
        );
        if let (Some(h), Some(want)) = (got, best) {
            // The same kind of primitive (another triangle may tie at the same distance).
            assert_eq!(h.prim >= ntri, want.1 >= ntri, "ray {i}");
            sphere_hits += usize::from(h.prim >= ntri);
        }
        assert_eq!(scene.occluded(&ray), best.is_some(), "ray {i}");
    }
    assert!(
        sphere_hits > 500,
        "the rays must reach the spheres ({sphere_hits})"
    );
}
