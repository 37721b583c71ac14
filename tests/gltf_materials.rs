//! glTF material features on the project's hand-written textured quad
//! (`tests/fixtures/textured_quad.gltf`: the square [−1, 1]² in the plane z = 0, facing +z,
//! u along +x and v along −y, seen by a camera at z = 3): normal, metallic-roughness and
//! emissive textures, and transmission.

mod common;

use common::{fixture, temp_dir, TempDir};
use glam::{Vec2, Vec3};
use pathtracer::bsdf::Bsdf;
use pathtracer::math::Ray;
use pathtracer::scene::Scene;
use std::path::{Path, PathBuf};

/// The fixture with its `materials` replaced by `materials` (JSON) and its images by PNG files
/// of `images` (name, width, height, RGB bytes), texture `i` showing image `i`, clamped.
fn quad_with(
    tag: &str,
    materials: &str,
    images: &[(&str, u32, u32, Vec<u8>)],
) -> (TempDir, PathBuf) {
    let dir = temp_dir(tag);
    let text = std::fs::read_to_string(fixture("textured_quad.gltf")).unwrap();
    let replace = |text: &str, key: &str, with: &str| {
        let start = text.find(&format!("\"{key}\"")).unwrap();
        let end = start + text[start..].find("\n ]").unwrap() + 3;
        format!("{}\"{key}\": {with}{}", &text[..start], &text[end..])
    };
    let mut uris = Vec::new();
    let mut textures = Vec::new();
    for (i, (name, w, h, rgb)) in images.iter().enumerate() {
        let png = image::RgbImage::from_raw(*w, *h, rgb.clone()).unwrap();
        png.save(dir.join(name)).unwrap();
        uris.push(format!(r#"{{"uri": "{name}"}}"#));
        textures.push(format!(r#"{{"source": {i}, "sampler": 0}}"#));
    }
    let text = replace(&text, "materials", materials);
    let text = replace(&text, "textures", &format!("[{}]", textures.join(", ")));
    let text = replace(&text, "images", &format!("[{}]", uris.join(", ")));
    let file = dir.join(format!("{tag}.gltf"));
    std::fs::write(&file, text).unwrap();
    (dir, file)
}

fn load(file: &Path) -> Scene {
    let l = pathtracer::setup::load(
        Some(file),
        None,
        pathtracer::light::env::EnvSampling::Importance,
    )
    .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    assert!(
        l.warnings.iter().all(|w| w.contains("has no lights")),
        "{:?}",
        l.warnings
    );
    l.scene
}

/// The shading point and BSDF where the ray from (x, y, 3) straight down −z meets the quad.
fn shade(scene: &Scene, x: f32, y: f32) -> (pathtracer::scene::Surface, Bsdf) {
    let ray = Ray::new(Vec3::new(x, y, 3.0), Vec3::NEG_Z);
    let hit = scene.intersect(&ray).expect("the ray meets the quad");
    let s = scene.surface(&ray, &hit);
    let b = scene.bsdf(&s);
    (s, b)
}

/// The encoding of a tangent-space normal as a texel.
fn encode(n: Vec3) -> Vec<u8> {
    let c = (n.normalize() + Vec3::ONE) * 0.5 * 255.0;
    vec![c.x.round() as u8, c.y.round() as u8, c.z.round() as u8]
}

/// A normal map tilts the shading normal: its red along the tangent (+u, world +x), its green
/// towards the image's top (−v, world +y), `scale` shortening both; the geometric normal
/// stays.
#[test]
fn normal_textures_tilt_the_shading_normal_the_right_way() {
    let tilt = Vec3::new(0.6, 0.0, 0.8);
    for (texel, scale, want) in [
        (tilt, 1.0f32, Vec3::new(0.6, 0.0, 0.8)),
        (Vec3::new(0.0, 0.6, 0.8), 1.0, Vec3::new(0.0, 0.6, 0.8)),
        (tilt, 0.5, Vec3::new(0.3, 0.0, 0.8).normalize()),
        (
            Vec3::new(-0.6, -0.6, 0.5),
            1.0,
            Vec3::new(-0.6, -0.6, 0.5).normalize(),
        ),
    ] {
        let (_dir, file) = quad_with(
            "normal_map",
            &format!(
                r#"[{{"pbrMetallicRoughness": {{"metallicFactor": 0}},
                    "normalTexture": {{"index": 0, "scale": {scale}}}}}]"#
            ),
            &[("n.png", 1, 1, encode(texel))],
        );
        let scene = load(&file);
        let (s, _) = shade(&scene, 0.3, -0.2);
        assert!(
            (s.ns - want).length() < 0.02,
            "texel {texel} scale {scale}: shading normal {}, want {want}",
            s.ns
        );
        assert!((s.ng - Vec3::Z).length() < 1e-6, "{}", s.ng);
    }
}

/// Metalness from blue, roughness from green, each times its factor, read as stored (not
/// sRGB-decoded): the quad's left texel (0, 128, 255) and right texel (0, 255, 64).
#[test]
fn metallic_roughness_textures_modulate_the_factors() {
    let (_dir, file) = quad_with(
        "metallic_roughness",
        r#"[{"pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 0.5,
             "metallicRoughnessTexture": {"index": 0}}}]"#,
        &[("mr.png", 2, 1, vec![0, 128, 255, 0, 255, 64])],
    );
    let scene = load(&file);
    for (x, metallic, roughness) in [
        (-0.5f32, 1.0f32, 0.5 * 128.0 / 255.0),
        (0.5, 64.0 / 255.0, 0.5),
    ] {
        let (_, b) = shade(&scene, x, 0.0);
        let Bsdf::Pbr(p) = b else { panic!("{b:?}") };
        assert!(
            (p.metallic - metallic).abs() < 1e-3 && (p.roughness - roughness).abs() < 1e-3,
            "x {x}: metallic {} roughness {}, want {metallic} {roughness}",
            p.metallic,
            p.roughness
        );
    }
}

/// An emissive texture multiplies the emitted radiance where a ray meets the emitter and where
/// light sampling picks a point: the irradiance that light sampling estimates in front of the
/// quad equals the texture integrated over it.
#[test]
fn emissive_textures_colour_the_light_and_its_samples() {
    // Quadrants red, green (top row) / blue, white, sRGB-encoded full values (linear 1).
    let (_dir, file) = quad_with(
        "emissive",
        r#"[{"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
             "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0},
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}}]"#,
        &[(
            "e.png",
            2,
            2,
            vec![255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255],
        )],
    );
    let scene = load(&file);
    assert_eq!(scene.lights.len(), 1);
    // Seen directly: each quadrant's colour × 2.
    for (x, y, c) in [
        (-0.5f32, 0.5f32, Vec3::X),
        (0.5, 0.5, Vec3::Y),
        (-0.5, -0.5, Vec3::Z),
        (0.5, -0.5, Vec3::ONE),
    ] {
        let (s, _) = shade(&scene, x, y);
        let le = scene.emitted(&s, Vec3::Z);
        assert!((le - c * 2.0).length() < 1e-4, "({x}, {y}): {le}");
        assert_eq!(scene.emitted(&s, Vec3::NEG_Z), Vec3::ZERO, "one-sided");
    }
    // Irradiance at a point in front of the quad's upper-right part, facing it.
    let p = Vec3::new(0.4, 0.3, 0.5);
    let mut rng = pathtracer::sampling::Rng::new(1, 1);
    let n = 400_000;
    let mut est = Vec3::ZERO;
    for _ in 0..n {
        if let Some(ls) = scene.sample_light(0, p, rng.next_2d(), None) {
            est += ls.li * (ls.wi.dot(Vec3::NEG_Z).max(0.0) / ls.pdf);
        }
    }
    let est = est / n as f32;
    // The same integral on a 400×400 grid of the quad: L(x) cos θ cos θ' / r² dA.
    let g = 400;
    let mut exact = Vec3::ZERO;
    for i in 0..g {
        for j in 0..g {
            let q = Vec2::new(
                -1.0 + 2.0 * (i as f32 + 0.5) / g as f32,
                -1.0 + 2.0 * (j as f32 + 0.5) / g as f32,
            );
            let (s, _) = shade(&scene, q.x, q.y);
            let d = Vec3::new(q.x, q.y, 0.0) - p;
            let r2 = d.length_squared();
            let cos = -d.z / r2.sqrt();
            exact += scene.emitted(&s, -d.normalize()) * (cos * cos / r2) * (4.0 / (g * g) as f32);
        }
    }
    for c in 0..3 {
        assert!(
            (est[c] - exact[c]).abs() < 0.01 * exact[c].max(0.05),
            "channel {c}: light sampling {est}, integral {exact}"
        );
    }
    // Green (upper right, nearest) dominates; red and blue differ.
    assert!(exact.y > exact.x && exact.x != exact.z, "{exact}");
}

/// `KHR_materials_transmission` and `KHR_materials_ior` reach the material: a clear, smooth,
/// wholly transmitting quad is a delta dielectric of the file's index, a rough one is not.
#[test]
fn transmission_and_ior_make_a_dielectric() {
    for (roughness, delta) in [(0.0f32, true), (0.4, false)] {
        let (_dir, file) = quad_with(
            "transmission",
            &format!(
                r#"[{{"pbrMetallicRoughness": {{"metallicFactor": 0, "roughnessFactor": {roughness}}},
                     "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}},
                                    "KHR_materials_ior": {{"ior": 1.33}}}}}}]"#
            ),
            &[],
        );
        let scene = load(&file);
        let (_, b) = shade(&scene, 0.0, 0.0);
        let Bsdf::Pbr(p) = b else { panic!("{b:?}") };
        assert_eq!((p.transmission, p.ior), (1.0, 1.33));
        assert_eq!(b.is_delta(), delta, "{b:?}");
        assert_eq!(b.transmits(), !delta, "{b:?}");
    }
}
