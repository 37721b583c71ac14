//! Our own pbrt-v4 scenes (`tests/pbrt/scenes`: one per material, light and shape kind)
//! against pbrt-v4's renders of the same files (`tests/pbrt/refs`, made as
//! `tests/pbrt/README.md` says). pbrt-v4 renders spectrally and this renderer in RGB: saturated
//! light on coloured surfaces (the 3000 K blackbody) differs by a few percent in places.

mod common;
use common::{run, temp_dir};
use pathtracer::io::image::{diff, Image};
use std::path::Path;

/// Scene, largest block metric (mean over 16×16 blocks of the per-channel relative
/// difference, the worst channel) and largest deviation of the ratio of means.
const CASES: &[(&str, f64, f64)] = &[
    ("diffuse", 0.02, 0.01),
    ("conductor_rough", 0.02, 0.01),
    // The anisotropy's direction follows pbrt-v4's ∂p/∂u on the sphere; this renderer's
    // shading frame does not yet (the closing note of issue 37 says so).
    ("conductor_aniso", 0.03, 0.01),
    ("conductor_smooth", 0.02, 0.01),
    ("conductor_reflectance", 0.02, 0.01),
    ("dielectric", 0.02, 0.01),
    ("dielectric_rough", 0.02, 0.01),
    ("thindielectric", 0.02, 0.01),
    ("coateddiffuse", 0.02, 0.01),
    ("coateddiffuse_rough", 0.02, 0.01),
    ("coatedconductor", 0.02, 0.01),
    ("diffusetransmission", 0.02, 0.01),
    ("point_spot_distant", 0.02, 0.01),
    ("area_twosided_blackbody", 0.04, 0.02),
    ("infinite_image", 0.02, 0.01),
    ("shapes", 0.02, 0.01),
    ("texture_fov_tall", 0.02, 0.01),
];

#[test]
fn own_pbrt_scenes_match_pbrt_v4() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/pbrt");
    let dir = temp_dir("pbrt-scenes");
    let mut failures = Vec::new();
    for &(name, max_block, max_ratio) in CASES {
        let out = dir.join(format!("{name}.exr"));
        let scene = root.join("scenes").join(format!("{name}.pbrt"));
        let o = run(&[
            "-s",
            "256",
            "-t",
            "2",
            "-f",
            out.to_str().unwrap(),
            scene.to_str().unwrap(),
        ]);
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let img = Image::load(&out).unwrap();
        let reference = Image::load(&root.join("refs").join(format!("{name}.exr"))).unwrap();
        let d = diff(&img, &reference).unwrap();
        let ratio = d.ratio_of_means_all;
        eprintln!(
            "{name:24} block {:.4}  ratio of means {ratio:.4}",
            d.block_max()
        );
        if d.block_max() > max_block || (ratio - 1.0).abs() > max_ratio {
            failures.push(format!("{name}: {d:?}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
