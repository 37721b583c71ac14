//! Free flights and shadow-ray transmittance through one medium, with the spectral-MIS
//! weights of `Weights`.
//!
//! Homogeneous media are sampled exactly: a collision distance from the hero's extinction,
//! and transmittance in closed form. Grid media follow pbrt-v4's null-scattering formulation
//! (Miller et al. 2019): tentative collisions at the rate of the majorant of each cell the ray
//! crosses, each one real with probability `σt/σ_maj` of the hero (delta tracking) for free
//! flights, or weighed by `σn/σ_maj` (ratio tracking) for shadow rays, with emission
//! gathered at every tentative collision.

use crate::math::{Ray, Rgb};
use crate::medium::{transmittance, GridMedium, Homogeneous, Medium};
use crate::sampling::Rng;
use glam::Vec3;

/// A path's weights (see the module's notes on spectral MIS).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Weights {
    /// Throughput, divided by the hero's densities.
    pub beta: Rgb,
    /// Per channel: the path's density with that channel as hero over the hero's.
    pub r_u: Rgb,
    /// Per channel: light sampling's density of the path up to the next emitter over the
    /// hero's density of the path (set at each non-delta vertex).
    pub r_l: Rgb,
    /// The hero channel (0, 1 or 2).
    pub hero: usize,
}

impl Weights {
    /// Whether the path still carries something.
    pub fn alive(&self) -> bool {
        self.beta.max_element() > 0.0 && self.beta.is_finite() && self.r_u.max_element() > 0.0
    }
}

/// The mean of the three channels.
#[inline]
pub(crate) fn average(v: Rgb) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

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

/// Tentative collisions along `ray` up to `t_max` in grid medium `m`, at the hero channel's
/// majorant rate (pbrt-v4's `SampleT_maj`): the first distance from `u`, further numbers from
/// `rng`. At each, `at(t, σ_maj, T_maj, rng)` is called with the majorant transmittance since
/// the previous one; it returns false to stop there (then `None`). Returns the majorant
/// transmittance from the last collision to the end.
fn track(
    m: &GridMedium,
    ray: &Ray,
    t_max: f32,
    (hero, mut u): (usize, f32),
    rng: &mut Rng,
    mut at: impl FnMut(f32, Rgb, Rgb, &mut Rng) -> bool,
) -> Option<Rgb> {
    let mut t_maj = Vec3::ONE;
    for (t0, t1, sigma_maj) in m.segments(ray, t_max) {
        if sigma_maj[hero] <= 0.0 {
            t_maj *= transmittance(sigma_maj, t1 - t0);
            continue;
        }
        let mut t_prev = t0;
        loop {
            let t = t_prev - (1.0 - u).ln() / sigma_maj[hero];
            u = rng.next_f32();
            if t >= t1 {
                t_maj *= transmittance(sigma_maj, t1 - t_prev);
                break;
            }
            t_maj *= transmittance(sigma_maj, t - t_prev);
            if !at(t, sigma_maj, t_maj, rng) {
                return None;
            }
            t_maj = Vec3::ONE;
            t_prev = t;
        }
    }
    Some(t_maj)
}

/// A free flight through grid medium `m` by delta tracking against its majorant grid.
fn delta_track(
    m: &GridMedium,
    ray: &Ray,
    t_max: f32,
    u: f32,
    rng: &mut Rng,
    w: &mut Weights,
    mut emitted: Option<&mut Rgb>,
) -> Flight {
    let h = w.hero;
    let mut collided = None;
    let end = track(m, ray, t_max, (h, u), rng, |t, sigma_maj, t_maj, rng| {
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
            collided = Some(t);
            return false;
        }
        let sigma_n = (sigma_maj - sigma_t).max(Vec3::ZERO);
        let pdf = hero_tr * sigma_n[h];
        if pdf > 0.0 {
            w.beta *= t_maj * sigma_n / pdf;
            w.r_u *= t_maj * sigma_n / pdf;
            w.r_l *= t_maj * sigma_maj / pdf;
        } else {
            w.beta = Vec3::ZERO;
        }
        w.alive()
    });
    match (end, collided) {
        (_, Some(t)) => Flight::Collided(t),
        (None, None) => Flight::Passed,
        (Some(t_maj), None) => {
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
    }
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
    let u = rng.next_f32();
    let end = track(m, ray, t_max, (h, u), rng, |t, sigma_maj, t_maj, rng| {
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
        acc.tr.max_element() > 0.0
    });
    match end {
        Some(t_maj) if t_maj[h] > 0.0 => {
            let p = t_maj[h];
            acc.tr *= t_maj / p;
            acc.r_l *= t_maj / p;
            acc.r_u *= t_maj / p;
        }
        _ => acc.tr = Vec3::ZERO,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::grid::{Factor, Field, GridEdge, GridFilter, VoxelGrid};
    use glam::{Affine3A, Quat};
    use std::sync::Arc;

    /// A chromatic grid medium of random densities in a tilted box around the origin.
    fn medium() -> Medium {
        let mut rng = Rng::new(17, 3);
        let res = [6u32, 4, 5];
        let values = (0..6 * 4 * 5 * 3).map(|_| rng.next_f32() * 2.0).collect();
        let grid = VoxelGrid::new(res, 3, values, GridEdge::Zero, GridFilter::Trilinear).unwrap();
        let to_unit = Affine3A::from_scale_rotation_translation(
            Vec3::new(0.5, 0.4, 0.6),
            Quat::from_rotation_z(0.4),
            Vec3::splat(0.5),
        );
        let density = Some(Factor {
            grid: 0,
            complement: false,
        });
        let field = |scale| Field {
            scale,
            factors: [density, None],
        };
        let sigma_a = field(Vec3::new(0.2, 0.5, 0.1));
        let sigma_s = field(Vec3::new(0.9, 0.3, 1.4));
        let fields = (sigma_a, sigma_s, Field::constant(Vec3::ZERO));
        Medium::Grid(Box::new(
            GridMedium::new(to_unit, vec![Arc::new(grid)], fields, 0.0).unwrap(),
        ))
    }

    /// `exp(−∫σt)` along `ray` to `t_max` by the midpoint rule on 20 000 steps.
    fn quadrature(m: &Medium, ray: &Ray, t_max: f32) -> Rgb {
        let Medium::Grid(g) = m else { unreachable!() };
        let n = 20_000;
        let dt = t_max / n as f32;
        let mut tau = Vec3::ZERO;
        for i in 0..n {
            let p = g.at(ray.at((i as f32 + 0.5) * dt));
            tau += (p.sigma_a + p.sigma_s) * dt;
        }
        Vec3::new((-tau.x).exp(), (-tau.y).exp(), (-tau.z).exp())
    }

    /// Asserts that per-channel samples `sum`, `sum_sq` over `n` have a mean within five
    /// standard errors (and 1e-3) of `expected`.
    fn assert_mean(sum: [f64; 3], sum_sq: [f64; 3], n: f64, expected: Rgb, what: &str) {
        for c in 0..3 {
            let mean = sum[c] / n;
            let var = (sum_sq[c] / n - mean * mean).max(0.0);
            let tolerance = 5.0 * (var / n).sqrt() + 1e-3;
            let want = f64::from(expected[c]);
            assert!(
                (mean - want).abs() < tolerance,
                "{what}, channel {c}: {mean} against quadrature {want} (± {tolerance})"
            );
        }
    }

    fn rays() -> Vec<(Ray, f32)> {
        let through = |o: Vec3, d: Vec3| Ray::new(o, d.normalize());
        vec![
            (through(Vec3::new(-3.0, 0.1, 0.2), Vec3::X), 6.0),
            (
                through(Vec3::new(-2.0, -2.0, -1.0), Vec3::new(1.0, 1.0, 0.5)),
                5.0,
            ),
            // Ends inside the box.
            (through(Vec3::new(0.3, -3.0, 0.0), Vec3::Y), 3.1),
            (
                through(Vec3::new(0.2, 0.2, 3.0), Vec3::new(0.1, -0.2, -1.0)),
                8.0,
            ),
        ]
    }

    #[test]
    fn ratio_tracking_estimates_the_quadrature_transmittance_for_every_hero() {
        let m = medium();
        let mut rng = Rng::new(5, 6);
        for (i, (ray, t_max)) in rays().into_iter().enumerate() {
            let expected = quadrature(&m, &ray, t_max);
            assert!(expected.max_element() < 0.95, "ray {i} misses the medium");
            for hero in 0..3 {
                let (mut sum, mut sum_sq) = ([0.0f64; 3], [0.0f64; 3]);
                let n = 40_000;
                for _ in 0..n {
                    let mut acc = Transmission::CLEAR;
                    transmit(&m, &ray, t_max, hero, &mut rng, &mut acc);
                    for c in 0..3 {
                        sum[c] += f64::from(acc.tr[c]);
                        sum_sq[c] += f64::from(acc.tr[c]).powi(2);
                    }
                }
                assert_mean(
                    sum,
                    sum_sq,
                    n as f64,
                    expected,
                    &format!("ray {i} hero {hero}"),
                );
            }
        }
    }

    #[test]
    fn delta_tracking_passes_with_the_quadrature_transmittance() {
        // Over uniformly chosen heroes, a flight that passes weighs beta / mean(r_u): its
        // expectation is the transmittance of every channel (spectral MIS).
        let m = medium();
        let mut rng = Rng::new(8, 9);
        for (i, (ray, t_max)) in rays().into_iter().enumerate() {
            let expected = quadrature(&m, &ray, t_max);
            let (mut sum, mut sum_sq) = ([0.0f64; 3], [0.0f64; 3]);
            let n = 60_000;
            for k in 0..n {
                let mut w = Weights {
                    beta: Vec3::ONE,
                    r_u: Vec3::ONE,
                    r_l: Vec3::ONE,
                    hero: k % 3,
                };
                let u = rng.next_f32();
                let v = match flight(&m, &ray, t_max, u, &mut rng, &mut w, None) {
                    Flight::Passed if w.alive() => w.beta / average(w.r_u),
                    _ => Vec3::ZERO,
                };
                for c in 0..3 {
                    sum[c] += f64::from(v[c]);
                    sum_sq[c] += f64::from(v[c]).powi(2);
                }
            }
            assert_mean(sum, sum_sq, n as f64, expected, &format!("ray {i}"));
        }
    }

    #[test]
    fn homogeneous_media_transmit_beer_lambert_exactly() {
        let h = Homogeneous {
            sigma_a: Vec3::new(0.1, 0.2, 0.3),
            sigma_s: Vec3::new(0.5, 0.0, 0.2),
            g: 0.0,
            le: Vec3::ZERO,
        };
        let mut acc = Transmission::CLEAR;
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        transmit(
            &Medium::Homogeneous(h),
            &ray,
            2.0,
            1,
            &mut Rng::new(1, 1),
            &mut acc,
        );
        assert_eq!(acc.tr, h.transmittance(2.0));
        assert_eq!(acc.r_u, h.transmittance(2.0));
        assert_eq!(acc.r_l, Vec3::ONE);
    }
}
