//! Memory layout helpers for large read-mostly arrays (BVHs, environment maps and their
//! distributions): huge pages and cache prefetch.

/// Structures larger than this (bytes, about a core's L2 cache) count as large (the BVHs
/// then prefetch and sit on huge pages).
pub const LARGE_BYTES: usize = 2 << 20;

/// Prefetches the cache lines of `len` bytes from `p` into L1 (a hint: never faults, so `p`
/// need not be valid; nothing on other architectures).
#[inline(always)]
pub(crate) fn prefetch_bytes(p: *const u8, len: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let (first, end) = (p as usize / 64, (p as usize + len).div_ceil(64));
        for line in first..end {
            // SAFETY: a prefetch is only a hint; SSE is part of the x86_64 baseline.
            unsafe { _mm_prefetch::<_MM_HINT_T0>((line * 64) as *const i8) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, len);
}

/// Moves `v` into a buffer that the kernel is asked to back with huge pages (2 MiB on
/// x86_64 Linux) when it is [`LARGE_BYTES`] or more: an incoherent ray through a large tree
/// touches a new page at almost every node, and with 4 KiB pages most of those touches miss
/// the TLB (Embree does the same). The advice is given before the buffer is first written, so
/// the pages can be huge from the start; elsewhere, or if the kernel declines, `v` is returned
/// as it is.
pub(crate) fn huge_pages<T: Copy>(v: Vec<T>) -> Vec<T> {
    #[cfg(target_os = "linux")]
    if std::mem::size_of_val(v.as_slice()) >= LARGE_BYTES {
        let mut out = Vec::<T>::with_capacity(v.len());
        let start = out.as_ptr() as usize;
        let end = start + v.len() * std::mem::size_of::<T>();
        // madvise needs a page-aligned start; the range stays inside the new buffer.
        let first = start.next_multiple_of(4096);
        if first < end {
            // SAFETY: the range lies within `out`'s allocation, which we own; MADV_HUGEPAGE
            // only changes how the kernel backs it, not its contents or validity.
            unsafe {
                libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
            }
        }
        out.extend_from_slice(&v);
        return out;
    }
    v
}
