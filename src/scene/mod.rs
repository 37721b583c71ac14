//! The built, renderable scene: world-space triangles and spheres, materials, lights, camera,
//! an 8-wide BVH over the triangles (packed leaves) and a 4-wide one over the spheres.

pub mod build;
pub mod bump;
pub mod instance;
pub mod texture;

use crate::accel::tribvh::TriangleBvh;
use crate::accel::wide::Bvh4;
use crate::bsdf::{Bsdf, Param};
use crate::camera::Camera;
use crate::geometry::{Sphere, Triangle};
use crate::guide::EnvGuide;
use crate::light::env::EnvLight;
use crate::light::{Light, LightSample};
use crate::math::{Aabb, Ray, Rgb};
use crate::sampling::Distribution1D;
use glam::Vec3;
use instance::NO_INSTANCE;

/// Marks "no light" in per-primitive light ids.
pub const NO_LIGHT: u32 = u32::MAX;

/// A material: how a surface scatters and what it emits.
#[derive(Clone, Debug)]
pub struct Material {
    /// Name from the scene file.
    pub name: String,
    /// Scattering.
    pub bsdf: Bsdf,
    /// Textures of [`Scene::textures`] that modulate it.
    pub textures: MaterialTextures,
    /// pbrt-v4's `mix`: this material is one of two others, chosen per shading point.
    pub mix: Option<Mix>,
    /// Black from behind (see [`crate::io::desc::MaterialDesc::one_sided`]).
    pub one_sided: bool,
    /// Mitsuba's `twosided` with two BSDFs: the materials seen from the front and from
    /// behind.
    pub sides: Option<(u32, u32)>,
    /// One-sided, two-sided with two materials, or with Mitsuba's normal-map shadowing: the
    /// packet integrator leaves its vertices to the scalar one.
    pub scalar_only: bool,
    /// The media on its two sides where they differ (a medium boundary).
    pub interface: Option<crate::medium::MediumInterface>,
    /// Only bounds media: rays pass through it as if it were not there ([`Bsdf::Black`]
    /// for everything else).
    pub null: bool,
}

/// A stochastic mix of two materials (pbrt-v4's `mix`): at each shading point, material `b`
/// with probability `amount`, else `a`, chosen by a hash of the point (deterministic, and
/// in expectation over the points of a pixel the mixture).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mix {
    /// Chosen with probability `1 − amount`.
    pub a: u32,
    /// Chosen with probability `amount`.
    pub b: u32,
    /// The probability of `b`, in [0, 1].
    pub amount: f32,
}

/// A uniform number in [0, 1) from the bits of a point and a material id.
fn hash_point(p: Vec3, material: u32) -> f32 {
    use crate::sampling::{hash_to_unit, mix64, vec3_bits};
    hash_to_unit(mix64(vec3_bits(p) ^ ((material as u64) << 7)))
}

/// The textures of a material, as indices into [`Scene::textures`] (see
/// [`crate::io::desc::TextureSlot`] for their conventions).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaterialTextures {
    /// Multiplies the albedo of a diffuse BSDF, the base colour of a metallic-roughness or
    /// principled one, a plastic's or coating's diffuse base, a conductor's tint.
    pub base: Option<u32>,
    /// Blue multiplies a metallic-roughness BSDF's metalness, green its roughness.
    pub metallic_roughness: Option<u32>,
    /// A tangent-space normal map and its scale.
    pub normal: Option<(u32, f32)>,
    /// The normal map follows Mitsuba's convention (see
    /// [`crate::io::desc::TextureSlot::Normal`]).
    pub normal_mitsuba: bool,
    /// Mitsuba's bump map (a height texture) and its scale.
    pub bump: Option<(u32, f32)>,
    /// pbrt-v4's displacement texture (see [`bump`]).
    pub displacement: Option<u32>,
    /// Multiplies a diffuse transmitter's transmittance.
    pub transmittance: Option<u32>,
    /// Multiplies the emitted radiance (set on the material's area lights).
    pub emission: Option<u32>,
    /// An alpha cut-out: its red channel is the surface's opacity (see
    /// [`Scene::intersect`]).
    pub alpha: Option<u32>,
    /// The cut-out draws a number per surface crossed, not one per ray (see
    /// [`crate::io::desc::TextureSlot::Alpha`]).
    pub alpha_per_crossing: bool,
    /// The cut-out blocks light-sampling rays wherever they meet it, holes included (see
    /// [`crate::io::desc::TextureSlot::Alpha`]).
    pub alpha_blocks_light: bool,
    /// Number parameters set per shading point: a texture (its red) and the parameter, the
    /// used entries first.
    pub numbers: [Option<(u32, Param)>; MAX_NUMBER_TEXTURES],
}

/// The most number parameters of one material that textures set.
pub const MAX_NUMBER_TEXTURES: usize = 4;

/// Shading data of one triangle.
#[derive(Clone, Copy, Debug)]
pub struct TriInfo {
    /// Unit vertex normals (recomputed from the faces, CS184 style).
    pub n: [Vec3; 3],
    /// Unit geometric normal ([`Triangle::unit_normal`]).
    pub ng: Vec3,
    /// Material id.
    pub material: u32,
    /// Light id when the triangle emits, else [`NO_LIGHT`].
    pub light: u32,
    /// Whether the three vertex normals are one unit vector (`n[0]`), which is then the
    /// shading normal everywhere on the triangle, with no interpolation or normalisation.
    pub flat: bool,
}

/// Vertex normals whose components all agree to within this make a [`TriInfo::flat`]
/// triangle: normals recomputed from the faces of a planar mesh differ by rounding only, and
/// interpolating them could move the normal by no more than this.
const FLAT_NORMALS: f32 = 1e-6;

impl TriInfo {
    /// Shading data from vertex normals `n` (unit, or zero where undefined) and the unit
    /// geometric normal `ng`. Vertex normals that agree to `FLAT_NORMALS` are replaced by
    /// their normalised mean (`ng` where that is zero) and marked [`TriInfo::flat`].
    pub fn new(n: [Vec3; 3], ng: Vec3, material: u32, light: u32) -> TriInfo {
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() <= FLAT_NORMALS;
        let flat = close(n[0], n[1]) && close(n[1], n[2]) && close(n[0], n[2]);
        TriInfo {
            n: if flat {
                [(n[0] + n[1] + n[2]).normalize_or(ng); 3]
            } else {
                n
            },
            ng,
            material,
            light,
            flat,
        }
    }
}

/// Shading data of one sphere.
#[derive(Clone, Copy, Debug)]
pub struct SphereInfo {
    /// Material id.
    pub material: u32,
    /// Light id when the sphere emits, else [`NO_LIGHT`].
    pub light: u32,
    /// The sphere's own axes in the world (unit columns): its texture coordinates are
    /// `(φ / 2π, θ / π)` about its z axis (φ from x towards y, θ from +z), as pbrt-v4's and
    /// Mitsuba's in the description's convention.
    pub axes: glam::Mat3,
    /// Its material has textures (its texture coordinates are computed only then).
    pub textured: bool,
}

/// A ray hit: distance, primitive id (triangles first, then spheres) and barycentrics.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f32,
    /// Primitive id: `< tris.len()` is a triangle, else sphere `prim − tris.len()`.
    pub prim: u32,
    /// Barycentric weight of vertex 1 (triangles).
    pub b1: f32,
    /// Barycentric weight of vertex 2 (triangles).
    pub b2: f32,
    /// The instance hit ([`instance::NO_INSTANCE`] for the scene's own primitives); `prim`
    /// is then a triangle of its prototype.
    pub instance: u32,
}

/// A shading point.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// Position.
    pub p: Vec3,
    /// Unit geometric normal (orientation as stored, not flipped to the viewer).
    pub ng: Vec3,
    /// Unit shading normal, on the same side as `ng`.
    pub ns: Vec3,
    /// Material id.
    pub material: u32,
    /// Light id or [`NO_LIGHT`].
    pub light: u32,
    /// Texture coordinates (see [`texture`]); zero where the mesh has none.
    pub uv: glam::Vec2,
    /// The primitive hit and its instance ([`Hit::prim`], [`Hit::instance`]), for the
    /// surface's tangent ([`Scene::tangent`]).
    pub prim: (u32, u32),
}

impl Surface {
    /// The surface as seen from the side of `w` (a unit direction away from it): whether that
    /// is the outside (`ng`'s side), the geometric normal turned to it, and the shading frame
    /// whose normal is the shading normal turned to the same side.
    #[inline]
    pub fn facing(&self, w: Vec3) -> (bool, Vec3, crate::math::Frame) {
        let (front, ng, ns) = crate::lanes::facing(self.ng.into(), self.ns.into(), w.into());
        (front, ng.into(), crate::math::Frame::from_normal(ns.into()))
    }
}

/// Counts of what a scene holds, for `--info`.
#[derive(Clone, Debug, Default)]
pub struct SceneStats {
    /// Triangles from meshes (area-light rectangles not included).
    pub mesh_triangles: usize,
    /// Mesh instances.
    pub meshes: usize,
    /// Degenerate triangles dropped.
    pub degenerate: usize,
    /// Material counts by type name.
    pub materials_by_type: Vec<(String, usize)>,
    /// Light counts by type name (as in the file).
    pub lights_by_type: Vec<(String, usize)>,
    /// Placed instances of shared objects.
    pub instances: usize,
    /// The plugins the file used, with counts (Mitsuba scenes; see
    /// [`crate::io::desc::SceneDesc::plugins`]).
    pub plugins: Vec<String>,
}

/// A renderable scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Scene name (file stem or "cornell").
    pub name: String,
    /// All triangles, world space.
    pub tris: Vec<Triangle>,
    /// Shading data per triangle.
    pub tri_info: Vec<TriInfo>,
    /// All spheres, world space.
    pub spheres: Vec<Sphere>,
    /// Shading data per sphere.
    pub sphere_info: Vec<SphereInfo>,
    /// Texture coordinates of each triangle's vertices; empty when no mesh has any.
    pub tri_uv: Vec<[glam::Vec2; 3]>,
    /// Textures, referenced by [`Material::textures`].
    pub textures: Vec<texture::Texture>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Lights. Add lights with [`Scene::add_light`] (or call
    /// [`Scene::update_light_selection`] after changing this list), so that power-proportional
    /// light selection knows them.
    pub lights: Vec<Light>,
    /// The CS184 camera.
    pub camera: Camera,
    /// The 8-wide BVH over `tris`, with packed leaves.
    pub tri_bvh: TriangleBvh,
    /// The 4-wide BVH over `spheres` (primitive `i` is sphere `i`).
    pub sphere_bvh: Bvh4,
    /// Bounds of the scene geometry (area-light rectangles excluded), used to place the camera.
    pub bounds: Aabb,
    /// Counts for `--info`.
    pub stats: SceneStats,
    /// Warnings from loading and building, each naming the file.
    pub warnings: Vec<String>,
    /// Light choice in proportion to emitted power (see [`Scene::add_light`]).
    pub light_selection: Distribution1D,
    /// Objects shared by instances ([`instance`]).
    pub prototypes: Vec<instance::Prototype>,
    /// Placed copies of the prototypes.
    pub instances: Vec<instance::Instance>,
    /// The 4-wide BVH over the instances' world bounds.
    pub instance_bvh: Bvh4,
    /// Whether any material has a Mitsuba normal or bump map (see [`Scene::shadowing`]).
    pub has_bent_normals: bool,
    /// Whether any material is [`Material::scalar_only`] (one-sided, two materials, bent
    /// normals).
    pub has_scalar_only: bool,
    /// Whether any material has an alpha cut-out (rays then test the hits they find).
    pub has_alpha: bool,
    /// Whether any cut-out blocks light-sampling rays ([`Scene::light_occluded`]).
    pub has_light_blockers: bool,
    /// Participating media, referenced by [`Material::interface`] and
    /// [`Scene::camera_medium`].
    pub media: Vec<crate::medium::Medium>,
    /// The medium the camera sits in, or [`crate::medium::NO_MEDIUM`].
    pub camera_medium: u32,
    /// Whether it needs the volumetric path tracer (`volpath`): it has media or
    /// surfaces that only bound them.
    pub volumetric: bool,
}

/// Most cut-out surfaces one ray passes through before it is taken as blocked.
const MAX_CUTOUTS: usize = 64;

/// A uniform number in [0, 1) from a ray's origin and direction.
fn hash_ray(ray: &Ray) -> f32 {
    use crate::sampling::{hash_to_unit, mix64, vec3_bits};
    hash_to_unit(mix64(vec3_bits(ray.o) ^ mix64(vec3_bits(ray.d))))
}

/// `(∂p/∂u, ∂p/∂v)` of triangle `tri` with texture coordinates `t`; `None` where the
/// coordinates are degenerate.
#[inline]
fn uv_derivatives(tri: &Triangle, t: &[glam::Vec2; 3]) -> Option<(Vec3, Vec3)> {
    let (dp1, dp2) = (tri.v[1] - tri.v[0], tri.v[2] - tri.v[0]);
    let (d1, d2) = (t[1] - t[0], t[2] - t[0]);
    let det = d1.x * d2.y - d1.y * d2.x;
    if det.abs() < 1e-12 {
        return None;
    }
    Some((
        (dp1 * d2.y - dp2 * d1.y) / det,
        (dp2 * d1.x - dp1 * d2.x) / det,
    ))
}

/// Up to this many spheres are tested one by one instead of through their BVH.
const FEW_SPHERES: usize = 4;

impl Scene {
    /// Adds a light (an environment map, say) and updates the power-proportional selection.
    pub fn add_light(&mut self, light: Light) {
        self.lights.push(light);
        self.update_light_selection();
    }

    /// Loads the environment map at `path` (see [`crate::light::env::load`]) and adds it as a
    /// light; returns the loader's warnings (each naming the file).
    pub fn add_environment(
        &mut self,
        path: &std::path::Path,
        sampling: crate::light::env::EnvSampling,
    ) -> crate::error::Result<Vec<String>> {
        let (env, warnings) = crate::light::env::load(path, sampling)?;
        self.add_light(Light::Environment(env));
        Ok(warnings)
    }

    /// Recomputes [`Scene::light_selection`] from the lights' powers.
    pub fn update_light_selection(&mut self) {
        let radius = if self.bounds.is_empty() {
            1.0
        } else {
            0.5 * self.bounds.extent().length()
        };
        let powers: Vec<f32> = self.lights.iter().map(|l| l.power(radius)).collect();
        self.light_selection = Distribution1D::new(&powers);
    }

    /// Probability that power selection picks light `j`.
    #[inline]
    pub fn light_pmf(&self, j: usize) -> f32 {
        if self.light_selection.total() > 0.0 && j < self.light_selection.len() {
            self.light_selection.pmf(j)
        } else {
            0.0
        }
    }

    /// Closest hit along `ray` within `(t_min, t_max)`. A triangle wins an exact tie with a
    /// sphere (spheres are tested only closer than the triangle hit).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.has_alpha || !self.instances.is_empty() {
            return self.intersect_general(ray);
        }
        self.intersect_own(ray)
    }

    /// [`Scene::intersect`] in scenes with instances or cut-outs (kept out of line: the
    /// common case is only the scene's own primitives).
    #[inline(never)]
    fn intersect_general(&self, ray: &Ray) -> Option<Hit> {
        if self.has_alpha {
            return self.intersect_through_cutouts(ray).0;
        }
        self.intersect_opaque(ray)
    }

    /// [`Scene::intersect`] for a path's continuation ray, and whether the ray passed through
    /// a hole of a cut-out that blocks light-sampling rays on its way: light sampling could
    /// not have reached what it finds, so its emission is not weighed against light sampling.
    #[inline]
    pub fn intersect_continuation(&self, ray: &Ray) -> (Option<Hit>, bool) {
        if self.has_light_blockers {
            return self.intersect_through_cutouts(ray);
        }
        (self.intersect(ray), false)
    }

    /// True when anything blocks light-sampling ray `ray` within `(t_min, t_max)`: as
    /// [`Scene::occluded`], and where the ray meets a cut-out that blocks light-sampling rays
    /// (Mitsuba's `mask` and `null`, whose shadow rays stop at them), holes included.
    #[inline]
    pub fn light_occluded(&self, ray: &Ray) -> bool {
        if self.has_light_blockers {
            let (hit, passed) = self.intersect_through_cutouts(ray);
            return hit.is_some() || passed;
        }
        self.occluded(ray)
    }

    /// [`Scene::intersect`] taking every surface as opaque.
    #[inline]
    fn intersect_opaque(&self, ray: &Ray) -> Option<Hit> {
        let hit = self.intersect_own(ray);
        if self.instances.is_empty() {
            hit
        } else {
            self.intersect_instances(ray, hit)
        }
    }

    /// The closest hit that an alpha cut-out does not remove: hits are found in order along
    /// the ray, each kept where its material's alpha `a` at the hit is 1, dropped where it is
    /// 0, and kept with probability `a` between (by a hash of the ray, as pbrt-v4 does; with
    /// the crossing's index too for per-crossing cut-outs, as Mitsuba's masks). Also whether
    /// the ray passed through a hole of a cut-out that blocks light-sampling rays.
    #[inline(never)]
    fn intersect_through_cutouts(&self, ray: &Ray) -> (Option<Hit>, bool) {
        let mut r = *ray;
        let u = hash_ray(ray);
        let mut passed = false;
        for crossing in 0..MAX_CUTOUTS {
            let Some(hit) = self.intersect_opaque(&r) else {
                return (None, passed);
            };
            let (material, uv) = self.hit_material_uv(&r, &hit);
            let textures = &self.materials[material as usize].textures;
            let Some(t) = textures.alpha else {
                return (Some(hit), passed);
            };
            let u = if textures.alpha_per_crossing {
                use crate::sampling::{hash_to_unit, mix64};
                hash_to_unit(mix64(u.to_bits() as u64 ^ mix64(crossing as u64 + 1)))
            } else {
                u
            };
            let a = self.textures[t as usize].eval(uv).x;
            if a >= 1.0 || (a > 0.0 && u < a) {
                return (Some(hit), passed);
            }
            passed |= textures.alpha_blocks_light;
            r.t_min = hit.t * (1.0 + 1e-6) + f32::MIN_POSITIVE;
            if r.t_min >= r.t_max {
                return (None, passed);
            }
        }
        (None, passed)
    }

    /// The material and texture coordinates of a hit of `ray`.
    fn hit_material_uv(&self, ray: &Ray, hit: &Hit) -> (u32, glam::Vec2) {
        let (b0, b1, b2) = (1.0 - hit.b1 - hit.b2, hit.b1, hit.b2);
        let at = |t: &[glam::Vec2; 3]| t[0] * b0 + t[1] * b1 + t[2] * b2;
        if hit.instance != NO_INSTANCE {
            let inst = &self.instances[hit.instance as usize];
            let proto = &self.prototypes[inst.prototype as usize];
            let uv = proto
                .tri_uv
                .get(hit.prim as usize)
                .map_or(glam::Vec2::ZERO, at);
            return (proto.tri_info[hit.prim as usize].material, uv);
        }
        let ntri = self.tris.len() as u32;
        if hit.prim < ntri {
            let uv = self
                .tri_uv
                .get(hit.prim as usize)
                .map_or(glam::Vec2::ZERO, at);
            (self.tri_info[hit.prim as usize].material, uv)
        } else {
            let i = (hit.prim - ntri) as usize;
            let (p, _) = self.spheres[i].project(ray.at(hit.t));
            (self.sphere_info[i].material, self.sphere_uv(i, p))
        }
    }

    /// [`Scene::intersect`] on the scene's own triangles and spheres.
    #[inline]
    fn intersect_own(&self, ray: &Ray) -> Option<Hit> {
        let mut hit = self.tri_bvh.closest(ray).map(|h| Hit {
            t: h.t,
            prim: h.prim,
            b1: h.b1,
            b2: h.b2,
            instance: NO_INSTANCE,
        });
        if !self.spheres.is_empty() {
            let ntri = self.tris.len() as u32;
            let mut r = *ray;
            r.t_max = hit.map_or(ray.t_max, |h| h.t);
            if self.spheres.len() <= FEW_SPHERES {
                // A handful of spheres: testing them all beats a traversal.
                for (p, s) in self.spheres.iter().enumerate() {
                    if let Some(t) = s.intersect(&r, r.t_max) {
                        r.t_max = t;
                        hit = Some(Hit {
                            t,
                            prim: ntri + p as u32,
                            b1: 0.0,
                            b2: 0.0,
                            instance: NO_INSTANCE,
                        });
                    }
                }
                return hit;
            }
            self.sphere_bvh.closest(&r, |p, t_max| {
                let t = self.spheres[p as usize].intersect(&r, t_max)?;
                hit = Some(Hit {
                    t,
                    prim: ntri + p,
                    b1: 0.0,
                    b2: 0.0,
                    instance: NO_INSTANCE,
                });
                Some(t)
            });
        }
        hit
    }

    /// The closest of `hit` and the instances' hits along `ray`.
    #[inline(never)]
    fn intersect_instances(&self, ray: &Ray, mut hit: Option<Hit>) -> Option<Hit> {
        let mut r = *ray;
        r.t_max = hit.map_or(ray.t_max, |h| h.t);
        self.instance_bvh.closest(&r, |i, t_max| {
            let inst = &self.instances[i as usize];
            let proto = &self.prototypes[inst.prototype as usize];
            let mut local = inst.local_ray(ray);
            local.t_max = t_max;
            let h = proto.bvh.closest(&local)?;
            hit = Some(Hit {
                t: h.t,
                prim: h.prim,
                b1: h.b1,
                b2: h.b2,
                instance: i,
            });
            Some(h.t)
        });
        hit
    }

    /// True when an instance blocks `ray`.
    #[inline(never)]
    fn occluded_instances(&self, ray: &Ray) -> bool {
        self.instance_bvh.any(ray, |i| {
            let inst = &self.instances[i as usize];
            self.prototypes[inst.prototype as usize]
                .bvh
                .any(&inst.local_ray(ray))
        })
    }

    /// True when anything blocks `ray` within `(t_min, t_max)`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.has_alpha || !self.instances.is_empty() {
            return self.occluded_general(ray);
        }
        self.occluded_own(ray)
    }

    /// [`Scene::occluded`] in scenes with instances or cut-outs.
    #[inline(never)]
    fn occluded_general(&self, ray: &Ray) -> bool {
        if self.has_alpha {
            return self.intersect_through_cutouts(ray).0.is_some();
        }
        self.occluded_own(ray) || self.occluded_instances(ray)
    }

    /// [`Scene::occluded`] by the scene's own triangles and spheres.
    #[inline]
    fn occluded_own(&self, ray: &Ray) -> bool {
        if self.spheres.len() <= FEW_SPHERES {
            return self
                .spheres
                .iter()
                .any(|s| s.intersect(ray, ray.t_max).is_some())
                || self.tri_bvh.any(ray);
        }
        self.tri_bvh.any(ray)
            || (!self.spheres.is_empty()
                && self.sphere_bvh.any(ray, |p| {
                    self.spheres[p as usize].intersect(ray, ray.t_max).is_some()
                }))
    }

    /// The shading point of `hit` on `ray`.
    #[inline(always)]
    pub fn surface(&self, ray: &Ray, hit: &Hit) -> Surface {
        let ntri = self.tris.len() as u32;
        if hit.instance != NO_INSTANCE {
            self.instance_surface(hit)
        } else if hit.prim < ntri {
            let tri = &self.tris[hit.prim as usize];
            let info = &self.tri_info[hit.prim as usize];
            let b0 = 1.0 - hit.b1 - hit.b2;
            let p = tri.v[0] * b0 + tri.v[1] * hit.b1 + tri.v[2] * hit.b2;
            let ng = info.ng;
            let ns = if info.flat {
                info.n[0]
            } else {
                (info.n[0] * b0 + info.n[1] * hit.b1 + info.n[2] * hit.b2).normalize_or(ng)
            };
            let mut ns = if ns.dot(ng) < 0.0 { -ns } else { ns };
            let mut uv = glam::Vec2::ZERO;
            if let Some(t) = self.tri_uv.get(hit.prim as usize) {
                uv = t[0] * b0 + t[1] * hit.b1 + t[2] * hit.b2;
                let textures = &self.materials[info.material as usize].textures;
                let bent = match (textures.normal, textures.bump, textures.displacement) {
                    (Some(map), _, _) => {
                        Some(self.mapped_normal(tri, t, ns, ng, uv, map, textures.normal_mitsuba))
                    }
                    (None, Some(bump), _) => Some(self.bumped_normal(tri, t, ns, ng, uv, bump)),
                    (None, None, Some(d)) => {
                        let d = &self.textures[d as usize];
                        let normals = (!info.flat).then_some(info.n);
                        let b = [b0, hit.b1, hit.b2];
                        let displacement = (d.eval(uv).x, d.gradient(uv));
                        bump::bumped_normal(tri.v, t, normals, ng, b, displacement)
                    }
                    (None, None, None) => None,
                };
                if let Some(bent) = bent {
                    ns = bent;
                }
            }
            Surface {
                p,
                ng,
                ns,
                material: info.material,
                light: info.light,
                uv,
                prim: (hit.prim, NO_INSTANCE),
            }
        } else {
            let i = (hit.prim - ntri) as usize;
            let s = &self.spheres[i];
            let (p, n) = s.project(ray.at(hit.t));
            Surface {
                p,
                ng: n,
                ns: n,
                material: self.sphere_info[i].material,
                light: self.sphere_info[i].light,
                uv: if self.sphere_info[i].textured {
                    self.sphere_uv(i, p)
                } else {
                    glam::Vec2::ZERO
                },
                prim: (hit.prim, NO_INSTANCE),
            }
        }
    }

    /// The shading point of a hit in an instance.
    #[inline(never)]
    fn instance_surface(&self, hit: &Hit) -> Surface {
        let inst = &self.instances[hit.instance as usize];
        self.prototypes[inst.prototype as usize].surface(inst, hit)
    }

    /// pbrt-v4's `∂p/∂u` at surface `s` (world space, not unit): from a triangle's texture
    /// coordinates, or `v₁ − v₀` without them (pbrt-v4's default coordinates); around a
    /// sphere's world Z axis. Anisotropic BSDFs align their first axis with it.
    pub fn tangent(&self, s: &Surface) -> Vec3 {
        let (prim, instance) = s.prim;
        let of_triangle = |tri: &Triangle, uv: Option<&[glam::Vec2; 3]>| {
            let Some(t) = uv else {
                return tri.v[1] - tri.v[0];
            };
            let (dp1, dp2) = (tri.v[1] - tri.v[0], tri.v[2] - tri.v[0]);
            let (d1, d2) = (t[1] - t[0], t[2] - t[0]);
            let det = d1.x * d2.y - d1.y * d2.x;
            // The description's v runs down the image: pbrt's ∂p/∂u is the same along u.
            if det.abs() < 1e-12 {
                dp1
            } else {
                (dp1 * d2.y - dp2 * d1.y) / det
            }
        };
        if instance != NO_INSTANCE {
            let inst = &self.instances[instance as usize];
            let proto = &self.prototypes[inst.prototype as usize];
            let t = of_triangle(&proto.tris[prim as usize], proto.tri_uv.get(prim as usize));
            return inst.to_world.transform_vector3(t);
        }
        let ntri = self.tris.len() as u32;
        if prim < ntri {
            of_triangle(&self.tris[prim as usize], self.tri_uv.get(prim as usize))
        } else {
            let i = (prim - ntri) as usize;
            self.sphere_info[i]
                .axes
                .z_axis
                .cross(s.p - self.spheres[i].center)
        }
    }

    /// Texture coordinates of point `p` on sphere `i` (see [`SphereInfo::axes`]).
    #[inline(never)]
    fn sphere_uv(&self, i: usize, p: Vec3) -> glam::Vec2 {
        let d = (p - self.spheres[i].center) / self.spheres[i].radius;
        let local = self.sphere_info[i].axes.transpose() * d;
        let phi = local.y.atan2(local.x).rem_euclid(std::f32::consts::TAU);
        let theta = local.z.clamp(-1.0, 1.0).acos();
        glam::Vec2::new(phi / std::f32::consts::TAU, theta / std::f32::consts::PI)
    }

    /// The shading normal at `uv` of triangle `tri` (texture coordinates `t`) under the
    /// tangent-space normal map `map` (and its scale): tangent `∂p/∂u` and bitangent `−∂p/∂v`
    /// (the image's up; `ns × tangent` for Mitsuba's maps), made orthonormal about the
    /// interpolated normal `ns`. Keeps `ns` where the
    /// coordinates are degenerate or the mapped normal would face away from `ng`.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn mapped_normal(
        &self,
        tri: &Triangle,
        t: &[glam::Vec2; 3],
        ns: Vec3,
        ng: Vec3,
        uv: glam::Vec2,
        (map, scale): (u32, f32),
        mitsuba: bool,
    ) -> Vec3 {
        let Some((dpdu, dpdv)) = uv_derivatives(tri, t) else {
            return ns;
        };
        let tangent = (dpdu - ns * ns.dot(dpdu)).normalize_or_zero();
        if tangent == Vec3::ZERO {
            return ns;
        }
        let b = ns.cross(tangent);
        let bitangent = if !mitsuba && b.dot(dpdv) > 0.0 { -b } else { b };
        let c = self.textures[map as usize].eval(uv) * 2.0 - Vec3::ONE;
        let n =
            (tangent * (c.x * scale) + bitangent * (c.y * scale) + ns * c.z).normalize_or_zero();
        if n.dot(ng) > 1e-3 && n.is_finite() {
            n
        } else {
            ns
        }
    }

    /// Mitsuba's shadowing term at `s` for light along `wi` (world), where its material has
    /// a Mitsuba normal or bump map: `2 / (1 + √(1 + α² tan²θᵢ))` with
    /// `α² = min(tan²θ / 8, 1)` of the bent normal's angle θ to the unbent one and θᵢ
    /// measured from the unbent normal; 1 elsewhere.
    #[inline]
    pub fn shadowing(&self, s: &Surface, wi: Vec3) -> f32 {
        if !self.has_bent_normals {
            return 1.0;
        }
        self.bent_shadowing(s, wi)
    }

    #[inline(never)]
    fn bent_shadowing(&self, s: &Surface, wi: Vec3) -> f32 {
        let textures = &self.materials[s.material as usize].textures;
        let (prim, instance) = s.prim;
        if !(textures.normal_mitsuba || textures.bump.is_some())
            || instance != NO_INSTANCE
            || prim as usize >= self.tris.len()
        {
            return 1.0;
        }
        let (tri, info) = (&self.tris[prim as usize], &self.tri_info[prim as usize]);
        let unbent = if info.flat {
            info.n[0]
        } else {
            // The hit's barycentric coordinates from its point.
            let (e1, e2, d) = (tri.v[1] - tri.v[0], tri.v[2] - tri.v[0], s.p - tri.v[0]);
            let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let (d1, d2) = (d.dot(e1), d.dot(e2));
            let det = d11 * d22 - d12 * d12;
            if det.abs() < 1e-30 {
                return 1.0;
            }
            let (b1, b2) = ((d22 * d1 - d12 * d2) / det, (d11 * d2 - d12 * d1) / det);
            (info.n[0] * (1.0 - b1 - b2) + info.n[1] * b1 + info.n[2] * b2).normalize_or(info.ng)
        };
        let c2 = s.ns.dot(unbent).powi(2);
        let alpha2 = (0.125 * (1.0 - c2).max(0.0) / c2.max(1e-12)).min(1.0);
        let ci2 = wi.dot(unbent).powi(2);
        let tan2 = (1.0 - ci2).max(0.0) / ci2.max(1e-12);
        2.0 / (1.0 + (1.0 + alpha2 * tan2).sqrt())
    }

    /// The shading normal at `uv` of triangle `tri` under Mitsuba's bump map `(map, scale)`:
    /// `∂p/∂u` and `∂p/∂v` each moved along `ns` to the height's gradient (times `scale`),
    /// their cross product turned to `ng`'s side. Keeps `ns` where the coordinates are
    /// degenerate.
    #[inline(never)]
    fn bumped_normal(
        &self,
        tri: &Triangle,
        t: &[glam::Vec2; 3],
        ns: Vec3,
        ng: Vec3,
        uv: glam::Vec2,
        (map, scale): (u32, f32),
    ) -> Vec3 {
        let Some((dpdu, dpdv)) = uv_derivatives(tri, t) else {
            return ns;
        };
        let g = self.textures[map as usize].gradient(uv) * scale;
        let du = dpdu + ns * (g.x - ns.dot(dpdu));
        let dv = dpdv + ns * (g.y - ns.dot(dpdv));
        let n = du.cross(dv).normalize_or_zero();
        let n = if n.dot(ng) < 0.0 { -n } else { n };
        if n.is_finite() && n != Vec3::ZERO {
            n
        } else {
            ns
        }
    }

    /// The BSDF at shading point `s`: its material's (a mix's choice), with the albedo (base
    /// colour, a coating's diffuse base) of a textured diffuse (metallic-roughness, coated)
    /// material multiplied by the texture at `s.uv`, and
    /// a metallic-roughness texture's blue and green multiplying metalness and roughness.
    #[inline]
    pub fn bsdf(&self, s: &Surface) -> Bsdf {
        self.material_bsdf(s)
    }

    /// `bsdf` (the BSDF at `s`) seen from the side `front` (see [`Bsdf::facing`]); black
    /// from behind a one-sided material.
    #[inline]
    pub fn seen_from(&self, bsdf: Bsdf, s: &Surface, front: bool) -> Bsdf {
        if front || !self.has_scalar_only {
            return bsdf.facing(front);
        }
        let m = &self.materials[s.material as usize];
        if m.one_sided {
            return Bsdf::Black;
        }
        match m.sides {
            Some((_, back)) if !front => self
                .bsdf(&Surface {
                    material: back,
                    ..*s
                })
                .facing(front),
            _ => bsdf.facing(front),
        }
    }

    /// The albedo at `s` where its material is a plain Lambertian one (no mix, no second side,
    /// no parameter textures, not scalar-only): that of the [`Bsdf::Diffuse`] [`Scene::bsdf`]
    /// gives there, without building the rest; `None` otherwise (ask [`Scene::bsdf`]).
    #[inline]
    pub fn plain_diffuse_albedo(&self, s: &Surface) -> Option<Rgb> {
        let m = &self.materials[s.material as usize];
        let Bsdf::Diffuse { albedo } = m.bsdf else {
            return None;
        };
        let scalar_only = self.has_scalar_only && (m.sides.is_some() || m.scalar_only);
        if m.mix.is_some() || m.textures.numbers[0].is_some() || scalar_only {
            return None;
        }
        Some(match m.textures.base {
            Some(t) => albedo * self.textures[t as usize].eval(s.uv),
            None => albedo,
        })
    }

    fn material_bsdf(&self, s: &Surface) -> Bsdf {
        let m = &self.materials[s.material as usize];
        if let (true, Some((front, _))) = (self.has_scalar_only, m.sides) {
            return self.bsdf(&Surface {
                material: front,
                ..*s
            });
        }
        if m.mix.is_some() {
            return self.mixed_bsdf(s);
        }
        let tex = |t: u32| self.textures[t as usize].eval(s.uv);
        let bsdf = match (m.textures.base, m.bsdf) {
            (Some(t), Bsdf::Diffuse { albedo }) => Bsdf::Diffuse {
                albedo: albedo * tex(t),
            },
            (
                Some(t),
                Bsdf::Layered(
                    mut l @ crate::bsdf::layered::Layered {
                        base: crate::bsdf::layered::Base::Diffuse(r),
                        ..
                    },
                ),
            ) => {
                l.base = crate::bsdf::layered::Base::Diffuse((r * tex(t)).min(Vec3::ONE));
                Bsdf::Layered(l)
            }
            (Some(t), Bsdf::Plastic(mut p)) => {
                p.diffuse = (p.diffuse * tex(t)).min(Vec3::ONE);
                Bsdf::Plastic(p)
            }
            (Some(t), Bsdf::Principled(mut p)) => {
                p.base *= tex(t);
                Bsdf::Principled(p)
            }
            (Some(t), Bsdf::Microfacet(mut c)) => {
                c.tint *= tex(t);
                Bsdf::Microfacet(c)
            }
            (Some(t), Bsdf::Conductor(mut c)) => {
                c.tint *= tex(t);
                Bsdf::Conductor(c)
            }
            (
                base,
                Bsdf::DiffuseTransmission {
                    reflectance,
                    transmittance,
                },
            ) if base.is_some() || m.textures.transmittance.is_some() => {
                let texture = |t: Option<u32>| t.map_or(Rgb::ONE, tex);
                Bsdf::DiffuseTransmission {
                    reflectance: (reflectance * texture(base)).min(Vec3::ONE),
                    transmittance: (transmittance * texture(m.textures.transmittance))
                        .min(Vec3::ONE),
                }
            }
            (base, Bsdf::Pbr(mut p)) => {
                if let Some(t) = base {
                    p.base *= tex(t);
                }
                if let Some(t) = m.textures.metallic_roughness {
                    let c = tex(t);
                    p.metallic = (p.metallic * c.z).clamp(0.0, 1.0);
                    p.roughness = (p.roughness * c.y).clamp(0.0, 1.0);
                }
                Bsdf::Pbr(p)
            }
            (_, b) => b,
        };
        match m.textures.numbers[0] {
            None => bsdf,
            Some(_) => self.with_numbers(bsdf, &m.textures.numbers, s.uv),
        }
    }

    /// `bsdf` with the number parameters that textures set at `uv`.
    #[inline(never)]
    fn with_numbers(
        &self,
        bsdf: Bsdf,
        numbers: &[Option<(u32, Param)>; MAX_NUMBER_TEXTURES],
        uv: glam::Vec2,
    ) -> Bsdf {
        numbers.iter().flatten().fold(bsdf, |b, &(t, param)| {
            b.with_param(param, self.textures[t as usize].eval(uv).x)
        })
    }

    /// [`Scene::bsdf`] of a mix: the material it chooses at `s` (nested mixes choose again,
    /// a few levels at most).
    #[inline(never)]
    fn mixed_bsdf(&self, s: &Surface) -> Bsdf {
        let mut id = s.material;
        for _ in 0..8 {
            let Some(mix) = self.materials[id as usize].mix else {
                return self.bsdf(&Surface { material: id, ..*s });
            };
            let amount = match self.materials[id as usize].textures.numbers[0] {
                Some((t, Param::Weight)) => self.textures[t as usize].eval(s.uv).x.clamp(0.0, 1.0),
                _ => mix.amount,
            };
            id = if hash_point(s.p, id) < amount {
                mix.b
            } else {
                mix.a
            };
        }
        Bsdf::Black
    }

    /// Radiance emitted by the surface at `s` towards `w` (unit, pointing away from it).
    #[inline]
    pub fn emitted(&self, s: &Surface, w: Vec3) -> Rgb {
        if s.light == NO_LIGHT {
            return Vec3::ZERO;
        }
        let light = &self.lights[s.light as usize];
        match light {
            Light::Area {
                texture: Some(t), ..
            } => light.emitted(w) * self.texture_at(*t, s.uv),
            Light::Sphere { side, .. } if w.dot(s.ng) * side < 0.0 => Vec3::ZERO,
            _ => light.emitted(w),
        }
    }

    /// Texture `t` at `uv` (kept out of line: the hot paths only branch to it).
    #[inline(never)]
    fn texture_at(&self, t: u32, uv: glam::Vec2) -> Rgb {
        self.textures[t as usize].eval(uv)
    }

    /// Samples incident light at `p` from light `j` with uniform `u` ([`Light::sample`], or
    /// `guide`'s sampling where it guides the light), with a textured area light's radiance
    /// multiplied by its texture at the sampled point.
    #[inline]
    pub fn sample_light(
        &self,
        j: usize,
        p: Vec3,
        u: glam::Vec2,
        guide: Option<&EnvGuide>,
    ) -> Option<LightSample> {
        let light = &self.lights[j];
        if let Some((g, e)) = self.guided_environment(j, guide) {
            return g.sample(e, p, u).map(LightSample::from);
        }
        let mut ls = light.sample(&self.tris, p, u)?;
        if let Light::Area {
            texture: Some(t), ..
        } = light
        {
            ls.li *= self.light_texture_at(light, *t, u);
        }
        Some(ls)
    }

    /// `guide` and the environment light it guides, where light `j` is that light.
    #[inline]
    pub fn guided_environment<'a>(
        &'a self,
        j: usize,
        guide: Option<&'a EnvGuide>,
    ) -> Option<(&'a EnvGuide, &'a EnvLight)> {
        match (guide, &self.lights[j]) {
            (Some(g), Light::Environment(e)) if g.light() == j => Some((g, e)),
            _ => None,
        }
    }

    /// Texture `t` of area light `light` at the point it samples from `u` (1 where the
    /// triangle has no texture coordinates).
    #[inline(never)]
    fn light_texture_at(&self, light: &Light, t: u32, u: glam::Vec2) -> Rgb {
        light
            .area_point(u)
            .and_then(|(tri, b)| {
                let uv = self.tri_uv.get(tri as usize)?;
                Some(uv[0] * (1.0 - b.x - b.y) + uv[1] * b.x + uv[2] * b.y)
            })
            .map_or(Vec3::ONE, |at| self.texture_at(t, at))
    }

    /// Radiance of infinite light `j` reaching a ray from `from` that escapes the scene along
    /// `d`, and the solid-angle density of light sampling at `from` choosing `d` (guided by
    /// `guide` where it guides the light).
    pub fn escaped_pdf(
        &self,
        j: usize,
        from: Vec3,
        d: Vec3,
        guide: Option<&EnvGuide>,
    ) -> (Rgb, f32) {
        match self.guided_environment(j, guide) {
            Some((g, e)) => g.radiance_pdf(e, from, d),
            None => self.lights[j].escaped_pdf(d),
        }
    }

    /// Radiance reaching a ray that escapes the scene along `d`.
    pub fn escaped(&self, d: Vec3) -> Rgb {
        self.lights
            .iter()
            .filter(|l| l.is_infinite())
            .map(|l| l.escaped(d))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Sphere;

    /// Vertex normals equal up to rounding make a flat triangle with one unit normal; normals
    /// that differ by more, as on a smooth mesh, are kept for interpolation.
    #[test]
    fn flat_triangles_are_told_from_smooth_ones() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let ulp = Vec3::new(f32::EPSILON, 0.0, -f32::EPSILON);
        let t = TriInfo::new([n, n + ulp, n - ulp], n, 0, NO_LIGHT);
        assert!(t.flat);
        assert_eq!(t.n[0], t.n[1]);
        assert_eq!(t.n[1], t.n[2]);
        assert!((t.n[0] - n).length() < 1e-6);
        assert!((t.n[0].length() - 1.0).abs() < 1e-6);
        // Zero vertex normals (undefined): the geometric normal.
        let t = TriInfo::new([Vec3::ZERO; 3], Vec3::Y, 0, NO_LIGHT);
        assert!(t.flat);
        assert_eq!(t.n[0], Vec3::Y);
        // A smooth mesh's normals differ far more than rounding.
        let m = Vec3::new(0.3, -0.5, 0.81).normalize();
        let t = TriInfo::new([n, n, m], n, 0, NO_LIGHT);
        assert!(!t.flat);
        assert_eq!(t.n, [n, n, m]);
    }

    /// A sphere's projected point lies on it and its normal is the unit outward direction.
    #[test]
    fn sphere_projection_gives_point_and_unit_normal() {
        let s = Sphere {
            center: Vec3::new(0.5, -1.0, 2.0),
            radius: 0.7,
        };
        for d in [
            Vec3::X,
            Vec3::new(-1.0, 2.0, 0.5),
            Vec3::new(0.0, 0.0, -3.0),
        ] {
            let (p, n) = s.project(s.center + d * 1.01);
            let u = d.normalize();
            assert!((n - u).length() < 1e-6, "{n} against {u}");
            assert!((n.length() - 1.0).abs() < 1e-6);
            assert!((p - (s.center + u * s.radius)).length() < 1e-6);
        }
        assert_eq!(s.project(s.center).1, Vec3::Y);
    }
}
