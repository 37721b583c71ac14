//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The shared test data folder beside the project, if present. Prints a notice when absent,
/// and fails under CI (`CI=true`), which always has it.
pub fn shared() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("shared");
    if p.join("scenes").is_dir() {
        Some(p)
    } else {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "../shared not found: under CI (CI=true) the tests that need it fail"
        );
        eprintln!("NOTICE: ../shared not found; skipping this test (CI always has it)");
        None
    }
}

/// Path of a fixture under tests/fixtures.
pub fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("fixtures")
        .join(name)
}

/// Runs the pathtracer binary with `args`.
pub fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pathtracer"))
        .args(args)
        .output()
        .expect("the test binary runs")
}

/// A fresh temporary directory for one test, removed with everything in it when the value
/// is dropped (at the end of the test, passed or failed).
pub fn temp_dir(tag: &str) -> TempDir {
    let d = std::env::temp_dir().join(format!("pathtracer-test-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    TempDir(d)
}

/// A temporary directory (see [`temp_dir`]); derefs to its path.
pub struct TempDir(PathBuf);

impl std::ops::Deref for TempDir {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl AsRef<Path> for TempDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Every `.dae` file under `dir`, sorted.
pub fn dae_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("readable dir").flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "dae") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// A 100×100 diffuse floor at y = 0 (albedo `albedo`) under `lights`.
pub fn floor_desc(
    albedo: f32,
    lights: Vec<pathtracer::io::desc::LightDesc>,
) -> pathtracer::io::desc::SceneDesc {
    use glam::{Mat4, Vec3};
    use pathtracer::error::Loc;
    use pathtracer::io::desc::{MaterialDesc, MaterialKind, SceneDesc, ShapeDesc};
    let s = 50.0;
    SceneDesc {
        materials: vec![MaterialDesc {
            name: "floor".into(),
            kind: MaterialKind::Diffuse {
                albedo: Vec3::splat(albedo),
            },
            emission: Vec3::ZERO,
            loc: Loc::default(),
            one_sided: false,
            interface: None,
        }],
        shapes: vec![ShapeDesc::Mesh {
            normals: pathtracer::io::desc::MeshNormals::Smooth,
            uvs: Vec::new(),
            one_sided: false,
            name: "floor".into(),
            positions: vec![
                Vec3::new(-s, 0.0, -s),
                Vec3::new(-s, 0.0, s),
                Vec3::new(s, 0.0, s),
                Vec3::new(s, 0.0, -s),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            materials: vec![0, 0],
            transform: Mat4::IDENTITY,
            loc: Loc::default(),
        }],
        lights,
        ..Default::default()
    }
}

/// Asserts that two images have the same size and the same bits in every pixel.
pub fn assert_same_bits(a: &pathtracer::io::image::Image, b: &pathtracer::io::image::Image) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let differing = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| p.to_array().map(f32::to_bits) != q.to_array().map(f32::to_bits))
        .count();
    assert_eq!(differing, 0, "pixels that differ");
}

/// Writes each malformed scene `(text, place, message)` of `cases` as `bad{i}.{ext}` in
/// `dir`, renders it, and asserts one error line naming `bad{i}.{ext}{place}` and holding
/// `message`, exit status 2 and no image written.
pub fn assert_malformed(dir: &Path, ext: &str, cases: &[(String, &str, &str)]) {
    for (i, (text, place, want)) in cases.iter().enumerate() {
        let file = dir.join(format!("bad{i}.{ext}"));
        std::fs::write(&file, text).unwrap();
        let out = dir.join(format!("bad{i}.png"));
        let o = run(&[
            "-s",
            "1",
            "-f",
            out.to_str().unwrap(),
            file.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        let lines: Vec<&str> = err.lines().filter(|l| !l.starts_with("warning")).collect();
        assert_eq!(o.status.code(), Some(2), "case {i} ({want}): {err}");
        assert_eq!(lines.len(), 1, "case {i}: one error line, not: {err}");
        assert!(lines[0].starts_with("error: "), "case {i}: {err}");
        let named = format!("bad{i}.{ext}{place}");
        assert!(
            lines[0].contains(&named) && lines[0].contains(want),
            "case {i}: want {named} … {want}, got {err}"
        );
        assert!(!out.exists(), "case {i}: no image");
        eprintln!("{}", lines[0].replace(dir.to_str().unwrap(), "…"));
    }
}

/// Four cells that tile a 45×29 frame (odd sizes, tiles cut at other places than the
/// frame's).
pub const CELLS_45X29: [pathtracer::film::Cell; 4] = [
    pathtracer::film::Cell {
        x: 0,
        y: 0,
        w: 20,
        h: 12,
    },
    pathtracer::film::Cell {
        x: 20,
        y: 0,
        w: 25,
        h: 12,
    },
    pathtracer::film::Cell {
        x: 0,
        y: 12,
        w: 20,
        h: 17,
    },
    pathtracer::film::Cell {
        x: 20,
        y: 12,
        w: 25,
        h: 17,
    },
];

/// Asserts that `part`, the image of `cell`, equals that region of `whole` bit for bit.
pub fn assert_cell_of(
    part: &pathtracer::io::image::Image,
    whole: &pathtracer::io::image::Image,
    cell: pathtracer::film::Cell,
    what: &str,
) {
    for y in 0..cell.h as usize {
        for x in 0..cell.w as usize {
            assert_eq!(
                part.get(x, y),
                whole.get(cell.x as usize + x, cell.y as usize + y),
                "{what}: cell {cell:?} pixel ({x}, {y})"
            );
        }
    }
}

/// The complete film of a render of `scene` with `o`.
pub fn film_of(
    scene: &pathtracer::scene::Scene,
    o: &pathtracer::render::RenderOptions,
) -> pathtracer::film::Film {
    use pathtracer::render::{new_film, render_into, Control};
    let stop = std::sync::atomic::AtomicBool::new(false);
    let mut film = new_film(o).unwrap();
    assert!(
        render_into(scene, o, &mut film, Control::new(&stop, &|_, _| {}))
            .unwrap()
            .complete
    );
    film
}

/// The film of `o`'s samples rendered as two sample ranges, `[0, split)` and `[split, spp)`,
/// merged (the later one first).
pub fn merged_ranges(
    scene: &pathtracer::scene::Scene,
    o: &pathtracer::render::RenderOptions,
    split: u32,
) -> pathtracer::film::Film {
    let part = |first, count| {
        film_of(
            scene,
            &pathtracer::render::RenderOptions {
                sample_range: Some((first, count)),
                ..o.clone()
            },
        )
    };
    let mut merged = part(split, o.spp - split);
    merged.merge(&part(0, split)).unwrap();
    merged
}

/// The film of a render with `o` stopped by a time limit after its first pass, then resumed
/// to its end.
pub fn stopped_and_resumed(
    scene: &pathtracer::scene::Scene,
    o: &pathtracer::render::RenderOptions,
) -> pathtracer::film::Film {
    use pathtracer::render::{new_film, render_into, Control, RenderOptions};
    let mut o = RenderOptions {
        time_limit: Some(f64::MIN_POSITIVE),
        ..o.clone()
    };
    let mut film = new_film(&o).unwrap();
    let stop = std::sync::atomic::AtomicBool::new(false);
    let ctl = Control::new(&stop, &|_, _| {});
    assert!(!render_into(scene, &o, &mut film, ctl).unwrap().complete);
    o.time_limit = None;
    assert!(render_into(scene, &o, &mut film, ctl).unwrap().complete);
    film
}
