//! Direct lighting from each light type against closed-form radiance, and `-o 0`.

mod common;
use glam::{Mat4, Vec3};
use pathtracer::camera::Camera;
use pathtracer::error::Loc;
use pathtracer::integrator::IntegratorSettings;
use pathtracer::io::desc::{LightDesc, LightKind};
use pathtracer::render::{render, RenderOptions};
use pathtracer::scene::build::build;
use std::f32::consts::{FRAC_1_PI, PI};

const RHO: f32 = 0.5;

/// A large diffuse floor at y = 0 lit by `light` (placed by `t`), seen from straight above
/// through a narrow field of view; returns the mean radiance of the small image at depth `m`
/// (all bounces up to `m` when `accumulate`, else only bounce `m`).
fn floor_radiance(light: LightKind, t: Mat4, m: u32, spp: u32, accumulate: bool) -> f32 {
    let desc = common::floor_desc(
        RHO,
        vec![LightDesc {
            name: "l".into(),
            kind: light,
            transform: t,
            loc: Loc::default(),
        }],
    );
    let mut scene = build(&desc);
    scene.camera = Camera::look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, 0.5, 0.375);
    let opts = RenderOptions {
        width: 8,
        height: 6,
        spp,
        seed: 2,
        integrator: IntegratorSettings {
            max_depth: m,
            accumulate,
            ..Default::default()
        },
        ..Default::default()
    };
    let (img, stats) = render(&scene, &opts, &|_, _| {}).unwrap();
    assert_eq!(stats.non_finite, 0);
    img.mean().x
}

fn close(got: f32, want: f32, tol: f32, what: &str) {
    assert!(
        (got / want - 1.0).abs() < tol,
        "{what}: got {got}, want {want}"
    );
}

#[test]
fn point_light_inverse_square() {
    // Intensity 4 at height 2 straight above: L = ρ/π · I / h².
    let l = floor_radiance(
        LightKind::Point {
            intensity: Vec3::splat(4.0),
        },
        Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)),
        1,
        1,
        true,
    );
    close(l, RHO * FRAC_1_PI * 4.0 / 4.0, 0.001, "point");
}

#[test]
fn directional_light_cosine() {
    // Direction to the light normalize(T·(0,0,−1,1)) = normalize(1, 1, 0): 45° incidence.
    let t = Mat4::from_translation(Vec3::new(1.0, 1.0, 1.0));
    let l = floor_radiance(
        LightKind::Directional {
            irradiance: Vec3::splat(2.0),
        },
        t,
        1,
        1,
        true,
    );
    close(
        l,
        RHO * FRAC_1_PI * 2.0 * (PI / 4.0).cos(),
        0.001,
        "directional",
    );
}

#[test]
fn spot_light_cone() {
    // Pointing down (−Z rotated to −Y), 60° cone: full intensity on the axis, nothing outside.
    let down = Mat4::from_rotation_x(-PI / 2.0);
    let on_axis = floor_radiance(
        LightKind::Spot {
            intensity: Vec3::splat(4.0),
            falloff_angle_deg: 60.0,
            falloff_exponent: 2.0,
            falloff_start_deg: None,
            linear_falloff: false,
        },
        Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)) * down,
        1,
        1,
        true,
    );
    close(on_axis, RHO * FRAC_1_PI, 0.001, "spot on axis");
    let tilted =
        Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)) * Mat4::from_rotation_z(PI / 3.0) * down;
    let outside = floor_radiance(
        LightKind::Spot {
            intensity: Vec3::splat(4.0),
            falloff_angle_deg: 60.0,
            falloff_exponent: 2.0,
            falloff_start_deg: None,
            linear_falloff: false,
        },
        tilted,
        1,
        1,
        true,
    );
    assert_eq!(
        outside, 0.0,
        "the floor below is 60° off the axis, outside the 30° half-angle"
    );
}

#[test]
fn ambient_sky() {
    // Constant radiance 1 from the upper hemisphere on an upward floor: L = ρ · 1.
    let l = floor_radiance(
        LightKind::Ambient {
            radiance: Vec3::ONE,
        },
        Mat4::IDENTITY,
        1,
        4096,
        true,
    );
    close(l, RHO, 0.01, "ambient");
}

#[test]
fn only_mth_bounce() {
    // With -o 0, -m 2 under a sky of radiance 1 over an infinite floor: the floor sees only
    // the sky (never itself), so bounce 2 carries nothing and bounce 1 carries ρ.
    let sky = LightKind::Ambient {
        radiance: Vec3::ONE,
    };
    let render_only = |m: u32| floor_radiance(sky.clone(), Mat4::IDENTITY, m, 4096, false);
    close(render_only(1), RHO, 0.01, "-o 0 -m 1");
    assert_eq!(render_only(2), 0.0);
    assert_eq!(
        render_only(0),
        0.0,
        "the floor does not emit and the camera looks at it"
    );
}
