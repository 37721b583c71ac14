//! PROTOTYPE: eight camera samples of one pixel traced together, for scenes of diffuse
//! surfaces lit by one rectangular area light. The shading of the eight paths (frames, light
//! sampling, MIS weights, BSDF sampling, roulette) runs as loops over the lanes that the
//! compiler vectorises; ray queries, surfaces and sample numbers stay per lane. Every lane does
//! the scalar integrator's operations in the same order, so the result is bit-identical to
//! [`crate::integrator::radiance`].

use crate::bsdf::Bsdf;
use crate::integrator::{Direct, IntegratorSettings, LightSelection};
use crate::light::{power_heuristic, Light};
use crate::math::{offset_origin, Frame, Ray, Rgb};
use crate::sampling::sampler::{dim, Sampler};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::scene::{Scene, Surface, NO_LIGHT};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Paths per packet.
pub const LANES: usize = 8;

/// Whether [`radiance8`] can trace `scene` with settings `s`.
pub fn supported(scene: &Scene, s: &IntegratorSettings) -> bool {
    let light_ok = scene.lights.len() == 1
        && matches!(
            scene.lights[0],
            Light::Area {
                quad: Some(_),
                texture: None,
                normal: Some(_),
                ..
            }
        );
    let materials_ok = scene.materials.iter().all(|m| {
        matches!(m.bsdf, Bsdf::Diffuse { .. } | Bsdf::Black)
            && m.textures.base.is_none()
            && m.textures.normal.is_none()
    });
    s.direct == Direct::Mis
        && s.selection == LightSelection::Power
        && s.light_samples == 1
        && s.accumulate
        && light_ok
        && materials_ok
        && {
            static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
            *ON.get_or_init(|| std::env::var("PT_PACKET").is_ok())
        }
}

/// Inputs of the vector stage of one bounce.
#[derive(Clone, Copy)]
struct In {
    p: [Vec3; LANES],
    ng: [Vec3; LANES],
    ns: [Vec3; LANES],
    d: [Vec3; LANES],
    albedo: [Vec3; LANES],
    beta: [Vec3; LANES],
    ul: [Vec2; LANES],
    ub: [Vec2; LANES],
    urr: [f32; LANES],
}

/// Outputs of the vector stage of one bounce.
#[derive(Clone, Copy)]
struct Out {
    /// Light sample: whether a shadow ray is traced, and its ray.
    shadow: [bool; LANES],
    so: [Vec3; LANES],
    sd: [Vec3; LANES],
    st: [f32; LANES],
    /// Contribution if unoccluded (already times `beta`).
    c: [Vec3; LANES],
    /// Continuation: whether it goes on, its ray origin and direction, new beta, BSDF pdf.
    cont: [bool; LANES],
    o: [Vec3; LANES],
    wi: [Vec3; LANES],
    beta: [Vec3; LANES],
    pdf: [f32; LANES],
}

/// The vector stage: the scalar integrator's shading of a diffuse vertex, lane by lane.
#[inline(never)]
fn shade(
    inp: &In,
    out: &mut Out,
    quad: (Vec3, Vec3, Vec3),
    normal: Vec3,
    pdf_area: f32,
    li: Rgb,
    pmf: f32,
    rr: bool,
) {
    for i in 0..LANES {
        let p = inp.p[i];
        let wo_w = -inp.d[i];
        // Surface::facing
        let front = inp.ng[i].dot(wo_w) >= 0.0;
        let ng = if front { inp.ng[i] } else { -inp.ng[i] };
        let ns = if inp.ns[i].dot(ng) < 0.0 {
            -inp.ns[i]
        } else {
            inp.ns[i]
        };
        let frame = Frame::from_normal(ns);
        let wo = frame.to_local(wo_w);
        let albedo = inp.albedo[i];
        let beta = inp.beta[i];
        // Light sample (Light::from_point on the parallelogram).
        let u = inp.ul[i];
        let q = quad.0 + quad.1 * u.x + quad.2 * u.y;
        let d = q - p;
        let d2 = d.length_squared();
        let dist = d2.sqrt();
        let lwi = d / dist;
        let cos_l = -lwi.dot(normal);
        let lpdf = pdf_area * d2 / cos_l;
        let side = lwi.dot(ng);
        let wi = frame.to_local(lwi);
        let f_ok = wo.z > 0.0 && wi.z > 0.0;
        let f = if f_ok { albedo * FRAC_1_PI } else { Vec3::ZERO };
        let ok = d2 != 0.0
            && cos_l > 0.0
            && side != 0.0
            && side >= 0.0
            && ((wi.z > 0.0) == (side > 0.0))
            && f.max_element() > 0.0;
        let so = offset_origin(p, ng, lwi);
        let to = p + lwi * dist - so;
        let len = to.length();
        out.shadow[i] = ok;
        out.so[i] = so;
        out.sd[i] = to / len;
        out.st[i] = len * (1.0 - 1e-4);
        let bpdf = if f_ok { cosine_hemisphere_pdf(wi) } else { 0.0 };
        let w = power_heuristic(1.0, 1.0 * pmf * lpdf, 1.0, bpdf);
        let ld = f * li * (wi.z.abs() * w / lpdf);
        out.c[i] = beta * ld;
        // BSDF sample.
        let bwi = cosine_hemisphere(inp.ub[i]);
        let pdf = cosine_hemisphere_pdf(bwi);
        let wi_w = frame.to_world(bwi);
        let c = wi_w.dot(ng);
        let mut cont = wo.z > 0.0 && pdf > 0.0 && (c > 0.0) == (bwi.z > 0.0) && c != 0.0;
        let mut nb = beta * albedo;
        if rr {
            let q = nb.max_element().min(1.0);
            let survive = !(q.is_nan() || q <= 0.0 || inp.urr[i] >= q);
            cont = cont && survive;
            nb /= q;
        }
        cont = cont && !(nb.max_element() <= 0.0 || !nb.is_finite());
        out.cont[i] = cont;
        out.beta[i] = nb;
        out.o[i] = offset_origin(p, ng, wi_w);
        out.wi[i] = wi_w;
        out.pdf[i] = pdf;
    }
}

/// Radiance of eight camera rays (as [`crate::integrator::radiance`] on each); `rays[i]`
/// counts lane `i`'s rays.
pub fn radiance8(
    scene: &Scene,
    cam: &[Ray; LANES],
    samplers: &[Sampler; LANES],
    s: &IntegratorSettings,
    rays: &mut [u64; LANES],
) -> [Rgb; LANES] {
    let Light::Area {
        quad: Some(quad),
        normal: Some(normal),
        area,
        radiance: li,
        ..
    } = &scene.lights[0]
    else {
        unreachable!("checked by supported()")
    };
    let quad_t = (quad.o, quad.e1, quad.e2);
    let pdf_area = 1.0 / area;
    let pmf = scene.light_pmf(0);
    let m = s.max_depth;
    let mut l = [Vec3::ZERO; LANES];
    let mut alive = [false; LANES];
    let dummy = Surface {
        p: Vec3::ZERO,
        ng: Vec3::Y,
        ns: Vec3::Y,
        material: 0,
        light: NO_LIGHT,
        uv: Vec2::ZERO,
    };
    let mut surf = [dummy; LANES];
    let mut inp = In {
        p: [Vec3::ZERO; LANES],
        ng: [Vec3::Y; LANES],
        ns: [Vec3::Y; LANES],
        d: [Vec3::Y; LANES],
        albedo: [Vec3::ZERO; LANES],
        beta: [Vec3::ONE; LANES],
        ul: [Vec2::ZERO; LANES],
        ub: [Vec2::ZERO; LANES],
        urr: [0.0; LANES],
    };
    for i in 0..LANES {
        rays[i] += 1;
        inp.d[i] = cam[i].d;
        match scene.intersect(&cam[i]) {
            None => l[i] = scene.escaped(cam[i].d),
            Some(h) => {
                surf[i] = scene.surface(&cam[i], &h);
                l[i] += scene.emitted(&surf[i], -cam[i].d);
                alive[i] = true;
            }
        }
    }
    let mut out = Out {
        shadow: [false; LANES],
        so: [Vec3::ZERO; LANES],
        sd: [Vec3::Y; LANES],
        st: [0.0; LANES],
        c: [Vec3::ZERO; LANES],
        cont: [false; LANES],
        o: [Vec3::ZERO; LANES],
        wi: [Vec3::Y; LANES],
        beta: [Vec3::ONE; LANES],
        pdf: [0.0; LANES],
    };
    for depth in 1..=m {
        if !alive.iter().any(|&a| a) {
            break;
        }
        let rr = depth >= s.rr_depth && depth < m;
        for i in 0..LANES {
            if !alive[i] {
                continue;
            }
            let albedo = match scene.bsdf(&surf[i]) {
                Bsdf::Diffuse { albedo } => albedo,
                _ => Vec3::ZERO,
            };
            if albedo == Vec3::ZERO {
                alive[i] = false;
                continue;
            }
            let sm = &samplers[i];
            inp.p[i] = surf[i].p;
            inp.ng[i] = surf[i].ng;
            inp.ns[i] = surf[i].ns;
            inp.albedo[i] = albedo;
            inp.ul[i] = sm.get_2d_sub(dim::bounce(depth, dim::LIGHT_POINT), 0, 1);
            inp.ub[i] = sm.get_2d(dim::bounce(depth, dim::BSDF_DIRECTION));
            if rr {
                inp.urr[i] = sm.get_1d(dim::bounce(depth, dim::ROULETTE));
            }
        }
        shade(&inp, &mut out, quad_t, *normal, pdf_area, *li, pmf, rr);
        for i in 0..LANES {
            if !alive[i] {
                continue;
            }
            if out.shadow[i] {
                rays[i] += 1;
                let mut r = Ray::new(out.so[i], out.sd[i]);
                r.t_max = out.st[i];
                if !scene.occluded(&r) {
                    l[i] += out.c[i];
                }
            }
            if !out.cont[i] {
                alive[i] = false;
                continue;
            }
            let from = surf[i].p;
            let wi_w = out.wi[i];
            let ray = Ray::new(out.o[i], wi_w);
            inp.beta[i] = out.beta[i];
            inp.d[i] = wi_w;
            rays[i] += 1;
            match scene.intersect(&ray) {
                Some(h) => {
                    surf[i] = scene.surface(&ray, &h);
                    if surf[i].light != NO_LIGHT {
                        let le = scene.emitted(&surf[i], -wi_w);
                        let pl = scene.lights[0].pdf_point(from, surf[i].p, surf[i].ng);
                        let w = power_heuristic(1.0, out.pdf[i], 1.0, 1.0 * pmf * pl);
                        l[i] += inp.beta[i] * le * w;
                    }
                }
                None => {
                    alive[i] = false;
                }
            }
        }
    }
    l
}
