//! Stage two of loading: [`SceneDesc`] → [`Scene`]. Applies transforms, recomputes vertex
//! normals from the faces (CS184 behaviour), turns emitters into lights, places the CS184
//! camera and builds the BVH. One file per concern: `materials` (BSDFs and textures), `shapes`
//! (meshes and spheres), `lights` (the file's lights and emissive shapes' area lights),
//! `camera`.

mod camera;
mod lights;
mod materials;
mod media;
mod objects;
mod shapes;

use super::*;
use crate::accel::bvh::Bvh;
use crate::accel::tribvh::TriangleBvh;
use crate::accel::wide::Bvh4;
use crate::geometry::{Sphere, Triangle};
use crate::io::desc::{SceneDesc, ShapeDesc};
use crate::sampling::Distribution1D;
use glam::Vec2;

/// What [`build`] gathers, in the order the scene's arrays are filled (which fixes every
/// index, so the same description always gives the same scene).
struct Builder<'a> {
    desc: &'a SceneDesc,
    warnings: Vec<String>,
    stats: SceneStats,
    materials: Vec<Material>,
    textures: Vec<texture::Texture>,
    tris: Vec<Triangle>,
    tri_info: Vec<TriInfo>,
    tri_uv: Vec<[Vec2; 3]>,
    /// Whether any mesh has texture coordinates.
    any_uv: bool,
    spheres: Vec<Sphere>,
    sphere_info: Vec<SphereInfo>,
    lights: Vec<Light>,
    bounds: Aabb,
    prototypes: Vec<instance::Prototype>,
    instances: Vec<instance::Instance>,
    media: Vec<crate::medium::Medium>,
    /// The scene's id of each description medium ([`crate::medium::NO_MEDIUM`] where it is
    /// not rendered).
    medium_ids: Vec<u32>,
    camera_medium: u32,
}

/// Builds a renderable scene from a description.
pub fn build(desc: &SceneDesc) -> Scene {
    let mut b = Builder {
        desc,
        warnings: desc.warnings.clone(),
        stats: SceneStats::default(),
        materials: Vec::new(),
        textures: Vec::new(),
        tris: Vec::new(),
        tri_info: Vec::new(),
        tri_uv: Vec::new(),
        any_uv: false,
        spheres: Vec::new(),
        sphere_info: Vec::new(),
        lights: Vec::new(),
        bounds: Aabb::EMPTY,
        prototypes: Vec::new(),
        instances: Vec::new(),
        media: Vec::new(),
        medium_ids: Vec::new(),
        camera_medium: crate::medium::NO_MEDIUM,
    };
    b.media();
    b.materials();
    for shape in &desc.shapes {
        match shape {
            ShapeDesc::Mesh { .. } => b.mesh(shape),
            ShapeDesc::Sphere {
                radius,
                material,
                transform,
                side,
                ..
            } => b.sphere(*radius, *material, transform, *side),
        }
    }
    b.objects();
    b.lights();
    if b.stats.degenerate > 0 {
        b.warnings.push(format!(
            "{}: {} degenerate (zero-area) triangles were dropped",
            desc.file, b.stats.degenerate
        ));
    }
    let camera = b.camera();
    b.finish(camera)
}

impl Builder<'_> {
    /// The scene of what was gathered, with its BVHs and light selection.
    fn finish(mut self, camera: Camera) -> Scene {
        if self.any_uv {
            // Area-light rectangles follow the meshes' triangles.
            self.tri_uv.resize(self.tris.len(), [Vec2::ZERO; 3]);
        } else {
            self.tri_uv = Vec::new();
        }
        let mut scene = Scene {
            name: self.desc.name.clone(),
            tris: self.tris,
            tri_info: self.tri_info,
            tri_uv: self.tri_uv,
            textures: self.textures,
            spheres: self.spheres,
            sphere_info: self.sphere_info,
            materials: self.materials,
            lights: self.lights,
            camera,
            tri_bvh: TriangleBvh::default(),
            sphere_bvh: Bvh4::default(),
            bounds: self.bounds,
            stats: self.stats,
            warnings: self.warnings,
            light_selection: Distribution1D::default(),
            prototypes: self.prototypes,
            instances: self.instances,
            instance_bvh: Bvh4::default(),
            has_alpha: false,
            has_light_blockers: false,
            has_bent_normals: false,
            has_scalar_only: false,
            media: self.media,
            camera_medium: self.camera_medium,
            volumetric: false,
        };
        scene.volumetric = !scene.media.is_empty() || scene.materials.iter().any(|m| m.null);
        scene.has_alpha = scene.materials.iter().any(|m| m.textures.alpha.is_some());
        scene.has_light_blockers = scene
            .materials
            .iter()
            .any(|m| m.textures.alpha.is_some() && m.textures.alpha_blocks_light);
        scene.has_scalar_only = scene.materials.iter().any(|m| m.scalar_only);
        scene.has_bent_normals = scene
            .materials
            .iter()
            .any(|m| m.textures.normal_mitsuba || m.textures.bump.is_some());
        let instance_bounds: Vec<Aabb> = scene
            .instances
            .iter()
            .map(|i| i.world_bounds(&scene.prototypes[i.prototype as usize].bounds))
            .collect();
        scene.instance_bvh = Bvh4::from_binary(&Bvh::build(&instance_bounds), 4);
        scene.tri_bvh = TriangleBvh::build(&scene.tris);
        let sphere_bounds: Vec<Aabb> = scene.spheres.iter().map(|s| s.bounds()).collect();
        scene.sphere_bvh = Bvh4::from_binary(&Bvh::build(&sphere_bounds), 4);
        scene.update_light_selection();
        scene
    }
}
