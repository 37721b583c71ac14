//! Stage two of loading: [`SceneDesc`] → [`Scene`]. Applies transforms, recomputes vertex
//! normals from the faces (CS184 behaviour), turns emitters into lights, places the CS184
//! camera and builds the BVH.

use super::geometry::{Sphere, Triangle};
use super::*;
use crate::accel::bvh::Bvh;
use crate::accel::tribvh::TriangleBvh;
use crate::accel::wide::Bvh4;
use crate::bsdf::microfacet::Microfacet;
use crate::io::desc::{LightKind, MaterialKind, MeshNormals, SceneDesc, ShapeDesc, TextureSlot};
use crate::light::Parallelogram;
use crate::sampling::Distribution1D;
use glam::{Mat4, Vec2, Vec4};
use std::collections::BTreeMap;

/// Builds a renderable scene from a description.
pub fn build(desc: &SceneDesc) -> Scene {
    let mut warnings = desc.warnings.clone();
    let mut stats = SceneStats::default();
    let mut materials: Vec<Material> = desc
        .materials
        .iter()
        .map(|m| Material {
            name: m.name.clone(),
            bsdf: bsdf_of(&m.kind),
            textures: MaterialTextures::default(),
        })
        .collect();
    // Base colour textures attach to diffuse and metallic-roughness materials (those with an
    // albedo or base colour to multiply), metallic-roughness textures to the latter, normal
    // maps to any that scatter, emission textures to emitters.
    let mut textures = Vec::new();
    for t in &desc.textures {
        let emits = desc
            .materials
            .get(t.material as usize)
            .is_some_and(|m| m.emission.max_element() > 0.0);
        let Some(tex) = texture::Texture::new(t) else {
            warnings.push(format!(
                "{}: texture '{}' holds no texels; ignored",
                desc.file, t.name
            ));
            continue;
        };
        let id = Some(textures.len() as u32);
        let fits = match (materials.get_mut(t.material as usize), t.slot) {
            (Some(m), TextureSlot::BaseColor)
                if matches!(m.bsdf, Bsdf::Diffuse { .. } | Bsdf::Pbr(_)) =>
            {
                m.textures.base = id;
                true
            }
            (Some(m), TextureSlot::MetallicRoughness) if matches!(m.bsdf, Bsdf::Pbr(_)) => {
                m.textures.metallic_roughness = id;
                true
            }
            (Some(m), TextureSlot::Normal { scale }) if !m.bsdf.is_black() => {
                m.textures.normal = id.map(|i| (i, scale));
                true
            }
            (Some(m), TextureSlot::Emission) if emits => {
                m.textures.emission = id;
                true
            }
            _ => false,
        };
        if fits {
            textures.push(tex);
        } else {
            warnings.push(format!(
                "{}: texture '{}' does not fit its material; ignored",
                desc.file, t.name
            ));
        }
    }
    let mut by_type: BTreeMap<String, usize> = BTreeMap::new();
    for m in &desc.materials {
        *by_type.entry(m.kind.type_name().to_string()).or_default() += 1;
    }
    stats.materials_by_type = by_type.into_iter().collect();

    let mut tris = Vec::new();
    let mut tri_info = Vec::new();
    let mut tri_uv: Vec<[Vec2; 3]> = Vec::new();
    let mut any_uv = false;
    let mut spheres = Vec::new();
    let mut sphere_info = Vec::new();
    let mut lights = Vec::new();
    let mut bounds = Aabb::EMPTY;

    for shape in &desc.shapes {
        match shape {
            ShapeDesc::Mesh {
                positions,
                triangles,
                materials: mats,
                transform,
                normals: given,
                one_sided,
                uvs,
                ..
            } => {
                let uvs = (uvs.len() == positions.len()).then_some(uvs);
                any_uv |= uvs.is_some();
                stats.meshes += 1;
                let world: Vec<Vec3> = positions
                    .iter()
                    .map(|p| transform.transform_point3(*p))
                    .collect();
                // Area-weighted vertex normals from world-space faces (CS184), or the file's
                // own (normals transform by the inverse transpose).
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
                        stats.degenerate += 1;
                        continue;
                    }
                    stats.mesh_triangles += 1;
                    bounds = bounds.union(&tri.bounds());
                    let id = tris.len() as u32;
                    let emission = desc.materials[m as usize].emission;
                    // A one-sided emitter is one light per material and plane orientation (a
                    // light's emitting side is one normal).
                    let side = if *one_sided {
                        let n = tri.cross().normalize_or_zero();
                        Some(n)
                    } else {
                        None
                    };
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
                        (lights.len() + k) as u32
                    } else {
                        NO_LIGHT
                    };
                    tris.push(tri);
                    let n = if flat {
                        [tri.cross().normalize_or_zero(); 3]
                    } else {
                        [
                            normals[t[0] as usize],
                            normals[t[1] as usize],
                            normals[t[2] as usize],
                        ]
                    };
                    tri_info.push(TriInfo::new(n, tri.unit_normal(), m, light));
                    tri_uv.push(uvs.map_or([Vec2::ZERO; 3], |uv| {
                        [uv[t[0] as usize], uv[t[1] as usize], uv[t[2] as usize]]
                    }));
                }
                for (m, ids, _, side) in emitters {
                    let texture = materials[m as usize].textures.emission;
                    let emission = desc.materials[m as usize].emission;
                    lights.push(area_light(&tris, ids, emission, side, texture));
                }
            }
            ShapeDesc::Sphere {
                radius,
                material,
                transform,
                ..
            } => {
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
                    continue;
                }
                bounds = bounds.union(&s.bounds());
                let emission = desc.materials[*material as usize].emission;
                let light = if emission.max_element() > 0.0 {
                    lights.push(Light::Sphere {
                        center: s.center,
                        radius: s.radius,
                        radiance: emission,
                    });
                    lights.len() as u32 - 1
                } else {
                    NO_LIGHT
                };
                spheres.push(s);
                sphere_info.push(SphereInfo {
                    material: *material,
                    light,
                });
            }
        }
    }

    // Every light so far comes from an emissive shape.
    let emissive_shapes = lights.len();
    let mut light_types: BTreeMap<String, usize> = BTreeMap::new();
    let mut back_material = None;
    for l in &desc.lights {
        *light_types
            .entry(l.kind.type_name().to_string())
            .or_default() += 1;
        let t: Mat4 = l.transform;
        let origin = t.transform_point3(Vec3::ZERO);
        let light = match &l.kind {
            LightKind::Area { radiance } => {
                // CS184 rectangle: full edge vectors from the centre, samples in [−½, ½]².
                let dir = t.transform_vector3(Vec3::NEG_Z).normalize_or(Vec3::NEG_Y);
                let ex = t.transform_vector3(Vec3::NEG_X);
                let ey = t.transform_vector3(Vec3::Y);
                let c = |a: f32, b: f32| origin + ex * a + ey * b;
                let quad = [
                    Triangle {
                        v: [c(-0.5, -0.5), c(0.5, -0.5), c(0.5, 0.5)],
                    },
                    Triangle {
                        v: [c(-0.5, -0.5), c(0.5, 0.5), c(-0.5, 0.5)],
                    },
                ];
                if quad
                    .iter()
                    .any(|q| !(q.area() > 0.0 && q.area().is_finite()))
                {
                    warnings.push(format!(
                        "{}:{}: area light '{}' has zero size; ignored",
                        desc.file, l.loc, l.name
                    ));
                    continue;
                }
                let back = *back_material.get_or_insert_with(|| {
                    materials.push(Material {
                        name: "area light".into(),
                        bsdf: Bsdf::Black,
                        textures: MaterialTextures::default(),
                    });
                    materials.len() as u32 - 1
                });
                let id = lights.len() as u32;
                let mut ids = Vec::new();
                for q in quad {
                    ids.push(tris.len() as u32);
                    let n = q.cross().normalize();
                    tris.push(q);
                    tri_info.push(TriInfo::new([n; 3], q.unit_normal(), back, id));
                }
                area_light(&tris, ids, *radiance, Some(dir), None)
            }
            LightKind::Point { intensity } => Light::Point {
                pos: origin,
                intensity: *intensity,
            },
            LightKind::Spot {
                intensity,
                falloff_angle_deg,
                falloff_exponent,
            } => Light::Spot {
                pos: origin,
                axis: t.transform_vector3(Vec3::NEG_Z).normalize_or(Vec3::NEG_Y),
                cos_cutoff: (falloff_angle_deg.to_radians() * 0.5)
                    .clamp(0.0, std::f32::consts::PI)
                    .cos(),
                exponent: *falloff_exponent,
                intensity: *intensity,
            },
            LightKind::Directional { irradiance } => {
                let d = (t * Vec4::new(0.0, 0.0, -1.0, 1.0)).truncate();
                Light::Directional {
                    dir: d.normalize_or(Vec3::Y),
                    irradiance: *irradiance,
                }
            }
            LightKind::Ambient { radiance } => Light::Ambient {
                radiance: *radiance,
            },
        };
        lights.push(light);
    }
    stats.lights_by_type = light_types.into_iter().collect();
    if emissive_shapes > 0 {
        stats
            .lights_by_type
            .push(("emissive shape".into(), emissive_shapes));
    }
    if stats.degenerate > 0 {
        warnings.push(format!(
            "{}: {} degenerate (zero-area) triangles were dropped",
            desc.file, stats.degenerate
        ));
    }

    let camera = match &desc.camera {
        // Where the file puts it (the vertical field of view over a 600-pixel-high image
        // here; the CLI sets it over the image's height, `Camera::set_vfov`).
        Some(c) if c.exact => {
            let t = c.transform;
            let pos = t.transform_point3(Vec3::ZERO);
            let forward = t.transform_vector3(Vec3::NEG_Z);
            let up = t.transform_vector3(Vec3::Y);
            Camera::look_at_up(
                pos,
                pos + forward,
                up,
                c.yfov_deg.unwrap_or(40.0) as f64,
                600,
            )
            .map(|mut cam| {
                (cam.near, cam.far) = (c.znear, c.zfar);
                cam
            })
            .unwrap_or_else(|| {
                warnings.push(format!(
                    "{}: camera {:?} has a degenerate transform; the default view is used",
                    desc.file, c.name
                ));
                Camera::cs184(None, &bounds)
            })
        }
        c => Camera::cs184(c.as_ref(), &bounds),
    };
    if any_uv {
        // Area-light rectangles follow the meshes' triangles.
        tri_uv.resize(tris.len(), [Vec2::ZERO; 3]);
    } else {
        tri_uv = Vec::new();
    }
    let mut scene = Scene {
        name: desc.name.clone(),
        tris,
        tri_info,
        tri_uv,
        textures,
        spheres,
        sphere_info,
        materials,
        lights,
        camera,
        tri_bvh: TriangleBvh::default(),
        sphere_bvh: Bvh4::default(),
        bounds,
        stats,
        warnings,
        light_selection: Distribution1D::default(),
    };
    scene.tri_bvh = TriangleBvh::build(&scene.tris);
    let sphere_bounds: Vec<Aabb> = scene.spheres.iter().map(|s| s.bounds()).collect();
    scene.sphere_bvh = Bvh4::from_binary(&Bvh::build(&sphere_bounds), 4);
    scene.update_light_selection();
    scene
}

/// An area light of triangles `ids`; untextured pairs that form a parallelogram (CGL area
/// lights) are sampled as one.
fn area_light(
    tris: &[Triangle],
    ids: Vec<u32>,
    radiance: Rgb,
    normal: Option<Vec3>,
    texture: Option<u32>,
) -> Light {
    let areas: Vec<f32> = ids.iter().map(|&i| tris[i as usize].area()).collect();
    let dist = Distribution1D::new(&areas);
    let quad = match ids[..] {
        [a, b] if texture.is_none() => {
            Parallelogram::of_triangles(&tris[a as usize], &tris[b as usize])
        }
        _ => None,
    };
    Light::Area {
        area: dist.total(),
        tris: ids,
        dist,
        radiance,
        normal,
        texture,
        quad,
    }
}

/// Triangles of one area light being gathered: material, triangle ids, and for one-sided
/// emitters the quantised and the exact emitting normal.
type Emitter = (u32, Vec<u32>, Option<glam::IVec3>, Option<Vec3>);

/// The BSDF of a material description. Colours that scatter are clamped to [0, 1]; the
/// dielectrics' `roughness` is parsed but, as in CS184, not used.
fn bsdf_of(kind: &MaterialKind) -> Bsdf {
    let unit = |c: Rgb| c.clamp(Vec3::ZERO, Vec3::ONE);
    match *kind {
        MaterialKind::Diffuse { albedo } => Bsdf::Diffuse {
            albedo: unit(albedo),
        },
        MaterialKind::Emission => Bsdf::Black,
        MaterialKind::Mirror { reflectance } => Bsdf::Mirror {
            reflectance: unit(reflectance),
        },
        MaterialKind::Glass {
            reflectance,
            transmittance,
            ior,
            ..
        } => Bsdf::Glass {
            reflectance: unit(reflectance),
            transmittance: unit(transmittance),
            ior,
        },
        MaterialKind::Refraction {
            transmittance, ior, ..
        } => Bsdf::Refraction {
            transmittance: unit(transmittance),
            ior,
        },
        MaterialKind::Microfacet { alpha, eta, k } => {
            Bsdf::Microfacet(Microfacet::new(alpha, eta, k))
        }
        MaterialKind::MetallicRoughness {
            base,
            metallic,
            roughness,
            transmission,
            ior,
        } => Bsdf::Pbr(
            crate::bsdf::pbr::Pbr::new(base, metallic, roughness)
                .with_transmission(transmission, ior),
        ),
    }
}
