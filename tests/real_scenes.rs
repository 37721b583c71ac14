//! Real-world OBJ and PLY files from `../shared/scenes/real`: McGuire's Cornell box against its
//! reference (block metric ≤ 0.02, ratio of means within 1.2%), and every OBJ/PLY file loads
//! (`--info`) and renders without a NaN or Inf pixel.

mod common;
use common::{run, shared, temp_dir};
use pathtracer::io::image::{diff, Image};

#[test]
fn mcguire_cornell_box_obj_matches_its_reference() {
    let Some(s) = shared() else { return };
    let dir = temp_dir("cornell-obj");
    let out = dir.join("cornell.exr");
    let scene = s.join("scenes/real/obj/CornellBox-Original.obj");
    // The issue's command at 64 spp (the closing note has the 256-spp run).
    let o = run(&[
        "-t",
        "2",
        "-s",
        "64",
        "-m",
        "100",
        "--lookat",
        "0",
        "1",
        "3.5",
        "0",
        "1",
        "0",
        "0",
        "1",
        "0",
        "--fov",
        "40",
        "-f",
        out.to_str().unwrap(),
        scene.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = Image::load(&out).unwrap();
    assert_eq!(img.count_non_finite(), 0);
    let reference = Image::load(&s.join("refs/CornellBox-Original_obj.exr")).unwrap();
    let d = diff(&img, &reference).unwrap();
    eprintln!(
        "CornellBox-Original.obj: block {:.5}, ratio of means {:?}",
        d.block_max(),
        d.ratio_of_means
    );
    assert!(d.block_max() <= 0.02, "{d:?}");
    assert!(
        d.ratio_of_means.iter().all(|r| (r - 1.0).abs() <= 0.012),
        "{d:?}"
    );
    // Emitting from both sides (towards the ceiling 1 cm above, too) would be caught.
    let mut brighter = img.clone();
    brighter.pixels.iter_mut().for_each(|p| *p *= 1.03);
    let b = diff(&brighter, &reference).unwrap();
    assert!(b.ratio_of_means.iter().any(|r| (r - 1.0).abs() > 0.012));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn every_obj_and_ply_file_loads_and_renders_finite() {
    let Some(s) = shared() else { return };
    let dir = temp_dir("real-scenes");
    let mut n = 0;
    for sub in ["obj", "ply"] {
        for e in std::fs::read_dir(s.join("scenes/real").join(sub)).unwrap() {
            let p = e.unwrap().path();
            let ext = p.extension().map(|x| x.to_string_lossy().into_owned());
            if ext.as_deref() != Some(sub) {
                continue;
            }
            let f = p.to_str().unwrap();
            let info = run(&["--info", f]);
            assert!(
                info.status.success(),
                "{f}: {}",
                String::from_utf8_lossy(&info.stderr)
            );
            let text = String::from_utf8_lossy(&info.stdout);
            assert!(text.contains("triangles"), "{f}: {text}");
            let out = dir.join(format!("{}.exr", p.file_stem().unwrap().to_string_lossy()));
            let o = run(&[
                "-t",
                "2",
                "-s",
                "2",
                "-m",
                "3",
                "-r",
                "96",
                "72",
                "-f",
                out.to_str().unwrap(),
                f,
            ]);
            assert!(
                o.status.success(),
                "{f}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let img = Image::load(&out).unwrap();
            assert_eq!(img.count_non_finite(), 0, "{f}");
            n += 1;
        }
    }
    assert_eq!(n, 4, "CornellBox-Original, suzanne, bunny and teapot");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_obj_and_ply_files_are_one_clear_error() {
    let dir = temp_dir("bad-mesh");
    for (name, text, want) in [
        (
            "a.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n",
            "a.obj:4: vertex index 7 is out of range",
        ),
        (
            "b.obj",
            "v 0 0 0\nv 1 inf 0\n",
            "b.obj:2: not a finite number",
        ),
        (
            "c.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
            "c.ply: the vertex element has no x, y and z",
        ),
        ("d.gltf", "{}", "d.gltf: glTF scenes are not supported yet"),
        ("e.stl", "solid", "e.stl: unknown scene format"),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        let o = run(&[
            "-s",
            "1",
            "-f",
            dir.join("o.png").to_str().unwrap(),
            p.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{name}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(want), "{name}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!dir.join("o.png").exists());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
