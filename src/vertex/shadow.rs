//! Shadow rays through null surfaces and media: what gets through from a vertex to a light
//! or the eye.

use super::flight::{transmit, Transmission};
use crate::math::{offset_origin, Ray};
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::Vec3;

/// Null surfaces a ray may cross between two vertices before it is given up.
pub(crate) const MAX_CROSSINGS: u32 = 256;

/// Where a shadow ray goes and what it starts in.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShadowRay {
    /// The point it ends at, `None` for infinitely far.
    pub target: Option<Vec3>,
    /// The medium at its origin.
    pub medium: u32,
    /// The hero channel of the path it serves.
    pub hero: usize,
}

/// The shadow ray from `o` along unit `d`: aimed at `target` from `o` and stopping just
/// short of it, or without end where there is no target (a light infinitely far).
#[inline]
pub(crate) fn aimed(o: Vec3, d: Vec3, target: Option<Vec3>) -> Ray {
    match target {
        Some(q) => {
            let to = q - o;
            let len = to.length();
            let mut r = Ray::new(o, to / len);
            r.t_max = len * (1.0 - 1e-4);
            r
        }
        None => Ray::new(o, d),
    }
}

/// Whether nothing blocks the light-sampling ray from `o` along `d` to `target` ([`aimed`])
/// in a scene without media ([`Scene::light_occluded`]: cut-outs that block light sampling
/// stop it); the ray is counted in `rays`.
#[inline]
pub(crate) fn reaches_light(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    target: Option<Vec3>,
    rays: &mut u64,
) -> bool {
    *rays += 1;
    !scene.light_occluded(&aimed(o, d, target))
}

/// Whether nothing blocks the ray from `o` to the eye at `eye` ([`Scene::occluded`]: it
/// passes the holes of every cut-out, as camera rays do); the ray is counted in `rays`.
#[inline]
pub(crate) fn reaches_eye(scene: &Scene, o: Vec3, d: Vec3, eye: Vec3, rays: &mut u64) -> bool {
    *rays += 1;
    !scene.occluded(&aimed(o, d, Some(eye)))
}

/// What gets through from `o` along unit `d` to the end of shadow ray `shadow`, crossing
/// null surfaces (each ray traced is counted; grid media draw from `rng`); `None` where a
/// surface that is not null blocks the way or nothing gets through. Each ray towards a target
/// is aimed at it from its own origin and stops just short of it.
pub(crate) fn shadow_transmittance(
    scene: &Scene,
    mut o: Vec3,
    d: Vec3,
    shadow: ShadowRay,
    rng: &mut Rng,
    rays: &mut u64,
) -> Option<Transmission> {
    let mut acc = Transmission::CLEAR;
    let mut medium = shadow.medium;
    for _ in 0..MAX_CROSSINGS {
        if let Some(q) = shadow.target {
            let to = q - o;
            let len = to.length();
            if len.is_nan() || len <= 0.0 || to.dot(d) <= 0.0 {
                return Some(acc);
            }
        }
        let ray = aimed(o, d, shadow.target);
        *rays += 1;
        let hit = scene.intersect(&ray);
        let (surf, t) = match hit {
            Some(hit) => {
                let surf = scene.surface(&ray, &hit);
                if !scene.materials[surf.material as usize].null {
                    return None;
                }
                (Some(surf), hit.t)
            }
            None => (None, ray.t_max),
        };
        if let Some(m) = scene.media.get(medium as usize) {
            if !transmit(m, &ray, t, shadow.hero, rng, &mut acc) {
                return None;
            }
        }
        let Some(surf) = surf else {
            return Some(acc);
        };
        if let Some(i) = scene.materials[surf.material as usize].interface {
            medium = i.toward(ray.d, surf.ng);
        }
        o = offset_origin(surf.p, surf.ng, ray.d);
    }
    None
}
