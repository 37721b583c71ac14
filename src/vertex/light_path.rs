//! Where light paths start and how they scatter, for both light tracers
//! (`lighttrace` on surfaces, `vollight` through media): the caustic
//! surfaces they aim at, the emission they leave a light with, the adjoint BSDF samples
//! and Veach's shading-normal correction.

use super::{sides_agree, SurfaceVertex};
use crate::bsdf::{reflect, refract, schlick, Bsdf};
use crate::light::Light;
use crate::math::{offset_origin, Frame, Ray, Rgb};
use crate::sampling::cosine_hemisphere;
use crate::sampling::sampler::{dim, Sampler};
use crate::scene::{Scene, Surface};
use glam::{Vec2, Vec3};

/// Conductors with a roughness α below this are caustic surfaces ([`is_caustic`]).
pub const CAUSTIC_ALPHA: f32 = 0.3;

/// True for the surfaces whose light paths this module traces: delta BSDFs and smooth
/// conductors (α < [`CAUSTIC_ALPHA`]).
#[inline]
pub fn is_caustic(b: &Bsdf) -> bool {
    match b {
        Bsdf::Mirror { .. } | Bsdf::Glass { .. } | Bsdf::Refraction { .. } => true,
        Bsdf::Microfacet(m) => m.alpha < CAUSTIC_ALPHA,
        _ => false,
    }
}

/// Whether light paths can start in `scene` and reach `camera`: a perspective pinhole, some
/// finite emitter, and every area light untextured (light paths leave area lights and
/// spheres only).
pub(crate) fn emits_to(scene: &Scene, camera: &crate::camera::Camera) -> bool {
    if camera.lens_radius > 0.0 || camera.orthographic {
        return false;
    }
    let mut finite = false;
    for l in &scene.lights {
        match l {
            Light::Area {
                texture: Some(_), ..
            } => return false,
            Light::Area { .. } | Light::Sphere { .. } => finite = true,
            _ => {}
        }
    }
    finite
}

/// Bounding spheres of the surfaces whose BSDF satisfies `pick`: each such sphere, and one
/// sphere around all such triangles.
pub fn targets(scene: &Scene, pick: impl Fn(&Bsdf) -> bool) -> Vec<(Vec3, f32)> {
    let caustic = |m: u32| {
        scene
            .materials
            .get(m as usize)
            .is_some_and(|m| pick(&m.bsdf))
    };
    let mut out: Vec<(Vec3, f32)> = scene
        .spheres
        .iter()
        .zip(&scene.sphere_info)
        .filter(|(_, i)| caustic(i.material))
        .map(|(s, _)| (s.center, s.radius))
        .collect();
    let mut b = crate::math::Aabb::EMPTY;
    for (t, i) in scene.tris.iter().zip(&scene.tri_info) {
        if caustic(i.material) {
            for v in t.v {
                b = b.grow(v);
            }
        }
    }
    if !b.is_empty() {
        // A little larger, so that rounding never leaves a caustic point outside.
        let r = 0.5 * b.extent().length();
        out.push((b.center(), r * 1.001 + 1e-6));
    }
    out
}

/// The cone of directions from `q` towards target sphere `(c, r)`: unit axis and cosine of
/// its half angle; `None` when `q` is inside the sphere.
#[inline]
fn cone(q: Vec3, c: Vec3, r: f32) -> Option<(Vec3, f32)> {
    let d = c - q;
    let d2 = d.length_squared();
    if d2 <= r * r {
        return None;
    }
    let dist = d2.sqrt();
    Some((d / dist, (1.0 - r * r / d2).max(0.0).sqrt()))
}

/// Samples a direction from `q` uniformly within the union of the cones towards `targets`
/// (a cone chosen in proportion to its solid angle with `u.x`, whose remainder is reused):
/// the direction and its solid-angle density ([`pdf_towards`]). `None` when `q` lies inside a
/// target (the caller then samples the whole hemisphere) or there is no target.
pub fn sample_towards(targets: &[(Vec3, f32)], q: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
    let mut total = 0.0f32;
    for &(c, r) in targets {
        let (_, cos_max) = cone(q, c, r)?;
        total += 1.0 - cos_max;
    }
    if total <= 0.0 || total.is_nan() {
        return None;
    }
    let mut x = u.x * total;
    for (i, &(c, r)) in targets.iter().enumerate() {
        let (axis, cos_max) = cone(q, c, r)?;
        let a = 1.0 - cos_max;
        if x < a || i + 1 == targets.len() {
            let v = (x / a).clamp(0.0, 1.0);
            let cos_t = 1.0 - v * a;
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            let local = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
            let w = Frame::from_normal(axis).to_world(local).normalize();
            let pdf = pdf_towards(targets, q, w);
            return Some((w, pdf));
        }
        x -= a;
    }
    None
}

/// Density of [`sample_towards`] at unit direction `w`: the number of cones holding `w` over
/// their summed solid angle (cones taken 10⁻⁶ wider in the cosine, for rounding).
pub fn pdf_towards(targets: &[(Vec3, f32)], q: Vec3, w: Vec3) -> f32 {
    let (mut total, mut inside) = (0.0f32, 0u32);
    for &(c, r) in targets {
        let Some((axis, cos_max)) = cone(q, c, r) else {
            return 0.0;
        };
        total += 1.0 - cos_max;
        // A sampled direction can round to just outside its cone; the band of 10⁻⁶ in the
        // cosine that takes it in lies outside the target sphere, where rays hit nothing.
        inside += (w.dot(axis) >= cos_max - 1e-6) as u32;
    }
    if total > 0.0 {
        inside as f32 / (2.0 * std::f32::consts::PI * total)
    } else {
        0.0
    }
}

/// What one light path needs besides the scene.
#[derive(Clone, Copy, Debug)]
pub struct LightPathSettings<'a> {
    /// The camera light paths are joined to.
    pub camera: &'a crate::camera::Camera,
    /// Bounding spheres of the caustic surfaces (`caustic_targets`).
    pub targets: &'a [(Vec3, f32)],
    /// One frame pixel in `stride` starts a light path in each light pass ([`starts_path`]);
    /// splats are scaled by `stride`.
    pub stride: u32,
    /// Frame size in pixels.
    pub width: u32,
    /// See `width`.
    pub height: u32,
    /// CS184 `max_ray_depth`: a joined path of `k` surfaces belongs to bounce `k`.
    pub max_depth: u32,
    /// Sum all bounces (`-o 1`) or only bounce `max_depth`.
    pub accumulate: bool,
    /// Vertex index from which Russian roulette may end the light path.
    pub rr_depth: u32,
    /// Russian roulette's survival scale (`crate::vertex::IntegratorSettings::rr_survival`).
    pub rr_survival: f32,
}

impl LightPathSettings<'_> {
    /// The light tracers' roulette rule, counted from the light.
    #[inline]
    pub(crate) fn roulette_rule(&self) -> super::RouletteRule {
        super::RouletteRule {
            rr_depth: self.rr_depth,
            max_depth: self.max_depth,
            scale: self.rr_survival,
        }
    }
}

/// Light paths per frame pixel and pass: one in this many (every light path meets a caustic
/// surface first, so a few go a long way against the path tracer's remaining noise).
pub const STRIDE: u32 = 8;

/// True when frame pixel `(x, y)` starts a light path in light pass `k`: one pixel in
/// `stride`, a different one in each pass.
#[inline]
pub fn starts_path(s: &LightPathSettings, x: u32, y: u32, k: u32) -> bool {
    (y as u64 * s.width as u64 + x as u64 + k as u64).is_multiple_of(s.stride as u64)
}

/// The start of a light path: the light, the point it leaves, that point's surface normal
/// (as [`Light::surface_point`] gives it), the path's throughput `Le · cos / (pmf · p_area ·
/// p_side · p_dir)` and its first ray.
pub(crate) struct Emission {
    pub light: usize,
    pub point: Vec3,
    pub normal: Vec3,
    pub beta: Rgb,
    pub ray: Ray,
}

/// Leaves a finite emitter chosen by power (from slots `slot(0, 0..4)` of `sampler`): a point
/// by area, a side of a two-sided emitter by a coin, a direction towards `targets` where the
/// point is outside them all ([`sample_towards`]), else cosine-distributed. `None` where the
/// scene emits nothing, the chosen light is not an untextured area light or sphere, or the
/// sample is degenerate.
pub(crate) fn emit(scene: &Scene, targets: &[(Vec3, f32)], sampler: &Sampler) -> Option<Emission> {
    let slot = |i: u32| dim::light_vertex(0, i);
    if scene.light_selection.total() <= 0.0 {
        return None;
    }
    let (j, pmf, _) = scene
        .light_selection
        .sample(sampler.get_1d(slot(dim::LIGHT_CHOICE)));
    let light = &scene.lights[j];
    let le = match light {
        Light::Area {
            radiance,
            texture: None,
            ..
        }
        | Light::Sphere { radiance, .. } => *radiance,
        _ => return None,
    };
    let (q, normal, one_sided, pdf_area) =
        light.surface_point(&scene.tris, sampler.get_2d(slot(dim::LIGHT_POINT)))?;
    if normal == Vec3::ZERO || !(pdf_area > 0.0 && pdf_area.is_finite()) || pmf <= 0.0 {
        return None;
    }
    // A two-sided emitter picks its side with a coin.
    let (mut n, mut side_pdf) = (normal, 1.0);
    if !one_sided {
        side_pdf = 0.5;
        if sampler.get_1d(slot(dim::BSDF_LOBE)) < 0.5 {
            n = -n;
        }
    }
    let ud = sampler.get_2d(slot(dim::BSDF_DIRECTION));
    let (d, dir_weight) = match sample_towards(targets, q, ud) {
        Some((d, pdf)) => (d, d.dot(n) / pdf),
        None => (
            Frame::from_normal(n).to_world(cosine_hemisphere(ud)),
            std::f32::consts::PI,
        ),
    };
    if d.dot(n) <= 0.0 || !(dir_weight > 0.0 && dir_weight.is_finite()) {
        return None;
    }
    Some(Emission {
        light: j,
        point: q,
        normal,
        beta: le * (dir_weight / (pmf * pdf_area * side_pdf)),
        ray: Ray::new(offset_origin(q, n, d), d),
    })
}

/// Whether `b` is one of the surfaces volumetric light paths pass through first
/// (`vollight`): delta BSDFs.
#[inline]
pub fn passes(b: &Bsdf) -> bool {
    b.is_delta()
}

/// Veach's correction of the adjoint BSDF for shading normals: `|wl·ns| |wc·ng| / (|wl·ng|
/// |wc·ns|)` (1 where they agree; 0 for grazing geometric angles).
#[inline]
pub(crate) fn shading_correction(wl: Vec3, wc: Vec3, ns: Vec3, ng: Vec3) -> f32 {
    let den = wl.dot(ng).abs() * wc.dot(ns).abs();
    if den == 0.0 {
        return 0.0;
    }
    wl.dot(ns).abs() * wc.dot(ng).abs() / den
}

/// Samples the camera-side direction `wc` of a light path arriving along `wl` (local frame,
/// `wl.z > 0`; `front`: `wl` is on the outside): the direction, the weight `f* · |cos| / pdf`
/// and the refraction factor `(n_l / n_c)⁴` (1 without refraction).
#[inline]
pub(crate) fn adjoint_sample(
    b: &Bsdf,
    wl: Vec3,
    u: Vec2,
    u1: f32,
    front: bool,
) -> Option<(Vec3, Rgb, f32)> {
    match *b {
        Bsdf::Glass {
            reflectance,
            transmittance,
            ior,
        } => {
            let eta = if front { 1.0 / ior } else { ior };
            match refract(wl, eta) {
                None => Some((reflect(wl), reflectance, 1.0)),
                Some(wt) => {
                    let r_l = schlick(wl.z, ior);
                    if u1 < r_l {
                        Some((reflect(wl), reflectance, 1.0))
                    } else {
                        let r_c = schlick(wt.z.abs(), ior);
                        let e4 = (eta * eta) * (eta * eta);
                        let w = transmittance * (e4 * (1.0 - r_c) / (1.0 - r_l));
                        Some((wt, w, e4))
                    }
                }
            }
        }
        Bsdf::Refraction { transmittance, ior } => {
            let eta = if front { 1.0 / ior } else { ior };
            let e4 = (eta * eta) * (eta * eta);
            refract(wl, eta).map(|wt| (wt, transmittance * e4, e4))
        }
        _ => b.sample(wl, u, u1, front).map(|bs| {
            // Importance is not scaled by 1/η² across a refraction as radiance is.
            let scale = if bs.wi.z < 0.0 {
                b.radiance_scale(front)
            } else {
                1.0
            };
            (bs.wi, bs.weight / scale, 1.0)
        }),
    }
}

/// Continues a light path that reached `surf` (BSDF `bsdf`) along `-wl` by the adjoint BSDF,
/// with the numbers of light-path vertex `vertex`: the vertex seen from the light's side, the
/// camera-side direction `wc`, the throughput factor (the adjoint sample's weight times
/// Veach's shading-normal correction and the shadowing of a bent normal) and the refraction
/// factor `(n_l / n_c)⁴` (1 without refraction); `None` where the path ends.
#[inline]
pub(crate) fn scatter_adjoint(
    scene: &Scene,
    surf: Surface,
    bsdf: Bsdf,
    wl: Vec3,
    sampler: &Sampler,
    vertex: u32,
) -> Option<(SurfaceVertex, Vec3, Rgb, f32)> {
    let v = SurfaceVertex::new(scene, surf, bsdf, wl);
    let u = sampler.get_2d(dim::light_vertex(vertex, dim::BSDF_DIRECTION));
    let u1 = sampler.get_1d(dim::light_vertex(vertex, dim::BSDF_LOBE));
    let (wc_local, weight, scale) = adjoint_sample(&v.bsdf, v.wo, u, u1, v.front)?;
    let wc = v.frame.to_world(wc_local);
    if !sides_agree(wc.dot(v.ng), wc_local.z) {
        return None;
    }
    let correction = shading_correction(wl, wc, v.frame.n, v.ng) * scene.shadowing(&surf, wl);
    Some((v, wc, weight * correction, scale))
}

/// Where point `p` projects on `s`'s camera: the continuous frame position, the camera's
/// importance over the squared distance `focal² / (cos³ θ · d²)` and the unit direction from
/// `p` to the eye; `None` outside the frame or behind the camera.
pub(crate) fn project(s: &LightPathSettings, p: Vec3) -> Option<(f32, f32, f32, Vec3)> {
    let cam = s.camera;
    let v = p - cam.pos;
    let z = v.dot(cam.forward);
    if z <= 0.0 {
        return None;
    }
    let (w, h) = (s.width as f32, s.height as f32);
    let px = w * 0.5 + cam.focal_px * v.dot(cam.right) / z;
    let py = h * 0.5 - cam.focal_px * v.dot(cam.up) / z;
    if !(px >= 0.0 && px < w && py >= 0.0 && py < h) {
        return None;
    }
    let d2 = v.length_squared();
    let dist = d2.sqrt();
    let cos = z / dist;
    let importance = cam.focal_px * cam.focal_px / (cos * cos * cos) / d2;
    Some((px, py, importance, -v / dist))
}

/// What surface `surf` (BSDF `bsdf`), reached by a light path along `-wl`, sends towards the
/// eye in direction `wc` with the camera's `importance`: the vertex seen from the camera and
/// `f · |wc·ng| · |cos θi| / |wl·ng| · importance` (the adjoint BSDF with Veach's
/// shading-normal correction); `None` where it sends nothing.
#[inline]
pub(crate) fn seen_by_camera(
    scene: &Scene,
    surf: Surface,
    bsdf: Bsdf,
    wl: Vec3,
    wc: Vec3,
    importance: f32,
) -> Option<(SurfaceVertex, Rgb)> {
    let v = SurfaceVertex::new(scene, surf, bsdf, wc);
    let (f, wi) = v.scatter(scene, wl)?;
    let side = wl.dot(v.ng);
    Some((
        v,
        f * (wc.dot(v.ng).abs() * wi.z.abs() / side.abs() * importance),
    ))
}

/// The share of a light path's value that one camera connection splats: the frame's pixels
/// are reached by one light path per `stride` pixels.
#[inline]
pub(crate) fn splat_scale(s: &LightPathSettings) -> f32 {
    s.stride as f32 / (s.width as f32 * s.height as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{chi2_test_sphere, Chi2Config};

    #[test]
    fn directions_towards_the_caustic_surfaces_match_their_pdf() {
        // Two overlapping cones and a third one, seen from a point outside all three: the
        // histogram fits the density, the density integrates to 1 over the sphere, and the
        // density returned with a sample is `pdf_towards`.
        let q = Vec3::new(0.1, 0.2, -0.3);
        let targets = [
            (Vec3::new(1.0, 0.5, 0.0), 0.6),
            (Vec3::new(1.2, -0.2, 0.3), 0.5),
            (Vec3::new(-0.5, 0.0, 2.0), 0.4),
        ];
        // Fine cells and sub-grids: the density is discontinuous at the cones' rims.
        let cfg = Chi2Config {
            samples: 1_000_000,
            theta_bins: 40,
            phi_bins: 80,
            resolution: 24,
            ..Default::default()
        };
        chi2_test_sphere(
            &cfg,
            |u| {
                let (w, pdf) = sample_towards(&targets, q, u)?;
                assert!((pdf - pdf_towards(&targets, q, w)).abs() <= 1e-6 * pdf);
                Some(w)
            },
            |w| pdf_towards(&targets, q, w),
        )
        .unwrap();
        // Inside a target there is no cone: the caller samples the hemisphere.
        assert!(sample_towards(&targets, Vec3::new(1.0, 0.5, 0.1), Vec2::splat(0.5)).is_none());
    }
}
