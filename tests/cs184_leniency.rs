//! What the CS184 renderer's COLLADA loader accepts beyond the standard is accepted here too,
//! each with a warning naming the file and line; what it would turn into garbage stays an error.

mod common;

use pathtracer::io::collada::{load_file, parse_str};
use pathtracer::io::desc::{LightKind, MaterialKind, ShapeDesc};

/// A scene with one sphere under `node_xform`, a light under `light_xform`, and `extra`
/// appended to the library section; the sphere's material has effect body `effect`.
fn scene(node_xform: &str, light_xform: &str, light_color: &str, effect: &str) -> String {
    format!(
        r##"<?xml version="1.0"?>
<COLLADA version="1.4.1"><asset><up_axis>Y_UP</up_axis></asset>
<library_lights><light id="L"><technique_common><point><color>{light_color}</color></point></technique_common></light></library_lights>
<library_effects><effect id="E">{effect}</effect></library_effects>
<library_materials><material id="M"><instance_effect url="#E"/></material></library_materials>
<library_geometries><geometry id="G"><extra><technique profile="CGL"><sphere><radius>0.5</radius></sphere></technique></extra></geometry></library_geometries>
<library_visual_scenes><visual_scene id="S">
<node>{node_xform}<instance_geometry url="#G"><bind_material><technique_common><instance_material symbol="m" target="#M"/></technique_common></bind_material></instance_geometry></node>
<node>{light_xform}<instance_light url="#L"/></node>
</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#S"/></scene></COLLADA>"##
    )
}

const DIFFUSE: &str = r#"<profile_COMMON><technique sid="common"><lambert><diffuse><color>0.5 0.5 0.5 1</color></diffuse></lambert></technique></profile_COMMON>"#;
const IDENTITY: &str = "<matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</matrix>";

fn warnings_of(text: &str) -> Vec<String> {
    parse_str(text, "s.dae", "s").unwrap().warnings
}

fn line_of(text: &str, needle: &str) -> usize {
    text[..text.find(needle).unwrap()].matches('\n').count() + 1
}

#[test]
fn a_short_matrix_is_padded_with_zeros() {
    // 15 numbers on a light: the missing entry is the bottom-right 1, which a light's
    // position does not use (CS184 renders this).
    let short = "<matrix>1 0 0 2 0 1 0 3 0 0 1 4 0 0 0</matrix>";
    let text = scene(IDENTITY, short, "1 1 1", DIFFUSE);
    let d = parse_str(&text, "s.dae", "s").unwrap();
    let line = line_of(&text, short);
    assert!(
        d.warnings.iter().any(|w| w.starts_with(&format!("s.dae:{line}:"))
            && w.contains("<matrix> has 15 numbers, not 16; the missing entries are 0, as in the CS184 renderer")),
        "{:?}",
        d.warnings
    );
    let l = &d.lights[0];
    assert_eq!(
        l.transform.transform_point3(glam::Vec3::ZERO),
        glam::Vec3::new(2.0, 3.0, 4.0)
    );
    // The same matrix on geometry: CS184 divides its points by w = 0, so it stays an error
    // naming the matrix.
    let text = scene(short, IDENTITY, "1 1 1", DIFFUSE);
    let e = parse_str(&text, "s.dae", "s").unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("s.dae:{}:", line_of(&text, short)))
            && e.contains("<matrix> has 15 numbers, not 16")
            && e.contains("bottom row 0 0 0 0"),
        "{e}"
    );
    // Geometry with a short matrix whose bottom row still holds a non-zero entry renders.
    let w = warnings_of(&scene(
        "<matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 1</matrix>",
        IDENTITY,
        "1 1 1",
        DIFFUSE,
    ));
    assert!(w.iter().any(|w| w.contains("has 15 numbers")), "{w:?}");
}

#[test]
fn extra_items_after_sixteen_matrix_numbers_are_ignored() {
    let long = "<matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 junk 7</matrix>";
    let text = scene(long, IDENTITY, "1 1 1", DIFFUSE);
    let w = warnings_of(&text);
    assert!(
        w.iter().any(
            |w| w.starts_with(&format!("s.dae:{}:", line_of(&text, long)))
                && w.contains("<matrix> has 18 items; only the first 16 are used")
        ),
        "{w:?}"
    );
    // Junk among the 16 stays an error.
    let bad = "<matrix>1 0 0 0 0 1 x 0 0 0 1 0 0 0 0 1</matrix>";
    let e = parse_str(&scene(bad, IDENTITY, "1 1 1", DIFFUSE), "s.dae", "s")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("<matrix>: item 7 'x' is not a finite number"),
        "{e}"
    );
}

#[test]
fn a_colour_with_fewer_numbers_is_padded_with_zeros() {
    let text = scene(IDENTITY, IDENTITY, "10", DIFFUSE);
    let d = parse_str(&text, "s.dae", "s").unwrap();
    assert!(
        d.warnings.iter().any(|w| w
            .starts_with(&format!("s.dae:{}:", line_of(&text, "<color>10<")))
            && w.contains("<color> has 1 number for a colour, not 3; the missing channels are 0")),
        "{:?}",
        d.warnings
    );
    match &d.lights[0].kind {
        LightKind::Point { intensity } => assert_eq!(*intensity, glam::Vec3::new(10.0, 0.0, 0.0)),
        k => panic!("{k:?}"),
    }
    // No number at all stays an error.
    let e = parse_str(&scene(IDENTITY, IDENTITY, "", DIFFUSE), "s.dae", "s")
        .unwrap_err()
        .to_string();
    assert!(e.contains("<color> needs 1 number, found 0"), "{e}");
}

#[test]
fn a_number_followed_by_text_reads_as_its_number() {
    let effect = r#"<extra><technique profile="CGL"><microfacet><alpha>0.25rough</alpha><eta>1 1 1</eta><k>1 1 1</k></microfacet></technique></extra>"#;
    let text = scene(IDENTITY, IDENTITY, "1 1 1", effect);
    let d = parse_str(&text, "s.dae", "s").unwrap();
    assert!(
        d.warnings.iter().any(
            |w| w.starts_with(&format!("s.dae:{}:", line_of(&text, "<alpha>")))
                && w.contains("<alpha> '0.25rough' is not a single number; read as 0.25")
        ),
        "{:?}",
        d.warnings
    );
    let m = d
        .materials
        .iter()
        .find(|m| matches!(m.kind, MaterialKind::Microfacet { .. }));
    match m.map(|m| &m.kind) {
        Some(MaterialKind::Microfacet { alpha, .. }) => assert_eq!(*alpha, 0.25),
        k => panic!("{k:?}"),
    }
    // No leading number stays an error.
    let effect = effect.replace("0.25rough", "rough");
    let e = parse_str(&scene(IDENTITY, IDENTITY, "1 1 1", &effect), "s.dae", "s")
        .unwrap_err()
        .to_string();
    assert!(e.contains("'rough' is not a number"), "{e}");
}

#[test]
fn an_effect_without_url_is_diffuse_grey() {
    let text = scene(IDENTITY, IDENTITY, "1 1 1", DIFFUSE)
        .replace(r##"<instance_effect url="#E"/>"##, "<instance_effect/>");
    let d = parse_str(&text, "s.dae", "s").unwrap();
    assert!(
        d.warnings.iter().any(|w| w
            .starts_with(&format!("s.dae:{}:", line_of(&text, "<instance_effect/>")))
            && w.contains("<instance_effect> has no url; diffuse 0.5 is used")),
        "{:?}",
        d.warnings
    );
    let ShapeDesc::Sphere { material, .. } = &d.shapes[0] else {
        panic!()
    };
    assert_eq!(
        d.materials[*material as usize].kind,
        MaterialKind::Diffuse {
            albedo: glam::Vec3::splat(0.5)
        }
    );
}

#[test]
fn a_short_float_array_uses_the_vectors_it_holds() {
    let text = scene(IDENTITY, IDENTITY, "1 1 1", DIFFUSE).replace(
        "<library_geometries>",
        r##"<library_geometries><geometry id="T"><mesh><source id="p"><float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array>
<technique_common><accessor source="#pa" count="5" stride="3"/></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
<triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p></triangles></mesh></geometry>"##,
    ).replace("<node>", r##"<node><instance_geometry url="#T"/></node><node>"##);
    let d = parse_str(&text, "s.dae", "s").unwrap();
    assert!(
        d.warnings.iter().any(|w| w
            .starts_with(&format!("s.dae:{}:", line_of(&text, "<float_array")))
            && w.contains("has 9 numbers, its accessor asks for 5 vectors (15 numbers); the 3 whole vectors it holds are used")),
        "{:?}",
        d.warnings
    );
    // Indices beyond the data stay an error.
    let bad = text.replace("<p>0 1 2</p>", "<p>0 1 4</p>");
    assert!(parse_str(&bad, "s.dae", "s").is_err());
}

#[test]
fn a_doctype_and_non_utf8_bytes_are_read() {
    let text = scene(IDENTITY, IDENTITY, "1 1 1", DIFFUSE).replace(
        "<?xml version=\"1.0\"?>\n",
        "<?xml version=\"1.0\"?>\n<!DOCTYPE COLLADA>\n",
    );
    let w = warnings_of(&text);
    assert!(
        w.iter()
            .any(|w| w.starts_with("s.dae:2:") && w.contains("<!DOCTYPE> is not part of COLLADA")),
        "{w:?}"
    );
    // A Latin-1 name (é as the single byte 0xE9) on line 3.
    let dir = common::temp_dir("latin1");
    let f = dir.join("latin1.dae");
    let mut bytes = scene(IDENTITY, IDENTITY, "1 1 1", DIFFUSE)
        .replace(r#"<light id="L">"#, "<light id=\"L\" name=\"lumi\u{1}re\">")
        .into_bytes();
    let at = bytes.iter().position(|&b| b == 1).unwrap();
    bytes[at] = 0xE9;
    std::fs::write(&f, &bytes).unwrap();
    let d = load_file(&f).unwrap();
    assert!(
        d.warnings[0].starts_with(&format!("{}:3:", f.display()))
            && d.warnings[0].contains("not valid UTF-8"),
        "{:?}",
        d.warnings
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_cli_prints_the_warnings_and_renders() {
    let dir = common::temp_dir("lenient-cli");
    let f = dir.join("short.dae");
    std::fs::write(
        &f,
        scene(
            IDENTITY,
            "<matrix>1 0 0 0 0 1 0 1 0 0 1 3 0 0 0</matrix>",
            "1 1 1",
            DIFFUSE,
        ),
    )
    .unwrap();
    let out = dir.join("o.png");
    let o = common::run(&[
        "-s",
        "1",
        "-r",
        "16",
        "12",
        "-f",
        out.to_str().unwrap(),
        f.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(&format!("warning: {}:", f.display())) && err.contains("has 15 numbers"),
        "{err}"
    );
    assert!(out.is_file());
    std::fs::remove_dir_all(&dir).unwrap();
}
