//! pbrt-v4's shapes as description meshes and spheres: `trianglemesh`, `plymesh` (also
//! `.ply.gz`), `bilinearmesh` (each patch as two triangles), `loopsubdiv` (subdivided to its
//! `levels`, shaded smooth), `sphere`, and `disk` and
//! `cylinder` tessellated into [`SEGMENTS`] slices (their area within 10⁻⁴ of the exact one).
//!
//! Winding: a triangle's winding normal in the description is the side pbrt-v4's surface
//! normal faces (which matters for one-sided emitters and for which side of a dielectric is
//! inside): turned to agree with the vertex normals `N` where given; otherwise the object's
//! own winding, reversed by `ReverseOrientation` and by transforms that swap handedness (as
//! pbrt-v4 flips its normals). Texture coordinates become the description's (v down).

use super::{error_at, Interp};
use crate::error::{Error, Result};
use crate::io::desc::{EmitSide, MeshNormals, ShapeDesc};
use crate::io::pbrt::params::Params;
use crate::io::pbrt::Directive;
use glam::{Mat4, Vec2, Vec3};

/// Slices of a tessellated disk or cylinder.
pub const SEGMENTS: usize = 256;

/// A mesh read from a shape's parameters, in object space.
struct Mesh {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    normals: Option<Vec<Vec3>>,
    uvs: Vec<Vec2>,
    /// Without normals: shade smooth (area-weighted vertex normals), not flat.
    smooth: bool,
}

/// A mesh's positions, normals (if given) and texture coordinates.
type Vertices = (Vec<Vec3>, Option<Vec<Vec3>>, Vec<Vec2>);

/// Turns triangles so that their winding normal (after `ctm`) faces pbrt's surface normal.
fn orient(mesh: &mut Mesh, ctm: &Mat4, reverse: bool) {
    match &mesh.normals {
        Some(n) => {
            let it = ctm.inverse().transpose();
            let sign = if reverse { -1.0 } else { 1.0 };
            for t in &mut mesh.triangles {
                let p = t.map(|i| ctm.transform_point3(mesh.positions[i as usize]));
                let winding = (p[1] - p[0]).cross(p[2] - p[0]);
                let normal: Vec3 = t.iter().map(|&i| it.transform_vector3(n[i as usize])).sum();
                if winding.dot(normal) * sign < 0.0 {
                    t.swap(1, 2);
                }
            }
        }
        None => {
            if reverse ^ (ctm.determinant() < 0.0) {
                for t in &mut mesh.triangles {
                    t.swap(1, 2);
                }
            }
        }
    }
}

/// The world-space area of `mesh` under `ctm`.
fn world_area(mesh: &Mesh, ctm: &Mat4) -> f32 {
    mesh.triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| ctm.transform_point3(mesh.positions[i as usize]));
            0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
        })
        .sum()
}

/// `n` points of a parameter's numbers in groups of 3.
fn points(v: &[f64]) -> Vec<Vec3> {
    v.chunks(3)
        .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
        .collect()
}

impl Interp {
    /// `Shape "type" ...`.
    pub(super) fn shape(&mut self, d: &Directive) -> Result<()> {
        let p = Params::new(d);
        let ty = d.args.iter().find_map(|a| match a {
            crate::io::pbrt::Arg::Str(s) => Some(s.clone()),
            _ => None,
        });
        let ty = ty.unwrap_or_default();
        p.ignore(&["emissionfilename"]);
        let interface = self.medium_interface(d, ty == "sphere")?;
        let material = match (self.state.material, interface) {
            (Some(m), None) => self.with_alpha(d, &p, m)?,
            (m, Some(i)) => {
                let m = m.map(|m| self.with_alpha(d, &p, m)).transpose()?;
                self.materials.bounding(&mut self.desc, m, i, d.loc)
            }
            (None, None) => {
                // pbrt's `interface` between equal media bounds nothing: pbrt-v4 skips it.
                p.ignore(&d.params.iter().map(|q| q.name.as_str()).collect::<Vec<_>>());
                return Ok(());
            }
        };
        let area = self.state.area;
        if area.is_some() && self.defining_object() {
            self.warn_once(d, "instanced light", "area lights in object instances are not supported (as in pbrt-v4); these shapes do not emit".into());
        }
        let area = area.filter(|_| !self.defining_object());
        let mesh = if ty == "sphere" {
            self.sphere(d, &p, material, area)?;
            None
        } else {
            self.shape_mesh(d, &p, &ty)?
        };
        self.report_unused(&p);
        if let Some(mesh) = mesh {
            self.add_mesh(d, ty, mesh, material, area);
        }
        Ok(())
    }

    /// The mesh of a shape of type `ty` other than a sphere (`None`, with a warning, for
    /// types not supported).
    fn shape_mesh(&mut self, d: &Directive, p: &Params, ty: &str) -> Result<Option<Mesh>> {
        Ok(Some(match ty {
            "trianglemesh" => self.triangle_mesh(d, p)?,
            "bilinearmesh" => self.bilinear_mesh(p, d)?,
            "loopsubdiv" => {
                let levels = p.int("levels", 3)?.clamp(0, 10) as u32;
                let control = self.triangle_mesh(d, p)?;
                let (positions, triangles) = crate::io::pbrt::subdiv::subdivide(
                    &control.positions,
                    &control.triangles,
                    levels,
                );
                Mesh {
                    positions,
                    triangles,
                    normals: None,
                    uvs: Vec::new(),
                    smooth: true,
                }
            }
            "plymesh" => self.ply_mesh(d, p)?,
            "disk" => disk(p)?,
            "cylinder" => cylinder(p)?,
            other => {
                self.warn_once(
                    d,
                    &format!("shape {other}"),
                    format!("shape \"{other}\" is not supported yet; it is left out"),
                );
                p.ignore(&d.params.iter().map(|q| q.name.as_str()).collect::<Vec<_>>());
                return Ok(None);
            }
        }))
    }

    /// Adds `mesh` (object space) under the current transform, oriented as pbrt-v4 orients
    /// it, emitting under `area` if given.
    fn add_mesh(
        &mut self,
        d: &Directive,
        ty: String,
        mut mesh: Mesh,
        mut material: u32,
        area: Option<super::AreaLight>,
    ) {
        orient(&mut mesh, &self.state.ctm, self.state.reverse);
        if let Some(light) = area {
            let radiance = light.radiance_for(world_area(&mesh, &self.state.ctm));
            material = self.materials.emitting(&mut self.desc, material, radiance);
        }
        let n = mesh.triangles.len();
        self.add_shape(ShapeDesc::Mesh {
            name: ty,
            positions: mesh.positions,
            triangles: mesh.triangles,
            materials: vec![material; n],
            normals: match mesh.normals {
                Some(n) => MeshNormals::Given(n),
                None if mesh.smooth => MeshNormals::Smooth,
                None => MeshNormals::Flat,
            },
            uvs: mesh.uvs,
            one_sided: area.is_none_or(|a| !a.two_sided),
            transform: self.state.ctm,
            loc: d.loc,
        });
    }

    /// The shared vertex data of `trianglemesh` and `bilinearmesh`: positions, normals and
    /// texture coordinates, their counts checked.
    fn vertices(&self, d: &Directive, p: &Params) -> Result<Vertices> {
        let positions = points(
            p.tuples("P", "point3", 3)?
                .ok_or_else(|| error_at(d, "a mesh needs \"point3 P\"".into()))?,
        );
        let count_error = |name: &str, n: usize| {
            let q = p.find(name, &["normal", "point2"]).ok().flatten();
            Error::At {
                file: d.file.display().to_string(),
                loc: q.map_or(d.loc, |q| q.loc),
                msg: format!("\"{name}\" has {n} values for {} vertices", positions.len()),
            }
        };
        let normals = match p.tuples("N", "normal", 3)? {
            Some(n) if n.len() / 3 != positions.len() => return Err(count_error("N", n.len() / 3)),
            n => n.map(points),
        };
        let uvs = match p.tuples("uv", "point2", 2)? {
            Some(uv) if uv.len() / 2 != positions.len() => {
                return Err(count_error("uv", uv.len() / 2))
            }
            Some(uv) => uv
                .chunks(2)
                .map(|c| Vec2::new(c[0] as f32, 1.0 - c[1] as f32))
                .collect(),
            None => Vec::new(),
        };
        p.ignore(&["S", "faceIndices"]);
        Ok((positions, normals, uvs))
    }

    /// A mesh's vertices and its `indices` in polygons of `corners` (3 or 4); without
    /// `indices`, one polygon of exactly that many vertices.
    fn polygons(&self, d: &Directive, p: &Params, corners: usize) -> Result<(Vertices, Vec<u32>)> {
        let vertices = self.vertices(d, p)?;
        let n = vertices.0.len();
        let indices = match p.indices("indices", n)? {
            Some(i) => i,
            None if n == corners => (0..corners as u32).collect(),
            None => {
                return Err(error_at(
                    d,
                    format!("a mesh of {n} vertices needs \"integer indices\""),
                ))
            }
        };
        if indices.len() % corners != 0 {
            return Err(error_at(
                d,
                format!(
                    "\"indices\" has {} values, not a multiple of {corners}",
                    indices.len()
                ),
            ));
        }
        Ok((vertices, indices))
    }

    fn triangle_mesh(&self, d: &Directive, p: &Params) -> Result<Mesh> {
        let ((positions, normals, uvs), indices) = self.polygons(d, p, 3)?;
        Ok(Mesh {
            triangles: indices.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
            positions,
            normals,
            uvs,
            smooth: false,
        })
    }

    /// A `bilinearmesh`, each patch `(p00, p10, p01, p11)` as two triangles.
    fn bilinear_mesh(&self, p: &Params, d: &Directive) -> Result<Mesh> {
        let ((positions, normals, uvs), indices) = self.polygons(d, p, 4)?;
        Ok(Mesh {
            triangles: indices
                .chunks(4)
                .flat_map(|c| [[c[0], c[1], c[3]], [c[0], c[3], c[2]]])
                .collect(),
            positions,
            normals,
            uvs,
            smooth: false,
        })
    }

    fn ply_mesh(&mut self, d: &Directive, p: &Params) -> Result<Mesh> {
        let file = p
            .string("filename")?
            .ok_or_else(|| error_at(d, "plymesh needs \"string filename\"".into()))?;
        if p.find("displacement", &["texture", "float"])?.is_some() {
            self.warn_once(
                d,
                "displacement",
                "plymesh \"displacement\" is not supported yet; ignored".into(),
            );
        }
        p.ignore(&["edgelength"]);
        let path = Interp::folder(d).join(file);
        let ply = crate::io::ply::load_file(&path)
            .map_err(|e| error_at(d, format!("plymesh \"{file}\": {e}")))?;
        if !self.desc.sources.contains(&path) {
            self.desc.sources.push(path);
        }
        let Some(ShapeDesc::Mesh {
            positions,
            triangles,
            normals,
            uvs,
            ..
        }) = ply.shapes.into_iter().next()
        else {
            return Err(error_at(d, format!("{file}: no mesh")));
        };
        Ok(Mesh {
            positions,
            triangles,
            normals: match normals {
                MeshNormals::Given(n) => Some(n),
                _ => None,
            },
            uvs,
            smooth: false,
        })
    }

    fn sphere(
        &mut self,
        d: &Directive,
        p: &Params,
        mut material: u32,
        area: Option<super::AreaLight>,
    ) -> Result<()> {
        let radius = p.float("radius", 1.0)?;
        let (zmin, zmax, phimax) = (
            p.float("zmin", -radius)?,
            p.float("zmax", radius)?,
            p.float("phimax", 360.0)?,
        );
        if zmin > -radius || zmax < radius || phimax < 360.0 {
            self.warn_once(d, "partial sphere", "partial spheres (zmin, zmax, phimax) are not supported yet; the whole sphere is rendered".into());
        }
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(error_at(
                d,
                format!("sphere radius must be positive, not {radius}"),
            ));
        }
        let ctm = self.state.ctm;
        if let Some(light) = area {
            let scale = (ctm.x_axis.truncate().length()
                + ctm.y_axis.truncate().length()
                + ctm.z_axis.truncate().length())
                / 3.0;
            let world_area = 4.0 * std::f32::consts::PI * (radius * scale).powi(2);
            let radiance = light.radiance_for(world_area);
            material = self.materials.emitting(&mut self.desc, material, radiance);
        }
        self.add_shape(ShapeDesc::Sphere {
            name: "sphere".into(),
            radius,
            material,
            side: if area.is_none_or(|a| a.two_sided) {
                EmitSide::Both
            } else if self.state.reverse ^ (self.state.ctm.determinant() < 0.0) {
                EmitSide::Inside
            } else {
                EmitSide::Outside
            },
            transform: self.state.ctm,
            loc: d.loc,
        });
        Ok(())
    }
}

/// pbrt's `disk` (`height`, `radius`, `innerradius`, `phimax`) facing +Z.
fn disk(p: &Params) -> Result<Mesh> {
    let (h, r, ri, phimax) = (
        p.float("height", 0.0)?,
        p.float("radius", 1.0)?,
        p.float("innerradius", 0.0)?,
        p.float("phimax", 360.0)?.clamp(0.0, 360.0).to_radians(),
    );
    let n = SEGMENTS;
    let mut m = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: None,
        uvs: Vec::new(),
        smooth: false,
    };
    for i in 0..=n {
        let phi = phimax * i as f32 / n as f32;
        let (s, c) = phi.sin_cos();
        m.positions.push(Vec3::new(r * c, r * s, h));
        m.positions.push(Vec3::new(ri * c, ri * s, h));
        let u = i as f32 / n as f32;
        m.uvs.push(Vec2::new(u, 1.0));
        m.uvs.push(Vec2::new(u, 0.0));
    }
    for i in 0..n as u32 {
        let (o0, i0, o1, i1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        m.triangles.push([i0, o0, o1]);
        if ri > 0.0 {
            m.triangles.push([i0, o1, i1]);
        }
    }
    Ok(m)
}

/// pbrt's `cylinder` (`radius`, `zmin`, `zmax`, `phimax`) about the Z axis, normals outward.
fn cylinder(p: &Params) -> Result<Mesh> {
    let (r, z0, z1, phimax) = (
        p.float("radius", 1.0)?,
        p.float("zmin", -1.0)?,
        p.float("zmax", 1.0)?,
        p.float("phimax", 360.0)?.clamp(0.0, 360.0).to_radians(),
    );
    let n = SEGMENTS;
    let mut m = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
        normals: Some(Vec::new()),
        uvs: Vec::new(),
        smooth: false,
    };
    for i in 0..=n {
        let phi = phimax * i as f32 / n as f32;
        let (s, c) = phi.sin_cos();
        for (z, v) in [(z0, 1.0), (z1, 0.0)] {
            m.positions.push(Vec3::new(r * c, r * s, z));
            m.normals.as_mut().expect("set").push(Vec3::new(c, s, 0.0));
            m.uvs.push(Vec2::new(i as f32 / n as f32, v));
        }
    }
    for i in 0..n as u32 {
        let (a0, a1, b0, b1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        m.triangles.push([a0, b0, b1]);
        m.triangles.push([a0, b1, a1]);
    }
    Ok(m)
}
