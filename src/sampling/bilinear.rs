//! A piecewise-bilinear distribution on the unit square, sampled exactly by inversion (as
//! Mitsuba's `Hierarchical2D` at level 0, or pbrt-v4's `PiecewiseLinear2D`).
//!
//! # Conventions
//! - The density is given by non-negative values at nodes: `w` columns of nodes at
//!   `u = i/w`, periodic in `u` (the cell right of column `w − 1` ends at column 0 again), and
//!   rows of nodes at increasing positions `v_k` from `v_0 = 0` to `v_last = 1` (not
//!   necessarily evenly spaced). Inside each cell the density is the bilinear interpolation of
//!   its four corners, so it is continuous, and it is positive everywhere inside a cell that
//!   has a positive corner.
//! - [`Bilinear2D::pdf`] is the density with respect to area on `[0, 1)²`; it integrates to 1.
//! - Sampling: a row cell by the marginal (linear in `v` inside a row cell), then `u` from the
//!   conditional, whose cumulative sums are the interpolation of the two node rows' sums, each
//!   step inverting a linear density in closed form. `pdf(sample(ξ))` is the density sampled.
//! - Sampling inside a block ([`Bilinear2D::cell_in_block`], then [`Bilinear2D::sample_cell`]):
//!   a cell of the block by its mass (an alias table, constant time: one read instead of
//!   dependent searches), then the cell's own bilinear density inverted as above. The density
//!   is the same; the points are not stratified across cells as inversion's are.

use super::{AliasTable, Distribution1D};
use glam::Vec2;

/// Inverts the CDF of the density `∝ (1 − t)·a + t·b` on `[0, 1)` (`a, b ≥ 0`, not both 0).
#[inline]
pub fn sample_linear(xi: f32, a: f32, b: f32) -> f32 {
    if a == b {
        return xi;
    }
    let x = xi * (a + b) / (a + (a * a + (b * b - a * a) * xi).max(0.0).sqrt());
    x.clamp(0.0, 1.0 - f32::EPSILON / 2.0)
}

/// The widest column range whose sums and nodes a conditional search prefetches.
const MAX_PREFETCH: usize = 64;

/// Where [`Bilinear2D::sample_with`] and [`Bilinear2D::pdf_with`] read node values: a copy
/// kept beside data read at the same place (an environment map's texels), so that both come
/// from the same cache lines.
pub trait Nodes {
    /// Value of node `(i, k)`: column `i ∈ [0, w]` (`w` is column 0 again), row `k`; exactly
    /// [`Bilinear2D::node`]'s.
    fn node(&self, i: usize, k: usize) -> f32;
    /// Asks for nodes `first..=last` of row `k` to be brought into cache (a hint only).
    fn prefetch(&self, _k: usize, _first: usize, _last: usize) {}
}

impl Nodes for Bilinear2D {
    #[inline]
    fn node(&self, i: usize, k: usize) -> f32 {
        Bilinear2D::node(self, i, k)
    }
}

/// Columns per entry of [`Bilinear2D`]'s guide tables (each row has `w / GUIDE_COLUMNS`
/// equal-probability steps).
const GUIDE_COLUMNS: usize = 8;

/// Bilinear density on `[0,1)²` from node values (see the module conventions).
#[derive(Clone, Debug, Default)]
pub struct Bilinear2D {
    /// Node columns (= cells per row).
    w: usize,
    /// Positions of the node rows.
    v: Vec<f32>,
    /// Node values, row-major (`v.len()` rows of `w`).
    nodes: Vec<f32>,
    /// Per node row, `w + 1` running sums of the cell integrals `(n_i + n_{i+1}) / 2`.
    prefix: Vec<f64>,
    /// Per node row, its total (the last running sum), kept apart so that it is in cache.
    totals: Vec<f64>,
    /// Steps of the node rows' guide tables (`g`; each row has `g + 1` entries).
    g: usize,
    /// Per node row, `g + 1` guide entries: entry `j` is the largest column `i < w` whose
    /// running sum is at most `j/g` of the row's total (a cutpoint table, Chen & Asau 1974).
    /// Small enough to stay in cache, it narrows the conditional's search to a few columns.
    guide: Vec<u32>,
    /// Row cells by mass `Δv · (R_k + R_{k+1}) / 2`.
    marginal: Distribution1D,
    /// Integral of the node interpolation over the square.
    total: f64,
}

impl Bilinear2D {
    /// Builds from `rows.len()` rows of `w` node values at positions `rows` (from 0 to 1,
    /// increasing). Non-finite or negative values count as 0. A distribution whose values
    /// are all 0 has `total() == 0` and must not be sampled.
    pub fn new(w: usize, rows: &[f32], values: &[f32]) -> Self {
        assert!(w > 0 && rows.len() >= 2 && values.len() == w * rows.len());
        let nodes: Vec<f32> = values
            .iter()
            .map(|&x| if x.is_finite() && x > 0.0 { x } else { 0.0 })
            .collect();
        let mut prefix = Vec::with_capacity(rows.len() * (w + 1));
        let mut row_sums = Vec::with_capacity(rows.len());
        for r in nodes.chunks_exact(w) {
            let mut acc = 0f64;
            prefix.push(0.0);
            for i in 0..w {
                acc += 0.5 * (r[i] as f64 + r[(i + 1) % w] as f64);
                prefix.push(acc);
            }
            row_sums.push(acc);
        }
        // Row cells by mass Δv · (R_k + R_{k+1}) / 2; the total is their sum over the width.
        let masses: Vec<f64> = (0..rows.len() - 1)
            .map(|k| (rows[k + 1] - rows[k]) as f64 * 0.5 * (row_sums[k] + row_sums[k + 1]))
            .collect();
        let total = masses.iter().sum::<f64>() / w as f64;
        let masses: Vec<f32> = masses.iter().map(|&m| m as f32).collect();
        let g = (w / GUIDE_COLUMNS).max(1);
        let guide = prefix
            .chunks_exact(w + 1)
            .flat_map(|r| guide_row(r, g))
            .collect();
        Bilinear2D {
            w,
            v: rows.to_vec(),
            nodes,
            prefix: crate::memory::huge_pages(prefix),
            totals: row_sums,
            g,
            guide,
            marginal: Distribution1D::new(&masses),
            total,
        }
    }

    /// Integral of the (unnormalised) node interpolation over the square.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Value of node `(i, k)`: column `i ∈ [0, w]` (`w` is column 0 again), row `k`.
    #[inline]
    pub fn node(&self, i: usize, k: usize) -> f32 {
        self.nodes[k * self.w + i % self.w]
    }

    /// Node columns (cells per row).
    pub fn width(&self) -> usize {
        self.w
    }

    #[inline]
    fn prefix(&self, i: usize, k: usize) -> f64 {
        self.prefix[k * (self.w + 1) + i]
    }

    /// Row cell containing `v` and the position `t ∈ [0, 1]` inside it.
    #[inline]
    fn row_cell(&self, v: f32) -> (usize, f32) {
        // The last row cell starting at or below `v` (the first one for `v` below every
        // row): a guess as if the rows were evenly spaced (an environment map's are, but for
        // the poles), then a walk to the right one.
        let n = self.v.len();
        let mut k = ((v * (n - 2) as f32 + 0.5).max(0.0) as usize).min(n - 2);
        while k + 1 < n - 1 && self.v[k + 1] <= v {
            k += 1;
        }
        while k > 0 && self.v[k] > v {
            k -= 1;
        }
        let dv = self.v[k + 1] - self.v[k];
        (k, ((v - self.v[k]) / dv).clamp(0.0, 1.0))
    }

    /// Samples a point of `[0,1)²` for uniform `xi`; returns it with its density.
    pub fn sample(&self, xi: Vec2) -> (Vec2, f32) {
        self.sample_with(xi, self)
    }

    /// [`Bilinear2D::sample`] reading node values from `nodes`.
    #[inline]
    pub fn sample_with(&self, xi: Vec2, nodes: &impl Nodes) -> (Vec2, f32) {
        let (k, _, xv) = self.marginal.sample(xi.y);
        let (rk, rk1) = (self.totals[k], self.totals[k + 1]);
        let t = sample_linear(xv, rk as f32, rk1 as f32);
        let v = self.v[k] + t * (self.v[k + 1] - self.v[k]);
        // Conditional over the columns: interpolated running sums.
        let t64 = t as f64;
        let c = |i: usize| (1.0 - t64) * self.prefix(i, k) + t64 * self.prefix(i, k + 1);
        let target = xi.x as f64 * ((1.0 - t64) * rk + t64 * rk1);
        let i = self.conditional_column(k, (xi.x, target), c, nodes, (0, self.w));
        let uv = self.point_in_column(i, k, t, v, target, c, nodes);
        (uv, self.pdf_with(uv, nodes))
    }

    /// The point of column `i` in row cell `k` (at `t` between its node rows, height `v`)
    /// where the interpolated running sums `c` reach `target`: the column's linear density
    /// inverted in closed form.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn point_in_column(
        &self,
        i: usize,
        k: usize,
        t: f32,
        v: f32,
        target: f64,
        c: impl Fn(usize) -> f64,
        nodes: &impl Nodes,
    ) -> Vec2 {
        let (c0, c1) = (c(i), c(i + 1));
        let xu = if c1 > c0 {
            ((target - c0) / (c1 - c0)).clamp(0.0, 1.0) as f32
        } else {
            0.5
        };
        let a = (1.0 - t) * nodes.node(i, k) + t * nodes.node(i, k + 1);
        let b = (1.0 - t) * nodes.node(i + 1, k) + t * nodes.node(i + 1, k + 1);
        let s = if a + b > 0.0 {
            sample_linear(xu, a, b)
        } else {
            xu
        };
        let u = ((i as f32 + s) / self.w as f32).min(1.0 - f32::EPSILON / 2.0);
        Vec2::new(u, v.min(1.0 - f32::EPSILON / 2.0))
    }

    /// The largest column `i` in `i0..i1` with `c(i) ≤ target`, where `c` (non-decreasing,
    /// `c(0) = 0`) mixes the running sums of node rows `k` and `k + 1`, `target` is fraction
    /// `x` of `c(w)` and `c(i0) ≤ target`. The answer lies between the two rows' answers for
    /// the same fraction, so their guide tables bound it to a few columns, whose sums and nodes
    /// are fetched at once; bounds that rounding got wrong are widened, so the answer is that
    /// of a search over every column of the range.
    #[inline]
    fn conditional_column(
        &self,
        k: usize,
        (x, target): (f32, f64),
        c: impl Fn(usize) -> f64,
        nodes: &impl Nodes,
        (i0, i1): (usize, usize),
    ) -> usize {
        let (lo, hi) = self.guided_bounds(k, x);
        let lo = lo.clamp(i0, i1 - 1);
        let (mut lo, mut hi) = (lo, hi.clamp(lo + 1, i1));
        if hi - lo <= MAX_PREFETCH {
            for r in [k, k + 1] {
                let first = &self.prefix[r * (self.w + 1) + lo];
                crate::memory::prefetch_bytes(
                    first as *const f64 as *const u8,
                    (hi - lo + 1) * std::mem::size_of::<f64>(),
                );
                nodes.prefetch(r, lo, hi);
            }
        }
        if c(lo) > target {
            lo = i0;
        }
        if hi < i1 && c(hi) <= target {
            hi = i1;
        }
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if c(mid) <= target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// Columns `(lo, hi)` between which the conditional of row cell `k` crosses fraction `x`
    /// of its total: the union of the two node rows' guide steps holding `x` (rows without
    /// mass have no say). Exact up to the rounding of the sums.
    #[inline]
    fn guided_bounds(&self, k: usize, x: f32) -> (usize, usize) {
        let j = ((x * self.g as f32) as usize).min(self.g - 1);
        let (mut lo, mut hi) = (self.w - 1, 0);
        for r in [k, k + 1] {
            if self.totals[r] > 0.0 {
                let steps = &self.guide[r * (self.g + 1) + j..][..2];
                lo = lo.min(steps[0] as usize);
                hi = hi.max(steps[1] as usize + 1);
            }
        }
        (lo.min(hi.saturating_sub(1)), hi.min(self.w))
    }

    /// Density of [`Bilinear2D::sample`] at `uv` (area measure on the unit square).
    pub fn pdf(&self, uv: Vec2) -> f32 {
        self.pdf_with(uv, self)
    }

    /// [`Bilinear2D::pdf`] reading node values from `nodes`.
    #[inline]
    pub fn pdf_with(&self, uv: Vec2, nodes: &impl Nodes) -> f32 {
        let node = |i, k| nodes.node(i, k);
        if self.total <= 0.0 {
            return 0.0;
        }
        // (At u = 1, the last cell's right edge: `s` = 1 there.)
        let x = uv.x.clamp(0.0, 1.0) * self.w as f32;
        let i = (x as usize).min(self.w - 1);
        let s = x - i as f32;
        let (k, t) = self.row_cell(uv.y);
        let top = node(i, k) * (1.0 - s) + node(i + 1, k) * s;
        let bottom = node(i, k + 1) * (1.0 - s) + node(i + 1, k + 1) * s;
        ((top * (1.0 - t) + bottom * t) as f64 / self.total) as f32
    }

    /// Density at node `(i, k)`.
    pub fn node_pdf(&self, i: usize, k: usize) -> f32 {
        if self.total <= 0.0 {
            0.0
        } else {
            (self.node(i, k) as f64 / self.total) as f32
        }
    }
}

/// A partition of a [`Bilinear2D`]'s cells into blocks of whole cells, `nu` across the
/// columns and `nv` across the row cells, with each block's probability and the distribution
/// restricted to it: for samplers that choose a block first and then a point by the
/// distribution inside it ([`Bilinear2D::cell_in_block`]), so that their density is the
/// distribution's own times a factor per block.
#[derive(Clone, Debug)]
pub struct Blocks {
    /// Blocks across the columns.
    pub nu: usize,
    /// Blocks across the row cells.
    pub nv: usize,
    /// First column of each block column, and `w` at the end.
    col: Vec<usize>,
    /// First row cell of each block row, and the number of row cells at the end.
    row: Vec<usize>,
    /// Block column of each column, block row of each row cell.
    col_block: Vec<u16>,
    row_block: Vec<u16>,
    /// Probability of each block under the whole distribution, row-major (`bv·nu + bu`).
    prob: Vec<f32>,
    /// Per block, its cells by their mass (row-major within the block); empty without mass.
    cells: Vec<AliasTable>,
}

impl Blocks {
    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.prob.len()
    }

    /// True when there are no blocks.
    pub fn is_empty(&self) -> bool {
        self.prob.is_empty()
    }

    /// Asks for the part of block `b`'s cell table that [`Bilinear2D::cell_in_block`] reads
    /// for `x` to be brought into cache (a hint only).
    #[inline]
    pub fn prefetch(&self, b: usize, x: f32) {
        self.cells[b].prefetch(x);
    }

    /// Probability of block `b` under the whole distribution.
    #[inline]
    pub fn prob(&self, b: usize) -> f32 {
        self.prob[b]
    }
}

impl Bilinear2D {
    /// The partition into `nu × nv` blocks (fewer where there are fewer columns or row cells),
    /// as even as whole cells allow.
    pub fn blocks(&self, nu: usize, nv: usize) -> Blocks {
        let cells = self.v.len() - 1;
        let (nu, nv) = (nu.clamp(1, self.w), nv.clamp(1, cells));
        let col: Vec<usize> = (0..=nu).map(|b| b * self.w / nu).collect();
        let row: Vec<usize> = (0..=nv).map(|b| b * cells / nv).collect();
        let owner = |bounds: &[usize], n: usize| -> Vec<u16> {
            (0..n)
                .map(|i| (bounds.partition_point(|&c| c <= i) - 1) as u16)
                .collect()
        };
        let (mut prob, mut tables) = (Vec::new(), Vec::new());
        for bv in 0..nv {
            for bu in 0..nu {
                let (i0, i1) = (col[bu], col[bu + 1]);
                let masses: Vec<f64> = (row[bv]..row[bv + 1])
                    .flat_map(|k| (i0..i1).map(move |i| (i, k)))
                    .map(|(i, k)| self.cell_mass(i, k))
                    .collect();
                let mass = masses.iter().sum::<f64>() / self.w as f64;
                prob.push(if self.total > 0.0 {
                    (mass / self.total) as f32
                } else {
                    0.0
                });
                tables.push(AliasTable::new(&masses).unwrap_or_default());
            }
        }
        Blocks {
            nu,
            nv,
            col_block: owner(&col, self.w),
            row_block: owner(&row, cells),
            col,
            row,
            prob,
            cells: tables,
        }
    }

    /// Mass of cell `(i, k)` (up to the factor `1/w`): its height times the mean of its
    /// four nodes.
    fn cell_mass(&self, i: usize, k: usize) -> f64 {
        let n = |i, k| self.node(i, k) as f64;
        (self.v[k + 1] - self.v[k]) as f64
            * 0.25
            * (n(i, k) + n(i + 1, k) + n(i, k + 1) + n(i + 1, k + 1))
    }

    /// The block of `blocks` holding the point `uv` of the square.
    #[inline]
    pub fn block_of(&self, blocks: &Blocks, uv: Vec2) -> usize {
        let i = ((uv.x.clamp(0.0, 1.0) * self.w as f32) as usize).min(self.w - 1);
        let (k, _) = self.row_cell(uv.y);
        blocks.row_block[k] as usize * blocks.nu + blocks.col_block[i] as usize
    }

    /// The first step of a sample of block `b` by the distribution restricted to it (density
    /// [`Bilinear2D::pdf`] / [`Blocks::prob`]): the cell for `x` (by the cells' masses, an
    /// alias table), with what the choice leaves of `x`; `None` where the block has no mass.
    /// [`Bilinear2D::sample_cell`] takes the second.
    #[inline]
    pub fn cell_in_block(&self, blocks: &Blocks, b: usize, x: f32) -> Option<Cell> {
        let table = &blocks.cells[b];
        if blocks.prob[b] <= 0.0 || table.is_empty() {
            return None;
        }
        let (bu, bv) = (b % blocks.nu, b / blocks.nu);
        let (i0, i1) = (blocks.col[bu], blocks.col[bu + 1]);
        let (c, rest) = table.sample(x);
        let width = i1 - i0;
        Some(Cell {
            i: i0 + c % width,
            k: blocks.row[bv] + c / width,
            rest,
        })
    }

    /// A point of `cell` by its bilinear density: the row position from the cell's linear
    /// marginal (`y`), the column position from the conditional there (the cell's `rest`);
    /// with the whole distribution's density there, `None` where it is 0.
    #[inline]
    pub fn sample_cell(&self, cell: Cell, y: f32, nodes: &impl Nodes) -> Option<(Vec2, f32)> {
        let Cell { i, k, rest } = cell;
        let (a00, a10) = (nodes.node(i, k), nodes.node(i + 1, k));
        let (a01, a11) = (nodes.node(i, k + 1), nodes.node(i + 1, k + 1));
        let t = if a00 + a10 + a01 + a11 > 0.0 {
            sample_linear(y, a00 + a10, a01 + a11)
        } else {
            y
        };
        let (left, right) = ((1.0 - t) * a00 + t * a01, (1.0 - t) * a10 + t * a11);
        let s = if left + right > 0.0 {
            sample_linear(rest, left, right)
        } else {
            rest
        };
        let u = ((i as f32 + s) / self.w as f32).min(1.0 - f32::EPSILON / 2.0);
        let v = (self.v[k] + t * (self.v[k + 1] - self.v[k])).min(1.0 - f32::EPSILON / 2.0);
        // The density there, from the corners already read (as [`Bilinear2D::pdf_with`]).
        let pdf = (((1.0 - s) * left + s * right) as f64 / self.total) as f32;
        (pdf > 0.0).then_some((Vec2::new(u, v), pdf))
    }
}

/// A cell of a [`Bilinear2D`] chosen inside a block: its column `i`, its row cell `k` (node
/// rows `k` and `k + 1`), and what the choice left of its uniform number (in `[0, 1)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Column of the cell's left nodes.
    pub i: usize,
    /// Node row of the cell's top nodes.
    pub k: usize,
    /// The rest of the number that chose it.
    pub rest: f32,
}

/// The `g + 1` guide entries of one node row from its `w + 1` running sums: entry `j` is the
/// largest column `i < w` with `sums[i] ≤ (j/g)·sums[w]`.
fn guide_row(sums: &[f64], g: usize) -> impl Iterator<Item = u32> + '_ {
    let w = sums.len() - 1;
    let total = sums[w];
    (0..=g).map(move |j| {
        let cut = j as f64 / g as f64 * total;
        (sums[..w].partition_point(|&s| s <= cut).max(1) - 1) as u32
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn grid() -> Bilinear2D {
        // 5 columns, 4 uneven rows; one zero corner region and a peak.
        let rows = [0.0, 0.1, 0.6, 1.0];
        let mut vals = vec![0.0f32; 20];
        for k in 0..4 {
            for i in 0..5 {
                vals[k * 5 + i] = (i as f32 * 0.7 + k as f32 * 0.3).sin().abs();
            }
        }
        vals[0] = 0.0;
        vals[1] = 0.0;
        vals[5] = 0.0;
        vals[13] = 9.0;
        Bilinear2D::new(5, &rows, &vals)
    }

    #[test]
    fn linear_inversion_follows_its_density() {
        let mut rng = Rng::new(1, 1);
        for (a, b) in [(1.0f32, 1.0f32), (0.0, 2.0), (3.0, 0.0), (0.2, 5.0)] {
            let n = 200_000;
            let mut below = 0;
            for _ in 0..n {
                let t = sample_linear(rng.next_f32(), a, b);
                assert!((0.0..1.0).contains(&t));
                below += usize::from(t < 0.5);
            }
            // Mass of [0, ½): (3a + b) / (4(a + b)).
            let want = (3.0 * a + b) as f64 / (4.0 * (a + b)) as f64;
            let got = below as f64 / n as f64;
            assert!((got - want).abs() < 0.004, "a={a} b={b}: {got} vs {want}");
        }
    }

    /// Histogram of samples on a 40×40 grid against the pdf integrated on a sub-grid, by a
    /// chi-square statistic (1% significance), and the pdf integrating to 1.
    #[test]
    fn samples_follow_the_pdf() {
        let d = grid();
        let mut rng = Rng::new(7, 3);
        chi2_against_pdf(&d, || d.sample(rng.next_2d()));
    }

    /// Choosing a block by its probability and then a point inside it by
    /// [`Bilinear2D::cell_in_block`] and [`Bilinear2D::sample_cell`] samples the whole
    /// distribution: every point lies in its block, the block probabilities sum to 1 and the
    /// histogram follows the pdf.
    #[test]
    fn block_samples_follow_the_pdf() {
        let d = grid();
        for (nu, nv) in [(2, 2), (3, 1), (5, 3), (9, 9)] {
            let blocks = d.blocks(nu, nv);
            let sum: f32 = (0..blocks.len()).map(|b| blocks.prob(b)).sum();
            assert!(
                (sum - 1.0).abs() < 1e-5,
                "{nu}×{nv}: probabilities sum to {sum}"
            );
            let choice = Distribution1D::new(
                &(0..blocks.len())
                    .map(|b| blocks.prob(b))
                    .collect::<Vec<_>>(),
            );
            let mut rng = Rng::new(11, nu as u64 * 16 + nv as u64);
            chi2_against_pdf(&d, || {
                let (b, _, _) = choice.sample(rng.next_f32());
                let xi = rng.next_2d();
                let (p, pdf) = d
                    .cell_in_block(&blocks, b, xi.x)
                    .and_then(|cell| d.sample_cell(cell, xi.y, &d))
                    .expect("a block of positive probability samples");
                assert_eq!(d.block_of(&blocks, p), b, "{p} outside block {b}");
                (p, pdf)
            });
        }
    }

    /// Chi-square test (1% significance) of the points `sample` returns, with their densities,
    /// against `d`'s pdf on a 40×40 grid; also checks that the pdf integrates to 1.
    fn chi2_against_pdf(d: &Bilinear2D, mut sample: impl FnMut() -> (Vec2, f32)) {
        let (nb, sub) = (40usize, 8usize);
        let mut expected = vec![0f64; nb * nb];
        let mut integral = 0f64;
        for (c, e) in expected.iter_mut().enumerate() {
            let (cx, cy) = (c % nb, c / nb);
            for j in 0..sub * sub {
                let u = (cx * sub + j % sub) as f32 + 0.5;
                let v = (cy * sub + j / sub) as f32 + 0.5;
                let p = d.pdf(Vec2::new(u, v) / (nb * sub) as f32) as f64;
                *e += p / (nb * sub * nb * sub) as f64;
            }
            integral += *e;
        }
        assert!(
            (integral - 1.0).abs() < 1e-3,
            "pdf integrates to {integral}"
        );
        let n = 1_000_000;
        let mut observed = vec![0f64; nb * nb];
        for _ in 0..n {
            let (p, pdf) = sample();
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
            assert!(pdf > 0.0, "sampled a zero-density point {p}");
            // The density at the sampled point, which `p` rounds: between the densities a
            // few ulps around `p`.
            let around = [-1.0, 0.0, 1.0].map(|k| k * 4.0 * f32::EPSILON);
            let (lo, hi) = around
                .iter()
                .flat_map(|&dx| around.map(|dy| d.pdf(p + Vec2::new(dx, dy))))
                .fold((f32::MAX, 0f32), |(lo, hi), q| (lo.min(q), hi.max(q)));
            assert!(
                pdf >= lo * (1.0 - 1e-6) && pdf <= hi * (1.0 + 1e-6),
                "{p}: density {pdf}, around it {lo}..{hi}"
            );
            observed[((p.y * nb as f32) as usize) * nb + (p.x * nb as f32) as usize] += 1.0;
        }
        let (mut chi2, mut dof) = (0f64, 0usize);
        let (mut po, mut pe) = (0f64, 0f64);
        for (o, e) in observed.iter().zip(&expected) {
            let e = e * n as f64;
            if e < 5.0 {
                po += o;
                pe += e;
                continue;
            }
            chi2 += (o - e) * (o - e) / e;
            dof += 1;
        }
        if pe > 0.0 {
            chi2 += (po - pe) * (po - pe) / pe;
            dof += 1;
        }
        // Wilson–Hilferty bound of the 99% quantile of chi-square with dof − 1 degrees.
        let k = (dof - 1) as f64;
        let q = k * (1.0 - 2.0 / (9.0 * k) + 2.326 * (2.0 / (9.0 * k)).sqrt()).powi(3);
        assert!(chi2 < q, "chi2 {chi2} over {dof} cells (99% bound {q})");
    }

    /// The guided search finds the column a search over every column finds, for rows with
    /// zeros, peaks and empty rows, at the guide steps' edges and in between, over the whole
    /// row and over a range of columns holding the answer.
    #[test]
    fn guided_search_matches_a_full_search() {
        let mut rng = Rng::new(5, 9);
        let (w, n) = (67usize, 6usize);
        let mut vals: Vec<f32> = (0..w * n)
            .map(|_| {
                let u = rng.next_f32();
                if u < 0.3 {
                    0.0
                } else {
                    u.powi(8) * 100.0
                }
            })
            .collect();
        vals[..w].fill(0.0);
        vals[2 * w..3 * w].fill(0.0);
        let d = Bilinear2D::new(w, &[0.0, 0.1, 0.3, 0.5, 0.9, 1.0], &vals);
        for trial in 0..20_000 {
            let k = trial % (n - 1);
            let t = if trial % 7 == 0 {
                0.0
            } else {
                rng.next_f32() as f64
            };
            let x = if trial % 5 == 0 {
                (trial / 5 % (d.g + 1)) as f32 / d.g as f32 * 0.999_999_9
            } else {
                rng.next_f32()
            };
            let c = |i: usize| (1.0 - t) * d.prefix(i, k) + t * d.prefix(i, k + 1);
            if c(w) <= 0.0 {
                continue;
            }
            let target = x as f64 * c(w);
            // The whole row, then a range of columns holding the target.
            let want = (0..w).rev().find(|&i| c(i) <= target).unwrap_or(0);
            let got = d.conditional_column(k, (x, target), c, &d, (0, w));
            assert_eq!(got, want, "k={k} t={t} x={x}");
            let i0 = (rng.next_f32() * (want + 1) as f32) as usize;
            let i1 = want + 1 + (rng.next_f32() * (w - want) as f32) as usize;
            let got = d.conditional_column(k, (x, target), c, &d, (i0.min(want), i1.min(w)));
            assert_eq!(got, want, "k={k} t={t} x={x} in {i0}..{i1}");
        }
    }

    /// The row cell found from a guess is the one a search over every row finds.
    #[test]
    fn row_cells_match_a_search() {
        let mut rng = Rng::new(3, 4);
        let uneven = grid();
        let even = Bilinear2D::new(2, &[0.0, 0.125, 0.375, 0.625, 0.875, 1.0], &[1.0; 12]);
        for d in [&uneven, &even] {
            let n = d.v.len();
            let mut vs: Vec<f32> = (0..2000).map(|_| rng.next_f32()).collect();
            vs.extend(d.v.iter().copied());
            vs.extend([-0.5, 0.0, 1.0, 1.5, f32::from_bits(1.0f32.to_bits() - 1)]);
            for v in vs {
                let want = d.v.partition_point(|&x| x <= v).clamp(1, n - 1) - 1;
                assert_eq!(d.row_cell(v).0, want, "v={v}");
            }
        }
    }

    #[test]
    fn zero_only_where_every_corner_is_zero() {
        let d = grid();
        let mut rng = Rng::new(2, 2);
        for _ in 0..10_000 {
            let p = rng.next_2d();
            let i = ((p.x * 5.0) as usize).min(4);
            let (k, _) = d.row_cell(p.y);
            let corners = [
                d.node(i, k),
                d.node(i + 1, k),
                d.node(i, k + 1),
                d.node(i + 1, k + 1),
            ];
            let any = corners.iter().any(|&c| c > 0.0);
            let pdf = d.pdf(p);
            assert_eq!(pdf > 0.0, any, "at {p}: pdf {pdf}, corners {corners:?}");
        }
        let empty = Bilinear2D::new(3, &[0.0, 1.0], &[0.0; 6]);
        assert_eq!(empty.total(), 0.0);
        assert_eq!(empty.pdf(Vec2::splat(0.5)), 0.0);
    }
}
