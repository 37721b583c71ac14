//! Caustic light tracing: paths that leave a light through specular or near-specular
//! surfaces, connected to the camera from the diffuse and glossy surfaces they reach.
//!
//! # Partition (why the sum is unbiased)
//! A *caustic* surface is one whose BSDF is a delta lobe (mirror, glass, refraction) or a
//! conductor rougher than nothing but smoother than [`CAUSTIC_ALPHA`] ([`is_caustic`]). With
//! light tracing on, the path tracer ([`crate::integrator::radiance`]) leaves out every path
//! `camera → x1 → … → xk → light` whose first hit `x1` is *not* caustic and whose last
//! surface `xk` *is* caustic, with a finite emitter (area light or emissive sphere) at its
//! end: it neither adds the light found by light sampling at `xk` nor the emission its
//! continuation ray finds. Exactly those paths are what this module traces from the other
//! end: a light path starts on a finite emitter, must meet a caustic surface first, then goes
//! on through any surfaces, and every non-caustic, non-delta vertex `x` it reaches is joined
//! to the camera (a shadow ray), which gives the path `camera → x → … → light`. Both sides
//! evaluate the same measurement, so the image is the sum of the two estimates.
//!
//! # Conventions
//! - A light pass `k` traces one light path for one frame pixel `(x, y)` in [`STRIDE`]
//!   ([`starts_path`]), drawing from the numbers of camera sample `k` of that pixel
//!   ([`crate::sampling::sampler::Sampler`], slots from [`SLOT_BASE`]); so light paths, like
//!   camera samples, are pure functions of the seed, pixel and sample index, and a sample
//!   range `[a, b)` holds light passes `[a, b)`.
//! - A light path's first direction is sampled uniformly within the cones towards the
//!   bounding spheres of the caustic surfaces ([`caustic_targets`], [`sample_towards`]), so
//!   it meets a caustic surface first far more often; from a point inside one of them it is
//!   cosine-distributed over the hemisphere.
//! - A joined vertex adds `C · STRIDE / (W·H)` to the pixel it projects to, where `W × H` is the frame
//!   and `C` the path's contribution with the pinhole's importance (`1 / (A_pixel · cos³ θ)`
//!   for a box pixel of area `A_pixel` on the plane at distance 1); the film divides the sums
//!   by the number of light passes ([`crate::film::Film::light_passes`]). Splats are added as
//!   fixed-point integers, so their sums do not depend on thread count or order.
//! - Light paths use the adjoint BSDFs: diffuse and conductor BSDFs are symmetric; a delta
//!   refraction carries `T · (n_l / n_c)⁴ · (1 − R_c) / (1 − R_l)` (the path tracer's
//!   CS184 weight `T · (n_l / n_c)²` times the Jacobian `(n_l / n_c)²` of refraction), where
//!   `l` is the light's side, `c` the camera's and `R` Schlick's reflectance at each side's
//!   angle; shading normals are corrected as Veach (1997, §5.3) describes.
//! - Light tracing is used only where it can represent every such path: a pinhole camera,
//!   not CS184's `-a` (the adaptive budget takes one light pass per level of its rounds, as
//!   a uniform render of its mean budget would), and scenes whose emitters
//!   are untextured area lights or spheres (point, spot and infinite lights stay with the path
//!   tracer) and whose BSDFs are diffuse, mirror, glass, refraction or conductors ([`usable`]).

use crate::bsdf::{reflect, refract, schlick, Bsdf};
use crate::light::Light;
use crate::math::{offset_origin, Frame, Ray, Rgb};
use crate::sampling::cosine_hemisphere;
use crate::sampling::sampler::Sampler;
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// Conductors with a roughness α below this are caustic surfaces ([`is_caustic`]).
pub const CAUSTIC_ALPHA: f32 = 0.3;

/// First dimension slot of light paths (far above the path tracer's slots).
pub const SLOT_BASE: u32 = 0xC000_0000;

/// Slots per light-path vertex.
const SLOTS_PER_VERTEX: u32 = 4;

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

/// True when light tracing can represent every path the path tracer leaves to it in `scene`
/// seen through its camera: a perspective pinhole, finite emitters that are untextured area lights or
/// spheres, BSDFs that light paths can sample (see the module documentation), and at least
/// one caustic surface and one finite emitter (else it would add nothing). Volumetric scenes
/// have light paths of their own ([`crate::vollight::usable`]).
pub fn usable(scene: &Scene, camera: &crate::camera::Camera) -> bool {
    if scene.volumetric {
        return crate::vollight::usable(scene, camera);
    }
    let supported = |b: &Bsdf| {
        matches!(
            b,
            Bsdf::Diffuse { .. }
                | Bsdf::Mirror { .. }
                | Bsdf::Glass { .. }
                | Bsdf::Refraction { .. }
                | Bsdf::Microfacet(_)
                | Bsdf::Black
        )
    };
    let caustic = scene.materials.iter().any(|m| is_caustic(&m.bsdf));
    emits_to(scene, camera) && caustic && scene.materials.iter().all(|m| supported(&m.bsdf))
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

/// Bounding spheres `(centre, radius)` of the scene's caustic surfaces: each caustic sphere,
/// and one sphere around all caustic triangles. A light path's first hit must be a caustic
/// surface, so its first direction is sampled only towards these ([`sample_towards`]). In
/// volumetric scenes, the delta surfaces ([`crate::vollight::delta_targets`]).
pub fn caustic_targets(scene: &Scene) -> Vec<(Vec3, f32)> {
    if scene.volumetric {
        crate::vollight::delta_targets(scene)
    } else {
        targets(scene, is_caustic)
    }
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
    /// Bounding spheres of the caustic surfaces ([`caustic_targets`]).
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
pub(crate) fn emit(
    scene: &Scene,
    targets: &[(Vec3, f32)],
    sampler: &Sampler,
    slot: impl Fn(u32, u32) -> u32,
) -> Option<Emission> {
    if scene.light_selection.total() <= 0.0 {
        return None;
    }
    let (j, pmf, _) = scene.light_selection.sample(sampler.get_1d(slot(0, 0)));
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
        light.surface_point(&scene.tris, sampler.get_2d(slot(0, 1)))?;
    if normal == Vec3::ZERO || !(pdf_area > 0.0 && pdf_area.is_finite()) || pmf <= 0.0 {
        return None;
    }
    // A two-sided emitter picks its side with a coin.
    let (mut n, mut side_pdf) = (normal, 1.0);
    if !one_sided {
        side_pdf = 0.5;
        if sampler.get_1d(slot(0, 3)) < 0.5 {
            n = -n;
        }
    }
    let ud = sampler.get_2d(slot(0, 2));
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

/// Traces the light path of `sampler` (a camera sample's numbers) and calls
/// `splat(x, y, value)` for each camera connection with the continuous frame position it
/// lands at and its value `C / (W·H)`. Returns the rays traced. Volumetric scenes trace
/// [`crate::vollight::trace`]'s paths.
pub fn trace(
    scene: &Scene,
    s: &LightPathSettings,
    sampler: &Sampler,
    mut splat: impl FnMut(f32, f32, Rgb),
) -> u64 {
    if s.max_depth < 2 {
        return 0;
    }
    if scene.volumetric {
        return crate::vollight::trace(scene, s, sampler, splat);
    }
    let slot = |vertex: u32, i: u32| SLOT_BASE + vertex * SLOTS_PER_VERTEX + i;
    let Some(Emission { beta, ray, .. }) = emit(scene, s.targets, sampler, slot) else {
        return 0;
    };
    let (mut beta, mut ray) = (beta, ray);
    // Product of the (n_l/n_c)⁴ factors of refractions (undone for roulette).
    let mut eta_scale = 1.0f32;
    let mut rays = 0u64;
    for vertex in 1..=s.max_depth {
        rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            break;
        };
        let surf = scene.surface(&ray, &hit);
        let bsdf = scene.bsdf(&surf);
        if bsdf.is_black() {
            break;
        }
        let caustic = is_caustic(&bsdf);
        if vertex == 1 && !caustic {
            break; // the path tracer's own path
        }
        let wl = -ray.d;
        if !caustic && !bsdf.is_delta() && (s.accumulate || vertex == s.max_depth) {
            rays += connect(scene, s, &surf, bsdf, wl, beta, &mut splat);
        }
        if vertex == s.max_depth {
            break;
        }
        // Continue: sample the adjoint BSDF in the frame of the light's side.
        let (front, ng, frame) = surf.facing(wl);
        let ns = frame.n;
        let wl_local = frame.to_local(wl);
        let bsdf = scene.seen_from(bsdf, &surf, front);
        let u = sampler.get_2d(slot(vertex, 1));
        let u1 = sampler.get_1d(slot(vertex, 0));
        let Some((wc_local, weight, scale)) = adjoint_sample(&bsdf, wl_local, u, u1, front) else {
            break;
        };
        let wc = frame.to_world(wc_local);
        let side = wc.dot(ng);
        if (side > 0.0) != (wc_local.z > 0.0) || side == 0.0 {
            break;
        }
        beta *= weight * shading_correction(wl, wc, ns, ng) * scene.shadowing(&surf, wl);
        eta_scale *= scale;
        if vertex >= s.rr_depth {
            let p = (beta.max_element() / eta_scale).min(1.0);
            if p.is_nan() || p <= 0.0 || sampler.get_1d(slot(vertex, 2)) >= p {
                break;
            }
            beta /= p;
        }
        if beta.max_element() <= 0.0 || !beta.is_finite() {
            break;
        }
        ray = Ray::new(offset_origin(surf.p, ng, wc), wc);
    }
    rays
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
        _ => b.sample(wl, u, u1, front).map(|bs| (bs.wi, bs.weight, 1.0)),
    }
}

/// Joins light-path vertex `surf` (reached along `-wl`, throughput `beta`) to the camera:
/// splats the contribution into the pixel it projects to when nothing blocks the view.
/// Returns the rays traced (0 or 1).
fn connect(
    scene: &Scene,
    s: &LightPathSettings,
    surf: &crate::scene::Surface,
    bsdf: Bsdf,
    wl: Vec3,
    beta: Rgb,
    splat: &mut impl FnMut(f32, f32, Rgb),
) -> u64 {
    let cam = s.camera;
    let v = surf.p - cam.pos;
    let z = v.dot(cam.forward);
    if z <= 0.0 {
        return 0;
    }
    let (w, h) = (s.width as f32, s.height as f32);
    let px = w * 0.5 + cam.focal_px * v.dot(cam.right) / z;
    let py = h * 0.5 - cam.focal_px * v.dot(cam.up) / z;
    if !(px >= 0.0 && px < w && py >= 0.0 && py < h) {
        return 0;
    }
    let d2 = v.length_squared();
    let dist = d2.sqrt();
    let wc = -v / dist;
    // The path tracer's view of this vertex: frame on the camera's side.
    let (front, ng, frame) = surf.facing(wc);
    let (wo, wi) = (frame.to_local(wc), frame.to_local(wl));
    let side = wl.dot(ng);
    let bsdf = scene.seen_from(bsdf, surf, front);
    if side == 0.0 || (side < 0.0 && !bsdf.transmits()) || (wi.z > 0.0) != (side > 0.0) {
        return 0;
    }
    let f = bsdf.eval(wo, wi) * scene.shadowing(surf, wl);
    if f.max_element() <= 0.0 {
        return 0;
    }
    let cos_cam = z / dist;
    let importance = cam.focal_px * cam.focal_px / (cos_cam * cos_cam * cos_cam);
    let c = beta * f * (wc.dot(ng).abs() * wi.z.abs() / side.abs() / d2 * importance);
    if !c.is_finite() || c.max_element() <= 0.0 {
        return 0;
    }
    // Shadow ray from the vertex towards the eye, stopping just short of it.
    let o = offset_origin(surf.p, ng, wc);
    let to = cam.pos - o;
    let len = to.length();
    let mut r = Ray::new(o, to / len);
    r.t_max = len * (1.0 - 1e-4);
    if scene.occluded(&r) {
        return 1;
    }
    splat(px, py, c * (s.stride as f32 / (w * h)));
    1
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
