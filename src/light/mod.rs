//! Light sources and their sampling from a receiving point.
//!
//! Conventions: a [`LightSample`] gives the unit direction `wi` from the receiver towards the
//! light, the distance to the sampled point (`f32::INFINITY` for infinitely distant lights),
//! the incident radiance `li` (for delta lights: intensity/d² or irradiance, so that the
//! estimator `f · li · cos / pdf` holds with `pdf = 1`), and `pdf` in solid angle.

pub mod env;
pub mod infinite;
pub mod studio;

use crate::geometry::Triangle;
use crate::math::Rgb;
use crate::sampling::{
    uniform_hemisphere, uniform_sphere, uniform_triangle, Distribution1D, UNIFORM_HEMISPHERE_PDF,
};
use glam::{Vec2, Vec3};

/// A light source, held by value in the scene's list.
#[derive(Clone, Debug)]
pub enum Light {
    /// Emitting triangles (a CGL area light's rectangle, or a mesh with an emissive material).
    Area {
        /// Scene triangle ids.
        tris: Vec<u32>,
        /// Triangle choice proportional to area.
        dist: Distribution1D,
        /// Total area.
        area: f32,
        /// Emitted radiance.
        radiance: Rgb,
        /// Emitting side for one-sided lights; `None` emits on both sides.
        normal: Option<Vec3>,
        /// A texture of the scene's multiplying `radiance` at each point's texture
        /// coordinates (glTF `emissiveTexture`); see `scene::Scene::sample_light`.
        texture: Option<u32>,
        /// The light as one parallelogram (a CGL area light's rectangle), when its triangles
        /// form one and it has no texture: points are then sampled on it directly.
        quad: Option<Parallelogram>,
    },
    /// An emissive sphere (emits on both sides, like emissive meshes), sampled uniformly by area.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Which side emits: 0 both, 1 the outside, −1 the inside.
        side: f32,
        /// Emitted radiance.
        radiance: Rgb,
    },
    /// Isotropic point light with `1/d²` falloff.
    Point {
        /// Position.
        pos: Vec3,
        /// Radiant intensity (W/sr).
        intensity: Rgb,
    },
    /// Point light limited to a cone, `intensity · cos^exponent` of the angle to the axis.
    Spot {
        /// Position.
        pos: Vec3,
        /// Unit axis the light points along.
        axis: Vec3,
        /// Cosine of the cone's half angle.
        cos_cutoff: f32,
        /// Exponent of the falloff inside the cone.
        exponent: f32,
        /// Cosine of the angle where pbrt-v4's smooth falloff begins: the intensity is also
        /// multiplied by `smoothstep(cos_cutoff, cos_start, cos θ)`; at most `cos_cutoff`
        /// (COLLADA's spots) for none.
        cos_start: f32,
        /// Between the two angles the intensity falls linearly in angle (Mitsuba's spot)
        /// instead of by the smoothstep.
        linear: bool,
        /// Intensity on the axis (W/sr).
        intensity: Rgb,
    },
    /// Infinitely distant light from one direction.
    Directional {
        /// Unit direction towards the light.
        dir: Vec3,
        /// Irradiance on a surface facing the light.
        irradiance: Rgb,
    },
    /// Constant radiance from the upper hemisphere (world +Y), infinitely far.
    Ambient {
        /// Sky radiance.
        radiance: Rgb,
    },
    /// An HDR environment map at infinity.
    Environment(env::EnvLight),
    /// pbrt-v4's `infinite` light (constant, or an equal-area image).
    Infinite(infinite::InfiniteLight),
}

/// One sample of incident light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the receiver towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point, `INFINITY` for distant lights.
    pub dist: f32,
    /// Incident radiance (or its delta-light equivalent).
    pub li: Rgb,
    /// Solid-angle pdf; 1 for delta lights.
    pub pdf: f32,
}

impl From<env::EnvSample> for LightSample {
    /// An environment light's sample: a direction to infinity.
    #[inline]
    fn from(s: env::EnvSample) -> LightSample {
        LightSample {
            wi: s.wi,
            dist: f32::INFINITY,
            li: s.radiance,
            pdf: s.pdf,
        }
    }
}

/// A parallelogram `{o + s·e1 + t·e2 : s, t ∈ [0, 1]}` with unit normal `n` along `e1 × e2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parallelogram {
    /// Corner.
    pub o: Vec3,
    /// First edge from `o`.
    pub e1: Vec3,
    /// Second edge from `o`.
    pub e2: Vec3,
    /// Unit normal, `normalize(e1 × e2)`.
    pub n: Vec3,
}

impl Parallelogram {
    /// The parallelogram that two triangles form together, when they do: they share an edge
    /// (exactly equal vertices) that is a diagonal, and the two other vertices mirror each
    /// other through its midpoint (within `1e-6` of the parallelogram's size).
    pub fn of_triangles(a: &Triangle, b: &Triangle) -> Option<Parallelogram> {
        let shared: Vec<Vec3> = a.v.iter().copied().filter(|v| b.v.contains(v)).collect();
        let [s0, s1] = shared[..] else {
            return None;
        };
        let pa = *a.v.iter().find(|v| !shared.contains(v))?;
        let pb = *b.v.iter().find(|v| !shared.contains(v))?;
        let (e1, e2) = (s0 - pa, s1 - pa);
        let size = e1.length() + e2.length();
        let n = e1.cross(e2).normalize_or_zero();
        let mirrored = (pa + pb - s0 - s1).length() <= 1e-6 * size;
        (mirrored && size.is_finite() && n != Vec3::ZERO).then_some(Parallelogram {
            o: pa,
            e1,
            e2,
            n,
        })
    }

    /// The point of parameters `u` (uniform by area for uniform `u`).
    #[inline]
    pub fn point(&self, u: Vec2) -> Vec3 {
        self.o + self.e1 * u.x + self.e2 * u.y
    }
}

/// Surface area 4πr² of a sphere of radius `radius`.
#[inline]
fn sphere_area(radius: f32) -> f32 {
    4.0 * std::f32::consts::PI * radius * radius
}

/// The triangle (a scene triangle id) and barycentrics (weights of vertices 1 and 2) of the
/// point an area light of triangles `ids` samples from `u`.
#[inline]
fn area_point(ids: &[u32], dist: &Distribution1D, u: Vec2) -> (u32, Vec2) {
    let (i, _, ux) = dist.sample(u.x);
    (ids[i], uniform_triangle(Vec2::new(ux, u.y)))
}

impl Light {
    /// For an area light sampled by triangles (not as a [`Parallelogram`]: textured lights
    /// always are), the triangle and barycentrics of the point [`Light::sample`] picks from
    /// `u`; `None` for other lights.
    #[inline]
    pub fn area_point(&self, u: Vec2) -> Option<(u32, Vec2)> {
        match self {
            Light::Area {
                tris,
                dist,
                quad: None,
                ..
            } => Some(area_point(tris, dist, u)),
            _ => None,
        }
    }

    /// True for lights that a BSDF-sampled ray can never hit (point, spot, directional).
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. }
        )
    }

    /// True for emitting surfaces (area lights, emissive spheres): the lights light tracing
    /// starts paths from.
    pub fn is_finite_emitter(&self) -> bool {
        matches!(self, Light::Area { .. } | Light::Sphere { .. })
    }

    /// True for lights at infinity that escaping rays see.
    pub fn is_infinite(&self) -> bool {
        matches!(
            self,
            Light::Ambient { .. } | Light::Environment(_) | Light::Infinite(_)
        )
    }

    /// Lower-case type name.
    pub fn type_name(&self) -> &'static str {
        match self {
            Light::Area { .. } => "area",
            Light::Sphere { .. } => "sphere",
            Light::Point { .. } => "point",
            Light::Spot { .. } => "spot",
            Light::Directional { .. } => "directional",
            Light::Ambient { .. } => "ambient",
            Light::Environment(_) => "environment",
            Light::Infinite(_) => "infinite",
        }
    }

    /// A point of an emitting surface (area light or sphere), uniform by area for uniform `u`:
    /// the point, its unit normal, whether only that side emits, and the density `1 / area`.
    /// Parallelograms map `u` onto themselves; other area lights pick their triangle with
    /// `u.x` (in proportion to area) and reuse its remainder within the chosen triangle, so a
    /// stratified `u` stays stratified over the whole light. `None` for other lights.
    #[inline]
    pub fn surface_point(&self, tris: &[Triangle], u: Vec2) -> Option<(Vec3, Vec3, bool, f32)> {
        match self {
            Light::Area {
                quad: Some(quad),
                area,
                normal,
                ..
            } => Some((
                quad.point(u),
                normal.unwrap_or(quad.n),
                normal.is_some(),
                1.0 / area,
            )),
            Light::Area {
                tris: ids,
                dist,
                area,
                normal,
                ..
            } => {
                let (t, b) = area_point(ids, dist, u);
                let tri = &tris[t as usize];
                let q = tri.v[0] * (1.0 - b.x - b.y) + tri.v[1] * b.x + tri.v[2] * b.y;
                let n = normal.unwrap_or_else(|| tri.cross().normalize_or_zero());
                Some((q, n, normal.is_some(), 1.0 / area))
            }
            Light::Sphere {
                center,
                radius,
                side,
                ..
            } => {
                let n = uniform_sphere(u);
                let emitting = if *side < 0.0 { -n } else { n };
                Some((
                    *center + n * *radius,
                    emitting,
                    *side != 0.0,
                    1.0 / sphere_area(*radius),
                ))
            }
            _ => None,
        }
    }

    /// Area of an emitting surface in square scene units (an area light's triangles, a
    /// sphere's 4πr²); `None` for lights without a surface.
    #[inline]
    pub fn surface_area(&self) -> Option<f32> {
        match self {
            Light::Area { area, .. } => Some(*area),
            Light::Sphere { radius, .. } => Some(sphere_area(*radius)),
            _ => None,
        }
    }

    /// Samples incident light at `p` from uniform numbers `u`. Emitting surfaces are sampled
    /// by area ([`Light::surface_point`]).
    pub fn sample(&self, tris: &[Triangle], p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Area { radiance, .. } | Light::Sphere { radiance, .. } => {
                let (q, n, one_sided, pdf_area) = self.surface_point(tris, u)?;
                Self::from_point(p, q, n, one_sided, *radiance, pdf_area)
            }
            Light::Point { pos, intensity } => {
                let d = *pos - p;
                let d2 = d.length_squared();
                (d2 > 0.0).then(|| LightSample {
                    wi: d / d2.sqrt(),
                    dist: d2.sqrt(),
                    li: *intensity / d2,
                    pdf: 1.0,
                })
            }
            Light::Spot {
                pos,
                axis,
                cos_cutoff,
                exponent,
                cos_start,
                linear,
                intensity,
            } => {
                let d = *pos - p;
                let d2 = d.length_squared();
                if d2 == 0.0 {
                    return None;
                }
                let wi = d / d2.sqrt();
                let c = (-wi).dot(*axis);
                let falloff = spot_falloff(c, *cos_cutoff, *cos_start, *linear);
                (c > *cos_cutoff).then(|| LightSample {
                    wi,
                    dist: d2.sqrt(),
                    li: *intensity * c.powf(*exponent) * falloff / d2,
                    pdf: 1.0,
                })
            }
            Light::Directional { dir, irradiance } => Some(LightSample {
                wi: *dir,
                dist: f32::INFINITY,
                li: *irradiance,
                pdf: 1.0,
            }),
            Light::Ambient { radiance } => {
                // Uniform on the upper hemisphere: local +Z is world +Y.
                let l = uniform_hemisphere(u);
                Some(LightSample {
                    wi: Vec3::new(l.x, l.z, -l.y),
                    dist: f32::INFINITY,
                    li: *radiance,
                    pdf: UNIFORM_HEMISPHERE_PDF,
                })
            }
            Light::Environment(e) => e.sample(u).map(|s| LightSample {
                wi: s.wi,
                dist: f32::INFINITY,
                li: s.radiance,
                pdf: s.pdf,
            }),
            Light::Infinite(l) => l.sample(u).map(|(wi, li, pdf)| LightSample {
                wi,
                dist: f32::INFINITY,
                li,
                pdf,
            }),
        }
    }

    /// Converts an area-measure sample at `q` with normal `n` to a solid-angle sample at `p`.
    fn from_point(
        p: Vec3,
        q: Vec3,
        n: Vec3,
        one_sided: bool,
        radiance: Rgb,
        pdf_area: f32,
    ) -> Option<LightSample> {
        let d = q - p;
        let d2 = d.length_squared();
        if d2 == 0.0 {
            return None;
        }
        let dist = d2.sqrt();
        let wi = d / dist;
        let cos_l = -wi.dot(n);
        let cos = if one_sided { cos_l } else { cos_l.abs() };
        (cos > 0.0).then(|| LightSample {
            wi,
            dist,
            li: radiance,
            pdf: pdf_area * d2 / cos,
        })
    }

    /// Radiance leaving an emitting surface of this light towards `w` (unit, pointing away from
    /// the surface).
    pub fn emitted(&self, w: Vec3) -> Rgb {
        match self {
            Light::Area {
                radiance,
                normal: Some(n),
                ..
            } => {
                if w.dot(*n) > 0.0 {
                    *radiance
                } else {
                    Vec3::ZERO
                }
            }
            Light::Area {
                radiance,
                normal: None,
                ..
            }
            | Light::Sphere { radiance, .. } => *radiance,
            _ => Vec3::ZERO,
        }
    }

    /// Radiance arriving along direction `-d` from infinity (for rays escaping along `d`).
    pub fn escaped(&self, d: Vec3) -> Rgb {
        match self {
            Light::Ambient { radiance } if d.y > 0.0 => *radiance,
            Light::Environment(e) => e.radiance(d),
            Light::Infinite(l) => l.radiance(d),
            _ => Vec3::ZERO,
        }
    }

    /// [`Light::escaped`] and [`Light::pdf_direction`] of `d` together (an environment map
    /// or an image infinite light maps `d` to its coordinates once for both).
    pub fn escaped_pdf(&self, d: Vec3) -> (Rgb, f32) {
        match self {
            Light::Environment(e) => e.radiance_pdf(d),
            Light::Infinite(l) => l.radiance_pdf(d),
            _ => (self.escaped(d), self.pdf_direction(d)),
        }
    }

    /// Emitted power (luminance, watts up to a constant) for light selection; `radius` is the
    /// scene's bounding radius, over which distant lights are taken to shine.
    pub fn power(&self, radius: f32) -> f32 {
        use std::f32::consts::PI;
        let lum = crate::math::luminance;
        let disk = PI * radius * radius;
        let p = match self {
            Light::Area {
                area,
                radiance,
                normal,
                ..
            } => area * lum(*radiance) * PI * if normal.is_some() { 1.0 } else { 2.0 },
            Light::Sphere {
                radius, radiance, ..
            } => sphere_area(*radius) * lum(*radiance) * PI,
            Light::Point { intensity, .. } => 4.0 * PI * lum(*intensity),
            Light::Spot {
                intensity,
                cos_cutoff,
                ..
            } => 2.0 * PI * (1.0 - cos_cutoff) * lum(*intensity),
            Light::Directional { irradiance, .. } => disk * lum(*irradiance),
            Light::Ambient { radiance } => 2.0 * PI * disk * lum(*radiance),
            Light::Environment(e) => 4.0 * PI * disk * e.average_luminance(),
            Light::Infinite(l) => 4.0 * PI * disk * l.average_luminance(),
        };
        if p.is_finite() {
            p.max(0.0)
        } else {
            0.0
        }
    }

    /// Solid-angle pdf with which [`Light::sample`] from `p` picks the point `q` (geometric
    /// normal `n`) of this light's surface; 0 for delta and infinite lights.
    pub fn pdf_point(&self, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        let Some(area) = self.surface_area() else {
            return 0.0;
        };
        let d = q - p;
        let d2 = d.length_squared();
        let cos = (d.dot(n) / d2.sqrt()).abs();
        if cos > 0.0 && area > 0.0 {
            d2 / (area * cos)
        } else {
            0.0
        }
    }

    /// Solid-angle pdf with which [`Light::sample`] picks direction `d` for an infinite light.
    pub fn pdf_direction(&self, d: Vec3) -> f32 {
        match self {
            Light::Ambient { .. } if d.y > 0.0 => UNIFORM_HEMISPHERE_PDF,
            Light::Environment(e) => e.pdf(d),
            Light::Infinite(l) => l.pdf(d),
            _ => 0.0,
        }
    }
}

/// Power-heuristic weight (β = 2) of a strategy taking `na` samples with pdf `pa` against one
/// taking `nb` samples with pdf `pb` (Veach 1997).
#[inline]
pub fn power_heuristic(na: f32, pa: f32, nb: f32, pb: f32) -> f32 {
    crate::lanes::power_heuristic(na * pa, nb * pb)
}

/// A spot light's falloff at `cos θ = c` from its axis, between the cone's edge `cos_cutoff`
/// and `cos_start`: pbrt-v4's smoothstep in `cos θ`, or Mitsuba's linear ramp in `θ`
/// (`linear`); 1 inside `cos_start` (and everywhere when `cos_start ≤ cos_cutoff`).
#[inline]
fn spot_falloff(c: f32, cos_cutoff: f32, cos_start: f32, linear: bool) -> f32 {
    if cos_start <= cos_cutoff {
        return 1.0;
    }
    if linear {
        let (edge, start) = (
            cos_cutoff.clamp(-1.0, 1.0).acos(),
            cos_start.clamp(-1.0, 1.0).acos(),
        );
        return ((edge - c.clamp(-1.0, 1.0).acos()) / (edge - start)).clamp(0.0, 1.0);
    }
    let t = ((c - cos_cutoff) / (cos_start - cos_cutoff)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> Triangle {
        Triangle { v: [a, b, c] }
    }

    /// A CGL-style rectangle: corners `c ± dx ± dy`, split along the diagonal `p0 p2`.
    fn rectangle() -> [Triangle; 2] {
        let (c, dx, dy) = (Vec3::new(0.0, 1.5, 0.0), Vec3::X * 0.25, Vec3::Z * 0.125);
        let p = [c - dx - dy, c + dx - dy, c + dx + dy, c - dx + dy];
        [tri(p[0], p[1], p[2]), tri(p[0], p[2], p[3])]
    }

    #[test]
    fn a_rectangle_is_one_parallelogram() {
        let [a, b] = rectangle();
        for (x, y) in [(&a, &b), (&b, &a)] {
            let q = Parallelogram::of_triangles(x, y).expect("a rectangle");
            assert!((q.e1.cross(q.e2).length() - (a.area() + b.area())).abs() < 1e-6);
            assert!((q.n.dot(a.unit_normal()).abs() - 1.0).abs() < 1e-6);
            // Its corners are the rectangle's.
            for u in [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE] {
                let p = q.point(u);
                assert!(a.v.iter().chain(&b.v).any(|v| (*v - p).length() < 1e-6));
            }
        }
    }

    #[test]
    fn other_pairs_are_not_parallelograms() {
        let [a, b] = rectangle();
        // A kite: the shared edge is a diagonal, but the far vertex is not mirrored.
        let kite = tri(b.v[0], b.v[1], b.v[2] + Vec3::X * 0.1);
        assert_eq!(Parallelogram::of_triangles(&a, &kite), None);
        // Both triangles on the same side of their shared edge.
        let same_side = tri(a.v[0], a.v[2], a.v[1] + Vec3::Z * 0.01);
        assert_eq!(Parallelogram::of_triangles(&a, &same_side), None);
        // Only one vertex shared, or the same triangle twice.
        let apart = tri(a.v[0], a.v[1] * 2.0, a.v[2] * 3.0);
        assert_eq!(Parallelogram::of_triangles(&a, &apart), None);
        assert_eq!(Parallelogram::of_triangles(&a, &a), None);
    }

    /// Sampling the rectangle as one parallelogram and by its triangles estimates the same
    /// irradiance at a receiver (both are uniform by area).
    #[test]
    fn parallelogram_and_triangle_sampling_agree() {
        let tris = rectangle().to_vec();
        let quad = Parallelogram::of_triangles(&tris[0], &tris[1]);
        assert!(quad.is_some());
        let dist = Distribution1D::new(&[tris[0].area(), tris[1].area()]);
        let light = |quad| Light::Area {
            tris: vec![0, 1],
            area: dist.total(),
            dist: dist.clone(),
            radiance: Vec3::ONE,
            normal: Some(-Vec3::Y),
            texture: None,
            quad,
        };
        let (by_quad, by_tris) = (light(quad), light(None));
        for p in [Vec3::ZERO, Vec3::new(0.4, 1.2, -0.3)] {
            let estimate = |l: &Light| {
                let mut rng = Rng::new(7, 1);
                let n = 400_000;
                let mut sum = 0.0f64;
                for _ in 0..n {
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    if let Some(s) = l.sample(&tris, p, u) {
                        sum += (s.li.x * s.wi.y.max(0.0) / s.pdf) as f64;
                    }
                }
                sum / n as f64
            };
            let (e1, e2) = (estimate(&by_quad), estimate(&by_tris));
            assert!(e1 > 0.0 && ((e1 - e2) / e2).abs() < 0.005, "{e1} vs {e2}");
        }
    }
}
