//! Per-sample random numbers for the integrator: independent, padded Owen-scrambled Sobol and
//! Z-ordered Sobol (blue-noise error across pixels).
//!
//! # Conventions
//! - A camera sample is identified by the render's seed, its pixel `(x, y)` in the full frame
//!   and its index `k` within the pixel. Every number it draws is a pure function of those and
//!   of a *dimension slot* ([`dim`]): no state is carried from one draw to the next, so a
//!   sample's value never depends on which other samples were taken before it, in which pass,
//!   cell, thread or sample range.
//! - Dimension slots are fixed per bounce (pixel, lens, then per bounce light choice, light
//!   position, BSDF lobe, BSDF direction, roulette), so a bounce's BSDF
//!   direction always comes from the same slot whether or not light sampling ran before it.
//! - Sobol samplers are *padded* (Burley 2020): every slot takes Sobol dimensions 0 and 1 of
//!   its own Owen-scrambled and index-shuffled copy of the sequence, so each 1D slot and each
//!   2D slot is a (0, 2)-sequence: any aligned run of `2^m` samples of a pixel puts one point in
//!   every elementary interval of area `2^-m`. The shuffle is a nested uniform scramble of the
//!   index, which maps the first `2^m` indices onto an aligned run, so with [`SamplerKind::Sobol`]
//!   every power-of-two prefix of a pixel's samples is stratified. [`SamplerKind::ZSobol`]
//!   permutes whole base-4 digits of the Morton index (pbrt-v4's scheme): a pixel's first `4^j`
//!   samples are stratified (`2·4^j` when `max_spp` rounds up to an odd power of two), and so are
//!   all of its samples.
//! - `n` sub-samples of one camera sample (the `-l n` light samples of a vertex) take indices
//!   `k·n + i` of the slot's sequence: together they are stratified as well.
//! - Numbers are in `[0, 1)`, with 24 bits of precision.

use super::mix64;
use glam::Vec2;

/// Which point set camera samples draw from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Independent uniform numbers (a hash of seed, pixel, sample and slot).
    Independent,
    /// Padded Owen-scrambled Sobol points, randomised per pixel (stratified within each pixel,
    /// white noise across pixels). The default: as low an error as ZSobol at a lower cost.
    #[default]
    Sobol,
    /// Owen-scrambled Sobol points ordered along a Morton curve over the frame with randomly
    /// permuted base-4 digits (Ahmed & Wonka 2020, as pbrt-v4's `ZSobolSampler`): stratified
    /// within each pixel, and the error is spread as blue noise across pixels.
    ZSobol,
}

impl SamplerKind {
    /// Every kind.
    pub const ALL: [SamplerKind; 3] = [
        SamplerKind::Independent,
        SamplerKind::Sobol,
        SamplerKind::ZSobol,
    ];

    /// Lower-case name as the command line spells it.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Sobol => "sobol",
            SamplerKind::ZSobol => "zsobol",
        }
    }
}

/// Dimension slots of a path. A slot names a 1D or 2D set of numbers; slots never collide.
pub mod dim {
    /// Position inside the pixel (2D).
    pub const PIXEL: u32 = 0;
    /// Position on the lens (2D).
    pub const LENS: u32 = 1;
    /// The hero channel of a path through media (1D), vertex 0 only.
    pub const HERO: u32 = 0;
    /// Choice of a light (1D), per vertex; a light path's light at its vertex 0.
    pub const LIGHT_CHOICE: u32 = 1;
    /// Point on the light (an area light's triangle choice included), or direction for `-H`
    /// (2D), per vertex.
    pub const LIGHT_POINT: u32 = 2;
    /// Choice of a BSDF lobe (1D), per vertex; a two-sided emitter's side at a light path's
    /// vertex 0.
    pub const BSDF_LOBE: u32 = 3;
    /// BSDF or phase direction (2D), per vertex; the emitted direction at a light path's
    /// vertex 0.
    pub const BSDF_DIRECTION: u32 = 4;
    /// Russian roulette (1D), per vertex.
    pub const ROULETTE: u32 = 5;
    /// First collision distance of the free flight that leaves the vertex (1D), per vertex.
    pub const DISTANCE: u32 = 6;
    /// Seed of the generator of a path's further flights (1D), vertex 0 only.
    pub const SEED: u32 = 7;
    /// Slots per vertex.
    pub const PER_VERTEX: u32 = 8;
    /// First slot of light paths (far above any camera path's).
    pub const LIGHT_PATH_BASE: u32 = 0xC000_0000;

    /// Slot `slot` of camera-path vertex `depth`: 0 for the camera, then the hit index (the
    /// bounce) from 1. Every camera tracer, on one lane or eight, draws from these.
    #[inline]
    pub fn bounce(depth: u32, slot: u32) -> u32 {
        2u32.saturating_add(depth.saturating_mul(PER_VERTEX))
            .saturating_add(slot)
    }

    /// Slot `slot` of light-path vertex `vertex`: 0 for the point it leaves the light from,
    /// then its scattering vertices from 1.
    #[inline]
    pub fn light_vertex(vertex: u32, slot: u32) -> u32 {
        LIGHT_PATH_BASE
            .saturating_add(vertex.saturating_mul(PER_VERTEX))
            .saturating_add(slot)
    }
}

/// Burley's improved Laine–Karras permutation: bit `i` of the result depends only on bits
/// `0..=i` of `x` (and on `seed`), so applied to bit-reversed numbers it is a nested
/// uniform (Owen) scramble.
#[inline]
fn lk_permute(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Owen scramble (nested uniform scramble) of a 32-bit fixed-point number in `[0, 1)`.
#[inline]
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    lk_permute(x.reverse_bits(), seed).reverse_bits()
}

/// Sobol dimension 0 (van der Corput) of `index`, as a 32-bit fraction.
#[inline]
pub fn sobol0(index: u32) -> u32 {
    index.reverse_bits()
}

/// Sobol dimension 1 of `index` (generator matrix: Pascal's triangle mod 2), as a 32-bit
/// fraction.
#[inline]
pub fn sobol1(index: u32) -> u32 {
    pascal(index).reverse_bits()
}

/// Sobol dimension 1 with its bits reversed: bit `i` is the XOR of the bits `j` of `index`
/// with `binomial(j, i)` odd, i.e. (Lucas) with `i` a bit-subset of `j`; computed as a
/// superset-sum transform over the five bits of the position, five shift-xor steps.
#[inline]
fn pascal(mut y: u32) -> u32 {
    y ^= (y >> 1) & 0x5555_5555;
    y ^= (y >> 2) & 0x3333_3333;
    y ^= (y >> 4) & 0x0F0F_0F0F;
    y ^= (y >> 8) & 0x00FF_00FF;
    y ^= (y >> 16) & 0x0000_FFFF;
    y
}

/// Dimension 0 of Sobol point `idx` (its sequence index, shuffled), Owen-scrambled by `seed`,
/// in `[0, 1)`: `owen_scramble(sobol0(idx), seed)` without reversing twice.
#[inline(always)]
fn scrambled_sobol0(idx: u32, seed: u32) -> f32 {
    to_unit(lk_permute(idx, seed).reverse_bits())
}

/// Dimension 1 of Sobol point `idx`, Owen-scrambled by `seed`, in `[0, 1)`:
/// `owen_scramble(sobol1(idx), seed)` without reversing twice.
#[inline(always)]
fn scrambled_sobol1(idx: u32, seed: u32) -> f32 {
    to_unit(lk_permute(pascal(idx), seed).reverse_bits())
}

/// ZSobol: one of the 24 digit permutations for a key (two multiply-xorshift rounds).
#[inline]
fn digit_hash(k: u64) -> usize {
    let mut h = k.wrapping_mul(0xD6E8_FEB8_6659_FD93);
    h ^= h >> 32;
    h = h.wrapping_mul(0xD6E8_FEB8_6659_FD93);
    (((h >> 32) * 24) >> 32) as usize
}

/// 32-bit fraction to `[0, 1)` (24 bits, exact in f32).
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Interleaves the bits of `x` and `y` (x in the even bits).
#[inline]
fn morton2(x: u32, y: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = v as u64;
        v = (v | (v << 16)) & 0x0000_FFFF_0000_FFFF;
        v = (v | (v << 8)) & 0x00FF_00FF_00FF_00FF;
        v = (v | (v << 4)) & 0x0F0F_0F0F_0F0F_0F0F;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        v = (v | (v << 1)) & 0x5555_5555_5555_5555;
        v
    }
    spread(x) | (spread(y) << 1)
}

/// The 24 permutations of four base-4 digits.
const PERMUTATIONS: [[u8; 4]; 24] = [
    [0, 1, 2, 3],
    [0, 1, 3, 2],
    [0, 2, 1, 3],
    [0, 2, 3, 1],
    [0, 3, 2, 1],
    [0, 3, 1, 2],
    [1, 0, 2, 3],
    [1, 0, 3, 2],
    [1, 2, 0, 3],
    [1, 2, 3, 0],
    [1, 3, 2, 0],
    [1, 3, 0, 2],
    [2, 1, 0, 3],
    [2, 1, 3, 0],
    [2, 0, 1, 3],
    [2, 0, 3, 1],
    [2, 3, 0, 1],
    [2, 3, 1, 0],
    [3, 1, 2, 0],
    [3, 1, 0, 2],
    [3, 2, 1, 0],
    [3, 2, 0, 1],
    [3, 0, 2, 1],
    [3, 0, 1, 2],
];

/// The numbers of one camera sample. Cheap to create; holds no sequence state.
#[derive(Clone, Copy, Debug)]
pub struct Sampler {
    kind: SamplerKind,
    /// Key of the render (seed) for ZSobol, of the pixel for the other kinds.
    key: u64,
    /// Independent: key of this sample. Sobol: sample index in the pixel. ZSobol: Morton
    /// index of (pixel, sample).
    index: u64,
    /// ZSobol: base-4 digits of the Morton index that belong to the sample index, rounded up
    /// (`log2_spp`), and the total number of digits.
    log2_spp: u32,
    digits: u32,
    /// Sobol: the sample index's bits reversed (the index shuffle's input, computed once).
    rev_index: u32,
}

/// What every sample of one render shares: the point set, the seed and (ZSobol) the frame's
/// Morton layout.
#[derive(Clone, Copy, Debug)]
pub struct SamplerSetup {
    kind: SamplerKind,
    seed: u64,
    /// ZSobol: bits of the sample index within the Morton index (`log2` of `max_spp` rounded
    /// up to a power of two) and base-4 digits of the whole Morton index.
    log2_spp: u32,
    digits: u32,
}

impl SamplerSetup {
    /// The samplers of a `width × height` frame rendered with `seed`, whose pixels take at most
    /// `max_spp` samples (ZSobol orders each pixel's samples within the next power of two).
    pub fn new(kind: SamplerKind, seed: u64, width: u32, height: u32, max_spp: u32) -> Self {
        let log2_spp = max_spp.max(1).next_power_of_two().trailing_zeros();
        let log2_res = width
            .max(height)
            .max(1)
            .next_power_of_two()
            .trailing_zeros();
        SamplerSetup {
            kind,
            seed,
            log2_spp,
            digits: log2_res + log2_spp.div_ceil(2),
        }
    }

    /// The kind of points drawn.
    pub fn kind(&self) -> SamplerKind {
        self.kind
    }

    /// Sample `k` of frame pixel `(x, y)`.
    #[inline]
    pub fn sample(&self, x: u32, y: u32, k: u32) -> Sampler {
        let pixel = ((y as u64) << 32) | x as u64;
        let pixel_key = mix64(mix64(self.seed ^ 0x9E37_79B9_7F4A_7C15) ^ mix64(pixel));
        let (key, index) = match self.kind {
            SamplerKind::Independent => (
                pixel_key,
                mix64(pixel_key ^ mix64(k as u64 ^ 0xD1B5_4A32_D192_ED03)),
            ),
            SamplerKind::Sobol => (pixel_key, k as u64),
            SamplerKind::ZSobol => {
                // Samples beyond max_spp (none in a render) get their own randomisation
                // instead of aliasing the next pixel's indices.
                let (k_lo, k_hi) = (k as u64 & ((1 << self.log2_spp) - 1), k >> self.log2_spp);
                (
                    mix64(self.seed ^ 0x2545_F491_4F6C_DD1D ^ mix64(k_hi as u64)),
                    (morton2(x, y) << self.log2_spp) | k_lo,
                )
            }
        };
        Sampler {
            kind: self.kind,
            key,
            index,
            log2_spp: self.log2_spp,
            digits: self.digits,
            rev_index: (index as u32).reverse_bits(),
        }
    }
}

impl Sampler {
    /// The kind of points drawn.
    pub fn kind(&self) -> SamplerKind {
        self.kind
    }

    /// ZSobol: the index into the frame-wide Sobol sequence of this sample for slot `slot`
    /// (pbrt-v4's `ZSobolSampler::GetSampleIndex`): the Morton index's base-4 digits, each
    /// permuted by a hash of the digits above it and of the slot.
    #[inline]
    fn zsobol_index(&self, slot: u32) -> u64 {
        let m = self.index;
        let odd = self.log2_spp & 1;
        let salt = 0x5555_5555u64.wrapping_mul(slot as u64 + 1) ^ self.key;
        let mut out = 0u64;
        for i in (odd..self.digits).rev() {
            let shift = 2 * i - odd;
            let digit = ((m >> shift) & 3) as usize;
            let higher = m >> (shift + 2);
            let p = digit_hash(higher ^ salt);
            out |= (PERMUTATIONS[p][digit] as u64) << shift;
        }
        if odd == 1 {
            let bit = m & 1;
            out |= bit ^ (digit_hash((m >> 1) ^ salt) as u64 & 1);
        }
        out
    }

    /// Seeds of slot `slot`: index shuffle, first and second coordinate scrambles.
    #[inline(always)]
    fn seeds(&self, slot: u32) -> (u32, u32, u32) {
        let h = mix64(self.key ^ (slot as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let h2 = h.wrapping_mul(0xD6E8_FEB8_6659_FD93);
        (h as u32, (h >> 32) as u32, (h2 >> 32) as u32)
    }

    /// Sobol, one sub-sample: the sample index shuffled by `shuffle`
    /// (`owen_scramble(index, shuffle)` with the first reversal done once per sample).
    #[inline(always)]
    fn sobol_index(&self, shuffle: u32) -> u32 {
        lk_permute(self.rev_index, shuffle).reverse_bits()
    }

    /// Sequence index (before any shuffle) of sub-sample `i` of `n` for `slot`.
    #[inline(always)]
    fn seq_index(&self, slot: u32, i: u32, n: u32) -> u64 {
        let base = match self.kind {
            SamplerKind::ZSobol => self.zsobol_index(slot),
            _ => self.index,
        };
        base.wrapping_mul(n as u64).wrapping_add(i as u64)
    }

    /// The Sobol index of sub-sample `i` of `n` for `slot` and the slot's coordinate
    /// scrambles. Indices beyond 32 bits (huge frames) fold their high bits into the scrambles.
    #[inline(always)]
    fn sobol_point(&self, slot: u32, i: u32, n: u32) -> (u32, u32, u32) {
        let (shuffle, mut sx, mut sy) = self.seeds(slot);
        if self.kind == SamplerKind::Sobol && n == 1 {
            return (self.sobol_index(shuffle), sx, sy);
        }
        let idx = self.seq_index(slot, i, n);
        let hi = idx >> 32;
        if hi != 0 {
            let h = mix64(hi ^ ((sx as u64) << 32 | sy as u64));
            (sx, sy) = (h as u32, (h >> 32) as u32);
        }
        let idx = idx as u32;
        let idx = if self.kind == SamplerKind::Sobol {
            owen_scramble(idx, shuffle)
        } else {
            idx
        };
        (idx, sx, sy)
    }

    /// A number in `[0, 1)` for 1D slot `slot`.
    #[inline]
    pub fn get_1d(&self, slot: u32) -> f32 {
        self.get_1d_sub(slot, 0, 1)
    }

    /// A point in `[0, 1)²` for 2D slot `slot`.
    #[inline]
    pub fn get_2d(&self, slot: u32) -> Vec2 {
        self.get_2d_sub(slot, 0, 1)
    }

    /// Sub-sample `i` of `n` of 1D slot `slot`.
    #[inline(always)]
    pub fn get_1d_sub(&self, slot: u32, i: u32, n: u32) -> f32 {
        match self.kind {
            SamplerKind::Independent => to_unit(self.hash(slot, i) as u32),
            _ => {
                let (idx, sx, _) = self.sobol_point(slot, i, n);
                scrambled_sobol0(idx, sx)
            }
        }
    }

    /// Sub-sample `i` of `n` of 2D slot `slot`.
    #[inline(always)]
    pub fn get_2d_sub(&self, slot: u32, i: u32, n: u32) -> Vec2 {
        match self.kind {
            SamplerKind::Independent => {
                let h = self.hash(slot, i);
                Vec2::new(to_unit(h as u32), to_unit((h >> 32) as u32))
            }
            _ => {
                let (idx, sx, sy) = self.sobol_point(slot, i, n);
                Vec2::new(scrambled_sobol0(idx, sx), scrambled_sobol1(idx, sy))
            }
        }
    }

    /// Whether `lanes` are Sobol samples of one pixel (one key): their draws then share the
    /// slot's seeds and differ only in the index, and [`Sampler::get_2d_lanes`] computes them
    /// for all lanes at once.
    pub fn shared_sobol<const N: usize>(lanes: &[Sampler; N]) -> bool {
        lanes
            .iter()
            .all(|s| s.kind == SamplerKind::Sobol && s.key == lanes[0].key)
    }

    /// [`Sampler::get_2d`] of slot `slot` for every lane; `shared` is
    /// [`Sampler::shared_sobol`] of `lanes`. Bit-identical to the lanes' own draws.
    #[inline]
    pub fn get_2d_lanes<const N: usize>(
        lanes: &[Sampler; N],
        shared: bool,
        slot: u32,
    ) -> [Vec2; N] {
        let mut x = [0f32; N];
        let mut y = [0f32; N];
        // The two Sobol loops differ only in where the seeds come from: one slot's seeds
        // used by every lane here, rather than an array of per-lane copies (which measured 4%
        // slower at fixed spp).
        if shared {
            let (shuffle, sx, sy) = lanes[0].seeds(slot);
            for i in 0..N {
                let idx = lanes[i].sobol_index(shuffle);
                x[i] = scrambled_sobol0(idx, sx);
                y[i] = scrambled_sobol1(idx, sy);
            }
        } else if lanes.iter().all(|s| s.kind == SamplerKind::Sobol) {
            // Lanes of different pixels (their own scrambles): the same straight-line draw
            // per lane, which the compiler can vectorise.
            for i in 0..N {
                let (shuffle, sx, sy) = lanes[i].seeds(slot);
                let idx = lanes[i].sobol_index(shuffle);
                x[i] = scrambled_sobol0(idx, sx);
                y[i] = scrambled_sobol1(idx, sy);
            }
        } else {
            return std::array::from_fn(|i| lanes[i].get_2d(slot));
        }
        std::array::from_fn(|i| Vec2::new(x[i], y[i]))
    }

    /// [`Sampler::get_1d`] of slot `slot` for every lane, as [`Sampler::get_2d_lanes`].
    #[inline]
    pub fn get_1d_lanes<const N: usize>(lanes: &[Sampler; N], shared: bool, slot: u32) -> [f32; N] {
        if shared {
            let (shuffle, sx, _) = lanes[0].seeds(slot);
            return std::array::from_fn(|i| scrambled_sobol0(lanes[i].sobol_index(shuffle), sx));
        }
        if lanes.iter().all(|s| s.kind == SamplerKind::Sobol) {
            return std::array::from_fn(|i| {
                let (shuffle, sx, _) = lanes[i].seeds(slot);
                scrambled_sobol0(lanes[i].sobol_index(shuffle), sx)
            });
        }
        std::array::from_fn(|i| lanes[i].get_1d(slot))
    }

    /// Independent: 64 random bits of (sample, slot, sub-sample).
    #[inline]
    fn hash(&self, slot: u32, i: u32) -> u64 {
        mix64(self.index ^ ((slot as u64) << 32 | i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// True when the points put exactly one point in every elementary interval of
    /// `[0,1)²` of area `1/len` (all `2^a × 2^b` boxes with `a + b = log2 len`).
    fn is_02_net(pts: &[Vec2]) -> bool {
        let n = pts.len();
        let m = n.trailing_zeros();
        assert!(n.is_power_of_two());
        for a in 0..=m {
            let (nx, ny) = (1usize << a, 1usize << (m - a));
            let mut seen = vec![false; n];
            for p in pts {
                let (cx, cy) = ((p.x * nx as f32) as usize, (p.y * ny as f32) as usize);
                let c = cy * nx + cx;
                if seen[c] {
                    return false;
                }
                seen[c] = true;
            }
        }
        true
    }

    fn is_stratified_1d(xs: &[f32]) -> bool {
        let n = xs.len();
        let mut seen = vec![false; n];
        for &x in xs {
            let c = (x * n as f32) as usize;
            if seen[c] {
                return false;
            }
            seen[c] = true;
        }
        true
    }

    #[test]
    fn sobol_dimensions_match_known_points() {
        // The first Sobol points in dimensions 0 and 1.
        let want = [
            (0.0, 0.0),
            (0.5, 0.5),
            (0.25, 0.75),
            (0.75, 0.25),
            (0.125, 0.625),
            (0.625, 0.125),
            (0.375, 0.375),
            (0.875, 0.875),
        ];
        let f = |x: u32| x as f64 / 4_294_967_296.0;
        for (i, (a, b)) in want.into_iter().enumerate() {
            assert_eq!(
                (f(sobol0(i as u32)), f(sobol1(i as u32))),
                (a, b),
                "index {i}"
            );
        }
    }

    #[test]
    fn sobol1_matches_direction_numbers() {
        // Reference: XOR of direction numbers v_0 = 2^31, v_{k+1} = v_k ^ (v_k >> 1).
        let slow = |mut i: u32| {
            let (mut x, mut v) = (0u32, 1u32 << 31);
            while i != 0 {
                if i & 1 != 0 {
                    x ^= v;
                }
                i >>= 1;
                v ^= v >> 1;
            }
            x
        };
        let mut h = 1u64;
        for i in (0..4096u32).chain((0..10_000).map(|_| {
            h = mix64(h);
            h as u32
        })) {
            assert_eq!(sobol1(i), slow(i), "index {i}");
        }
    }

    #[test]
    fn owen_scramble_is_a_nested_permutation() {
        // Bijective on 8-bit prefixes, and the top bits of the result depend only on the top
        // bits of the input (the interval a point lies in maps to one interval).
        for seed in [0u32, 1, 0xdead_beef, 0x1234_5678] {
            let mut seen = [false; 256];
            for v in 0..256u32 {
                let s = owen_scramble(v << 24, seed) >> 24;
                assert!(!seen[s as usize]);
                seen[s as usize] = true;
                for low in [1u32, 0x00ff_ffff, 0x0012_3456] {
                    assert_eq!(owen_scramble((v << 24) | low, seed) >> 24, s);
                }
            }
        }
    }

    /// Every 1D and 2D slot of the first `2^m` samples of a pixel is stratified, for every
    /// Sobol kind, at several pixels, seeds, slots and sub-sample counts.
    #[test]
    fn prefixes_of_each_slot_are_stratified() {
        for kind in [SamplerKind::Sobol, SamplerKind::ZSobol] {
            for (x, y, seed) in [(0u32, 0u32, 0u64), (17, 5, 3), (479, 359, 99)] {
                for max_spp in [1u32, 7, 64, 256] {
                    // ZSobol orders a pixel's samples within the next power of two of max_spp
                    // by whole base-4 digits (above one single bit when that power is odd):
                    // its stratified prefixes are those that end on a digit boundary.
                    let log2 = max_spp.next_power_of_two().trailing_zeros();
                    let sizes: Vec<u32> = match kind {
                        SamplerKind::ZSobol => (0..=log2)
                            .filter(|m| (m - (log2 & 1)) % 2 == 0 || *m == 0)
                            .collect(),
                        _ => (0..=8).collect(),
                    };
                    for m in sizes {
                        let n = 1u32 << m;
                        for slot in [dim::PIXEL, dim::LENS, dim::bounce(1, 4), dim::bounce(37, 2)] {
                            let s2: Vec<Vec2> = (0..n)
                                .map(|k| {
                                    SamplerSetup::new(kind, seed, 480, 360, max_spp)
                                        .sample(x, y, k)
                                        .get_2d(slot)
                                })
                                .collect();
                            assert!(
                                is_02_net(&s2),
                                "{kind:?} 2D slot {slot}, 2^{m}, spp {max_spp}"
                            );
                            let s1: Vec<f32> = (0..n)
                                .map(|k| {
                                    SamplerSetup::new(kind, seed, 480, 360, max_spp)
                                        .sample(x, y, k)
                                        .get_1d(slot)
                                })
                                .collect();
                            assert!(is_stratified_1d(&s1), "{kind:?} 1D slot {slot}, 2^{m}");
                        }
                        // Four sub-samples per camera sample: 4·2^m points, stratified together.
                        let sub: Vec<Vec2> = (0..n)
                            .flat_map(|k| {
                                let s = SamplerSetup::new(kind, seed, 480, 360, max_spp)
                                    .sample(x, y, k);
                                (0..4).map(move |i| s.get_2d_sub(dim::bounce(2, 2), i, 4))
                            })
                            .collect();
                        assert!(is_02_net(&sub), "{kind:?} sub-samples, 2^{m}");
                    }
                }
            }
        }
    }

    #[test]
    fn independent_numbers_are_uniform_and_uncorrelated() {
        let n = 200_000u32;
        let (mut sum, mut prod, mut lo) = (0f64, 0f64, 0usize);
        for k in 0..n {
            let s = SamplerSetup::new(SamplerKind::Independent, 1, 8, 8, n).sample(3, 4, k);
            let p = s.get_2d(dim::PIXEL);
            let q = s.get_1d(dim::bounce(1, dim::ROULETTE));
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
            sum += p.x as f64;
            prod += (p.x as f64 - 0.5) * (q as f64 - 0.5);
            lo += usize::from(p.y < 0.25);
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.003);
        assert!((prod / n as f64).abs() < 0.002);
        assert!((lo as f64 / n as f64 - 0.25).abs() < 0.004);
        // Prefixes of independent numbers are not stratified (the test above can fail).
        let pts: Vec<Vec2> = (0..64)
            .map(|k| {
                SamplerSetup::new(SamplerKind::Independent, 0, 8, 8, 64)
                    .sample(0, 0, k)
                    .get_2d(dim::PIXEL)
            })
            .collect();
        assert!(!is_02_net(&pts));
    }

    #[test]
    fn pixels_slots_and_seeds_are_decorrelated() {
        // Different pixels, slots and seeds give different points for every kind.
        for kind in SamplerKind::ALL {
            let a = SamplerSetup::new(kind, 0, 32, 32, 16).sample(10, 10, 3);
            let b = SamplerSetup::new(kind, 0, 32, 32, 16).sample(11, 10, 3);
            let c = SamplerSetup::new(kind, 1, 32, 32, 16).sample(10, 10, 3);
            let p = a.get_2d(dim::bounce(1, 4));
            assert_ne!(p, b.get_2d(dim::bounce(1, 4)), "{kind:?} pixels");
            assert_ne!(p, c.get_2d(dim::bounce(1, 4)), "{kind:?} seeds");
            assert_ne!(p, a.get_2d(dim::bounce(2, 4)), "{kind:?} bounces");
            // Deterministic: the same sample gives the same numbers.
            assert_eq!(
                p,
                SamplerSetup::new(kind, 0, 32, 32, 16)
                    .sample(10, 10, 3)
                    .get_2d(dim::bounce(1, 4))
            );
        }
    }

    #[test]
    fn lane_draws_equal_each_lanes_own_draws() {
        for kind in SamplerKind::ALL {
            let setup = SamplerSetup::new(kind, 3, 64, 48, 64);
            // Eight samples of one pixel, and (as passes of one sample per pixel fill
            // packets) samples of eight pixels.
            let one_pixel = [(0, 0, 0), (5, 7, 8), (63, 47, 56), (20, 30, 3)]
                .map(|(x, y, k0)| std::array::from_fn(|i| (x, y, k0 + i as u32)));
            let pixels: [[(u32, u32, u32); 8]; 2] = [
                std::array::from_fn(|i| (i as u32 * 7, 40 - i as u32, 0)),
                std::array::from_fn(|i| (50 + i as u32, 3, i as u32 % 3)),
            ];
            for (set, same) in one_pixel
                .iter()
                .map(|s| (s, true))
                .chain(pixels.iter().map(|s| (s, false)))
            {
                let lanes: [Sampler; 8] = std::array::from_fn(|i| {
                    let (x, y, k) = set[i];
                    setup.sample(x, y, k)
                });
                let shared = Sampler::shared_sobol(&lanes);
                assert_eq!(shared, same && kind == SamplerKind::Sobol);
                for slot in [0, 2, 3, 7, 40, 501] {
                    let v2 = Sampler::get_2d_lanes(&lanes, shared, slot);
                    let v1 = Sampler::get_1d_lanes(&lanes, shared, slot);
                    for i in 0..8 {
                        assert_eq!(
                            v2[i].to_array().map(f32::to_bits),
                            lanes[i].get_2d(slot).to_array().map(f32::to_bits)
                        );
                        assert_eq!(v1[i].to_bits(), lanes[i].get_1d(slot).to_bits());
                    }
                }
            }
        }
    }

    #[test]
    fn zsobol_spreads_one_sample_per_pixel_over_a_block() {
        // With one sample per pixel, the pixel-jitter points of a 4×4 pixel block (aligned in
        // Morton order) are one 16-point Sobol run: stratified together (blue-noise spread).
        let pts: Vec<Vec2> = (0..16u32)
            .map(|i| {
                let (x, y) = (8 + i % 4, 4 + i / 4);
                SamplerSetup::new(SamplerKind::ZSobol, 5, 64, 48, 1)
                    .sample(x, y, 0)
                    .get_2d(dim::bounce(1, 4))
            })
            .collect();
        assert!(is_02_net(&pts));
    }
}
