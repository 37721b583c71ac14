//! The command line: errors name file and line and exit with 2, warnings, `--info`, `diff`.

mod common;
use common::*;

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Writes the fixture with `from` replaced by `to` and returns its path.
fn variant(dir: &std::path::Path, name: &str, from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(fixture("quad.dae")).unwrap();
    assert!(text.contains(from), "fixture lacks {from:?}");
    let p = dir.join(name);
    std::fs::write(&p, text.replacen(from, to, 1)).unwrap();
    p.display().to_string()
}

fn assert_error(args: &[&str], needles: &[&str]) {
    let o = run(args);
    let e = stderr(&o);
    assert_eq!(
        o.status.code(),
        Some(2),
        "exit code for {args:?}; stderr: {e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    for n in needles {
        assert!(e.contains(n), "stderr of {args:?} lacks {n:?}:\n{e}");
    }
}

#[test]
fn fixture_loads_with_info() {
    let f = fixture("quad.dae");
    let o = run(&["--info", f.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("triangles    2 in 1 meshes"), "{out}");
    assert!(out.contains("spheres      1"), "{out}");
    assert!(out.contains("lights       1 (1 area)"), "{out}");
    assert!(out.contains("materials    2 (2 diffuse)"), "{out}");
    assert!(
        out.contains("bounding box min (-2.0000, 0.0000, -2.0000) max (2.0000, 0.5000, 2.0000)"),
        "{out}"
    );
}

#[test]
fn missing_file() {
    assert_error(
        &["--info", "no/such/scene.dae"],
        &["error: no/such/scene.dae: cannot read scene file"],
    );
}

#[test]
fn malformed_xml_names_line() {
    let d = temp_dir("xml");
    let p = variant(&d, "bad.dae", "</library_cameras>", "</library_camerasX>");
    assert_error(&["--info", &p], &[&format!("{p}:25:"), "malformed XML"]);
}

#[test]
fn dangling_reference() {
    let d = temp_dir("dangling");
    let p = variant(&d, "dangle.dae", "url=\"#floor\"", "url=\"#nothing\"");
    assert_error(
        &["--info", &p],
        &[&format!("{p}:75:"), "no element with id 'nothing'"],
    );
}

#[test]
fn nan_in_float_array() {
    let d = temp_dir("nan");
    let p = variant(&d, "nan.dae", "-1 0 -1  1 0 -1", "-1 0 -1  1 NaN -1");
    assert_error(
        &["--info", &p],
        &[
            &format!("{p}:47:"),
            "'floor-pos-array'",
            "item 5 is 'NaN', not a finite number",
        ],
    );
}

#[test]
fn index_out_of_range() {
    let d = temp_dir("index");
    let p = variant(&d, "index.dae", "<p>3 2 1 0</p>", "<p>3 2 1 9</p>");
    assert_error(
        &["--info", &p],
        &[
            &format!("{p}:54:"),
            "vertex index 9 is out of range (the mesh has 4 positions)",
        ],
    );
}

#[test]
fn unknown_cgl_element_is_a_warning() {
    let d = temp_dir("unknown");
    let p = variant(&d, "unknown.dae", "<!--EXTRA-->", "<velvet/>");
    let o = run(&["--info", &p]);
    assert!(o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains(&format!("warning: {p}:36:")) && e.contains("unknown element <velvet>"),
        "{e}"
    );
}

#[test]
fn bad_flags() {
    assert_error(&["-s", "0"], &["invalid value '0' for '-s <N>'"]);
    assert_error(&["-r", "-5", "3"], &["invalid value '-5' for '-r <W> <H>'"]);
    assert_error(&["--frobnicate"], &["unexpected argument '--frobnicate'"]);
    assert_error(&["-m", "x"], &["invalid value 'x' for '-m <N>'"]);
    assert_error(&["-f", "out.jpg"], &["out.jpg: unsupported output format"]);
}

#[test]
fn renders_fixture_and_diffs() {
    let d = temp_dir("render");
    let f = fixture("quad.dae");
    let a = d.join("a.exr");
    let o = run(&[
        "-s",
        "4",
        "-r",
        "64",
        "48",
        "-t",
        "2",
        "-f",
        a.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("rendered 64x48 at 4 spp on 2 threads"));
    let o = run(&["diff", a.to_str().unwrap(), a.to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success()
            && out.contains("RMSE            0.000000")
            && out.contains("ratio of means  1.00000"),
        "{out}"
    );
    // Images of different sizes: non-zero exit.
    let b = d.join("b.exr");
    assert!(run(&[
        "-s",
        "1",
        "-r",
        "32",
        "48",
        "-f",
        b.to_str().unwrap(),
        f.to_str().unwrap()
    ])
    .status
    .success());
    let o = run(&["diff", a.to_str().unwrap(), b.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("images differ in size: 64x48 vs 32x48"));
}

#[test]
fn info_on_every_shared_scene() {
    let Some(shared) = shared() else { return };
    let files = dae_files(&shared.join("scenes").join("cs184"));
    assert!(files.len() >= 30);
    for f in files {
        let o = run(&["--info", f.to_str().unwrap()]);
        assert!(o.status.success(), "{}: {}", f.display(), stderr(&o));
        assert!(String::from_utf8_lossy(&o.stdout).contains("bounding box min"));
    }
}
