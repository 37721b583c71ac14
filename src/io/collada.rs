//! COLLADA 1.4.1 loader with the CS184 `<technique profile="CGL">` extensions.
//!
//! Stage one of loading: XML → [`SceneDesc`]. Every error names the file, line and column;
//! unknown elements inside a CGL technique are warnings. What is read:
//! `<up_axis>`, the `<visual_scene>` node tree (`<matrix>`, `<translate>`, `<rotate>`, `<scale>`,
//! nested `<node>`, `<instance_node>`), `<instance_geometry>` with `<bind_material>`,
//! `<instance_light>`, `<instance_camera>`; meshes from `<polylist>`, `<triangles>` and
//! `<polygons>` (fan-triangulated); CGL spheres; materials from CGL BSDFs or the common
//! profile's diffuse colour; CGL and common-profile lights; perspective cameras.
//! As in CS184, a light or effect with a CGL technique uses it in place of the common one.

use super::desc::*;
use crate::error::{Error, Loc, Result};
use crate::math::Rgb;
use glam::{Mat4, Vec3, Vec4};
use roxmltree::{Document, Node};
use std::collections::HashMap;
use std::path::Path;

/// Reads and parses a COLLADA file.
pub fn load_file(path: &Path) -> Result<SceneDesc> {
    let (file, bytes, name) = super::read_scene_file(path, "scene")?;
    match String::from_utf8(bytes) {
        Ok(text) => parse_str(&text, &file, &name),
        Err(e) => {
            // The CS184 renderer reads bytes; names in Latin-1 and the like are common.
            let at = e.utf8_error().valid_up_to();
            let text = String::from_utf8_lossy(e.as_bytes()).into_owned();
            let line = text[..at.min(text.len())].matches('\n').count() + 1;
            let mut desc = parse_str(&text, &file, &name)?;
            desc.warnings.insert(
                0,
                format!(
                    "{file}:{line}: the file is not valid UTF-8 (first bad byte at offset {at}); \
                     bad bytes were replaced, as the CS184 renderer reads bytes as they are"
                ),
            );
            Ok(desc)
        }
    }
}

/// Parses COLLADA text; `file` is used in messages and `name` becomes the scene name.
pub fn parse_str(text: &str, file: &str, name: &str) -> Result<SceneDesc> {
    let original = text;
    // A DOCTYPE is blanked out (lines kept) rather than parsed: its entities are not needed
    // and would let a small file expand into a huge one.
    let blanked;
    let text = match doctype_span(text) {
        Some((a, b)) => {
            let mut t = text.to_string();
            let blank: String = text[a..b]
                .chars()
                .map(|c| if c == '\n' { '\n' } else { ' ' })
                .collect();
            t.replace_range(a..b, &blank);
            blanked = t;
            blanked.as_str()
        }
        None => text,
    };
    let doc = Document::parse(text).map_err(|e| {
        let p = e.pos();
        Error::At {
            file: file.into(),
            loc: Loc {
                line: p.row,
                col: p.col,
            },
            msg: format!("malformed XML: {e}"),
        }
    })?;
    let mut p = Parser {
        file,
        doc: &doc,
        ids: HashMap::new(),
        desc: SceneDesc::default(),
        material_cache: HashMap::new(),
        pending_short: None,
        short_stack: Vec::new(),
        default_material: None,
        up: Mat4::IDENTITY,
    };
    p.desc.name = name.into();
    p.desc.file = file.into();
    if let Some((at, _)) = doctype_span(original) {
        // COLLADA has no DTD; the CS184 renderer's XML parser skips one.
        let line = text[..at].matches('\n').count() + 1;
        p.desc.warnings.push(format!(
            "{file}:{line}: <!DOCTYPE> is not part of COLLADA; read as the CS184 renderer \
             does (its declarations are not used)"
        ));
    }
    p.run()?;
    Ok(p.desc)
}

/// Byte range of a `<!DOCTYPE …>` declaration (with its internal subset `[…]`, if any).
fn doctype_span(text: &str) -> Option<(usize, usize)> {
    let a = text.find("<!DOCTYPE")?;
    let rest = &text[a..];
    let end = match (rest.find('['), rest.find('>')) {
        (Some(open), Some(gt)) if open < gt => {
            let close = rest[open..].find("]")? + open;
            rest[close..].find('>')? + close
        }
        (_, Some(gt)) => gt,
        _ => return None,
    };
    Some((a, a + end + 1))
}

/// Length of the longest prefix of `t` that reads as a decimal number (as C's `strtod`
/// would take it), if any.
fn numeric_prefix(t: &str) -> Option<usize> {
    let b = t.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    let digits = |i: &mut usize| {
        let s = *i;
        while *i < b.len() && b[*i].is_ascii_digit() {
            *i += 1;
        }
        *i > s
    };
    let mut any = digits(&mut i);
    if i < b.len() && b[i] == b'.' {
        i += 1;
        any |= digits(&mut i);
    }
    if !any {
        return None;
    }
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        if digits(&mut j) {
            i = j;
        }
    }
    Some(i)
}

struct Parser<'a, 'input> {
    file: &'a str,
    doc: &'a Document<'input>,
    ids: HashMap<&'a str, Node<'a, 'input>>,
    desc: SceneDesc,
    material_cache: HashMap<String, u32>,
    /// A `<matrix>` of fewer than 16 numbers read in the node being parsed.
    pending_short: Option<(Loc, usize)>,
    /// The short matrices of the nodes above the current one (innermost last).
    short_stack: Vec<(Loc, usize)>,
    default_material: Option<u32>,
    up: Mat4,
}

/// How a mesh primitive's `<p>` interleaves its inputs: the indices of one vertex, and the
/// place of the VERTEX (position) index among them.
#[derive(Clone, Copy)]
struct PrimitiveLayout {
    stride: usize,
    vertex_offset: usize,
}

impl PrimitiveLayout {
    /// The position indices of the `n` vertices of `idx` from vertex `first` on.
    fn positions(self, idx: &[u32], first: usize, n: usize) -> Vec<u32> {
        (first..first + n)
            .map(|j| idx[j * self.stride + self.vertex_offset])
            .collect()
    }
}

/// A polygon as a list of position indices, with the node that holds them.
type Polygon<'a, 'i> = (Vec<u32>, Node<'a, 'i>);

/// The triangles of a mesh being read, each with its material index.
#[derive(Default)]
struct MeshTriangles {
    triangles: Vec<[u32; 3]>,
    materials: Vec<u32>,
}

fn child<'a, 'i>(n: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    n.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

fn elements<'a, 'i>(n: Node<'a, 'i>) -> impl Iterator<Item = Node<'a, 'i>> {
    n.children().filter(|c| c.is_element())
}

fn path<'a, 'i>(n: Node<'a, 'i>, p: &str) -> Option<Node<'a, 'i>> {
    p.split('/').try_fold(n, |n, part| child(n, part))
}

/// The `<technique profile="CGL">` inside `n`'s `<extra>` elements, or else one with the
/// older profile name `CMU462` (the same schema, used by some CS184 scenes).
fn cgl_technique<'a, 'i>(n: Node<'a, 'i>) -> Option<Node<'a, 'i>> {
    let find = |profile: &str| {
        elements(n)
            .filter(|e| e.tag_name().name() == "extra")
            .flat_map(elements)
            .find(|t| t.tag_name().name() == "technique" && t.attribute("profile") == Some(profile))
    };
    find("CGL").or_else(|| find("CMU462"))
}

impl<'a, 'i> Parser<'a, 'i> {
    fn loc(&self, n: Node) -> Loc {
        let p = self.doc.text_pos_at(n.range().start);
        Loc {
            line: p.row,
            col: p.col,
        }
    }

    fn err(&self, n: Node, msg: impl Into<String>) -> Error {
        Error::At {
            file: self.file.into(),
            loc: self.loc(n),
            msg: msg.into(),
        }
    }

    fn warn(&mut self, n: Node, msg: impl AsRef<str>) {
        let w = format!("{}:{}: {}", self.file, self.loc(n), msg.as_ref());
        self.desc.warnings.push(w);
    }

    /// Resolves the `#id` in attribute `attr` of `n`.
    fn resolve(&self, n: Node<'a, 'i>, attr: &str) -> Result<Node<'a, 'i>> {
        let tag = n.tag_name().name();
        let url = n
            .attribute(attr)
            .ok_or_else(|| self.err(n, format!("<{tag}> has no '{attr}' attribute")))?;
        let id = url.strip_prefix('#').ok_or_else(|| {
            self.err(
                n,
                format!("<{tag} {attr}=\"{url}\">: only local references ('#id') are supported"),
            )
        })?;
        self.ids.get(id).copied().ok_or_else(|| {
            self.err(
                n,
                format!("<{tag} {attr}=\"{url}\">: no element with id '{id}' in this file"),
            )
        })
    }

    fn floats(&self, n: Node) -> Result<Vec<f32>> {
        let text = n.text().unwrap_or("");
        let mut out = Vec::with_capacity(text.len() / 4);
        for (i, tok) in text.split_ascii_whitespace().enumerate() {
            let v: f32 = tok.parse().map_err(|_| {
                self.err(
                    n,
                    format!(
                        "<{}>: item {} '{tok}' is not a number",
                        n.tag_name().name(),
                        i + 1
                    ),
                )
            })?;
            if !v.is_finite() {
                let what = n
                    .attribute("id")
                    .map(|id| format!(" '{id}'"))
                    .unwrap_or_default();
                return Err(self.err(
                    n,
                    format!(
                        "<{}>{what}: item {} is '{tok}', not a finite number",
                        n.tag_name().name(),
                        i + 1
                    ),
                ));
            }
            out.push(v);
        }
        Ok(out)
    }

    fn float_n(&self, n: Node, count: usize) -> Result<Vec<f32>> {
        let v = self.floats(n)?;
        if v.len() < count {
            return Err(self.err(
                n,
                format!(
                    "<{}> needs {count} number{}, found {}",
                    n.tag_name().name(),
                    if count == 1 { "" } else { "s" },
                    v.len()
                ),
            ));
        }
        Ok(v)
    }

    /// A colour: three numbers. Fewer (but at least one) are padded with 0 and warned about,
    /// as the CS184 renderer's stream extraction leaves the missing channels 0.
    fn rgb(&mut self, n: Node) -> Result<Rgb> {
        let v = self.float_n(n, 1)?;
        if v.len() < 3 {
            self.warn(
                n,
                format!(
                    "<{}> has {} number{} for a colour, not 3; the missing channels are 0, as \
                     in the CS184 renderer",
                    n.tag_name().name(),
                    v.len(),
                    if v.len() == 1 { "" } else { "s" }
                ),
            );
        }
        Ok(Vec3::new(
            v[0],
            v.get(1).copied().unwrap_or(0.0),
            v.get(2).copied().unwrap_or(0.0),
        ))
    }

    /// A single number. Text after a leading number ("50deg", "1 2") is ignored with a
    /// warning, as the CS184 renderer's `atof` does; no leading number is an error.
    fn scalar(&mut self, n: Node) -> Result<f32> {
        let text = n.text().unwrap_or("").trim();
        match self.floats(n) {
            Ok(v) if v.len() == 1 => return Ok(v[0]),
            Ok(v) if v.is_empty() => return Err(self.float_n(n, 1).unwrap_err()),
            _ => {}
        }
        let prefix = numeric_prefix(text);
        match prefix
            .and_then(|p| text[..p].parse::<f32>().ok())
            .filter(|v| v.is_finite())
        {
            Some(v) => {
                self.warn(
                    n,
                    format!(
                        "<{}> '{text}' is not a single number; read as {v}, as the CS184 \
                         renderer's atof does",
                        n.tag_name().name()
                    ),
                );
                Ok(v)
            }
            None => Err(self.float_n(n, 1).err().unwrap_or_else(|| {
                self.err(
                    n,
                    format!("<{}> '{text}' is not a number", n.tag_name().name()),
                )
            })),
        }
    }

    /// The 16 numbers of a `<matrix>`, row-major. Fewer are padded with 0 (the CS184
    /// renderer's stream extraction leaves the missing entries of its zero-initialised matrix
    /// 0) and anything after the 16th is ignored, each with a warning.
    fn matrix_numbers(&mut self, e: Node) -> Result<Vec<f32>> {
        let text = e.text().unwrap_or("");
        let tokens: Vec<&str> = text.split_ascii_whitespace().collect();
        if tokens.len() > 16 {
            self.warn(
                e,
                format!(
                    "<matrix> has {} items; only the first 16 are used, as in the CS184 renderer",
                    tokens.len()
                ),
            );
        }
        let mut v = Vec::with_capacity(16);
        for (i, tok) in tokens.iter().take(16).enumerate() {
            match tok.parse::<f32>() {
                Ok(x) if x.is_finite() => v.push(x),
                _ => {
                    return Err(self.err(
                        e,
                        format!("<matrix>: item {} '{tok}' is not a finite number", i + 1),
                    ))
                }
            }
        }
        if v.len() < 16 {
            self.warn(
                e,
                format!(
                    "<matrix> has {} numbers, not 16; the missing entries are 0, as in the \
                     CS184 renderer",
                    v.len()
                ),
            );
            self.pending_short = Some((self.loc(e), v.len()));
            v.resize(16, 0.0);
        }
        Ok(v)
    }

    fn indices(&self, n: Node) -> Result<Vec<u32>> {
        let text = n.text().unwrap_or("");
        text.split_ascii_whitespace()
            .enumerate()
            .map(|(i, tok)| {
                tok.parse::<u32>().map_err(|_| {
                    self.err(
                        n,
                        format!(
                            "<{}>: item {} '{tok}' is not a non-negative integer",
                            n.tag_name().name(),
                            i + 1
                        ),
                    )
                })
            })
            .collect()
    }

    fn run(&mut self) -> Result<()> {
        let root = self.doc.root_element();
        if root.tag_name().name() != "COLLADA" {
            return Err(self.err(
                root,
                format!(
                    "not a COLLADA file: the root element is <{}>",
                    root.tag_name().name()
                ),
            ));
        }
        for n in root.descendants().filter(|n| n.is_element()) {
            if let Some(id) = n.attribute("id") {
                self.ids.insert(id, n);
            }
        }
        if let Some(up) = path(root, "asset/up_axis") {
            let axis = up.text().unwrap_or("").trim();
            self.up = match axis {
                "Y_UP" => Mat4::IDENTITY,
                // (x, y, z) → (−x, z, y), as CS184 does.
                "Z_UP" => Mat4::from_cols(
                    Vec4::new(-1.0, 0.0, 0.0, 0.0),
                    Vec4::new(0.0, 0.0, 1.0, 0.0),
                    Vec4::new(0.0, 1.0, 0.0, 0.0),
                    Vec4::W,
                ),
                // (x, y, z) → (y, x, −z), as CS184 does.
                "X_UP" => Mat4::from_cols(
                    Vec4::new(0.0, 1.0, 0.0, 0.0),
                    Vec4::new(1.0, 0.0, 0.0, 0.0),
                    Vec4::new(0.0, 0.0, -1.0, 0.0),
                    Vec4::W,
                ),
                other => {
                    return Err(self.err(
                        up,
                        format!("<up_axis> must be X_UP, Y_UP or Z_UP, not '{other}'"),
                    ))
                }
            };
        }
        let vs = match path(root, "scene/instance_visual_scene") {
            Some(ivs) => self.resolve(ivs, "url")?,
            None => match path(root, "library_visual_scenes/visual_scene") {
                Some(v) => v,
                None => return Err(self.err(root, "no <visual_scene> in the file")),
            },
        };
        let up = self.up;
        for n in elements(vs).filter(|n| n.tag_name().name() == "node") {
            self.node(n, up, 0)?;
        }
        Ok(())
    }

    fn node(&mut self, n: Node<'a, 'i>, parent: Mat4, depth: u32) -> Result<()> {
        if depth > 64 {
            return Err(self.err(
                n,
                "node hierarchy deeper than 64 levels (a cycle of <instance_node>?)",
            ));
        }
        let mut local = Mat4::IDENTITY;
        for e in elements(n) {
            let m = match e.tag_name().name() {
                "matrix" => {
                    let v = self.matrix_numbers(e)?;
                    // Row-major in the file.
                    Mat4::from_cols_array(&[
                        v[0], v[4], v[8], v[12], v[1], v[5], v[9], v[13], v[2], v[6], v[10], v[14],
                        v[3], v[7], v[11], v[15],
                    ])
                }
                "translate" => {
                    let v = self.float_n(e, 3)?;
                    Mat4::from_translation(Vec3::new(v[0], v[1], v[2]))
                }
                "rotate" => {
                    let v = self.float_n(e, 4)?;
                    let axis = Vec3::new(v[0], v[1], v[2]);
                    if axis.length_squared() == 0.0 {
                        return Err(self.err(e, "<rotate> axis is zero"));
                    }
                    Mat4::from_axis_angle(axis.normalize(), v[3].to_radians())
                }
                "scale" => {
                    let v = self.float_n(e, 3)?;
                    Mat4::from_scale(Vec3::new(v[0], v[1], v[2]))
                }
                "lookat" | "skew" => {
                    self.warn(
                        e,
                        format!(
                            "<{}> transforms are not supported; ignored",
                            e.tag_name().name()
                        ),
                    );
                    continue;
                }
                _ => continue,
            };
            local *= m;
        }
        let world = parent * local;
        let short = self.pending_short.take();
        if let Some(sm) = short {
            self.short_stack.push(sm);
        }
        for e in elements(n) {
            match e.tag_name().name() {
                "node" => self.node(e, world, depth + 1)?,
                "instance_node" => {
                    let target = self.resolve(e, "url")?;
                    self.node(target, world, depth + 1)?;
                }
                "instance_geometry" => self.instance_geometry(e, world)?,
                "instance_light" => self.instance_light(e, world)?,
                "instance_camera" => self.instance_camera(e, world)?,
                _ => {}
            }
        }
        if short.is_some() {
            self.short_stack.pop();
        }
        Ok(())
    }

    fn instance_camera(&mut self, inst: Node<'a, 'i>, world: Mat4) -> Result<()> {
        let cam = self.resolve(inst, "url")?;
        if self.desc.camera.is_some() {
            self.warn(inst, "more than one camera; the first one is used");
            return Ok(());
        }
        let name = cam
            .attribute("name")
            .or(cam.attribute("id"))
            .unwrap_or("camera")
            .to_string();
        let Some(persp) = path(cam, "optics/technique_common/perspective") else {
            return Err(self.err(
                cam,
                format!("camera '{name}' has no <optics>/<technique_common>/<perspective>"),
            ));
        };
        let mut get = |tag: &str| -> Result<Option<f32>> {
            child(persp, tag).map(|e| self.scalar(e)).transpose()
        };
        let desc = CameraDesc {
            exact: false,
            fov_axis: crate::io::desc::FovAxis::Height,
            right_is_x: false,
            lens: None,
            orthographic: false,
            name,
            xfov_deg: get("xfov")?,
            yfov_deg: get("yfov")?,
            aspect: get("aspect_ratio")?,
            znear: get("znear")?.unwrap_or(0.001),
            zfar: get("zfar")?.unwrap_or(1000.0),
            transform: world,
            loc: self.loc(inst),
        };
        for (v, what) in [(desc.xfov_deg, "xfov"), (desc.yfov_deg, "yfov")] {
            if let Some(f) = v {
                if !(f > 0.0 && f < 180.0) {
                    return Err(self.err(
                        persp,
                        format!("<{what}> must be between 0 and 180 degrees, not {f}"),
                    ));
                }
            }
        }
        if let Some(a) = desc.aspect {
            if a <= 0.0 {
                return Err(self.err(persp, format!("<aspect_ratio> must be positive, not {a}")));
            }
        }
        self.desc.camera = Some(desc);
        Ok(())
    }

    fn instance_light(&mut self, inst: Node<'a, 'i>, world: Mat4) -> Result<()> {
        let light = self.resolve(inst, "url")?;
        let name = light
            .attribute("name")
            .or(light.attribute("id"))
            .unwrap_or("light")
            .to_string();
        let cgl = cgl_technique(light);
        let technique = cgl.or_else(|| child(light, "technique_common"));
        let Some(technique) = technique else {
            self.warn(
                light,
                format!(
                    "light '{name}' has neither a CGL technique nor <technique_common>; ignored"
                ),
            );
            return Ok(());
        };
        let mut kind = None;
        for e in elements(technique) {
            let tag = e.tag_name().name();
            if kind.is_some() {
                if cgl.is_some() {
                    self.warn(
                        e,
                        format!(
                            "extra element <{tag}> in the CGL technique of light '{name}'; ignored"
                        ),
                    );
                }
                continue;
            }
            let color = |p: &mut Self| -> Result<Rgb> {
                let c = child(e, "color")
                    .ok_or_else(|| p.err(e, format!("<{tag}> light '{name}' has no <color>")))?;
                p.rgb(c)
            };
            kind = match tag {
                "area" => Some(LightKind::Area {
                    radiance: color(self)?,
                }),
                "point" => Some(LightKind::Point {
                    intensity: color(self)?,
                }),
                "directional" => Some(LightKind::Directional {
                    irradiance: color(self)?,
                }),
                "ambient" => Some(LightKind::Ambient {
                    radiance: color(self)?,
                }),
                "spot" => {
                    let angle = child(e, "falloff_angle")
                        .map(|x| self.scalar(x))
                        .transpose()?
                        .unwrap_or(180.0);
                    let exp = child(e, "falloff_exponent")
                        .map(|x| self.scalar(x))
                        .transpose()?
                        .unwrap_or(0.0);
                    Some(LightKind::Spot {
                        intensity: color(self)?,
                        falloff_angle_deg: angle,
                        falloff_exponent: exp,
                        falloff_start_deg: None,
                        linear_falloff: false,
                    })
                }
                other => {
                    self.warn(
                        e,
                        format!("unknown light type <{other}> in light '{name}'; ignored"),
                    );
                    None
                }
            };
            if let Some(k) = &kind {
                if cgl.is_some() {
                    let known: &[&str] = match k {
                        LightKind::Spot { .. } => &[
                            "color",
                            "falloff_angle",
                            "falloff_exponent",
                            "constant_attenuation",
                            "linear_attenuation",
                            "quadratic_attenuation",
                        ],
                        LightKind::Point { .. } => &[
                            "color",
                            "constant_attenuation",
                            "linear_attenuation",
                            "quadratic_attenuation",
                        ],
                        _ => &["color"],
                    };
                    self.check_known(e, known, "CGL light");
                }
            }
        }
        if let Some(kind) = kind {
            self.desc.lights.push(LightDesc {
                name,
                kind,
                transform: world,
                loc: self.loc(inst),
            });
        }
        Ok(())
    }

    /// Warns about children of `e` whose names are not in `known`.
    fn check_known(&mut self, e: Node, known: &[&str], what: &str) {
        for c in elements(e) {
            let tag = c.tag_name().name();
            if !known.contains(&tag) {
                self.warn(
                    c,
                    format!(
                        "unknown element <{tag}> in {what} <{}>; ignored",
                        e.tag_name().name()
                    ),
                );
            }
        }
    }

    fn instance_geometry(&mut self, inst: Node<'a, 'i>, world: Mat4) -> Result<()> {
        let geom = self.resolve(inst, "url")?;
        if let Some(&(loc, n)) = self.short_stack.last() {
            if world.row(3) == Vec4::ZERO {
                // The CS184 renderer divides vertex positions by this row's w = 0: garbage.
                return Err(Error::At {
                    file: self.file.into(),
                    loc,
                    msg: format!(
                        "<matrix> has {n} numbers, not 16, and the zero entries leave the bottom \
                         row 0 0 0 0: geometry placed with it would be degenerate (the CS184 \
                         renderer divides its points by w = 0); write all 16 numbers"
                    ),
                });
            }
        }
        let name = geom
            .attribute("name")
            .or(geom.attribute("id"))
            .unwrap_or("geometry")
            .to_string();
        // Material bindings: symbol → material element.
        let mut bindings: Vec<(&str, Node<'a, 'i>)> = Vec::new();
        if let Some(tc) = path(inst, "bind_material/technique_common") {
            for im in elements(tc).filter(|e| e.tag_name().name() == "instance_material") {
                let target = self.resolve(im, "target")?;
                bindings.push((im.attribute("symbol").unwrap_or(""), target));
            }
        }
        let loc = self.loc(inst);
        if let Some(mesh) = child(geom, "mesh") {
            return self.mesh(mesh, &name, &bindings, world, loc);
        }
        if let Some(t) = cgl_technique(geom) {
            let mut radius = None;
            for e in elements(t) {
                if e.tag_name().name() == "sphere" {
                    let r = child(e, "radius").ok_or_else(|| {
                        self.err(e, format!("<sphere> in geometry '{name}' has no <radius>"))
                    })?;
                    let r = self.scalar(r)?;
                    if r <= 0.0 {
                        return Err(self.err(
                            e,
                            format!("sphere '{name}' has radius {r}; it must be positive"),
                        ));
                    }
                    self.check_known(e, &["radius"], "CGL geometry");
                    radius = Some(r);
                } else {
                    self.warn(e, format!("unknown element <{}> in the CGL technique of geometry '{name}'; ignored", e.tag_name().name()));
                }
            }
            if let Some(radius) = radius {
                let material = match bindings.first() {
                    Some(&(_, m)) => self.material(m)?,
                    None => self.default_material(),
                };
                self.desc.shapes.push(ShapeDesc::Sphere {
                    name,
                    radius,
                    material,
                    transform: world,
                    side: crate::io::desc::EmitSide::Both,
                    loc,
                });
                return Ok(());
            }
        }
        self.warn(
            geom,
            format!("geometry '{name}' has neither a <mesh> nor a CGL <sphere>; ignored"),
        );
        Ok(())
    }

    fn default_material(&mut self) -> u32 {
        if let Some(m) = self.default_material {
            return m;
        }
        let id = self.desc.materials.len() as u32;
        self.desc.materials.push(MaterialDesc {
            name: "default".into(),
            kind: MaterialKind::Diffuse {
                albedo: Vec3::splat(0.5),
            },
            emission: Vec3::ZERO,
            loc: Loc::default(),
            one_sided: false,
            interface: None,
        });
        self.default_material = Some(id);
        id
    }

    /// Reads the vectors of a `<source>` through its accessor (or `stride` floats at a time).
    fn source_vectors(&mut self, src: Node, dims: usize) -> Result<Vec<Vec3>> {
        let arr = if src.tag_name().name() == "float_array" {
            src
        } else {
            child(src, "float_array")
                .ok_or_else(|| self.err(src, "<source> has no <float_array>"))?
        };
        let floats = self.floats(arr)?;
        let accessor = path(src, "technique_common/accessor");
        let stride = accessor
            .and_then(|a| a.attribute("stride"))
            .map(|s| {
                s.parse::<usize>()
                    .map_err(|_| self.err(src, format!("accessor stride '{s}' is not a number")))
            })
            .transpose()?
            .unwrap_or(dims);
        let offset = accessor
            .and_then(|a| a.attribute("offset"))
            .and_then(|s| s.parse::<usize>().ok())
            .unwrap_or(0);
        if stride < dims {
            return Err(self.err(
                src,
                format!("accessor stride {stride} is smaller than {dims}"),
            ));
        }
        let count = accessor
            .and_then(|a| a.attribute("count"))
            .and_then(|s| s.parse::<usize>().ok())
            .unwrap_or((floats.len().saturating_sub(offset)) / stride);
        // (Saturating: absurd counts and offsets from the file read as "too short".)
        let needed = count
            .saturating_sub(1)
            .saturating_mul(stride)
            .saturating_add(offset)
            .saturating_add(dims);
        let count = if count > 0 && floats.len() < needed {
            // The CS184 renderer ignores the accessor and reads the array itself: use what
            // the array holds (indices beyond it are still an error).
            let have = (floats.len().saturating_sub(offset) + stride - dims) / stride;
            self.warn(
                arr,
                format!(
                    "<float_array> has {} numbers, its accessor asks for {count} vectors \
                     ({needed} numbers); the {have} whole vectors it holds are used, as in the \
                     CS184 renderer",
                    floats.len()
                ),
            );
            have
        } else {
            count
        };
        Ok((0..count)
            .map(|i| Vec3::from_slice(&floats[offset + i * stride..offset + i * stride + dims]))
            .collect())
    }

    fn mesh(
        &mut self,
        mesh: Node<'a, 'i>,
        name: &str,
        bindings: &[(&str, Node<'a, 'i>)],
        world: Mat4,
        loc: Loc,
    ) -> Result<()> {
        let (vertices, positions) = self.mesh_positions(mesh, name)?;
        let vertices_id = vertices.attribute("id").unwrap_or("");
        let mut triangles = MeshTriangles::default();
        for prim in elements(mesh) {
            let tag = prim.tag_name().name();
            if !matches!(tag, "polylist" | "triangles" | "polygons") {
                if matches!(tag, "lines" | "linestrips" | "trifans" | "tristrips") {
                    self.warn(
                        prim,
                        format!("<{tag}> primitives are not supported; ignored"),
                    );
                }
                continue;
            }
            let layout = self.primitive_layout(prim, tag, vertices_id)?;
            let material = self.primitive_material(prim, bindings)?;
            let count: usize = prim
                .attribute("count")
                .unwrap_or("0")
                .parse()
                .map_err(|_| self.err(prim, format!("<{tag}> count is not a number")))?;
            let polys = match tag {
                "polylist" => self.polylist_polygons(prim, count, layout)?,
                "triangles" => self.triangles_polygons(prim, count, layout)?,
                _ => self.p_element_polygons(prim, layout)?,
            };
            self.fan_triangulate(polys, name, positions.len(), material, &mut triangles)?;
        }
        self.desc.shapes.push(ShapeDesc::Mesh {
            normals: crate::io::desc::MeshNormals::Smooth,
            uvs: Vec::new(),
            one_sided: false,
            name: name.into(),
            positions,
            triangles: triangles.triangles,
            materials: triangles.materials,
            transform: world,
            loc,
        });
        Ok(())
    }

    /// The `<vertices>` element of mesh `name` and the positions its POSITION input reads.
    fn mesh_positions(
        &mut self,
        mesh: Node<'a, 'i>,
        name: &str,
    ) -> Result<(Node<'a, 'i>, Vec<Vec3>)> {
        let vertices = child(mesh, "vertices")
            .ok_or_else(|| self.err(mesh, format!("mesh '{name}' has no <vertices>")))?;
        let pos_input = elements(vertices)
            .find(|i| i.tag_name().name() == "input" && i.attribute("semantic") == Some("POSITION"))
            .ok_or_else(|| {
                self.err(
                    vertices,
                    format!("<vertices> of mesh '{name}' has no POSITION input"),
                )
            })?;
        let src = self.resolve(pos_input, "source")?;
        let positions = self.source_vectors(src, 3)?;
        Ok((vertices, positions))
    }

    /// The index stride and VERTEX offset of primitive `prim` (a `<tag>`) from its `<input>`s,
    /// whose VERTEX input must refer to the `<vertices>` with id `vertices_id`.
    fn primitive_layout(
        &self,
        prim: Node<'a, 'i>,
        tag: &str,
        vertices_id: &str,
    ) -> Result<PrimitiveLayout> {
        let mut stride = 0;
        let mut vertex_offset = None;
        for input in elements(prim).filter(|i| i.tag_name().name() == "input") {
            let off: usize = input
                .attribute("offset")
                .unwrap_or("0")
                .parse()
                .map_err(|_| self.err(input, "<input> offset is not a number"))?;
            stride = stride.max(off + 1);
            if input.attribute("semantic") == Some("VERTEX") {
                let target = self.resolve(input, "source")?;
                if target.attribute("id") != Some(vertices_id) {
                    return Err(self.err(input, "VERTEX input must refer to the mesh's <vertices>"));
                }
                vertex_offset = Some(off);
            }
        }
        let Some(vertex_offset) = vertex_offset else {
            return Err(self.err(prim, format!("<{tag}> has no VERTEX input")));
        };
        Ok(PrimitiveLayout {
            stride,
            vertex_offset,
        })
    }

    /// The material index of primitive `prim`: the binding of its material symbol, else the
    /// first binding, else the default material.
    fn primitive_material(
        &mut self,
        prim: Node<'a, 'i>,
        bindings: &[(&str, Node<'a, 'i>)],
    ) -> Result<u32> {
        let symbol = prim.attribute("material");
        let bound = bindings
            .iter()
            .find(|(s, _)| Some(*s) == symbol)
            .or(bindings.first())
            .map(|&(_, m)| m);
        match bound {
            Some(m) => self.material(m),
            None => Ok(self.default_material()),
        }
    }

    /// The first `count` polygons of a `<polylist>`, sized by its `<vcount>`, indexed by its `<p>`.
    fn polylist_polygons(
        &self,
        prim: Node<'a, 'i>,
        count: usize,
        layout: PrimitiveLayout,
    ) -> Result<Vec<Polygon<'a, 'i>>> {
        let stride = layout.stride;
        let vc =
            child(prim, "vcount").ok_or_else(|| self.err(prim, "<polylist> has no <vcount>"))?;
        let sizes = self.indices(vc)?;
        if sizes.len() < count {
            return Err(self.err(
                vc,
                format!(
                    "<vcount> lists {} polygons, <polylist count> says {count}",
                    sizes.len()
                ),
            ));
        }
        let p = child(prim, "p").ok_or_else(|| self.err(prim, "<polylist> has no <p>"))?;
        let idx = self.indices(p)?;
        let total: usize = sizes[..count].iter().map(|&s| s as usize).sum::<usize>() * stride;
        if idx.len() < total {
            return Err(self.err(
                p,
                format!("<p> has {} indices, the polygons need {total}", idx.len()),
            ));
        }
        let mut polys = Vec::new();
        let mut k = 0;
        for &s in &sizes[..count] {
            polys.push((layout.positions(&idx, k, s as usize), p));
            k += s as usize;
        }
        Ok(polys)
    }

    /// The first `count` triangles of a `<triangles>` primitive, indexed by its `<p>`.
    fn triangles_polygons(
        &self,
        prim: Node<'a, 'i>,
        count: usize,
        layout: PrimitiveLayout,
    ) -> Result<Vec<Polygon<'a, 'i>>> {
        let stride = layout.stride;
        let p = child(prim, "p").ok_or_else(|| self.err(prim, "<triangles> has no <p>"))?;
        let idx = self.indices(p)?;
        if idx.len() < count * 3 * stride {
            return Err(self.err(
                p,
                format!(
                    "<p> has {} indices, {count} triangles need {}",
                    idx.len(),
                    count * 3 * stride
                ),
            ));
        }
        Ok((0..count)
            .map(|t| (layout.positions(&idx, t * 3, 3), p))
            .collect())
    }

    /// The polygons of a `<polygons>` primitive, one per `<p>`; `<ph>` polygons with holes
    /// are warned about and skipped.
    fn p_element_polygons(
        &mut self,
        prim: Node<'a, 'i>,
        layout: PrimitiveLayout,
    ) -> Result<Vec<Polygon<'a, 'i>>> {
        let mut polys = Vec::new();
        for p in elements(prim) {
            match p.tag_name().name() {
                "p" => {
                    let idx = self.indices(p)?;
                    polys.push((layout.positions(&idx, 0, idx.len() / layout.stride), p));
                }
                "ph" => self.warn(
                    p,
                    "<ph> polygons with holes are not supported; the polygon is ignored",
                ),
                _ => {}
            }
        }
        Ok(polys)
    }

    /// Fan-triangulates `polys` of mesh `name` into `out`, each triangle with `material`;
    /// an error when an index is not below `position_count`.
    fn fan_triangulate(
        &self,
        polys: Vec<Polygon<'a, 'i>>,
        name: &str,
        position_count: usize,
        material: u32,
        out: &mut MeshTriangles,
    ) -> Result<()> {
        for (poly, pnode) in polys {
            if let Some(&bad) = poly.iter().find(|&&i| i as usize >= position_count) {
                return Err(self.err(pnode, format!("mesh '{name}': vertex index {bad} is out of range (the mesh has {position_count} positions)")));
            }
            if poly.len() < 3 {
                continue;
            }
            for j in 1..poly.len() - 1 {
                out.triangles.push([poly[0], poly[j], poly[j + 1]]);
                out.materials.push(material);
            }
        }
        Ok(())
    }

    fn material(&mut self, mat: Node<'a, 'i>) -> Result<u32> {
        let id = mat.attribute("id").unwrap_or("").to_string();
        if let Some(&m) = self.material_cache.get(&id) {
            return Ok(m);
        }
        let name = mat.attribute("name").unwrap_or(&id).to_string();
        let ie = child(mat, "instance_effect")
            .ok_or_else(|| self.err(mat, format!("material '{name}' has no <instance_effect>")))?;
        if ie.attribute("url").is_none() {
            // The CS184 renderer gives such a material its default: diffuse 0.5.
            self.warn(
                ie,
                format!("material '{name}': <instance_effect> has no url; diffuse 0.5 is used, as in the CS184 renderer"),
            );
            let kind = MaterialKind::Diffuse {
                albedo: Vec3::splat(0.5),
            };
            return Ok(self.push_material(mat, id, name, kind, Vec3::ZERO));
        }
        let effect = self.resolve(ie, "url")?;
        // Common profile: diffuse colour and (non-standard for CS184) emission colour.
        let (mut kind, mut emission) = self.common_profile_material(effect, &name)?;
        if let Some(t) = cgl_technique(effect) {
            for e in elements(t) {
                if let Some(k) = self.cgl_material_element(e, &name, &mut emission)? {
                    kind = Some(k);
                }
            }
        }
        let kind = kind.unwrap_or(MaterialKind::Diffuse {
            albedo: Vec3::splat(0.5),
        });
        if let MaterialKind::Diffuse { albedo } = &kind {
            if albedo.max_element() > 1.0 || albedo.min_element() < 0.0 {
                self.warn(
                    mat,
                    format!("material '{name}': diffuse albedo {albedo} outside [0, 1] is clamped"),
                );
            }
        }
        Ok(self.push_material(mat, id, name, kind, emission))
    }

    /// Adds material `name` read from `mat` to the scene, caches its index under `id` and
    /// returns it.
    fn push_material(
        &mut self,
        mat: Node,
        id: String,
        name: String,
        kind: MaterialKind,
        emission: Vec3,
    ) -> u32 {
        let idx = self.desc.materials.len() as u32;
        self.desc.materials.push(MaterialDesc {
            name,
            kind,
            emission,
            loc: self.loc(mat),
            one_sided: false,
            interface: None,
        });
        self.material_cache.insert(id, idx);
        idx
    }

    /// The diffuse colour (if any) and emission colour (zero without one) of the
    /// `profile_COMMON` technique of `effect`, for material `name`.
    fn common_profile_material(
        &mut self,
        effect: Node<'a, 'i>,
        name: &str,
    ) -> Result<(Option<MaterialKind>, Vec3)> {
        let mut kind = None;
        let mut emission = Vec3::ZERO;
        if let Some(tech) = path(effect, "profile_COMMON/technique") {
            if let Some(shading) = elements(tech).find(|e| {
                matches!(
                    e.tag_name().name(),
                    "phong" | "lambert" | "blinn" | "constant"
                )
            }) {
                if let Some(d) = child(shading, "diffuse") {
                    if let Some(c) = child(d, "color") {
                        kind = Some(MaterialKind::Diffuse {
                            albedo: self.rgb(c)?,
                        });
                    } else if child(d, "texture").is_some() {
                        self.warn(d, format!("material '{name}': textures are not supported; diffuse 0.5 is used"));
                    }
                }
                if let Some(c) = path(shading, "emission/color") {
                    emission = self.rgb(c)?;
                }
            }
        }
        Ok((kind, emission))
    }

    /// The child `<param>` of CGL material element `e` in material `name`; an error without it.
    fn cgl_param(&self, e: Node<'a, 'i>, name: &str, param: &str) -> Result<Node<'a, 'i>> {
        let tag = e.tag_name().name();
        child(e, param)
            .ok_or_else(|| self.err(e, format!("<{tag}> in material '{name}' has no <{param}>")))
    }

    /// The material kind of element `e` of the CGL technique of material `name` (`None`, with a
    /// warning, for an unknown element); an `<emission>` sets `emission`.
    fn cgl_material_element(
        &mut self,
        e: Node<'a, 'i>,
        name: &str,
        emission: &mut Vec3,
    ) -> Result<Option<MaterialKind>> {
        let param = |p: &Self, n: &str| p.cgl_param(e, name, n);
        let k = match e.tag_name().name() {
            "emission" => {
                *emission = self.rgb(param(self, "radiance")?)?;
                self.check_known(e, &["radiance"], "CGL material");
                MaterialKind::Emission
            }
            "mirror" => {
                self.check_known(e, &["reflectance"], "CGL material");
                MaterialKind::Mirror {
                    reflectance: self.rgb(param(self, "reflectance")?)?,
                }
            }
            "glass" => {
                self.check_known(
                    e,
                    &["reflectance", "transmittance", "roughness", "ior"],
                    "CGL material",
                );
                MaterialKind::Glass {
                    reflectance: self.rgb(param(self, "reflectance")?)?,
                    transmittance: self.rgb(param(self, "transmittance")?)?,
                    roughness: child(e, "roughness")
                        .map(|r| self.scalar(r))
                        .transpose()?
                        .unwrap_or(0.0),
                    ior: self.ior(param(self, "ior")?)?,
                }
            }
            "refraction" => {
                self.check_known(e, &["transmittance", "roughness", "ior"], "CGL material");
                MaterialKind::Refraction {
                    transmittance: self.rgb(param(self, "transmittance")?)?,
                    roughness: child(e, "roughness")
                        .map(|r| self.scalar(r))
                        .transpose()?
                        .unwrap_or(0.0),
                    ior: self.ior(param(self, "ior")?)?,
                }
            }
            "microfacet" => {
                self.check_known(e, &["alpha", "eta", "k"], "CGL material");
                let an = param(self, "alpha")?;
                let alpha = self.scalar(an)?;
                if alpha <= 0.0 {
                    return Err(self.err(an, format!("<alpha> must be positive, not {alpha}")));
                }
                MaterialKind::Microfacet {
                    alpha,
                    eta: self.rgb(param(self, "eta")?)?,
                    k: self.rgb(param(self, "k")?)?,
                }
            }
            "diffuse" => {
                let r = child(e, "reflectance").or_else(|| child(e, "albedo"));
                let albedo = match r {
                    Some(r) => self.rgb(r)?,
                    None => Vec3::splat(0.5),
                };
                MaterialKind::Diffuse { albedo }
            }
            other => {
                self.warn(e, format!("unknown element <{other}> in the CGL technique of material '{name}'; ignored"));
                return Ok(None);
            }
        };
        Ok(Some(k))
    }

    fn ior(&mut self, n: Node) -> Result<f32> {
        let v = self.scalar(n)?;
        if v <= 0.0 {
            return Err(self.err(n, format!("<ior> must be positive, not {v}")));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wrap(body: &str, nodes: &str) -> String {
        format!(
            r##"<?xml version="1.0"?>
<COLLADA version="1.4.1"><asset><up_axis>Y_UP</up_axis></asset>
{body}
<library_visual_scenes><visual_scene id="S">{nodes}</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#S"/></scene></COLLADA>"##
        )
    }

    const SQUARE: &str = r##"<source id="pos"><float_array id="pa" count="12">0 0 0 1 0 0 1 1 0 0 1 0</float_array>
        <technique_common><accessor source="#pa" count="4" stride="3"/></technique_common></source>
        <vertices id="v"><input semantic="POSITION" source="#pos"/></vertices>"##;

    #[test]
    fn triangles_and_polygons_are_fan_triangulated() {
        let body = format!(
            r##"<library_geometries>
            <geometry id="t"><mesh>{SQUARE}<triangles count="2"><input semantic="VERTEX" source="#v" offset="0"/><input semantic="NORMAL" source="#v" offset="1"/><p>0 9 1 9 2 9 0 9 2 9 3 9</p></triangles></mesh></geometry>
            <geometry id="p"><mesh>{SQUARE}<polygons count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2 3</p></polygons></mesh></geometry>
            </library_geometries>"##
        );
        let d = parse_str(&wrap(&body, r##"<node><instance_geometry url="#t"/></node><node><instance_geometry url="#p"/></node>"##), "t.dae", "t").unwrap();
        for s in &d.shapes {
            let ShapeDesc::Mesh {
                triangles,
                positions,
                ..
            } = s
            else {
                panic!()
            };
            assert_eq!(positions.len(), 4);
            assert_eq!(triangles, &vec![[0, 1, 2], [0, 2, 3]]);
        }
        assert_eq!(d.shapes.len(), 2);
        assert_eq!(
            d.materials[0].kind,
            MaterialKind::Diffuse {
                albedo: Vec3::splat(0.5)
            },
            "unbound meshes get the default diffuse 0.5"
        );
    }

    #[test]
    fn transforms_compose_in_order_with_up_axis() {
        let nodes = r##"<node><translate>1 2 3</translate><rotate>0 0 1 90</rotate><scale>2 2 2</scale>
            <node><matrix>1 0 0 5  0 1 0 0  0 0 1 0  0 0 0 1</matrix><instance_geometry url="#g"/></node></node>"##;
        let body = r##"<library_geometries><geometry id="g"><extra><technique profile="CGL"><sphere><radius>1</radius></sphere></technique></extra></geometry></library_geometries>"##;
        let text = wrap(body, nodes).replace("Y_UP", "Z_UP");
        let d = parse_str(&text, "t.dae", "t").unwrap();
        let ShapeDesc::Sphere {
            transform, radius, ..
        } = &d.shapes[0]
        else {
            panic!()
        };
        assert_eq!(*radius, 1.0);
        // Object origin: matrix → (5,0,0); scale → (10,0,0); rotate 90° about z → (0,10,0);
        // translate → (1,12,3); Z_UP (x,y,z) → (−x,z,y) → (−1,3,12).
        let p = transform.transform_point3(Vec3::ZERO);
        assert!((p - Vec3::new(-1.0, 3.0, 12.0)).length() < 1e-4, "{p}");
    }

    #[test]
    fn cgl_materials_keep_all_parameters() {
        let fx = |id: &str, cgl: &str| {
            format!(
                r##"<effect id="{id}"><profile_COMMON><technique sid="common"><phong><diffuse><color>0.1 0.2 0.3 1</color></diffuse></phong></technique></profile_COMMON><extra><technique profile="CGL">{cgl}</technique></extra></effect>"##
            )
        };
        let effects = [
            fx("e1", "<glass><reflectance>1 0.9 0.8</reflectance><transmittance>0.7 0.6 0.5</transmittance><roughness>0.1</roughness><ior>1.45</ior></glass>"),
            fx("e2", "<microfacet><alpha>0.25</alpha><eta>0.059 0.06 0.047</eta><k>4.1 3.6 2.8</k></microfacet>"),
            fx("e3", "<refraction><transmittance>1 1 1</transmittance><roughness>0</roughness><ior>1.5</ior></refraction>"),
            fx("e4", "<emission><radiance>10 9 8</radiance></emission>"),
            fx("e5", "<mirror><reflectance>0.9 0.9 0.9</reflectance></mirror>"),
            fx("e6", ""),
        ];
        let mats: String = (1..=6)
            .map(|i| format!(r##"<material id="m{i}"><instance_effect url="#e{i}"/></material>"##))
            .collect();
        let nodes: String = (1..=6)
            .map(|i| format!(r##"<node><instance_geometry url="#g"><bind_material><technique_common><instance_material symbol="x" target="#m{i}"/></technique_common></bind_material></instance_geometry></node>"##))
            .collect();
        let body = format!(
            r##"<library_effects>{}</library_effects><library_materials>{mats}</library_materials>
            <library_geometries><geometry id="g"><extra><technique profile="CGL"><sphere><radius>1</radius></sphere></technique></extra></geometry></library_geometries>"##,
            effects.join("")
        );
        let d = parse_str(&wrap(&body, &nodes), "t.dae", "t").unwrap();
        let k: Vec<&MaterialKind> = d.materials.iter().map(|m| &m.kind).collect();
        assert_eq!(
            *k[0],
            MaterialKind::Glass {
                reflectance: Vec3::new(1.0, 0.9, 0.8),
                transmittance: Vec3::new(0.7, 0.6, 0.5),
                roughness: 0.1,
                ior: 1.45
            }
        );
        assert_eq!(
            *k[1],
            MaterialKind::Microfacet {
                alpha: 0.25,
                eta: Vec3::new(0.059, 0.06, 0.047),
                k: Vec3::new(4.1, 3.6, 2.8)
            }
        );
        assert_eq!(
            *k[2],
            MaterialKind::Refraction {
                transmittance: Vec3::ONE,
                roughness: 0.0,
                ior: 1.5
            }
        );
        assert_eq!(*k[3], MaterialKind::Emission);
        assert_eq!(d.materials[3].emission, Vec3::new(10.0, 9.0, 8.0));
        assert_eq!(
            *k[4],
            MaterialKind::Mirror {
                reflectance: Vec3::splat(0.9)
            }
        );
        assert_eq!(
            *k[5],
            MaterialKind::Diffuse {
                albedo: Vec3::new(0.1, 0.2, 0.3)
            },
            "empty CGL technique: the common diffuse colour"
        );
    }

    #[test]
    fn every_light_type_and_cgl_precedence() {
        let light = |id: &str, common: &str, cgl: &str| {
            let extra = if cgl.is_empty() {
                String::new()
            } else {
                format!(r#"<extra><technique profile="CGL">{cgl}</technique></extra>"#)
            };
            format!(
                r#"<light id="{id}"><technique_common>{common}</technique_common>{extra}</light>"#
            )
        };
        let lights = [
            light("a", "<point><color>1 1 1</color></point>", "<area><color>10 10 10</color></area>"),
            light("p", "<point><color>2 2 2</color><constant_attenuation>1</constant_attenuation></point>", ""),
            light("d", "<directional><color>3 3 3</color></directional>", ""),
            light("s", "<spot><color>4 4 4</color><falloff_angle>30</falloff_angle><falloff_exponent>2</falloff_exponent></spot>", ""),
            light("h", "<ambient><color>0.5 0.5 0.5</color></ambient>", ""),
        ];
        let nodes: String = ["a", "p", "d", "s", "h"]
            .iter()
            .map(|id| format!(r##"<node><instance_light url="#{id}"/></node>"##))
            .collect();
        let d = parse_str(
            &wrap(
                &format!("<library_lights>{}</library_lights>", lights.join("")),
                &nodes,
            ),
            "t.dae",
            "t",
        )
        .unwrap();
        let k: Vec<&LightKind> = d.lights.iter().map(|l| &l.kind).collect();
        assert_eq!(
            *k[0],
            LightKind::Area {
                radiance: Vec3::splat(10.0)
            },
            "CGL technique wins over technique_common"
        );
        assert_eq!(
            *k[1],
            LightKind::Point {
                intensity: Vec3::splat(2.0)
            }
        );
        assert_eq!(
            *k[2],
            LightKind::Directional {
                irradiance: Vec3::splat(3.0)
            }
        );
        assert_eq!(
            *k[3],
            LightKind::Spot {
                intensity: Vec3::splat(4.0),
                falloff_angle_deg: 30.0,
                falloff_exponent: 2.0,
                falloff_start_deg: None,
                linear_falloff: false,
            }
        );
        assert_eq!(
            *k[4],
            LightKind::Ambient {
                radiance: Vec3::splat(0.5)
            }
        );
    }

    #[test]
    fn bad_up_axis_and_missing_scene_are_errors() {
        let e = parse_str(&wrap("", "").replace("Y_UP", "W_UP"), "f.dae", "f")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("f.dae:2:")
                && e.contains("<up_axis> must be X_UP, Y_UP or Z_UP, not 'W_UP'"),
            "{e}"
        );
        let e = parse_str("<COLLADA/>", "g.dae", "g")
            .unwrap_err()
            .to_string();
        assert!(e.contains("g.dae:1:1: no <visual_scene>"), "{e}");
        let e = parse_str("<svg/>", "h.dae", "h").unwrap_err().to_string();
        assert!(e.contains("not a COLLADA file"), "{e}");
    }
}
