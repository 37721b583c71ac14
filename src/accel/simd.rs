//! Vectors of `f32` lanes for the box and pack tests, so that each test is written once and
//! compiled at two widths: [`F4`] (SSE, part of the x86_64 baseline) and [`F8`] (AVX).
//!
//! Every method is `#[inline(always)]` and carries no `target_feature` (the two exclude each
//! other): the AVX methods are meant to be inlined into functions compiled with AVX (or
//! AVX-512), where the intrinsics they call inline too.

#![cfg(target_arch = "x86_64")]

use std::arch::x86_64::*;

/// A vector of `N` `f32` lanes; comparisons give all-ones lanes where true.
///
/// # Safety
/// Every method is `unsafe`: the CPU must support the instructions of the implementation
/// (always for [`F4`]; AVX for [`F8`]). Pointers must be valid for the lanes read or written.
pub(crate) trait Lanes: Copy {
    /// Number of lanes.
    const N: usize;
    /// All lanes `x`.
    unsafe fn splat(x: f32) -> Self;
    /// `N` lanes from `p` (unaligned).
    unsafe fn load(p: *const f32) -> Self;
    /// The low half of the lanes from `lo`, the high half from `hi` (`N / 2` each; for `N` = 4
    /// only `lo` is read, all four lanes).
    unsafe fn load_halves(lo: *const f32, hi: *const f32) -> Self;
    /// Stores the lanes to `p` (unaligned).
    unsafe fn store(self, p: *mut f32);
    /// Lane-wise `self + b`.
    unsafe fn add(self, b: Self) -> Self;
    /// Lane-wise `self - b`.
    unsafe fn sub(self, b: Self) -> Self;
    /// Lane-wise `self * b`.
    unsafe fn mul(self, b: Self) -> Self;
    /// Lane-wise `self / b`.
    unsafe fn div(self, b: Self) -> Self;
    /// `minps` semantics: `b` unless `self < b`.
    unsafe fn min(self, b: Self) -> Self;
    /// `maxps` semantics: `b` unless `self > b`.
    unsafe fn max(self, b: Self) -> Self;
    /// Bitwise and.
    unsafe fn and(self, b: Self) -> Self;
    /// Bitwise or.
    unsafe fn or(self, b: Self) -> Self;
    /// `!self & b`, bitwise.
    unsafe fn andnot(self, b: Self) -> Self;
    /// Lane-wise `self == b` (ordered).
    unsafe fn eq(self, b: Self) -> Self;
    /// Lane-wise `self < b` (ordered).
    unsafe fn lt(self, b: Self) -> Self;
    /// Lane-wise `self > b` (ordered).
    unsafe fn gt(self, b: Self) -> Self;
    /// Lane-wise `self <= b` (ordered).
    unsafe fn le(self, b: Self) -> Self;
    /// The minimum over all lanes, in every lane.
    unsafe fn hmin(self) -> Self;
    /// Bit `i` set when lane `i`'s sign bit is (a comparison's true).
    unsafe fn mask(self) -> u32;
}

/// Four lanes (SSE).
#[derive(Clone, Copy)]
pub(crate) struct F4(__m128);

/// Eight lanes (AVX).
#[derive(Clone, Copy)]
pub(crate) struct F8(__m256);

impl Lanes for F4 {
    const N: usize = 4;
    #[inline(always)]
    unsafe fn splat(x: f32) -> Self {
        F4(_mm_set1_ps(x))
    }
    #[inline(always)]
    unsafe fn load(p: *const f32) -> Self {
        F4(_mm_loadu_ps(p))
    }
    #[inline(always)]
    unsafe fn load_halves(lo: *const f32, _hi: *const f32) -> Self {
        F4(_mm_loadu_ps(lo))
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut f32) {
        _mm_storeu_ps(p, self.0)
    }
    #[inline(always)]
    unsafe fn add(self, b: Self) -> Self {
        F4(_mm_add_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn sub(self, b: Self) -> Self {
        F4(_mm_sub_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn mul(self, b: Self) -> Self {
        F4(_mm_mul_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn div(self, b: Self) -> Self {
        F4(_mm_div_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn min(self, b: Self) -> Self {
        F4(_mm_min_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn max(self, b: Self) -> Self {
        F4(_mm_max_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn and(self, b: Self) -> Self {
        F4(_mm_and_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn or(self, b: Self) -> Self {
        F4(_mm_or_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn andnot(self, b: Self) -> Self {
        F4(_mm_andnot_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn eq(self, b: Self) -> Self {
        F4(_mm_cmpeq_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn lt(self, b: Self) -> Self {
        F4(_mm_cmplt_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn gt(self, b: Self) -> Self {
        F4(_mm_cmpgt_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn le(self, b: Self) -> Self {
        F4(_mm_cmple_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn hmin(self) -> Self {
        let m = _mm_min_ps(self.0, _mm_shuffle_ps::<0b10_11_00_01>(self.0, self.0));
        F4(_mm_min_ps(m, _mm_shuffle_ps::<0b01_00_11_10>(m, m)))
    }
    #[inline(always)]
    unsafe fn mask(self) -> u32 {
        _mm_movemask_ps(self.0) as u32
    }
}

impl Lanes for F8 {
    const N: usize = 8;
    #[inline(always)]
    unsafe fn splat(x: f32) -> Self {
        F8(_mm256_set1_ps(x))
    }
    #[inline(always)]
    unsafe fn load(p: *const f32) -> Self {
        F8(_mm256_loadu_ps(p))
    }
    #[inline(always)]
    unsafe fn load_halves(lo: *const f32, hi: *const f32) -> Self {
        F8(_mm256_loadu2_m128(hi, lo))
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut f32) {
        _mm256_storeu_ps(p, self.0)
    }
    #[inline(always)]
    unsafe fn add(self, b: Self) -> Self {
        F8(_mm256_add_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn sub(self, b: Self) -> Self {
        F8(_mm256_sub_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn mul(self, b: Self) -> Self {
        F8(_mm256_mul_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn div(self, b: Self) -> Self {
        F8(_mm256_div_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn min(self, b: Self) -> Self {
        F8(_mm256_min_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn max(self, b: Self) -> Self {
        F8(_mm256_max_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn and(self, b: Self) -> Self {
        F8(_mm256_and_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn or(self, b: Self) -> Self {
        F8(_mm256_or_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn andnot(self, b: Self) -> Self {
        F8(_mm256_andnot_ps(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn eq(self, b: Self) -> Self {
        F8(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn lt(self, b: Self) -> Self {
        F8(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn gt(self, b: Self) -> Self {
        F8(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn le(self, b: Self) -> Self {
        F8(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, b.0))
    }
    #[inline(always)]
    unsafe fn hmin(self) -> Self {
        let m = _mm256_min_ps(self.0, _mm256_permute_ps::<0b10_11_00_01>(self.0));
        let m = _mm256_min_ps(m, _mm256_permute_ps::<0b01_00_11_10>(m));
        F8(_mm256_min_ps(m, _mm256_permute2f128_ps::<1>(m, m)))
    }
    #[inline(always)]
    unsafe fn mask(self) -> u32 {
        _mm256_movemask_ps(self.0) as u32
    }
}
