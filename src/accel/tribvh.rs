//! The triangle BVH: a [`TriWide`] tree whose leaves hold packs of four triangles in
//! structure-of-arrays layout, tested against a ray at once with the watertight test of
//! [`intersect_triangle`] (SSE on x86_64; the scalar test elsewhere and as the reference).
//!
//! Each lane computes exactly the scalar test's operations in the same order, and a pack with
//! an edge function of exactly zero in any lane falls back to the scalar test (which then
//! re-evaluates in `f64`), so hits are bit-identical to [`intersect_triangle`].

use super::bvh::Bvh;
use super::wide::{huge_pages, prefetch_bytes, LeafAny, LeafClosest, Node, WideBvh, LARGE_BYTES};
use crate::math::{Aabb, Ray};
use crate::scene::geometry::{intersect_triangle, RayTri, Triangle};
use glam::Vec3;

/// Triangles per pack.
pub const PACK: usize = 4;
/// Children per node of the triangle tree.
pub const TRI_WIDTH: usize = 8;
/// The tree type of [`TriangleBvh`].
pub type TriWide = WideBvh<TRI_WIDTH>;
/// A binary subtree with at most this many triangles becomes one leaf.
const MAX_LEAF: usize = 2 * PACK;
/// Marks an unused lane (its vertices repeat the pack's last triangle, so it can only tie).
const NONE: u32 = u32::MAX;

/// Four triangles: `v[vertex][axis][lane]` and the triangle id of each lane.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct Tri4 {
    /// Vertex coordinates, world space.
    pub v: [[[f32; PACK]; 3]; 3],
    /// Triangle id per lane; `u32::MAX` for an unused lane.
    pub id: [u32; PACK],
}

impl Tri4 {
    /// Triangle of lane `i`.
    pub fn triangle(&self, i: usize) -> Triangle {
        let p = |k: usize| Vec3::new(self.v[k][0][i], self.v[k][1][i], self.v[k][2][i]);
        Triangle {
            v: [p(0), p(1), p(2)],
        }
    }
}

/// A closest hit: distance, triangle id and barycentric weights of vertices 1 and 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    /// Distance along the ray.
    pub t: f32,
    /// Triangle id (index into the triangle list the BVH was built from).
    pub prim: u32,
    /// Barycentric weight of vertex 1.
    pub b1: f32,
    /// Barycentric weight of vertex 2.
    pub b2: f32,
}

/// A 4-wide BVH over triangles with packed leaves. Leaf children address `packs`: `child` is
/// the first pack, `count` the number of packs.
#[derive(Clone, Debug, Default)]
pub struct TriangleBvh {
    /// The tree (its `prims` are left empty; leaves index `packs`).
    pub bvh: TriWide,
    /// Triangle packs; each leaf's packs are contiguous (in node and slot order).
    pub packs: Vec<Tri4>,
}

impl TriangleBvh {
    /// Builds over `tris` (triangle `i` has id `i`; degenerate or non-finite ones are skipped
    /// by the binned-SAH build).
    pub fn build(tris: &[Triangle]) -> TriangleBvh {
        let bounds: Vec<Aabb> = tris.iter().map(|t| t.bounds()).collect();
        Self::from_binary(&Bvh::build(&bounds), tris)
    }

    /// Collapses the binary tree `b` built over `tris` and packs its leaves.
    pub fn from_binary(b: &Bvh, tris: &[Triangle]) -> TriangleBvh {
        let mut bvh = TriWide::from_binary(b, MAX_LEAF);
        let prims = std::mem::take(&mut bvh.prims);
        let mut packs = Vec::with_capacity(prims.len() / 2 + 1);
        for node in &mut bvh.nodes {
            for i in 0..TRI_WIDTH {
                let count = node.count[i] as usize;
                if count == 0 {
                    continue;
                }
                let first = node.child[i] as usize;
                let start = packs.len();
                for chunk in prims[first..first + count].chunks(PACK) {
                    let mut pack = Tri4 {
                        v: [[[0.0; PACK]; 3]; 3],
                        id: [NONE; PACK],
                    };
                    for lane in 0..PACK {
                        // Unused lanes repeat the last triangle.
                        let id = chunk[lane.min(chunk.len() - 1)];
                        let t = &tris[id as usize];
                        for k in 0..3 {
                            for a in 0..3 {
                                pack.v[k][a][lane] = t.v[k][a];
                            }
                        }
                        if lane < chunk.len() {
                            pack.id[lane] = id;
                        }
                    }
                    packs.push(pack);
                }
                node.child[i] = start as u32;
                node.count[i] = (packs.len() - start) as u16;
            }
        }
        // (The wide tree's own build puts large node arrays on huge pages.)
        let mut out = TriangleBvh {
            bvh,
            packs: huge_pages(packs),
        };
        out.bvh.large = out.bytes() > LARGE_BYTES;
        out
    }

    /// Bytes of the structure (nodes and packs).
    pub fn bytes(&self) -> usize {
        self.bvh.nodes.len() * std::mem::size_of::<Node<TRI_WIDTH>>()
            + self.packs.len() * std::mem::size_of::<Tri4>()
    }

    /// Checks that every child box contains its subtree and that every triangle of `tris`
    /// with non-empty finite bounds appears in exactly one lane, with its own vertices.
    pub fn check_invariants(&self, tris: &[Triangle]) -> Result<(), String> {
        let mut seen = vec![0u32; tris.len()];
        let contains = |n: &Node<TRI_WIDTH>, i: usize, b: &Aabb| n.slot_box(i).contains(b);
        for (ni, n) in self.bvh.nodes.iter().enumerate() {
            for i in 0..TRI_WIDTH {
                if n.valid & (1 << i) == 0 {
                    continue;
                }
                if n.count[i] == 0 {
                    let c = &self.bvh.nodes[n.child[i] as usize];
                    for j in 0..TRI_WIDTH {
                        if c.valid & (1 << j) != 0 && !contains(n, i, &c.slot_box(j)) {
                            return Err(format!("node {ni} slot {i} does not contain its child"));
                        }
                    }
                    continue;
                }
                let first = n.child[i] as usize;
                for pack in &self.packs[first..first + n.count[i] as usize] {
                    // Unused lanes come last and repeat the last used lane's triangle.
                    let used = pack.id.iter().take_while(|&&id| id != NONE).count();
                    if used == 0 || pack.id[used..].iter().any(|&id| id != NONE) {
                        return Err(format!("node {ni} slot {i}: unused lanes must come last"));
                    }
                    if (used..PACK).any(|l| pack.triangle(l).v != pack.triangle(used - 1).v) {
                        return Err(format!(
                            "node {ni} slot {i}: an unused lane must repeat the last triangle"
                        ));
                    }
                    for lane in 0..PACK {
                        let tri = pack.triangle(lane);
                        if !contains(n, i, &tri.bounds()) {
                            return Err(format!("node {ni} slot {i} does not contain a lane"));
                        }
                        let id = pack.id[lane];
                        if id == NONE {
                            continue;
                        }
                        let Some(t) = tris.get(id as usize) else {
                            return Err(format!("triangle id {id} out of range"));
                        };
                        if t.v != tri.v {
                            return Err(format!("triangle {id} has other vertices in its pack"));
                        }
                        seen[id as usize] += 1;
                    }
                }
            }
        }
        for (i, t) in tris.iter().enumerate() {
            let b = t.bounds();
            let want = u32::from(!b.is_empty() && b.min.is_finite() && b.max.is_finite());
            if seen[i] != want {
                return Err(format!("triangle {i} appears {} times", seen[i]));
            }
        }
        Ok(())
    }

    /// The closest hit of `ray` in `(ray.t_min, ray.t_max)`. The pack tests are inlined into
    /// the traversal, so they too are compiled for AVX where the traversal uses it.
    #[inline]
    pub fn closest(&self, ray: &Ray) -> Option<TriHit> {
        let mut leaf = self.closest_leaf(ray);
        self.bvh.closest_leaf(ray, &mut leaf);
        leaf.hit
    }

    /// Whether `ray` hits any triangle in `(ray.t_min, ray.t_max)`.
    #[inline]
    pub fn any(&self, ray: &Ray) -> bool {
        self.bvh.any_leaf(ray, self.any_leaf(ray))
    }

    #[inline(always)]
    fn closest_leaf<'a>(&'a self, ray: &'a Ray) -> ClosestLeaf<'a> {
        ClosestLeaf {
            packs: &self.packs,
            rt: PackRay::new(ray),
            ray,
            hit: None,
        }
    }

    #[inline(always)]
    fn any_leaf<'a>(&'a self, ray: &'a Ray) -> AnyLeaf<'a> {
        AnyLeaf {
            packs: &self.packs,
            rt: PackRay::new(ray),
            ray,
        }
    }
}

/// The closest-hit leaf test over packs (inlined into the traversal).
struct ClosestLeaf<'a> {
    packs: &'a [Tri4],
    rt: PackRay,
    ray: &'a Ray,
    hit: Option<TriHit>,
}

impl LeafClosest for &mut ClosestLeaf<'_> {
    #[inline(always)]
    fn prefetch(&self, first: u32, count: u32) {
        let packs = self.packs.as_ptr().wrapping_add(first as usize);
        prefetch_bytes(
            packs as *const u8,
            count as usize * std::mem::size_of::<Tri4>(),
        );
    }
    #[inline(always)]
    fn test(&mut self, first: u32, count: u32, mut t_max: f32) -> Option<f32> {
        let mut found = None;
        #[cfg(target_arch = "x86_64")]
        if count == 2 && crate::accel::wide::avx() {
            let p = &self.packs[first as usize..first as usize + 2];
            // SAFETY: the CPU supports AVX (checked at run time).
            if let Some(h) = unsafe { self.rt.closest_avx(self.ray, &p[0], &p[1], t_max) } {
                self.hit = Some(h);
                return Some(h.t);
            }
            return None;
        }
        for pack in &self.packs[first as usize..(first + count) as usize] {
            if let Some(h) = self.rt.closest(self.ray, pack, t_max) {
                t_max = h.t;
                found = Some(h.t);
                self.hit = Some(h);
            }
        }
        found
    }
}

/// The any-hit leaf test over packs (inlined into the traversal).
struct AnyLeaf<'a> {
    packs: &'a [Tri4],
    rt: PackRay,
    ray: &'a Ray,
}

impl LeafAny for AnyLeaf<'_> {
    #[inline(always)]
    fn test(&mut self, first: u32, count: u32) -> bool {
        #[cfg(target_arch = "x86_64")]
        if count == 2 && crate::accel::wide::avx() {
            let p = &self.packs[first as usize..first as usize + 2];
            // SAFETY: the CPU supports AVX (checked at run time).
            return unsafe { self.rt.any_avx(self.ray, &p[0], &p[1]) };
        }
        for pack in &self.packs[first as usize..(first + count) as usize] {
            if self.rt.any(self.ray, pack) {
                return true;
            }
        }
        false
    }
}

/// Per-ray data for the pack test: the scalar test's permutation and shear.
#[derive(Clone, Copy)]
pub struct PackRay {
    rt: RayTri,
    /// The origin in the permuted axis order `(o[kx], o[ky], o[kz])`.
    o: [f32; 3],
}

impl PackRay {
    /// Prepares `ray`.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let rt = RayTri::new(ray);
        let o = ray.o.to_array();
        PackRay {
            o: rt.k.map(|k| o[k]),
            rt,
        }
    }

    /// Reference: the scalar test on each lane, the lowest lane winning ties.
    pub(crate) fn closest_scalar(&self, ray: &Ray, pack: &Tri4, t_max: f32) -> Option<TriHit> {
        let mut t_max = t_max;
        let mut hit = None;
        for lane in 0..PACK {
            if let Some((t, b1, b2)) =
                intersect_triangle(ray, &self.rt, &pack.triangle(lane), t_max)
            {
                t_max = t;
                hit = Some(TriHit {
                    t,
                    prim: pack.id[lane],
                    b1,
                    b2,
                });
            }
        }
        hit
    }

    /// The nearest hit among the pack's lanes in `(ray.t_min, t_max)`, lowest lane on ties;
    /// bit-identical to [`PackRay::closest_scalar`].
    #[inline(always)]
    pub fn closest(&self, ray: &Ray, pack: &Tri4, t_max: f32) -> Option<TriHit> {
        #[cfg(target_arch = "x86_64")]
        {
            self.closest_sse(ray, pack, t_max)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.closest_scalar(ray, pack, t_max)
        }
    }

    /// Whether any lane is hit in `(ray.t_min, ray.t_max)`.
    #[inline(always)]
    pub fn any(&self, ray: &Ray, pack: &Tri4) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            match self.hits_sse(ray, pack, ray.t_max) {
                Lanes::Miss => false,
                Lanes::Mask(mask, ..) => mask != 0,
                Lanes::Fallback => self.closest_scalar(ray, pack, ray.t_max).is_some(),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.closest_scalar(ray, pack, ray.t_max).is_some()
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn closest_sse(&self, ray: &Ray, pack: &Tri4, t_max: f32) -> Option<TriHit> {
        use std::arch::x86_64::*;
        let (mask, l) = match self.hits_sse(ray, pack, t_max) {
            Lanes::Miss => return None,
            Lanes::Mask(mask, l) => (mask, l),
            // An edge function is exactly zero: the scalar test redoes it in f64.
            Lanes::Fallback => return self.closest_scalar(ray, pack, t_max),
        };
        if mask == 0 {
            return None;
        }
        // SAFETY: SSE and SSE2 are part of the x86_64 baseline; stores are unaligned-safe.
        unsafe {
            // Nearest valid lane, lowest index on ties.
            let tm = _mm_or_ps(
                _mm_and_ps(l.ok, l.t),
                _mm_andnot_ps(l.ok, _mm_set1_ps(f32::INFINITY)),
            );
            let m = _mm_min_ps(tm, _mm_shuffle_ps::<0b10_11_00_01>(tm, tm));
            let m = _mm_min_ps(m, _mm_shuffle_ps::<0b01_00_11_10>(m, m));
            let lane = (_mm_movemask_ps(_mm_and_ps(l.ok, _mm_cmpeq_ps(tm, m))) as u32)
                .trailing_zeros() as usize;
            let mut ts = [0f32; PACK];
            let mut vs = [0f32; PACK];
            let mut ws = [0f32; PACK];
            _mm_storeu_ps(ts.as_mut_ptr(), l.t);
            _mm_storeu_ps(vs.as_mut_ptr(), _mm_mul_ps(l.v, l.inv));
            _mm_storeu_ps(ws.as_mut_ptr(), _mm_mul_ps(l.w, l.inv));
            debug_assert_ne!(pack.id[lane], NONE, "an unused lane only ties");
            Some(TriHit {
                t: ts[lane],
                prim: pack.id[lane],
                b1: vs[lane],
                b2: ws[lane],
            })
        }
    }

    /// Two packs at once with AVX: the same result as testing `p0`, then `p1`.
    ///
    /// # Safety
    /// The CPU must support AVX. Inlined (`inline(always)` rules out `target_feature`), so that
    /// the AVX traversals compile it with their own features.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn closest_avx(&self, ray: &Ray, p0: &Tri4, p1: &Tri4, t_max: f32) -> Option<TriHit> {
        use std::arch::x86_64::*;
        let (ok, t, v, w, inv) = match self.hits_avx(ray, p0, p1, t_max) {
            Lanes8::Miss => return None,
            Lanes8::Mask(ok, t, v, w, inv) => (ok, t, v, w, inv),
            Lanes8::Fallback => {
                let h0 = self.closest(ray, p0, t_max);
                let h1 = self.closest(ray, p1, h0.map_or(t_max, |h| h.t));
                return h1.or(h0);
            }
        };
        if _mm256_movemask_ps(ok) == 0 {
            return None;
        }
        let tm = _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), t, ok);
        let m = _mm256_min_ps(tm, _mm256_permute_ps::<0b10_11_00_01>(tm));
        let m = _mm256_min_ps(m, _mm256_permute_ps::<0b01_00_11_10>(m));
        let m = _mm256_min_ps(m, _mm256_permute2f128_ps::<1>(m, m));
        let lane = (_mm256_movemask_ps(_mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_EQ_OQ>(tm, m)))
            as u32)
            .trailing_zeros() as usize;
        let mut ts = [0f32; 8];
        let mut vs = [0f32; 8];
        let mut ws = [0f32; 8];
        _mm256_storeu_ps(ts.as_mut_ptr(), t);
        _mm256_storeu_ps(vs.as_mut_ptr(), _mm256_mul_ps(v, inv));
        _mm256_storeu_ps(ws.as_mut_ptr(), _mm256_mul_ps(w, inv));
        let pack = if lane < PACK { p0 } else { p1 };
        debug_assert_ne!(pack.id[lane % PACK], NONE, "an unused lane only ties");
        Some(TriHit {
            t: ts[lane],
            prim: pack.id[lane % PACK],
            b1: vs[lane],
            b2: ws[lane],
        })
    }

    /// Whether a lane of `p0` or `p1` is hit in `(ray.t_min, ray.t_max)`, with AVX.
    ///
    /// # Safety
    /// As [`PackRay::closest_avx`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn any_avx(&self, ray: &Ray, p0: &Tri4, p1: &Tri4) -> bool {
        use std::arch::x86_64::*;
        match self.hits_avx(ray, p0, p1, ray.t_max) {
            Lanes8::Miss => false,
            Lanes8::Mask(ok, ..) => _mm256_movemask_ps(ok) != 0,
            Lanes8::Fallback => self.any(ray, p0) || self.any(ray, p1),
        }
    }

    /// The lanes of `p0` (0–3) and `p1` (4–7) hit in `(ray.t_min, t_max)`: the 4-lane test
    /// at twice the width.
    ///
    /// # Safety
    /// As [`PackRay::closest_avx`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn hits_avx(&self, ray: &Ray, p0: &Tri4, p1: &Tri4, t_max: f32) -> Lanes8 {
        use std::arch::x86_64::*;
        let [kx, ky, kz] = self.rt.k;
        let s = self.rt.s;
        let zero = _mm256_setzero_ps();
        let (ox, oy, oz) = (
            _mm256_set1_ps(self.o[0]),
            _mm256_set1_ps(self.o[1]),
            _mm256_set1_ps(self.o[2]),
        );
        let (sx, sy, sz) = (
            _mm256_set1_ps(s.x),
            _mm256_set1_ps(s.y),
            _mm256_set1_ps(s.z),
        );
        // Macros rather than closures: a closure would not be inlined into the AVX caller.
        macro_rules! ld {
            ($k:expr, $a:expr) => {
                _mm256_loadu2_m128(p1.v[$k][$a].as_ptr(), p0.v[$k][$a].as_ptr())
            };
        }
        macro_rules! vert {
            ($k:expr) => {{
                let dx = _mm256_sub_ps(ld!($k, kx), ox);
                let dy = _mm256_sub_ps(ld!($k, ky), oy);
                let dz = _mm256_sub_ps(ld!($k, kz), oz);
                (
                    _mm256_sub_ps(dx, _mm256_mul_ps(sx, dz)),
                    _mm256_sub_ps(dy, _mm256_mul_ps(sy, dz)),
                    _mm256_mul_ps(sz, dz),
                )
            }};
        }
        macro_rules! eq {
            ($x:expr) => {
                _mm256_cmp_ps::<_CMP_EQ_OQ>($x, zero)
            };
        }
        macro_rules! lt {
            ($x:expr) => {
                _mm256_cmp_ps::<_CMP_LT_OQ>($x, zero)
            };
        }
        macro_rules! gt {
            ($x:expr) => {
                _mm256_cmp_ps::<_CMP_GT_OQ>($x, zero)
            };
        }
        let (ax, ay, az) = vert!(0);
        let (bx, by, bz) = vert!(1);
        let (cx, cy, cz) = vert!(2);
        let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
        let v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
        let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
        if _mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(eq!(u), eq!(v)), eq!(w))) != 0 {
            return Lanes8::Fallback;
        }
        let neg = _mm256_or_ps(_mm256_or_ps(lt!(u), lt!(v)), lt!(w));
        let pos = _mm256_or_ps(_mm256_or_ps(gt!(u), gt!(v)), gt!(w));
        let outside = _mm256_and_ps(neg, pos);
        if _mm256_movemask_ps(outside) == 0xff {
            return Lanes8::Miss;
        }
        let det = _mm256_add_ps(_mm256_add_ps(u, v), w);
        let t = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(u, az), _mm256_mul_ps(v, bz)),
            _mm256_mul_ps(w, cz),
        );
        let inv = _mm256_div_ps(_mm256_set1_ps(1.0), det);
        let t = _mm256_mul_ps(t, inv);
        let ok = _mm256_andnot_ps(
            _mm256_or_ps(outside, eq!(det)),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(t, _mm256_set1_ps(ray.t_min)),
                _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(t_max)),
            ),
        );
        Lanes8::Mask(ok, t, v, w, inv)
    }

    /// The lanes hit in `(ray.t_min, t_max)`, or `Fallback` when an edge function is exactly
    /// zero in some lane.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn hits_sse(&self, ray: &Ray, pack: &Tri4, t_max: f32) -> Lanes {
        use std::arch::x86_64::*;
        let [kx, ky, kz] = self.rt.k;
        let s = self.rt.s;
        // SAFETY: SSE and SSE2 are part of the x86_64 baseline; all loads are unaligned-safe.
        unsafe {
            let zero = _mm_setzero_ps();
            let (ox, oy, oz) = (
                _mm_set1_ps(self.o[0]),
                _mm_set1_ps(self.o[1]),
                _mm_set1_ps(self.o[2]),
            );
            let (sx, sy, sz) = (_mm_set1_ps(s.x), _mm_set1_ps(s.y), _mm_set1_ps(s.z));
            let ld = |k: usize, a: usize| _mm_loadu_ps(pack.v[k][a].as_ptr());
            // Vertex k relative to the origin, sheared: (x, y, z-distance term).
            let vert = |k: usize| {
                let dx = _mm_sub_ps(ld(k, kx), ox);
                let dy = _mm_sub_ps(ld(k, ky), oy);
                let dz = _mm_sub_ps(ld(k, kz), oz);
                (
                    _mm_sub_ps(dx, _mm_mul_ps(sx, dz)),
                    _mm_sub_ps(dy, _mm_mul_ps(sy, dz)),
                    _mm_mul_ps(sz, dz),
                )
            };
            let (ax, ay, az) = vert(0);
            let (bx, by, bz) = vert(1);
            let (cx, cy, cz) = vert(2);
            let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
            let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
            let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
            let zero_edge = _mm_or_ps(
                _mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)),
                _mm_cmpeq_ps(w, zero),
            );
            if _mm_movemask_ps(zero_edge) != 0 {
                return Lanes::Fallback;
            }
            let neg = _mm_or_ps(
                _mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)),
                _mm_cmplt_ps(w, zero),
            );
            let pos = _mm_or_ps(
                _mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)),
                _mm_cmpgt_ps(w, zero),
            );
            // Most packs miss on the edge signs: skip the distance and the division then.
            let outside = _mm_and_ps(neg, pos);
            if _mm_movemask_ps(outside) == 0b1111 {
                return Lanes::Miss;
            }
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let t = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)),
                _mm_mul_ps(w, cz),
            );
            let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
            let t = _mm_mul_ps(t, inv);
            let ok = _mm_andnot_ps(
                _mm_or_ps(outside, _mm_cmpeq_ps(det, zero)),
                _mm_and_ps(
                    _mm_cmpgt_ps(t, _mm_set1_ps(ray.t_min)),
                    _mm_cmplt_ps(t, _mm_set1_ps(t_max)),
                ),
            );
            Lanes::Mask(_mm_movemask_ps(ok), LaneData { ok, t, v, w, inv })
        }
    }
}

/// Result of the 4-lane test: no lane inside its triangle's edges, the mask of hit lanes and
/// the lanes' data, or a request for the scalar test.
#[cfg(target_arch = "x86_64")]
enum Lanes {
    Miss,
    Mask(i32, LaneData),
    Fallback,
}

/// Result of the 8-lane test, as [`Lanes`]; `Mask` holds the hit lanes, the distances, the
/// edge functions `v`, `w` and `1/det`.
#[cfg(target_arch = "x86_64")]
enum Lanes8 {
    Miss,
    Mask(
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256,
        std::arch::x86_64::__m256,
    ),
    Fallback,
}

/// Per-lane data of the 4-lane test: hit mask, distance, edge functions `v`, `w` and `1/det`.
#[cfg(target_arch = "x86_64")]
struct LaneData {
    ok: std::arch::x86_64::__m128,
    t: std::arch::x86_64::__m128,
    v: std::arch::x86_64::__m128,
    w: std::arch::x86_64::__m128,
    inv: std::arch::x86_64::__m128,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::wide::Sse;
    use crate::sampling::{uniform_sphere, Rng};

    fn random_tris(rng: &mut Rng, n: usize, size: f32) -> Vec<Triangle> {
        (0..n)
            .map(|_| {
                let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0;
                let mut p =
                    || c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * size;
                Triangle { v: [p(), p(), p()] }
            })
            .collect()
    }

    #[test]
    fn sse_pack_test_equals_scalar_test() {
        let mut rng = Rng::new(11, 3);
        let mut lanes_hit = 0;
        let mut prev: Option<Tri4> = None;
        let mut pairs_hit = 0;
        for round in 0..20_000 {
            // Some packs share edges and vertices with a grid so that exact zeros occur.
            let tris = if round % 4 == 0 {
                let o = Vec3::new(rng.next_f32(), 0.0, rng.next_f32()).floor();
                let (a, b, c, d) = (o, o + Vec3::X, o + Vec3::Z, o + Vec3::X + Vec3::Z);
                vec![
                    Triangle { v: [a, b, c] },
                    Triangle { v: [b, d, c] },
                    Triangle { v: [a, c, b] },
                    Triangle { v: [a, b, d] },
                ]
            } else {
                random_tris(&mut rng, 4, 2.0)
            };
            // Every third pack has 1–3 used lanes; the rest repeat the last (as the build does).
            let used = if round % 3 == 1 {
                1 + (rng.next_u32() % 3) as usize
            } else {
                PACK
            };
            let mut pack = Tri4 {
                v: [[[0.0; PACK]; 3]; 3],
                id: [NONE; PACK],
            };
            for lane in 0..PACK {
                let t = &tris[lane.min(used - 1)];
                for k in 0..3 {
                    for a in 0..3 {
                        pack.v[k][a][lane] = t.v[k][a];
                    }
                }
                if lane < used {
                    pack.id[lane] = (round * PACK + lane) as u32;
                }
            }
            let ray = if round % 4 == 0 {
                // Through a grid vertex or edge, from above.
                let p = Vec3::new(
                    (rng.next_f32() * 2.0).floor() * 0.5,
                    0.0,
                    (rng.next_f32() * 2.0).floor() * 0.5,
                );
                Ray::new(p + Vec3::Y, -Vec3::Y)
            } else {
                Ray::new(
                    Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0,
                    uniform_sphere(rng.next_2d()),
                )
            };
            let mut ray = ray;
            if round % 5 == 2 {
                ray.t_min = rng.next_f32() * 2.0;
            }
            let rt = PackRay::new(&ray);
            let t_max = if rng.next_f32() < 0.3 {
                1.5
            } else {
                f32::INFINITY
            };
            let a = rt.closest(&ray, &pack, t_max);
            let b = rt.closest_scalar(&ray, &pack, t_max);
            let bits = |h: Option<TriHit>| {
                h.map(|h| (h.t.to_bits(), h.prim, h.b1.to_bits(), h.b2.to_bits()))
            };
            assert_eq!(bits(a), bits(b), "round {round}");
            assert!(
                a.is_none_or(|h| h.prim != NONE),
                "an unused lane is never reported"
            );
            let mut r = ray;
            r.t_max = t_max;
            assert_eq!(rt.any(&r, &pack), b.is_some(), "round {round}");
            lanes_hit += usize::from(a.is_some());
            // Two packs at once (AVX): as the scalar test on the first pack, then the second.
            #[cfg(target_arch = "x86_64")]
            if let Some(p0) = prev.filter(|_| crate::accel::wide::avx()) {
                let h0 = rt.closest_scalar(&ray, &p0, t_max);
                let want = rt
                    .closest_scalar(&ray, &pack, h0.map_or(t_max, |h| h.t))
                    .or(h0);
                // SAFETY: the CPU supports AVX (checked above).
                let got = unsafe { rt.closest_avx(&ray, &p0, &pack, t_max) };
                assert_eq!(bits(got), bits(want), "pair, round {round}");
                // SAFETY: as above.
                let any = unsafe { rt.any_avx(&r, &p0, &pack) };
                assert_eq!(any, want.is_some(), "pair, round {round}");
                pairs_hit += usize::from(want.is_some());
            }
            prev = Some(pack);
        }
        #[cfg(target_arch = "x86_64")]
        if crate::accel::wide::avx() {
            assert!(
                pairs_hit > 2000,
                "the pair test must exercise hits ({pairs_hit})"
            );
        }
        assert!(
            lanes_hit > 2000,
            "the test must exercise hits ({lanes_hit})"
        );
    }

    #[test]
    fn triangle_bvh_matches_brute_force() {
        let mut rng = Rng::new(4, 8);
        for n in [1, 3, 4, 5, 17, 2000] {
            let tris = random_tris(&mut rng, n, 0.6);
            let bvh = TriangleBvh::build(&tris);
            bvh.check_invariants(&tris).unwrap();
            // These trees are small; the traversals for large ones must find the same hits.
            assert!(!bvh.bvh.large);
            let mut large = bvh.clone();
            large.bvh.large = true;
            for _ in 0..2000 {
                let ray = Ray::new(
                    Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0,
                    uniform_sphere(rng.next_2d()),
                );
                let rt = RayTri::new(&ray);
                let mut best: Option<(f32, u32)> = None;
                for (i, t) in tris.iter().enumerate() {
                    let t_max = best.map_or(ray.t_max, |b| b.0);
                    if let Some((d, _, _)) = intersect_triangle(&ray, &rt, t, t_max) {
                        best = Some((d, i as u32));
                    }
                }
                let got = bvh.closest(&ray);
                assert_eq!(large.closest(&ray), got, "n = {n}");
                assert_eq!(large.any(&ray), best.is_some(), "n = {n}");
                assert_eq!(
                    got.map(|h| h.t.to_bits()),
                    best.map(|b| b.0.to_bits()),
                    "n = {n}"
                );
                if let Some(h) = got {
                    // The reported triangle is hit at that distance, with those barycentrics.
                    let (t, b1, b2) =
                        intersect_triangle(&ray, &rt, &tris[h.prim as usize], f32::INFINITY)
                            .unwrap();
                    assert_eq!((t, b1, b2), (h.t, h.b1, h.b2));
                }
                assert_eq!(bvh.any(&ray), best.is_some());
                // The baseline path too, where the default one uses AVX or AVX-512.
                let mut leaf = bvh.closest_leaf(&ray);
                bvh.bvh.closest_leaf_with::<Sse>(&ray, &mut leaf);
                assert_eq!(leaf.hit, got, "n = {n}");
                let any = bvh.bvh.any_leaf_with::<Sse>(&ray, bvh.any_leaf(&ray));
                assert_eq!(any, best.is_some());
                // The AVX path where the default one uses AVX-512.
                #[cfg(target_arch = "x86_64")]
                if crate::accel::wide::avx() {
                    let mut leaf = bvh.closest_leaf(&ray);
                    // SAFETY: the CPU supports AVX (checked above).
                    unsafe { bvh.bvh.closest_leaf_avx(&ray, &mut leaf) };
                    assert_eq!(leaf.hit, got, "n = {n}");
                    // SAFETY: as above.
                    let any = unsafe { bvh.bvh.any_leaf_avx(&ray, bvh.any_leaf(&ray)) };
                    assert_eq!(any, best.is_some());
                }
            }
        }
    }

    #[test]
    fn empty_triangle_bvh_hits_nothing() {
        let bvh = TriangleBvh::build(&[]);
        assert!(bvh.closest(&Ray::new(Vec3::ZERO, Vec3::X)).is_none());
        assert!(!bvh.any(&Ray::new(Vec3::ZERO, Vec3::X)));
    }
}
