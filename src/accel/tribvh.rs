//! The triangle BVH: a [`TriWide`] tree whose leaves hold packs of four triangles in
//! structure-of-arrays layout, tested against a ray at once with the watertight test of
//! [`intersect_triangle`] (SSE on x86_64; the scalar test elsewhere and as the reference).
//!
//! Each lane computes exactly the scalar test's operations in the same order, and a pack with
//! an edge function of exactly zero in any lane falls back to the scalar test (which then
//! re-evaluates in `f64`), so hits are bit-identical to [`intersect_triangle`].

use super::bvh::Bvh;
#[cfg(target_arch = "x86_64")]
use super::simd::{Lanes, F4, F8};
use super::wide::{LeafAny, LeafClosest, Node, WideBvh};
use crate::geometry::{intersect_triangle, RayTri, Triangle};
use crate::math::{Aabb, Ray};
use crate::memory::{huge_pages, prefetch_bytes, LARGE_BYTES};
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

/// An 8-wide ([`TRI_WIDTH`]) BVH over triangles with packed leaves of four. Leaf children address `packs`: `child` is
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
        let mut leaf = self.closest_leaf::<true>(ray);
        self.bvh.closest_leaf(ray, &mut leaf);
        if leaf.fallback {
            return self.closest_exact(ray);
        }
        leaf.hit
    }

    /// Whether `ray` hits any triangle in `(ray.t_min, ray.t_max)`.
    #[inline]
    pub fn any(&self, ray: &Ray) -> bool {
        let mut leaf = self.any_leaf::<true>(ray);
        let hit = self.bvh.any_leaf(ray, &mut leaf);
        if leaf.fallback {
            return self.any_exact(ray);
        }
        hit
    }

    /// [`TriangleBvh::closest`] for the rare ray that meets an edge function of exactly zero:
    /// the traversal again, with leaf tests that redo such packs with the scalar test (a
    /// call). Kept out of the fast traversal, where a call would make the compiler keep the
    /// ray's constants in memory rather than in registers.
    #[cold]
    #[inline(never)]
    fn closest_exact(&self, ray: &Ray) -> Option<TriHit> {
        let mut leaf = self.closest_leaf::<false>(ray);
        self.bvh.closest_leaf(ray, &mut leaf);
        leaf.hit
    }

    /// [`TriangleBvh::any`] for the rare ray that meets an edge function of exactly zero (see
    /// [`TriangleBvh::closest_exact`]).
    #[cold]
    #[inline(never)]
    fn any_exact(&self, ray: &Ray) -> bool {
        self.bvh.any_leaf(ray, &mut self.any_leaf::<false>(ray))
    }

    #[inline(always)]
    fn closest_leaf<'a, const DEFER: bool>(&'a self, ray: &'a Ray) -> ClosestLeaf<'a, DEFER> {
        ClosestLeaf {
            packs: &self.packs,
            rt: PackRay::new(ray),
            ray,
            hit: None,
            avx: avx_packs(),
            fallback: false,
        }
    }

    #[inline(always)]
    fn any_leaf<'a, const DEFER: bool>(&'a self, ray: &'a Ray) -> AnyLeaf<'a, DEFER> {
        AnyLeaf {
            packs: &self.packs,
            rt: PackRay::new(ray),
            ray,
            avx: avx_packs(),
            fallback: false,
        }
    }
}

/// Whether two-pack leaves are tested in one AVX pass (asked once per query, not per leaf).
#[inline(always)]
fn avx_packs() -> bool {
    #[cfg(target_arch = "x86_64")]
    return crate::accel::wide::avx();
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// The closest-hit leaf test over packs (inlined into the traversal). With `DEFER`, a pack
/// with an edge function of exactly zero is not redone with the scalar test here: the test
/// sets `fallback` and the query is redone by [`TriangleBvh::closest_exact`].
struct ClosestLeaf<'a, const DEFER: bool> {
    packs: &'a [Tri4],
    rt: PackRay,
    ray: &'a Ray,
    hit: Option<TriHit>,
    /// Whether the CPU supports AVX.
    avx: bool,
    /// Whether a deferred pack test needed the scalar test.
    fallback: bool,
}

impl<const DEFER: bool> ClosestLeaf<'_, DEFER> {
    /// The result of a lane test (`None`: it needs the scalar test).
    #[inline(always)]
    fn settle(&mut self, r: Option<Option<TriHit>>, packs: &[Tri4], t_max: f32) -> Option<TriHit> {
        match r {
            Some(h) => h,
            None if DEFER => {
                self.fallback = true;
                None
            }
            None => self.rt.closest_exact(self.ray, packs, t_max),
        }
    }
}

impl<const DEFER: bool> LeafClosest for &mut ClosestLeaf<'_, DEFER> {
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
        let packs = &self.packs[first as usize..(first + count) as usize];
        #[cfg(target_arch = "x86_64")]
        if count == 2 && self.avx {
            // SAFETY: the CPU supports AVX (checked at run time).
            let r = unsafe {
                self.rt
                    .closest_lanes_or_fallback::<F8>(self.ray, packs, t_max)
            };
            let h = self.settle(r, packs, t_max)?;
            self.hit = Some(h);
            return Some(h.t);
        }
        for pack in packs {
            let r = self.rt.closest_or_fallback(self.ray, pack, t_max);
            if let Some(h) = self.settle(r, std::slice::from_ref(pack), t_max) {
                t_max = h.t;
                found = Some(h.t);
                self.hit = Some(h);
            }
        }
        found
    }
}

/// The any-hit leaf test over packs (inlined into the traversal), with `DEFER` as in
/// [`ClosestLeaf`] (a deferred test ends the traversal at once).
struct AnyLeaf<'a, const DEFER: bool> {
    packs: &'a [Tri4],
    rt: PackRay,
    ray: &'a Ray,
    /// Whether the CPU supports AVX.
    avx: bool,
    /// Whether a deferred pack test needed the scalar test.
    fallback: bool,
}

impl<const DEFER: bool> AnyLeaf<'_, DEFER> {
    /// The result of a lane test (`None`: it needs the scalar test).
    #[inline(always)]
    fn settle(&mut self, r: Option<bool>, packs: &[Tri4]) -> bool {
        match r {
            Some(hit) => hit,
            None if DEFER => {
                self.fallback = true;
                true
            }
            None => self.rt.any_exact(self.ray, packs),
        }
    }
}

impl<const DEFER: bool> LeafAny for &mut AnyLeaf<'_, DEFER> {
    #[inline(always)]
    fn test(&mut self, first: u32, count: u32) -> bool {
        let packs = &self.packs[first as usize..(first + count) as usize];
        #[cfg(target_arch = "x86_64")]
        if count == 2 && self.avx {
            // SAFETY: the CPU supports AVX (checked at run time).
            let r = unsafe { self.rt.any_lanes_or_fallback::<F8>(self.ray, packs) };
            return self.settle(r, packs);
        }
        for pack in packs {
            let r = self.rt.any_or_fallback(self.ray, pack);
            if self.settle(r, std::slice::from_ref(pack)) {
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

    /// [`PackRay::closest_scalar`] on `packs` one after the other.
    fn closest_exact(&self, ray: &Ray, packs: &[Tri4], t_max: f32) -> Option<TriHit> {
        packs.iter().fold(None, |best: Option<TriHit>, p| {
            let t = best.map_or(t_max, |h| h.t);
            self.closest_scalar(ray, p, t).or(best)
        })
    }

    /// Whether [`PackRay::closest_scalar`] finds a hit in `(ray.t_min, ray.t_max)` in any of
    /// `packs`.
    fn any_exact(&self, ray: &Ray, packs: &[Tri4]) -> bool {
        packs
            .iter()
            .any(|p| self.closest_scalar(ray, p, ray.t_max).is_some())
    }

    /// [`PackRay::closest`], or `None` where that needs the scalar test (an edge function
    /// exactly zero in some lane), which this never calls.
    #[inline(always)]
    fn closest_or_fallback(&self, ray: &Ray, pack: &Tri4, t_max: f32) -> Option<Option<TriHit>> {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: SSE and SSE2 are part of the x86_64 baseline.
            unsafe { self.closest_lanes_or_fallback::<F4>(ray, std::slice::from_ref(pack), t_max) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Some(self.closest_scalar(ray, pack, t_max))
        }
    }

    /// [`PackRay::any`], or `None` where that needs the scalar test, which this never calls.
    #[inline(always)]
    fn any_or_fallback(&self, ray: &Ray, pack: &Tri4) -> Option<bool> {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: SSE and SSE2 are part of the x86_64 baseline.
            unsafe { self.any_lanes_or_fallback::<F4>(ray, std::slice::from_ref(pack)) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Some(self.closest_scalar(ray, pack, ray.t_max).is_some())
        }
    }

    /// The nearest hit among the pack's lanes in `(ray.t_min, t_max)`, lowest lane on ties;
    /// bit-identical to `PackRay::closest_scalar`.
    #[inline(always)]
    pub fn closest(&self, ray: &Ray, pack: &Tri4, t_max: f32) -> Option<TriHit> {
        // An edge function exactly zero: the scalar test redoes it in f64.
        self.closest_or_fallback(ray, pack, t_max)
            .unwrap_or_else(|| self.closest_scalar(ray, pack, t_max))
    }

    /// Whether any lane is hit in `(ray.t_min, ray.t_max)`.
    #[inline(always)]
    pub fn any(&self, ray: &Ray, pack: &Tri4) -> bool {
        self.any_or_fallback(ray, pack)
            .unwrap_or_else(|| self.any_exact(ray, std::slice::from_ref(pack)))
    }

    /// Two packs at once with AVX: the same result as [`PackRay::closest`] on `packs[0]`,
    /// then on `packs[1]`.
    ///
    /// # Safety
    /// The CPU must support AVX. Inlined (`inline(always)` rules out `target_feature`), so that
    /// the AVX traversals compile it with their own features.
    #[cfg(all(target_arch = "x86_64", test))]
    #[inline(always)]
    unsafe fn closest_avx(&self, ray: &Ray, packs: &[Tri4], t_max: f32) -> Option<TriHit> {
        self.closest_lanes_or_fallback::<F8>(ray, packs, t_max)
            .unwrap_or_else(|| self.closest_exact(ray, packs, t_max))
    }

    /// Whether a lane of `packs[0]` or `packs[1]` is hit in `(ray.t_min, ray.t_max)`, with AVX.
    ///
    /// # Safety
    /// As [`PackRay::closest_avx`].
    #[cfg(all(target_arch = "x86_64", test))]
    #[inline(always)]
    unsafe fn any_avx(&self, ray: &Ray, packs: &[Tri4]) -> bool {
        self.any_lanes_or_fallback::<F8>(ray, packs)
            .unwrap_or_else(|| self.any_exact(ray, packs))
    }

    /// The nearest hit among the lanes of `packs` (`V::N / 4` of them), lowest lane on ties
    /// (the same result as testing the packs one after the other), or `None` where that
    /// needs the scalar test (an edge function exactly zero in some lane).
    ///
    /// # Safety
    /// The CPU must support `V`'s instructions.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn closest_lanes_or_fallback<V: Lanes>(
        &self,
        ray: &Ray,
        packs: &[Tri4],
        t_max: f32,
    ) -> Option<Option<TriHit>> {
        let l = match self.hits::<V>(ray, packs, t_max) {
            Hits::Miss => return Some(None),
            Hits::Lanes(l) => l,
            Hits::Fallback => return None,
        };
        if l.ok.mask() == 0 {
            return Some(None);
        }
        // Nearest valid lane, lowest index on ties.
        let tm = l.ok.and(l.t).or(l.ok.andnot(V::splat(f32::INFINITY)));
        let lane = l.ok.and(tm.eq(tm.hmin())).mask().trailing_zeros() as usize;
        let mut ts = [0f32; 8];
        let mut vs = [0f32; 8];
        let mut ws = [0f32; 8];
        l.t.store(ts.as_mut_ptr());
        l.v.mul(l.inv).store(vs.as_mut_ptr());
        l.w.mul(l.inv).store(ws.as_mut_ptr());
        let id = packs[lane / PACK].id[lane % PACK];
        debug_assert_ne!(id, NONE, "an unused lane only ties");
        Some(Some(TriHit {
            t: ts[lane],
            prim: id,
            b1: vs[lane],
            b2: ws[lane],
        }))
    }

    /// Whether a lane of `packs` (`V::N / 4` of them) is hit in `(ray.t_min, ray.t_max)`,
    /// or `None` where that needs the scalar test.
    ///
    /// # Safety
    /// The CPU must support `V`'s instructions.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn any_lanes_or_fallback<V: Lanes>(&self, ray: &Ray, packs: &[Tri4]) -> Option<bool> {
        match self.hits::<V>(ray, packs, ray.t_max) {
            Hits::Miss => Some(false),
            Hits::Lanes(l) => Some(l.ok.mask() != 0),
            Hits::Fallback => None,
        }
    }

    /// The watertight test on all lanes of `packs` (`V::N / 4` packs, pack `i` in lanes
    /// `4i..4i + 4`), each lane doing the scalar test's operations in the same order: the lanes
    /// hit in `(ray.t_min, t_max)`, or `Fallback` when an edge function is exactly zero in some
    /// lane.
    ///
    /// # Safety
    /// The CPU must support `V`'s instructions.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn hits<V: Lanes>(&self, ray: &Ray, packs: &[Tri4], t_max: f32) -> Hits<V> {
        debug_assert_eq!(packs.len() * PACK, V::N);
        let [kx, ky, kz] = self.rt.k;
        let s = self.rt.s;
        let zero = V::splat(0.0);
        let (ox, oy, oz) = (
            V::splat(self.o[0]),
            V::splat(self.o[1]),
            V::splat(self.o[2]),
        );
        let (sx, sy, sz) = (V::splat(s.x), V::splat(s.y), V::splat(s.z));
        let (p0, p1) = (&packs[0], &packs[packs.len() - 1]);
        // Vertex k relative to the origin, sheared: (x, y, z-distance term). A macro, not a
        // closure: closures are not always inlined, and then the intrinsics are not either.
        macro_rules! vert {
            ($k:expr) => {{
                let ld = |a: usize| V::load_halves(p0.v[$k][a].as_ptr(), p1.v[$k][a].as_ptr());
                let (dx, dy, dz) = (ld(kx).sub(ox), ld(ky).sub(oy), ld(kz).sub(oz));
                (dx.sub(sx.mul(dz)), dy.sub(sy.mul(dz)), sz.mul(dz))
            }};
        }
        let (ax, ay, az) = vert!(0);
        let (bx, by, bz) = vert!(1);
        let (cx, cy, cz) = vert!(2);
        let u = cx.mul(by).sub(cy.mul(bx));
        let v = ax.mul(cy).sub(ay.mul(cx));
        let w = bx.mul(ay).sub(by.mul(ax));
        if u.eq(zero).or(v.eq(zero)).or(w.eq(zero)).mask() != 0 {
            return Hits::Fallback;
        }
        let neg = u.lt(zero).or(v.lt(zero)).or(w.lt(zero));
        let pos = u.gt(zero).or(v.gt(zero)).or(w.gt(zero));
        // Most packs miss on the edge signs: skip the distance and the division then.
        let outside = neg.and(pos);
        if outside.mask() == (1 << V::N) - 1 {
            return Hits::Miss;
        }
        let det = u.add(v).add(w);
        let t = u.mul(az).add(v.mul(bz)).add(w.mul(cz));
        let inv = V::splat(1.0).div(det);
        let t = t.mul(inv);
        let ok = outside
            .or(det.eq(zero))
            .andnot(t.gt(V::splat(ray.t_min)).and(t.lt(V::splat(t_max))));
        Hits::Lanes(LaneData { ok, t, v, w, inv })
    }
}

/// Result of the lane test: no lane inside its triangle's edges, the lanes' data, or a
/// request for the scalar test.
#[cfg(target_arch = "x86_64")]
enum Hits<V> {
    Miss,
    Lanes(LaneData<V>),
    Fallback,
}

/// Per-lane data of the lane test: hit mask, distance, edge functions `v`, `w` and `1/det`.
#[cfg(target_arch = "x86_64")]
struct LaneData<V> {
    ok: V,
    t: V,
    v: V,
    w: V,
    inv: V,
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
                let got = unsafe { rt.closest_avx(&ray, &[p0, pack], t_max) };
                assert_eq!(bits(got), bits(want), "pair, round {round}");
                // SAFETY: as above.
                let any = unsafe { rt.any_avx(&r, &[p0, pack]) };
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
                let mut leaf = bvh.closest_leaf::<false>(&ray);
                bvh.bvh.closest_leaf_with::<Sse>(&ray, &mut leaf);
                assert_eq!(leaf.hit, got, "n = {n}");
                let any = bvh
                    .bvh
                    .any_leaf_with::<Sse>(&ray, &mut bvh.any_leaf::<false>(&ray));
                assert_eq!(any, best.is_some());
                // The AVX path where the default one uses AVX-512.
                #[cfg(target_arch = "x86_64")]
                if crate::accel::wide::avx() {
                    let mut leaf = bvh.closest_leaf::<false>(&ray);
                    // SAFETY: the CPU supports AVX (checked above).
                    unsafe { bvh.bvh.closest_leaf_avx(&ray, &mut leaf) };
                    assert_eq!(leaf.hit, got, "n = {n}");
                    let mut leaf = bvh.any_leaf::<false>(&ray);
                    // SAFETY: as above.
                    let any = unsafe { bvh.bvh.any_leaf_avx(&ray, &mut leaf) };
                    assert_eq!(any, best.is_some());
                }
            }
        }
    }

    #[test]
    fn rays_through_shared_edges_and_vertices_match_brute_force() {
        // A grid of unit squares, two triangles each, at z = 0: rays from above through grid
        // points and edge midpoints meet edge functions of exactly zero, which the fast
        // traversals leave to the exact redo.
        let mut tris = Vec::new();
        for y in 0..12 {
            for x in 0..12 {
                let p = |dx: u32, dy: u32| Vec3::new((x + dx) as f32, (y + dy) as f32, 0.0);
                tris.push(Triangle {
                    v: [p(0, 0), p(1, 0), p(1, 1)],
                });
                tris.push(Triangle {
                    v: [p(0, 0), p(1, 1), p(0, 1)],
                });
            }
        }
        let bvh = TriangleBvh::build(&tris);
        let mut deferred = 0;
        for y in 0..=24 {
            for x in 0..=24 {
                let target = Vec3::new(x as f32 * 0.5, y as f32 * 0.5, 0.0);
                for o in [Vec3::new(0.0, 0.0, 3.0), Vec3::new(0.5, -0.25, 2.0)] {
                    let ray = Ray::new(target + o, -o.normalize());
                    let rt = RayTri::new(&ray);
                    let mut best: Option<f32> = None;
                    for t in &tris {
                        let t_max = best.unwrap_or(ray.t_max);
                        if let Some((d, _, _)) = intersect_triangle(&ray, &rt, t, t_max) {
                            best = Some(d);
                        }
                    }
                    let got = bvh.closest(&ray).map(|h| h.t);
                    assert_eq!(got.map(f32::to_bits), best.map(f32::to_bits), "{target}");
                    assert_eq!(bvh.any(&ray), best.is_some(), "{target}");
                    let mut leaf = bvh.closest_leaf::<true>(&ray);
                    bvh.bvh.closest_leaf(&ray, &mut leaf);
                    deferred += usize::from(leaf.fallback);
                }
            }
        }
        assert!(deferred > 0, "no ray needed the exact redo");
    }

    #[test]
    fn empty_triangle_bvh_hits_nothing() {
        let bvh = TriangleBvh::build(&[]);
        assert!(bvh.closest(&Ray::new(Vec3::ZERO, Vec3::X)).is_none());
        assert!(!bvh.any(&Ray::new(Vec3::ZERO, Vec3::X)));
    }
}
