//! Free flights and shadow-ray transmittance through one medium, with the spectral-MIS
//! weights of [`Weights`].
//!
//! Homogeneous media are sampled exactly: a collision distance from the hero's extinction,
//! and transmittance in closed form. Grid media follow pbrt-v4's null-scattering formulation
//! (Miller et al. 2019): tentative collisions at the rate of the majorant of each cell the ray
//! crosses, each one real with probability `σt/σ_maj` of the hero (delta tracking) for free
//! flights, or weighed by `σn/σ_maj` (ratio tracking) for shadow rays, with emission
//! gathered at every tentative collision.

use super::{average, Weights};
use crate::math::{Ray, Rgb};
use crate::medium::{transmittance, GridMedium, Homogeneous, Medium};
use crate::sampling::Rng;
use glam::Vec3;

/// What a free flight ended in.
pub(crate) enum Flight {
    /// A collision at this distance (the weights already updated).
    Collided(f32),
    /// It reached the end of its segment (the weights already updated).
    Passed,
}

/// A free flight along `ray` up to distance `t_max` in `medium`: the first number `u` from
/// the caller, further ones from `rng`. The weights are updated for the event that happened;
/// where `emitted` is given, the medium's emission along the way is added to it (weighted,
/// ready to add to the path's radiance).
pub(crate) fn flight(
    medium: &Medium,
    ray: &Ray,
    t_max: f32,
    u: f32,
    rng: &mut Rng,
    w: &mut Weights,
    emitted: Option<&mut Rgb>,
) -> Flight {
    match medium {
        Medium::Homogeneous(h) => fly(h, t_max, u, w, emitted),
        Medium::Grid(m) => delta_track(m, ray, t_max, u, rng, w, emitted),
    }
}

/// A free flight through homogeneous medium `h`: a collision distance sampled from the
/// hero's extinction; a collision always scatters, weighted by the albedo.
fn fly(h: &Homogeneous, t_max: f32, u: f32, w: &mut Weights, emitted: Option<&mut Rgb>) -> Flight {
    let sigma_t = h.sigma_t();
    let sh = sigma_t[w.hero];
    if sh > 0.0 {
        let t = -(1.0 - u).ln() / sh;
        if t < t_max {
            let tr = transmittance(sigma_t, t);
            let pdf = sh * tr[w.hero];
            if let Some(e) = emitted {
                *e += emission(w, tr / pdf, sigma_t, h.sigma_a * h.le);
            }
            w.beta *= h.sigma_s * tr / pdf;
            w.r_u *= sigma_t * tr / pdf;
            return Flight::Collided(t);
        }
    }
    let tr = transmittance(sigma_t, t_max);
    let p = tr[w.hero];
    if p > 0.0 {
        w.beta *= tr / p;
        w.r_u *= tr / p;
        w.r_l /= p;
    } else {
        w.beta = Vec3::ZERO;
    }
    Flight::Passed
}

/// The emission estimate at a tentative collision of a path with weights `w`: `scaled_tr`
/// is the majorant transmittance to it over the hero's density of sampling it, `sigma_maj`
/// the majorant, `source` the medium's `σa·Le` there.
#[inline]
fn emission(w: &Weights, scaled_tr: Rgb, sigma_maj: Rgb, source: Rgb) -> Rgb {
    if source.max_element() <= 0.0 {
        return Vec3::ZERO;
    }
    let r_e = average(w.r_u * sigma_maj * scaled_tr);
    if r_e > 0.0 {
        w.beta * scaled_tr * source / r_e
    } else {
        Vec3::ZERO
    }
}

/// A free flight through grid medium `m` by delta tracking against its majorant grid.
fn delta_track(
    m: &GridMedium,
    ray: &Ray,
    t_max: f32,
    mut u: f32,
    rng: &mut Rng,
    w: &mut Weights,
    mut emitted: Option<&mut Rgb>,
) -> Flight {
    let h = w.hero;
    let mut t_maj = Vec3::ONE;
    for (t0, t1, sigma_maj) in m.segments(ray, t_max) {
        if sigma_maj[h] <= 0.0 {
            t_maj *= transmittance(sigma_maj, t1 - t0);
            continue;
        }
        let mut t_prev = t0;
        loop {
            let t = t_prev - (1.0 - u).ln() / sigma_maj[h];
            u = rng.next_f32();
            if t >= t1 {
                t_maj *= transmittance(sigma_maj, t1 - t_prev);
                break;
            }
            t_maj *= transmittance(sigma_maj, t - t_prev);
            let mp = m.at(ray.at(t));
            let hero_tr = t_maj[h];
            if let Some(e) = emitted.as_deref_mut() {
                let source = mp.sigma_a * mp.le;
                *e += emission(w, t_maj / (hero_tr * sigma_maj[h]), sigma_maj, source);
            }
            let sigma_t = mp.sigma_a + mp.sigma_s;
            if rng.next_f32() * sigma_maj[h] < sigma_t[h] {
                let pdf = hero_tr * sigma_t[h];
                w.beta *= t_maj * mp.sigma_s / pdf;
                w.r_u *= t_maj * sigma_t / pdf;
                return Flight::Collided(t);
            }
            let sigma_n = (sigma_maj - sigma_t).max(Vec3::ZERO);
            let pdf = hero_tr * sigma_n[h];
            if !(pdf > 0.0) {
                w.beta = Vec3::ZERO;
                return Flight::Passed;
            }
            w.beta *= t_maj * sigma_n / pdf;
            w.r_u *= t_maj * sigma_n / pdf;
            w.r_l *= t_maj * sigma_maj / pdf;
            if !w.alive() {
                return Flight::Passed;
            }
            t_maj = Vec3::ONE;
            t_prev = t;
        }
    }
    let p = t_maj[h];
    if p > 0.0 {
        w.beta *= t_maj / p;
        w.r_u *= t_maj / p;
        w.r_l *= t_maj / p;
    } else {
        w.beta = Vec3::ZERO;
    }
    Flight::Passed
}

/// What the media along a shadow ray let through, with what spectral MIS needs: per channel,
/// the transmittance estimate `tr`, and the densities, relative to the hero's, with which
/// light sampling (`r_l`) and the path's own flights (`r_u`) produce its tracking decisions.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Transmission {
    pub tr: Rgb,
    pub r_l: Rgb,
    pub r_u: Rgb,
}

impl Transmission {
    /// Nothing in the way yet.
    pub const CLEAR: Transmission = Transmission {
        tr: Vec3::ONE,
        r_l: Vec3::ONE,
        r_u: Vec3::ONE,
    };

    /// The spectral-MIS estimate of the transmittance itself, for a path with hero
    /// densities `r_u` so far (light tracing's camera connections).
    pub fn seen_by(&self, r_u: Rgb) -> Rgb {
        let r = average(r_u * self.r_l);
        if r > 0.0 {
            self.tr / r
        } else {
            Vec3::ZERO
        }
    }
}

/// Multiplies into `acc` what `medium` lets through along `ray` up to distance `t`, for hero
/// channel `hero`: exactly for homogeneous media, by ratio tracking with Russian roulette
/// (numbers from `rng`) for grids. False where nothing gets through.
pub(crate) fn transmit(
    medium: &Medium,
    ray: &Ray,
    t: f32,
    hero: usize,
    rng: &mut Rng,
    acc: &mut Transmission,
) -> bool {
    match medium {
        Medium::Homogeneous(h) => {
            let tr = h.transmittance(t);
            acc.tr *= tr;
            acc.r_u *= tr;
        }
        Medium::Grid(m) => ratio_track(m, ray, t, hero, rng, acc),
    }
    acc.tr.max_element() > 0.0
}

/// Ratio tracking through grid medium `m` (pbrt-v4's `SampleLd` loop).
fn ratio_track(
    m: &GridMedium,
    ray: &Ray,
    t_max: f32,
    h: usize,
    rng: &mut Rng,
    acc: &mut Transmission,
) {
    let mut t_maj = Vec3::ONE;
    for (t0, t1, sigma_maj) in m.segments(ray, t_max) {
        if sigma_maj[h] <= 0.0 {
            t_maj *= transmittance(sigma_maj, t1 - t0);
            continue;
        }
        let mut t_prev = t0;
        loop {
            let t = t_prev - (1.0 - rng.next_f32()).ln() / sigma_maj[h];
            if t >= t1 {
                t_maj *= transmittance(sigma_maj, t1 - t_prev);
                break;
            }
            t_maj *= transmittance(sigma_maj, t - t_prev);
            let mp = m.at(ray.at(t));
            let sigma_n = (sigma_maj - mp.sigma_a - mp.sigma_s).max(Vec3::ZERO);
            let pdf = t_maj[h] * sigma_maj[h];
            acc.tr *= t_maj * sigma_n / pdf;
            acc.r_l *= t_maj * sigma_maj / pdf;
            acc.r_u *= t_maj * sigma_n / pdf;
            let estimate = acc.tr / average(acc.r_l + acc.r_u);
            if estimate.max_element() < 0.05 {
                const KILL: f32 = 0.75;
                if rng.next_f32() < KILL {
                    acc.tr = Vec3::ZERO;
                } else {
                    acc.tr /= 1.0 - KILL;
                }
            }
            if !(acc.tr.max_element() > 0.0) {
                acc.tr = Vec3::ZERO;
                return;
            }
            t_maj = Vec3::ONE;
            t_prev = t;
        }
    }
    let p = t_maj[h];
    if p > 0.0 {
        acc.tr *= t_maj / p;
        acc.r_l *= t_maj / p;
        acc.r_u *= t_maj / p;
    } else {
        acc.tr = Vec3::ZERO;
    }
}
