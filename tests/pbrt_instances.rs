//! pbrt-v4 object instancing: instances share their object's triangles (a two-level BVH).
//! A file with 10,000 instances of a 100,000-triangle PLY loads and renders in bounded
//! memory (peak resident memory within 1.5× of the same scene with one copy), and instances
//! render as the same scene with the copies written out (flattened).

mod common;
use common::{run, temp_dir};
use pathtracer::io::image::{diff, Image};
use std::fmt::Write as _;
use std::path::Path;

/// A binary PLY grid of `n × n` quads (2·n² triangles) over the unit square in x–z.
fn write_grid(path: &Path, n: usize) {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        (n + 1) * (n + 1),
        2 * n * n
    )
    .into_bytes();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
            let y = 0.05 * ((x * 20.0).sin() + (z * 17.0).cos());
            for v in [x, y, z] {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let at = |i: usize, j: usize| (j * (n + 1) + i) as i32;
    for j in 0..n {
        for i in 0..n {
            for t in [
                [at(i, j), at(i, j + 1), at(i + 1, j)],
                [at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)],
            ] {
                bytes.push(3);
                for v in t {
                    bytes.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

const HEADER: &str =
    "LookAt 60 80 140  60 0 60  0 1 0\nCamera \"perspective\" \"float fov\" [ 50 ]\n\
    Film \"rgb\" \"integer xresolution\" [ 32 ] \"integer yresolution\" [ 24 ]\nWorldBegin\n\
    LightSource \"distant\" \"point3 from\" [ 1 3 2 ] \"rgb L\" [ 3 3 3 ]\n";

/// Peak memory in MiB from a `peak memory X MiB` line of `text`.
fn peak_mib(text: &str) -> f64 {
    let at = text.find("peak memory ").expect("peak memory reported") + "peak memory ".len();
    text[at..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn ten_thousand_instances_of_a_large_mesh_stay_within_one_copys_memory() {
    let dir = temp_dir("pbrt-instances");
    write_grid(&dir.join("grid.ply"), 224);
    let object =
        "ObjectBegin \"grid\"\nShape \"plymesh\" \"string filename\" [ \"grid.ply\" ]\nObjectEnd\n";
    let mut many = format!("{HEADER}{object}");
    for k in 0..10_000 {
        let (i, j) = (k % 100, k / 100);
        let _ = writeln!(
            many,
            "AttributeBegin\nTranslate {} 0 {}\nObjectInstance \"grid\"\nAttributeEnd",
            i as f32 * 1.2,
            j as f32 * 1.2
        );
    }
    let one = format!("{HEADER}{object}ObjectInstance \"grid\"\n");
    std::fs::write(dir.join("many.pbrt"), many).unwrap();
    std::fs::write(dir.join("one.pbrt"), one).unwrap();
    let mut peaks = Vec::new();
    for name in ["one", "many"] {
        let file = dir.join(format!("{name}.pbrt"));
        let info = run(&["--info", file.to_str().unwrap()]);
        assert!(
            info.status.success(),
            "{}",
            String::from_utf8_lossy(&info.stderr)
        );
        let info = String::from_utf8_lossy(&info.stdout).to_string();
        let out = dir.join(format!("{name}.exr"));
        let r = run(&[
            "-s",
            "2",
            "-t",
            "2",
            "-f",
            out.to_str().unwrap(),
            file.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&r.stderr).to_string();
        assert!(r.status.success(), "{err}");
        assert_eq!(Image::load(&out).unwrap().count_non_finite(), 0);
        eprintln!(
            "{name}: {info}render: {}",
            err.lines()
                .find(|l| l.starts_with("rendered"))
                .unwrap_or("")
        );
        peaks.push((peak_mib(&info), peak_mib(&err)));
    }
    if name_has_instances(&dir.join("many.pbrt")) {
        let (one, many) = (peaks[0], peaks[1]);
        assert!(
            many.0 <= 1.5 * one.0,
            "loading: {many:?} vs one copy {one:?} MiB"
        );
        assert!(
            many.1 <= 1.5 * one.1,
            "rendering: {many:?} vs one copy {one:?} MiB"
        );
    }
}

/// `--info` of `file` reports 10,000 instances of one object.
fn name_has_instances(file: &Path) -> bool {
    let o = run(&["--info", file.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("instances    10000 of 1 objects (100352 shared triangles"),
        "{text}"
    );
    true
}

#[test]
fn instances_render_as_their_flattened_copies() {
    let dir = temp_dir("pbrt-instances-flat");
    let header = "LookAt 0 3 6  0 0.5 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 45 ]\n\
        Film \"rgb\" \"integer xresolution\" [ 64 ] \"integer yresolution\" [ 48 ]\n\
        Sampler \"sobol\" \"integer pixelsamples\" [ 64 ]\nWorldBegin\n\
        LightSource \"infinite\" \"rgb L\" [ 0.3 0.3 0.3 ]\n\
        AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 6 6 6 ]\n\
        Shape \"trianglemesh\" \"point3 P\" [ -1 4 -1  1 4 -1  1 4 1  -1 4 1 ] \"integer indices\" [ 0 1 2  0 2 3 ]\nAttributeEnd\n\
        Material \"diffuse\" \"rgb reflectance\" [ 0.5 0.5 0.5 ]\n\
        Shape \"trianglemesh\" \"point3 P\" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ] \"integer indices\" [ 0 2 1  0 3 2 ]\n";
    let shapes = "Material \"coateddiffuse\" \"rgb reflectance\" [ 0.7 0.3 0.2 ] \"float roughness\" [ 0.1 ]\n\
        Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  0.5 0 0  0.25 0 0.4  0.25 0.5 0.15 ]\n\
        \"integer indices\" [ 0 2 1  0 1 3  1 2 3  2 0 3 ]\nShape \"sphere\" \"float radius\" [ 0.1 ]\n";
    let mut instanced =
        format!("{header}ObjectBegin \"tet\"\nTranslate 0 0.1 0\n{shapes}ObjectEnd\n");
    let mut flattened = header.to_string();
    for k in 0..24 {
        let place = format!(
            "Translate {} 0 {}\nRotate {} 0 1 0\nScale {} {} 1\n",
            (k % 6) as f32 * 0.9 - 2.3,
            (k / 6) as f32 * 0.9 - 1.4,
            k * 37,
            if k % 5 == 0 { -1.0 } else { 1.0 },
            1.0 + 0.1 * (k % 3) as f32
        );
        let _ = writeln!(
            instanced,
            "AttributeBegin\n{place}ObjectInstance \"tet\"\nAttributeEnd"
        );
        let _ = writeln!(
            flattened,
            "AttributeBegin\n{place}Translate 0 0.1 0\n{shapes}AttributeEnd"
        );
    }
    let mut images = Vec::new();
    for (name, text) in [("instanced", &instanced), ("flattened", &flattened)] {
        let file = dir.join(format!("{name}.pbrt"));
        std::fs::write(&file, text).unwrap();
        let out = dir.join(format!("{name}.exr"));
        let r = run(&[
            "-t",
            "2",
            "-f",
            out.to_str().unwrap(),
            file.to_str().unwrap(),
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        images.push(Image::load(&out).unwrap());
    }
    // The same paths but for rounding (instances intersect in their own space), so the
    // images agree far below the noise of a 64-spp render.
    let d = diff(&images[0], &images[1]).unwrap();
    eprintln!("instanced vs flattened: {d:?}");
    assert!(
        d.block_max() < 0.002 && (d.ratio_of_means_all - 1.0).abs() < 0.002,
        "{d:?}"
    );
    let noise = diff(&images[0], &Image::new(64, 48)).unwrap();
    assert!(noise.rmse > 0.0);
}
