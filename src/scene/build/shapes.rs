//! Shapes: meshes (transformed to world space, with vertex normals, texture coordinates and
//! one area light per emissive material and side) and spheres.

use super::lights::{area_light, Emitter};
use super::{Builder, Sphere, Triangle};
use crate::io::desc::{EmitSide, MeshNormals, ShapeDesc};
use crate::light::Light;
use crate::scene::{SphereInfo, TriInfo, NO_LIGHT};
use glam::{Mat4, Vec2, Vec3};

/// Area-weighted vertex normals of the world-space faces (CS184), or the file's own
/// (normals transform by the inverse transpose).
fn vertex_normals(
    world: &[Vec3],
    triangles: &[[u32; 3]],
    given: &MeshNormals,
    transform: &Mat4,
) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; world.len()];
    match given {
        MeshNormals::Given(n) if n.len() == world.len() => {
            let it = transform.inverse().transpose();
            for (o, n) in normals.iter_mut().zip(n) {
                *o = it.transform_vector3(*n).normalize_or_zero();
            }
        }
        _ => {
            for t in triangles {
                let c = (world[t[1] as usize] - world[t[0] as usize])
                    .cross(world[t[2] as usize] - world[t[0] as usize]);
                if c.is_finite() {
                    for &i in t {
                        normals[i as usize] += c;
                    }
                }
            }
            for n in &mut normals {
                *n = n.normalize_or_zero();
            }
        }
    }
    normals
}

impl Builder<'_> {
    /// A mesh: its non-degenerate triangles, their shading normals and texture coordinates,
    /// and its emissive materials as one area light each (per side for one-sided emitters).
    pub(super) fn mesh(&mut self, shape: &ShapeDesc) {
        let ShapeDesc::Mesh {
            positions,
            triangles,
            materials: mats,
            transform,
            normals: given,
            one_sided,
            uvs,
            ..
        } = shape
        else {
            return;
        };
        let uvs = (uvs.len() == positions.len()).then_some(uvs);
        self.any_uv |= uvs.is_some();
        self.stats.meshes += 1;
        let world: Vec<Vec3> = positions
            .iter()
            .map(|p| transform.transform_point3(*p))
            .collect();
        let normals = vertex_normals(&world, triangles, given, transform);
        let flat = *given == MeshNormals::Flat;
        // Emissive materials of this mesh become one area light each.
        let mut emitters: Vec<Emitter> = Vec::new();
        for (t, &m) in triangles.iter().zip(mats) {
            let tri = Triangle {
                v: [
                    world[t[0] as usize],
                    world[t[1] as usize],
                    world[t[2] as usize],
                ],
            };
            let area = tri.area();
            if !(area > 0.0 && area.is_finite()) {
                self.stats.degenerate += 1;
                continue;
            }
            self.stats.mesh_triangles += 1;
            self.bounds = self.bounds.union(&tri.bounds());
            let id = self.tris.len() as u32;
            let emission = self.desc.materials[m as usize].emission;
            // A one-sided emitter is one light per material and plane orientation (a light's
            // emitting side is one normal).
            let side = one_sided.then(|| tri.cross().normalize_or_zero());
            let key = side.map(|n| (n * 1e5).round().as_ivec3());
            let light = if emission.max_element() > 0.0 {
                let k = match emitters.iter().position(|e| e.0 == m && e.2 == key) {
                    Some(k) => k,
                    None => {
                        emitters.push((m, Vec::new(), key, side));
                        emitters.len() - 1
                    }
                };
                emitters[k].1.push(id);
                (self.lights.len() + k) as u32
            } else {
                NO_LIGHT
            };
            self.tris.push(tri);
            let n = if flat {
                [tri.cross().normalize_or_zero(); 3]
            } else {
                [
                    normals[t[0] as usize],
                    normals[t[1] as usize],
                    normals[t[2] as usize],
                ]
            };
            self.tri_info
                .push(TriInfo::new(n, tri.unit_normal(), m, light));
            self.tri_uv.push(uvs.map_or([Vec2::ZERO; 3], |uv| {
                [uv[t[0] as usize], uv[t[1] as usize], uv[t[2] as usize]]
            }));
        }
        for (m, ids, _, side) in emitters {
            let texture = self.materials[m as usize].textures.emission;
            let emission = self.desc.materials[m as usize].emission;
            self.lights
                .push(area_light(&self.tris, ids, emission, side, texture));
        }
    }

    /// A sphere (CGL), scaled by the mean of its transform's axis lengths; an emissive one
    /// is also a light. Degenerate spheres are skipped.
    pub(super) fn sphere(&mut self, radius: f32, material: u32, transform: &Mat4, side: EmitSide) {
        let center = transform.transform_point3(Vec3::ZERO);
        let scale = (transform.x_axis.truncate().length()
            + transform.y_axis.truncate().length()
            + transform.z_axis.truncate().length())
            / 3.0;
        let s = Sphere {
            center,
            radius: radius * scale,
        };
        if !(s.radius > 0.0 && s.center.is_finite() && s.radius.is_finite()) {
            return;
        }
        self.bounds = self.bounds.union(&s.bounds());
        let emission = self.desc.materials[material as usize].emission;
        let light = if emission.max_element() > 0.0 {
            self.lights.push(Light::Sphere {
                center: s.center,
                radius: s.radius,
                side: match side {
                    EmitSide::Both => 0.0,
                    EmitSide::Outside => 1.0,
                    EmitSide::Inside => -1.0,
                },
                radiance: emission,
            });
            self.lights.len() as u32 - 1
        } else {
            NO_LIGHT
        };
        self.spheres.push(s);
        self.warn_unbumped(material, "a sphere");
        self.sphere_info.push(SphereInfo {
            material,
            light,
            axes: crate::math::orthonormal_axes(glam::Mat3::from_mat4(*transform)),
            textured: self
                .materials
                .get(material as usize)
                .is_some_and(|m| m.textures != Default::default()),
        });
    }

    /// One warning per material whose displacement (pbrt-v4's bump map) `what` (a sphere, an
    /// instanced object) leaves unrendered.
    pub(super) fn warn_unbumped(&mut self, material: u32, what: &str) {
        let Some(m) = self.materials.get(material as usize) else {
            return;
        };
        if m.textures.displacement.is_some() {
            let warning = format!(
                "{}: material \"{}\": displacement on {what} is not supported yet; its own \
                 normal is used",
                self.desc.file, m.name
            );
            if !self.warnings.contains(&warning) {
                self.warnings.push(warning);
            }
        }
    }
}
