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

/// An error at header line `line` of `file`.
fn error_at(file: &str, line: usize, msg: String) -> Error {
    Error::At {
        file: file.to_string(),
        loc: Loc {
            line: line as u32,
            col: 0,
        },
        msg,
    }
}

/// An error about `file` as a whole: a missing header line or bad data.
fn file_error(file: &str, msg: String) -> Error {
    Error::File {
        file: file.to_string(),
        msg,
    }
}

/// What a PLY header declares.
struct Header {
    format: Format,
    elements: Vec<Element>,
    /// The offset of the data section, just after the `end_header` line.
    data_start: usize,
}

/// Parses a whole PLY file.
pub fn parse(bytes: &[u8], file: &str, name: &str) -> Result<SceneDesc> {
    let header = parse_header(bytes, file)?;
    let data = &bytes[header.data_start..];
    let mesh = read_data(data, header.format, &header.elements, file)?;
    let triangles = mesh_triangles(&mesh, file)?;
    Ok(mesh_scene(mesh, triangles, file, name))
}

/// Parses the header: text lines up to `end_header`.
fn parse_header(bytes: &[u8], file: &str) -> Result<Header> {
    let at = |line: usize, msg: String| error_at(file, line, msg);
    let bad = |msg: String| file_error(file, msg);
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
                el.props.push(parse_property(&mut w, line, line_no, file)?);
            }
            "comment" | "obj_info" | "" => {}
            "end_header" => break,
            other => return Err(at(line_no, format!("unknown header line `{other}`"))),
        }
    }
    let format = format.ok_or_else(|| bad("the header has no format line".into()))?;
    Ok(Header {
        format,
        elements,
        data_start: pos,
    })
}

/// Parses the words after `property` on header line `line_no` (the whole `line`, for
/// messages): a scalar's type and name, or `list`, its count and value types and its name.
fn parse_property(
    w: &mut std::str::SplitWhitespace<'_>,
    line: &str,
    line_no: usize,
    file: &str,
) -> Result<Property> {
    let t = w.next().unwrap_or("");
    Ok(if t == "list" {
        let c = w.next().and_then(Scalar::of);
        let v = w.next().and_then(Scalar::of);
        match (c, v, w.next()) {
            (Some(c), Some(v), Some(n)) => Property {
                name: n.into(),
                list: Some(c),
                ty: v,
            },
            _ => {
                let msg = format!("malformed list property: {line}");
                return Err(error_at(file, line_no, msg));
            }
        }
    } else {
        match (Scalar::of(t), w.next()) {
            (Some(ty), Some(n)) => Property {
                name: n.into(),
                list: None,
                ty,
            },
            _ => {
                let msg = format!("malformed property: {line}");
                return Err(error_at(file, line_no, msg));
            }
        }
    })
}

/// The mesh the data section holds, before its faces and strips become triangles.
#[derive(Default)]
struct MeshData {
    positions: Vec<Vec3>,
    /// Per-vertex normals, read when the vertex element has `nx ny nz`.
    normals: Vec<Vec3>,
    has_normals: bool,
    uvs: Vec<glam::Vec2>,
    faces: Vec<Vec<u32>>,
    /// Triangle-strip index lists, -1 between strips.
    strips: Vec<i64>,
}

/// Where the properties the mesh uses sit in one element's property list, and which kind
/// of element it is.
struct ElementLayout {
    /// `x y z`.
    position: [Option<usize>; 3],
    /// `nx ny nz`.
    normal: [Option<usize>; 3],
    /// The texture coordinate pair, under the first of its usual names that is present.
    uv: Option<(usize, usize)>,
    /// The `vertex_indices` (or `vertex_index`) list.
    index_list: Option<usize>,
    is_vertex: bool,
    is_face: bool,
    is_strip: bool,
}

impl ElementLayout {
    /// Finds the properties of `el` that the mesh uses, by name.
    fn of(el: &Element) -> ElementLayout {
        let find = |n: &str| {
            el.props
                .iter()
                .position(|p| p.name == n && p.list.is_none())
        };
        let uv = [
            ("u", "v"),
            ("s", "t"),
            ("texture_u", "texture_v"),
            ("texture_s", "texture_t"),
        ]
        .iter()
        .find_map(|(u, v)| Some((find(u)?, find(v)?)));
        let index_list = el.props.iter().position(|p| {
            p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
        });
        ElementLayout {
            position: [find("x"), find("y"), find("z")],
            normal: [find("nx"), find("ny"), find("nz")],
            uv,
            index_list,
            is_vertex: el.name == "vertex",
            is_face: el.name == "face",
            is_strip: el.name == "tristrips",
        }
    }
}

/// Reads the data section, element after element, into the mesh.
struct DataReader<'a> {
    values: Reader<'a>,
    /// The length of the data section in bytes.
    data_len: usize,
    file: &'a str,
    mesh: MeshData,
}

/// Reads every element's items from the data section `data`.
fn read_data(data: &[u8], format: Format, elements: &[Element], file: &str) -> Result<MeshData> {
    let text = if format == Format::Ascii {
        std::str::from_utf8(data)
            .map_err(|_| file_error(file, "ASCII data that is not text".into()))?
    } else {
        ""
    };
    let mut reader = DataReader {
        values: Reader {
            data,
            pos: 0,
            format,
            words: text.split_ascii_whitespace(),
        },
        data_len: data.len(),
        file,
        mesh: MeshData::default(),
    };
    for el in elements {
        reader.element(el)?;
    }
    Ok(reader.mesh)
}

impl DataReader<'_> {
    /// Reads the items of element `el`, once it is checked to have what the mesh needs.
    fn element(&mut self, el: &Element) -> Result<()> {
        let file = self.file;
        let bad = |msg: String| file_error(file, msg);
        // Nothing is allocated for more items than the data could hold (one byte or word each).
        if el.count > self.data_len {
            return Err(bad(format!(
                "{} {} items claimed, but the data holds only {} bytes",
                el.count, el.name, self.data_len
            )));
        }
        let layout = ElementLayout::of(el);
        if layout.is_vertex {
            if layout.position.iter().any(Option::is_none) {
                return Err(bad("the vertex element has no x, y and z".into()));
            }
            self.mesh.has_normals = layout.normal.iter().all(Option::is_some);
            self.mesh.positions.reserve(el.count);
        }
        if (layout.is_face || layout.is_strip) && layout.index_list.is_none() {
            return Err(bad(format!(
                "the {} element has no vertex_indices list",
                el.name
            )));
        }
        let mut vals = vec![0f64; el.props.len()];
        for item in 0..el.count {
            let list = self.item(el, &layout, item, &mut vals)?;
            if layout.is_vertex {
                self.push_vertex(&layout, &vals, item)?;
            } else if layout.is_face {
                if list.len() < 3 {
                    return Err(bad(format!(
                        "face {item} has {} vertices; a face needs at least 3",
                        list.len()
                    )));
                }
                self.mesh.faces.push(list);
            }
        }
        Ok(())
    }

    /// Reads item `item` of `el`: its scalar properties into `vals` (by property), the
    /// indices of a strip onto the mesh's strips; returns the vertex indices of a face.
    fn item(
        &mut self,
        el: &Element,
        layout: &ElementLayout,
        item: usize,
        vals: &mut [f64],
    ) -> Result<Vec<u32>> {
        let file = self.file;
        let bad = |msg: String| file_error(file, msg);
        let short = || bad(format!("the data ends inside {} {item}", el.name));
        let mut list: Vec<u32> = Vec::new();
        for (k, p) in el.props.iter().enumerate() {
            match p.list {
                None => vals[k] = self.values.value(p.ty).ok_or_else(short)?,
                Some(ct) => {
                    let n = self.values.value(ct).ok_or_else(short)?;
                    if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                        return Err(bad(format!("{} {item}: bad list length {n}", el.name)));
                    }
                    let keep = Some(k) == layout.index_list;
                    for _ in 0..n as usize {
                        let v = self.values.value(p.ty).ok_or_else(short)?;
                        if keep && layout.is_strip && v == -1.0 {
                            self.mesh.strips.push(-1);
                        } else if keep {
                            if !(0.0..u32::MAX as f64).contains(&v) || v.fract() != 0.0 {
                                return Err(bad(format!(
                                    "{} {item}: bad vertex index {v}",
                                    el.name
                                )));
                            }
                            if layout.is_strip {
                                self.mesh.strips.push(v as i64);
                            } else {
                                list.push(v as u32);
                            }
                        }
                    }
                }
            }
        }
        Ok(list)
    }

    /// Adds vertex `item` from its property values `vals`: its position (which must be
    /// finite), and its normal and texture coordinates where the element has them.
    fn push_vertex(&mut self, layout: &ElementLayout, vals: &[f64], item: usize) -> Result<()> {
        let get = |i: Option<usize>| i.map_or(0.0, |i| vals[i] as f32);
        let [x, y, z] = layout.position;
        let p = Vec3::new(get(x), get(y), get(z));
        if !p.is_finite() {
            return Err(file_error(
                self.file,
                format!("vertex {item}: a coordinate is not finite"),
            ));
        }
        let mesh = &mut self.mesh;
        mesh.positions.push(p);
        if mesh.has_normals {
            let [nx, ny, nz] = layout.normal;
            let n = Vec3::new(get(nx), get(ny), get(nz));
            mesh.normals
                .push(if n.is_finite() { n } else { Vec3::ZERO });
        }
        if let Some((u, v)) = layout.uv {
            let t = glam::Vec2::new(vals[u] as f32, 1.0 - vals[v] as f32);
            mesh.uvs
                .push(if t.is_finite() { t } else { glam::Vec2::ZERO });
        }
        Ok(())
    }
}

/// The mesh's triangles: its faces fan-triangulated, then its strips' triangles; an index
/// out of range is an error.
fn mesh_triangles(mesh: &MeshData, file: &str) -> Result<Vec<[u32; 3]>> {
    let vertex_count = mesh.positions.len();
    let mut triangles = Vec::new();
    for (i, f) in mesh.faces.iter().enumerate() {
        if let Some(&v) = f.iter().find(|&&v| v as usize >= vertex_count) {
            return Err(file_error(
                file,
                format!("face {i}: vertex index {v} is out of range ({vertex_count} vertices)"),
            ));
        }
        for k in 1..f.len() - 1 {
            triangles.push([f[0], f[k], f[k + 1]]);
        }
    }
    for t in strip_triangles(&mesh.strips) {
        if let Some(&v) = t.iter().find(|&&v| v as usize >= vertex_count) {
            return Err(file_error(
                file,
                format!("tristrips: vertex index {v} is out of range ({vertex_count} vertices)"),
            ));
        }
        triangles.push(t);
    }
    Ok(triangles)
}

/// The scene of the one mesh, with one grey diffuse material; a warning when it has no faces.
fn mesh_scene(mesh: MeshData, triangles: Vec<[u32; 3]>, file: &str, name: &str) -> SceneDesc {
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
        positions: mesh.positions,
        triangles,
        normals: if mesh.has_normals {
            MeshNormals::Given(mesh.normals)
        } else {
            MeshNormals::Flat
        },
        uvs: mesh.uvs,
        one_sided: true,
        transform: Mat4::IDENTITY,
        loc: Loc::default(),
    });
    desc
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
