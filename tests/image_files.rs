//! Image files as scenes name them: TGA textures in pbrt-v4 and Mitsuba files, OpenEXR
//! `chromaticities`, and malformed images (one error naming the file and the scene line,
//! exit 2, no output; bounded time and memory).
//!
//! Every file here is written by the test itself, but `tests/mitsuba/scenes/sky*.exr`, which
//! `tests/mitsuba/make.py` wrote.

mod common;
use common::{run, temp_dir};
use pathtracer::io::image::Image;
use pathtracer::io::image_file::{decode, Chromaticities};
use std::path::Path;
use std::time::Instant;

/// An 8×8 texture of coloured checks as 8-bit RGB, rows from the top.
fn checks() -> Vec<[u8; 3]> {
    (0..64)
        .map(|i| {
            let (x, y) = (i % 8, i / 8);
            [
                40 + 200 * ((x + y) % 2) as u8,
                30 + 25 * x as u8,
                30 + 25 * y as u8,
            ]
        })
        .collect()
}

/// `pixels` (8×8, rows from the top) as an RLE true-colour TGA stored bottom-up, one raw
/// packet per row, with a TGA 2.0 footer.
fn tga(pixels: &[[u8; 3]]) -> Vec<u8> {
    let mut b = vec![0u8, 0, 10, 0, 0, 0, 0, 0, 0, 0, 0, 0, 8, 0, 8, 0, 24, 0];
    for row in pixels.chunks(8).rev() {
        b.push(7);
        for p in row {
            b.extend_from_slice(&[p[2], p[1], p[0]]);
        }
    }
    b.extend_from_slice(&[0; 8]);
    b.extend_from_slice(b"TRUEVISION-XFILE.\0");
    b
}

/// `pixels` (8×8) as a PNG written by the `image` crate.
fn png(pixels: &[[u8; 3]]) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    let flat: Vec<u8> = pixels.iter().flatten().copied().collect();
    image::write_buffer_with_format(
        &mut out,
        &flat,
        8,
        8,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .unwrap();
    out.into_inner()
}

/// Renders `scene` at 4 spp to an EXR in its folder; the image.
fn render(scene: &Path) -> Image {
    let out = scene.with_extension("out.exr");
    let o = run(&[
        "-s",
        "4",
        "-t",
        "2",
        "-f",
        out.to_str().unwrap(),
        scene.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{}: {stderr}", scene.display());
    assert!(!stderr.contains("not supported"), "{stderr}");
    Image::load(&out).unwrap()
}

const PBRT_SCENE: &str =
    "LookAt 0 0 3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n\
    Film \"rgb\" \"integer xresolution\" [ 32 ] \"integer yresolution\" [ 32 ]\n\
    Sampler \"independent\"\nWorldBegin\nLightSource \"infinite\" \"rgb L\" [ 1 1 1 ]\n\
    Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"FILE\"\n\
    Material \"diffuse\" \"texture reflectance\" \"t\"\n\
    Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ]\n\
    \"point2 uv\" [ 0 0  1 0  1 1  0 1 ] \"integer indices\" [ 0 1 2  0 2 3 ]\n";

const MITSUBA_SCENE: &str = r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
    </sensor>
    <shape type="rectangle">
        <bsdf type="diffuse"><texture type="bitmap" name="reflectance">
            <string name="filename" value="FILE"/></texture></bsdf>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>
"#;

#[test]
fn a_tga_texture_renders_as_the_same_texels_in_a_png_do_in_pbrt_and_mitsuba_files() {
    let dir = temp_dir("tga-texture");
    let texels = checks();
    std::fs::write(dir.join("checks.tga"), tga(&texels)).unwrap();
    std::fs::write(dir.join("checks.png"), png(&texels)).unwrap();
    for (ext, template) in [("pbrt", PBRT_SCENE), ("xml", MITSUBA_SCENE)] {
        let mut images = Vec::new();
        for texture in ["checks.tga", "checks.png"] {
            let scene = dir.join(format!("{}_{ext}.{ext}", &texture[7..]));
            std::fs::write(&scene, template.replace("FILE", texture)).unwrap();
            images.push(render(&scene));
        }
        // The texture shows (the checks differ from their mean) and TGA equals PNG.
        let img = &images[0];
        let spread = img.pixels.iter().map(|p| p.x).fold(0.0f32, f32::max)
            - img.pixels.iter().map(|p| p.x).fold(f32::MAX, f32::min);
        assert!(spread > 0.3, "{ext}: the checks do not show ({spread})");
        assert_eq!(
            images[0], images[1],
            "{ext}: TGA and PNG texels render differently"
        );
    }
}

/// `tests/mitsuba/scenes/NAME`.
fn mitsuba_asset(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/mitsuba/scenes")
        .join(name)
}

/// `sky_adobe.exr` with its `chromaticities` attribute set to `c`.
fn sky_with_chromaticities(c: &Chromaticities) -> Vec<u8> {
    let mut bytes = std::fs::read(mitsuba_asset("sky_adobe.exr")).unwrap();
    let name = b"chromaticities\0chromaticities\0";
    let at = bytes
        .windows(name.len())
        .position(|w| w == name)
        .expect("make.py writes the attribute")
        + name.len()
        + 4;
    let values = [c.red, c.green, c.blue, c.white].concat();
    for (i, v) in values.iter().enumerate() {
        bytes[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
    }
    bytes
}

#[test]
fn exr_chromaticities_convert_to_rec709_and_rec709_ones_change_nothing() {
    let plain = Image::load(&mitsuba_asset("sky.exr")).unwrap();
    let adobe = Image::load(&mitsuba_asset("sky_adobe.exr")).unwrap();
    let rec709 = Image::from_bytes(
        &sky_with_chromaticities(&Chromaticities::REC709),
        "exr",
        "sky_rec709.exr",
    )
    .unwrap();
    assert_eq!(rec709, plain, "Rec. 709 chromaticities changed the pixels");
    // Adobe RGB's values in Rec. 709: the published matrix (Adobe RGB and sRGB share D65).
    let m = glam::Mat3::from_cols(
        glam::Vec3::new(1.3982, 0.0, 0.0),
        glam::Vec3::new(-0.3982, 1.0, -0.0429),
        glam::Vec3::new(0.0, 0.0, 1.0429),
    );
    for (a, p) in adobe.pixels.iter().zip(&plain.pixels) {
        let want = m * *p;
        assert!(
            (*a - want).abs().max_element() < 2e-3 * (1.0 + want.abs().max_element()),
            "{a} {want}"
        );
    }
    // A render from a map with Rec. 709 chromaticities is bit for bit the plain map's.
    let dir = temp_dir("rec709-envmap");
    std::fs::write(
        dir.join("sky_rec709.exr"),
        sky_with_chromaticities(&Chromaticities::REC709),
    )
    .unwrap();
    std::fs::copy(mitsuba_asset("sky.exr"), dir.join("sky.exr")).unwrap();
    let scene = std::fs::read_to_string(mitsuba_asset("envmap.xml")).unwrap();
    std::fs::write(dir.join("plain.xml"), &scene).unwrap();
    std::fs::write(
        dir.join("rec709.xml"),
        scene.replace("sky.exr", "sky_rec709.exr"),
    )
    .unwrap();
    assert_eq!(
        render(&dir.join("plain.xml")),
        render(&dir.join("rec709.xml"))
    );
}

/// A Radiance file of one pixel per row with a `PRIMARIES=` line.
#[test]
fn radiance_primaries_convert_to_rec709() {
    let head = |primaries: &str| {
        let mut b =
            format!("#?RADIANCE\n{primaries}FORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n").into_bytes();
        b.extend_from_slice(&[0, 128, 0, 129]);
        b
    };
    let plain = decode(&head(""), "g.hdr").unwrap();
    assert_eq!(plain.rgb[0], glam::Vec3::new(0.0, 1.0, 0.0));
    let adobe = decode(
        &head("PRIMARIES= 0.64 0.33 0.21 0.71 0.15 0.06 0.3127 0.329\n"),
        "g.hdr",
    )
    .unwrap();
    let g = adobe.rgb[0];
    assert!(
        (g - glam::Vec3::new(-0.3982, 1.0, -0.0429))
            .abs()
            .max_element()
            < 1e-3,
        "{g}"
    );
}

/// A 2×2 TGA header of image type `kind`, `depth` bits, descriptor `desc`, `w × h` pixels.
fn tga_header(kind: u8, w: u16, h: u16, depth: u8, desc: u8) -> Vec<u8> {
    let mut b = vec![0u8, 0, kind, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    b.extend_from_slice(&w.to_le_bytes());
    b.extend_from_slice(&h.to_le_bytes());
    b.extend_from_slice(&[depth, desc]);
    b
}

/// Malformed image files: `(file name, bytes, what the error must say)`.
fn malformed() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let good_png = png(&checks());
    let mut bad_crc = good_png.clone();
    bad_crc[29] ^= 0xFF; // the IHDR chunk's CRC
    let mut truncated_data = tga_header(2, 64, 64, 24, 0);
    truncated_data.extend_from_slice(&[7; 100]);
    let mut short_rle = tga_header(10, 4, 4, 24, 0);
    short_rle.extend_from_slice(&[0x83, 1, 2, 3]); // 4 of 16 pixels, then nothing
    let mut run_without_pixel = tga_header(10, 2, 2, 24, 0);
    run_without_pixel.extend_from_slice(&[0x83, 1]);
    let mut absurd = tga_header(2, 65535, 65535, 32, 8);
    absurd.extend_from_slice(&[0; 64]);
    let mut bad_depth = tga_header(2, 2, 2, 7, 0);
    bad_depth.extend_from_slice(&[0; 16]);
    let mut bad_index = vec![0u8, 1, 1, 0, 0, 2, 0, 24, 0, 0, 0, 0, 2, 0, 1, 0, 8, 0];
    bad_index.extend_from_slice(&[0, 0, 0, 255, 255, 255, 0, 9]); // index 9 of a 2-entry map
    let mut huge_hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 200000 +X 200000\n".to_vec();
    huge_hdr.extend_from_slice(&[1, 2, 3, 4]);
    vec![
        (
            "truncated_header.tga",
            tga_header(2, 2, 2, 24, 0)[..10].to_vec(),
            "TGA",
        ),
        ("truncated_data.tga", truncated_data, "TGA"),
        ("short_rle.tga", short_rle, "TGA"),
        ("run_without_pixel.tga", run_without_pixel, "TGA"),
        ("absurd_size.tga", absurd, "TGA"),
        ("bad_depth.tga", bad_depth, "TGA"),
        ("bad_index.tga", bad_index, "TGA"),
        ("bad_crc.png", bad_crc, "PNG"),
        (
            "truncated.png",
            good_png[..good_png.len() / 2].to_vec(),
            "PNG",
        ),
        ("not_a.png", b"GIF89a....".to_vec(), "not a PNG image"),
        ("absurd_size.hdr", huge_hdr, "Radiance"),
        (
            "short.pfm",
            b"PF\n100000 100000\n-1.0\n\0\0\0\0".to_vec(),
            "PFM",
        ),
        ("empty.exr", Vec::new(), "not an OpenEXR image"),
        ("no_rgb.exr", exr_with_channel("Z"), "neither R, G, B nor Y"),
    ]
}

/// A 2×2 float EXR whose only channel is `name`.
fn exr_with_channel(name: &str) -> Vec<u8> {
    use exr::prelude::*;
    let channel = AnyChannel::new(name, FlatSamples::F32(vec![0.5; 4]));
    let layer = Layer::new(
        (2, 2),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(vec![channel].into()),
    );
    let mut out = std::io::Cursor::new(Vec::new());
    exr::image::Image::from_layer(layer)
        .write()
        .to_buffered(&mut out)
        .unwrap();
    out.into_inner()
}

#[test]
fn malformed_images_give_one_error_naming_the_file_in_bounded_time() {
    let cases = malformed();
    assert!(cases.len() >= 8);
    for (name, bytes, says) in cases {
        let start = Instant::now();
        let e = decode(&bytes, name).expect_err(name);
        assert!(
            e.starts_with(&format!("{name}: ")) && e.contains(says),
            "{name}: {e}"
        );
        assert!(
            start.elapsed().as_secs_f32() < 2.0,
            "{name} took {:?}",
            start.elapsed()
        );
    }
}

#[test]
fn a_scene_naming_a_malformed_image_stops_with_the_file_and_line() {
    let dir = temp_dir("bad-texture");
    let mut truncated = tga(&checks());
    truncated.truncate(60);
    std::fs::write(dir.join("bad.tga"), &truncated).unwrap();
    let mut crc = png(&checks());
    crc[29] ^= 0xFF;
    std::fs::write(dir.join("bad.png"), &crc).unwrap();
    // One error naming the scene's line 7 (the texture) and the image, exit 2, no image.
    let pbrt = [(PBRT_SCENE.replace("FILE", "bad.tga"), ":7", "bad.tga")];
    common::assert_malformed(&dir, "pbrt", &pbrt);
    let mitsuba = [(MITSUBA_SCENE.replace("FILE", "bad.png"), ":7", "bad.png")];
    common::assert_malformed(&dir, "xml", &mitsuba);
}
