//! Environment lights: every shared map loads and matches its twin in other encodings, the
//! bunny under sunrise.exr matches its reference, importance sampling beats uniform sampling,
//! and bad maps give clear warnings or errors.

mod common;
use common::{fixture, run, shared, temp_dir};
use glam::Vec3;
use pathtracer::integrator::IntegratorSettings;
use pathtracer::io::image::{diff, Image};
use pathtracer::light::env::{self, EnvSampling};
use pathtracer::render::{render, RenderOptions};
use std::path::Path;

/// Largest per-channel relative difference `|a − b| / max(|b|, 1e-6)` (0 where both are 0 or
/// both NaN; infinite where only one is NaN).
fn max_relative(a: &Image, b: &Image) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let mut worst = 0f32;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            if p[c].is_nan() != q[c].is_nan() {
                return f32::INFINITY;
            }
            let d = (p[c] - q[c]).abs();
            if d > 0.0 {
                worst = worst.max(d / q[c].abs().max(1e-6));
            }
        }
    }
    worst
}

#[test]
fn every_shared_map_loads_and_twins_match() {
    let Some(s) = shared() else { return };
    let dir = s.join("envmaps");
    let mut n = 0;
    for entry in [dir.clone(), dir.join("dwab")] {
        for f in std::fs::read_dir(&entry).unwrap().flatten() {
            let p = f.path();
            if p.extension().is_some_and(|e| e == "exr") {
                let (light, _warnings) =
                    env::load(&p, EnvSampling::Importance).unwrap_or_else(|e| panic!("{e}"));
                assert_eq!((light.width, light.height), (1024, 512), "{}", p.display());
                assert!(light.dist.total() > 0.0);
                n += 1;
            }
        }
    }
    assert_eq!(n, 10, "8 maps plus 2 DWAB originals");
    // DWAB originals against their ZIP twins; float PIZ and uncompressed float against half ZIP.
    for (a, b) in [
        ("dwab/forest.exr", "forest.exr"),
        ("dwab/sunrise.exr", "sunrise.exr"),
        ("sunrise_f32_piz.exr", "sunrise.exr"),
        ("studio_f32_no.exr", "studio.exr"),
    ] {
        let (ia, ib) = (
            Image::load(&dir.join(a)).unwrap(),
            Image::load(&dir.join(b)).unwrap(),
        );
        let r = max_relative(&ia, &ib);
        eprintln!("{a} vs {b}: max relative difference {r:e}");
        assert!(r <= 1e-3, "{a} vs {b}: {r}");
    }
}

fn bunny_render(s: &Path, sampling: EnvSampling, spp: u32) -> Image {
    let desc =
        pathtracer::io::collada::load_file(&s.join("scenes/cs184/sky/bunny_unlit.dae")).unwrap();
    let mut scene = pathtracer::scene::build::build(&desc);
    scene
        .add_environment(&s.join("envmaps/sunrise.exr"), sampling)
        .unwrap();
    let opts = RenderOptions {
        spp,
        seed: 3,
        integrator: IntegratorSettings {
            max_depth: 100,
            light_samples: 4,
            ..Default::default()
        },
        ..Default::default()
    };
    let (img, stats) = render(&scene, &opts, &|_, _| {}).unwrap();
    assert_eq!(stats.non_finite, 0);
    img
}

#[test]
fn bunny_under_sunrise_matches_reference() {
    let Some(s) = shared() else { return };
    let img = bunny_render(&s, EnvSampling::Importance, 64);
    let reference = Image::load(&s.join("refs/bunny_unlit_sunrise_m100.exr")).unwrap();
    let d = diff(&img, &reference).unwrap();
    eprintln!(
        "bunny + sunrise: block {:.5}, ratio of means {:?}",
        d.block_max(),
        d.ratio_of_means
    );
    assert!(
        d.block_max() <= 0.02 && d.ratio_of_means.iter().all(|r| (r - 1.0).abs() <= 0.012),
        "{d:?}"
    );
}

#[test]
fn importance_sampling_beats_uniform() {
    let Some(s) = shared() else { return };
    let reference = Image::load(&s.join("refs/bunny_unlit_sunrise_m100.exr")).unwrap();
    let imp = diff(&bunny_render(&s, EnvSampling::Importance, 16), &reference)
        .unwrap()
        .rel_mse;
    let uni = diff(&bunny_render(&s, EnvSampling::Uniform, 16), &reference)
        .unwrap()
        .rel_mse;
    eprintln!(
        "16 spp relMSE: importance {imp:.6}, uniform {uni:.6}, ratio {:.1}",
        uni / imp
    );
    assert!(uni >= 4.0 * imp, "importance {imp} vs uniform {uni}");
}

/// Writes a small EXR through the exr crate: `tiles` chooses tiled blocks, `luma` a single Y
/// channel in half floats (otherwise RGB floats).
fn write_exr(
    path: &Path,
    w: usize,
    h: usize,
    tiles: bool,
    luma: bool,
    value: impl Fn(usize, usize) -> f32,
) {
    use exr::prelude::*;
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: if tiles {
            Blocks::Tiles(Vec2(16, 16))
        } else {
            Blocks::ScanLines
        },
        line_order: LineOrder::Increasing,
    };
    let values: Vec<f32> = (0..w * h).map(|i| value(i % w, i / w)).collect();
    let list: Vec<AnyChannel<FlatSamples>> = if luma {
        vec![AnyChannel::new(
            "Y",
            FlatSamples::F16(values.iter().map(|&v| f16::from_f32(v)).collect()),
        )]
    } else {
        ["B", "G", "R"]
            .iter()
            .map(|n| AnyChannel::new(*n, FlatSamples::F32(values.clone())))
            .collect()
    };
    let channels = AnyChannels::sort(list.into_iter().collect());
    let layer = Layer::new(Vec2(w, h), LayerAttributes::named(""), encoding, channels);
    exr::prelude::Image::from_layer(layer)
        .write()
        .to_file(path)
        .unwrap();
}

#[test]
fn tiled_and_luminance_only_exr() {
    let d = temp_dir("exr-kinds");
    let f = |x: usize, y: usize| (x + 3 * y) as f32 * 0.25;
    write_exr(&d.join("tiled.exr"), 40, 20, true, false, f);
    write_exr(&d.join("luma.exr"), 40, 20, false, true, f);
    for name in ["tiled.exr", "luma.exr"] {
        let img = Image::load(&d.join(name)).unwrap();
        assert_eq!((img.width, img.height), (40, 20));
        assert_eq!(img.get(7, 3), Vec3::splat(f(7, 3)), "{name}");
    }
}

#[test]
fn bad_maps_warn_or_fail_clearly() {
    let d = temp_dir("bad-maps");
    let scene = fixture("quad.dae");
    let scene = scene.to_str().unwrap();
    // NaN, infinite and negative texels: one warning that counts them, and a finite image.
    let bad = d.join("bad.exr");
    write_exr(&bad, 32, 16, false, false, |x, y| match (x, y) {
        (1, 1) => f32::NAN,
        (2, 1) => f32::INFINITY,
        (3, 2) => -4.0,
        _ => 1.0,
    });
    let out = d.join("out.exr");
    let o = run(&[
        "-s",
        "2",
        "-r",
        "32",
        "24",
        "-e",
        bad.to_str().unwrap(),
        "-f",
        out.to_str().unwrap(),
        scene,
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert_eq!(e.matches("texels were NaN").count(), 1, "{e}");
    assert!(
        e.contains(&format!(
            "{}: 3 texels were NaN, infinite or negative and are treated as 0",
            bad.display()
        )),
        "{e}"
    );
    assert_eq!(Image::load(&out).unwrap().count_non_finite(), 0);
    // Unreadable and unsupported files, and a map of zero size: errors naming the file.
    let garbage = d.join("garbage.exr");
    std::fs::write(&garbage, b"this is not an EXR file").unwrap();
    let jpg = d.join("map.jpg");
    std::fs::write(&jpg, b"whatever").unwrap();
    let empty = d.join("empty.hdr");
    std::fs::write(&empty, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n").unwrap();
    for (map, needle) in [
        (&garbage, "the file is not an OpenEXR image"),
        (&jpg, "the file is not a JPEG image"),
        (&empty, ""),
        (&d.join("missing.exr"), "cannot read image"),
    ] {
        let o = run(&[
            "-s",
            "1",
            "-r",
            "8",
            "6",
            "-e",
            map.to_str().unwrap(),
            "-f",
            out.to_str().unwrap(),
            scene,
        ]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(
            e.contains(&format!("error: {}", map.display())) && e.contains(needle),
            "{e}"
        );
        assert!(!e.contains("panicked"));
    }
}

#[test]
fn env_pdf_image_is_written() {
    let d = temp_dir("pdf-image");
    let map = d.join("sky.exr");
    write_exr(&map, 64, 32, false, false, |x, y| {
        if (x, y) == (20, 8) {
            500.0
        } else {
            1.0
        }
    });
    let png = d.join("pdf.png");
    let out = d.join("out.png");
    let f = fixture("quad.dae");
    let o = run(&[
        "-s",
        "1",
        "-r",
        "8",
        "6",
        "-e",
        map.to_str().unwrap(),
        "--env-pdf-image",
        png.to_str().unwrap(),
        "-f",
        out.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = Image::load(&png).unwrap();
    assert_eq!((img.width, img.height), (64, 32));
    // Brightest in the hot texel's 3×3 neighbourhood (the sampling weights are max-filtered),
    // dim far from it.
    let near = (19..=21)
        .flat_map(|x| (7..=9).map(move |y| (x, y)))
        .map(|(x, y)| img.get(x, y).x)
        .fold(0.0, f32::max);
    assert!(
        near > 0.99 && img.get(50, 25).x < 0.05,
        "{near} {}",
        img.get(50, 25).x
    );
}

#[test]
fn radiance_hdr_map_loads() {
    let d = temp_dir("hdr");
    let path = d.join("sky.hdr");
    let (w, h) = (16u32, 8u32);
    let pixels: Vec<image::Rgb<f32>> = (0..w * h)
        .map(|i| image::Rgb([i as f32 * 0.5, 1.0, 2.0]))
        .collect();
    let file = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    image::codecs::hdr::HdrEncoder::new(file)
        .encode(&pixels, w as usize, h as usize)
        .unwrap();
    let (light, warnings) = env::load(&path, EnvSampling::Importance).unwrap();
    assert!(warnings.is_empty());
    assert_eq!((light.width, light.height), (16, 8));
    let img = Image::load(&path).unwrap();
    // RGBE keeps about 8 bits of mantissa: 1% relative accuracy.
    assert!(
        (img.get(5, 2).x - (2.0 * 16.0 + 5.0) * 0.5).abs() < 0.1
            && (img.get(5, 2).z - 2.0).abs() < 0.02
    );
}
