//! Stanford PLY meshes (ASCII, binary little- and big-endian), into a [`SceneDesc`].
//!
//! Read: the `vertex` element's `x y z` (and `nx ny nz` when present, which then shade the
//! mesh; otherwise it is shaded flat; texture coordinates `u v`, `s t`, `texture_u texture_v`
//! or `texture_s texture_t` when present, v up as in OBJ and flipped to the description's
//! top-down convention), the `face` element's vertex index list (`vertex_indices`
//! or `vertex_index`; faces of any size, fan-triangulated), and the `tristrips` element's
//! (triangle strips, as scanned models store them: `-1` ends a strip, the winding alternates
//! along it, and triangles that repeat a vertex, which join strips, are dropped). Every other
//! element and property is skipped by its declared type. The mesh gets one grey (0.5) diffuse material.
//!
//! Errors name the file and the header line, or the element and item for data (`vertex 17`,
//! `face 3`): a malformed header, an unknown type, data cut short, a non-finite coordinate,
//! an index out of range, a face with fewer than three vertices.

use crate::error::{Error, Loc, Result};
use crate::io::desc::{MaterialDesc, MaterialKind, MeshNormals, SceneDesc, ShapeDesc};
use glam::{Mat4, Vec3};
use std::path::Path;

/// Most bytes a gzip-compressed PLY file may expand to.
pub const MAX_GZ_BYTES: u64 = 1 << 32;

/// Loads a PLY file; one whose name ends in `.gz` is gunzipped first (as pbrt-v4's
/// `plymesh` files often are), to at most [`MAX_GZ_BYTES`].
pub fn load_file(path: &Path) -> Result<SceneDesc> {
    let (file, bytes, name) = super::read_scene_file(path, "mesh")?;
    let gz = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gz"));
    if !gz {
        return parse(&bytes, &file, &name);
    }
    let bytes = gunzip(&bytes, &file)?;
    let name = name.strip_suffix(".ply").unwrap_or(&name).to_string();
    parse(&bytes, &file, &name)
}

/// The bytes of gzip data, refused when corrupt or larger than [`MAX_GZ_BYTES`].
fn gunzip(bytes: &[u8], file: &str) -> Result<Vec<u8>> {
    use std::io::Read;
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(bytes)
        .take(MAX_GZ_BYTES + 1)
        .read_to_end(&mut out)
        .map_err(|e| Error::File {
            file: file.to_string(),
            msg: format!("not valid gzip data: {e}"),
        })?;
    if out.len() as u64 > MAX_GZ_BYTES {
        return Err(Error::File {
            file: file.to_string(),
            msg: format!("expands to more than {MAX_GZ_BYTES} bytes"),
        });
    }
    Ok(out)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn of(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for a list.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Reads values of one element item after another, in any of the three formats.
struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    format: Format,
    /// ASCII: the tokens of the data section.
    words: std::str::SplitAsciiWhitespace<'a>,
}

impl Reader<'_> {
    fn value(&mut self, ty: Scalar) -> Option<f64> {
        if self.format == Format::Ascii {
            let w = self.words.next()?;
            return match ty {
                Scalar::F32 | Scalar::F64 => w.parse().ok(),
                _ => w.parse::<i64>().ok().map(|v| v as f64),
            };
        }
        let n = ty.size();
        let b = self.data.get(self.pos..self.pos + n)?;
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.format == Format::Big {
            a[..n].reverse();
        }
        Some(match ty {
            Scalar::I8 => a[0] as i8 as f64,
            Scalar::U8 => a[0] as f64,
            Scalar::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(a),
        })
    }
}

/// Parses a whole PLY file.
pub fn parse(bytes: &[u8], file: &str, name: &str) -> Result<SceneDesc> {
    let at = |line: usize, msg: String| Error::At {
        file: file.to_string(),
        loc: Loc {
            line: line as u32,
            col: 0,
        },
        msg,
    };
    let bad = |msg: String| Error::File {
        file: file.to_string(),
        msg,
    };
    // The header: text lines up to `end_header`.
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let rest = &bytes[pos..];
        let Some(nl) = rest.iter().position(|&b| b == b'\n') else {
            return Err(bad("the header has no end_header line".into()));
        };
        line_no += 1;
        let line = String::from_utf8_lossy(&rest[..nl]);
        let line = line.trim_end_matches('\r').trim();
        pos += nl + 1;
        let mut w = line.split_whitespace();
        let key = w.next().unwrap_or("");
        if line_no == 1 {
            if line != "ply" {
                return Err(at(1, "not a PLY file (the first line is not `ply`)".into()));
            }
            continue;
        }
        match key {
            "format" => {
                format = Some(match w.next() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Little,
                    Some("binary_big_endian") => Format::Big,
                    other => {
                        return Err(at(line_no, format!("unknown format {other:?}")));
                    }
                });
            }
            "element" => {
                let n = w.next().unwrap_or("").to_string();
                let count: usize = w
                    .next()
                    .and_then(|c| c.parse().ok())
                    .ok_or_else(|| at(line_no, format!("element {n:?} needs a count")))?;
                elements.push(Element {
                    name: n,
                    count,
                    props: Vec::new(),
                });
            }
            "property" => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| at(line_no, "a property before any element".into()))?;
                let t = w.next().unwrap_or("");
                let prop = if t == "list" {
                    let c = w.next().and_then(Scalar::of);
                    let v = w.next().and_then(Scalar::of);
                    match (c, v, w.next()) {
                        (Some(c), Some(v), Some(n)) => Property {
                            name: n.into(),
                            list: Some(c),
                            ty: v,
                        },
                        _ => return Err(at(line_no, format!("malformed list property: {line}"))),
                    }
                } else {
                    match (Scalar::of(t), w.next()) {
                        (Some(ty), Some(n)) => Property {
                            name: n.into(),
                            list: None,
                            ty,
                        },
                        _ => return Err(at(line_no, format!("malformed property: {line}"))),
                    }
                };
                el.props.push(prop);
            }
            "comment" | "obj_info" | "" => {}
            "end_header" => break,
            other => return Err(at(line_no, format!("unknown header line `{other}`"))),
        }
    }
    let format = format.ok_or_else(|| bad("the header has no format line".into()))?;
    // Nothing is allocated for more items than the data could hold (one byte or word each).
    let data = &bytes[pos..];
    let text = if format == Format::Ascii {
        std::str::from_utf8(data).map_err(|_| bad("ASCII data that is not text".into()))?
    } else {
        ""
    };
    let mut r = Reader {
        data,
        pos: 0,
        format,
        words: text.split_ascii_whitespace(),
    };
    let mut positions: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut has_normals = false;
    let mut uvs: Vec<glam::Vec2> = Vec::new();
    let mut faces: Vec<Vec<u32>> = Vec::new();
    // Triangle-strip index lists, -1 between strips.
    let mut strips: Vec<i64> = Vec::new();
    for el in &elements {
        if el.count > data.len() {
            return Err(bad(format!(
                "{} {} items claimed, but the data holds only {} bytes",
                el.count,
                el.name,
                data.len()
            )));
        }
        let find = |n: &str| {
            el.props
                .iter()
                .position(|p| p.name == n && p.list.is_none())
        };
        let (xi, yi, zi) = (find("x"), find("y"), find("z"));
        let (nx, ny, nz) = (find("nx"), find("ny"), find("nz"));
        let uv_props = [
            ("u", "v"),
            ("s", "t"),
            ("texture_u", "texture_v"),
            ("texture_s", "texture_t"),
        ]
        .iter()
        .find_map(|(u, v)| Some((find(u)?, find(v)?)));
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        let is_strip = el.name == "tristrips";
        if is_vertex {
            if xi.is_none() || yi.is_none() || zi.is_none() {
                return Err(bad("the vertex element has no x, y and z".into()));
            }
            has_normals = nx.is_some() && ny.is_some() && nz.is_some();
            positions.reserve(el.count);
        }
        let list_i = el.props.iter().position(|p| {
            p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
        });
        if (is_face || is_strip) && list_i.is_none() {
            return Err(bad(format!(
                "the {} element has no vertex_indices list",
                el.name
            )));
        }
        let mut vals = vec![0f64; el.props.len()];
        for item in 0..el.count {
            let short = || bad(format!("the data ends inside {} {item}", el.name));
            let mut list: Vec<u32> = Vec::new();
            for (k, p) in el.props.iter().enumerate() {
                match p.list {
                    None => vals[k] = r.value(p.ty).ok_or_else(short)?,
                    Some(ct) => {
                        let n = r.value(ct).ok_or_else(short)?;
                        if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                            return Err(bad(format!("{} {item}: bad list length {n}", el.name)));
                        }
                        let keep = Some(k) == list_i;
                        for _ in 0..n as usize {
                            let v = r.value(p.ty).ok_or_else(short)?;
                            if keep && is_strip && v == -1.0 {
                                strips.push(-1);
                            } else if keep {
                                if !(0.0..u32::MAX as f64).contains(&v) || v.fract() != 0.0 {
                                    return Err(bad(format!(
                                        "{} {item}: bad vertex index {v}",
                                        el.name
                                    )));
                                }
                                if is_strip {
                                    strips.push(v as i64);
                                } else {
                                    list.push(v as u32);
                                }
                            }
                        }
                    }
                }
            }
            if is_vertex {
                let get = |i: Option<usize>| i.map_or(0.0, |i| vals[i] as f32);
                let p = Vec3::new(get(xi), get(yi), get(zi));
                if !p.is_finite() {
                    return Err(bad(format!("vertex {item}: a coordinate is not finite")));
                }
                positions.push(p);
                if has_normals {
                    let n = Vec3::new(get(nx), get(ny), get(nz));
                    normals.push(if n.is_finite() { n } else { Vec3::ZERO });
                }
                if let Some((u, v)) = uv_props {
                    let t = glam::Vec2::new(vals[u] as f32, 1.0 - vals[v] as f32);
                    uvs.push(if t.is_finite() { t } else { glam::Vec2::ZERO });
                }
            } else if is_face {
                if list.len() < 3 {
                    return Err(bad(format!(
                        "face {item} has {} vertices; a face needs at least 3",
                        list.len()
                    )));
                }
                faces.push(list);
            }
        }
    }
    let mut triangles = Vec::new();
    for (i, f) in faces.iter().enumerate() {
        if let Some(&v) = f.iter().find(|&&v| v as usize >= positions.len()) {
            return Err(bad(format!(
                "face {i}: vertex index {v} is out of range ({} vertices)",
                positions.len()
            )));
        }
        for k in 1..f.len() - 1 {
            triangles.push([f[0], f[k], f[k + 1]]);
        }
    }
    for t in strip_triangles(&strips) {
        if let Some(&v) = t.iter().find(|&&v| v as usize >= positions.len()) {
            return Err(bad(format!(
                "tristrips: vertex index {v} is out of range ({} vertices)",
                positions.len()
            )));
        }
        triangles.push(t);
    }
    let mut desc = SceneDesc {
        name: name.to_string(),
        file: file.to_string(),
        materials: vec![MaterialDesc {
            name: "default".into(),
            kind: MaterialKind::Diffuse {
                albedo: Vec3::splat(0.5),
            },
            emission: Vec3::ZERO,
            loc: Loc::default(),
            one_sided: false,
            interface: None,
        }],
        ..Default::default()
    };
    if triangles.is_empty() {
        desc.warnings.push(format!("{file}: no faces"));
    }
    desc.shapes.push(ShapeDesc::Mesh {
        name: name.to_string(),
        materials: vec![0; triangles.len()],
        positions,
        triangles,
        normals: if has_normals {
            MeshNormals::Given(normals)
        } else {
            MeshNormals::Flat
        },
        uvs,
        one_sided: true,
        transform: Mat4::IDENTITY,
        loc: Loc::default(),
    });
    Ok(desc)
}

/// The triangles of triangle strips (`-1` ends a strip): triangle `k` of a strip is
/// `(s[k], s[k+1], s[k+2])` with every other one turned round so that all keep the strip's
/// winding; triangles that repeat a vertex (strip joins) are dropped.
fn strip_triangles(strips: &[i64]) -> Vec<[u32; 3]> {
    let mut out = Vec::new();
    for strip in strips.split(|&v| v < 0) {
        for (k, w) in strip.windows(3).enumerate() {
            let [a, b, c] = [w[0] as u32, w[1] as u32, w[2] as u32];
            if a == b || b == c || a == c {
                continue;
            }
            out.push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const QUAD: &str =
        "ply\nformat ascii 1.0\ncomment a quad\nelement vertex 4\nproperty float x\n\
                        property float y\nproperty float z\nelement face 1\n\
                        property list uchar int vertex_indices\nend_header\n\
                        0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";

    fn tris(d: &SceneDesc) -> Vec<[u32; 3]> {
        match &d.shapes[0] {
            ShapeDesc::Mesh { triangles, .. } => triangles.clone(),
            _ => panic!(),
        }
    }

    #[test]
    fn gzipped_files_read_as_their_contents() {
        use std::io::Write;
        let dir = std::env::temp_dir().join(format!("ply-gz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(QUAD.as_bytes()).unwrap();
        let path = dir.join("quad.ply.gz");
        std::fs::write(&path, gz.finish().unwrap()).unwrap();
        let d = crate::io::load_scene(&path).unwrap();
        assert_eq!(d.name, "quad");
        assert_eq!(
            tris(&d),
            tris(&parse(QUAD.as_bytes(), "q.ply", "q").unwrap())
        );
        std::fs::write(&path, b"not gzip").unwrap();
        let e = crate::io::load_scene(&path).unwrap_err().to_string();
        assert!(e.contains("quad.ply.gz: not valid gzip data"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn triangle_strips_restart_at_minus_one_and_keep_their_winding() {
        let text = "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\n\
                    property float y\nproperty float z\nelement tristrips 1\n\
                    property list int int vertex_indices\nend_header\n\
                    0 0 0\n0 1 0\n1 0 0\n1 1 0\n2 0 0\n2 1 0\n\
                    13 0 1 2 3 -1 2 3 3 4 -1 3 4 5\n";
        let d = parse(text.as_bytes(), "s.ply", "s").unwrap();
        // (2, 3, 3) and (3, 3, 4) repeat a vertex: a strip join, dropped.
        assert_eq!(tris(&d), [[0, 1, 2], [2, 1, 3], [3, 4, 5]]);
        let ShapeDesc::Mesh { positions, .. } = &d.shapes[0] else {
            panic!()
        };
        let normal = |t: [u32; 3]| {
            let p = |i: u32| positions[i as usize];
            (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).normalize()
        };
        assert_eq!(normal([0, 1, 2]), normal([2, 1, 3]));
        let bad = text.replace("3 4 5\n", "3 4 9\n");
        let e = parse(bad.as_bytes(), "s.ply", "s").unwrap_err().to_string();
        assert!(
            e.contains("s.ply: tristrips: vertex index 9 is out of range"),
            "{e}"
        );
        let bad = text.replace("-1 3 4 5", "-2 3 4 5");
        let e = parse(bad.as_bytes(), "s.ply", "s").unwrap_err().to_string();
        assert!(e.contains("tristrips 0: bad vertex index -2"), "{e}");
    }

    #[test]
    fn ascii_and_both_binary_orders_read_the_same_mesh() {
        let a = parse(QUAD.as_bytes(), "q.ply", "q").unwrap();
        assert_eq!(tris(&a), [[0, 1, 2], [0, 2, 3]]);
        for (fmt, big) in [("binary_little_endian", false), ("binary_big_endian", true)] {
            let mut b = format!(
                "ply\nformat {fmt} 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
                 property float z\nproperty uchar red\nelement face 1\n\
                 property list uchar int vertex_indices\nend_header\n"
            )
            .into_bytes();
            for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
                for v in p {
                    b.extend(if big {
                        v.to_be_bytes()
                    } else {
                        v.to_le_bytes()
                    });
                }
                b.push(200);
            }
            b.push(4);
            for i in [0i32, 1, 2, 3] {
                b.extend(if big {
                    i.to_be_bytes()
                } else {
                    i.to_le_bytes()
                });
            }
            let d = parse(&b, "q.ply", "q").unwrap();
            assert_eq!(tris(&d), tris(&a), "{fmt}");
            let ShapeDesc::Mesh { positions, .. } = &d.shapes[0] else {
                panic!()
            };
            assert_eq!(positions[2], Vec3::new(1.0, 1.0, 0.0));
        }
    }

    /// Texture coordinates under each of their usual names, v flipped to top-down; none
    /// without them.
    #[test]
    fn texture_coordinates_are_read_and_flipped() {
        assert!(matches!(
            &parse(QUAD.as_bytes(), "q.ply", "q").unwrap().shapes[0],
            ShapeDesc::Mesh { uvs, .. } if uvs.is_empty()
        ));
        for (u, v) in [
            ("u", "v"),
            ("s", "t"),
            ("texture_u", "texture_v"),
            ("texture_s", "texture_t"),
        ] {
            let text = format!(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                 property float z\nproperty float {u}\nproperty float {v}\nelement face 1\n\
                 property list uchar int vertex_indices\nend_header\n\
                 0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 0.25\n3 0 1 2\n"
            );
            let d = parse(text.as_bytes(), "q.ply", "q").unwrap();
            let ShapeDesc::Mesh { uvs, .. } = &d.shapes[0] else {
                panic!()
            };
            assert_eq!(
                uvs,
                &[
                    glam::Vec2::new(0.0, 1.0),
                    glam::Vec2::new(1.0, 1.0),
                    glam::Vec2::new(1.0, 0.75)
                ],
                "{u} {v}"
            );
        }
    }

    #[test]
    fn bad_input_is_a_clear_error() {
        for (text, want) in [
            ("plx\n", "q.ply:1: not a PLY file"),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
                "q.ply:4: malformed property",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\n",
                "q.ply: the header has no end_header",
            ),
            (
                &QUAD.replace("4 0 1 2 3", "4 0 1 2 9"),
                "q.ply: face 0: vertex index 9 is out of range",
            ),
            (
                &QUAD.replace("4 0 1 2 3", "2 0 1"),
                "q.ply: face 0 has 2 vertices",
            ),
            (
                &QUAD.replace("1 1 0\n", "1 nan 0\n"),
                "q.ply: vertex 2: a coordinate is not finite",
            ),
            (
                &QUAD.replace("4 0 1 2 3\n", ""),
                "q.ply: the data ends inside face 0",
            ),
            (
                &QUAD.replace("element face 1", "element face 4000000000"),
                "q.ply: 4000000000 face items claimed",
            ),
        ] {
            let e = parse(text.as_bytes(), "q.ply", "q")
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(want), "{e}");
        }
    }
}
