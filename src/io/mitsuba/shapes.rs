//! Shape plugins as description meshes and spheres: `obj`, `ply`, `serialized` (with
//! `shape_index`; all with `face_normals`,
//! `flip_normals`, `flip_tex_coords`), `rectangle` (`[−1, 1]²` in the xy-plane, facing +Z),
//! `cube` (`[−1, 1]³`), `disk` (unit, facing +Z), `cylinder` (`p0`, `p1`, `radius`; open,
//! facing out) and `sphere` (`center`, `radius`) under `to_world`; `shapegroup` and
//! `instance` share geometry. An `<emitter type="area">` inside a shape makes it emit
//! `radiance` from its front side (the side its normal faces; `flip_normals` turns it).
//!
//! Winding: the description's winding normal is Mitsuba's normal. Built-in shapes' normals
//! follow `to_world`'s inverse transpose, so their winding is reversed under a mirroring
//! transform; meshes keep the winding of their file.

use super::xml::Node;
use super::Interp;
use crate::error::Result;
use crate::io::desc::{EmitSide, InstanceDesc, MeshNormals, ObjectDesc, ShapeDesc};
use crate::math::Rgb;
use glam::{Mat4, Vec2, Vec3};

/// Slices of a tessellated disk or cylinder.
pub const SEGMENTS: usize = 256;

/// A mesh in object space.
struct Mesh {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    normals: MeshNormals,
    uvs: Vec<Vec2>,
}

impl<'a> Interp<'a> {
    /// A shape (`group`: the shape group it belongs to, if any).
    pub(super) fn shape(&mut self, node: &'a Node, group: Option<u32>) -> Result<()> {
        match node.plugin.as_str() {
            "shapegroup" if group.is_some() => {
                Err(self
                    .doc
                    .error(node, node.loc, "a shapegroup cannot be inside another"))
            }
            "shapegroup" => self.group(node).map(|_| ()),
            "instance" => self.instance(node, group),
            _ => self.geometry(node, group),
        }
    }

    /// The object of shape group `node`, made on first use.
    fn group(&mut self, node: &'a Node) -> Result<u32> {
        let index = self
            .doc
            .nodes
            .iter()
            .position(|n| std::ptr::eq(n, node))
            .unwrap_or(usize::MAX);
        if let Some(&g) = self.groups.get(&index) {
            return Ok(g);
        }
        self.count(node);
        let g = self.desc.objects.len() as u32;
        self.desc.objects.push(ObjectDesc {
            name: node.id.clone().unwrap_or_else(|| "shapegroup".into()),
            shapes: Vec::new(),
        });
        self.groups.insert(index, g);
        let shapes: Vec<usize> = self.children(node, "shape").map(|c| c.0).collect();
        for s in shapes {
            self.shape(self.node(s), Some(g))?;
        }
        Ok(g)
    }

    fn instance(&mut self, node: &'a Node, group: Option<u32>) -> Result<()> {
        self.count(node);
        if group.is_some() {
            return Err(self.doc.error(
                node,
                node.loc,
                "an instance cannot be inside a shapegroup",
            ));
        }
        let target: Vec<usize> = self.children(node, "shape").map(|c| c.0).collect();
        let [g] = target[..] else {
            return Err(self
                .doc
                .error(node, node.loc, "instance needs one <ref> to a shapegroup"));
        };
        let g = self.node(g);
        if g.plugin != "shapegroup" {
            return Err(self.doc.error(
                node,
                node.loc,
                format!("instance refers to a \"{}\", not a shapegroup", g.plugin),
            ));
        }
        let object = self.group(g)?;
        let transform = self.to_world(node)?;
        self.desc.instances.push(InstanceDesc {
            object,
            transform,
            loc: node.loc,
        });
        Ok(())
    }

    /// The shape's material (its BSDF emitting its area emitter's radiance, bounding its
    /// media; `inwards`: its normals point inside, which swaps them).
    fn shape_material(
        &mut self,
        node: &'a Node,
        group: Option<u32>,
        inwards: bool,
    ) -> Result<(u32, bool)> {
        let bsdfs: Vec<usize> = self.children(node, "bsdf").map(|c| c.0).collect();
        if bsdfs.len() > 1 {
            self.warn_once(
                node,
                node.loc,
                "bsdfs",
                "a shape with several BSDFs: the first is used",
            );
        }
        let emitters: Vec<usize> = self.children(node, "emitter").map(|c| c.0).collect();
        let mut radiance = Rgb::ZERO;
        if let Some(&e) = emitters.first() {
            let e = self.node(e);
            self.count(e);
            if e.plugin != "area" {
                return Err(self.doc.error(
                    e,
                    e.loc,
                    format!("a shape's emitter must be \"area\", not \"{}\"", e.plugin),
                ));
            }
            radiance = self.colour_opt(e, "radiance")?.unwrap_or(Rgb::ONE);
            if group.is_some() {
                self.warn_once(
                    e,
                    e.loc,
                    "group emitter",
                    "emitters inside a shapegroup are not supported; the shape does not emit",
                );
                radiance = Rgb::ZERO;
            }
        }
        let mut material = self.material(bsdfs.first().copied(), radiance)?;
        if let Some(interface) = self.shape_media(node, inwards)? {
            let null = bsdfs
                .first()
                .is_some_and(|&b| self.node(b).plugin == "null");
            material = self.bounding(material, null, interface);
        }
        Ok((material, radiance != Rgb::ZERO))
    }

    fn geometry(&mut self, node: &'a Node, group: Option<u32>) -> Result<()> {
        self.count(node);
        let to_world = self.to_world(node)?;
        let flip = self.bool(node, "flip_normals", false)?;
        let mirrored = to_world.determinant() < 0.0;
        let mesh = match node.plugin.as_str() {
            "sphere" => return self.sphere(node, group, to_world, flip),
            "rectangle" => built_in(rectangle(), mirrored),
            "cube" => built_in(cube(), mirrored),
            "disk" => built_in(disk(), mirrored),
            "cylinder" => {
                let (p0, p1) = (
                    self.vector_opt(node, "p0")?.unwrap_or_default().as_vec3(),
                    self.vector_opt(node, "p1")?
                        .unwrap_or(glam::DVec3::Z)
                        .as_vec3(),
                );
                let radius = self.float(node, "radius", 1.0)?;
                let placed = cylinder_frame(p0, p1, radius).ok_or_else(|| {
                    self.doc.error(
                        node,
                        node.loc,
                        "cylinder: p0 equals p1 or the radius is not positive",
                    )
                })?;
                let m = built_in(cylinder(), mirrored ^ (placed.determinant() < 0.0));
                return self.add_mesh(node, group, m, to_world * placed, flip);
            }
            "obj" | "ply" => self.mesh_file(node)?,
            "serialized" => self.serialized(node)?,
            _ => {
                self.unsupported(node, "ignored");
                return Ok(());
            }
        };
        self.add_mesh(node, group, mesh, to_world, flip)
    }

    fn add_mesh(
        &mut self,
        node: &'a Node,
        group: Option<u32>,
        mut mesh: Mesh,
        transform: Mat4,
        flip: bool,
    ) -> Result<()> {
        let (material, emits) = self.shape_material(node, group, false)?;
        if flip {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
            if let MeshNormals::Given(n) = &mut mesh.normals {
                n.iter_mut().for_each(|v| *v = -*v);
            }
        }
        let n = mesh.triangles.len();
        let shape = ShapeDesc::Mesh {
            name: node.id.clone().unwrap_or_else(|| node.plugin.clone()),
            positions: mesh.positions,
            triangles: mesh.triangles,
            materials: vec![material; n],
            normals: mesh.normals,
            uvs: mesh.uvs,
            one_sided: emits,
            transform,
            loc: node.loc,
        };
        self.push_shape(shape, group);
        Ok(())
    }

    fn push_shape(&mut self, shape: ShapeDesc, group: Option<u32>) {
        match group {
            Some(g) => self.desc.objects[g as usize].shapes.push(shape),
            None => self.desc.shapes.push(shape),
        }
    }

    fn sphere(
        &mut self,
        node: &'a Node,
        group: Option<u32>,
        to_world: Mat4,
        flip: bool,
    ) -> Result<()> {
        let center = self
            .vector_opt(node, "center")?
            .unwrap_or_default()
            .as_vec3();
        let radius = self.float(node, "radius", 1.0)?;
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(self.doc.error(
                node,
                node.loc,
                format!("sphere radius must be positive, not {radius}"),
            ));
        }
        let (material, emits) = self.shape_material(node, group, flip)?;
        let inside = flip ^ (to_world.determinant() < 0.0);
        let shape = ShapeDesc::Sphere {
            name: node.id.clone().unwrap_or_else(|| "sphere".into()),
            radius,
            side: match (emits, inside) {
                (false, _) => EmitSide::Both,
                (true, false) => EmitSide::Outside,
                (true, true) => EmitSide::Inside,
            },
            material,
            transform: to_world * Mat4::from_translation(center),
            loc: node.loc,
        };
        self.push_shape(shape, group);
        Ok(())
    }

    /// A `serialized` file's shape `shape_index`.
    fn serialized(&mut self, node: &'a Node) -> Result<Mesh> {
        let Some(file) = self.string(node, "filename")? else {
            return Err(self
                .doc
                .error(node, node.loc, "serialized needs a \"filename\""));
        };
        let index = self.int(node, "shape_index", 0)?;
        let face_normals = self.bool(node, "face_normals", false)?;
        let path = self.doc.folder(node).join(file);
        let bytes = std::fs::read(&path).map_err(|e| {
            self.doc.error(
                node,
                node.loc,
                format!("serialized \"{}\": {e}", path.display()),
            )
        })?;
        let index = usize::try_from(index).map_err(|_| {
            self.doc.error(
                node,
                node.loc,
                format!("shape_index must not be negative, not {index}"),
            )
        })?;
        let m = super::serialized::read(&bytes, index).map_err(|e| {
            self.doc
                .error(node, node.loc, format!("{}: {e}", path.display()))
        })?;
        if !self.desc.sources.contains(&path) {
            self.desc.sources.push(path);
        }
        Ok(Mesh {
            positions: m.positions,
            triangles: m.triangles,
            normals: match m.normals {
                Some(n) if !face_normals => MeshNormals::Given(n),
                _ if face_normals => MeshNormals::Flat,
                _ => MeshNormals::Smooth,
            },
            uvs: m.uvs,
        })
    }

    /// An `obj` or `ply` file's geometry (its materials are not used).
    fn mesh_file(&mut self, node: &'a Node) -> Result<Mesh> {
        let Some(file) = self.string(node, "filename")? else {
            return Err(self.doc.error(
                node,
                node.loc,
                format!("{} needs a \"filename\"", node.plugin),
            ));
        };
        let path = self.doc.folder(node).join(file);
        let face_normals = self.bool(node, "face_normals", false)?;
        let flip_uv = self.bool(node, "flip_tex_coords", true)?;
        let loaded = if node.plugin == "obj" {
            let (_, bytes, name) = crate::io::read_scene_file(&path, "mesh")
                .map_err(|e| self.doc.error(node, node.loc, e.to_string()))?;
            let text = String::from_utf8_lossy(&bytes);
            crate::io::obj::parse(&text, &path.display().to_string(), &name, &mut |_| {
                Err("material libraries are not read for Mitsuba shapes".into())
            })
        } else {
            crate::io::ply::load_file(&path)
        }
        .map_err(|e| {
            self.doc
                .error(node, node.loc, format!("{}: {e}", node.plugin))
        })?;
        if !self.desc.sources.contains(&path) {
            self.desc.sources.push(path);
        }
        let mut mesh = Mesh {
            positions: Vec::new(),
            triangles: Vec::new(),
            normals: MeshNormals::Flat,
            uvs: Vec::new(),
        };
        let mut given: Vec<Vec3> = Vec::new();
        let mut all_given = true;
        for s in loaded.shapes {
            let ShapeDesc::Mesh {
                positions,
                triangles,
                normals,
                uvs,
                transform,
                ..
            } = s
            else {
                continue;
            };
            let base = mesh.positions.len() as u32;
            let count = positions.len();
            mesh.positions
                .extend(positions.into_iter().map(|p| transform.transform_point3(p)));
            mesh.triangles
                .extend(triangles.into_iter().map(|t| t.map(|i| i + base)));
            if uvs.len() == count {
                mesh.uvs.resize(base as usize, Vec2::ZERO);
                mesh.uvs.extend(uvs.into_iter().map(|uv| {
                    if flip_uv {
                        uv
                    } else {
                        Vec2::new(uv.x, 1.0 - uv.y)
                    }
                }));
            }
            match normals {
                MeshNormals::Given(n) if n.len() == count => {
                    given.extend(n.into_iter().map(|v| transform.transform_vector3(v)))
                }
                _ => all_given = false,
            }
        }
        if !mesh.uvs.is_empty() {
            mesh.uvs.resize(mesh.positions.len(), Vec2::ZERO);
        }
        mesh.normals = if face_normals {
            MeshNormals::Flat
        } else if all_given && given.len() == mesh.positions.len() {
            MeshNormals::Given(given)
        } else {
            MeshNormals::Smooth
        };
        Ok(mesh)
    }
}

/// A built-in shape's mesh, its winding reversed under a mirroring transform.
fn built_in(mut m: Mesh, mirrored: bool) -> Mesh {
    if mirrored {
        for t in &mut m.triangles {
            t.swap(1, 2);
        }
    }
    m
}

/// `[−1, 1]²` at z = 0, facing +Z; uv `((x + 1)/2, (y + 1)/2)`.
fn rectangle() -> Mesh {
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    Mesh {
        positions: corners.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        normals: MeshNormals::Flat,
        uvs: corners
            .iter()
            .map(|&(x, y)| Vec2::new(0.5 * (x + 1.0), 0.5 * (y + 1.0)))
            .collect(),
    }
}

/// `[−1, 1]³`, faces outward, each face's uv over the whole square.
fn cube() -> Mesh {
    let mut m = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: MeshNormals::Flat,
        uvs: Vec::new(),
    };
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let n = Vec3::from_array(std::array::from_fn(|i| if i == axis { sign } else { 0.0 }));
            let (u, v) = (n.any_orthonormal_pair().0, n.any_orthonormal_pair().1);
            let base = m.positions.len() as u32;
            for (a, b, uv) in [
                (-1.0, -1.0, (0.0, 1.0)),
                (1.0, -1.0, (1.0, 1.0)),
                (1.0, 1.0, (1.0, 0.0)),
                (-1.0, 1.0, (0.0, 0.0)),
            ] {
                m.positions.push((n + u * a + v * b).round());
                m.uvs.push(Vec2::new(uv.0, uv.1));
            }
            let t = if u.cross(v).dot(n) > 0.0 {
                [[0, 1, 2], [0, 2, 3]]
            } else {
                [[0, 2, 1], [0, 3, 2]]
            };
            m.triangles.extend(t.map(|t| t.map(|i| i + base)));
        }
    }
    m
}

/// The unit disk at z = 0, facing +Z.
fn disk() -> Mesh {
    let mut m = Mesh {
        positions: vec![Vec3::ZERO],
        triangles: Vec::new(),
        normals: MeshNormals::Flat,
        uvs: vec![Vec2::ZERO],
    };
    for i in 0..=SEGMENTS {
        let phi = std::f32::consts::TAU * i as f32 / SEGMENTS as f32;
        let (s, c) = phi.sin_cos();
        m.positions.push(Vec3::new(c, s, 0.0));
        m.uvs.push(Vec2::new(1.0, i as f32 / SEGMENTS as f32));
    }
    for i in 1..=SEGMENTS as u32 {
        m.triangles.push([0, i, i + 1]);
    }
    m
}

/// The open unit cylinder from z = 0 to 1 about the Z axis, facing out, shaded smooth.
fn cylinder() -> Mesh {
    let mut m = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: MeshNormals::Given(Vec::new()),
        uvs: Vec::new(),
    };
    let mut normals = Vec::new();
    for i in 0..=SEGMENTS {
        let phi = std::f32::consts::TAU * i as f32 / SEGMENTS as f32;
        let (s, c) = phi.sin_cos();
        for z in [0.0, 1.0] {
            m.positions.push(Vec3::new(c, s, z));
            normals.push(Vec3::new(c, s, 0.0));
            m.uvs.push(Vec2::new(i as f32 / SEGMENTS as f32, z));
        }
    }
    for i in 0..SEGMENTS as u32 {
        let (a0, a1, b0, b1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        m.triangles.push([a0, b0, b1]);
        m.triangles.push([a0, b1, a1]);
    }
    m.normals = MeshNormals::Given(normals);
    m
}

/// Places the unit cylinder between `p0` and `p1` with `radius`.
fn cylinder_frame(p0: Vec3, p1: Vec3, radius: f32) -> Option<Mat4> {
    let d = p1 - p0;
    let length = d.length();
    if !(length > 0.0 && radius > 0.0 && length.is_finite() && radius.is_finite()) {
        return None;
    }
    let z = d / length;
    let (x, y) = z.any_orthonormal_pair();
    Some(Mat4::from_cols(
        (x * radius).extend(0.0),
        (y * radius).extend(0.0),
        d.extend(0.0),
        p0.extend(1.0),
    ))
}
