//! Multiple importance sampling, light selection by power and time-limited rendering.

mod common;
use common::shared;
use glam::{Mat4, Vec3};
use pathtracer::camera::Camera;
use pathtracer::error::Loc;
use pathtracer::integrator::{Direct, IntegratorSettings, LightSelection};
use pathtracer::io::desc::{LightDesc, LightKind};
use pathtracer::io::image::{diff, Image};
use pathtracer::light::env;
use pathtracer::render::{render, RenderOptions};
use pathtracer::sampling::sampler::SamplerKind;
use pathtracer::scene::build::build;
use std::path::Path;

#[test]
fn time_limited_passes_equal_a_fixed_spp_render() {
    let scene = build(&pathtracer::builtin::cornell_box());
    for sampler in SamplerKind::ALL {
        let base = RenderOptions {
            sampler,
            width: 40,
            height: 30,
            spp: 5,
            integrator: IntegratorSettings {
                max_depth: 4,
                ..Default::default()
            },
            ..Default::default()
        };
        let (fixed, _) = render(&scene, &base, &|_, _| {}).unwrap();
        let (passes, stats) = render(
            &scene,
            &RenderOptions {
                time_limit: Some(1e6),
                ..base.clone()
            },
            &|_, _| {},
        )
        .unwrap();
        assert_eq!(stats.samples, 40 * 30 * 5);
        assert!(
            fixed.pixels == passes.pixels,
            "5 passes must equal a 5-spp render bit for bit"
        );
        // An exhausted budget still finishes the first pass.
        let (_, stats) = render(
            &scene,
            &RenderOptions {
                time_limit: Some(1e-9),
                ..base
            },
            &|_, _| {},
        )
        .unwrap();
        assert_eq!(stats.samples, 40 * 30);
    }
}

#[test]
fn power_selection_is_unbiased() {
    // Two point lights at the same place, intensities 1 and 9, over a diffuse floor: choosing
    // one by power and dividing by its probability gives exactly ρ/π · 10 / h² every time.
    let point = |i: f32| LightDesc {
        name: "p".into(),
        kind: LightKind::Point {
            intensity: Vec3::splat(i),
        },
        transform: Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)),
        loc: Loc::default(),
    };
    let desc = common::floor_desc(0.5, vec![point(1.0), point(9.0)]);
    let mut scene = build(&desc);
    assert!(
        (scene.light_pmf(1) - 0.9).abs() < 1e-6,
        "selection in proportion to power"
    );
    scene.camera = Camera::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, 0.5, 0.375);
    let expect = 0.5 / std::f32::consts::PI * 10.0 / 4.0;
    for selection in [LightSelection::Power, LightSelection::All] {
        let opts = RenderOptions {
            width: 8,
            height: 6,
            spp: 1,
            integrator: IntegratorSettings {
                max_depth: 1,
                selection,
                ..Default::default()
            },
            ..Default::default()
        };
        let (img, _) = render(&scene, &opts, &|_, _| {}).unwrap();
        for p in &img.pixels {
            assert!(
                (p.x / expect - 1.0).abs() < 1e-3,
                "{selection:?}: {} vs {expect}",
                p.x
            );
        }
    }
}

fn rel_mse(s: &Path, scene_file: &str, map: Option<&str>, reference: &str, direct: Direct) -> f64 {
    let desc = pathtracer::io::collada::load_file(&s.join(scene_file)).unwrap();
    let mut scene = build(&desc);
    if let Some(map) = map {
        scene
            .add_environment(&s.join(map), env::EnvSampling::Importance)
            .unwrap();
    }
    let opts = RenderOptions {
        spp: 16,
        seed: 9,
        integrator: IntegratorSettings {
            max_depth: 100,
            light_samples: 1,
            direct,
            ..Default::default()
        },
        ..Default::default()
    };
    let (img, _) = render(&scene, &opts, &|_, _| {}).unwrap();
    diff(
        &img,
        &Image::load(&s.join("refs").join(format!("{reference}.exr"))).unwrap(),
    )
    .unwrap()
    .rel_mse
}

#[test]
fn mis_beats_each_strategy_alone() {
    let Some(s) = shared() else { return };
    for (scene, map, reference) in [
        (
            "scenes/cs184/sky/CBspheres_microfacet_al_ag.dae",
            None,
            "CBspheres_microfacet_al_ag_m100",
        ),
        (
            "scenes/cs184/sky/bunny_unlit.dae",
            Some("envmaps/sunrise.exr"),
            "bunny_unlit_sunrise_m100",
        ),
    ] {
        let mis = rel_mse(&s, scene, map, reference, Direct::Mis);
        let light = rel_mse(&s, scene, map, reference, Direct::Light);
        let bsdf = rel_mse(&s, scene, map, reference, Direct::Bsdf);
        eprintln!("{reference} at 16 spp: relMSE MIS {mis:.6}, light sampling {light:.6}, BSDF sampling {bsdf:.6}");
        assert!(
            mis < light && mis < bsdf,
            "{reference}: MIS {mis}, light {light}, BSDF {bsdf}"
        );
    }
}
