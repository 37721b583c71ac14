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
//! - A light pass `k` traces one light path per frame pixel `(x, y)`, drawing from the numbers
//!   of camera sample `k` of that pixel ([`crate::sampling::sampler::Sampler`], slots from
//!   [`SLOT_BASE`]); so light paths, like camera samples, are pure functions of the seed,
//!   pixel and sample index, and a sample range `[a, b)` holds light passes `[a, b)`.
//! - A joined vertex adds `C / (W·H)` to the pixel it projects to, where `W × H` is the frame
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
//!   uniform sampling (not CS184's `-a` or the adaptive budget), and scenes whose emitters
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
/// seen through its camera: a pinhole, finite emitters that are untextured area lights or
/// spheres, BSDFs that light paths can sample (see the module documentation), and at least
/// one caustic surface and one finite emitter (else it would add nothing).
pub fn usable(scene: &Scene) -> bool {
    if scene.camera.lens_radius > 0.0 {
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
    finite && caustic && scene.materials.iter().all(|m| supported(&m.bsdf))
}

/// What one light path needs besides the scene.
#[derive(Clone, Copy, Debug)]
pub struct LightPathSettings {
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

/// Traces the light path of `sampler` (a camera sample's numbers) and calls
/// `splat(x, y, value)` for each camera connection with the frame pixel it lands in and its
/// value `C / (W·H)`. Returns the rays traced.
pub fn trace(
    scene: &Scene,
    s: &LightPathSettings,
    sampler: &Sampler,
    mut splat: impl FnMut(u32, u32, Rgb),
) -> u64 {
    let slot = |vertex: u32, i: u32| SLOT_BASE + vertex * SLOTS_PER_VERTEX + i;
    let total = scene.light_selection.total();
    if total <= 0.0 || s.max_depth < 2 {
        return 0;
    }
    // The emitter, by power (lights this module does not emit from end the path).
    let (j, pmf, _) = scene.light_selection.sample(sampler.get_1d(slot(0, 0)));
    let u = sampler.get_2d(slot(0, 1));
    let (q, n, one_sided, le, pdf_area) = match &scene.lights[j] {
        Light::Area {
            tris,
            dist,
            area,
            radiance,
            normal,
            texture: None,
        } => {
            let (i, _, ux) = dist.sample(u.x);
            let tri = &scene.tris[tris[i] as usize];
            let b = crate::sampling::uniform_triangle(Vec2::new(ux, u.y));
            let q = tri.v[0] * (1.0 - b.x - b.y) + tri.v[1] * b.x + tri.v[2] * b.y;
            let n = normal.unwrap_or_else(|| tri.cross().normalize_or_zero());
            (q, n, normal.is_some(), *radiance, 1.0 / area)
        }
        Light::Sphere {
            center,
            radius,
            radiance,
        } => {
            let n = crate::sampling::uniform_sphere(u);
            let area = 4.0 * std::f32::consts::PI * radius * radius;
            (*center + n * *radius, n, false, *radiance, 1.0 / area)
        }
        _ => return 0,
    };
    if n == Vec3::ZERO || !(pdf_area > 0.0 && pdf_area.is_finite()) || pmf <= 0.0 {
        return 0;
    }
    // A two-sided emitter picks its side with a coin; directions are cosine-distributed.
    let mut side_pdf = 1.0;
    let mut n = n;
    if !one_sided {
        side_pdf = 0.5;
        if sampler.get_1d(slot(0, 3)) < 0.5 {
            n = -n;
        }
    }
    let d = Frame::from_normal(n).to_world(cosine_hemisphere(sampler.get_2d(slot(0, 2))));
    if d.dot(n) <= 0.0 {
        return 0;
    }
    // Le · cos / (pmf · p_area · side · cos/π).
    let mut beta = le * (std::f32::consts::PI / (pmf * pdf_area * side_pdf));
    // Product of the (n_l/n_c)⁴ factors of refractions (undone for roulette).
    let mut eta_scale = 1.0f32;
    let mut ray = Ray::new(offset_origin(q, n, d), d);
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
        let front = surf.ng.dot(wl) >= 0.0;
        let ng = if front { surf.ng } else { -surf.ng };
        let ns = if surf.ns.dot(ng) < 0.0 {
            -surf.ns
        } else {
            surf.ns
        };
        let frame = Frame::from_normal(ns);
        let wl_local = frame.to_local(wl);
        let bsdf = bsdf.facing(front);
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
        beta *= weight * shading_correction(wl, wc, ns, ng);
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
fn shading_correction(wl: Vec3, wc: Vec3, ns: Vec3, ng: Vec3) -> f32 {
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
fn adjoint_sample(b: &Bsdf, wl: Vec3, u: Vec2, u1: f32, front: bool) -> Option<(Vec3, Rgb, f32)> {
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
    splat: &mut impl FnMut(u32, u32, Rgb),
) -> u64 {
    let cam = &scene.camera;
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
    let front = surf.ng.dot(wc) >= 0.0;
    let ng = if front { surf.ng } else { -surf.ng };
    let ns = if surf.ns.dot(ng) < 0.0 {
        -surf.ns
    } else {
        surf.ns
    };
    let frame = Frame::from_normal(ns);
    let (wo, wi) = (frame.to_local(wc), frame.to_local(wl));
    let side = wl.dot(ng);
    let bsdf = bsdf.facing(front);
    if side == 0.0 || (side < 0.0 && !bsdf.transmits()) || (wi.z > 0.0) != (side > 0.0) {
        return 0;
    }
    let f = bsdf.eval(wo, wi);
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
    splat(px as u32, py as u32, c / (w * h));
    1
}
