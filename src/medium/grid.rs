//! Heterogeneous media: voxel grids over the unit cube, the fields that scale them into
//! coefficients, and the majorant grid that free flights track against.
//!
//! Conventions: a grid covers the unit cube `[0, 1]³` of the medium's own space; voxel
//! `(i, j, k)` is centred at `((i + ½)/nx, (j + ½)/ny, (k + ½)/nz)` and its values are stored
//! x fastest, then y, then z, `channels` (1 or 3) per voxel (pbrt-v4's `SampledGrid` and
//! Mitsuba's `.vol` order). Outside the cube the medium is empty.

use crate::math::{Ray, Rgb};
use glam::{Affine3A, IVec3, Vec3};
use std::fmt::Debug;
use std::sync::Arc;

/// How a grid treats lookups beyond its outermost voxel centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridEdge {
    /// Voxels beyond the grid count as 0, so values fade over the outer half voxel (pbrt-v4).
    Zero,
    /// The outermost voxels extend to the cube's faces (Mitsuba's `clamp` wrap mode).
    Clamp,
}

/// How a grid finds values between voxel centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridFilter {
    /// Trilinear interpolation of the eight nearest voxels.
    Trilinear,
    /// The value of the voxel containing the point.
    Nearest,
}

/// A grid of voxel values over the unit cube (see the module's conventions).
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelGrid {
    res: [u32; 3],
    channels: u32,
    voxels: Voxels,
    edge: GridEdge,
    filter: GridFilter,
}

/// Where a grid's values live.
#[derive(Clone, Debug)]
enum Voxels {
    /// Every voxel's values, in the module's order.
    Dense(Vec<f32>),
    /// A sparse one-channel grid's lookups, voxel `v` being the source's `first + v`, and
    /// the largest values over its blocks.
    Sparse {
        source: Arc<dyn SparseVoxels>,
        first: IVec3,
        blocks: BlockMax,
    },
}

impl PartialEq for Voxels {
    fn eq(&self, other: &Voxels) -> bool {
        match (self, other) {
            (Voxels::Dense(a), Voxels::Dense(b)) => a == b,
            (
                Voxels::Sparse { source, first, .. },
                Voxels::Sparse {
                    source: s,
                    first: f,
                    ..
                },
            ) => Arc::ptr_eq(source, s) && first == f,
            _ => false,
        }
    }
}

/// A sparse grid of one value per voxel over all of integer index space (a NanoVDB tree).
/// Its values are finite and non-negative.
pub trait SparseVoxels: Debug + Send + Sync {
    /// The value of voxel `ijk`.
    fn value(&self, ijk: IVec3) -> f32;
    /// The values of the eight voxels `ijk + (0 or 1, 0 or 1, 0 or 1)`, x fastest, then y,
    /// then z.
    fn cube(&self, ijk: IVec3) -> [f32; 8] {
        std::array::from_fn(|i| {
            let i = i as i32;
            self.value(ijk + IVec3::new(i & 1, i >> 1 & 1, i >> 2))
        })
    }
}

/// The largest value over each block of `side³` voxels of a sparse grid's dense extent, for
/// majorants: voxel `v` of the extent lies in block `v / side`.
#[derive(Clone, Debug)]
pub struct BlockMax {
    first: IVec3,
    res: [u32; 3],
    side: u32,
    blocks: [u32; 3],
    max: Vec<f32>,
}

impl BlockMax {
    /// Blocks per axis at most.
    const MOST_BLOCKS: u32 = 128;

    /// Blocks over the voxels `first + v`, `v` within `res`, each starting at `background`
    /// (the value of voxels no block added covers).
    pub fn new(first: IVec3, res: [u32; 3], background: f32) -> BlockMax {
        let widest = res.iter().copied().max().unwrap_or(1);
        let side = widest.div_ceil(Self::MOST_BLOCKS).max(1);
        let blocks = res.map(|n| n.div_ceil(side));
        let count = blocks.iter().map(|&n| n as usize).product();
        BlockMax {
            first,
            res,
            side,
            blocks,
            max: vec![background; count],
        }
    }

    /// Raises the blocks that the index box of `size³` voxels from `lo` overlaps to at least
    /// `value`.
    pub fn add(&mut self, lo: IVec3, size: i32, value: f32) {
        let v0 = (lo - self.first).as_i64vec3();
        let v1 = v0 + i64::from(size) - 1;
        let res = glam::I64Vec3::new(
            i64::from(self.res[0]),
            i64::from(self.res[1]),
            i64::from(self.res[2]),
        );
        if v1.cmplt(glam::I64Vec3::ZERO).any() || v0.cmpge(res).any() {
            return;
        }
        let v0 = v0.max(glam::I64Vec3::ZERO);
        let v1 = v1.min(res - 1);
        let side = i64::from(self.side);
        let b0 = (v0 / side).as_uvec3();
        let b1 = (v1 / side).as_uvec3();
        for z in b0.z..=b1.z {
            for y in b0.y..=b1.y {
                for x in b0.x..=b1.x {
                    let i = self.block_index(x, y, z);
                    self.max[i] = self.max[i].max(value);
                }
            }
        }
    }

    fn block_index(&self, x: u32, y: u32, z: u32) -> usize {
        let [bx, by, _] = self.blocks.map(|n| n as usize);
        (z as usize * by + y as usize) * bx + x as usize
    }

    /// The largest value over extent voxels `v0` to `v1` (both included, within the extent).
    fn max_over(&self, v0: [i32; 3], v1: [i32; 3]) -> f32 {
        let b = |v: i32| v as u32 / self.side;
        let mut max = 0.0f32;
        for z in b(v0[2])..=b(v1[2]) {
            for y in b(v0[1])..=b(v1[1]) {
                for x in b(v0[0])..=b(v1[0]) {
                    max = max.max(self.max[self.block_index(x, y, z)]);
                }
            }
        }
        max
    }
}

impl VoxelGrid {
    /// A grid of `res` voxels with `channels` values each; an error naming what is wrong where
    /// a size is 0, `channels` is neither 1 nor 3, the data's length is not `nx·ny·nz·channels`
    /// or a value is negative or not finite.
    pub fn new(
        res: [u32; 3],
        channels: u32,
        values: Vec<f32>,
        edge: GridEdge,
        filter: GridFilter,
    ) -> Result<VoxelGrid, String> {
        if res.contains(&0) {
            return Err(format!("grid size {res:?} has a zero side"));
        }
        if channels != 1 && channels != 3 {
            return Err(format!("grids have 1 or 3 channels, not {channels}"));
        }
        let expected = voxel_count(res)
            .and_then(|n| n.checked_mul(channels as usize))
            .ok_or_else(|| format!("grid size {res:?} is too large"))?;
        if values.len() != expected {
            return Err(format!(
                "grid of {}×{}×{} voxels × {channels} channel(s) needs {expected} values, got {}",
                res[0],
                res[1],
                res[2],
                values.len()
            ));
        }
        if let Some(i) = values.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(format!(
                "grid value {} (number {}) is negative or not finite",
                values[i],
                i + 1
            ));
        }
        Ok(VoxelGrid {
            res,
            channels,
            voxels: Voxels::Dense(values),
            edge,
            filter,
        })
    }

    /// A one-channel trilinear grid of `blocks`' extent whose voxel `v` is `source`'s voxel
    /// `first + v` (with [`GridEdge::Zero`] beyond the extent); an error where a size is 0.
    pub fn sparse(source: Arc<dyn SparseVoxels>, blocks: BlockMax) -> Result<VoxelGrid, String> {
        let res = blocks.res;
        if res.contains(&0) {
            return Err(format!("grid size {res:?} has a zero side"));
        }
        Ok(VoxelGrid {
            res,
            channels: 1,
            voxels: Voxels::Sparse {
                source,
                first: blocks.first,
                blocks,
            },
            edge: GridEdge::Zero,
            filter: GridFilter::Trilinear,
        })
    }

    /// Whether its values come from a sparse grid.
    pub fn is_sparse(&self) -> bool {
        matches!(self.voxels, Voxels::Sparse { .. })
    }

    /// Voxels per axis.
    pub fn res(&self) -> [u32; 3] {
        self.res
    }

    /// Values per voxel (1 or 3; a single channel stands for all three).
    pub fn channels(&self) -> u32 {
        self.channels
    }

    /// The value of voxel `(x, y, z)`, with the grid's edge rule beyond it.
    #[inline]
    fn voxel(&self, x: i32, y: i32, z: i32) -> Rgb {
        match &self.voxels {
            Voxels::Dense(values) => self.dense_voxel(values, x, y, z),
            Voxels::Sparse { source, first, .. } => {
                let inside = IVec3::new(x, y, z).cmplt(self.res_i32()).all();
                if x < 0 || y < 0 || z < 0 || !inside {
                    return Vec3::ZERO;
                }
                Vec3::splat(source.value(*first + IVec3::new(x, y, z)))
            }
        }
    }

    /// Voxels per axis, as integers.
    fn res_i32(&self) -> IVec3 {
        IVec3::new(self.res[0] as i32, self.res[1] as i32, self.res[2] as i32)
    }

    /// The value of voxel `(x, y, z)` of a dense grid whose values are `values`.
    #[inline]
    fn dense_voxel(&self, values: &[f32], x: i32, y: i32, z: i32) -> Rgb {
        let [nx, ny, nz] = self.res.map(|n| n as i32);
        let (x, y, z) = match self.edge {
            GridEdge::Zero => {
                if x < 0 || y < 0 || z < 0 || x >= nx || y >= ny || z >= nz {
                    return Vec3::ZERO;
                }
                (x, y, z)
            }
            GridEdge::Clamp => (x.clamp(0, nx - 1), y.clamp(0, ny - 1), z.clamp(0, nz - 1)),
        };
        let i = ((z as usize * ny as usize + y as usize) * nx as usize + x as usize)
            * self.channels as usize;
        if self.channels == 1 {
            Vec3::splat(values[i])
        } else {
            Vec3::new(values[i], values[i + 1], values[i + 2])
        }
    }

    /// The values of voxels `(x, y, z)` to `(x + 1, y + 1, z + 1)` of a sparse grid, x
    /// fastest.
    fn sparse_cube(&self, x: i32, y: i32, z: i32) -> [Rgb; 8] {
        let base = IVec3::new(x, y, z);
        let inside = base.cmpge(IVec3::ZERO).all() && (base + 1).cmplt(self.res_i32()).all();
        match &self.voxels {
            Voxels::Sparse { source, first, .. } if inside => {
                source.cube(*first + base).map(Vec3::splat)
            }
            _ => std::array::from_fn(|i| {
                let i = i as i32;
                self.voxel(x + (i & 1), y + (i >> 1 & 1), z + (i >> 2))
            }),
        }
    }

    /// The value at point `p` of the unit cube.
    #[inline]
    pub fn lookup(&self, p: Vec3) -> Rgb {
        let n = Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32);
        if self.filter == GridFilter::Nearest {
            let i = (p * n).floor();
            return self.voxel(i.x as i32, i.y as i32, i.z as i32);
        }
        let s = p * n - 0.5;
        let f = s.floor();
        let d = s - f;
        let (x, y, z) = (f.x as i32, f.y as i32, f.z as i32);
        let lerp = |t: f32, a: Rgb, b: Rgb| a + (b - a) * t;
        if let Voxels::Dense(values) = &self.voxels {
            let v = |x, y, z| self.dense_voxel(values, x, y, z);
            let row = |y: i32, z: i32| lerp(d.x, v(x, y, z), v(x + 1, y, z));
            let plane = |z: i32| lerp(d.y, row(y, z), row(y + 1, z));
            return lerp(d.z, plane(z), plane(z + 1));
        }
        let c = self.sparse_cube(x, y, z);
        let row = |i: usize| lerp(d.x, c[i], c[i + 1]);
        let plane = |i: usize| lerp(d.y, row(i), row(i + 2));
        lerp(d.z, plane(0), plane(4))
    }

    /// Per channel, the smallest and largest values that lookups inside the box `[lo, hi]` of
    /// the unit cube can return.
    pub fn range_in(&self, lo: Vec3, hi: Vec3) -> (Rgb, Rgb) {
        let n = Vec3::new(self.res[0] as f32, self.res[1] as f32, self.res[2] as f32);
        // The voxels whose centres (or, for nearest lookups, cells) the box touches, and one
        // beyond on each side for interpolation.
        let first = (lo * n - 0.5).floor();
        let last = (hi * n - 0.5).floor() + 1.0;
        let clamp = |v: f32, i: usize| (v.max(0.0) as i32).min(self.res[i] as i32 - 1);
        let (x0, y0, z0) = (clamp(first.x, 0), clamp(first.y, 1), clamp(first.z, 2));
        let (x1, y1, z1) = (clamp(last.x, 0), clamp(last.y, 1), clamp(last.z, 2));
        if let Voxels::Sparse { blocks, .. } = &self.voxels {
            let max = blocks.max_over([x0, y0, z0], [x1, y1, z1]);
            return (Vec3::ZERO, Vec3::splat(max));
        }
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::ZERO;
        for z in z0..=z1 {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let v = self.voxel(x, y, z);
                    min = min.min(v);
                    max = max.max(v);
                }
            }
        }
        let beyond = (first.cmplt(Vec3::ZERO) | last.cmpge(n)).any();
        if self.edge == GridEdge::Zero && beyond {
            min = Vec3::ZERO;
        }
        (min, max)
    }
}

/// `nx·ny·nz`, `None` where it overflows.
pub fn voxel_count(res: [u32; 3]) -> Option<usize> {
    (res[0] as usize)
        .checked_mul(res[1] as usize)?
        .checked_mul(res[2] as usize)
}

/// One factor of a [`Field`]: the value of grid number `grid`, or one minus it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Factor {
    /// Index into [`GridMedium`]'s grids.
    pub grid: u8,
    /// Use `1 − value` (Mitsuba's absorption share `1 − albedo`).
    pub complement: bool,
}

/// A coefficient over space: `scale` times the product of up to two grid factors (a constant
/// where there are none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Field {
    /// Per-channel scale (per unit length for coefficients, radiance for emission).
    pub scale: Rgb,
    /// The grid factors.
    pub factors: [Option<Factor>; 2],
}

impl Field {
    /// A constant field.
    pub fn constant(scale: Rgb) -> Field {
        Field {
            scale,
            factors: [None; 2],
        }
    }

    /// `scale` times grid `grid`.
    pub fn grid(scale: Rgb, grid: u8) -> Field {
        Field {
            scale,
            factors: [
                Some(Factor {
                    grid,
                    complement: false,
                }),
                None,
            ],
        }
    }

    /// Its value from the grids' values at a point.
    #[inline]
    fn value(&self, grid_values: &[Rgb; MAX_GRIDS]) -> Rgb {
        let mut v = self.scale;
        for f in self.factors.iter().flatten() {
            let g = grid_values[f.grid as usize];
            v *= if f.complement {
                (Vec3::ONE - g).max(Vec3::ZERO)
            } else {
                g
            };
        }
        v
    }

    /// Per channel, its largest value where the grids range as `ranges` says.
    fn max_value(&self, ranges: &[(Rgb, Rgb)]) -> Rgb {
        let mut v = self.scale;
        for f in self.factors.iter().flatten() {
            let (min, max) = ranges[f.grid as usize];
            v *= if f.complement {
                (Vec3::ONE - min).max(Vec3::ZERO)
            } else {
                max
            };
        }
        v
    }
}

/// Blackbody emission from a temperature grid (pbrt-v4's `temperature`): at a point of grid
/// temperature `t`, the kelvins are `(t − offset) · scale`; above 100 K the emitted radiance
/// is the medium's emission field times the blackbody's RGB there, from a table.
#[derive(Clone, Debug, PartialEq)]
pub struct Temperature {
    /// Index of the temperature grid.
    pub grid: u8,
    /// Subtracted from grid values, kelvins.
    pub offset: f32,
    /// Multiplies grid values after the offset.
    pub scale: f32,
    /// RGB per kelvin step from 0 K, linearly interpolated.
    table: Vec<Rgb>,
    /// Kelvins per table step.
    step: f32,
}

impl Temperature {
    /// Entries of the table.
    const STEPS: usize = 2048;

    /// A temperature field from grid `grid` whose kelvins reach at most `hottest`, with
    /// `rgb(kelvin)` the emitted RGB of a blackbody (`None` for none).
    pub fn new(
        (grid, offset, scale): (u8, f32, f32),
        hottest: f32,
        rgb: impl Fn(f64) -> Option<Rgb>,
    ) -> Temperature {
        let top = hottest.max(101.0);
        let step = top / (Self::STEPS - 1) as f32;
        let table = (0..Self::STEPS)
            .map(|i| {
                let k = i as f32 * step;
                if k > 100.0 {
                    rgb(f64::from(k)).unwrap_or(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        Temperature {
            grid,
            offset,
            scale,
            table,
            step,
        }
    }

    /// The blackbody RGB for grid value `t`.
    #[inline]
    fn rgb(&self, t: f32) -> Rgb {
        let k = (t - self.offset) * self.scale;
        let glows = k > 100.0;
        if !glows {
            return Vec3::ZERO;
        }
        let x = (k / self.step).min((Self::STEPS - 1) as f32);
        let i = (x as usize).min(Self::STEPS - 2);
        let f = x - i as f32;
        self.table[i] * (1.0 - f) + self.table[i + 1] * f
    }
}

/// Grids one medium may hold (σa, σs and emission each from their own).
pub const MAX_GRIDS: usize = 3;

/// Cells per axis of the majorant grid: pbrt-v4's choices for its dense grids and for its
/// NanoVDB (here: sparse) ones.
const MAJORANT_RES: usize = 16;
const SPARSE_MAJORANT_RES: usize = 64;

/// A medium whose coefficients vary over a box (pbrt-v4's `uniformgrid` and `rgbgrid`,
/// Mitsuba's `heterogeneous` with grid volumes): `σa = sigma_a(p)`, `σs = sigma_s(p)`, emitted
/// radiance `Le(p)` (the source term is `σa·Le`), Henyey-Greenstein asymmetry `g`.
#[derive(Clone, Debug)]
pub struct GridMedium {
    to_unit: Affine3A,
    grids: Vec<Arc<VoxelGrid>>,
    sigma_a: Field,
    sigma_s: Field,
    emission: Field,
    /// Henyey-Greenstein asymmetry in (−1, 1).
    pub g: f32,
    /// Per cell of a `majorant_res³` grid over the unit cube, per channel, a bound on `σt`.
    majorant: Vec<Rgb>,
    majorant_res: usize,
    /// The box of the unit cube the medium fills (all of it unless a format clips it).
    bounds: (Vec3, Vec3),
    /// Blackbody emission, where a temperature grid gives it.
    temperature: Option<Temperature>,
}

impl PartialEq for GridMedium {
    fn eq(&self, other: &GridMedium) -> bool {
        self.to_unit == other.to_unit
            && self.grids == other.grids
            && (self.sigma_a, self.sigma_s, self.emission, self.g)
                == (other.sigma_a, other.sigma_s, other.emission, other.g)
    }
}

/// A medium's coefficients at one point.
#[derive(Clone, Copy, Debug)]
pub struct MediumPoint {
    /// Absorption per unit length.
    pub sigma_a: Rgb,
    /// Scattering per unit length.
    pub sigma_s: Rgb,
    /// Emitted radiance (the source term is `σa·Le`).
    pub le: Rgb,
}

impl GridMedium {
    /// A grid medium: `to_unit` maps world space onto the grids' unit cube; the fields refer
    /// to `grids` by index (at most [`MAX_GRIDS`]; an error otherwise, or where a field names
    /// a grid that is not there).
    pub fn new(
        to_unit: Affine3A,
        grids: Vec<Arc<VoxelGrid>>,
        (sigma_a, sigma_s, emission): (Field, Field, Field),
        g: f32,
    ) -> Result<GridMedium, String> {
        if grids.len() > MAX_GRIDS {
            return Err(format!("a medium holds at most {MAX_GRIDS} grids"));
        }
        let known = |f: &Field| {
            f.factors
                .iter()
                .flatten()
                .all(|x| (x.grid as usize) < grids.len())
        };
        if !(known(&sigma_a) && known(&sigma_s) && known(&emission)) {
            return Err("a medium field names a grid it does not hold".into());
        }
        let mut m = GridMedium {
            to_unit,
            grids,
            sigma_a,
            sigma_s,
            emission,
            g,
            majorant: Vec::new(),
            majorant_res: MAJORANT_RES,
            bounds: (Vec3::ZERO, Vec3::ONE),
            temperature: None,
        };
        if m.grids.iter().any(|g| g.is_sparse()) {
            m.majorant_res = SPARSE_MAJORANT_RES;
        }
        m.majorant = m.majorants();
        Ok(m)
    }

    /// The medium emitting as a blackbody of temperature `t` times its emission field; an
    /// error where `t` names a grid it does not hold.
    pub fn with_temperature(mut self, t: Temperature) -> Result<GridMedium, String> {
        if t.grid as usize >= self.grids.len() {
            return Err("a temperature names a grid the medium does not hold".into());
        }
        self.temperature = Some(t);
        Ok(self)
    }

    /// The largest value of grid `i` (0 where there is none).
    pub fn grid_max(&self, i: usize) -> f32 {
        self.grids
            .get(i)
            .map_or(0.0, |g| g.range_in(Vec3::ZERO, Vec3::ONE).1.max_element())
    }

    /// The medium confined to the box `[lo, hi]` of its unit cube (pbrt-v4's NanoVDB media end
    /// at their grid's world box, which is not the cube of its voxel centres).
    pub fn clipped(mut self, lo: Vec3, hi: Vec3) -> GridMedium {
        self.bounds = (lo.max(Vec3::ZERO), hi.min(Vec3::ONE));
        self
    }

    /// Per majorant cell, the largest `σa + σs` lookups in it can give.
    fn majorants(&self) -> Vec<Rgb> {
        let n = self.majorant_res;
        let mut out = Vec::with_capacity(n * n * n);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let lo = Vec3::new(x as f32, y as f32, z as f32) / n as f32;
                    let hi = Vec3::new((x + 1) as f32, (y + 1) as f32, (z + 1) as f32) / n as f32;
                    let ranges: Vec<(Rgb, Rgb)> =
                        self.grids.iter().map(|g| g.range_in(lo, hi)).collect();
                    out.push(self.sigma_a.max_value(&ranges) + self.sigma_s.max_value(&ranges));
                }
            }
        }
        out
    }

    /// Whether it emits anywhere.
    pub fn emits(&self) -> bool {
        self.emission.scale.max_element() > 0.0
    }

    /// Its coefficients at world point `p` (zero outside its box).
    #[inline]
    pub fn at(&self, p: Vec3) -> MediumPoint {
        let u = self.to_unit.transform_point3(p);
        let (lo, hi) = self.bounds;
        if !(u.cmpge(lo).all() && u.cmple(hi).all()) {
            return MediumPoint {
                sigma_a: Vec3::ZERO,
                sigma_s: Vec3::ZERO,
                le: Vec3::ZERO,
            };
        }
        let mut values = [Vec3::ZERO; MAX_GRIDS];
        for (v, g) in values.iter_mut().zip(&self.grids) {
            *v = g.lookup(u);
        }
        MediumPoint {
            sigma_a: self.sigma_a.value(&values),
            sigma_s: self.sigma_s.value(&values),
            le: if self.emits() {
                let le = self.emission.value(&values);
                match &self.temperature {
                    Some(t) => le * t.rgb(values[t.grid as usize].x),
                    None => le,
                }
            } else {
                Vec3::ZERO
            },
        }
    }

    /// The stretches of `ray` within `(0, t_max)` that cross the medium's box,
    /// one per majorant cell, in order, with the cell's majorant.
    pub fn segments(&self, ray: &Ray, t_max: f32) -> Segments<'_> {
        let o = self.to_unit.transform_point3(ray.o);
        let d = self.to_unit.transform_vector3(ray.d);
        let (lo, hi) = self.bounds;
        let (mut t0, mut t1) = (0.0f32, t_max);
        for a in 0..3 {
            if d[a] == 0.0 {
                if !(lo[a]..=hi[a]).contains(&o[a]) {
                    return Segments::empty(&self.majorant, self.majorant_res);
                }
                continue;
            }
            let (near, far) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            let (near, far) = if near <= far {
                (near, far)
            } else {
                (far, near)
            };
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        let overlaps = t0 < t1;
        if !overlaps {
            return Segments::empty(&self.majorant, self.majorant_res);
        }
        Segments::new((&self.majorant, self.majorant_res), o, d, t0, t1)
    }
}

/// The majorant cells a ray crosses, as a 3D DDA (pbrt-v4's `DDAMajorantIterator`): items
/// `(t_start, t_end, σ_maj)`.
pub struct Segments<'a> {
    majorant: &'a [Rgb],
    /// Cells per axis.
    res: usize,
    t: f32,
    t_end: f32,
    voxel: [i32; 3],
    step: [i32; 3],
    limit: [i32; 3],
    next_crossing: [f32; 3],
    delta: [f32; 3],
}

impl<'a> Segments<'a> {
    fn empty(majorant: &'a [Rgb], res: usize) -> Segments<'a> {
        Segments {
            majorant,
            res,
            t: 0.0,
            t_end: 0.0,
            voxel: [0; 3],
            step: [0; 3],
            limit: [0; 3],
            next_crossing: [f32::INFINITY; 3],
            delta: [0.0; 3],
        }
    }

    /// From unit-space origin `o` and direction `d`, over `[t0, t1]` (inside the cube), through
    /// `majorant`'s cells (`res` per axis).
    fn new(
        (majorant, res): (&'a [Rgb], usize),
        o: Vec3,
        d: Vec3,
        t0: f32,
        t1: f32,
    ) -> Segments<'a> {
        let n = res as i32;
        let mut s = Segments::empty(majorant, res);
        s.t = t0;
        s.t_end = t1;
        let entry = o + d * t0;
        for a in 0..3 {
            let v = ((entry[a] * n as f32) as i32).clamp(0, n - 1);
            s.voxel[a] = v;
            if d[a] == 0.0 {
                s.next_crossing[a] = f32::INFINITY;
                s.delta[a] = f32::INFINITY;
                s.step[a] = 1;
                s.limit[a] = n;
                continue;
            }
            s.delta[a] = 1.0 / (d[a].abs() * n as f32);
            let (boundary, step, limit) = if d[a] > 0.0 {
                ((v + 1) as f32 / n as f32, 1, n)
            } else {
                (v as f32 / n as f32, -1, -1)
            };
            s.next_crossing[a] = t0 + (boundary - entry[a]) / d[a];
            s.step[a] = step;
            s.limit[a] = limit;
        }
        s
    }
}

impl Iterator for Segments<'_> {
    type Item = (f32, f32, Rgb);

    fn next(&mut self) -> Option<(f32, f32, Rgb)> {
        let left = self.t < self.t_end;
        if !left {
            return None;
        }
        let c = self.next_crossing;
        let axis = if c[0] < c[1] {
            if c[0] < c[2] {
                0
            } else {
                2
            }
        } else if c[1] < c[2] {
            1
        } else {
            2
        };
        let exit = self.t_end.min(c[axis]);
        let n = self.res;
        let [x, y, z] = self.voxel.map(|v| v as usize);
        let segment = (self.t, exit, self.majorant[(z * n + y) * n + x]);
        self.t = exit;
        self.voxel[axis] += self.step[axis];
        if c[axis] > self.t_end || self.voxel[axis] == self.limit[axis] {
            self.t = self.t_end;
        }
        self.next_crossing[axis] += self.delta[axis];
        Some(segment)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn random_grid(res: [u32; 3], channels: u32, edge: GridEdge, seed: u64) -> VoxelGrid {
        let mut rng = Rng::new(seed, 1);
        let n = voxel_count(res).unwrap() * channels as usize;
        let values = (0..n).map(|_| rng.next_f32() * 3.0).collect();
        VoxelGrid::new(res, channels, values, edge, GridFilter::Trilinear).unwrap()
    }

    #[test]
    fn lookups_interpolate_between_voxel_centres() {
        let g = VoxelGrid::new(
            [2, 1, 1],
            1,
            vec![1.0, 3.0],
            GridEdge::Zero,
            GridFilter::Trilinear,
        )
        .unwrap();
        // Centres at x = 0.25 and 0.75; y and z at the single voxel's centre.
        let at = |x: f32| g.lookup(Vec3::new(x, 0.5, 0.5)).x;
        assert_eq!(at(0.25), 1.0);
        assert_eq!(at(0.75), 3.0);
        assert_eq!(at(0.5), 2.0);
        // pbrt-v4 fades to 0 beyond the outer centres; Mitsuba's clamp holds the edge value.
        assert_eq!(at(0.0), 0.5);
        let clamped = VoxelGrid {
            edge: GridEdge::Clamp,
            ..g.clone()
        };
        assert_eq!(clamped.lookup(Vec3::new(1.0, 0.5, 0.5)).x, 3.0);
        let nearest = VoxelGrid {
            filter: GridFilter::Nearest,
            ..clamped
        };
        assert_eq!(nearest.lookup(Vec3::new(0.49, 0.5, 0.5)).x, 1.0);
    }

    #[test]
    fn malformed_grids_are_refused() {
        let make = |res, ch, v: Vec<f32>| {
            VoxelGrid::new(res, ch, v, GridEdge::Zero, GridFilter::Trilinear)
        };
        assert!(make([2, 2, 2], 1, vec![1.0; 7]).is_err());
        assert!(make([2, 2, 2], 3, vec![1.0; 8]).is_err());
        assert!(make([2, 0, 2], 1, vec![]).is_err());
        assert!(make([1, 1, 1], 2, vec![1.0; 2]).is_err());
        assert!(make([1, 1, 1], 1, vec![-1.0]).is_err());
        assert!(make([1, 1, 1], 1, vec![f32::NAN]).is_err());
        assert!(make([u32::MAX, u32::MAX, u32::MAX], 1, vec![]).is_err());
        assert!(make([1, 1, 2], 1, vec![0.0, 2.0]).is_ok());
    }

    #[test]
    fn majorants_bound_every_lookup_along_rays() {
        // Random rays through a random tilted grid: every point of every segment has σt at
        // most the segment's majorant, and the segments tile the ray's stretch in the box.
        for (edge, channels) in [(GridEdge::Zero, 1), (GridEdge::Clamp, 3)] {
            let grid = Arc::new(random_grid([7, 5, 9], channels, edge, 5));
            let albedo = Arc::new(random_grid([7, 5, 9], 1, GridEdge::Clamp, 6));
            let to_unit = Affine3A::from_scale_rotation_translation(
                Vec3::new(0.5, 0.25, 0.4),
                glam::Quat::from_rotation_y(0.3),
                Vec3::new(0.5, 0.2, 0.1),
            );
            let sigma_a = Field {
                scale: Vec3::new(2.0, 1.0, 0.5),
                factors: [
                    Some(Factor {
                        grid: 0,
                        complement: false,
                    }),
                    Some(Factor {
                        grid: 1,
                        complement: true,
                    }),
                ],
            };
            let sigma_s = Field {
                factors: [
                    sigma_a.factors[0],
                    Some(Factor {
                        grid: 1,
                        complement: false,
                    }),
                ],
                ..sigma_a
            };
            let m = GridMedium::new(
                to_unit,
                vec![grid, albedo],
                (sigma_a, sigma_s, Field::constant(Vec3::ZERO)),
                0.0,
            )
            .unwrap();
            let centre = to_unit.inverse().transform_point3(Vec3::splat(0.5));
            assert_majorants_bound(&m, centre, 8.0);
        }
    }

    /// Asserts that along 300 random rays from within `spread` of `centre` towards it, every
    /// point of every segment has σt at most the segment's majorant, and that the segments
    /// tile the ray's stretch in the medium's box.
    pub(crate) fn assert_majorants_bound(m: &GridMedium, centre: Vec3, spread: f32) {
        let mut rng = Rng::new(9, 2);
        for _ in 0..300 {
            let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
            let o = centre + r3() * spread;
            let d = (centre + r3() * (spread / 8.0) - o).normalize();
            let ray = Ray::new(o, d);
            let mut last: Option<f32> = None;
            for (t0, t1, maj) in m.segments(&ray, 100.0 * spread) {
                assert!(t0 < t1, "{t0} {t1}");
                if let Some(l) = last {
                    assert!((t0 - l).abs() < 1e-4 * spread, "gap {l} {t0}");
                }
                last = Some(t1);
                for k in 0..16 {
                    let t = t0 + (t1 - t0) * (k as f32 + 0.5) / 16.0;
                    let p = m.at(ray.at(t));
                    let st = p.sigma_a + p.sigma_s;
                    assert!(st.cmple(maj * 1.0001 + 1e-6).all(), "{st} > {maj}");
                }
            }
        }
    }
}
