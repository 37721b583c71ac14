//! Wavefront OBJ with MTL materials, into a [`SceneDesc`].
//!
//! Read: `v` (x y z, an optional w ignored), `vn`, `vt` (u and v; v is flipped to the
//! description's top-down convention),
//! `f` with any of `v`, `v/vt`, `v//vn`, `v/vt/vn` and negative (relative) indices, polygons of
//! any size fan-triangulated; `usemtl`, `mtllib`; `g`, `o`, `s`, `l`, `p` are accepted and
//! ignored; comments run from `#` to the end of the line; blanks are spaces or tabs and CRLF
//! line ends are fine. Faces with normals shade with them (one vertex per position/normal
//! pair), faces without shade flat. Coordinates are taken as they are (Y-up).
//!
//! MTL: `newmtl`, `Kd`, `Ks`, `Ns`, `Ni`, `d`/`Tr`, `Tf`, `illum`, `map_Kd` (a PNG or JPEG,
//! relative to the OBJ's folder, sRGB-decoded, repeating, multiplying the material's colour;
//! one that cannot be read is a warning and grey) and `Ke` (emission: such faces become area
//! lights that emit from their front side only, the side their winding faces). `Ka`,
//! `sharpness` and other `map_*` are read and not used (another texture is a warning). A
//! missing MTL file or an unknown material name is a warning and a grey (0.5) diffuse fallback.
//!
//! Materials are mapped onto the metallic-roughness model ([`crate::bsdf::pbr`]) with roughness
//! `√α`, where `α = √(2 / (Ns + 2))` is the GGX/Beckmann width equivalent to a Phong exponent
//! `Ns` (Walter et al. 2007; `Ns` 0 when absent):
//! - transparent (`illum` 4, 6, 7 or 9, or a dissolve `d` < 1, `Tr` = 1 − `d`): a dielectric of
//!   index `Ni` (1.5 when absent or below 1.001) whose transmission is `1 − d`, or 1 for those
//!   `illum` modes, tinted by `Tf` (white when absent) when wholly transmitting and by `Kd`
//!   otherwise;
//! - a specular `Ks` > 0 (and `illum` not 0 or 1, which have no highlights): with a black `Kd`,
//!   a metal of base colour `Ks`; otherwise a diffuse base `Kd` under a specular layer of index
//!   `Ni` (`Ks` selects the layer, its magnitude is not used);
//! - otherwise Lambertian with albedo `Kd` (0.8 when absent).
//!
//! Errors (exit 2): a number that does not parse or is not finite, an index of 0 or out of
//! range, a face with fewer than three vertices, each naming `file:line`.

use crate::error::{Error, Loc, Result};
use crate::io::desc::{
    MaterialDesc, MaterialKind, MeshNormals, SceneDesc, ShapeDesc, TextureDesc, TextureSlot, Wrap,
};
use crate::io::image::decode_texture;
use glam::{Mat4, Vec2, Vec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Loads an OBJ file and the MTL files and textures it names (relative to its folder, or
/// else found by their file name beside it, with a warning).
pub fn load_file(path: &Path) -> Result<SceneDesc> {
    let (file, bytes, name) = super::read_scene_file(path, "scene")?;
    let text = String::from_utf8_lossy(&bytes);
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let (mut read, mut notes) = (Vec::new(), Vec::new());
    let mut desc = parse(&text, &file, &name, &mut |named: &str| {
        let (p, b, note) = read_beside(&dir, named)?;
        notes.extend(note.map(|n| format!("{file}: {n}")));
        read.push(p.clone());
        Ok((p.display().to_string(), b))
    })?;
    desc.sources.extend(read);
    desc.warnings.extend(notes);
    Ok(desc)
}

/// The file an OBJ or MTL names: at its path relative to `dir`, or else the file of its bare
/// name in `dir` ([`super::found_beside`]), with a note saying so.
fn read_beside(
    dir: &Path,
    named: &str,
) -> std::result::Result<(PathBuf, Vec<u8>, Option<String>), String> {
    let given = dir.join(named);
    let error = match std::fs::read(&given) {
        Ok(bytes) => return Ok((given, bytes, None)),
        Err(e) => format!("{}: {e}", given.display()),
    };
    let beside = super::found_beside(dir, named).ok_or_else(|| error.clone())?;
    let bytes = std::fs::read(&beside).map_err(|_| error)?;
    let note = format!(
        "\"{named}\" was not found; {} (the file of that name beside the OBJ) is used",
        beside.display()
    );
    Ok((beside, bytes, Some(note)))
}

/// A reader of the files an OBJ names (MTL libraries, textures): the name as the file gives
/// it → (its path for messages, its bytes).
pub type FileReader<'a> = dyn FnMut(&str) -> std::result::Result<(String, Vec<u8>), String> + 'a;

/// The statements of OBJ or MTL text: for each line that is not blank or a comment, its place,
/// its keyword and the rest of its tokens.
fn statements(text: &str) -> impl Iterator<Item = (Loc, &str, std::str::SplitWhitespace<'_>)> {
    text.lines().enumerate().filter_map(|(i, line)| {
        let mut it = line.split('#').next().unwrap_or("").split_whitespace();
        let key = it.next()?;
        let loc = Loc {
            line: i as u32 + 1,
            col: 0,
        };
        Some((loc, key, it))
    })
}

/// The error maker for one place of `file`.
fn error_at(file: &str, loc: Loc) -> impl Fn(String) -> Error + '_ {
    move |msg| Error::At {
        file: file.to_string(),
        loc,
        msg,
    }
}

/// Parses `n` finite numbers from `it` (more are ignored).
fn numbers<'a>(
    it: &mut (impl Iterator<Item = &'a str> + ?Sized),
    n: usize,
    at: &dyn Fn(String) -> Error,
) -> Result<Vec<f32>> {
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let t = it
            .next()
            .ok_or_else(|| at(format!("expected {n} numbers, found {k}")))?;
        let v: f32 = t.parse().map_err(|_| at(format!("not a number: {t:?}")))?;
        if !v.is_finite() {
            return Err(at(format!("not a finite number: {t:?}")));
        }
        out.push(v);
    }
    Ok(out)
}

/// An OBJ index (1-based, or negative relative to the end) into a list of `len` items.
fn index(t: &str, len: usize, what: &str, at: &dyn Fn(String) -> Error) -> Result<usize> {
    let i: i64 = t
        .parse()
        .map_err(|_| at(format!("not a {what} index: {t:?}")))?;
    let r = if i > 0 {
        i - 1
    } else if i < 0 {
        len as i64 + i
    } else {
        return Err(at(format!("{what} index 0 (OBJ indices start at 1)")));
    };
    if r < 0 || r >= len as i64 {
        return Err(at(format!(
            "{what} index {i} is out of range: {len} {what}s are defined so far"
        )));
    }
    Ok(r as usize)
}

/// The grey diffuse material used where a material is missing.
fn fallback(name: &str, loc: Loc) -> MaterialDesc {
    MaterialDesc {
        name: name.to_string(),
        kind: MaterialKind::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        emission: Vec3::ZERO,
        loc,
        one_sided: false,
        interface: None,
    }
}

/// Parses MTL text into materials by name (later definitions of a name win).
fn parse_mtl(
    text: &str,
    file: &str,
    desc: &mut SceneDesc,
    by_name: &mut HashMap<String, u32>,
    read: &mut FileReader,
) -> Result<()> {
    let SceneDesc {
        materials: out,
        warnings,
        textures,
        ..
    } = desc;
    let mut current: Option<(usize, Mtl)> = None;
    for (loc, key, mut it) in statements(text) {
        let at = error_at(file, loc);
        if key == "newmtl" {
            let name = it.collect::<Vec<_>>().join(" ");
            if name.is_empty() {
                return Err(at("newmtl without a name".into()));
            }
            start_material(name, loc, &mut current, out, by_name);
            continue;
        }
        let Some((c, mtl)) = current.as_mut() else {
            if !key.is_empty() {
                warnings.push(format!(
                    "{file}:{loc}: `{key}` before any newmtl is ignored"
                ));
            }
            continue;
        };
        let c = *c;
        let rgb = |it: &mut dyn Iterator<Item = &str>| mtl_colour(it, key, &at);
        let number =
            |it: &mut dyn Iterator<Item = &str>| -> Result<f32> { Ok(numbers(it, 1, &at)?[0]) };
        match key {
            "Kd" => mtl.kd = Some(rgb(&mut it)?),
            "Ke" => out[c].emission = rgb(&mut it)?.max(Vec3::ZERO),
            "Ks" => mtl.ks = rgb(&mut it)?,
            "Tf" => mtl.tf = Some(rgb(&mut it)?),
            "Ka" => {
                rgb(&mut it)?;
            }
            "Ns" => mtl.ns = number(&mut it)?,
            "Ni" => mtl.ni = Some(number(&mut it)?),
            "d" => mtl.dissolve = number(&mut it)?,
            "Tr" => mtl.dissolve = 1.0 - number(&mut it)?,
            "illum" => mtl.illum = Some(number(&mut it)?),
            "sharpness" => {
                number(&mut it)?;
            }
            "map_Kd" => {
                // Options (`-s 1 1 1`, `-clamp on`, …) come first; the file name is last.
                let Some(name) = it.last() else {
                    return Err(at("map_Kd without a file name".into()));
                };
                if let Err(e) = set_base_colour_texture(textures, c as u32, name, read) {
                    warnings.push(format!(
                        "{file}:{loc}: material {:?}: cannot read its texture ({e}): grey \
                         diffuse instead",
                        out[c].name
                    ));
                    mtl.unreadable_texture = true;
                }
            }
            k if k.starts_with("map_")
                || k == "bump"
                || k == "disp"
                || k == "decal"
                || k == "refl"
                || k == "norm" =>
            {
                warnings.push(format!(
                    "{file}:{loc}: material {:?}: textures ({k}) are not supported yet and are ignored",
                    out[c].name
                ));
            }
            other => warnings.push(format!(
                "{file}:{loc}: unknown MTL statement `{other}` ignored"
            )),
        }
    }
    if let Some((c, m)) = current {
        out[c].kind = m.kind();
    }
    Ok(())
}

/// Starts MTL material `name`: the current one gets its scattering model, and `name` is
/// added to `materials` as a grey material that its statements then fill in.
fn start_material(
    name: String,
    loc: Loc,
    current: &mut Option<(usize, Mtl)>,
    materials: &mut Vec<MaterialDesc>,
    by_name: &mut HashMap<String, u32>,
) {
    if let Some((c, m)) = current.take() {
        materials[c].kind = m.kind();
    }
    materials.push(fallback(&name, loc));
    by_name.insert(name, materials.len() as u32 - 1);
    *current = Some((materials.len() - 1, Mtl::default()));
}

/// The colour of MTL statement `key`: three numbers, or one for grey; `spectral` and `xyz`
/// colours are refused.
fn mtl_colour(
    it: &mut dyn Iterator<Item = &str>,
    key: &str,
    at: &dyn Fn(String) -> Error,
) -> Result<Vec3> {
    let v: Vec<&str> = it.collect();
    if v.first() == Some(&"spectral") || v.first() == Some(&"xyz") {
        return Err(at(format!("`{key} {}` colours are not supported", v[0])));
    }
    // One number means grey.
    let n = if v.len() == 1 { 1 } else { 3 };
    let c = numbers(&mut v.into_iter(), n, at)?;
    Ok(if n == 1 {
        Vec3::splat(c[0])
    } else {
        Vec3::new(c[0], c[1], c[2])
    })
}

/// Makes the image file `named` the base colour texture of material `material`, in place of
/// any it had (which is dropped even when `named` cannot be read); the error says why not.
fn set_base_colour_texture(
    textures: &mut Vec<TextureDesc>,
    material: u32,
    named: &str,
    read: &mut FileReader,
) -> std::result::Result<(), String> {
    let tex = read(named).and_then(|(path, bytes)| {
        let (width, height, texels) = decode_texture(&bytes, &path)?;
        Ok(TextureDesc {
            name: path,
            material,
            slot: TextureSlot::BaseColor,
            width,
            height,
            texels,
            wrap: [Wrap::Repeat; 2],
            nearest: false,
            uv_transform: None,
        })
    });
    textures.retain(|t| t.material != material);
    textures.push(tex?);
    Ok(())
}

/// The MTL statements of one material that decide its scattering model.
#[derive(Debug)]
struct Mtl {
    kd: Option<Vec3>,
    ks: Vec3,
    tf: Option<Vec3>,
    ns: f32,
    ni: Option<f32>,
    dissolve: f32,
    illum: Option<f32>,
    unreadable_texture: bool,
}

impl Default for Mtl {
    fn default() -> Self {
        Mtl {
            kd: None,
            ks: Vec3::ZERO,
            tf: None,
            ns: 0.0,
            ni: None,
            dissolve: 1.0,
            illum: None,
            unreadable_texture: false,
        }
    }
}

impl Mtl {
    /// The scattering model (see the module documentation).
    fn kind(&self) -> MaterialKind {
        if self.unreadable_texture {
            return MaterialKind::Diffuse {
                albedo: Vec3::splat(0.5),
            };
        }
        let kd = self.kd.unwrap_or(Vec3::splat(0.8));
        let illum = self.illum.map(|i| i.round() as i32);
        let alpha = (2.0 / (self.ns.max(0.0) + 2.0)).sqrt();
        let roughness = alpha.sqrt();
        let ior = self.ni.filter(|&n| n >= 1.001).unwrap_or(1.5);
        let glass = matches!(illum, Some(4 | 6 | 7 | 9));
        let dissolve = self.dissolve.clamp(0.0, 1.0);
        if glass || dissolve < 1.0 {
            let transmission = if glass { 1.0 } else { 1.0 - dissolve };
            let base = if transmission >= 1.0 {
                self.tf.unwrap_or(Vec3::ONE)
            } else {
                kd
            };
            return MaterialKind::MetallicRoughness {
                base,
                metallic: 0.0,
                roughness,
                transmission,
                ior,
            };
        }
        if self.ks.max_element() > 0.0 && !matches!(illum, Some(0 | 1)) {
            let metal = kd.max_element() <= 0.0;
            return MaterialKind::MetallicRoughness {
                base: if metal { self.ks } else { kd },
                metallic: if metal { 1.0 } else { 0.0 },
                roughness,
                transmission: 0.0,
                ior,
            };
        }
        MaterialKind::Diffuse { albedo: kd }
    }
}

/// Parses OBJ text; `mtl` reads the material libraries it names.
pub fn parse(text: &str, file: &str, name: &str, read: &mut FileReader) -> Result<SceneDesc> {
    let mut parser = ObjParser::new(file, name);
    for (loc, key, it) in statements(text) {
        parser.statement(loc, key, it, read)?;
    }
    Ok(parser.finish(name))
}

/// A face corner's indices into the OBJ's positions, texture coordinates and normals.
type Corner = (usize, Option<usize>, Option<usize>);

/// The OBJ's `v`, `vn` and `vt` lists, as read so far.
#[derive(Default)]
struct VertexLists {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    /// Texture coordinates, v flipped to the description's top-down convention.
    texcoords: Vec<Vec2>,
}

/// A mesh built up face by face: one vertex per distinct corner its faces use, and its
/// triangles with their materials.
#[derive(Default)]
struct MeshBuilder {
    positions: Vec<Vec3>,
    /// One per vertex for corners with a normal (none for a mesh shaded flat).
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    vertex_of: HashMap<Corner, u32>,
    triangles: Vec<[u32; 3]>,
    materials: Vec<u32>,
}

impl MeshBuilder {
    /// Adds a face with `corners`, fan-triangulated, its triangles of `material`; a corner
    /// already used by an earlier face shares that face's vertex.
    fn add_face(&mut self, corners: &[Corner], material: u32, lists: &VertexLists) {
        let MeshBuilder {
            positions,
            normals,
            uvs,
            vertex_of,
            ..
        } = self;
        let uv = |t: Option<usize>| t.map_or(Vec2::ZERO, |t| lists.texcoords[t]);
        let ids: Vec<u32> = corners
            .iter()
            .map(|&(v, vt, vn)| {
                *vertex_of.entry((v, vt, vn)).or_insert_with(|| {
                    positions.push(lists.positions[v]);
                    if let Some(n) = vn {
                        normals.push(lists.normals[n]);
                    }
                    uvs.push(uv(vt));
                    positions.len() as u32 - 1
                })
            })
            .collect();
        for k in 1..ids.len() - 1 {
            self.triangles.push([ids[0], ids[k], ids[k + 1]]);
            self.materials.push(material);
        }
    }
}

/// The state of OBJ parsing: the scene so far, the vertex lists, and the two meshes that
/// faces go to.
struct ObjParser<'f> {
    file: &'f str,
    desc: SceneDesc,
    /// Material indices in `desc` by name.
    by_name: HashMap<String, u32>,
    lists: VertexLists,
    /// Faces with a normal at every corner: one vertex per (position, texture coordinate,
    /// normal) used.
    smooth: MeshBuilder,
    /// The other faces, shaded flat: one vertex per (position, texture coordinate) used.
    flat: MeshBuilder,
    /// Whether any face corner has a texture coordinate.
    any_uv: bool,
    /// The material of the last `usemtl`.
    material: Option<u32>,
    /// The grey material of faces before any `usemtl`, added when first needed.
    default_material: Option<u32>,
}

impl<'f> ObjParser<'f> {
    /// A parser of OBJ file `file`, for a scene called `name`.
    fn new(file: &'f str, name: &str) -> ObjParser<'f> {
        ObjParser {
            file,
            desc: SceneDesc {
                name: name.to_string(),
                file: file.to_string(),
                ..Default::default()
            },
            by_name: HashMap::new(),
            lists: VertexLists::default(),
            smooth: MeshBuilder::default(),
            flat: MeshBuilder::default(),
            any_uv: false,
            material: None,
            default_material: None,
        }
    }

    /// Takes one statement: its keyword `key` and the rest of its tokens `it`.
    fn statement(
        &mut self,
        loc: Loc,
        key: &str,
        mut it: std::str::SplitWhitespace<'_>,
        read: &mut FileReader,
    ) -> Result<()> {
        let file = self.file;
        let at = error_at(file, loc);
        match key {
            "v" => {
                let v = numbers(&mut it, 3, &at)?;
                self.lists.positions.push(Vec3::new(v[0], v[1], v[2]));
            }
            "vn" => {
                let v = numbers(&mut it, 3, &at)?;
                self.lists.normals.push(Vec3::new(v[0], v[1], v[2]));
            }
            "vt" => {
                let u = numbers(&mut it, 1, &at)?[0];
                let v = match it.next() {
                    Some(t) => numbers(&mut std::iter::once(t), 1, &at)?[0],
                    None => 0.0,
                };
                self.lists.texcoords.push(Vec2::new(u, 1.0 - v));
            }
            "f" => self.face(it.collect(), loc)?,
            "usemtl" => self.use_material(it.collect::<Vec<_>>().join(" "), loc),
            "mtllib" => self.material_libraries(it, loc, read)?,
            "g" | "o" | "s" | "l" | "p" | "cstype" | "deg" | "curv" | "surf" | "end" | "parm" => {}
            other => self.desc.warnings.push(format!(
                "{file}:{loc}: unknown OBJ statement `{other}` ignored"
            )),
        }
        Ok(())
    }

    /// Adds a face with the vertices `corners` (`v`, `v/vt`, `v//vn` or `v/vt/vn`) to the
    /// smooth mesh when each has a normal, else to the flat one.
    fn face(&mut self, corners: Vec<&str>, loc: Loc) -> Result<()> {
        let at = error_at(self.file, loc);
        if corners.len() < 3 {
            return Err(at(format!(
                "a face needs at least 3 vertices, found {}",
                corners.len()
            )));
        }
        let mut parsed = Vec::with_capacity(corners.len());
        for c in &corners {
            parsed.push(self.corner(c, &at)?);
        }
        let m = self.face_material(loc);
        let smooth = parsed.iter().all(|p| p.2.is_some());
        self.any_uv |= parsed.iter().any(|p| p.1.is_some());
        if smooth {
            self.smooth.add_face(&parsed, m, &self.lists);
        } else {
            // Flat vertices are told apart by position and texture coordinate alone.
            let flat: Vec<Corner> = parsed.iter().map(|&(v, vt, _)| (v, vt, None)).collect();
            self.flat.add_face(&flat, m, &self.lists);
        }
        Ok(())
    }

    /// The indices of face vertex `c`, checked against the lists read so far.
    fn corner(&self, c: &str, at: &dyn Fn(String) -> Error) -> Result<Corner> {
        let lists = &self.lists;
        let mut parts = c.split('/');
        let v = index(
            parts.next().unwrap_or(""),
            lists.positions.len(),
            "vertex",
            at,
        )?;
        let vt = match parts.next().filter(|s| !s.is_empty()) {
            Some(t) => Some(index(t, lists.texcoords.len(), "texture coordinate", at)?),
            None => None,
        };
        let vn = match parts.next().filter(|s| !s.is_empty()) {
            Some(n) => Some(index(n, lists.normals.len(), "normal", at)?),
            None => None,
        };
        if parts.next().is_some() {
            return Err(at(format!("malformed face vertex {c:?}")));
        }
        Ok((v, vt, vn))
    }

    /// The material of a face: that of the last `usemtl`, or else the default grey one.
    fn face_material(&mut self, loc: Loc) -> u32 {
        if let Some(m) = self.material {
            return m;
        }
        let materials = &mut self.desc.materials;
        *self.default_material.get_or_insert_with(|| {
            materials.push(fallback("default", loc));
            materials.len() as u32 - 1
        })
    }

    /// Makes material `name` the current one; an unknown name is a warning and grey.
    fn use_material(&mut self, name: String, loc: Loc) {
        let file = self.file;
        self.material = Some(match self.by_name.get(&name) {
            Some(&m) => m,
            None => {
                self.desc.warnings.push(format!(
                    "{file}:{loc}: unknown material {name:?}: grey diffuse instead"
                ));
                self.desc.materials.push(fallback(&name, loc));
                let m = self.desc.materials.len() as u32 - 1;
                self.by_name.insert(name, m);
                m
            }
        });
    }

    /// Reads the MTL files `libraries`; one that cannot be read is a warning.
    fn material_libraries(
        &mut self,
        libraries: std::str::SplitWhitespace<'_>,
        loc: Loc,
        read: &mut FileReader,
    ) -> Result<()> {
        let file = self.file;
        for lib in libraries {
            match read(lib) {
                Ok((path, bytes)) => parse_mtl(
                    &String::from_utf8_lossy(&bytes),
                    &path,
                    &mut self.desc,
                    &mut self.by_name,
                    read,
                )?,
                Err(e) => self.desc.warnings.push(format!(
                    "{file}:{loc}: cannot read the material library ({e}): its materials \
                     are grey diffuse"
                )),
            }
        }
        Ok(())
    }

    /// The scene: its materials, and a mesh for the faces with normals and one for those
    /// without (each where there are any); a warning when there are no faces.
    fn finish(self, name: &str) -> SceneDesc {
        let ObjParser {
            file,
            mut desc,
            smooth,
            flat,
            any_uv,
            ..
        } = self;
        let loc = Loc::default();
        if !smooth.triangles.is_empty() {
            desc.shapes.push(ShapeDesc::Mesh {
                name: format!("{name} (with normals)"),
                positions: smooth.positions,
                triangles: smooth.triangles,
                materials: smooth.materials,
                normals: MeshNormals::Given(smooth.normals),
                uvs: if any_uv { smooth.uvs } else { Vec::new() },
                one_sided: true,
                transform: Mat4::IDENTITY,
                loc,
            });
        }
        if !flat.triangles.is_empty() {
            desc.shapes.push(ShapeDesc::Mesh {
                name: name.to_string(),
                positions: flat.positions,
                triangles: flat.triangles,
                materials: flat.materials,
                normals: MeshNormals::Flat,
                uvs: if any_uv { flat.uvs } else { Vec::new() },
                one_sided: true,
                transform: Mat4::IDENTITY,
                loc,
            });
        }
        if desc.shapes.is_empty() {
            desc.warnings.push(format!("{file}: no faces"));
        }
        desc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(obj: &str, mtl: &str) -> Result<SceneDesc> {
        let mtl = mtl.to_string();
        parse(obj, "t.obj", "t", &mut |_| {
            Ok(("t.mtl".into(), mtl.clone().into_bytes()))
        })
    }

    #[test]
    fn polygons_indices_materials_and_emitters() {
        let d = load(
            "mtllib t.mtl\r\nv 0 0 0\nv 1 0 0\t\nv 1 1 0 # c\nv 0 1 0\nusemtl red\nf 1 2 3 4\nusemtl lamp\nf -4 -3 -2\n",
            "newmtl red\n  Kd 0.5 0.1 0.1 # Red\nnewmtl lamp\nKd 0.78 0.78 0.78\nKe 17 12 4\n",
        )
        .unwrap();
        let ShapeDesc::Mesh {
            triangles,
            materials,
            normals,
            one_sided,
            ..
        } = &d.shapes[0]
        else {
            panic!()
        };
        assert_eq!(triangles, &[[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
        assert_eq!(materials, &[0, 0, 1]);
        assert_eq!(*normals, MeshNormals::Flat);
        assert!(*one_sided);
        assert_eq!(d.materials[1].emission, Vec3::new(17.0, 12.0, 4.0));
        assert_eq!(
            d.materials[0].kind,
            MaterialKind::Diffuse {
                albedo: Vec3::new(0.5, 0.1, 0.1)
            }
        );
    }

    /// Each MTL class maps onto its model: Lambertian, plastic-like (diffuse under a layer of
    /// index Ni), metal (black Kd), glass by illum or by dissolve, and illum 1 (no highlights).
    #[test]
    fn mtl_statements_choose_the_material() {
        let mtl = "newmtl matte\nKd 0.5 0.4 0.3\nKs 0 0 0\nNs 10\n\
                   newmtl plastic\nKd 0.5 0.4 0.3\nKs 0.2 0.2 0.2\nNs 98\nNi 1.6\n\
                   newmtl metal\nKd 0 0 0\nKs 0.725 0.71 0.68\nNs 200\n\
                   newmtl glass\nKd 0 0 0\nKs 1 1 1\nNs 1000000\nNi 1.45\nTf 0.9 1 0.9\nillum 7\n\
                   newmtl veil\nKd 0.2 0.3 0.4\nd 0.25\n\
                   newmtl dull\nKd 0.5 0.5 0.5\nKs 1 1 1\nillum 1\n";
        let d = load("mtllib t.mtl\n", mtl).unwrap();
        let kind = |name: &str| {
            d.materials
                .iter()
                .find(|m| m.name == name)
                .map(|m| m.kind.clone())
                .unwrap()
        };
        assert_eq!(
            kind("matte"),
            MaterialKind::Diffuse {
                albedo: Vec3::new(0.5, 0.4, 0.3)
            }
        );
        let rough = |ns: f32| (2.0 / (ns + 2.0)).sqrt().sqrt();
        assert_eq!(
            kind("plastic"),
            MaterialKind::MetallicRoughness {
                base: Vec3::new(0.5, 0.4, 0.3),
                metallic: 0.0,
                roughness: rough(98.0),
                transmission: 0.0,
                ior: 1.6
            }
        );
        assert_eq!(
            kind("metal"),
            MaterialKind::MetallicRoughness {
                base: Vec3::new(0.725, 0.71, 0.68),
                metallic: 1.0,
                roughness: rough(200.0),
                transmission: 0.0,
                ior: 1.5
            }
        );
        let MaterialKind::MetallicRoughness {
            base,
            transmission: 1.0,
            ior,
            roughness,
            ..
        } = kind("glass")
        else {
            panic!("{:?}", kind("glass"))
        };
        assert_eq!((base, ior), (Vec3::new(0.9, 1.0, 0.9), 1.45));
        assert!(roughness < 0.04, "Ns 10⁶ is nearly smooth: {roughness}");
        assert_eq!(
            kind("veil"),
            MaterialKind::MetallicRoughness {
                base: Vec3::new(0.2, 0.3, 0.4),
                metallic: 0.0,
                roughness: 1.0,
                transmission: 0.75,
                ior: 1.5
            }
        );
        assert_eq!(
            kind("dull"),
            MaterialKind::Diffuse {
                albedo: Vec3::splat(0.5)
            }
        );
        assert_eq!(d.warnings, ["t.obj: no faces"]);
        // A bad number in any of them names the line.
        let e = load("mtllib t.mtl\n", "newmtl a\nNs x\n").unwrap_err();
        assert!(e.to_string().contains("t.mtl:2"), "{e}");
    }

    #[test]
    fn bad_input_names_the_line() {
        for (obj, want) in [
            ("v 0 0 0\nv 1 nan 0\n", "t.obj:2: not a finite number"),
            ("v 0 0 0\nv 1 x 0\n", "t.obj:2: not a number: \"x\""),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
                "t.obj:4: vertex index 4 is out of range",
            ),
            ("v 0 0 0\nf 1 0 1\n", "t.obj:2: vertex index 0"),
            (
                "v 0 0 0\nv 1 0 0\nf 1 2\n",
                "t.obj:3: a face needs at least 3 vertices",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n",
                "t.obj:4: normal index 1 is out of range",
            ),
            ("v 0 0\n", "t.obj:1: expected 3 numbers, found 2"),
        ] {
            let e = load(obj, "").unwrap_err().to_string();
            assert!(e.starts_with(want), "{e}");
        }
        let e = load("mtllib t.mtl\n", "newmtl a\nKd 1 z 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.mtl:2: not a number"), "{e}");
    }

    /// An OBJ exported from another folder tree names its MTL and texture by paths that do
    /// not exist here: the files of those names beside it are used, each with a warning.
    #[test]
    fn foreign_paths_find_the_files_beside_the_obj() {
        let dir = std::env::temp_dir().join(format!("pt-obj-beside-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        image::RgbImage::from_pixel(1, 1, image::Rgb([255, 0, 0]))
            .save(dir.join("red.png"))
            .unwrap();
        std::fs::write(
            dir.join("paint.mtl"),
            "newmtl paint\nKd 1 1 1\nmap_Kd C:\\project\\textures\\red.png\n",
        )
        .unwrap();
        let obj = dir.join("model.obj");
        std::fs::write(
            &obj,
            "mtllib ../../exported/tree/paint.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl paint\nf 1 2 3\n",
        )
        .unwrap();
        let d = load_file(&obj).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(d.materials[0].name, "paint");
        assert_eq!(d.textures.len(), 1, "the texture is found");
        assert_eq!(d.textures[0].texels[0], Vec3::new(1.0, 0.0, 0.0));
        let found: Vec<_> = d
            .warnings
            .iter()
            .filter(|w| w.contains("beside the OBJ"))
            .collect();
        assert_eq!(found.len(), 2, "{:?}", d.warnings);
        assert!(
            found[0].contains("../../exported/tree/paint.mtl"),
            "{}",
            found[0]
        );
        assert!(found[1].contains("red.png"), "{}", found[1]);
    }

    #[test]
    fn missing_materials_are_warnings_and_grey() {
        let d = parse(
            "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl what\nf 1 2 3\n",
            "t.obj",
            "t",
            &mut |_| Err("gone.mtl: no such file".into()),
        )
        .unwrap();
        assert_eq!(d.warnings.len(), 2, "{:?}", d.warnings);
        assert!(d.warnings[0].starts_with("t.obj:1: cannot read the material library"));
        assert!(d.warnings[1].starts_with("t.obj:5: unknown material \"what\""));
        assert_eq!(
            d.materials[0].kind,
            MaterialKind::Diffuse {
                albedo: Vec3::splat(0.5)
            }
        );
    }

    #[test]
    fn faces_with_normals_shade_with_them() {
        let d = load(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 1 1\nf 1//1 2//2 3//1\n",
            "",
        )
        .unwrap();
        let ShapeDesc::Mesh {
            positions, normals, ..
        } = &d.shapes[0]
        else {
            panic!()
        };
        assert_eq!(positions.len(), 3);
        assert_eq!(
            *normals,
            MeshNormals::Given(vec![
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
                Vec3::new(0.0, 0.0, 1.0)
            ])
        );
    }
}
