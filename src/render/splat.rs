//! Splatting camera samples into the pixels their filter reaches, as Mitsuba's films do
//! ([`PixelFilter::splat`]): a sample at continuous frame position `p` adds `f(c − p)·L` and
//! `f(c − p)` to every pixel of the frame whose centre `c` lies within the filter's radius
//! (`f` the separable filter, [`PixelFilter::f1`] per axis). Pixels outside the frame get
//! nothing (Mitsuba's films do not sample a border).
//!
//! A run of samples gathers its splats in a [`Block`] (its pixels and the ring they reach),
//! exactly, on the film's fixed-point grid; blocks are added into the pass's sums over the
//! cell, and those into the film at the end of the pass. Integer sums do not depend on the
//! order they are added in, so the result does not depend on threads, tiles or passes.

use crate::film::{fixed, Cell};
use crate::filter::PixelFilter;
use glam::{Vec2, Vec3};

/// Most pixels a splat spans along one axis: the widest filter's (radius 16).
const MAX_SPAN: usize = 34;

/// Weighted sums of splatted samples over a rectangle of the frame: per pixel, row-major,
/// weight × radiance per channel and the weight, fixed point.
pub(super) struct Block {
    /// Left column and top row of the rectangle, frame pixels.
    x0: u32,
    y0: u32,
    /// Its width and height.
    w: u32,
    h: u32,
    sums: Vec<[i128; 4]>,
}

/// A rectangle of frame pixels: left, top, right and bottom (inclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Rect {
    pub(super) x0: u32,
    pub(super) y0: u32,
    pub(super) x1: u32,
    pub(super) y1: u32,
}

impl Block {
    /// An empty block over the pixels that samples of the pixels in `rect` reach: `reach`
    /// pixels further on each side, within the `frame`.
    pub(super) fn around(rect: Rect, reach: u32, frame: (u32, u32)) -> Block {
        let x0 = rect.x0.saturating_sub(reach);
        let y0 = rect.y0.saturating_sub(reach);
        let x1 = (rect.x1 + reach).min(frame.0 - 1);
        let y1 = (rect.y1 + reach).min(frame.1 - 1);
        let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
        Block {
            x0,
            y0,
            w,
            h,
            sums: vec![[0; 4]; (w * h) as usize],
        }
    }

    /// Adds the sample of radiance `l` at continuous frame position `pos` (in a pixel of the
    /// block's rectangle), weighted by `filter` into each pixel of the frame it reaches.
    pub(super) fn add(&mut self, filter: &PixelFilter, pos: Vec2, l: Vec3) {
        let r = filter.radius;
        // Pixel i's centre is i + ½: it lies within r of pos when pos − r − ½ ≤ i ≤ pos + r − ½.
        let span = |p: f32, lo: u32, n: u32| {
            let a = ((p - r - 0.5).ceil() as i64).max(lo as i64);
            let b = ((p + r - 0.5).floor() as i64).min(lo as i64 + n as i64 - 1);
            (a <= b).then_some((a as u32, b as u32))
        };
        let (Some((xa, xb)), Some((ya, yb))) =
            (span(pos.x, self.x0, self.w), span(pos.y, self.y0, self.h))
        else {
            return;
        };
        // The weights along each axis, once: at most 2·⌈r + ½⌉ pixels each, r ≤ 16.
        let weights = |a: u32, b: u32, p: f32| {
            let mut w = [0f32; MAX_SPAN];
            for (k, i) in (a..=b).take(MAX_SPAN).enumerate() {
                w[k] = filter.f1(i as f32 + 0.5 - p);
            }
            (w, ((b - a + 1) as usize).min(MAX_SPAN))
        };
        let ((wx, nx), (wy, ny)) = (weights(xa, xb, pos.x), weights(ya, yb, pos.y));
        let l = [l.x as f64, l.y as f64, l.z as f64];
        for (y, &wy) in (ya..=yb).zip(&wy[..ny]) {
            if wy <= 0.0 {
                continue;
            }
            let row = ((y - self.y0) * self.w + (xa - self.x0)) as usize;
            for (s, &wx) in self.sums[row..row + nx].iter_mut().zip(&wx[..nx]) {
                let weight = (wx * wy) as f64;
                if weight <= 0.0 {
                    continue;
                }
                s[0] += fixed(weight * l[0]);
                s[1] += fixed(weight * l[1]);
                s[2] += fixed(weight * l[2]);
                s[3] += fixed(weight);
            }
        }
    }

    /// Adds the block's sums into `sums`, row-major over `cell` (pixels outside it dropped).
    pub(super) fn add_into(&self, cell: Cell, sums: &mut [[i128; 4]]) {
        for row in 0..self.h {
            let y = self.y0 + row;
            if y < cell.y || y >= cell.y + cell.h {
                continue;
            }
            for col in 0..self.w {
                let x = self.x0 + col;
                if x < cell.x || x >= cell.x + cell.w {
                    continue;
                }
                let from = &self.sums[(row * self.w + col) as usize];
                let to = &mut sums[((y - cell.y) * cell.w + (x - cell.x)) as usize];
                for c in 0..4 {
                    to[c] += from[c];
                }
            }
        }
    }
}

/// The pixels outside `cell` but inside the frame whose samples reach into the cell
/// (`reach` pixels around it), row by row: what a cell render traces besides its own pixels
/// so that its border pixels get the splats the whole frame's render gives them.
pub(super) fn ring(cell: Cell, reach: u32, frame: (u32, u32)) -> Vec<(u32, u32)> {
    let outer = Block::around(
        Rect {
            x0: cell.x,
            y0: cell.y,
            x1: cell.x + cell.w - 1,
            y1: cell.y + cell.h - 1,
        },
        reach,
        frame,
    );
    let inside =
        |x: u32, y: u32| x >= cell.x && x < cell.x + cell.w && y >= cell.y && y < cell.y + cell.h;
    (outer.y0..outer.y0 + outer.h)
        .flat_map(|y| (outer.x0..outer.x0 + outer.w).map(move |x| (x, y)))
        .filter(|&(x, y)| !inside(x, y))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::FilterKind;

    fn tent() -> PixelFilter {
        PixelFilter {
            kind: FilterKind::Triangle,
            radius: 1.0,
            splat: true,
        }
    }

    /// A sample splats into exactly the pixels whose centres are within the radius, with
    /// the filter's weights, and nowhere outside the frame.
    #[test]
    fn a_sample_reaches_the_pixels_within_the_radius() {
        let f = tent();
        let rect = Rect {
            x0: 0,
            y0: 0,
            x1: 3,
            y1: 3,
        };
        let mut b = Block::around(rect, f.reach(), (4, 4));
        assert_eq!((b.x0, b.y0, b.w, b.h), (0, 0, 4, 4));
        // At (1.25, 2.5): columns 0 and 1 (centres 0.5, 1.5), row 2 only (centre 2.5; rows
        // 1 and 3 are exactly at the radius, weight 0).
        b.add(&f, Vec2::new(1.25, 2.5), Vec3::ONE);
        let weight =
            |b: &Block, x: u32, y: u32| b.sums[(y * 4 + x) as usize][3] as f64 / 2f64.powi(40);
        let touched: Vec<(u32, u32)> = (0..4)
            .flat_map(|y| (0..4).map(move |x| (x, y)))
            .filter(|&(x, y)| weight(&b, x, y) != 0.0)
            .collect();
        assert_eq!(touched, [(0, 2), (1, 2)]);
        assert!((weight(&b, 0, 2) - 0.25).abs() < 1e-9 && (weight(&b, 1, 2) - 0.75).abs() < 1e-9);
        // A corner sample loses what falls outside the frame.
        b.add(&f, Vec2::new(0.1, 0.1), Vec3::ONE);
        assert!((weight(&b, 0, 0) - 0.6 * 0.6).abs() < 1e-6);
        assert_eq!(f.reach(), 1);
        let gaussian = PixelFilter {
            kind: FilterKind::Gaussian,
            radius: 2.0,
            splat: true,
        };
        assert_eq!(gaussian.reach(), 2);
    }

    /// A cell's ring holds the frame pixels around it within reach, clipped to the frame.
    #[test]
    fn the_ring_of_a_cell() {
        let cell = Cell {
            x: 0,
            y: 1,
            w: 2,
            h: 2,
        };
        let r = ring(cell, 1, (4, 4));
        assert_eq!(
            r,
            [
                (0, 0),
                (1, 0),
                (2, 0),
                (2, 1),
                (2, 2),
                (0, 3),
                (1, 3),
                (2, 3)
            ]
        );
    }
}
