//! Instancing: objects whose triangles are held once (a prototype, with its own BVH) and
//! placed many times by transforms (instances), found through a BVH over the instances'
//! world bounds — a two-level BVH. A ray is taken into an instance's space by the inverse
//! transform without renormalising its direction, so hit distances are the world's.
//!
//! Shading at an instance hit: position by the transform; geometric and shading normals by
//! its inverse transpose (which turns them as the flattened copy's winding normal would be
//! turned after pbrt-v4's orientation rule, see `io::pbrt::scene::shapes`). Instances do not emit
//! (as in pbrt-v4).

use super::{Hit, Surface, TriInfo, NO_LIGHT};
use crate::accel::tribvh::TriangleBvh;
use crate::geometry::Triangle;
use crate::math::{Aabb, Ray};
use glam::{Mat3, Mat4, Vec2, Vec3};

/// Marks a hit that is not in an instance.
pub const NO_INSTANCE: u32 = u32::MAX;

/// The shared triangles of an object, in its own space.
#[derive(Clone, Debug)]
pub struct Prototype {
    /// Its name in the file.
    pub name: String,
    /// Triangles, object space.
    pub tris: Vec<Triangle>,
    /// Shading data per triangle, object space (lights are [`NO_LIGHT`]).
    pub tri_info: Vec<TriInfo>,
    /// Texture coordinates per triangle; empty when it has none.
    pub tri_uv: Vec<[Vec2; 3]>,
    /// Its BVH.
    pub bvh: TriangleBvh,
    /// Bounds of its triangles.
    pub bounds: Aabb,
}

/// A placed copy of a prototype.
#[derive(Clone, Copy, Debug)]
pub struct Instance {
    /// Index into [`super::Scene::prototypes`].
    pub prototype: u32,
    /// Object to world.
    pub to_world: Mat4,
    /// World to object.
    pub to_object: Mat4,
    /// The normals' transform (inverse transpose of `to_world`'s linear part).
    pub normals: Mat3,
}

impl Instance {
    /// An instance of `prototype` placed by `to_world`; `None` for a singular transform.
    pub fn new(prototype: u32, to_world: Mat4) -> Option<Instance> {
        let det = to_world.determinant();
        if !(det.is_finite() && det.abs() > 1e-20) {
            return None;
        }
        let to_object = to_world.inverse();
        Some(Instance {
            prototype,
            to_world,
            to_object,
            normals: Mat3::from_mat4(to_object).transpose(),
        })
    }

    /// World bounds of the prototype's `bounds` under this instance's transform.
    pub fn world_bounds(&self, bounds: &Aabb) -> Aabb {
        bounds.corners().iter().fold(Aabb::EMPTY, |b, &c| {
            b.grow(self.to_world.transform_point3(c))
        })
    }

    /// `ray` in the instance's space (same parameter `t`).
    #[inline]
    pub fn local_ray(&self, ray: &Ray) -> Ray {
        Ray {
            o: self.to_object.transform_point3(ray.o),
            d: self.to_object.transform_vector3(ray.d),
            t_min: ray.t_min,
            t_max: ray.t_max,
        }
    }
}

impl Prototype {
    /// The shading point of triangle `prim` at barycentrics `(b1, b2)`, in world space through
    /// `inst`.
    pub fn surface(&self, inst: &Instance, hit: &Hit) -> Surface {
        let tri = &self.tris[hit.prim as usize];
        let info = &self.tri_info[hit.prim as usize];
        let b0 = 1.0 - hit.b1 - hit.b2;
        let p = tri.v[0] * b0 + tri.v[1] * hit.b1 + tri.v[2] * hit.b2;
        let ns = if info.flat {
            info.n[0]
        } else {
            info.n[0] * b0 + info.n[1] * hit.b1 + info.n[2] * hit.b2
        };
        let ng = (inst.normals * info.ng).normalize_or(Vec3::Z);
        let ns = (inst.normals * ns).normalize_or(ng);
        let ns = if ns.dot(ng) < 0.0 { -ns } else { ns };
        let uv = self
            .tri_uv
            .get(hit.prim as usize)
            .map_or(Vec2::ZERO, |t| t[0] * b0 + t[1] * hit.b1 + t[2] * hit.b2);
        Surface {
            p: inst.to_world.transform_point3(p),
            ng,
            ns,
            material: info.material,
            light: NO_LIGHT,
            uv,
            prim: (hit.prim, hit.instance),
        }
    }
}
