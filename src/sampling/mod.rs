//! Random numbers, warps from the unit square to common domains, and discrete distributions.
//!
//! Every warp documents its pdf and its measure (solid angle for directions, area for points);
//! `chi2` holds the goodness-of-fit harness that tests them.

pub mod bilinear;
pub mod chi2;
pub mod sampler;

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// PCG32 random number generator (O'Neill 2014): 64-bit state, 32-bit output, selectable stream.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

const PCG_MULT: u64 = 6364136223846793005;

impl Rng {
    /// A generator on stream `stream` seeded with `seed`; distinct streams are independent.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Rng {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// A generator for one pixel of one render: the same `(seed, index)` always gives the same
    /// sequence, whatever thread draws it.
    pub fn for_pixel(seed: u64, index: u64) -> Self {
        Rng::new(
            mix64(seed ^ 0x9E37_79B9_7F4A_7C15),
            mix64(index.wrapping_add(seed.rotate_left(17))),
        )
    }

    /// The stream of sample `sample` of pixel `index` in a render with `seed`: every sample
    /// has its own stream, so a sample's value does not depend on how many samples were taken
    /// before it, in which pass or on which thread.
    pub fn for_sample(seed: u64, index: u64, sample: u64) -> Self {
        Rng::new(mix64(seed ^ mix64(index ^ 0x5851_F42D_4C95_7F2D)), sample)
    }

    /// Next uniform 32-bit integer.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform float in `[0, 1)`.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform floats in `[0, 1)²`.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

/// SplitMix64 finaliser: a bijective 64-bit hash.
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The bits of a vector's three components folded into one word (the input of [`mix64`] for
/// hashes of points and directions).
#[inline]
pub fn vec3_bits(v: Vec3) -> u64 {
    (v.x.to_bits() as u64) ^ ((v.y.to_bits() as u64) << 21) ^ ((v.z.to_bits() as u64) << 42)
}

/// A uniform number in [0, 1) from the top 24 bits of a hash.
#[inline]
pub fn hash_to_unit(h: u64) -> f32 {
    (h >> 40) as f32 / (1u64 << 24) as f32
}

/// Cosine-weighted direction on the +Z hemisphere (Malley's method); pdf `cos θ / π` (solid
/// angle). One lane of [`crate::lanes::cosine_hemisphere`].
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    crate::lanes::cosine_hemisphere(u.x, u.y).into()
}

/// Pdf of [`cosine_hemisphere`] for local direction `w` (solid angle).
#[inline]
pub fn cosine_hemisphere_pdf(w: Vec3) -> f32 {
    w.z.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the +Z hemisphere; pdf `1 / 2π` (solid angle).
#[inline]
pub fn uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Pdf of [`uniform_hemisphere`] (solid angle).
pub const UNIFORM_HEMISPHERE_PDF: f32 = 0.5 * FRAC_1_PI;

/// Uniform direction on the unit sphere; pdf `1 / 4π` (solid angle).
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Pdf of [`uniform_sphere`] (solid angle).
pub const UNIFORM_SPHERE_PDF: f32 = 0.25 * FRAC_1_PI;

/// Uniform point on the unit disk (Shirley–Chiu concentric map); pdf `1 / π` (area). One
/// lane of [`crate::lanes::concentric_disk`].
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let (x, y) = crate::lanes::concentric_disk(u.x, u.y);
    Vec2::new(x, y)
}

/// `(sin t, cos t)` for `|t| ≤ π/4` by Taylor polynomials: one lane of
/// [`crate::lanes::sin_cos_quarter`].
#[inline]
pub fn sin_cos_quarter(t: f32) -> (f32, f32) {
    crate::lanes::sin_cos_quarter(t)
}

/// Uniform barycentrics `(b1, b2)` on a triangle (Heitz 2019 low-distortion map); pdf `1 / area`.
#[inline]
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    if u.x < u.y {
        let b0 = u.x / 2.0;
        let b1 = u.y - b0;
        Vec2::new(b1, 1.0 - b0 - b1)
    } else {
        let b1 = u.y / 2.0;
        let b0 = u.x - b1;
        Vec2::new(b1, 1.0 - b0 - b1)
    }
}

/// A discrete distribution over `n` items by weight, sampled in constant time by Walker's
/// alias method (Vose's construction): item `j = ⌊u·n⌋` is kept with probability
/// `keep[j]`, else its alias is taken. The leftover fraction of `u` is returned as a fresh
/// uniform number (with `log2 n` fewer bits of precision).
#[derive(Clone, Debug, Default)]
pub struct AliasTable {
    /// Per slot: the probability of keeping it, and its alias.
    slots: Vec<(f32, u32)>,
}

impl AliasTable {
    /// Builds from non-negative weights; `None` when they are empty or sum to zero.
    pub fn new(weights: &[f64]) -> Option<AliasTable> {
        let n = weights.len();
        let clean = |w: f64| if w.is_finite() && w > 0.0 { w } else { 0.0 };
        let total: f64 = weights.iter().map(|&w| clean(w)).sum();
        if n == 0 || total <= 0.0 || n > u32::MAX as usize {
            return None;
        }
        let mut scaled: Vec<f64> = weights
            .iter()
            .map(|&w| clean(w) * n as f64 / total)
            .collect();
        let mut slots: Vec<(f32, u32)> = (0..n as u32).map(|j| (1.0, j)).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&j| scaled[j] < 1.0);
        while let (Some(&j), Some(&k)) = (small.last(), large.last()) {
            small.pop();
            slots[j] = (scaled[j] as f32, k as u32);
            scaled[k] -= 1.0 - scaled[j];
            if scaled[k] < 1.0 {
                large.pop();
                small.push(k);
            }
        }
        // What rounding leaves in either list keeps its own slot.
        for j in small.into_iter().chain(large) {
            slots[j] = (1.0, j as u32);
        }
        Some(AliasTable { slots })
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// True when there are no items.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The slot `u ∈ [0, 1)` falls in, and where in it (in `[0, 1]`).
    #[inline]
    fn slot(&self, u: f32) -> (usize, f32) {
        let n = self.slots.len();
        let x = u * n as f32;
        let j = (x as usize).min(n - 1);
        (j, (x - j as f32).clamp(0.0, 1.0))
    }

    /// Asks for the slot [`AliasTable::sample`] reads for `u` to be brought into cache (a
    /// hint only), so that a sample drawn later does not wait for memory.
    #[inline]
    pub fn prefetch(&self, u: f32) {
        if !self.slots.is_empty() {
            let slot = &self.slots[self.slot(u).0];
            crate::memory::prefetch_bytes(
                (slot as *const (f32, u32)).cast(),
                std::mem::size_of::<(f32, u32)>(),
            );
        }
    }

    /// The item for `u ∈ [0, 1)`, and what is left of `u` as a number in `[0, 1)`.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let (j, f) = self.slot(u);
        let (keep, alias) = self.slots[j];
        // (A slot kept for sure stays itself even if rounding made `f` reach 1.)
        if f < keep || keep >= 1.0 {
            (j, (f / keep).min(1.0 - f32::EPSILON / 2.0))
        } else {
            let rest = ((f - keep) / (1.0 - keep)).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
            (alias as usize, rest)
        }
    }
}

/// A discrete distribution over `n` items by weight, sampled by inverting its CDF.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    cdf: Vec<f32>,
    total: f32,
}

impl Distribution1D {
    /// Builds from non-negative weights. All-zero or empty weights give a distribution whose
    /// `total()` is 0 and that must not be sampled.
    pub fn new(weights: &[f32]) -> Self {
        let mut cdf = Vec::with_capacity(weights.len());
        let mut acc = 0.0f64;
        for &w in weights {
            acc += if w.is_finite() && w > 0.0 {
                w as f64
            } else {
                0.0
            };
            cdf.push(acc as f32);
        }
        let total = acc as f32;
        if total > 0.0 {
            for c in &mut cdf {
                *c /= total;
            }
        }
        Distribution1D { cdf, total }
    }

    /// Sum of the weights.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// True when there are no items.
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Probability of item `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        self.cdf[i] - lo
    }

    /// Picks an item for `u ∈ [0,1)`; returns `(index, pmf, u remapped to [0,1) within the item)`.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let n = self.cdf.len();
        // The number of entries at most `u` (the CDF is non-decreasing): counted without
        // branches for short tables (an area light's few triangles, where the choice is a coin
        // flip a branch would mispredict), by bisection otherwise.
        let i = if n <= 8 {
            self.cdf.iter().map(|&c| usize::from(c <= u)).sum::<usize>()
        } else {
            self.cdf.partition_point(|&c| c <= u)
        }
        .min(n - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let p = self.cdf[i] - lo;
        let ur = if p > 0.0 {
            ((u - lo) / p).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        (i, p, ur)
    }
}

#[cfg(test)]
mod tests {
    use super::chi2::{chi2_test_sphere, Chi2Config};
    use super::*;

    #[test]
    fn sin_cos_quarter_matches_the_library() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let t = (i as f32 / 100_000.0 * 2.0 - 1.0) * (PI / 4.0);
            let (s, c) = sin_cos_quarter(t);
            let (ls, lc) = (t as f64).sin_cos();
            worst = worst.max((s as f64 - ls).abs()).max((c as f64 - lc).abs());
        }
        assert!(worst < 2e-7, "largest error {worst}");
    }

    #[test]
    fn concentric_disk_stays_in_the_disk_and_keeps_quadrants() {
        let mut rng = Rng::new(3, 4);
        for _ in 0..100_000 {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let d = concentric_disk(u);
            assert!(d.length() <= 1.0 + 1e-6, "{u} -> {d}");
            let a = 2.0 * u - Vec2::ONE;
            // The map keeps each point in the sector of its square's triangle.
            assert!(d.x * a.x >= -1e-6 || d.y * a.y >= -1e-6, "{u} -> {d}");
            assert!(
                (d.length() - a.x.abs().max(a.y.abs())).abs() < 1e-5,
                "{u} -> {d}"
            );
        }
    }

    #[test]
    fn rng_is_uniform_and_deterministic() {
        let mut a = Rng::for_pixel(7, 123);
        let mut b = Rng::for_pixel(7, 123);
        let mut c = Rng::for_pixel(7, 124);
        let mut sum = 0.0f64;
        let mut same = 0;
        for _ in 0..100_000 {
            let x = a.next_f32();
            assert_eq!(x, b.next_f32());
            assert!((0.0..1.0).contains(&x));
            if x == c.next_f32() {
                same += 1;
            }
            sum += x as f64;
        }
        assert!((sum / 100_000.0 - 0.5).abs() < 0.005);
        assert!(same < 50, "neighbouring pixel streams must differ");
    }

    fn cfg() -> Chi2Config {
        Chi2Config {
            samples: 400_000,
            theta_bins: 10,
            phi_bins: 20,
            ..Default::default()
        }
    }

    #[test]
    fn cosine_hemisphere_matches_pdf() {
        chi2_test_sphere(
            &cfg(),
            |u| Some(cosine_hemisphere(u)),
            cosine_hemisphere_pdf,
        )
        .unwrap();
    }

    #[test]
    fn uniform_hemisphere_matches_pdf() {
        chi2_test_sphere(
            &cfg(),
            |u| Some(uniform_hemisphere(u)),
            |w| {
                if w.z > 0.0 {
                    UNIFORM_HEMISPHERE_PDF
                } else {
                    0.0
                }
            },
        )
        .unwrap();
    }

    #[test]
    fn uniform_sphere_matches_pdf() {
        chi2_test_sphere(&cfg(), |u| Some(uniform_sphere(u)), |_| UNIFORM_SPHERE_PDF).unwrap();
    }

    #[test]
    fn wrong_pdf_fails_chi2() {
        // The harness must be able to fail: cosine samples tested against the uniform pdf.
        assert!(chi2_test_sphere(
            &cfg(),
            |u| Some(cosine_hemisphere(u)),
            |w| if w.z > 0.0 {
                UNIFORM_HEMISPHERE_PDF
            } else {
                0.0
            }
        )
        .is_err());
    }

    #[test]
    fn disk_and_triangle_are_uniform() {
        let mut rng = Rng::new(1, 2);
        let n = 200_000;
        let mut quad = [0usize; 4];
        let mut tri = [0usize; 4];
        for _ in 0..n {
            let d = concentric_disk(rng.next_2d());
            assert!(d.length() <= 1.0 + 1e-6);
            quad[(d.x > 0.0) as usize + 2 * (d.y > 0.0) as usize] += 1;
            // Triangle split into 4 congruent sub-triangles by its edge midpoints.
            let b = uniform_triangle(rng.next_2d());
            let b0 = 1.0 - b.x - b.y;
            assert!(b.x >= 0.0 && b.y >= 0.0 && b0 >= -1e-6);
            let k = if b0 > 0.5 {
                0
            } else if b.x > 0.5 {
                1
            } else if b.y > 0.5 {
                2
            } else {
                3
            };
            tri[k] += 1;
        }
        for c in quad.iter().chain(tri.iter()) {
            let f = *c as f64 / n as f64;
            assert!((f - 0.25).abs() < 0.006, "{quad:?} {tri:?}");
        }
    }

    /// The alias table picks items by weight and leaves a uniform number independent of the
    /// pick: a chi-square test (1%) over (item, tenth of the leftover number) against
    /// `weight / total · 1/10`, on skewed weights with zeros.
    #[test]
    fn alias_table_samples_by_weight_with_a_uniform_leftover() {
        let weights: Vec<f64> = (0..37)
            .map(|i| match i % 7 {
                0 => 0.0,
                3 => 50.0,
                _ => (i as f64 * 0.37).sin().abs() + 0.01,
            })
            .collect();
        let table = AliasTable::new(&weights).expect("positive weights");
        assert_eq!(table.len(), weights.len());
        let total: f64 = weights.iter().sum();
        let n = 2_000_000;
        let mut observed = vec![0f64; weights.len() * 10];
        let mut rng = Rng::new(21, 22);
        for _ in 0..n {
            let (i, rest) = table.sample(rng.next_f32());
            assert!((0.0..1.0).contains(&rest), "leftover {rest}");
            assert!(weights[i] > 0.0, "item {i} has no weight");
            observed[i * 10 + (rest * 10.0) as usize] += 1.0;
        }
        let (mut stat, mut dof) = (0.0, 0usize);
        for (c, &o) in observed.iter().enumerate() {
            let e = weights[c / 10] / total / 10.0 * n as f64;
            if e > 0.0 {
                stat += (o - e).powi(2) / e;
                dof += 1;
            }
        }
        let p = chi2::chi2_survival(stat, (dof - 1) as f64);
        assert!(p > 0.01, "chi-square {stat} over {dof} cells: p = {p}");
        assert!(AliasTable::new(&[0.0, 0.0]).is_none());
        assert!(AliasTable::new(&[]).is_none());
    }

    #[test]
    fn distribution_samples_by_weight() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        assert_eq!(d.total(), 4.0);
        assert!((d.pmf(2) - 0.75).abs() < 1e-6);
        assert_eq!(d.pmf(1), 0.0);
        let mut counts = [0; 3];
        let mut rng = Rng::new(3, 4);
        for _ in 0..40_000 {
            let (i, p, ur) = d.sample(rng.next_f32());
            assert!(p > 0.0 && (0.0..1.0).contains(&ur));
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        assert!((counts[0] as f64 / 40_000.0 - 0.25).abs() < 0.01);
    }
}
