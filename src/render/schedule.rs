//! The schedules that fill a film, one per mode: one pass to the target (uniform, and CS184's
//! `-a` with its per-pixel stopping rule), passes of one sample per pixel under a time limit,
//! and the adaptive budget's rounds (each brought to its targets in one pass, or under a time
//! limit in sub-passes). Light passes follow the camera passes they belong to.

use super::session::{cap, reached, Session};
use super::{allocate, RenderStats};
use crate::film::Film;
use crate::integrator::packet::LANES;

/// Passes per round of the adaptive budget under a time limit.
const SUB_PASSES: u64 = 16;

/// Fills `film` by the schedule of the session's options and returns the figures.
pub(super) fn run(s: &Session, film: &mut Film) -> RenderStats {
    let opts = &s.opts;
    if !opts.adaptive_budget {
        for p in film.pixels_mut() {
            p.target = s.count;
        }
    } else if film.level == 0 {
        // The adaptive budget starts from a uniform pilot of n0 samples per pixel.
        let n0 = (opts.spp / 8).clamp(2, 16);
        for p in film.pixels_mut() {
            p.target = n0;
        }
        film.level = n0;
    }
    let mut more = to_targets(s, film);
    if opts.adaptive_budget {
        more = budget_rounds(s, film, more);
    }
    let complete = more && s.reached_all(film);
    s.stats(film, complete)
}

/// Brings every pixel to its target: one pass without a time limit; with one, passes of one
/// sample per pixel (uniform) or the adaptive round's sub-passes. False when time ran out or
/// the render was stopped first.
fn to_targets(s: &Session, film: &mut Film) -> bool {
    // Light passes to hold at the end: the budget's level (mean samples per pixel) with the
    // adaptive budget, all of them otherwise.
    let light_target = if s.opts.adaptive_budget {
        film.level.min(s.count)
    } else {
        s.count
    };
    if s.opts.time_limit.is_none() {
        s.pass(film, u32::MAX, !s.opts.adaptive_budget);
        s.light_to(film, light_target);
        return !s.stopped() || s.reached_to(film, light_target);
    }
    if s.opts.adaptive_budget {
        return budget_sub_passes(s, film, light_target);
    }
    unit_passes(s, film)
}

/// Passes of one sample per pixel (with their light passes) until the target, the time
/// limit or a stop; the result of N passes equals an N-spp render.
fn unit_passes(s: &Session, film: &mut Film) -> bool {
    let done = film.pixels().iter().map(|p| p.n).min().unwrap_or(0);
    for k in done..s.count {
        s.pass(film, k + 1, false);
        s.light_to(film, k + 1);
        (s.ctl.progress)(k as usize + 1, s.count as usize);
        if s.out_of_time() || s.stopped() {
            return s.reached_all(film);
        }
    }
    s.light_to(film, s.count)
}

/// An adaptive round under a time limit: [`SUB_PASSES`] passes that each take every pixel
/// that fraction of the way to its target (in whole packets); a pass that would end past the
/// limit (judged by the last pass) is cut to the part that fits, so the round ends at the
/// limit rather than up to a pass before or after it.
fn budget_sub_passes(s: &Session, film: &mut Film, light_target: u32) -> bool {
    let from: Vec<u32> = film.pixels().iter().map(|p| p.n).collect();
    let target: Vec<u32> = film.pixels().iter().map(|p| p.target).collect();
    let light_from = film.light_passes.min(light_target);
    // Pixel `i`'s target after `f` of the round's SUB_PASSES passes (f may be fractional):
    // its share of the increment so far, to the nearest whole packet, so that every pixel is
    // about the same fraction of the way whenever time runs out.
    let part = |i: usize, f: f64| -> u32 {
        let (s0, t) = (from[i], target[i]);
        if f >= SUB_PASSES as f64 {
            return t.max(s0);
        }
        let inc = t.saturating_sub(s0) as f64 * f / SUB_PASSES as f64;
        let packets = (inc / LANES as f64).round() as u32;
        s0 + t.saturating_sub(s0).min(packets * LANES as u32)
    };
    let mut last = 0f64;
    for j in 1..=SUB_PASSES {
        // Less than a tenth of a pass is not started.
        let t0 = s.elapsed();
        let left = s.opts.time_limit.map_or(f64::INFINITY, |limit| limit - t0);
        let f = if last > left { left / last } else { 1.0 };
        if f < 0.1 {
            restore(film, &target);
            return false;
        }
        let at = (j - 1) as f64 + f;
        for (i, p) in film.pixels_mut().iter_mut().enumerate() {
            p.target = part(i, at);
        }
        s.pass(film, u32::MAX, false);
        let step = (light_target - light_from) as f64 * at / SUB_PASSES as f64;
        s.light_to(film, light_from + step.ceil() as u32);
        last = s.elapsed() - t0;
        if f < 1.0 || s.out_of_time() || s.stopped() {
            // Back to the round's targets, which a resumed render continues.
            restore(film, &target);
            return reached(film);
        }
    }
    true
}

/// The adaptive budget's rounds after the pilot (`more`: whether the pilot finished):
/// film.level is the level (mean samples per pixel) whose targets the pixels hold, so a
/// resumed render finishes the round it was stopped in. Each round doubles the level and
/// spreads it where it lowers the mean relative MSE ([`allocate`]).
fn budget_rounds(s: &Session, film: &mut Film, mut more: bool) -> bool {
    let spp = s.opts.spp;
    while more && film.level < spp {
        (s.ctl.progress)(film.level as usize, spp as usize);
        let level = film.level.saturating_mul(2).min(spp);
        let cell = film.cell();
        let n = (cell.w * cell.h) as usize;
        let (mut var, mut cost, mut current) = (vec![0f64; n], vec![1f64; n], vec![0u32; n]);
        for (i, p) in film.pixels().iter().enumerate() {
            let q = film.pixel_index(i);
            let other = film.light_mean(q);
            (var[q], cost[q], current[q]) = (p.rel_variance_beside(other), p.cost(), p.n);
        }
        let budget = level as f64 * cost.iter().sum::<f64>();
        // Whole packets per pixel once the round's mean increment (film.level) allows.
        let quantum = (film.level / 4).clamp(1, LANES as u32);
        let targets = allocate(
            &var,
            &cost,
            (cell.w as usize, cell.h as usize),
            &current,
            budget,
            (cap(&s.opts), quantum),
        );
        for i in 0..n {
            let q = film.pixel_index(i);
            film.pixels_mut()[i].target = targets[q];
        }
        film.level = level;
        more = to_targets(s, film);
    }
    if more {
        (s.ctl.progress)(spp as usize, spp as usize);
    }
    more
}

/// Puts back the targets of an adaptive round (sub-passes lower them temporarily), so that
/// the film records the round a resumed render has to finish.
fn restore(film: &mut Film, target: &[u32]) {
    for (p, &t) in film.pixels_mut().iter_mut().zip(target) {
        p.target = t;
    }
}
