//! Wide BVHs (4 or 8 children per node) collapsed from the binary SAH tree, with the child
//! boxes of a node tested at once (SSE on x86_64, four boxes per instruction, or AVX, eight,
//! compiled for AVX-512 where the CPU has it; a scalar loop elsewhere and as the reference)
//! and ordered traversal: closest-hit queries descend into the nearest hit child and visit the
//! others nearest first, any-hit queries stop at the first hit.

use super::bvh::Bvh;
#[cfg(target_arch = "x86_64")]
use super::simd::{Lanes, F4, F8};
use crate::math::{Aabb, Ray};
use crate::memory::{huge_pages, prefetch_bytes, LARGE_BYTES};
use glam::Vec3;
use std::mem::MaybeUninit;

/// Marks an empty child slot.
const EMPTY: u32 = u32::MAX;
/// Traversal stack entries. A wide tree is never deeper than the binary tree it was
/// collapsed from, whose SAH build switches to median splits at depth 32 (depth ≤ 32 + log2 n
/// ≤ 64), and each level pushes at most W − 1 more entries than it pops: 7·64 + 1 < 512.
/// The push guard is only a memory-safety net (a debug assertion flags it).
const STACK: usize = 512;

/// One node: `W` child boxes in structure-of-arrays layout (W = 4: 128 bytes, two cache
/// lines; W = 8: 256 bytes). `W` must be 4 or 8.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node<const W: usize> {
    /// Slab planes `planes[row][child]`: rows 0–2 are the lower corners' x, y, z, rows 3–5
    /// the upper corners'. Empty slots hold +∞ (never hit).
    pub planes: [[f32; W]; 6],
    /// Interior child: node index; leaf child: first primitive slot; empty: `u32::MAX`.
    pub child: [u32; W],
    /// Primitive count of a leaf child; 0 for interior and empty slots.
    pub count: [u16; W],
    /// Bit `i` set when slot `i` holds a child (empty slots must never be entered: their +∞
    /// boxes would pass the slab test of a ray with an infinite `t_max`).
    pub valid: u32,
}

/// A wide BVH; `prims` are the binary tree's primitive ids in leaf order.
#[derive(Clone, Debug)]
pub struct WideBvh<const W: usize> {
    /// Nodes; node 0 is the root (none in the `Default` tree, which hits nothing).
    pub nodes: Vec<Node<W>>,
    /// Primitive ids in leaf order.
    pub prims: Vec<u32>,
    /// Whether the structure is larger than a core's L2 cache ([`LARGE_BYTES`]; builds set it
    /// from the structure's size). Its node loads then mostly miss the cache, which changes
    /// what is fastest: closest-hit traversals prefetch the entries they push, and any-hit
    /// traversals push every hit child and pop the last, a loop with one branch per node.
    /// On a smaller structure that costs a few percent: any-hit traversals descend directly
    /// into the last hit child there and push the others. Either pushes without a branch per
    /// child (every slot is written, the stack pointer raised past the hit ones), whose
    /// mispredictions cost more than the writes.
    pub large: bool,
}

impl<const W: usize> Default for WideBvh<W> {
    fn default() -> Self {
        WideBvh {
            nodes: Vec::new(),
            prims: Vec::new(),
            large: false,
        }
    }
}

/// A 4-wide node.
pub type Node4 = Node<4>;
/// An 8-wide node.
pub type Node8 = Node<8>;
/// The 4-wide BVH.
pub type Bvh4 = WideBvh<4>;
/// The 8-wide BVH.
pub type Bvh8 = WideBvh<8>;

impl<const W: usize> Node<W> {
    /// The box of slot `i`.
    pub fn slot_box(&self, i: usize) -> Aabb {
        let p = |r: usize| {
            Vec3::new(
                self.planes[r][i],
                self.planes[r + 1][i],
                self.planes[r + 2][i],
            )
        };
        Aabb {
            min: p(0),
            max: p(3),
        }
    }
}

/// Per-ray data for the box tests.
#[derive(Clone, Copy)]
pub struct RayBox {
    o: [f32; 3],
    inv: [f32; 3],
    /// Plane row through which the ray enters each axis's slab: the lower corner for a
    /// positive direction component, the upper one for a negative.
    near: [usize; 3],
    /// Plane row through which the ray leaves each axis's slab (the other corner).
    far: [usize; 3],
    /// `inv` scaled by [`FAR_SCALE`], for the exit distances.
    inv_far: [f32; 3],
}

/// Exit distances are scaled up by this factor (pbrt's 1 + 2γ₃, with room for the rounding of
/// the scaled reciprocal itself) so that rounding never culls a box the ray passes through.
const FAR_SCALE: f32 = 1.000_000_4;

impl RayBox {
    /// Prepares `ray`. A zero direction component gives an infinite inverse, and a NaN
    /// distance where the ray lies in one of that axis's planes; the box tests take the
    /// bounds in an order that drops a NaN (`maxps`/`minps` return the second operand), so
    /// that slab then does not constrain the ray, as it should not.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let inv = ray.d.recip();
        let neg = |a: usize| usize::from(inv[a] < 0.0);
        RayBox {
            o: ray.o.to_array(),
            inv: inv.to_array(),
            near: [3 * neg(0), 1 + 3 * neg(1), 2 + 3 * neg(2)],
            far: [3 - 3 * neg(0), 4 - 3 * neg(1), 5 - 3 * neg(2)],
            inv_far: (inv * FAR_SCALE).to_array(),
        }
    }
}

/// Scalar slab test of a node's `W` boxes: bit `i` of the mask is set when child `i`'s box is
/// hit within `(t_min, t_max)`; `near[i]` is its entry distance.
#[inline]
pub fn hit_scalar<const W: usize>(
    n: &Node<W>,
    r: &RayBox,
    t_min: f32,
    t_max: f32,
) -> (u32, [f32; W]) {
    let mut mask = 0;
    let mut near = [0f32; W];
    let t_far = t_max * FAR_SCALE;
    for (i, nr) in near.iter_mut().enumerate() {
        // `maxps`/`minps` semantics (the second operand on ties and NaN), so that even the
        // sign of a zero distance matches the SIMD versions; pairs, not a chain, to keep the
        // dependency chain short there. A NaN distance (see `RayBox::new`) is dropped where
        // it is the first operand; as the second it drops its partner instead, so the bounds
        // only widen.
        let max = |a: f32, b: f32| if a > b { a } else { b };
        let min = |a: f32, b: f32| if a < b { a } else { b };
        let t0 = |a: usize| (n.planes[r.near[a]][i] - r.o[a]) * r.inv[a];
        let t1 = |a: usize| (n.planes[r.far[a]][i] - r.o[a]) * r.inv_far[a];
        let lo = max(max(t0(0), t0(1)), max(t0(2), t_min));
        let hi = min(min(t1(0), t1(1)), min(t1(2), t_far));
        *nr = lo;
        if lo <= hi {
            mask |= 1 << i;
        }
    }
    (mask, near)
}

/// SSE version of [`hit_scalar`] (four boxes per instruction), with identical results.
#[cfg(target_arch = "x86_64")]
#[inline]
pub fn hit<const W: usize>(n: &Node<W>, r: &RayBox, t_min: f32, t_max: f32) -> (u32, [f32; W]) {
    // SAFETY: SSE and SSE2 are part of the x86_64 baseline.
    unsafe { hit_lanes::<F4, W>(n, r, t_min, t_max) }
}

/// [`hit_scalar`] with `V::N` boxes per instruction (`W` must be a multiple of `V::N`).
///
/// # Safety
/// The CPU must support `V`'s instructions.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn hit_lanes<V: Lanes, const W: usize>(
    n: &Node<W>,
    r: &RayBox,
    t_min: f32,
    t_max: f32,
) -> (u32, [f32; W]) {
    debug_assert!(W.is_multiple_of(V::N));
    let mut mask = 0;
    let mut near = [0f32; W];
    // Not `step_by`, which the compiler does not always unroll. Loads and stores are
    // unaligned and stay inside the W-float rows (h + N ≤ W).
    for h in (0..W / V::N).map(|c| V::N * c) {
        let t = |a: usize, row: &[usize; 3], inv: &[f32; 3]| {
            let p = V::load(n.planes[row[a]].as_ptr().add(h));
            p.sub(V::splat(r.o[a])).mul(V::splat(inv[a]))
        };
        let lo = (t(0, &r.near, &r.inv).max(t(1, &r.near, &r.inv)))
            .max(t(2, &r.near, &r.inv).max(V::splat(t_min)));
        let hi = (t(0, &r.far, &r.inv_far).min(t(1, &r.far, &r.inv_far)))
            .min(t(2, &r.far, &r.inv_far).min(V::splat(t_max * FAR_SCALE)));
        lo.store(near.as_mut_ptr().add(h));
        mask |= lo.le(hi).mask() << h;
    }
    (mask, near)
}

/// Scalar fallback on other architectures.
#[cfg(not(target_arch = "x86_64"))]
#[inline]
pub fn hit<const W: usize>(n: &Node<W>, r: &RayBox, t_min: f32, t_max: f32) -> (u32, [f32; W]) {
    hit_scalar(n, r, t_min, t_max)
}

/// Pushes the children of `n` whose bits are set in `mask` onto `stack` from slot `sp`, in
/// slot order, and returns the new stack pointer (`sp + W ≤ STACK`). Every slot is written and
/// the pointer raised past the hit ones only: no branch per child to mispredict.
#[inline(always)]
fn push_hit_children<const W: usize>(
    stack: &mut [MaybeUninit<(u32, u32)>; STACK],
    mut sp: usize,
    n: &Node<W>,
    mut mask: u32,
) -> usize {
    for i in 0..W {
        stack[sp].write((n.child[i], n.count[i] as u32));
        sp += (mask & 1) as usize;
        mask >>= 1;
    }
    sp
}

/// A box test for the traversal: `Sse` (or scalar) everywhere, `Avx` where the CPU has it.
/// A closest-hit leaf test: the nearest hit distance in `(ray.t_min, t_max)` among the `count`
/// entries from slot `first`. Implemented by closures; a type of its own with an
/// `#[inline(always)]` method makes sure the test is compiled into the traversal.
pub trait LeafClosest {
    /// Tests the leaf.
    fn test(&mut self, first: u32, count: u32, t_max: f32) -> Option<f32>;
    /// Hint that the leaf will be tested soon.
    #[inline(always)]
    fn prefetch(&self, _first: u32, _count: u32) {}
}

impl<F: FnMut(u32, u32, f32) -> Option<f32>> LeafClosest for F {
    #[inline(always)]
    fn test(&mut self, first: u32, count: u32, t_max: f32) -> Option<f32> {
        self(first, count, t_max)
    }
}

/// An any-hit leaf test: whether any of the `count` entries from slot `first` is hit.
pub trait LeafAny {
    /// Tests the leaf.
    fn test(&mut self, first: u32, count: u32) -> bool;
}

impl<F: FnMut(u32, u32) -> bool> LeafAny for F {
    #[inline(always)]
    fn test(&mut self, first: u32, count: u32) -> bool {
        self(first, count)
    }
}

pub(crate) trait BoxTest {
    /// As [`hit_scalar`].
    ///
    /// # Safety
    /// The CPU must support the instructions of the implementation.
    unsafe fn hit<const W: usize>(
        n: &Node<W>,
        r: &RayBox,
        t_min: f32,
        t_max: f32,
    ) -> (u32, [f32; W]);
}

/// The baseline box test ([`hit`]).
pub(crate) struct Sse;

impl BoxTest for Sse {
    #[inline(always)]
    unsafe fn hit<const W: usize>(
        n: &Node<W>,
        r: &RayBox,
        t_min: f32,
        t_max: f32,
    ) -> (u32, [f32; W]) {
        hit(n, r, t_min, t_max)
    }
}

/// Whether the CPU supports AVX (cached by the standard library).
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn avx() -> bool {
    std::arch::is_x86_feature_detected!("avx")
}

/// Whether the CPU supports AVX-512 F and VL. The AVX traversals are then compiled for
/// AVX-512 too: the same 8-wide instructions, with 32 vector registers instead of 16, so the
/// per-ray constants stay in registers.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn avx512() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512vl")
}

/// Eight boxes per instruction with AVX (for widths that are multiples of 8; [`hit`] for
/// the others), with results identical to [`hit_scalar`].
#[cfg(target_arch = "x86_64")]
pub(crate) struct Avx;

#[cfg(not(target_arch = "x86_64"))]
pub(crate) struct Avx;

#[cfg(not(target_arch = "x86_64"))]
impl BoxTest for Avx {
    #[inline(always)]
    unsafe fn hit<const W: usize>(
        n: &Node<W>,
        r: &RayBox,
        t_min: f32,
        t_max: f32,
    ) -> (u32, [f32; W]) {
        hit(n, r, t_min, t_max)
    }
}

#[cfg(target_arch = "x86_64")]
impl BoxTest for Avx {
    /// Always inlined (which rules out `target_feature`): the AVX traversals, compiled with
    /// their own features, then compile it for AVX or AVX-512.
    #[inline(always)]
    unsafe fn hit<const W: usize>(
        n: &Node<W>,
        r: &RayBox,
        t_min: f32,
        t_max: f32,
    ) -> (u32, [f32; W]) {
        if W.is_multiple_of(8) {
            hit_lanes::<F8, W>(n, r, t_min, t_max)
        } else {
            hit(n, r, t_min, t_max)
        }
    }
}

/// SAH cost of visiting a wide node, for the collapse (dynamic programming); each cost is weighted by
/// the surface area of the box that leads to it.
const COST_NODE: f32 = 1.0;
/// SAH cost of testing a leaf, beside [`COST_PRIM`] per primitive in it.
const COST_LEAF: f32 = 1.0;
/// SAH cost of each primitive of a leaf (pack tests handle several at once).
const COST_PRIM: f32 = 0.1;

/// SAH cost of testing a leaf of `count` primitives (before the area weight).
fn leaf_cost_per_area(count: u32) -> f32 {
    COST_LEAF + COST_PRIM * count as f32
}

/// The optimal collapse of a binary tree into a `W`-wide one (Ylitie, Karras and Laine
/// 2017, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs"): for every
/// binary node and every number of slots `i` (1 to `W`), the least SAH cost of its subtree
/// when it may take up to `i` slots of its wide parent, by dynamic programming bottom-up.
struct Plan {
    /// `cost[n * W + i - 1]`.
    cost: Vec<f32>,
    /// How node `n` takes up to `i` slots: `(0, 0)` = one slot (a leaf when `leaf[n]`, else a
    /// wide node), else opened, its left child taking up to `.0` slots and its right `.1`.
    pick: Vec<(u8, u8)>,
    /// Whether node `n` in one slot is a leaf.
    leaf: Vec<bool>,
    /// The left child's share of the `W` slots when node `n` is a wide node.
    wide_split: Vec<u8>,
}

/// (first primitive slot, primitive count) of every binary subtree.
fn subtree_ranges(b: &Bvh) -> Vec<(u32, u32)> {
    // Children follow their parent in the depth-first order, so a reverse sweep sees them
    // first.
    let mut range = vec![(0u32, 0u32); b.nodes.len()];
    for i in (0..b.nodes.len()).rev() {
        let n = &b.nodes[i];
        range[i] = if n.count > 0 {
            (n.offset, n.count as u32)
        } else {
            let (l, r) = (range[i + 1], range[n.offset as usize]);
            (l.0, l.1 + r.1)
        };
    }
    range
}

impl Plan {
    fn new<const W: usize>(
        b: &Bvh,
        range: &[(u32, u32)],
        is_leaf: &impl Fn(usize) -> bool,
    ) -> Plan {
        let n = b.nodes.len();
        let mut p = Plan {
            cost: vec![f32::INFINITY; n * W],
            pick: vec![(0, 0); n * W],
            leaf: vec![false; n],
            wide_split: vec![1; n],
        };
        for i in (0..n).rev() {
            let node = &b.nodes[i];
            let area = node.bounds().area();
            let leaf_cost = if is_leaf(i) {
                area * leaf_cost_per_area(range[i].1)
            } else {
                f32::INFINITY
            };
            if node.count > 0 {
                p.leaf[i] = true;
                p.cost[i * W..(i + 1) * W].fill(leaf_cost);
                continue;
            }
            let (l, r) = (i + 1, node.offset as usize);
            // Opening node i into up to j slots: the best share of the left child.
            let mut open = [(f32::INFINITY, 0u8); 9];
            for (j, o) in open.iter_mut().enumerate().take(W + 1).skip(2) {
                for k in 1..j {
                    let c = p.cost[l * W + k - 1] + p.cost[r * W + j - k - 1];
                    if c < o.0 {
                        *o = (c, k as u8);
                    }
                }
            }
            let internal = area * COST_NODE + open[W].0;
            p.wide_split[i] = open[W].1;
            p.leaf[i] = leaf_cost <= internal;
            p.cost[i * W] = leaf_cost.min(internal);
            for (j, &(c, k)) in open.iter().enumerate().take(W + 1).skip(2) {
                let (prev, prev_pick) = (p.cost[i * W + j - 2], p.pick[i * W + j - 2]);
                (p.cost[i * W + j - 1], p.pick[i * W + j - 1]) = if c < prev {
                    (c, (k, j as u8 - k))
                } else {
                    (prev, prev_pick)
                };
            }
        }
        p
    }

    /// Appends the slots binary node `n` takes when it may take up to `i`: `(node, is_leaf)`.
    fn gather<const W: usize>(&self, b: &Bvh, n: usize, i: usize, out: &mut Vec<(usize, bool)>) {
        match self.pick[n * W + i - 1] {
            (0, _) => out.push((n, self.leaf[n])),
            (kl, kr) => {
                self.gather::<W>(b, n + 1, kl as usize, out);
                self.gather::<W>(b, b.nodes[n].offset as usize, kr as usize, out);
            }
        }
    }
}

/// A traversal's public entry point, which picks the widest box test the CPU supports at run
/// time, and its AVX and AVX-512 compilations (`$with::<T>` is the traversal over box test
/// `T`). A macro rather than a generic dispatcher: each traversal keeps exactly the code it
/// had, which a trait over the queries did not (any-hit was slower through one).
macro_rules! dispatch {
    ($(#[$doc:meta])* $name:ident, $avx:ident, $avx512:ident, $with:ident, $leaf:ident, $ret:ty) => {
        $(#[$doc])*
        #[inline]
        pub fn $name(&self, ray: &Ray, leaf: impl $leaf) -> $ret {
            #[cfg(target_arch = "x86_64")]
            if W.is_multiple_of(8) && avx512() {
                // SAFETY: the CPU supports AVX-512 F and VL (checked at run time).
                return unsafe { self.$avx512(ray, leaf) };
            }
            #[cfg(target_arch = "x86_64")]
            if W.is_multiple_of(8) && avx() {
                // SAFETY: the CPU supports AVX (checked at run time).
                return unsafe { self.$avx(ray, leaf) };
            }
            self.$with::<Sse>(ray, leaf)
        }

        /// The traversal compiled with AVX box tests.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx")]
        pub(crate) unsafe fn $avx(&self, ray: &Ray, leaf: impl $leaf) -> $ret {
            self.$with::<Avx>(ray, leaf)
        }

        /// The traversal compiled for AVX-512 (the AVX box tests with 32 registers).
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512vl")]
        unsafe fn $avx512(&self, ray: &Ray, leaf: impl $leaf) -> $ret {
            self.$with::<Avx>(ray, leaf)
        }
    };
}

impl<const W: usize> WideBvh<W> {
    /// Collapses a binary BVH into the `W`-wide tree of least SAH cost that keeps its subtrees
    /// (dynamic programming): each wide node takes up to `W` binary descendants. A binary leaf, or a
    /// binary subtree holding at most `max_leaf` primitives, may become one leaf (its
    /// primitives are contiguous in leaf order), so that leaves can be tested as a pack.
    pub fn from_binary(b: &Bvh, max_leaf: usize) -> Self {
        let mut out = WideBvh {
            nodes: Vec::with_capacity(b.nodes.len() / 2 + 1),
            prims: b.prims.clone(),
            large: false,
        };
        if b.prims.is_empty() {
            out.nodes.push(Self::empty_node());
            return out;
        }
        let range = subtree_ranges(b);
        let max_leaf = max_leaf.min(u16::MAX as usize) as u32;
        let is_leaf = |i: usize| b.nodes[i].count > 0 || range[i].1 <= max_leaf;
        if is_leaf(0) {
            // A single leaf: a root with one leaf child.
            let mut n = Self::empty_node();
            Self::set_slot(&mut n, 0, b, 0, range[0].0, range[0].1);
            out.nodes.push(n);
            return out;
        }
        let plan = Plan::new::<W>(b, &range, &is_leaf);
        out.emit(b, &plan, 0, &range);
        out.large = out.nodes.len() * std::mem::size_of::<Node<W>>()
            + out.prims.len() * std::mem::size_of::<u32>()
            > LARGE_BYTES;
        out.nodes = huge_pages(std::mem::take(&mut out.nodes));
        out
    }

    fn empty_node() -> Node<W> {
        Node {
            planes: [[f32::INFINITY; W]; 6],
            child: [EMPTY; W],
            count: [0; W],
            valid: 0,
        }
    }

    fn set_slot(n: &mut Node<W>, slot: usize, b: &Bvh, bnode: usize, child: u32, count: u32) {
        let node = &b.nodes[bnode];
        for a in 0..3 {
            n.planes[a][slot] = node.min[a];
            n.planes[3 + a][slot] = node.max[a];
        }
        n.child[slot] = child;
        n.count[slot] = count as u16;
        n.valid |= 1 << slot;
    }

    /// Emits the wide node for binary node `bnode` as `plan` lays it out; returns its index.
    fn emit(&mut self, b: &Bvh, plan: &Plan, bnode: usize, range: &[(u32, u32)]) -> u32 {
        let mut kids = Vec::with_capacity(W);
        let (l, r) = (bnode + 1, b.nodes[bnode].offset as usize);
        let k = plan.wide_split[bnode] as usize;
        plan.gather::<W>(b, l, k, &mut kids);
        plan.gather::<W>(b, r, W - k, &mut kids);
        let index = self.nodes.len();
        self.nodes.push(Self::empty_node());
        for (slot, &(k, leaf)) in kids.iter().enumerate() {
            let (child, count) = if leaf {
                range[k]
            } else {
                (self.emit(b, plan, k, range), 0)
            };
            let mut n = self.nodes[index];
            Self::set_slot(&mut n, slot, b, k, child, count);
            self.nodes[index] = n;
        }
        index as u32
    }

    dispatch! {
        /// Closest-hit traversal over leaves: `leaf(first, count, t_max)` tests the leaf's
        /// `count` entries from slot `first` and returns the nearest hit distance in
        /// `(ray.t_min, t_max)`, if any. Returns the closest distance found (or `ray.t_max`).
        closest_leaf, closest_leaf_avx, closest_leaf_avx512, closest_leaf_with, LeafClosest, f32
    }

    /// Prefetches entry `(child, count)` (a node, or the leaf through `leaf`) on a large tree:
    /// entries pushed for later are then on their way from memory while the nearer subtree is
    /// traversed.
    #[inline(always)]
    fn prefetch(&self, child: u32, count: u32, leaf: &impl LeafClosest) {
        if !self.large {
            return;
        }
        if count > 0 {
            leaf.prefetch(child, count);
        } else {
            let node = self.nodes.as_ptr().wrapping_add(child as usize);
            prefetch_bytes(node as *const u8, std::mem::size_of::<Node<W>>());
        }
    }

    /// The closest-hit traversal with box test `T`.
    #[inline(always)]
    pub(crate) fn closest_leaf_with<T: BoxTest>(
        &self,
        ray: &Ray,
        mut leaf: impl LeafClosest,
    ) -> f32 {
        let mut t_max = ray.t_max;
        if self.nodes.is_empty() {
            return t_max;
        }
        let r = RayBox::new(ray);
        // Entries: (child, count, entry distance); count 0 = interior node. Only entries
        // below `sp` are ever read, so the array needs no initialisation.
        let mut stack = [MaybeUninit::<(u32, u32, f32)>::uninit(); STACK];
        let mut sp = 0;
        // The current entry: the root first.
        let (mut child, mut count) = (0u32, 0u32);
        loop {
            // Descend into the nearest hit child and push the others, as Embree does. The
            // first two children are ordered with selects rather than branches: for scattered
            // rays their order is a coin flip, and a mispredicted branch costs more than
            // waiting for the box test.
            while count == 0 {
                let n = &self.nodes[child as usize];
                // SAFETY: `T` is `Avx` only inside the AVX-enabled functions.
                let (mask, dist) = unsafe { T::hit(n, &r, ray.t_min, t_max) };
                let mut mask = mask & n.valid;
                if mask == 0 {
                    break;
                }
                let i0 = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let e0 = (n.child[i0], n.count[i0] as u32, dist[i0]);
                if mask == 0 {
                    (child, count) = (e0.0, e0.1);
                    continue;
                }
                let i1 = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let e1 = (n.child[i1], n.count[i1] as u32, dist[i1]);
                // Ties keep the lower slot first.
                let first = e0.2 <= e1.2;
                let near = if first { e0 } else { e1 };
                let far = if first { e1 } else { e0 };
                (child, count) = (near.0, near.1);
                debug_assert!(sp + W <= STACK, "traversal stack overflow");
                if sp + W > STACK {
                    continue;
                }
                stack[sp].write(far);
                sp += 1;
                self.prefetch(far.0, far.1, &leaf);
                if mask == 0 {
                    continue;
                }
                // Three or more: insert the rest into the pushed run (kept far to near), then
                // continue with its nearest entry.
                let base = sp - 1;
                stack[sp].write(near);
                sp += 1;
                while mask != 0 {
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let e = (n.child[i], n.count[i] as u32, dist[i]);
                    self.prefetch(e.0, e.1, &leaf);
                    let mut j = sp;
                    // SAFETY: slots base..sp were written above.
                    while j > base && unsafe { stack[j - 1].assume_init().2 } < e.2 {
                        stack[j] = stack[j - 1];
                        j -= 1;
                    }
                    stack[j].write(e);
                    sp += 1;
                }
                sp -= 1;
                // SAFETY: written above.
                let (c, k, _) = unsafe { stack[sp].assume_init() };
                (child, count) = (c, k);
            }
            if count > 0 {
                if let Some(t) = leaf.test(child, count, t_max) {
                    t_max = t;
                }
            }
            // Pop the next entry that may still hold a nearer hit.
            loop {
                if sp == 0 {
                    return t_max;
                }
                sp -= 1;
                // SAFETY: every slot below the stack pointer was written before it was raised.
                let (c, k, near) = unsafe { stack[sp].assume_init() };
                // Scaled as in the box test: the entry distance may be rounded up, and a hit
                // lying on the box's face must not be culled.
                if near <= t_max * FAR_SCALE {
                    child = c;
                    count = k;
                    break;
                }
            }
        }
    }

    dispatch! {
        /// Any-hit traversal over leaves: true as soon as `leaf(first, count)` reports a hit
        /// in `(ray.t_min, ray.t_max)`.
        any_leaf, any_leaf_avx, any_leaf_avx512, any_leaf_with, LeafAny, bool
    }

    /// The any-hit traversal with box test `T`.
    #[inline(always)]
    pub(crate) fn any_leaf_with<T: BoxTest>(&self, ray: &Ray, mut leaf: impl LeafAny) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let r = RayBox::new(ray);
        // Entries: (child, count); count 0 = interior node. Only entries below `sp` are ever
        // read, so the array needs no initialisation.
        let mut stack = [MaybeUninit::<(u32, u32)>::uninit(); STACK];
        if !self.large {
            // Descend into the last hit child (the same order as below) and push the others.
            let mut sp = 0;
            let (mut child, mut count) = (0u32, 0u32);
            loop {
                while count == 0 {
                    let n = &self.nodes[child as usize];
                    // SAFETY: `T` is `Avx` only inside the AVX-enabled functions.
                    let (mask, _) = unsafe { T::hit(n, &r, ray.t_min, ray.t_max) };
                    let mut mask = mask & n.valid;
                    if mask == 0 {
                        break;
                    }
                    let i = 31 - mask.leading_zeros() as usize;
                    mask &= !(1 << i);
                    (child, count) = (n.child[i], n.count[i] as u32);
                    debug_assert!(sp + W <= STACK, "traversal stack overflow");
                    if sp + W <= STACK {
                        sp = push_hit_children(&mut stack, sp, n, mask);
                    }
                }
                if count > 0 && leaf.test(child, count) {
                    return true;
                }
                if sp == 0 {
                    return false;
                }
                sp -= 1;
                // SAFETY: every slot below the stack pointer was written before it was raised.
                (child, count) = unsafe { stack[sp].assume_init() };
            }
        }
        // Push every hit child; pop the last.
        let mut sp = 1;
        stack[0].write((0, 0));
        while sp > 0 {
            sp -= 1;
            // SAFETY: every slot below the stack pointer was written before it was raised.
            let (child, count) = unsafe { stack[sp].assume_init() };
            if count > 0 {
                if leaf.test(child, count) {
                    return true;
                }
                continue;
            }
            let n = &self.nodes[child as usize];
            // SAFETY: `T` is `Avx` only inside the AVX-enabled functions.
            let (mask, _) = unsafe { T::hit(n, &r, ray.t_min, ray.t_max) };
            let mask = mask & n.valid;
            debug_assert!(sp + W <= STACK, "traversal stack overflow");
            if mask == 0 || sp + W > STACK {
                continue;
            }
            sp = push_hit_children(&mut stack, sp, n, mask);
        }
        false
    }

    /// Closest-hit traversal over single primitives: `test(prim, t_max)` returns the hit
    /// distance of `prim` if it is hit in `(ray.t_min, t_max)`. Returns the closest distance
    /// found (or `ray.t_max`).
    #[inline]
    pub fn closest(&self, ray: &Ray, mut test: impl FnMut(u32, f32) -> Option<f32>) -> f32 {
        self.closest_leaf(ray, |first, count, t_max| {
            let mut best = None;
            let mut t_max = t_max;
            for &p in &self.prims[first as usize..(first + count) as usize] {
                if let Some(t) = test(p, t_max) {
                    t_max = t;
                    best = Some(t);
                }
            }
            best
        })
    }

    /// Any-hit traversal over single primitives: true as soon as `test(prim)` reports a hit
    /// in `(ray.t_min, ray.t_max)`.
    #[inline]
    pub fn any(&self, ray: &Ray, mut test: impl FnMut(u32) -> bool) -> bool {
        self.any_leaf(ray, |first, count| {
            self.prims[first as usize..(first + count) as usize]
                .iter()
                .any(|&p| test(p))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{uniform_sphere, Rng};

    #[test]
    fn simd_and_scalar_box_tests_agree() {
        box_tests_agree::<4>();
        box_tests_agree::<8>();
    }

    fn box_tests_agree<const W: usize>() {
        let mut rng = Rng::new(3, 9);
        for _ in 0..20_000 {
            let mut n = WideBvh::<W>::empty_node();
            for i in 0..W - 1 {
                let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
                let e = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                for a in 0..3 {
                    n.planes[a][i] = c[a] - e[a];
                    n.planes[3 + a][i] = c[a] + e[a];
                }
            }
            // A flat box (zero extent on one axis) in the last slot exercises the boundary cases.
            for a in 0..3 {
                n.planes[a][W - 1] = if a == 1 { 0.5 } else { -1.0 };
                n.planes[3 + a][W - 1] = if a == 1 { 0.5 } else { 1.0 };
            }
            let mut d = uniform_sphere(rng.next_2d());
            let u = rng.next_f32();
            if u < 0.2 {
                d.x = 0.0;
            } else if u < 0.4 {
                d.y = -0.0;
            }
            let mut o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
            if rng.next_f32() < 0.2 {
                // On the flat box's plane.
                o.y = 0.5;
            }
            let ray = Ray::new(o, d.normalize());
            let r = RayBox::new(&ray);
            let (m1, n1) = hit(&n, &r, 0.0, 10.0);
            let (m2, n2) = hit_scalar(&n, &r, 0.0, 10.0);
            assert_eq!(m1, m2);
            // The flat box is never culled where the ray meets it: an axis along which the
            // ray does not move constrains it only by the origin (a ray lying in the box's
            // plane included).
            let b = n.slot_box(W - 1);
            let (mut lo, mut hi) = (0.0f32, 10.0f32);
            for a in 0..3 {
                if ray.d[a] == 0.0 {
                    if ray.o[a] < b.min[a] || ray.o[a] > b.max[a] {
                        hi = -1.0;
                    }
                } else {
                    let t0 = (b.min[a] - ray.o[a]) / ray.d[a];
                    let t1 = (b.max[a] - ray.o[a]) / ray.d[a];
                    lo = lo.max(t0.min(t1));
                    hi = hi.min(t0.max(t1));
                }
            }
            if lo < hi * 0.999 {
                assert_ne!(m2 & (1 << (W - 1)), 0, "flat box culled: {ray:?}");
            }
            for i in 0..W {
                if m1 & (1 << i) != 0 {
                    assert_eq!(n1[i].to_bits(), n2[i].to_bits());
                }
            }
            #[cfg(target_arch = "x86_64")]
            if avx() {
                // SAFETY: the CPU supports AVX.
                let (m3, n3) = unsafe { Avx::hit(&n, &r, 0.0, 10.0) };
                assert_eq!(m3, m2);
                for i in 0..W {
                    if m3 & (1 << i) != 0 {
                        assert_eq!(n3[i].to_bits(), n2[i].to_bits());
                    }
                }
            }
        }
    }

    #[test]
    fn huge_page_buffers_keep_their_contents() {
        for n in [0, 1000, LARGE_BYTES / 4 + 1234] {
            let v: Vec<u32> = (0..n as u32)
                .map(|i| i.wrapping_mul(2_654_435_761))
                .collect();
            assert_eq!(huge_pages(v.clone()), v, "n = {n}");
        }
    }

    #[test]
    fn wide_tree_matches_binary_tree() {
        // Random boxes as primitives; the test closure is an exact slab test per box.
        let mut rng = Rng::new(5, 6);
        let boxes: Vec<Aabb> = (0..3000)
            .map(|_| {
                let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
                Aabb {
                    min: c,
                    max: c + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.3,
                }
            })
            .collect();
        let bin = Bvh::build(&boxes);
        // Both traversal variants on this small tree: as it is and as if it were large.
        for max_leaf in [0, 4, 9] {
            for large in [false, true] {
                check_wide_against_binary::<4>(&bin, &boxes, max_leaf, large, &mut rng);
                check_wide_against_binary::<8>(&bin, &boxes, max_leaf, large, &mut rng);
            }
        }
    }

    /// The SAH cost of a wide tree under the collapse's cost model.
    fn sah_cost<const W: usize>(wide: &WideBvh<W>) -> f64 {
        let mut cost = 0.0;
        for n in &wide.nodes {
            let mut node_box = Aabb::EMPTY;
            for i in (0..W).filter(|i| n.valid & (1 << i) != 0) {
                let b = n.slot_box(i);
                node_box = node_box.union(&b);
                if n.count[i] > 0 {
                    cost += f64::from(b.area() * leaf_cost_per_area(n.count[i].into()));
                }
            }
            cost += f64::from(node_box.area() * COST_NODE);
        }
        cost
    }

    /// The cost the collapse predicts for its tree, and the cost of the plainest collapse:
    /// every interior binary node a wide node, every binary leaf a leaf.
    fn planned_and_plain_cost<const W: usize>(bin: &Bvh, max_leaf: usize) -> (f64, f64) {
        let range = subtree_ranges(bin);
        let is_leaf = |i: usize| bin.nodes[i].count > 0 || range[i].1 <= max_leaf as u32;
        let plan = Plan::new::<W>(bin, &range, &is_leaf);
        let plain = bin
            .nodes
            .iter()
            .map(|n| {
                let c = if n.count > 0 {
                    leaf_cost_per_area(n.count.into())
                } else {
                    COST_NODE
                };
                f64::from(n.bounds().area() * c)
            })
            .sum();
        (f64::from(plan.cost[0]), plain)
    }

    #[test]
    fn collapse_reaches_its_planned_cost_and_beats_the_plain_one() {
        let mut rng = Rng::new(8, 1);
        let boxes: Vec<Aabb> = (0..5000)
            .map(|_| {
                let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
                let e = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()).powf(3.0);
                Aabb { min: c, max: c + e }
            })
            .collect();
        let bin = Bvh::build(&boxes);
        for max_leaf in [0, 4, 8] {
            let (planned, plain) = planned_and_plain_cost::<8>(&bin, max_leaf);
            let got = sah_cost(&WideBvh::<8>::from_binary(&bin, max_leaf));
            assert!(
                (got - planned).abs() <= 1e-4 * planned,
                "max_leaf {max_leaf}: built {got}, planned {planned}"
            );
            assert!(got < plain, "max_leaf {max_leaf}: {got} vs plain {plain}");
            let (planned4, _) = planned_and_plain_cost::<4>(&bin, max_leaf);
            let got4 = sah_cost(&WideBvh::<4>::from_binary(&bin, max_leaf));
            assert!((got4 - planned4).abs() <= 1e-4 * planned4);
            // Eight slots can do all that four can, and more.
            assert!(got <= got4, "max_leaf {max_leaf}: W=8 {got} vs W=4 {got4}");
        }
    }

    fn check_wide_against_binary<const W: usize>(
        bin: &Bvh,
        boxes: &[Aabb],
        max_leaf: usize,
        large: bool,
        rng: &mut Rng,
    ) {
        let mut wide = WideBvh::<W>::from_binary(bin, max_leaf);
        assert!(!wide.large);
        for n in &wide.nodes {
            assert_ne!(n.valid, 0, "no empty node");
        }
        wide.large = large;
        let mut counts = vec![0u32; boxes.len()];
        for n in &wide.nodes {
            for i in 0..W {
                if n.count[i] > 0 {
                    for &p in
                        &wide.prims[n.child[i] as usize..(n.child[i] + n.count[i] as u32) as usize]
                    {
                        counts[p as usize] += 1;
                        let b = &boxes[p as usize];
                        assert!(
                            n.slot_box(i).contains(b),
                            "leaf box contains its primitives"
                        );
                    }
                }
            }
        }
        assert!(counts.iter().all(|&c| c == 1), "every primitive once");
        let slab = crate::accel::bvh::tests::slab;
        for _ in 0..5000 {
            let ray = Ray::new(
                Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 12.0 - 1.0,
                uniform_sphere(rng.next_2d()),
            );
            let a = bin.closest(&ray, |p, t| {
                slab(&boxes[p as usize], &ray, t).filter(|&x| x > 0.0)
            });
            let b = wide.closest(&ray, |p, t| {
                slab(&boxes[p as usize], &ray, t).filter(|&x| x > 0.0)
            });
            assert_eq!(a.to_bits(), b.to_bits());
            let any = bin.any(&ray, |p| {
                slab(&boxes[p as usize], &ray, f32::INFINITY).is_some()
            });
            assert_eq!(
                any,
                wide.any(&ray, |p| slab(&boxes[p as usize], &ray, f32::INFINITY)
                    .is_some())
            );
            // The baseline traversal too, where the default one uses AVX or AVX-512.
            let prims =
                |first: u32, count: u32| &wide.prims[first as usize..(first + count) as usize];
            let leaf_closest = |first: u32, count: u32, mut t_max: f32| {
                let mut best = None;
                for &p in prims(first, count) {
                    if let Some(t) = slab(&boxes[p as usize], &ray, t_max).filter(|&x| x > 0.0) {
                        t_max = t;
                        best = Some(t);
                    }
                }
                best
            };
            let leaf_any = |first: u32, count: u32| {
                prims(first, count)
                    .iter()
                    .any(|&p| slab(&boxes[p as usize], &ray, f32::INFINITY).is_some())
            };
            let c = wide.closest_leaf_with::<Sse>(&ray, leaf_closest);
            assert_eq!(a.to_bits(), c.to_bits());
            assert_eq!(any, wide.any_leaf_with::<Sse>(&ray, leaf_any));
            // The AVX path too, where the default one uses AVX-512.
            #[cfg(target_arch = "x86_64")]
            if avx() {
                // SAFETY: the CPU supports AVX (checked above).
                let c = unsafe { wide.closest_leaf_avx(&ray, leaf_closest) };
                assert_eq!(a.to_bits(), c.to_bits());
                // SAFETY: as above.
                assert_eq!(any, unsafe { wide.any_leaf_avx(&ray, leaf_any) });
            }
        }
    }
}
