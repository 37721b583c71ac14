//! Participating media ([`pathtracer::volpath`]): exact answers (a white furnace, Beer-Lambert
//! through an absorbing slab), the pbrt-v4 forms of the medium test scenes against Mitsuba's
//! renders of their XML forms (`tests/mitsuba/refs`), the files whose integrator ignores
//! media, and the same bits for any thread count, cell, sample range and stop.

mod common;
use common::CELLS_45X29;
use common::{assert_cell_of, film_of, merged_ranges, run, stopped_and_resumed, temp_dir};
use pathtracer::io::image::{diff, Image};
use pathtracer::light::env::EnvSampling;
use pathtracer::render::{render, RenderOptions};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

/// Renders pbrt-v4 text `text` (written to `dir/name.pbrt`) at `spp`; the image and what
/// the renderer printed on stderr.
fn render_pbrt(dir: &Path, name: &str, text: &str, spp: u32) -> (Image, String) {
    let scene = dir.join(format!("{name}.pbrt"));
    std::fs::write(&scene, text).unwrap();
    let out = dir.join(format!("{name}.exr"));
    let o = run(&[
        "-s",
        &spp.to_string(),
        "-t",
        "2",
        "-f",
        out.to_str().unwrap(),
        scene.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{name}: {stderr}");
    (Image::load(&out).unwrap(), stderr)
}

/// The mean of channel `c` over the pixels `x0..x1 × y0..y1`.
fn mean(img: &Image, c: usize, (x0, x1, y0, y1): (u32, u32, u32, u32)) -> f64 {
    let mut sum = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            sum += f64::from(img.pixels[y as usize * img.width + x as usize][c]);
        }
    }
    sum / f64::from((x1 - x0) * (y1 - y0))
}

const CAMERA: &str = "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 30 ]\n\
    Film \"rgb\" \"integer xresolution\" [ 32 ] \"integer yresolution\" [ 32 ]\n\
    PixelFilter \"box\" \"float xradius\" [ 0.5 ] \"float yradius\" [ 0.5 ]\n";

/// A sphere of chromatic, forward-scattering medium of albedo 1 (bounded by a null surface)
/// in a white environment of radiance 1: every pixel's expected value is 1, seen through the
/// medium or not (a furnace: scattering neither adds nor loses light).
#[test]
fn an_albedo_one_medium_in_a_white_furnace_returns_the_environment() {
    let dir = temp_dir("media-furnace");
    let text = format!(
        "{CAMERA}Integrator \"volpath\" \"integer maxdepth\" [ 1000 ]\nWorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n\
         MakeNamedMedium \"fog\" \"string type\" [ \"homogeneous\" ] \"rgb sigma_a\" [ 0 0 0 ]\n\
           \"rgb sigma_s\" [ 4 1 0.25 ] \"float g\" [ 0.5 ]\n\
         AttributeBegin\n  MediumInterface \"fog\" \"\"\n  Material \"interface\"\n\
           Shape \"sphere\" \"float radius\" [ 1 ]\nAttributeEnd\n"
    );
    let (img, _) = render_pbrt(&dir, "furnace", &text, 256);
    // The sphere covers the middle of the frame (its radius subtends 11.5° of the 15°).
    assert_white(&img);
}

/// Asserts that a furnace image is 1 within noise: within 1% over the middle of the frame
/// (where the medium is) and 0.5% over all of it, every pixel finite.
fn assert_white(img: &Image) {
    for c in 0..3 {
        let middle = mean(img, c, (10, 22, 10, 22));
        let all = mean(img, c, (0, 32, 0, 32));
        assert!((middle - 1.0).abs() < 0.01, "channel {c}: {middle}");
        assert!((all - 1.0).abs() < 0.005, "channel {c}: {all}");
    }
    assert!(img.pixels.iter().all(|v| v.is_finite()));
}

/// A grid medium of albedo 1 (a random chromatic density in a tilted box, pbrt-v4's
/// `rgbgrid`) in a white environment: every pixel's expected value is 1, as in the
/// homogeneous furnace; delta tracking, ratio-tracked light sampling and their MIS must
/// neither add nor lose light.
#[test]
fn an_albedo_one_grid_medium_in_a_white_furnace_returns_the_environment() {
    let dir = temp_dir("media-grid-furnace");
    let mut seed = 12345u32;
    let mut next = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        f64::from(seed >> 8) / f64::from(1u32 << 24)
    };
    let sigma: Vec<String> = (0..5 * 4 * 6 * 3)
        .map(|_| format!("{:.3}", 3.0 * next()))
        .collect();
    let text = format!(
        "{CAMERA}Integrator \"volpath\" \"integer maxdepth\" [ 1000 ]\nWorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n\
         AttributeBegin\n  Rotate 30 1 1 0\n\
         MakeNamedMedium \"smoke\" \"string type\" [ \"rgbgrid\" ] \"float g\" [ 0.5 ]\n\
           \"integer nx\" [ 5 ] \"integer ny\" [ 4 ] \"integer nz\" [ 6 ] \"float scale\" [ 2 ]\n\
           \"point3 p0\" [ -0.8 -0.7 -0.9 ] \"point3 p1\" [ 0.8 0.7 0.9 ]\n\
           \"rgb sigma_s\" [ {} ] \"rgb sigma_a\" [ {} ]\nAttributeEnd\n\
         AttributeBegin\n  MediumInterface \"smoke\" \"\"\n  Material \"interface\"\n\
           Shape \"sphere\" \"float radius\" [ 1.5 ]\nAttributeEnd\n",
        sigma.join(" "),
        // pbrt-v4 takes a missing sigma_a grid as 1 everywhere.
        vec!["0"; sigma.len()].join(" ")
    );
    let (img, stderr) = render_pbrt(&dir, "furnace", &text, 256);
    assert!(!stderr.contains("warning"), "{stderr}");
    // The sphere covers the middle of the frame.
    assert_white(&img);
}

/// Emission from media (pbrt-v4's `Le`, the source term `σa·Le`): a purely absorbing,
/// glowing slab seen face-on is `Le·(1 − exp(−σa·d/cos θ))` per pixel, and a glowing,
/// absorbing `rgbgrid` (random `σa` and `Le` per voxel) matches the emission integrated
/// along each pixel's rays by quadrature of the loaded medium.
#[test]
fn glowing_media_emit_what_the_emission_integral_says() {
    let dir = temp_dir("media-emission");
    let sigma_a = [0.4f64, 1.6, 4.0];
    let le = [2.0f64, 1.0, 0.5];
    let text = format!(
        "{CAMERA}Integrator \"volpath\" \"integer maxdepth\" [ 4 ]\nWorldBegin\n\
         MakeNamedMedium \"glow\" \"string type\" [ \"homogeneous\" ] \"rgb sigma_a\" [ {} {} {} ]\n\
           \"rgb sigma_s\" [ 0 0 0 ] \"rgb Le\" [ {} {} {} ]\n\
         AttributeBegin\n  MediumInterface \"glow\" \"\"\n  Material \"interface\"\n\
           Shape \"trianglemesh\" \"point3 P\" [ -3 -3 0  3 -3 0  3 3 0  -3 3 0\n\
             -3 -3 0.5  3 -3 0.5  3 3 0.5  -3 3 0.5 ]\n\
           \"integer indices\" [ 0 2 1  0 3 2  4 5 6  4 6 7  0 1 5  0 5 4  3 6 2  3 7 6\n\
             0 4 7  0 7 3  1 2 6  1 6 5 ]\nAttributeEnd\n",
        sigma_a[0], sigma_a[1], sigma_a[2], le[0], le[1], le[2]
    );
    let (img, _) = render_pbrt(&dir, "slab", &text, 256);
    let tan = (15f64).to_radians().tan();
    for c in 0..3 {
        let mut expected = 0.0;
        for y in 0..32 {
            for x in 0..32 {
                let (u, v) = ((x as f64 + 0.5) / 16.0 - 1.0, (y as f64 + 0.5) / 16.0 - 1.0);
                let cos = 1.0 / (1.0 + (u * tan).powi(2) + (v * tan).powi(2)).sqrt();
                expected += le[c] * (1.0 - (-sigma_a[c] * 0.5 / cos).exp()) / 1024.0;
            }
        }
        let got = mean(&img, c, (0, 32, 0, 32));
        assert!(
            (got / expected - 1.0).abs() < 0.01,
            "slab, channel {c}: {got} against {expected}"
        );
    }
    glowing_grid(&dir);
}

/// The `rgbgrid` half of [`glowing_media_emit_what_the_emission_integral_says`].
fn glowing_grid(dir: &Path) {
    let mut seed = 99u32;
    let mut next = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        f64::from(seed >> 8) / f64::from(1u32 << 24)
    };
    let mut values = |n: usize, scale: f64| -> String {
        (0..n)
            .map(|_| format!("{:.3}", scale * next()))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let (sigma_a, le) = (values(4 * 4 * 3 * 3, 2.0), values(4 * 4 * 3 * 3, 3.0));
    let text = format!(
        "{CAMERA}Integrator \"volpath\" \"integer maxdepth\" [ 4 ]\nWorldBegin\n\
         MakeNamedMedium \"glow\" \"string type\" [ \"rgbgrid\" ] \"integer nx\" [ 4 ]\n\
           \"integer ny\" [ 4 ] \"integer nz\" [ 3 ] \"point3 p0\" [ -1 -1 -0.6 ] \"point3 p1\" [ 1 1 0.6 ]\n\
           \"rgb sigma_a\" [ {sigma_a} ] \"rgb sigma_s\" [ {} ]\n\
           \"rgb Le\" [ {le} ] \"float Lescale\" [ 2 ]\n\
         AttributeBegin\n  MediumInterface \"glow\" \"\"\n  Material \"interface\"\n\
           Shape \"sphere\" \"float radius\" [ 1.7 ]\nAttributeEnd\n",
        vec!["0"; 4 * 4 * 3 * 3].join(" ")
    );
    let (img, _) = render_pbrt(dir, "grid", &text, 256);
    let file = dir.join("grid.pbrt");
    let loaded = pathtracer::setup::load(Some(&file), None, EnvSampling::Importance).unwrap();
    let Some(pathtracer::medium::Medium::Grid(m)) = loaded.scene.media.first() else {
        panic!("no grid medium");
    };
    // The camera at z = 5 looks down −z with a 30° field over 32 pixels; 2×2 rays per
    // pixel. Mirroring the image does not change its mean, so x's sign does not matter.
    let tan = (15f64).to_radians().tan();
    let mut expected = [0.0f64; 3];
    for y in 0..64 {
        for x in 0..64 {
            let (u, v) = ((x as f64 + 0.5) / 32.0 - 1.0, (y as f64 + 0.5) / 32.0 - 1.0);
            let d = glam::DVec3::new(u * tan, -v * tan, -1.0).normalize();
            let (steps, length) = (2000, 10.0);
            let dt = length / f64::from(steps);
            let mut tau = [0.0f64; 3];
            for i in 0..steps {
                let p = glam::DVec3::new(0.0, 0.0, 5.0) + d * ((f64::from(i) + 0.5) * dt);
                let at = m.at(p.as_vec3());
                for c in 0..3 {
                    let (a, l) = (f64::from(at.sigma_a[c]), f64::from(at.le[c]));
                    expected[c] += (-tau[c]).exp() * a * l * dt / 4096.0;
                    tau[c] += a * dt;
                }
            }
        }
    }
    for (c, want) in expected.into_iter().enumerate() {
        let got = mean(&img, c, (0, 32, 0, 32));
        assert!(
            want > 0.05 && (got / want - 1.0).abs() < 0.01,
            "grid, channel {c}: {got} against {want}"
        );
    }
}

/// An emitter of radiance 1 seen through a purely absorbing slab of thickness 0.5 (bounded
/// by a null box): each pixel is `exp(−σa · 0.5 / cos θ)` for its ray's angle θ to the
/// slab's normal, which the free flights estimate; the image's mean agrees within 1%.
#[test]
fn an_absorbing_slab_transmits_beer_lambert() {
    let dir = temp_dir("media-slab");
    let sigma_a = [0.4f64, 1.6, 4.0];
    let text = format!(
        "{CAMERA}Integrator \"volpath\" \"integer maxdepth\" [ 4 ]\nWorldBegin\n\
         AttributeBegin\n  AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n\
           Shape \"trianglemesh\" \"point3 P\" [ -2 -2 -1  2 -2 -1  2 2 -1  -2 2 -1 ]\n\
           \"integer indices\" [ 0 1 2  0 2 3 ]\nAttributeEnd\n\
         MakeNamedMedium \"ink\" \"string type\" [ \"homogeneous\" ] \"rgb sigma_a\" [ {} {} {} ]\n\
           \"rgb sigma_s\" [ 0 0 0 ]\n\
         AttributeBegin\n  MediumInterface \"ink\" \"\"\n  Material \"interface\"\n\
           Shape \"trianglemesh\" \"point3 P\" [ -3 -3 0  3 -3 0  3 3 0  -3 3 0\n\
             -3 -3 0.5  3 -3 0.5  3 3 0.5  -3 3 0.5 ]\n\
           \"integer indices\" [ 0 2 1  0 3 2  4 5 6  4 6 7  0 1 5  0 5 4  3 6 2  3 7 6\n\
             0 4 7  0 7 3  1 2 6  1 6 5 ]\nAttributeEnd\n",
        sigma_a[0], sigma_a[1], sigma_a[2]
    );
    let (img, _) = render_pbrt(&dir, "slab", &text, 1024);
    // Each pixel's centre ray: 30° over 32 pixels.
    let tan = (15f64).to_radians().tan();
    let cos = |x: u32, y: u32| {
        let (u, v) = (
            (f64::from(x) + 0.5) / 16.0 - 1.0,
            (f64::from(y) + 0.5) / 16.0 - 1.0,
        );
        1.0 / (1.0 + (u * tan).powi(2) + (v * tan).powi(2)).sqrt()
    };
    for (c, s) in sigma_a.iter().enumerate() {
        let mut expected = 0.0;
        for y in 0..32 {
            for x in 0..32 {
                expected += (-s * 0.5 / cos(x, y)).exp() / 1024.0;
            }
        }
        let got = mean(&img, c, (0, 32, 0, 32));
        assert!(
            (got / expected - 1.0).abs() < 0.01,
            "channel {c}: {got} against {expected}"
        );
    }
}

/// The pbrt-v4 forms of the Mitsuba medium scenes (`tests/pbrt/scenes/media_*.pbrt`, written
/// to be the same scenes) match Mitsuba's renders of the XML forms as closely as the XML
/// forms do (`mitsuba_scenes`: block metric 0.02, ratio of means within 1%).
#[test]
fn pbrt_forms_of_the_medium_scenes_match_mitsuba_on_their_xml_forms() {
    let dir = temp_dir("media-pbrt-xml");
    for name in ["media_fog", "media_glass", "media_smoke"] {
        let scene = root().join(format!("tests/pbrt/scenes/{name}.pbrt"));
        let out = dir.join(format!("{name}.exr"));
        let o = run(&[
            "-s",
            "256",
            "-t",
            "2",
            "-f",
            out.to_str().unwrap(),
            scene.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{name}: {stderr}");
        assert!(!stderr.contains("warning"), "{name}: {stderr}");
        let reference =
            Image::load(&root().join(format!("tests/mitsuba/refs/{name}.exr"))).unwrap();
        let d = diff(&Image::load(&out).unwrap(), &reference).unwrap();
        eprintln!(
            "{name}: block {:.4}, ratio of means {:.4}",
            d.block_max(),
            d.ratio_of_means_all
        );
        assert!(d.block_max() <= 0.02, "{name}: {d:?}");
        assert!((d.ratio_of_means_all - 1.0).abs() <= 0.01, "{name}: {d:?}");
    }
}

/// A volumetric caustic (`tests/pbrt/scenes/media_caustic.pbrt`: a glass sphere under a light,
/// both in fog) against pbrt-v4's bidirectional render of it: light tracing
/// ([`pathtracer::vollight`]) and path tracing alone (`--caustics path`) agree with it in
/// their means, and at equal samples light tracing's relative MSE is lower.
#[test]
fn volumetric_caustics_match_pbrt_v4_and_light_tracing_lowers_their_noise() {
    let dir = temp_dir("media-caustic");
    let scene = root().join("tests/pbrt/scenes/media_caustic.pbrt");
    let reference = Image::load(&root().join("tests/pbrt/refs/media_caustic.exr")).unwrap();
    let render = |caustics: &str| {
        let out = dir.join(format!("{caustics}.exr"));
        let o = run(&[
            "-s",
            "256",
            "-t",
            "2",
            "--caustics",
            caustics,
            "-f",
            out.to_str().unwrap(),
            scene.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        diff(&Image::load(&out).unwrap(), &reference).unwrap()
    };
    let (light, path) = (render("light"), render("path"));
    eprintln!(
        "light tracing: relMSE {:.5}, ratio {:.4}; path tracing: relMSE {:.5}, ratio {:.4}",
        light.rel_mse, light.ratio_of_means_all, path.rel_mse, path.ratio_of_means_all
    );
    for d in [&light, &path] {
        assert!((d.ratio_of_means_all - 1.0).abs() < 0.03, "{d:?}");
    }
    assert!(
        light.rel_mse < 0.8 * path.rel_mse,
        "{light:?} against {path:?}"
    );
}

/// Files whose integrator ignores media (pbrt-v4's and Mitsuba's `path`) render without
/// them, with one warning naming the file and line.
#[test]
fn path_integrators_leave_media_out_with_a_warning() {
    let dir = temp_dir("media-path");
    let pbrt = std::fs::read_to_string(root().join("tests/pbrt/scenes/media_fog.pbrt"))
        .unwrap()
        .replace("Integrator \"volpath\"", "Integrator \"path\"");
    let (with_path, stderr) = render_pbrt(&dir, "fog_path", &pbrt, 16);
    assert!(
        stderr.contains("fog_path.pbrt:9:") && stderr.contains("ignores participating media"),
        "{stderr}"
    );
    let (fog, _) = render_pbrt(
        &dir,
        "fog_volpath",
        &pbrt.replace("\"path\"", "\"volpath\""),
        16,
    );
    let d = diff(&with_path, &fog).unwrap();
    assert!(d.block_max() > 0.1, "the fog changes the image: {d:?}");
    let xml = std::fs::read_to_string(root().join("tests/mitsuba/scenes/media_fog.xml"))
        .unwrap()
        .replace("type=\"volpath\"", "type=\"path\"");
    let file = dir.join("fog_path.xml");
    std::fs::write(&file, xml).unwrap();
    let out = dir.join("fog_path_xml.exr");
    let o = run(&[
        "-s",
        "4",
        "-f",
        out.to_str().unwrap(),
        file.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("fog_path.xml:3:") && stderr.contains("ignores participating media"),
        "{stderr}"
    );
}

/// The same bits for any thread count, cell, merged sample ranges and a stop then resume, in
/// a fog (`media_fog`), with volumetric caustic light paths (`media_glass`, whose water
/// sphere is a delta surface) and in a grid medium (`media_smoke`).
#[test]
fn medium_renders_are_bit_identical_for_any_threads_cells_ranges_and_stops() {
    for name in ["media_fog", "media_glass", "media_smoke"] {
        let file = root().join(format!("tests/mitsuba/scenes/{name}.xml"));
        let loaded = pathtracer::setup::load(Some(&file), None, EnvSampling::Importance).unwrap();
        let scene = &loaded.scene;
        assert!(scene.volumetric && !scene.media.is_empty());
        let base = RenderOptions {
            width: 45,
            height: 29,
            spp: 5,
            threads: Some(2),
            seed: 7,
            ..loaded.choices(&[]).unwrap().render_options()
        };
        let whole = film_of(scene, &base);
        assert_eq!(
            whole.light_passes > 0,
            name == "media_glass",
            "{name}: light tracing where a delta surface is"
        );
        let image = whole.develop();
        for threads in [1, 3] {
            let o = RenderOptions {
                threads: Some(threads),
                ..base.clone()
            };
            assert!(film_of(scene, &o) == whole, "{name}: {threads} threads");
        }
        for c in CELLS_45X29 {
            let o = RenderOptions {
                cell: Some(c),
                ..base.clone()
            };
            let img = render(scene, &o, &|_, _| {}).unwrap().0;
            assert_cell_of(&img, &image, c, name);
        }
        assert!(
            merged_ranges(scene, &base, 2) == whole,
            "{name}: merged sample ranges"
        );
        assert!(
            stopped_and_resumed(scene, &base).develop() == image,
            "{name}: stopped and resumed"
        );
    }
}
