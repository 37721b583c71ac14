//! Thin lens, CS184 camera files, cell rendering and adaptive sampling.

mod common;
use common::{fixture, run, temp_dir};
use glam::{Mat4, Vec3};
use pathtracer::camera::Camera;
use pathtracer::error::Loc;
use pathtracer::integrator::IntegratorSettings;
use pathtracer::io::desc::{MaterialDesc, MaterialKind, SceneDesc, ShapeDesc};
use pathtracer::io::image::Image;
use pathtracer::render::{render, Cell, RenderOptions};
use pathtracer::sampling::sampler::SamplerKind;
use pathtracer::scene::{build::build, Scene};

fn material(name: &str, kind: MaterialKind, emission: f32) -> MaterialDesc {
    MaterialDesc {
        name: name.into(),
        kind,
        emission: Vec3::splat(emission),
        loc: Loc::default(),
        one_sided: false,
        interface: None,
    }
}

/// Emitters only (m = 0): the image is exactly what the camera sees of the emitters.
fn render_m0(scene: &Scene, w: u32, h: u32, spp: u32) -> Image {
    let opts = RenderOptions {
        width: w,
        height: h,
        spp,
        seed: 4,
        integrator: IntegratorSettings {
            max_depth: 0,
            ..Default::default()
        },
        ..Default::default()
    };
    render(scene, &opts, &|_, _| {}).unwrap().0
}

/// A checkerboard of emitting (radiance 1) and black squares of side 0.1 in the plane z = −4,
/// shifted by `shift` in x, seen from the origin looking down −Z (vfov 30°).
fn checker_scene(shift: f32) -> Scene {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut mats = Vec::new();
    for i in -10i32..10 {
        for j in -10..10 {
            let (x, y) = (i as f32 * 0.1 + shift, j as f32 * 0.1);
            let b = positions.len() as u32;
            positions.extend([
                Vec3::new(x, y, -4.0),
                Vec3::new(x + 0.1, y, -4.0),
                Vec3::new(x + 0.1, y + 0.1, -4.0),
                Vec3::new(x, y + 0.1, -4.0),
            ]);
            triangles.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
            let m = ((i + j).rem_euclid(2)) as u32;
            mats.extend([m, m]);
        }
    }
    let desc = SceneDesc {
        materials: vec![
            material("white", MaterialKind::Emission, 1.0),
            material("black", MaterialKind::Diffuse { albedo: Vec3::ZERO }, 0.0),
        ],
        shapes: vec![ShapeDesc::Mesh {
            normals: pathtracer::io::desc::MeshNormals::Smooth,
            uvs: Vec::new(),
            one_sided: false,
            name: "checker".into(),
            positions,
            triangles,
            materials: mats,
            transform: Mat4::IDENTITY,
            loc: Loc::default(),
        }],
        ..Default::default()
    };
    let mut scene = build(&desc);
    scene.camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -4.0), 39.0, 30.0);
    scene
}

/// Pixels with values strictly between 10% and 90% along the middle row near the edge at the
/// image centre (x = 48 of 96).
fn edge_width(img: &Image) -> usize {
    let y = img.height / 2;
    (38..58)
        .filter(|&x| (0.1..0.9).contains(&img.get(x, y).x))
        .count()
}

#[test]
fn thin_lens_keeps_the_focal_plane_sharp() {
    // Shift the edge by a third of a pixel so that the pinhole image has one mixed pixel.
    let px = 4.0 / Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, 39.0, 30.0).focal_px;
    let mut scene = checker_scene(px / 3.0);
    let pinhole = edge_width(&render_m0(&scene, 96, 64, 64));
    scene.camera.lens_radius = 0.2;
    scene.camera.focal_distance = 4.0;
    let focused = edge_width(&render_m0(&scene, 96, 64, 64));
    eprintln!("edge width: pinhole {pinhole} px, thin lens focused on the plane {focused} px");
    assert!(
        pinhole <= 1 && focused.abs_diff(pinhole) <= 1,
        "pinhole {pinhole}, focused {focused}"
    );
    // Focused elsewhere, the same lens blurs the edge over many pixels: the measure can fail.
    scene.camera.focal_distance = 2.0;
    let blurred = edge_width(&render_m0(&scene, 96, 64, 64));
    eprintln!("edge width with the focus at 2 instead of 4: {blurred} px");
    assert!(blurred >= 8, "defocused edge width {blurred}");
}

#[test]
fn defocused_point_spreads_into_the_circle_of_confusion() {
    // An emitting sphere of radius 0.02 at distance 2, focus at 4, lens radius 0.1.
    let desc = SceneDesc {
        materials: vec![material("glow", MaterialKind::Emission, 1.0)],
        shapes: vec![ShapeDesc::Sphere {
            name: "dot".into(),
            radius: 0.02,
            material: 0,
            transform: Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0)),
            side: pathtracer::io::desc::EmitSide::Both,
            loc: Loc::default(),
        }],
        ..Default::default()
    };
    let mut scene = build(&desc);
    scene.camera = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, 39.0, 30.0);
    let (a, d, z) = (0.1f32, 4.0f32, 2.0f32);
    scene.camera.lens_radius = a;
    scene.camera.focal_distance = d;
    // Thin-lens circle of confusion on the image plane, in pixels: 2·f·A·|D − z| / (D·z).
    let expect = 2.0 * scene.camera.focal_px * a * (d - z).abs() / (d * z);
    let img = render_m0(&scene, 128, 128, 512);
    // The disk is the convolution of the lens disk with the dot's own small image; its
    // half-plateau contour sits at the circle of confusion.
    let plateau: f32 = (59..69)
        .flat_map(|y| (59..69).map(move |x| (x, y)))
        .map(|(x, y)| img.get(x, y).x)
        .sum::<f32>()
        / 100.0;
    let area = img.pixels.iter().filter(|p| p.x > plateau * 0.5).count() as f32;
    let diameter = 2.0 * (area / std::f32::consts::PI).sqrt();
    eprintln!(
        "defocus disk diameter {diameter:.2} px, thin-lens circle of confusion {expect:.2} px"
    );
    assert!(
        (diameter / expect - 1.0).abs() < 0.1,
        "disk diameter {diameter} px, thin-lens circle of confusion {expect} px"
    );
}

#[test]
fn saved_camera_reproduces_the_image() {
    let d = temp_dir("camfile");
    let f = fixture("quad.dae");
    let (a, b, cam) = (d.join("a.exr"), d.join("b.exr"), d.join("cam.txt"));
    let o = run(&[
        "-s",
        "2",
        "-r",
        "40",
        "30",
        "-b",
        "0.05",
        "-d",
        "4.5",
        "--save-camera",
        cam.to_str().unwrap(),
        "-f",
        a.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_to_string(&cam).unwrap().lines().count(), 6);
    let o = run(&[
        "-s",
        "2",
        "-r",
        "40",
        "30",
        "-c",
        cam.to_str().unwrap(),
        "-f",
        b.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        Image::load(&a).unwrap().mean().x > 0.01,
        "the fixture is lit"
    );
    assert!(
        Image::load(&a).unwrap().pixels == Image::load(&b).unwrap().pixels,
        "save then load must be bit-identical"
    );
    // A flag given on the command line wins over the file.
    let c = d.join("c.exr");
    assert!(run(&[
        "-s",
        "2",
        "-r",
        "40",
        "30",
        "-c",
        cam.to_str().unwrap(),
        "-b",
        "0",
        "-f",
        c.to_str().unwrap(),
        f.to_str().unwrap()
    ])
    .status
    .success());
    assert!(
        Image::load(&a).unwrap().pixels != Image::load(&c).unwrap().pixels,
        "-b 0 overrides the file's lens"
    );
}

#[test]
fn hand_written_camera_moves_the_view() {
    let d = temp_dir("camhand");
    let f = fixture("quad.dae");
    // Looking at the ball from the side and above: position (3, 2, 0), target (0, 0.25, 0).
    let cam = Camera::look_at(
        Vec3::new(3.0, 2.0, 0.0),
        Vec3::new(0.0, 0.25, 0.0),
        40.0,
        30.0,
    );
    let (r, u, b) = (cam.right, cam.up, -cam.forward);
    let text = format!(
        "40 30 1.3333 0.01 100\n3 2 0 0 0.25 0\n1.0 1.57 3.5 0 100\n{} {} {} {} {} {} {} {} {}\n800 600 {}\n3.5 0\n",
        r.x, u.x, b.x, r.y, u.y, b.y, r.z, u.z, b.z, cam.focal_px
    );
    let file = d.join("side.cam");
    std::fs::write(&file, text).unwrap();
    let out = d.join("side.exr");
    let o = run(&[
        "-s",
        "4",
        "-r",
        "40",
        "30",
        "-c",
        file.to_str().unwrap(),
        "-f",
        out.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The same camera built in the library renders the same image; the file's view differs
    // from the scene's own camera.
    let mut scene = build(&pathtracer::io::collada::load_file(&f).unwrap());
    let opts = RenderOptions {
        width: 40,
        height: 30,
        spp: 4,
        ..Default::default()
    };
    let default_view = render(&scene, &opts, &|_, _| {}).unwrap().0;
    scene.camera = cam;
    let expected = render(&scene, &opts, &|_, _| {}).unwrap().0;
    let got = Image::load(&out).unwrap();
    assert!(got.mean().x > 0.01, "the view is lit");
    assert!(
        got.pixels == expected.pixels,
        "the file's camera renders as the same camera built in the library"
    );
    assert!(got.pixels != default_view.pixels, "the file moves the view");
}

#[test]
fn malformed_camera_files_name_the_line() {
    let d = temp_dir("cambad");
    let f = fixture("quad.dae");
    let good = [
        "40 30 1.3333 0.01 100",
        "3 2 0 0 0.25 0",
        "1 1.57 3.5 0 100",
        "1 0 0 0 1 0 0 0 1",
        "800 600 1119",
        "3.5 0",
    ];
    let cases: [(usize, &str, &str); 4] = [
        (
            2,
            "1 1.57 3.5 0",
            "expected 5 numbers (phi theta r minR maxR), found 4",
        ),
        (0, "40 abc 1.3 0.01 100", "'abc' is not a finite number"),
        (3, "1 0 0 0 2 0 0 0 1", "not a rotation"),
        (5, "3.5 -1", "lens radius non-negative"),
    ];
    for (line, replacement, needle) in cases {
        let mut lines = good.map(String::from);
        lines[line] = replacement.into();
        let file = d.join(format!("bad{line}.cam"));
        std::fs::write(&file, lines.join("\n")).unwrap();
        let o = run(&[
            "-s",
            "1",
            "-r",
            "8",
            "6",
            "-c",
            file.to_str().unwrap(),
            "-f",
            d.join("x.png").to_str().unwrap(),
            f.to_str().unwrap(),
        ]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(
            e.contains(&format!("{}:{}:", file.display(), line + 1)) && e.contains(needle),
            "{e}"
        );
    }
    let short = d.join("short.cam");
    std::fs::write(&short, good[..4].join("\n")).unwrap();
    let o = run(&[
        "-c",
        short.to_str().unwrap(),
        "-f",
        d.join("x.png").to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&o.stderr)
        .contains(&format!("{}:5: camera file ends early", short.display())));
}

#[test]
fn four_cells_tile_the_full_render() {
    let scene = build(&pathtracer::builtin::cornell_box());
    for sampler in SamplerKind::ALL {
        let base = RenderOptions {
            sampler,
            width: 61,
            height: 37,
            spp: 3,
            integrator: IntegratorSettings {
                max_depth: 4,
                ..Default::default()
            },
            ..Default::default()
        };
        let (full, _) = render(&scene, &base, &|_, _| {}).unwrap();
        let cells = [
            Cell {
                x: 0,
                y: 0,
                w: 25,
                h: 20,
            },
            Cell {
                x: 25,
                y: 0,
                w: 36,
                h: 20,
            },
            Cell {
                x: 0,
                y: 20,
                w: 25,
                h: 17,
            },
            Cell {
                x: 25,
                y: 20,
                w: 36,
                h: 17,
            },
        ];
        for c in cells {
            let (img, _) = render(
                &scene,
                &RenderOptions {
                    cell: Some(c),
                    ..base.clone()
                },
                &|_, _| {},
            )
            .unwrap();
            assert_eq!((img.width, img.height), (c.w as usize, c.h as usize));
            for y in 0..c.h as usize {
                for x in 0..c.w as usize {
                    assert_eq!(
                        img.get(x, y),
                        full.get(c.x as usize + x, c.y as usize + y),
                        "cell {c:?} pixel ({x}, {y})"
                    );
                }
            }
        }
    }
    let base = RenderOptions {
        width: 61,
        height: 37,
        ..Default::default()
    };
    assert!(
        render(
            &scene,
            &RenderOptions {
                cell: Some(Cell {
                    x: 50,
                    y: 0,
                    w: 20,
                    h: 5
                }),
                ..base
            },
            &|_, _| {}
        )
        .is_err(),
        "a cell outside the frame is an error"
    );
}

#[test]
fn cli_cell_and_adaptive() {
    let d = temp_dir("cli-cell");
    let f = fixture("quad.dae");
    let out = d.join("cell.exr");
    let o = run(&[
        "-s",
        "2",
        "-r",
        "40",
        "30",
        "-p",
        "10",
        "5",
        "12",
        "8",
        "-f",
        out.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = Image::load(&out).unwrap();
    assert_eq!((img.width, img.height), (12, 8));
    let o = run(&[
        "-s",
        "2",
        "-r",
        "40",
        "30",
        "-p",
        "30",
        "5",
        "12",
        "8",
        "-f",
        out.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("does not fit in the 40x30 frame"));
    // Adaptive: the rate image beside the output and the mean sample count.
    let out = d.join("adaptive.png");
    let o = run(&[
        "-s",
        "256",
        "-a",
        "16",
        "0.05",
        "-r",
        "40",
        "30",
        "-f",
        out.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("mean samples per pixel"), "{e}");
    let rate = Image::load(&d.join("adaptive_rate.png")).unwrap();
    assert_eq!((rate.width, rate.height), (40, 30));
    let o = run(&[
        "-a",
        "0",
        "0.05",
        "-f",
        out.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("adaptive BATCH must be an integer in 1..=")
    );
}
