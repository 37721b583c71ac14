//! Pixel reconstruction filters, sampled by importance as pbrt-v4 does: each camera sample
//! lands at the pixel's centre plus an offset drawn from the filter's own (normalised) shape,
//! and counts for its pixel only, so samples stay unweighted and every pixel's value is the
//! filtered radiance. Filters are separable: `f(x, y) = f₁(x)·f₁(y)` on `[−r, r]²`.
//!
//! - `box`: `f₁ = 1`; with radius ½ (the default, CS184's) the sample is the uniform point of
//!   the pixel itself, exactly as without a filter.
//! - `triangle`: `f₁(x) = r − |x|`, sampled by inverting its CDF in closed form.
//! - `gaussian`: pbrt-v4's truncated Gaussian `f₁(x) = g(x) − g(r)` with
//!   `g(x) = exp(−x² / 2σ²)`, σ = ½ (pbrt-v4's default), sampled by inverting its CDF
//!   (an erf) numerically to single precision.
//!
//! Mitsuba applies its filters the other way ([`PixelFilter::splat`]): each sample lands
//! uniformly in its pixel and is splatted, weighted by `f(centre − position)`, into every
//! pixel of the frame whose centre lies within the filter's radius; a pixel's value is its
//! weighted sum over its sum of weights. Both converge to the same filtered image; splatting
//! averages each pixel over the samples of its neighbours too, so its pixels are less noisy
//! (and correlated).

use crate::bsdf::microfacet::{erf64, erf_inv};
use glam::Vec2;
use std::fmt;
use std::str::FromStr;

/// The shape of a pixel filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FilterKind {
    /// Constant over its square.
    #[default]
    Box,
    /// A tent, zero at its radius.
    Triangle,
    /// pbrt-v4's truncated Gaussian (σ = ½).
    Gaussian,
}

impl FilterKind {
    /// pbrt-v4's default radius of the filter, in pixels.
    pub fn default_radius(self) -> f32 {
        match self {
            FilterKind::Box => 0.5,
            FilterKind::Triangle => 2.0,
            FilterKind::Gaussian => 1.5,
        }
    }
}

impl FromStr for FilterKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "box" => Ok(FilterKind::Box),
            "triangle" => Ok(FilterKind::Triangle),
            "gaussian" => Ok(FilterKind::Gaussian),
            _ => Err(format!("filter must be box, triangle or gaussian, not {s}")),
        }
    }
}

impl fmt::Display for FilterKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FilterKind::Box => "box",
            FilterKind::Triangle => "triangle",
            FilterKind::Gaussian => "gaussian",
        })
    }
}

/// The Gaussian's standard deviation in pixels.
pub const GAUSSIAN_SIGMA: f32 = 0.5;

/// A pixel filter: its shape and radius in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFilter {
    /// The shape.
    pub kind: FilterKind,
    /// Half the width of its square, in pixels (> 0).
    pub radius: f32,
    /// Splat each sample into the pixels around it (Mitsuba's reconstruction) instead of
    /// drawing its offset from the filter (pbrt-v4's).
    pub splat: bool,
}

impl Default for PixelFilter {
    fn default() -> Self {
        PixelFilter {
            kind: FilterKind::Box,
            radius: 0.5,
            splat: false,
        }
    }
}

impl PixelFilter {
    /// Where a sample with uniform numbers `u` lands, relative to its pixel's top-left
    /// corner (the pixel's centre is `(½, ½)`).
    #[inline]
    pub fn position(&self, u: Vec2) -> Vec2 {
        if *self == PixelFilter::default() || self.spreads() {
            return u;
        }
        Vec2::new(0.5 + self.offset(u.x), 0.5 + self.offset(u.y))
    }

    /// An offset from the pixel's centre along one axis, drawn from `f₁` with uniform `u`.
    fn offset(&self, u: f32) -> f32 {
        let r = self.radius;
        match self.kind {
            FilterKind::Box => (2.0 * u - 1.0) * r,
            FilterKind::Triangle => {
                let x = if u < 0.5 {
                    (2.0 * u).sqrt() - 1.0
                } else {
                    1.0 - (2.0 - 2.0 * u).max(0.0).sqrt()
                };
                x * r
            }
            FilterKind::Gaussian => {
                gaussian_offset(u as f64, r as f64, GAUSSIAN_SIGMA as f64) as f32
            }
        }
    }

    /// Whether this is the pixel's own box (radius ½): each sample uniform in its pixel and
    /// counting for it alone, however the filter is applied.
    pub fn is_pixel_box(&self) -> bool {
        self.kind == FilterKind::Box && self.radius == 0.5
    }

    /// Whether samples are splatted into more than their own pixel: [`PixelFilter::splat`]
    /// with a filter other than the pixel's own box (which splats into the sample's pixel
    /// alone, which is what drawing its position does).
    pub fn spreads(&self) -> bool {
        self.splat && !self.is_pixel_box()
    }

    /// How many pixels beyond its own a splatted sample reaches on each side: pixels whose
    /// centres lie within the radius of a point of the pixel (0 when it does not spread).
    pub fn reach(&self) -> u32 {
        if self.spreads() {
            ((self.radius + 0.5).ceil() as u32).saturating_sub(1)
        } else {
            0
        }
    }

    /// Calls `add(x, y, weight)` for each pixel of a `width × height` frame that a
    /// contribution landing at continuous frame position `(px, py)` counts for, with the
    /// normalised filter's weight there: the pixel it lands in (weight 1) for the pixel's own
    /// box; for a filter whose offsets are drawn ([`PixelFilter::position`]), each pixel whose
    /// centre lies within the radius, `f₁(dx)·f₁(dy) / norm²`, so that splatted light
    /// paths are filtered as camera samples are. `norm` is [`PixelFilter::integral_1d`],
    /// computed once by the caller.
    pub fn spread(
        &self,
        norm: f32,
        (px, py): (f32, f32),
        (width, height): (u32, u32),
        mut add: impl FnMut(u32, u32, f32),
    ) {
        if self.is_pixel_box() {
            add(px as u32, py as u32, 1.0);
            return;
        }
        if norm <= 0.0 {
            return;
        }
        let r = self.radius;
        let x0 = (px - r - 0.5).ceil().max(0.0) as u32;
        let y0 = (py - r - 0.5).ceil().max(0.0) as u32;
        let x1 = ((px + r - 0.5).floor().max(0.0) as u32).min(width.saturating_sub(1));
        let y1 = ((py + r - 0.5).floor().max(0.0) as u32).min(height.saturating_sub(1));
        for y in y0..=y1 {
            let wy = self.f1(y as f32 + 0.5 - py);
            for x in x0..=x1 {
                let w = wy * self.f1(x as f32 + 0.5 - px) / (norm * norm);
                if w > 0.0 {
                    add(x, y, w);
                }
            }
        }
    }

    /// `∫ f₁(x) dx` over the filter's support (a midpoint rule of 4096 steps).
    pub fn integral_1d(&self) -> f32 {
        const STEPS: usize = 4096;
        let h = 2.0 * self.radius / STEPS as f32;
        (0..STEPS)
            .map(|i| self.f1(-self.radius + (i as f32 + 0.5) * h))
            .sum::<f32>()
            * h
    }

    /// The one-axis filter `f₁(x)` (unnormalised; tests compare shapes).
    pub fn f1(&self, x: f32) -> f32 {
        let r = self.radius;
        if x.abs() > r {
            return 0.0;
        }
        match self.kind {
            FilterKind::Box => 1.0,
            FilterKind::Triangle => r - x.abs(),
            FilterKind::Gaussian => {
                let g = |x: f32| (-x * x / (2.0 * GAUSSIAN_SIGMA * GAUSSIAN_SIGMA)).exp();
                (g(x) - g(r)).max(0.0)
            }
        }
    }
}

/// The `x` in `[−r, r]` where the truncated Gaussian's CDF reaches `u`: from the untruncated
/// Gaussian's inverse (close, as `g(r)` is small), Newton steps kept in a bisection bracket.
fn gaussian_offset(u: f64, r: f64, sigma: f64) -> f64 {
    let s2 = sigma * std::f64::consts::SQRT_2;
    let g = |x: f64| (-x * x / (2.0 * sigma * sigma)).exp();
    let gr = g(r);
    let half = sigma * (std::f64::consts::PI / 2.0).sqrt();
    let erf_r = erf64(r / s2);
    let cdf = |x: f64| half * (erf64(x / s2) + erf_r) - gr * (x + r);
    let total = cdf(r);
    let target = u.clamp(0.0, 1.0) * total;
    let guess = erf_inv(((2.0 * u - 1.0) * erf_r) as f32) as f64 * s2;
    let (mut lo, mut hi, mut x) = (-r, r, guess.clamp(-r, r));
    for _ in 0..40 {
        let v = cdf(x) - target;
        if v.abs() <= 1e-7 * total {
            break;
        }
        if v > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let d = g(x) - gr;
        let next = x - v / d;
        x = if d > 0.0 && next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Chi-square of each filter's offsets against its own shape, on 40 bins over `[−r, r]`
    /// (one axis; the axes are independent), 1% over the tests (Šidák).
    #[test]
    fn filter_offsets_follow_the_filter() {
        let filters = [
            PixelFilter {
                splat: false,
                kind: FilterKind::Box,
                radius: 1.0,
            },
            PixelFilter {
                splat: false,
                kind: FilterKind::Triangle,
                radius: 2.0,
            },
            PixelFilter {
                splat: false,
                kind: FilterKind::Gaussian,
                radius: 1.5,
            },
            PixelFilter {
                splat: false,
                kind: FilterKind::Gaussian,
                radius: 3.0,
            },
        ];
        let significance = 1.0 - (0.99f64).powf(1.0 / filters.len() as f64);
        for f in filters {
            let bins = 40;
            let n = 200_000;
            let mut counts = vec![0f64; bins];
            let mut rng = Rng::new(5, 5);
            for _ in 0..n {
                let p = f.position(rng.next_2d());
                let x = p.x - 0.5;
                assert!(x.abs() <= f.radius * (1.0 + 1e-5), "{f:?}: {x}");
                let b = (((x + f.radius) / (2.0 * f.radius)) * bins as f32) as usize;
                counts[b.min(bins - 1)] += 1.0;
            }
            // Expected counts: the filter integrated over each bin (fine midpoint sums).
            let w = 2.0 * f.radius / bins as f32;
            let expected: Vec<f64> = (0..bins)
                .map(|b| {
                    (0..100)
                        .map(|k| f.f1(-f.radius + w * (b as f32 + (k as f32 + 0.5) / 100.0)) as f64)
                        .sum::<f64>()
                })
                .collect();
            let total: f64 = expected.iter().sum();
            let chi2: f64 = counts
                .iter()
                .zip(&expected)
                .filter(|(_, e)| **e > 0.0)
                .map(|(c, e)| {
                    let e = e / total * n as f64;
                    (c - e) * (c - e) / e
                })
                .sum();
            let p = crate::sampling::chi2::chi2_survival(chi2, (bins - 1) as f64);
            assert!(p > significance, "{f:?}: χ² {chi2:.1}, p {p:.2e}");
        }
    }

    #[test]
    fn the_default_box_is_the_pixel_itself() {
        let u = Vec2::new(0.123, 0.987);
        assert_eq!(PixelFilter::default().position(u), u);
    }
}
