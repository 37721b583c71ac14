//! glTF 2.0 (`.gltf` with `.bin` files or data URIs, `.glb`) into a [`SceneDesc`], through the
//! `gltf` crate.
//!
//! Read: the default scene's node tree (or the first scene's; every root node without scenes)
//! with each node's transform; triangle primitives with positions, normals (shading with them;
//! flat without) and indices; the first perspective camera (placed where its node is, looking
//! down the node's −Z, `yfov` over the image height); `KHR_lights_punctual` point, spot and
//! directional lights; materials (below).
//!
//! Materials are glTF's metallic-roughness model ([`crate::bsdf::pbr`]) with their base colour,
//! metallic and roughness factors, `KHR_materials_transmission`'s factor, `KHR_materials_ior`,
//! and emission (`emissiveFactor` × `KHR_materials_emissive_strength`; emissive triangles emit
//! from their front side only). Their textures (PNG or JPEG, in a file, a data URI or a
//! buffer view; bilinear, the sampler's wrap modes) are the base colour (sRGB-decoded),
//! metallic-roughness (blue and green), normal (tangent space, tangents from the texture
//! coordinates; a mesh's `TANGENT` attribute is not read) and emissive (sRGB-decoded) ones;
//! each material's textures read the texture coordinate set its base colour texture names. A
//! texture that cannot be read is a warning, and its factor alone is used. Transmission
//! textures are not read (one warning per file).
//!
//! Errors: what the `gltf` crate reports (JSON path included for validation errors), and
//! non-finite positions or indices out of range, naming the accessor as a JSON pointer.

use crate::error::{Error, Loc, Result};
use crate::io::desc::{
    CameraDesc, LightDesc, LightKind, MaterialDesc, MaterialKind, MeshNormals, SceneDesc,
    ShapeDesc, TextureDesc, TextureSlot, Wrap,
};
use crate::io::image::srgb_to_linear;
use crate::math::Rgb;
use glam::{Mat4, Vec2, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// Loads a `.gltf` or `.glb` file with its buffers (images are not read yet).
pub fn load_file(path: &Path) -> Result<SceneDesc> {
    let (file, bytes, name) = super::read_scene_file(path, "scene")?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse(&bytes, &file, &name, Some(base))
}

/// Parses a `.gltf` or `.glb` held in memory; `base` is the folder that relative buffer URIs
/// are read from (`None`: only data URIs and the GLB's own buffer).
pub fn parse(bytes: &[u8], file: &str, name: &str, base: Option<&Path>) -> Result<SceneDesc> {
    let err = |msg: String| Error::File {
        file: file.to_string(),
        msg,
    };
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| err(e.to_string()))?;
    // The crate's validation indexes a primitive's POSITION accessor before checking it:
    // check every attribute's accessor index here first, then validate.
    let root = document.into_json();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for a in prim.attributes.values() {
                if a.value() >= root.accessors.len() {
                    return Err(err(format!(
                        "/meshes/{m}/primitives/{p}/attributes: accessor {} does not exist",
                        a.value()
                    )));
                }
            }
        }
    }
    let document = gltf::Document::from_json(root).map_err(|e| err(e.to_string()))?;
    // The crate unwraps the percent-decoding of relative URIs: check it here first.
    for b in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = b.source() {
            if !uri.contains(':') && !percent_decodes_to_utf8(uri) {
                return Err(err(format!(
                    "/buffers/{}: the URI is not percent-encoded UTF-8",
                    b.index()
                )));
            }
        }
    }
    // As `gltf::import_buffers`, one buffer at a time, so that errors can name it.
    let mut blob = blob;
    let mut buffers = Vec::new();
    for b in document.buffers() {
        let what = match b.source() {
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => "its data URI".into(),
            gltf::buffer::Source::Uri(uri) => format!("'{uri}'"),
            gltf::buffer::Source::Bin => "the GLB's binary chunk".into(),
        };
        let data =
            gltf::buffer::Data::from_source_and_blob(b.source(), base, &mut blob).map_err(|e| {
                err(match e {
                    gltf::Error::Io(e) => {
                        format!("/buffers/{}: cannot read {what}: {e}", b.index())
                    }
                    gltf::Error::Base64(e) => {
                        format!("/buffers/{}: {what} is not valid base64: {e}", b.index())
                    }
                    e => format!("/buffers/{}: {e}", b.index()),
                })
            })?;
        if data.len() < b.length() {
            return Err(err(format!(
                "/buffers/{}: {what} holds {} bytes, but byteLength is {}",
                b.index(),
                data.len(),
                b.length()
            )));
        }
        buffers.push(data);
    }
    let mut desc = build_desc(&document, &buffers, file, name, base)?;
    if let Some(base) = base {
        // The buffers' files (the textures' are added as they are read).
        let buffers = document.buffers().filter_map(|b| match b.source() {
            gltf::buffer::Source::Uri(uri) => Some(uri),
            gltf::buffer::Source::Bin => None,
        });
        for uri in buffers {
            if let (false, Some(rel)) = (uri.contains(':'), percent_decode(uri)) {
                desc.sources.push(base.join(rel));
            }
        }
    }
    Ok(desc)
}

/// Whether `%XX` decoding of `uri` gives valid UTF-8 (as the `gltf` crate requires).
fn percent_decodes_to_utf8(uri: &str) -> bool {
    percent_decode(uri).is_some()
}

/// `uri` with its `%XX` escapes decoded, if that is UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (
            b[i],
            b.get(i + 1).and_then(|&c| hex(c)),
            b.get(i + 2).and_then(|&c| hex(c)),
        ) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

/// Whether every element of accessor `a` lies inside its buffer view and buffer (the crate's
/// readers assume so). Sparse accessors are refused.
fn fits(a: &gltf::Accessor, buffers: &[gltf::buffer::Data]) -> bool {
    if a.sparse().is_some() {
        return false;
    }
    let Some(view) = a.view() else {
        // No view: all zeros, read without touching a buffer.
        return true;
    };
    let elem = a.size();
    let stride = view.stride().unwrap_or(elem);
    let Some(data) = buffers.get(view.buffer().index()) else {
        return false;
    };
    let view_end = view.offset().checked_add(view.length());
    let last = a
        .count()
        .checked_sub(1)
        .and_then(|n| n.checked_mul(stride))
        .and_then(|x| x.checked_add(a.offset()))
        .and_then(|x| x.checked_add(elem));
    match (view_end, last) {
        (Some(ve), Some(l)) => stride >= elem && ve <= data.len() && l <= view.length(),
        (Some(ve), None) => a.count() == 0 && ve <= data.len(),
        _ => false,
    }
}

/// The texels of a decoded image: 8- and 16-bit images are sRGB-decoded when `srgb` (colour
/// textures) and taken as stored otherwise (data textures), float images are taken as linear; grey images are grey, alpha is dropped. `None` when the pixel
/// data does not hold `width × height` pixels.
fn texels_of(d: &gltf::image::Data, srgb: bool) -> Option<Vec<Rgb>> {
    use gltf::image::Format::*;
    let (channels, bytes) = match d.format {
        R8 => (1, 1),
        R8G8 => (2, 1),
        R8G8B8 => (3, 1),
        R8G8B8A8 => (4, 1),
        R16 => (1, 2),
        R16G16 => (2, 2),
        R16G16B16 => (3, 2),
        R16G16B16A16 => (4, 2),
        R32G32B32FLOAT => (3, 4),
        R32G32B32A32FLOAT => (4, 4),
    };
    let n = (d.width as usize).checked_mul(d.height as usize)?;
    if n == 0 || d.pixels.len() != n * channels * bytes {
        return None;
    }
    let p = &d.pixels;
    let decode = |v: f32| if srgb { srgb_to_linear(v) } else { v };
    let value = |i: usize| -> f32 {
        match bytes {
            1 => decode(p[i] as f32 / 255.0),
            2 => decode(u16::from_ne_bytes([p[2 * i], p[2 * i + 1]]) as f32 / 65535.0),
            _ => {
                let v = f32::from_ne_bytes([p[4 * i], p[4 * i + 1], p[4 * i + 2], p[4 * i + 3]]);
                if v.is_finite() {
                    v.max(0.0)
                } else {
                    0.0
                }
            }
        }
    };
    Some(
        (0..n)
            .map(|k| {
                let at = k * channels;
                if channels < 3 {
                    Vec3::splat(value(at))
                } else {
                    Vec3::new(value(at), value(at + 1), value(at + 2))
                }
            })
            .collect(),
    )
}

/// The texture coordinate set of a material's textures: the one its first texture names
/// (base colour, metallic-roughness, normal, emissive), 0 without textures.
fn uv_set(m: &gltf::Material) -> u32 {
    let pbr = m.pbr_metallic_roughness();
    pbr.base_color_texture()
        .map(|t| t.tex_coord())
        .or_else(|| pbr.metallic_roughness_texture().map(|t| t.tex_coord()))
        .or_else(|| m.normal_texture().map(|t| t.tex_coord()))
        .or_else(|| m.emissive_texture().map(|t| t.tex_coord()))
        .unwrap_or(0)
}

/// `v` clamped to [0, 1], with NaN as 0.
fn finite_unit(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// The JSON pointer of accessor `a` for messages (`/meshes` without one).
fn accessor_pointer(a: Option<gltf::Accessor>) -> String {
    a.map_or("/meshes".to_string(), |a| {
        format!("/accessors/{}", a.index())
    })
}

/// The normals read by `normals` (non-finite ones as zero) when there is one per vertex
/// (`vertex_count`); flat shading otherwise.
fn given_normals(
    normals: Option<gltf::mesh::util::ReadNormals>,
    vertex_count: usize,
) -> MeshNormals {
    match normals {
        Some(n) => {
            let n: Vec<Vec3> = n
                .map(|v| {
                    let v = Vec3::from(v);
                    if v.is_finite() {
                        v
                    } else {
                        Vec3::ZERO
                    }
                })
                .collect();
            if n.len() == vertex_count {
                MeshNormals::Given(n)
            } else {
                MeshNormals::Flat
            }
        }
        None => MeshNormals::Flat,
    }
}

/// The texture coordinates read by `tex_coords` when `usable` (non-finite ones as zero),
/// kept only when there is one per vertex (`vertex_count`); empty otherwise.
fn usable_tex_coords(
    tex_coords: Option<gltf::mesh::util::ReadTexCoords>,
    usable: bool,
    vertex_count: usize,
) -> Vec<Vec2> {
    let uvs: Vec<Vec2> = match tex_coords {
        Some(t) if usable => t
            .into_f32()
            .map(|v| {
                let v = Vec2::from(v);
                if v.is_finite() {
                    v
                } else {
                    Vec2::ZERO
                }
            })
            .collect(),
        _ => Vec::new(),
    };
    if uvs.len() == vertex_count {
        uvs
    } else {
        Vec::new()
    }
}

/// What the node walk gathers.
struct Walk<'a> {
    doc: &'a gltf::Document,
    /// The folder relative image URIs are read from (`None`: only embedded images).
    base: Option<&'a Path>,
    buffers: &'a [gltf::buffer::Data],
    file: &'a str,
    desc: SceneDesc,
    /// glTF material index (`None`: the default material) → description index.
    materials: HashMap<Option<usize>, u32>,
    approximated: bool,
}

impl Walk<'_> {
    fn material(&mut self, m: gltf::Material) -> u32 {
        if let Some(&i) = self.materials.get(&m.index()) {
            return i;
        }
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, _] = pbr.base_color_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        let e = Vec3::from(m.emissive_factor()) * strength;
        if m.transmission()
            .is_some_and(|t| t.transmission_texture().is_some())
        {
            self.approximated = true;
        }
        let name = m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| match m.index() {
                Some(i) => format!("material {i}"),
                None => "default material".into(),
            });
        self.desc.materials.push(MaterialDesc {
            name,
            kind: MaterialKind::MetallicRoughness {
                base: Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE),
                metallic: finite_unit(pbr.metallic_factor()),
                roughness: finite_unit(pbr.roughness_factor()),
                transmission: m
                    .transmission()
                    .map_or(0.0, |t| finite_unit(t.transmission_factor())),
                ior: m
                    .ior()
                    .filter(|i| i.is_finite() && *i >= 1.0)
                    .unwrap_or(1.5),
            },
            emission: if e.is_finite() {
                e.max(Vec3::ZERO)
            } else {
                Vec3::ZERO
            },
            loc: Loc::default(),
            one_sided: false,
            interface: None,
        });
        let i = self.desc.materials.len() as u32 - 1;
        self.materials.insert(m.index(), i);
        let set = uv_set(&m);
        let slots = [
            pbr.base_color_texture()
                .map(|t| (t.texture(), t.tex_coord(), TextureSlot::BaseColor)),
            pbr.metallic_roughness_texture()
                .map(|t| (t.texture(), t.tex_coord(), TextureSlot::MetallicRoughness)),
            m.normal_texture().map(|t| {
                let scale = if t.scale().is_finite() {
                    t.scale()
                } else {
                    1.0
                };
                (
                    t.texture(),
                    t.tex_coord(),
                    TextureSlot::Normal {
                        scale,
                        mitsuba: false,
                    },
                )
            }),
            m.emissive_texture()
                .map(|t| (t.texture(), t.tex_coord(), TextureSlot::Emission)),
        ];
        for (texture, tex_coord, slot) in slots.into_iter().flatten() {
            let what = match slot {
                TextureSlot::BaseColor => "the base colour factor alone is used",
                TextureSlot::MetallicRoughness => {
                    "the metallic and roughness factors alone are used"
                }
                TextureSlot::Normal { .. } => "the mesh's own normals are used",
                TextureSlot::Emission => "the emissive factor alone is used",
                TextureSlot::Alpha { .. } => "the surface is opaque",
                TextureSlot::Bump { .. } | TextureSlot::Displacement => {
                    "the mesh's own normals are used"
                }
                TextureSlot::Number(_) => "the material's number alone is used",
                TextureSlot::Transmittance => "the transmittance factor alone is used",
            };
            if tex_coord != set {
                self.desc.warnings.push(format!(
                    "{}: /textures/{}: reads texture coordinate set {tex_coord}, but a \
                     material's textures share one set here; set {set} is used",
                    self.file,
                    texture.index()
                ));
            }
            match self.texture(texture.clone(), i, slot) {
                Ok((t, file, moved)) => {
                    if let (Some(uri), Some(file)) = (moved, &file) {
                        self.desc.warnings.push(format!(
                            "{}: /textures/{}: \"{uri}\" was not found; {} (the file of that \
                             name beside the glTF) is used",
                            self.file,
                            texture.index(),
                            file.display()
                        ));
                    }
                    self.desc.textures.push(t);
                    self.desc.sources.extend(file);
                }
                Err(e) => self.desc.warnings.push(format!(
                    "{}: /textures/{}: {e}; {what}",
                    self.file,
                    texture.index()
                )),
            }
        }
        i
    }

    /// Decodes a colour texture (sRGB to linear) for material `material`; with the file it
    /// was read from, if it came from one, and the URI it was named by when that file was
    /// found beside the glTF instead ([`Walk::moved_image`]).
    fn texture(
        &self,
        t: gltf::Texture,
        material: u32,
        slot: TextureSlot,
    ) -> std::result::Result<(TextureDesc, Option<std::path::PathBuf>, Option<String>), String>
    {
        let img = t.source();
        // The crate unwraps what it expects of an image; check the JSON first.
        let json = self
            .doc
            .as_json()
            .images
            .get(img.index())
            .ok_or("the image does not exist")?;
        match (&json.uri, &json.buffer_view, &json.mime_type) {
            (Some(uri), None, _) => {
                if !uri.contains(':') && !percent_decodes_to_utf8(uri) {
                    return Err("the image URI is not percent-encoded UTF-8".into());
                }
            }
            (None, Some(v), Some(_)) => {
                let view = self
                    .doc
                    .views()
                    .nth(v.value())
                    .ok_or("the image's buffer view does not exist")?;
                let end = view.offset().checked_add(view.length());
                let len = self.buffers.get(view.buffer().index()).map(|b| b.len());
                if !matches!((end, len), (Some(e), Some(l)) if e <= l) {
                    return Err("the image's buffer view reaches past its buffer".into());
                }
            }
            _ => {
                return Err("an image needs either a URI or a buffer view with a MIME type".into())
            }
        }
        let moved = self.moved_image(json);
        let source = match &moved {
            Some((bare_uri, _)) => gltf::image::Source::Uri {
                uri: bare_uri,
                mime_type: json.mime_type.as_ref().map(|m| m.0.as_str()),
            },
            None => img.source(),
        };
        let d = gltf::image::Data::from_source(source, self.base, self.buffers)
            .map_err(|e| format!("the image cannot be read: {e}"))?;
        let srgb = matches!(slot, TextureSlot::BaseColor | TextureSlot::Emission);
        let texels = texels_of(&d, srgb).ok_or("the image's pixel data has the wrong size")?;
        let wrap = |m: gltf::texture::WrappingMode| match m {
            gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        };
        let s = t.sampler();
        let moved_from = moved.as_ref().and(json.uri.clone());
        let file = match (&json.uri, self.base, moved) {
            (_, _, Some((_, beside))) => Some(beside),
            (Some(uri), Some(base), None) if !uri.contains(':') => {
                percent_decode(uri).map(|r| base.join(r))
            }
            _ => None,
        };
        let desc = TextureDesc {
            name: img
                .name()
                .map(str::to_string)
                .or_else(|| json.uri.clone().filter(|u| !u.starts_with("data:")))
                .unwrap_or_else(|| format!("image {}", img.index())),
            material,
            slot,
            width: d.width,
            height: d.height,
            texels,
            wrap: [wrap(s.wrap_s()), wrap(s.wrap_t())],
            nearest: false,
            uv_transform: None,
        };
        Ok((desc, file, moved_from))
    }

    /// An image whose relative URI names a file that is not there, from another folder tree,
    /// while a file of its bare name lies beside the glTF ([`super::found_beside`]): the
    /// URI's last segment (still percent-encoded) and that file.
    fn moved_image<'j>(
        &self,
        json: &'j gltf::json::Image,
    ) -> Option<(&'j str, std::path::PathBuf)> {
        let uri = json.uri.as_deref().filter(|u| !u.contains(':'))?;
        let beside = super::found_beside(self.base?, &percent_decode(uri)?)?;
        Some((uri.rsplit(['/', '\\']).next().unwrap_or(uri), beside))
    }

    fn mesh(&mut self, mesh: gltf::Mesh, world: Mat4) -> Result<()> {
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                self.desc.warnings.push(format!(
                    "{}: /meshes/{}: a primitive of mode {:?} is skipped (only triangles render)",
                    self.file,
                    mesh.index(),
                    prim.mode()
                ));
                continue;
            }
            self.check_vertex_accessors(&prim)?;
            let buffers = self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let positions = self.finite_positions(&mesh, &prim, reader.read_positions())?;
            let indices = self.checked_indices(&prim, reader.read_indices(), positions.len())?;
            let normals = given_normals(reader.read_normals(), positions.len());
            let triangles: Vec<[u32; 3]> = indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect();
            // Texture coordinates: the set the base colour texture reads (0 without one).
            let set = uv_set(&prim.material());
            let uv_ok = self.check_tex_coords_accessor(&prim, set)?;
            let uvs = usable_tex_coords(reader.read_tex_coords(set), uv_ok, positions.len());
            let m = self.material(prim.material());
            self.desc.shapes.push(ShapeDesc::Mesh {
                uvs,
                name: mesh
                    .name()
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("mesh {}", mesh.index())),
                materials: vec![m; triangles.len()],
                positions,
                triangles,
                normals,
                one_sided: true,
                transform: world,
                loc: Loc::default(),
            });
        }
        Ok(())
    }

    /// Checks that the positions, normals and indices accessors of `prim` have the types
    /// their semantics need and lie inside their buffers (the crate's readers assume so).
    fn check_vertex_accessors(&self, prim: &gltf::Primitive) -> Result<()> {
        // The crate's readers assume each accessor has the type its semantic needs.
        use gltf::accessor::{DataType, Dimensions};
        let typed = |a: Option<gltf::Accessor>, dims: Dimensions, ints: bool| {
            a.is_none_or(|a| {
                a.dimensions() == dims
                    && if ints {
                        matches!(a.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
                    } else {
                        a.data_type() == DataType::F32
                    }
            })
        };
        for (a, dims, ints, what) in [
            (
                prim.get(&gltf::Semantic::Positions),
                Dimensions::Vec3,
                false,
                "positions",
            ),
            (
                prim.get(&gltf::Semantic::Normals),
                Dimensions::Vec3,
                false,
                "normals",
            ),
            (prim.indices(), Dimensions::Scalar, true, "indices"),
        ] {
            if !typed(a.clone(), dims, ints) || !a.as_ref().is_none_or(|a| fits(a, self.buffers)) {
                return Err(Error::File {
                    file: self.file.to_string(),
                    msg: format!(
                        "/accessors/{}: {what} of the wrong type, or reaching past their buffer",
                        a.map_or(0, |a| a.index())
                    ),
                });
            }
        }
        Ok(())
    }

    /// The vertex positions of `prim` in `mesh`, read by `positions`; an error when the
    /// primitive has none or one is not finite.
    fn finite_positions(
        &self,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        positions: Option<gltf::mesh::util::ReadPositions>,
    ) -> Result<Vec<Vec3>> {
        let Some(positions) = positions else {
            return Err(Error::File {
                file: self.file.to_string(),
                msg: format!("/meshes/{}: a primitive without positions", mesh.index()),
            });
        };
        let positions: Vec<Vec3> = positions.map(Vec3::from).collect();
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(Error::File {
                file: self.file.to_string(),
                msg: format!(
                    "{}: a position is not finite",
                    accessor_pointer(prim.get(&gltf::Semantic::Positions))
                ),
            });
        }
        Ok(positions)
    }

    /// The vertex indices of `prim`, read by `indices` (0, 1, 2, … without an index
    /// accessor); an error when one is not below `vertex_count`.
    fn checked_indices(
        &self,
        prim: &gltf::Primitive,
        indices: Option<gltf::mesh::util::ReadIndices>,
        vertex_count: usize,
    ) -> Result<Vec<u32>> {
        let indices: Vec<u32> = match indices {
            Some(i) => i.into_u32().collect(),
            None => (0..vertex_count as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= vertex_count) {
            return Err(Error::File {
                file: self.file.to_string(),
                msg: format!(
                    "{}: index {bad} is out of range ({vertex_count} vertices)",
                    accessor_pointer(prim.indices())
                ),
            });
        }
        Ok(indices)
    }

    /// Whether `prim` has a usable accessor for texture coordinate set `set` (2 floats, or
    /// normalized 8- or 16-bit integers, inside its buffer); an error when it has an unusable one.
    fn check_tex_coords_accessor(&self, prim: &gltf::Primitive, set: u32) -> Result<bool> {
        use gltf::accessor::{DataType, Dimensions};
        let uv_acc = prim.get(&gltf::Semantic::TexCoords(set));
        let uv_ok = uv_acc.as_ref().is_some_and(|a| {
            a.dimensions() == Dimensions::Vec2
                && (a.data_type() == DataType::F32
                    || (a.normalized() && matches!(a.data_type(), DataType::U8 | DataType::U16)))
                && fits(a, self.buffers)
        });
        if uv_acc.is_some() && !uv_ok {
            return Err(Error::File {
                file: self.file.to_string(),
                msg: format!(
                    "{}: texture coordinates of the wrong type, or reaching past their buffer",
                    accessor_pointer(uv_acc)
                ),
            });
        }
        Ok(uv_ok)
    }

    fn node(&mut self, node: gltf::Node, parent: Mat4, depth: usize) -> Result<()> {
        if depth > 256 {
            return Err(Error::File {
                file: self.file.to_string(),
                msg: format!("/nodes/{}: the node tree is deeper than 256", node.index()),
            });
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(Error::File {
                file: self.file.to_string(),
                msg: format!("/nodes/{}: the transform is not finite", node.index()),
            });
        }
        if let Some(mesh) = node.mesh() {
            self.mesh(mesh, world)?;
        }
        if let Some(cam) = node.camera() {
            match cam.projection() {
                gltf::camera::Projection::Perspective(p) if self.desc.camera.is_none() => {
                    let yfov = p.yfov().to_degrees();
                    if !(yfov > 0.0 && yfov < 180.0) {
                        return Err(Error::File {
                            file: self.file.to_string(),
                            msg: format!(
                                "/cameras/{}: yfov {} is not in (0, π)",
                                cam.index(),
                                p.yfov()
                            ),
                        });
                    }
                    self.desc.camera = Some(CameraDesc {
                        name: cam
                            .name()
                            .map(str::to_string)
                            .unwrap_or_else(|| format!("camera {}", cam.index())),
                        xfov_deg: None,
                        yfov_deg: Some(yfov),
                        aspect: p.aspect_ratio(),
                        znear: p.znear(),
                        zfar: p.zfar().unwrap_or(1e4),
                        transform: world,
                        loc: Loc::default(),
                        exact: true,
                        fov_axis: crate::io::desc::FovAxis::Height,
                        right_is_x: false,
                        lens: None,
                        orthographic: false,
                    });
                }
                gltf::camera::Projection::Perspective(_) => {}
                gltf::camera::Projection::Orthographic(_) => self.desc.warnings.push(format!(
                    "{}: /cameras/{}: orthographic cameras are not supported; skipped",
                    self.file,
                    cam.index()
                )),
            }
        }
        if let Some(light) = node.light() {
            let colour = Vec3::from(light.color()) * light.intensity();
            let name = light
                .name()
                .map(str::to_string)
                .unwrap_or_else(|| format!("light {}", light.index()));
            // Directional lights shine along the node's −Z: the direction to the light is its
            // +Z, and LightKind::Directional reads T·(0,0,−1,1), so flip z and drop the
            // translation.
            let rotation = Mat4::from_cols(world.x_axis, world.y_axis, world.z_axis, glam::Vec4::W);
            let (kind, transform) = match light.kind() {
                gltf::khr_lights_punctual::Kind::Point => {
                    (LightKind::Point { intensity: colour }, world)
                }
                gltf::khr_lights_punctual::Kind::Spot {
                    outer_cone_angle, ..
                } => (
                    LightKind::Spot {
                        intensity: colour,
                        falloff_angle_deg: 2.0 * outer_cone_angle.to_degrees(),
                        falloff_exponent: 0.0,
                        falloff_start_deg: None,
                        linear_falloff: false,
                    },
                    world,
                ),
                gltf::khr_lights_punctual::Kind::Directional => (
                    LightKind::Directional { irradiance: colour },
                    rotation * Mat4::from_scale(Vec3::new(1.0, 1.0, -1.0)),
                ),
            };
            if colour.is_finite() {
                self.desc.lights.push(LightDesc {
                    name,
                    kind,
                    transform,
                    loc: Loc::default(),
                });
            }
        }
        for child in node.children() {
            self.node(child, world, depth + 1)?;
        }
        Ok(())
    }
}

/// The description of a loaded glTF document.
pub fn build_desc(
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    file: &str,
    name: &str,
    base: Option<&Path>,
) -> Result<SceneDesc> {
    let mut w = Walk {
        doc,
        base,
        buffers,
        file,
        desc: SceneDesc {
            name: name.to_string(),
            file: file.to_string(),
            ..Default::default()
        },
        materials: HashMap::new(),
        approximated: false,
    };
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    match scene {
        Some(s) => {
            for n in s.nodes() {
                w.node(n, Mat4::IDENTITY, 0)?;
            }
        }
        None => {
            // No scene: every node that is nobody's child.
            let children: std::collections::HashSet<usize> = doc
                .nodes()
                .flat_map(|n| n.children().map(|c| c.index()).collect::<Vec<_>>())
                .collect();
            for n in doc.nodes().filter(|n| !children.contains(&n.index())) {
                w.node(n, Mat4::IDENTITY, 0)?;
            }
        }
    }
    if w.approximated {
        w.desc.warnings.push(format!(
            "{file}: transmission textures are not supported; materials use their \
             transmission factor only"
        ));
    }
    if w.desc.shapes.is_empty() {
        w.desc.warnings.push(format!("{file}: no triangles"));
    }
    Ok(w.desc)
}
