//! Lights: the file's lights (CS184 area rectangles as two triangles each, point, spot,
//! directional, ambient) and the area lights of emissive shapes.

use super::{Builder, Triangle};
use crate::bsdf::Bsdf;
use crate::io::desc::{LightDesc, LightKind};
use crate::light::infinite::InfiniteLight;
use crate::light::{Light, Parallelogram};
use crate::math::Rgb;
use crate::sampling::Distribution1D;
use crate::scene::{Material, MaterialTextures, TriInfo};
use glam::{Mat4, Vec3, Vec4};
use std::collections::BTreeMap;

impl Builder<'_> {
    /// The file's lights, after the emissive shapes' (which are lights already), and the
    /// count of each type.
    pub(super) fn lights(&mut self) {
        // Every light so far comes from an emissive shape.
        let emissive_shapes = self.lights.len();
        let mut light_types: BTreeMap<String, usize> = BTreeMap::new();
        let mut back_material = None;
        for l in &self.desc.lights {
            *light_types
                .entry(l.kind.type_name().to_string())
                .or_default() += 1;
            if let Some(light) = self.light(l, &mut back_material) {
                self.lights.push(light);
            }
        }
        self.stats.lights_by_type = light_types.into_iter().collect();
        if emissive_shapes > 0 {
            self.stats
                .lights_by_type
                .push(("emissive shape".into(), emissive_shapes));
        }
    }

    /// The light of one description (`None`, with a warning, when it is unusable);
    /// `back_material` is the black material of CS184 area rectangles, made on first use.
    fn light(&mut self, l: &LightDesc, back_material: &mut Option<u32>) -> Option<Light> {
        let t: Mat4 = l.transform;
        let origin = t.transform_point3(Vec3::ZERO);
        Some(match &l.kind {
            LightKind::Area { radiance } => {
                match self.area_rectangle(&t, *radiance, back_material) {
                    Some(light) => light,
                    None => {
                        self.warnings.push(format!(
                            "{}:{}: area light '{}' has zero size; ignored",
                            self.desc.file, l.loc, l.name
                        ));
                        return None;
                    }
                }
            }
            LightKind::Point { intensity } => Light::Point {
                pos: origin,
                intensity: *intensity,
            },
            LightKind::Spot {
                intensity,
                falloff_angle_deg,
                falloff_exponent,
                falloff_start_deg,
                linear_falloff,
            } => Light::Spot {
                pos: origin,
                axis: t.transform_vector3(Vec3::NEG_Z).normalize_or(Vec3::NEG_Y),
                cos_cutoff: (falloff_angle_deg.to_radians() * 0.5)
                    .clamp(0.0, std::f32::consts::PI)
                    .cos(),
                exponent: *falloff_exponent,
                cos_start: falloff_start_deg.map_or(-2.0, |d| {
                    (d.to_radians() * 0.5)
                        .clamp(0.0, std::f32::consts::PI)
                        .cos()
                }),
                linear: *linear_falloff,
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
            LightKind::Infinite { scale, image } => self.infinite_light(l, *scale, image)?,
            LightKind::LatLong { scale, image } => {
                let mut img = image.clone();
                img.pixels.iter_mut().for_each(|p| *p *= *scale);
                let rotation = crate::math::orthonormal_axes(glam::Mat3::from_mat4(t));
                let env = crate::light::env::EnvLight::mitsuba(
                    img,
                    crate::light::env::EnvSampling::Importance,
                    rotation,
                );
                Light::Environment(env)
            }
        })
    }

    /// A pbrt-v4 infinite light: constant, or its image turned by the light's transform.
    fn infinite_light(
        &mut self,
        l: &LightDesc,
        scale: Rgb,
        image: &Option<(u32, Vec<Rgb>)>,
    ) -> Option<Light> {
        let Some((size, texels)) = image else {
            return Some(Light::Infinite(InfiniteLight::constant(scale)));
        };
        let turn = glam::Mat3::from_mat4(l.transform);
        let light = InfiniteLight::image(*size as usize, texels.clone(), scale, turn);
        if light.is_none() {
            self.warnings.push(format!(
                "{}:{}: infinite light '{}' has no usable image; ignored",
                self.desc.file, l.loc, l.name
            ));
        }
        light.map(Light::Infinite)
    }

    /// A CS184 area light: a rectangle with full edge vectors from the centre (samples in
    /// [−½, ½]²), added as two black triangles (`back_material`, made on first use) that
    /// emit on one side; `None` when it has zero size.
    fn area_rectangle(
        &mut self,
        t: &Mat4,
        radiance: Rgb,
        back_material: &mut Option<u32>,
    ) -> Option<Light> {
        let origin = t.transform_point3(Vec3::ZERO);
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
            return None;
        }
        let materials = &mut self.materials;
        let back = *back_material.get_or_insert_with(|| {
            materials.push(Material {
                name: "area light".into(),
                bsdf: Bsdf::Black,
                textures: MaterialTextures::default(),
                mix: None,
                one_sided: false,
                sides: None,
                scalar_only: false,
                interface: None,
                null: false,
            });
            materials.len() as u32 - 1
        });
        let id = self.lights.len() as u32;
        let mut ids = Vec::new();
        for q in quad {
            ids.push(self.tris.len() as u32);
            let n = q.cross().normalize();
            self.tris.push(q);
            self.tri_info
                .push(TriInfo::new([n; 3], q.unit_normal(), back, id));
        }
        Some(area_light(&self.tris, ids, radiance, Some(dir), None))
    }
}

/// An area light of triangles `ids`; untextured pairs that form a parallelogram (CGL area
/// lights) are sampled as one.
pub(super) fn area_light(
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
pub(super) type Emitter = (u32, Vec<u32>, Option<glam::IVec3>, Option<Vec3>);
