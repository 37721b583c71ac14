//! The film: per-pixel sums of the camera samples of one frame (or one cell of it), kept
//! exactly so that renders can be paused, saved, resumed and merged without changing a bit.
//!
//! Conventions:
//! - Every pixel holds the samples `[first, first + n)` of its sample sequence ([`Film::first`]
//!   is shared by all pixels, `n` is per pixel). A render adds samples at the end of each
//!   pixel's range; [`Film::merge`] joins two films whose ranges are adjacent in every pixel.
//! - Radiance sums are fixed-point integers ([`FRAC_BITS`] fractional bits, `i128`): each
//!   sample is rounded once to that grid (2⁻⁴⁰ ≈ 9·10⁻¹³) and clamped to ±[`MAX_SAMPLE`], and
//!   integer addition is associative, so the sums of a sample range do not depend on how the
//!   range was split into passes, checkpoints or machines. The same holds for the sums of
//!   squares (each square clamped to [`MAX_SAMPLE`]), the ray counts and the sample counts.
//! - CS184's adaptive sampling (`-a`) keeps its own illuminance sums in `f64`, in sample
//!   order; they are exact under resumption (the order is the same) but not under merging, so
//!   `-a` renders are never split into sample ranges.
//! - Splatted camera samples ([`crate::filter::PixelFilter::splat`]) are held beside the
//!   pixels: per pixel the fixed-point sums of weight × radiance and of the weights
//!   ([`Film::add_filtered`]); the pixel's value is their ratio. Each contribution is rounded
//!   once, so these sums too do not depend on how the work was split.
//! - Pixels are stored tile by tile ([`TILE`]-square tiles, row-major within a tile, tiles
//!   row-major over the cell), so that threads own whole tiles; [`Film::develop`] returns the
//!   row-major image.
//! - The file form ([`Film::save`], [`Film::load`]): the 8-byte magic `PTFILM\r\n`, the format
//!   version (u32), the length of a UTF-8 header (u32) of `key=value` lines, the pixel records
//!   (little-endian, [`RECORD_BYTES`] each, in storage order), and the SHA-256 of everything
//!   before it. The header holds the geometry (`frame`, `cell`, `first`, `level`), `light`
//!   and `filtered=1` where the film holds light passes or splatted samples (their sums
//!   follow the pixel records: 48 and 64 bytes per pixel), `features=1` where it records
//!   denoising features (their sums follow those: 48 bytes per pixel, in storage order), and
//!   the caller's identity lines (what the render belongs to, see [`Film::identity`]).
//! - Denoising features (`features`) are summed per pixel over the same samples as
//!   the radiance, in fixed point ([`FEATURE_FRAC_BITS`]), so they too are exact under any
//!   split of the work.

use crate::error::{Error, Result};
use crate::io::image::Image;
use crate::math::Rgb;
use glam::Vec3;
use sha2::{Digest, Sha256};
use std::path::Path;

/// The features of one camera sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Features {
    /// The surface's colour ([`crate::bsdf::Bsdf::albedo`]) times the colour of the delta
    /// bounces before it, per channel in `[0, 1]`; black where the ray escapes.
    pub albedo: Rgb,
    /// The unit world-space shading normal there, turned towards the arriving ray; zero
    /// where the ray escapes.
    pub normal: Vec3,
}

/// Side of the square tiles that threads take, in pixels.
pub const TILE: u32 = 16;
/// Fractional bits of the fixed-point sums.
pub const FRAC_BITS: i32 = 40;
/// Largest magnitude a sample's channel (and its square) contributes; larger values are
/// clamped (2⁵⁴ ≈ 1.8·10¹⁶, far above any radiance a scene produces).
pub const MAX_SAMPLE: f64 = 18_014_398_509_481_984.0;
/// Bytes of one pixel record in the file form.
pub const RECORD_BYTES: usize = 6 * 16 + 4 + 4 + 8 + 8 + 8 + 1;
/// Fractional bits of the feature sums (components within ±1: `n · 2³⁰` fits an `i64` for
/// any sample count a pixel holds).
pub const FEATURE_FRAC_BITS: i32 = 30;
/// Current file-format version.
pub const VERSION: u32 = 1;
const MAGIC: &[u8; 8] = b"PTFILM\r\n";

/// A rectangle of the frame, in pixels: top-left corner and size (`-p X Y DX DY`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cell {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width.
    pub w: u32,
    /// Height.
    pub h: u32,
}

/// The accumulated samples of one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilmPixel {
    /// Sum of the samples' radiance per channel, fixed point ([`FRAC_BITS`]).
    pub sum: [i128; 3],
    /// Sum of the squares per channel, fixed point.
    pub sum2: [i128; 3],
    /// Samples taken.
    pub n: u32,
    /// Samples this pixel is to reach in the current round (adaptive budget).
    pub target: u32,
    /// Rays traced for these samples (their cost).
    pub rays: u64,
    /// CS184 adaptive sampling: sums of the samples' illuminance and of its square.
    pub s1: f64,
    /// See `s1`.
    pub s2: f64,
    /// CS184 adaptive sampling stopped this pixel.
    pub done: bool,
}

/// One pixel's sums of its samples' denoising features: albedo (0–2) and normal (3–5), fixed
/// point ([`FEATURE_FRAC_BITS`]). Kept beside the pixels, only in films that record them.
pub type FeatureSums = [i64; 6];

/// Adds one sample's denoising features to `sums` (albedo in `[0, 1]`, normal within ±1;
/// values beyond are clamped, non-finite ones count as 0).
#[inline]
pub fn add_features(sums: &mut FeatureSums, f: Features) {
    const SCALE: f32 = (1u64 << FEATURE_FRAC_BITS) as f32;
    let values = f.albedo.to_array().into_iter().chain(f.normal.to_array());
    for (sum, v) in sums.iter_mut().zip(values) {
        let v = if v.is_finite() {
            v.clamp(-1.0, 1.0)
        } else {
            0.0
        };
        *sum += (v * SCALE).round_ties_even() as i64;
    }
}

/// The mean features of `n` samples whose sums are `sums` (zero without samples).
pub fn mean_features(sums: &FeatureSums, n: u32) -> Features {
    if n == 0 {
        return Features::default();
    }
    let scale = (1u64 << FEATURE_FRAC_BITS) as f64 * n as f64;
    let mean = |i: usize| (sums[i] as f64 / scale) as f32;
    Features {
        albedo: Vec3::new(mean(0), mean(1), mean(2)),
        normal: Vec3::new(mean(3), mean(4), mean(5)),
    }
}

/// `v` on the fixed-point grid, rounded to nearest (ties to even), clamped to
/// ±[`MAX_SAMPLE`]; NaN gives 0. Runs six times per sample, so the common case (|v| < 2¹¹)
/// is one multiplication and the add-and-subtract rounding trick, and the rest works on the
/// bits; neither calls the slow float-to-`i128` conversion.
#[inline]
pub(crate) fn fixed(v: f64) -> i128 {
    const SCALE: f64 = (1u64 << FRAC_BITS) as f64;
    // 1.5·2^52: adding it leaves an integer-spaced grid for |x| < 2^51.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    let x = v * SCALE;
    if x.abs() < 2_251_799_813_685_248.0 {
        return ((x + ROUND) - ROUND) as i64 as i128;
    }
    fixed_large(v)
}

/// [`fixed`] for values outside its fast range, on the bits of `v`.
fn fixed_large(v: f64) -> i128 {
    if v.is_nan() {
        return 0;
    }
    let v = v.clamp(-MAX_SAMPLE, MAX_SAMPLE);
    let bits = v.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    if exp == 0 {
        return 0; // zero or subnormal, far below the grid
    }
    // |v| = mant · 2^(exp − 1075); on the grid: mant · 2^shift.
    let mant = (bits & ((1u64 << 52) - 1)) | (1u64 << 52);
    let shift = exp - 1075 + FRAC_BITS;
    let mag = if shift >= 0 {
        (mant as i128) << shift
    } else if shift > -60 {
        let k = (-shift) as u32;
        let (q, rem, half) = (mant >> k, mant & ((1u64 << k) - 1), 1u64 << (k - 1));
        (q + (rem > half || (rem == half && q & 1 == 1)) as u64) as i128
    } else {
        0
    };
    if bits >> 63 == 1 {
        -mag
    } else {
        mag
    }
}

/// A fixed-point sum as a float.
#[inline]
fn float(s: i128) -> f64 {
    s as f64 / (1u64 << FRAC_BITS) as f64
}

impl FilmPixel {
    /// Adds one sample of radiance `l` (finite) that took `rays` rays.
    #[inline]
    pub fn add(&mut self, l: Vec3, rays: u64) {
        for (c, v) in l.to_array().into_iter().enumerate() {
            let v = v as f64;
            self.sum[c] += fixed(v);
            self.sum2[c] += fixed((v * v).min(MAX_SAMPLE));
        }
        self.n += 1;
        self.rays += rays;
    }

    /// Mean radiance (black without samples).
    pub fn mean(&self) -> Vec3 {
        if self.n == 0 {
            return Vec3::ZERO;
        }
        let n = self.n as f64;
        Vec3::new(
            (float(self.sum[0]) / n) as f32,
            (float(self.sum[1]) / n) as f32,
            (float(self.sum[2]) / n) as f32,
        )
    }

    /// Relative variance of one sample: per channel, the sample variance over `mean² + 0.01`
    /// (the denominator of the relative MSE), summed over channels; 0 below two samples.
    pub fn rel_variance(&self) -> f64 {
        self.rel_variance_beside(Vec3::ZERO)
    }

    /// [`FilmPixel::rel_variance`] of a pixel whose value is its mean plus `other` (the
    /// light paths' estimate, [`Film::light_mean`]): `other` joins the mean in the
    /// denominator only, as its variance does not fall with this pixel's samples.
    pub fn rel_variance_beside(&self, other: Vec3) -> f64 {
        if self.n < 2 {
            return 0.0;
        }
        let n = self.n as f64;
        (0..3)
            .map(|c| {
                let (s, s2) = (float(self.sum[c]), float(self.sum2[c]));
                let mean = s / n;
                let var = ((s2 - s * mean) / (n - 1.0)).max(0.0);
                let value = mean + other[c] as f64;
                var / (value * value + 0.01)
            })
            .sum()
    }

    /// Rays per sample, at least 1.
    pub fn cost(&self) -> f64 {
        (self.rays as f64 / self.n.max(1) as f64).max(1.0)
    }

    fn write(&self, out: &mut Vec<u8>) {
        for v in self.sum.iter().chain(&self.sum2) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&self.n.to_le_bytes());
        out.extend_from_slice(&self.target.to_le_bytes());
        out.extend_from_slice(&self.rays.to_le_bytes());
        out.extend_from_slice(&self.s1.to_le_bytes());
        out.extend_from_slice(&self.s2.to_le_bytes());
        out.push(self.done as u8);
    }

    /// Reads a record of [`RECORD_BYTES`] bytes; `None` when a field is out of range.
    fn read(b: &[u8]) -> Option<FilmPixel> {
        let i128_at = |o: usize| i128::from_le_bytes(b[o..o + 16].try_into().unwrap_or([0; 16]));
        let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().unwrap_or([0; 4]));
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap_or([0; 8]));
        let mut p = FilmPixel::default();
        for c in 0..3 {
            p.sum[c] = i128_at(16 * c);
            p.sum2[c] = i128_at(48 + 16 * c);
        }
        p.n = u32_at(96);
        p.target = u32_at(100);
        p.rays = u64_at(104);
        p.s1 = f64::from_bits(u64_at(112));
        p.s2 = f64::from_bits(u64_at(120));
        p.done = match b[128] {
            0 => false,
            1 => true,
            _ => return None,
        };
        // Sums a render can produce: |sum| ≤ n · 2^94 (samples clamped to 2^54 on a 2^-40
        // grid), squares non-negative; anything else would overflow when merged or resumed.
        let bound = p.n as i128 * (1i128 << 94);
        let plausible = p.sum.iter().all(|s| s.abs() <= bound)
            && p.sum2.iter().all(|s| (0..=bound).contains(s));
        (plausible && p.s1.is_finite() && p.s2.is_finite()).then_some(p)
    }
}

/// One tile of a film: its corner and size in cell pixels and where its pixels start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Left column, relative to the cell.
    pub x0: u32,
    /// Top row, relative to the cell.
    pub y0: u32,
    /// Width.
    pub w: u32,
    /// Height.
    pub h: u32,
    /// Index of its first pixel in the film's storage.
    pub start: usize,
}

impl Tile {
    /// Frame coordinates (column, row) of the tile's pixel `i` (storage order) when the tile
    /// belongs to `cell`.
    #[inline]
    pub fn frame_xy(&self, cell: Cell, i: usize) -> (u32, u32) {
        let i = i as u32;
        (cell.x + self.x0 + i % self.w, cell.y + self.y0 + i / self.w)
    }
}

/// The samples of one frame (or cell), as sums per pixel. See the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    frame: (u32, u32),
    cell: Cell,
    first: u32,
    /// Adaptive budget: the level (mean samples per pixel) whose targets the pixels hold; 0
    /// before the first round.
    pub level: u32,
    tiles: Vec<Tile>,
    pixels: Vec<FilmPixel>,
    identity: Vec<(String, String)>,
    /// Light passes held (`lighttrace`): passes `[first, first + light_passes)`.
    pub light_passes: u32,
    /// Sums of the light paths' splats per pixel and channel, row-major over the cell, fixed
    /// point ([`SPLAT_FRAC_BITS`]); empty until the first light pass.
    splat: Vec<[i128; 3]>,
    /// Splatted camera samples ([`crate::filter::PixelFilter::splat`]): per pixel, row-major
    /// over the cell, the sums of weight × radiance per channel and of the weights, fixed
    /// point ([`FRAC_BITS`]); a pixel's value is their ratio. Empty unless samples are
    /// splatted.
    filtered: Vec<[i128; 4]>,
    /// Per pixel, in storage order, the sums of its samples' denoising features; empty where
    /// the film records none.
    features: Vec<FeatureSums>,
}

/// Fractional bits of the light-path splat sums.
pub const SPLAT_FRAC_BITS: i32 = 32;

/// A splat value on the fixed-point grid of [`SPLAT_FRAC_BITS`], rounded to nearest and
/// clamped to ±2²⁴ (far above any splat a scene produces); NaN gives 0. The render's `i64`
/// accumulators are folded into the film every 64 light passes: they hold 2⁷ splats of the
/// clamp's size, and splats of ordinary size (below 1) by the billion.
#[inline]
pub fn splat_fixed(v: f32) -> i64 {
    const SCALE: f64 = (1u64 << SPLAT_FRAC_BITS) as f64;
    let v = (v as f64).clamp(-16_777_216.0, 16_777_216.0) * SCALE;
    if v.is_nan() {
        0
    } else {
        v.round_ties_even() as i64
    }
}

impl Film {
    /// An empty film for `cell` of a `width × height` frame (the whole frame without a cell),
    /// whose pixels start at sample `first`.
    pub fn new(width: u32, height: u32, cell: Option<Cell>, first: u32) -> Result<Film> {
        let cell = cell.unwrap_or(Cell {
            x: 0,
            y: 0,
            w: width,
            h: height,
        });
        if width == 0 || height == 0 {
            return Err(Error::Usage("image size must be positive".into()));
        }
        if cell.w == 0
            || cell.h == 0
            || cell.x as u64 + cell.w as u64 > width as u64
            || cell.y as u64 + cell.h as u64 > height as u64
        {
            return Err(Error::Usage(format!(
                "cell {}x{} at ({}, {}) does not fit in the {width}x{height} frame",
                cell.w, cell.h, cell.x, cell.y
            )));
        }
        let n = cell.w as u64 * cell.h as u64;
        if n > (1 << 28) {
            return Err(Error::Usage(format!(
                "{}x{} pixels are more than this renderer holds (at most 2^28)",
                cell.w, cell.h
            )));
        }
        let tiles = tiles_of(cell.w, cell.h);
        Ok(Film {
            frame: (width, height),
            cell,
            first,
            level: 0,
            tiles,
            pixels: vec![FilmPixel::default(); n as usize],
            identity: Vec::new(),
            light_passes: 0,
            splat: Vec::new(),
            filtered: Vec::new(),
            features: Vec::new(),
        })
    }

    /// The film recording denoising features (or not): renders into it add each sample's
    /// features to its pixel.
    pub fn with_features(mut self, on: bool) -> Film {
        self.features = if on {
            vec![[0; 6]; self.pixels.len()]
        } else {
            Vec::new()
        };
        self
    }

    /// Whether it records denoising features.
    pub fn has_features(&self) -> bool {
        !self.features.is_empty()
    }

    /// Its mean albedo and normal images, row-major over the cell; `None` where it records no
    /// features.
    pub fn feature_images(&self) -> Option<(Image, Image)> {
        if !self.has_features() {
            return None;
        }
        let (w, h) = (self.cell.w as usize, self.cell.h as usize);
        let (mut albedo, mut normal) = (Image::new(w, h), Image::new(w, h));
        for (i, px) in self.pixels.iter().enumerate() {
            let f = mean_features(&self.features[i], px.n);
            let p = self.pixel_index(i);
            albedo.pixels[p] = f.albedo;
            normal.pixels[p] = f.normal;
        }
        Some((albedo, normal))
    }

    /// Frame size `(width, height)`.
    pub fn frame(&self) -> (u32, u32) {
        self.frame
    }

    /// The region of the frame the film covers.
    pub fn cell(&self) -> Cell {
        self.cell
    }

    /// Index of the first sample of every pixel's range.
    pub fn first(&self) -> u32 {
        self.first
    }

    /// The tiles, in storage order.
    pub fn tiles(&self) -> &[Tile] {
        &self.tiles
    }

    /// What the film belongs to: `key=value` pairs its maker sets (scene hash, options) and
    /// that [`Film::save`] records; see [`Film::identity_mismatch`].
    pub fn identity(&self) -> &[(String, String)] {
        &self.identity
    }

    /// Sets the identity (keys and values must not contain line breaks or `=` in keys).
    pub fn set_identity(&mut self, identity: Vec<(String, String)>) {
        self.identity = identity;
    }

    /// Describes every difference between this film's identity and `other` (an expected
    /// identity), or `None` when they agree: "KEY is A in the checkpoint but B here".
    pub fn identity_mismatch(&self, other: &[(String, String)]) -> Option<String> {
        self.identity_differences(other, ("in the checkpoint", "here"))
    }

    /// Every difference between this film's identity and `other`, each as "KEY is A
    /// {this} but B {that}" with `(this, that)` the words for the two sides; `None` when
    /// they agree.
    pub fn identity_differences(
        &self,
        other: &[(String, String)],
        (this, that): (&str, &str),
    ) -> Option<String> {
        let get = |list: &[(String, String)], k: &str| {
            list.iter()
                .find(|(key, _)| key == k)
                .map(|(_, v)| v.clone())
        };
        let mut keys: Vec<&str> = self.identity.iter().map(|(k, _)| k.as_str()).collect();
        for (k, _) in other {
            if !keys.contains(&k.as_str()) {
                keys.push(k);
            }
        }
        let diffs: Vec<String> = keys
            .into_iter()
            .filter_map(|k| {
                let (a, b) = (get(&self.identity, k), get(other, k));
                (a != b).then(|| {
                    format!(
                        "{k} is {} {this} but {} {that}",
                        a.as_deref().unwrap_or("(absent)"),
                        b.as_deref().unwrap_or("(absent)")
                    )
                })
            })
            .collect();
        (!diffs.is_empty()).then(|| diffs.join("; "))
    }

    /// Pixels in storage order (tile by tile).
    pub fn pixels(&self) -> &[FilmPixel] {
        &self.pixels
    }

    /// Pixels in storage order, mutable.
    pub fn pixels_mut(&mut self) -> &mut [FilmPixel] {
        &mut self.pixels
    }

    /// Each tile with its pixels, mutable (disjoint, for threads).
    pub fn tiles_mut(&mut self) -> Vec<(Tile, &mut [FilmPixel], &mut [FeatureSums])> {
        let mut rest: &mut [FilmPixel] = &mut self.pixels;
        let mut features: &mut [FeatureSums] = &mut self.features;
        let mut out = Vec::with_capacity(self.tiles.len());
        for t in &self.tiles {
            let n = (t.w * t.h) as usize;
            let (a, b) = std::mem::take(&mut rest).split_at_mut(n);
            let (fa, fb) = if features.is_empty() {
                (&mut [][..], &mut [][..])
            } else {
                std::mem::take(&mut features).split_at_mut(n)
            };
            out.push((*t, a, fa));
            rest = b;
            features = fb;
        }
        out
    }

    /// Row-major cell index of storage index `i`.
    pub fn pixel_index(&self, i: usize) -> usize {
        // Tiles are in row-major order of equal-size rows, so a search finds the tile.
        let t = match self.tiles.binary_search_by(|t| t.start.cmp(&i)) {
            Ok(t) => t,
            Err(t) => t - 1,
        };
        let tile = &self.tiles[t];
        let j = (i - tile.start) as u32;
        ((tile.y0 + j / tile.w) * self.cell.w + tile.x0 + j % tile.w) as usize
    }

    /// Row-major `(index, pixel)` pairs of storage order, for whole-film passes.
    pub fn row_major(&self) -> impl Iterator<Item = (usize, &FilmPixel)> {
        self.tiles.iter().flat_map(move |t| {
            (0..t.w * t.h).map(move |j| {
                (
                    ((t.y0 + j / t.w) * self.cell.w + t.x0 + j % t.w) as usize,
                    &self.pixels[t.start + j as usize],
                )
            })
        })
    }

    /// Adds one batch of light passes: `passes` more passes whose splat sums (row-major over
    /// the cell, [`SPLAT_FRAC_BITS`]) are `sums`.
    pub fn add_light_passes(&mut self, passes: u32, sums: &[[i64; 3]]) {
        if self.splat.is_empty() {
            self.splat = vec![[0; 3]; self.pixels.len()];
        }
        for (acc, v) in self.splat.iter_mut().zip(sums) {
            for c in 0..3 {
                acc[c] += v[c] as i128;
            }
        }
        self.light_passes += passes;
    }

    /// Adds splatted camera samples: per pixel (row-major over the cell) the sums of weight ×
    /// radiance per channel and of the weights, fixed point ([`FRAC_BITS`]).
    pub fn add_filtered(&mut self, sums: &[[i128; 4]]) {
        if self.filtered.is_empty() {
            self.filtered = vec![[0; 4]; self.pixels.len()];
        }
        for (acc, v) in self.filtered.iter_mut().zip(sums) {
            for c in 0..4 {
                acc[c] += v[c];
            }
        }
    }

    /// Whether the film holds splatted camera samples (its pixels' values are their weighted
    /// means, [`Film::add_filtered`]).
    pub fn is_filtered(&self) -> bool {
        !self.filtered.is_empty()
    }

    /// The value of row-major pixel `p` of the cell from its camera samples: their weighted
    /// mean where samples are splatted (black without weight), else [`FilmPixel::mean`] of
    /// `px`, the pixel's record.
    fn camera_mean(&self, p: usize, px: &FilmPixel) -> Vec3 {
        let Some(s) = self.filtered.get(p) else {
            return px.mean();
        };
        if s[3] <= 0 {
            return Vec3::ZERO;
        }
        let w = s[3] as f64;
        Vec3::new(
            (s[0] as f64 / w) as f32,
            (s[1] as f64 / w) as f32,
            (s[2] as f64 / w) as f32,
        )
    }

    /// The light paths' estimate at row-major pixel `p` of the cell (0 without light passes);
    /// a pixel's value is its [`FilmPixel::mean`] plus this.
    pub fn light_mean(&self, p: usize) -> Vec3 {
        if self.light_passes == 0 || self.splat.is_empty() {
            return Vec3::ZERO;
        }
        let s = self.splat[p];
        let scale = 1.0 / ((1u64 << SPLAT_FRAC_BITS) as f64 * self.light_passes as f64);
        Vec3::new(
            (s[0] as f64 * scale) as f32,
            (s[1] as f64 * scale) as f32,
            (s[2] as f64 * scale) as f32,
        )
    }

    /// Samples per pixel, row-major over the cell.
    pub fn counts(&self) -> Vec<u32> {
        let mut out = vec![0u32; self.pixels.len()];
        for (p, px) in self.row_major() {
            out[p] = px.n;
        }
        out
    }

    /// A per-pixel figure, row-major over the cell.
    pub fn map<T: Default + Clone>(&self, f: impl Fn(&FilmPixel) -> T) -> Vec<T> {
        let mut out = vec![T::default(); self.pixels.len()];
        for (p, px) in self.row_major() {
            out[p] = f(px);
        }
        out
    }

    /// Total samples held.
    pub fn samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.n as u64).sum()
    }

    /// The image: each pixel's mean radiance (weighted mean where samples are splatted),
    /// row-major over the cell (black where a pixel holds no samples).
    pub fn develop(&self) -> Image {
        let mut img = Image::new(self.cell.w as usize, self.cell.h as usize);
        for (p, px) in self.row_major() {
            img.pixels[p] = self.camera_mean(p, px) + self.light_mean(p);
        }
        img
    }

    /// Adds the samples of `other`, a film of the same frame, cell and identity whose range
    /// is adjacent to this one's in every pixel (it starts where this one ends, or ends where
    /// it starts). The result holds the joined ranges; it equals, bit for bit, the film of
    /// the joined range rendered at once.
    pub fn merge(&mut self, other: &Film) -> Result<()> {
        if self.frame != other.frame || self.cell != other.cell {
            return Err(Error::Usage(format!(
                "cannot merge films of different frames or cells ({}x{} cell {:?} and {}x{} cell {:?})",
                self.frame.0, self.frame.1, self.cell, other.frame.0, other.frame.1, other.cell
            )));
        }
        if let Some(d) =
            self.identity_differences(&other.identity, ("in this film", "in the other"))
        {
            return Err(Error::Usage(format!(
                "cannot merge films of different renders: {d}"
            )));
        }
        // The joined range starts at the smaller first sample of the films that hold samples;
        // in every pixel the two ranges must join into one range starting there.
        let holds = |f: &Film| f.pixels.iter().any(|p| p.n > 0);
        let start = match (holds(self), holds(other)) {
            (true, true) => self.first.min(other.first),
            (false, true) => other.first,
            _ => self.first,
        };
        let (a, b, f) = (self.first as u64, other.first as u64, start as u64);
        let joins = self.pixels.iter().zip(&other.pixels).all(|(p, q)| {
            let (pn, qn) = (p.n as u64, q.n as u64);
            match (pn, qn) {
                (0, 0) => true,
                (0, _) => b == f,
                (_, 0) => a == f,
                _ => (a == f && a + pn == b) || (b == f && b + qn == a),
            }
        });
        if !joins {
            return Err(Error::Usage(
                "cannot merge films whose sample ranges are not adjacent in every pixel".into(),
            ));
        }
        // Light passes join like samples: this film's passes end where the other's begin.
        let lone = |f: &Film, g: &Film| f.light_passes > 0 && g.light_passes == 0;
        if (lone(self, other) && self.first != start) || (lone(other, self) && other.first != start)
        {
            return Err(Error::Usage(
                "cannot merge films whose light passes do not start the joined range".into(),
            ));
        }
        if self.light_passes > 0 && other.light_passes > 0 {
            let (a, b) = (self.first as u64, other.first as u64);
            let (na, nb) = (self.light_passes as u64, other.light_passes as u64);
            if (a + na != b && b + nb != a) || a.min(b) != start as u64 {
                return Err(Error::Usage(
                    "cannot merge films whose light passes are not adjacent".into(),
                ));
            }
        }
        if self.has_features() != other.has_features() {
            return Err(Error::Usage(
                "cannot merge a film that records denoising features with one that does not".into(),
            ));
        }
        self.first = start;
        if self
            .pixels
            .iter()
            .zip(&other.pixels)
            .any(|(p, q)| p.n.checked_add(q.n).is_none())
        {
            return Err(Error::Usage(
                "cannot merge films: a pixel would hold more than 2^32 samples".into(),
            ));
        }
        self.level = self.level.max(other.level);
        for (p, q) in self.pixels.iter_mut().zip(&other.pixels) {
            for c in 0..3 {
                p.sum[c] += q.sum[c];
                p.sum2[c] += q.sum2[c];
            }
            p.n += q.n;
            p.rays += q.rays;
            p.s1 += q.s1;
            p.s2 += q.s2;
            p.done |= q.done;
            p.target = p.target.saturating_add(q.target);
        }
        for (a, b) in self.features.iter_mut().zip(&other.features) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
        if other.light_passes > 0 {
            if self.splat.is_empty() {
                self.splat = vec![[0; 3]; self.pixels.len()];
            }
            for (a, b) in self.splat.iter_mut().zip(&other.splat) {
                for c in 0..3 {
                    a[c] += b[c];
                }
            }
            self.light_passes += other.light_passes;
        }
        if other.is_filtered() {
            self.add_filtered(&other.filtered);
        }
        Ok(())
    }

    /// The file form (see the module documentation).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut header = format!(
            "frame={}x{}\ncell={},{},{},{}\nfirst={}\nlevel={}\n",
            self.frame.0,
            self.frame.1,
            self.cell.x,
            self.cell.y,
            self.cell.w,
            self.cell.h,
            self.first,
            self.level
        );
        if self.light_passes > 0 {
            header.push_str(&format!("light={}\n", self.light_passes));
        }
        if self.is_filtered() {
            header.push_str("filtered=1\n");
        }
        if self.has_features() {
            header.push_str("features=1\n");
        }
        for (k, v) in &self.identity {
            header.push_str(&format!("id.{k}={v}\n"));
        }
        let mut out = Vec::with_capacity(16 + header.len() + self.pixels.len() * RECORD_BYTES);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(header.len() as u32).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        for p in &self.pixels {
            p.write(&mut out);
        }
        if self.light_passes > 0 {
            for s in &self.splat {
                for v in s {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        for s in &self.filtered {
            for v in s {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        for sums in &self.features {
            for v in sums {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        let digest = Sha256::digest(&out);
        out.extend_from_slice(&digest);
        out
    }

    /// Reads the file form; `file` names it in errors. A truncated, corrupt or foreign file
    /// is an error, never a film.
    pub fn from_bytes(bytes: &[u8], file: &str) -> Result<Film> {
        let bad = |msg: String| file_error(file, msg);
        let (header, data) = verified_header(bytes, file)?;
        let header = FileHeader::parse(header, file)?;
        let cell = header.cell;
        // The size is checked before anything is allocated for the pixels.
        let expected = (cell.w as u64 * cell.h as u64).saturating_mul(header.record_bytes());
        if data.len() as u64 != expected {
            return Err(bad(format!(
                "{} bytes of pixel data, expected {expected} for {}x{} pixels",
                data.len(),
                cell.w,
                cell.h
            )));
        }
        let mut film = Film::new(header.frame.0, header.frame.1, Some(cell), header.first)
            .map_err(|e| bad(format!("bad geometry: {e}")))?;
        film.level = header.level;
        film.identity = header.identity;
        let (records, rest) = data.split_at(film.pixels.len() * RECORD_BYTES);
        let (splats, rest) = rest.split_at(if header.light > 0 {
            film.pixels.len() * 48
        } else {
            0
        });
        let (weighted, feature_sums) = rest.split_at(if header.filtered {
            film.pixels.len() * 64
        } else {
            0
        });
        for (p, rec) in film
            .pixels
            .iter_mut()
            .zip(records.chunks_exact(RECORD_BYTES))
        {
            *p = FilmPixel::read(rec).ok_or_else(|| bad("a pixel record is invalid".into()))?;
        }
        if header.light > 0 {
            film.light_passes = header.light;
            film.splat = splats.chunks_exact(48).map(i128s).collect();
        }
        if header.filtered {
            film.filtered = weighted.chunks_exact(64).map(i128s).collect();
        }
        if header.features {
            film.features = read_feature_sums(&film.pixels, feature_sums, file)?;
        }
        Ok(film)
    }

    /// Writes the file form to `path`, crash-safe (see [`crate::io::atomic`]).
    pub fn save(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes();
        crate::io::atomic::write(path, "cannot write checkpoint", |w| {
            std::io::Write::write_all(w, &bytes)
        })
    }

    /// Reads a film written by [`Film::save`].
    pub fn load(path: &Path) -> Result<Film> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.display().to_string(),
            what: "cannot read checkpoint",
            source,
        })?;
        Film::from_bytes(&bytes, &path.display().to_string())
    }
}

/// The error for a film file `file` that cannot be read, saying why.
fn file_error(file: &str, msg: String) -> Error {
    Error::File {
        file: file.to_string(),
        msg,
    }
}

/// Checks a film file's magic, checksum and version; its header text and the pixel data
/// that follows it (without the checksum).
fn verified_header<'a>(bytes: &'a [u8], file: &str) -> Result<(&'a str, &'a [u8])> {
    let bad = |msg: String| file_error(file, msg);
    if bytes.len() < 16 + 32 || &bytes[..8] != MAGIC {
        return Err(bad("not a pathtracer film or checkpoint file".into()));
    }
    let (body, digest) = bytes.split_at(bytes.len() - 32);
    if Sha256::digest(body).as_slice() != digest {
        return Err(bad(
            "checksum mismatch: the file is truncated or corrupt".into()
        ));
    }
    let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
    if version != VERSION {
        return Err(bad(format!(
            "film format version {version}, this program reads version {VERSION}"
        )));
    }
    let hlen = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
    let header = body
        .get(16..16usize.saturating_add(hlen))
        .ok_or_else(|| bad("header runs past the end of the file".into()))?;
    let header = std::str::from_utf8(header).map_err(|_| bad("header is not UTF-8".into()))?;
    Ok((header, &body[16 + hlen..]))
}

/// The fields of a film file's header.
struct FileHeader {
    /// The frame's width and height.
    frame: (u32, u32),
    cell: Cell,
    first: u32,
    level: u32,
    /// Light passes held; 0 where the file holds no splats.
    light: u32,
    /// Whether the file holds filtered (splatted) camera samples.
    filtered: bool,
    /// Whether the file holds feature sums.
    features: bool,
    identity: Vec<(String, String)>,
}

impl FileHeader {
    /// Parses the `key=value` lines of a header; `file` names it in errors.
    fn parse(header: &str, file: &str) -> Result<FileHeader> {
        let bad = |msg: String| file_error(file, msg);
        let (mut frame, mut cell, mut first, mut level) = (None, None, None, None);
        let mut light = 0u32;
        let mut filtered = false;
        let mut features = false;
        let mut identity = Vec::new();
        for line in header.lines() {
            let (k, v) = line
                .split_once('=')
                .ok_or_else(|| bad(format!("bad header line '{line}'")))?;
            let nums = |sep: char, n: usize| -> Option<Vec<u32>> {
                let v: Vec<u32> = v
                    .split(sep)
                    .map(|s| s.parse().ok())
                    .collect::<Option<_>>()?;
                (v.len() == n).then_some(v)
            };
            match k {
                "frame" => frame = nums('x', 2).map(|f| (f[0], f[1])),
                "cell" => {
                    cell = nums(',', 4).map(|c| Cell {
                        x: c[0],
                        y: c[1],
                        w: c[2],
                        h: c[3],
                    })
                }
                "first" => first = v.parse::<u32>().ok(),
                "level" => level = v.parse::<u32>().ok(),
                "light" => {
                    light = v
                        .parse::<u32>()
                        .ok()
                        .filter(|&n| n > 0)
                        .ok_or_else(|| bad(format!("bad light pass count '{v}'")))?
                }
                "filtered" if v == "1" => filtered = true,
                "features" if v == "1" => features = true,
                _ => match k.strip_prefix("id.") {
                    Some(key) => identity.push((key.to_string(), v.to_string())),
                    None => return Err(bad(format!("unknown header key '{k}'"))),
                },
            }
        }
        let (Some(frame), Some(cell), Some(first), Some(level)) = (frame, cell, first, level)
        else {
            return Err(bad(
                "header lacks (or has an unreadable) frame, cell, first sample or level".into(),
            ));
        };
        Ok(FileHeader {
            frame,
            cell,
            first,
            level,
            light,
            filtered,
            features,
            identity,
        })
    }

    /// The bytes each pixel takes in the file: its record, then its splats, filtered
    /// samples and feature sums where the file holds them.
    fn record_bytes(&self) -> u64 {
        RECORD_BYTES as u64
            + if self.light > 0 { 48 } else { 0 }
            + if self.filtered { 64 } else { 0 }
            + if self.features { 48 } else { 0 }
    }
}

/// The feature sums of `pixels` from their 48-byte records in `bytes`; sums no render can
/// produce are an error (`file` names the file).
fn read_feature_sums(pixels: &[FilmPixel], bytes: &[u8], file: &str) -> Result<Vec<FeatureSums>> {
    // Sums a render can produce: each within ±n on the feature grid.
    let plausible = |p: &FilmPixel, sums: &FeatureSums| {
        let bound = (p.n as i128) << FEATURE_FRAC_BITS;
        sums.iter().all(|&s| (s as i128).abs() <= bound)
    };
    let mut features = Vec::with_capacity(pixels.len());
    for (p, rec) in pixels.iter().zip(bytes.chunks_exact(48)) {
        let sums: FeatureSums = std::array::from_fn(|i| {
            i64::from_le_bytes(rec[8 * i..8 * i + 8].try_into().unwrap_or([0; 8]))
        });
        if !plausible(p, &sums) {
            return Err(file_error(
                file,
                "a pixel's feature sums are invalid".into(),
            ));
        }
        features.push(sums);
    }
    Ok(features)
}

/// `N` little-endian `i128`s from the first `16·N` bytes of `b` (which holds them).
fn i128s<const N: usize>(b: &[u8]) -> [i128; N] {
    std::array::from_fn(|c| {
        i128::from_le_bytes(b[16 * c..16 * c + 16].try_into().unwrap_or([0; 16]))
    })
}

/// The tiles of a `w × h` cell, row-major.
fn tiles_of(w: u32, h: u32) -> Vec<Tile> {
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let mut out = Vec::with_capacity((tx * ty) as usize);
    let mut start = 0usize;
    for j in 0..ty {
        for i in 0..tx {
            let (x0, y0) = (i * TILE, j * TILE);
            let (tw, th) = ((x0 + TILE).min(w) - x0, (y0 + TILE).min(h) - y0);
            out.push(Tile {
                x0,
                y0,
                w: tw,
                h: th,
                start,
            });
            start += (tw * th) as usize;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(i: u32) -> Vec3 {
        // Values over many magnitudes, so that float sums would depend on the order.
        let x = (i as f32 * 0.618_034).fract();
        Vec3::new(x * 1e3, x * 1e-3 + 0.1, (1.0 - x) * 7.0)
    }

    fn filled(first: u32, count: u32) -> Film {
        let mut f = Film::new(37, 21, None, first).unwrap();
        for (i, p) in f.pixels_mut().iter_mut().enumerate() {
            for k in first..first + count {
                p.add(sample(k * 1000 + i as u32), 3);
            }
        }
        f
    }

    #[test]
    fn fixed_point_conversion_rounds_to_nearest_even() {
        let scale = (1u64 << FRAC_BITS) as f64;
        let mut x = 0x1234_5678_9abc_def0u64;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Magnitudes from 1e-15 to 1e18 (beyond the clamp), both signs, and exact halves of
            // the grid.
            let e = (x % 110) as i32 - 50;
            let m = (x >> 8) as f64 / (1u64 << 56) as f64;
            let mut v = m * 2f64.powi(e);
            if x & 1 == 1 {
                v = -v;
            }
            if x & 6 == 6 {
                v = ((x >> 20) % 1000) as f64 / scale + 0.5 / scale;
            }
            let want = (v.clamp(-MAX_SAMPLE, MAX_SAMPLE) * scale).round_ties_even() as i128;
            assert_eq!(fixed(v), want, "{v:e}");
            assert_eq!(fixed_large(v), want, "{v:e}");
        }
        assert_eq!(fixed(f64::NAN), 0);
        assert_eq!(fixed(f64::INFINITY), fixed(MAX_SAMPLE));
        assert_eq!(fixed(-0.0), 0);
    }

    #[test]
    fn merged_ranges_equal_the_whole_range() {
        let whole = filled(0, 10);
        let mut a = filled(0, 3);
        a.merge(&filled(3, 4)).unwrap();
        a.merge(&filled(7, 3)).unwrap();
        assert_eq!(a, whole);
        // Either order.
        let mut b = filled(7, 3);
        b.merge(&filled(0, 7)).unwrap();
        assert_eq!(b, whole);
        // Not adjacent.
        let mut c = filled(0, 3);
        assert!(c.merge(&filled(4, 3)).is_err());
    }

    #[test]
    fn file_form_round_trips_and_rejects_damage() {
        let mut f = filled(5, 4);
        f.level = 3;
        f.set_identity(vec![
            ("spp".into(), "16".into()),
            ("scene".into(), "ab".into()),
        ]);
        let bytes = f.to_bytes();
        assert_eq!(Film::from_bytes(&bytes, "x").unwrap(), f);
        for cut in [0, 10, 40, bytes.len() / 2, bytes.len() - 1] {
            let e = Film::from_bytes(&bytes[..cut], "ck.film")
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("ck.film: "), "{e}");
        }
        let mut flipped = bytes.clone();
        flipped[bytes.len() / 2] ^= 4;
        let e = Film::from_bytes(&flipped, "ck.film")
            .unwrap_err()
            .to_string();
        assert!(e.contains("truncated or corrupt"), "{e}");
    }

    #[test]
    fn identity_differences_are_named() {
        let mut f = Film::new(4, 4, None, 0).unwrap();
        f.set_identity(vec![
            ("spp".into(), "16".into()),
            ("seed".into(), "0".into()),
        ]);
        let d = f
            .identity_mismatch(&[("spp".into(), "32".into()), ("seed".into(), "0".into())])
            .unwrap();
        assert_eq!(d, "spp is 16 in the checkpoint but 32 here");
        assert!(f.identity_mismatch(f.identity()).is_none());
    }

    #[test]
    fn storage_order_maps_to_row_major() {
        let f = Film::new(40, 20, None, 0).unwrap();
        let mut seen = vec![false; 800];
        for i in 0..800 {
            let p = f.pixel_index(i);
            assert!(!seen[p]);
            seen[p] = true;
        }
        assert_eq!(f.pixel_index(16), 40);
        assert_eq!(f.pixel_index(256), 16);
    }
}
