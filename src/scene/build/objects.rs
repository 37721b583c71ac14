//! Objects and their instances: each object's meshes become one prototype (its triangles
//! once, with their own BVH); each instance places it. Spheres of an object are copied into
//! the world per instance (they are a few numbers each).

use super::Builder;
use crate::io::desc::{EmitSide, ShapeDesc};
use crate::math::Aabb;
use crate::scene::instance::{Instance, Prototype};
use crate::scene::NO_LIGHT;

impl Builder<'_> {
    /// The description's objects as prototypes and its instances as placed copies.
    pub(super) fn objects(&mut self) {
        let desc = self.desc;
        let mut spheres_of = Vec::new();
        for object in &desc.objects {
            spheres_of.push(self.prototype(object));
        }
        for inst in &desc.instances {
            let k = inst.object as usize;
            let (Some(proto), Some(spheres)) = (self.prototypes.get(k), spheres_of.get(k)) else {
                continue;
            };
            let Some(placed) = Instance::new(inst.object, inst.transform) else {
                self.warnings.push(format!(
                    "{}:{}: an instance of '{}' has a singular transform; ignored",
                    desc.file, inst.loc, proto.name
                ));
                continue;
            };
            if !proto.tris.is_empty() {
                self.bounds = self.bounds.union(&placed.world_bounds(&proto.bounds));
                self.instances.push(placed);
                self.stats.instances += 1;
            }
            for &(radius, material, t) in spheres {
                self.sphere(radius, material, &(inst.transform * t), EmitSide::Both);
            }
        }
    }

    /// Object `object`'s meshes as a prototype (pushed to `self.prototypes`); returns its
    /// spheres as `(radius, material, transform)` for the instances to copy.
    fn prototype(&mut self, object: &crate::io::desc::ObjectDesc) -> Vec<(f32, u32, glam::Mat4)> {
        // The mesh builder fills the scene's arrays: give it empty ones and take them back.
        let tris = std::mem::take(&mut self.tris);
        let info = std::mem::take(&mut self.tri_info);
        let uv = std::mem::take(&mut self.tri_uv);
        let any_uv = std::mem::replace(&mut self.any_uv, false);
        let bounds = std::mem::replace(&mut self.bounds, Aabb::EMPTY);
        let lights = self.lights.len();
        let mut spheres = Vec::new();
        for shape in &object.shapes {
            match shape {
                ShapeDesc::Mesh { .. } => self.mesh(shape),
                ShapeDesc::Sphere {
                    radius,
                    material,
                    transform,
                    ..
                } => spheres.push((*radius, *material, *transform)),
            }
        }
        if self.lights.len() > lights {
            self.lights.truncate(lights);
            self.warnings.push(format!(
                "{}: object '{}' has emitting shapes; instances do not emit",
                self.desc.file, object.name
            ));
        }
        let mut proto = Prototype {
            name: object.name.clone(),
            tris: std::mem::replace(&mut self.tris, tris),
            tri_info: std::mem::replace(&mut self.tri_info, info),
            tri_uv: std::mem::replace(&mut self.tri_uv, uv),
            bvh: Default::default(),
            bounds: std::mem::replace(&mut self.bounds, bounds),
        };
        let materials: std::collections::BTreeSet<u32> =
            proto.tri_info.iter().map(|t| t.material).collect();
        for m in materials {
            self.warn_unbumped(m, "an instanced object");
        }
        for t in &mut proto.tri_info {
            t.light = NO_LIGHT;
        }
        if !std::mem::replace(&mut self.any_uv, any_uv) {
            proto.tri_uv = Vec::new();
        }
        proto.bvh = crate::accel::tribvh::TriangleBvh::build(&proto.tris);
        self.prototypes.push(proto);
        spheres
    }
}
