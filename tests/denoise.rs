//! Denoising features (albedo and normal past delta bounces, kept in the film) and the
//! `--denoise` flag: features are exact where the answer is known and bit-identical under any
//! split of the work; without Open Image Denoise `--denoise` fails before rendering; with it
//! (CI installs `pyoidn`; elsewhere the tests that need it print a notice and skip) the
//! denoised image is finite and closer to the converged one than the noisy image.

mod common;
use common::{run, temp_dir};
use glam::Vec3;
use pathtracer::film::Film;
use pathtracer::io::desc::MaterialKind;
use pathtracer::io::image::Image;
use pathtracer::render::{new_film, render_into, Control, RenderOptions};
use pathtracer::scene::build::build;
use pathtracer::scene::Scene;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// A pbrt-v4 scene: a camera at the origin looking along `look`, a 10° field of view, 16×16
/// pixels, the diffuse wall x = 2 (reflectance 0.2, 0.5, 0.7) and, where `mirror`, a smooth
/// conductor of reflectance (0.9, 0.8, 0.7) in the plane x + z = −2, facing the camera.
fn wall_scene(dir: &Path, name: &str, look: &str, mirror: bool) -> String {
    let mirror = if mirror {
        "AttributeBegin\n\
         Material \"conductor\" \"rgb reflectance\" [ 0.9 0.8 0.7 ] \"float roughness\" [ 0 ]\n\
         Shape \"trianglemesh\" \"point3 P\" [ -1 -1 -1  1 -1 -3  1 1 -3  -1 1 -1 ]\n\
           \"integer indices\" [ 0 1 2  0 2 3 ]\n\
         AttributeEnd\n"
    } else {
        ""
    };
    let text = format!(
        "LookAt 0 0 0  {look}  0 1 0\n\
         Camera \"perspective\" \"float fov\" [ 10 ]\n\
         Film \"rgb\" \"integer xresolution\" [ 16 ] \"integer yresolution\" [ 16 ]\n\
         WorldBegin\n\
         LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n\
         {mirror}\
         Material \"diffuse\" \"rgb reflectance\" [ 0.2 0.5 0.7 ]\n\
         Shape \"trianglemesh\" \"point3 P\" [ 2 -5 5  2 -5 -10  2 5 -10  2 5 5 ]\n\
           \"integer indices\" [ 0 1 2  0 2 3 ]\n"
    );
    let path = dir.join(format!("{name}.pbrt"));
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// The feature images of `scene` rendered with `opts` (features on).
fn features_of(scene: &Scene, opts: &RenderOptions) -> (Film, Image, Image) {
    let opts = RenderOptions {
        features: true,
        ..opts.clone()
    };
    let mut film = new_film(&opts).unwrap();
    let stop = AtomicBool::new(false);
    render_into(scene, &opts, &mut film, Control::new(&stop, &|_, _| {})).unwrap();
    let (albedo, normal) = film.feature_images().expect("the film records features");
    (film, albedo, normal)
}

fn load(path: &str) -> Scene {
    let sampling = pathtracer::light::env::EnvSampling::Importance;
    pathtracer::setup::load(Some(Path::new(path)), None, sampling)
        .unwrap()
        .scene
}

fn opts(width: u32, height: u32, spp: u32) -> RenderOptions {
    RenderOptions {
        width,
        height,
        spp,
        threads: Some(2),
        ..Default::default()
    }
}

#[test]
fn the_albedo_of_a_diffuse_wall_is_its_reflectance() {
    let dir = temp_dir("features-wall");
    let scene = load(&wall_scene(&dir, "wall", "1 0 0", false));
    let (_, albedo, normal) = features_of(&scene, &opts(16, 16, 8));
    for (a, n) in albedo.pixels.iter().zip(&normal.pixels) {
        assert!(
            (*a - Vec3::new(0.2, 0.5, 0.7)).abs().max_element() < 1e-6,
            "albedo {a}"
        );
        assert!(
            (*n - Vec3::new(-1.0, 0.0, 0.0)).abs().max_element() < 1e-6,
            "normal {n}"
        );
    }
}

#[test]
fn through_a_mirror_the_features_are_those_of_what_it_shows() {
    // The mirror turns the view by 90° onto the wall: its reflectance times the wall's, and
    // the wall's normal.
    let dir = temp_dir("features-mirror");
    let scene = load(&wall_scene(&dir, "mirror", "0 0 -1", true));
    let (_, albedo, normal) = features_of(&scene, &opts(16, 16, 8));
    let want = Vec3::new(0.9 * 0.2, 0.8 * 0.5, 0.7 * 0.7);
    for (a, n) in albedo.pixels.iter().zip(&normal.pixels) {
        assert!(
            (*a - want).abs().max_element() < 1e-5,
            "albedo {a}, want {want}"
        );
        assert!(
            (*n - Vec3::new(-1.0, 0.0, 0.0)).abs().max_element() < 1e-6,
            "normal {n}"
        );
    }
}

/// The built-in box, seen as the command line sees it at 480×360 (CS184's camera, whose
/// smaller renders are centre crops), with a mirror ball, so that features follow delta
/// bounces.
fn mirror_box() -> Scene {
    let mut desc = pathtracer::builtin::cornell_box();
    desc.materials[4].kind = MaterialKind::Mirror {
        reflectance: Vec3::new(0.9, 0.85, 0.8),
    };
    let mut scene = build(&desc);
    let sampling = pathtracer::light::env::EnvSampling::Importance;
    scene.camera = pathtracer::setup::load(None, None, sampling)
        .unwrap()
        .scene
        .camera;
    scene
}

#[test]
fn features_are_bit_identical_for_any_thread_count_cell_and_sample_range() {
    let scene = mirror_box();
    let base = opts(480, 360, 3);
    let whole = features_of(&scene, &base);
    for threads in [1, 3] {
        let o = RenderOptions {
            threads: Some(threads),
            ..base.clone()
        };
        assert!(features_of(&scene, &o).0 == whole.0, "{threads} threads");
    }
    // Sample ranges merge into the whole film, features included.
    let part = |first, count| {
        let o = RenderOptions {
            sample_range: Some((first, count)),
            ..base.clone()
        };
        features_of(&scene, &o).0
    };
    let mut merged = part(0, 1);
    merged.merge(&part(1, 2)).unwrap();
    assert!(merged == whole.0, "merged sample ranges");
    // A cell's features are the whole frame's there.
    let cell = pathtracer::film::Cell {
        x: 270,
        y: 205,
        w: 61,
        h: 43,
    };
    let o = RenderOptions {
        cell: Some(cell),
        ..base.clone()
    };
    let (_, albedo, normal) = features_of(&scene, &o);
    for y in 0..cell.h as usize {
        for x in 0..cell.w as usize {
            let at = (y + cell.y as usize) * 480 + x + cell.x as usize;
            assert_eq!(albedo.pixels[y * cell.w as usize + x], whole.1.pixels[at]);
            assert_eq!(normal.pixels[y * cell.w as usize + x], whole.2.pixels[at]);
        }
    }
    // The ball shows the walls: some albedos are the white walls' tinted by the mirror.
    let white_in_ball = whole.1.pixels.iter().any(|a| {
        (*a - Vec3::new(0.73 * 0.9, 0.73 * 0.85, 0.73 * 0.8))
            .abs()
            .max_element()
            < 1e-5
    });
    assert!(white_in_ball, "the mirror ball shows the white walls");
    // A film without features refuses to merge with one that has them.
    let plain = {
        let o = RenderOptions {
            sample_range: Some((1, 2)),
            ..base.clone()
        };
        let mut f = new_film(&o).unwrap();
        let stop = AtomicBool::new(false);
        render_into(&scene, &o, &mut f, Control::new(&stop, &|_, _| {})).unwrap();
        f
    };
    assert!(plain.feature_images().is_none());
    let mut other = part(0, 1);
    let err = other.merge(&plain).unwrap_err().to_string();
    assert!(err.contains("denoising features"), "{err}");
}

#[test]
fn a_film_with_features_saves_and_loads() {
    let scene = mirror_box();
    let (film, ..) = features_of(&scene, &opts(20, 12, 3));
    let back = Film::from_bytes(&film.to_bytes(), "film").unwrap();
    assert!(back == film && back.has_features());
    // Damaged feature sums are refused.
    let mut bytes = film.to_bytes();
    let n = bytes.len();
    let at = n - 32 - 8;
    bytes[at..at + 8].copy_from_slice(&i64::MAX.to_le_bytes());
    let body = bytes[..n - 32].to_vec();
    let digest = sha256(&body);
    bytes[n - 32..].copy_from_slice(&digest);
    let err = Film::from_bytes(&bytes, "film").unwrap_err().to_string();
    assert!(err.contains("feature sums are invalid"), "{err}");
}

fn sha256(bytes: &[u8]) -> [u8; 32] {
    use sha2::Digest;
    sha2::Sha256::digest(bytes).into()
}

#[test]
fn without_oidn_denoise_fails_before_rendering() {
    let dir = temp_dir("denoise-missing");
    let out = dir.join("out.png");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_pathtracer"))
        .args(["-s", "4", "-r", "32", "24", "--denoise", "-f"])
        .arg(&out)
        .env("PATHTRACER_OIDN", dir.join("no-such-library.so"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("Open Image Denoise 2 was not found"), "{err}");
    assert!(err.contains("pip install pyoidn"), "{err}");
    assert!(
        !err.contains("rendered"),
        "it fails before rendering: {err}"
    );
    let errors = err.lines().filter(|l| l.starts_with("error:")).count();
    assert_eq!(errors, 1, "one error line: {err}");
    assert!(!out.exists());
}

/// The denoiser, or `None` with a notice (an error where `PATHTRACER_REQUIRE_OIDN` is set).
fn denoiser() -> Option<pathtracer::denoise::Denoiser> {
    match pathtracer::denoise::Denoiser::load() {
        Ok(d) => Some(d),
        Err(e) if std::env::var_os("PATHTRACER_REQUIRE_OIDN").is_some() => {
            panic!("PATHTRACER_REQUIRE_OIDN is set but OIDN does not load: {e}")
        }
        Err(e) => {
            eprintln!("NOTICE: skipping (Open Image Denoise not found: {e})");
            None
        }
    }
}

#[test]
fn denoised_images_are_finite_and_closer_to_the_converged_image() {
    let Some(d) = denoiser() else {
        return;
    };
    let scene = mirror_box();
    let (film, albedo, normal) = features_of(&scene, &opts(96, 72, 4));
    let noisy = film.develop();
    let frame = pathtracer::denoise::Frame {
        width: 96,
        height: 72,
        color: &noisy.pixels,
        albedo: Some(&albedo.pixels),
        normal: Some(&normal.pixels),
    };
    let clean = d.denoise(&frame).unwrap();
    assert!(clean
        .iter()
        .all(|p| p.is_finite() && p.min_element() >= 0.0));
    let (reference, _) =
        pathtracer::render::render(&scene, &opts(96, 72, 1024), &|_, _| {}).unwrap();
    let rel_mse = |img: &[Vec3]| {
        let sum: f64 = img
            .iter()
            .zip(&reference.pixels)
            .map(|(a, r)| {
                let d = *a - *r;
                ((d * d) / (*r * *r + 0.01)).element_sum() as f64 / 3.0
            })
            .sum();
        sum / img.len() as f64
    };
    let (before, after) = (rel_mse(&noisy.pixels), rel_mse(&clean));
    eprintln!("relMSE noisy {before:.4}, denoised {after:.4}");
    assert!(
        after < before / 3.0,
        "denoised {after} against noisy {before}"
    );
    // Extreme inputs: a sun of 10⁵, NaN and infinite pixels, out-of-range features.
    let mut wild = noisy.pixels.clone();
    wild[0] = Vec3::splat(f32::NAN);
    wild[1] = Vec3::splat(f32::INFINITY);
    wild[2] = Vec3::splat(1.0e5);
    wild[3] = Vec3::splat(-4.0);
    let mut bad_albedo = albedo.pixels.clone();
    bad_albedo[5] = Vec3::splat(f32::NAN);
    bad_albedo[6] = Vec3::splat(7.0);
    let frame = pathtracer::denoise::Frame {
        color: &wild,
        albedo: Some(&bad_albedo),
        ..frame
    };
    let out = d.denoise(&frame).unwrap();
    assert!(out.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));
    // Sizes that disagree are an error, not a read out of bounds.
    let short = pathtracer::denoise::Frame {
        color: &noisy.pixels[..10],
        ..frame
    };
    assert!(d.denoise(&short).unwrap_err().contains("pixels"));
}

#[test]
fn denoise_writes_the_denoised_image_the_noisy_one_and_the_features() {
    if denoiser().is_none() {
        return;
    }
    let dir = temp_dir("denoise-cli");
    let out = dir.join("box.exr");
    let o = run(&[
        "-s",
        "8",
        "-r",
        "64",
        "48",
        "--denoise",
        "-f",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("denoised in"), "{err}");
    for name in [
        "box.exr",
        "box_noisy.exr",
        "box_albedo.exr",
        "box_normal.exr",
    ] {
        let img = Image::load(&dir.join(name)).unwrap();
        assert_eq!((img.width, img.height), (64, 48), "{name}");
        assert!(img.pixels.iter().all(|p| p.is_finite()), "{name}");
    }
    let clean = Image::load(&out).unwrap();
    let noisy = Image::load(&dir.join("box_noisy.exr")).unwrap();
    assert!(clean.pixels != noisy.pixels);
}

#[test]
fn a_sun_of_ten_to_the_five_in_the_environment_denoises_to_finite_pixels() {
    if denoiser().is_none() {
        return;
    }
    // A latitude-longitude sky of 0.3 with a 2×2-texel sun of 10⁵ at 30° elevation, over a
    // diffuse floor, a diffuse ball and a mirror ball that shows the sun.
    let dir = temp_dir("denoise-sun");
    let mut sky = Image::new(64, 32);
    for p in &mut sky.pixels {
        *p = Vec3::splat(0.3);
    }
    for (x, y) in [(20, 10), (21, 10), (20, 11), (21, 11)] {
        sky.pixels[y * 64 + x] = Vec3::splat(1.0e5);
    }
    sky.save(&dir.join("sun.exr")).unwrap();
    let xml = r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="5"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0, 1.2, 4.5" target="0, 0.6, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>
    <shape type="sphere"><point name="center" x="-0.6" y="0.45" z="0"/><float name="radius" value="0.45"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf>
    </shape>
    <shape type="sphere"><point name="center" x="0.6" y="0.45" z="0"/><float name="radius" value="0.45"/>
        <bsdf type="conductor"/>
    </shape>
    <emitter type="envmap"><string name="filename" value="sun.exr"/></emitter>
</scene>"#;
    let scene = dir.join("sun.xml");
    std::fs::write(&scene, xml).unwrap();
    let out = dir.join("sun_out.exr");
    let o = run(&[
        "--denoise",
        "-f",
        out.to_str().unwrap(),
        scene.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let noisy = Image::load(&dir.join("sun_out_noisy.exr")).unwrap();
    let brightest = noisy
        .pixels
        .iter()
        .map(|p| p.max_element())
        .fold(0.0, f32::max);
    assert!(brightest > 1.0e3, "the sun is in the image: {brightest}");
    let clean = Image::load(&out).unwrap();
    assert!(clean
        .pixels
        .iter()
        .all(|p| p.is_finite() && p.min_element() >= 0.0));
}
