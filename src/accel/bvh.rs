//! Bounding volume hierarchy: surface-area-heuristic build over primitive bounds (binned on
//! large subtrees, a full sweep over the sorted centroids below [`SWEEP_MAX`] primitives),
//! flattened depth-first into 32-byte nodes, traversed iteratively near child first.
//!
//! The BVH knows only primitive ids and bounds; callers supply the primitive test as a closure.
//! It is the build stage of the wide trees the renderer traverses (`wide`, `tribvh`), and
//! the reference they are tested against.

use crate::math::{Aabb, Ray};
use glam::Vec3;

/// One flattened node. Interior nodes (`count == 0`) have their first child right after them
/// and their second child at `offset`; leaves hold `count` primitive ids from `prims[offset..]`.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Node {
    /// Lower corner of the node's bounds.
    pub min: [f32; 3],
    /// Second child (interior) or first primitive slot (leaf).
    pub offset: u32,
    /// Upper corner of the node's bounds.
    pub max: [f32; 3],
    /// Number of primitives; 0 for interior nodes.
    pub count: u16,
    /// Split axis of an interior node (0 = x, 1 = y, 2 = z).
    pub axis: u16,
}

impl Node {
    /// The node's bounds.
    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: Vec3::from(self.min),
            max: Vec3::from(self.max),
        }
    }
}

/// A flattened BVH over primitive ids `0..n`.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    /// Nodes in depth-first order; node 0 is the root.
    pub nodes: Vec<Node>,
    /// Primitive ids in leaf order.
    pub prims: Vec<u32>,
}

const BINS: usize = 16;
/// Subtrees of at most this many primitives are split by a full SAH sweep: every split of
/// the centroid order on each axis is costed, not only those at bin boundaries. The orders
/// are sorted once per subtree and partitioned stably at each split (O(n log n) in all).
/// It finds much cheaper splits where a few large primitives share a node with many small
/// ones (the Cornell box's walls around the bunny), at up to twice the build time of
/// binning; above it, binning keeps large builds fast.
pub const SWEEP_MAX: usize = 1 << 16;
const MAX_LEAF: usize = 8;
const TRAVERSAL_COST: f32 = 1.0;
const INTERSECT_COST: f32 = 1.0;
const STACK: usize = 64;
/// Below this depth splits follow the SAH; deeper ones are median splits (depth ≤ 32 + log2 n).
const MAX_SAH_DEPTH: usize = 32;

struct BuildPrim {
    bounds: Aabb,
    centroid: Vec3,
    id: u32,
}

/// The full-sweep SAH build of one subtree: `order[axis]` lists the primitives (indices
/// into `prims`) by centroid along `axis`; every node owns the same range of all three.
struct Sweep<'a> {
    prims: &'a [BuildPrim],
    order: [Vec<u32>; 3],
    /// Surface area of the union of a range's suffix, per split position.
    right_area: Vec<f32>,
    /// Whether a primitive goes left at the current split.
    left: Vec<bool>,
    /// Room for the stable partition.
    tmp: Vec<u32>,
}

impl<'a> Sweep<'a> {
    fn new(prims: &'a [BuildPrim]) -> Self {
        let n = prims.len();
        let order = std::array::from_fn(|axis| {
            let mut o: Vec<u32> = (0..n as u32).collect();
            o.sort_unstable_by(|&i, &j| {
                let (a, b) = (&prims[i as usize], &prims[j as usize]);
                a.centroid[axis].total_cmp(&b.centroid[axis])
            });
            o
        });
        Sweep {
            prims,
            order,
            right_area: vec![0.0; n],
            left: vec![false; n],
            tmp: Vec::with_capacity(n),
        }
    }

    /// Builds the node over positions `lo..hi` of the orders; returns its index.
    fn build(&mut self, bvh: &mut Bvh, lo: usize, hi: usize, depth: usize) -> usize {
        let prims = self.prims;
        let n = hi - lo;
        let range = &self.order[0][lo..hi];
        let bounds = range
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.union(&prims[i as usize].bounds));
        let index = bvh.push_interior(bounds);
        macro_rules! leaf {
            () => {
                bvh.leaf(
                    index,
                    self.order[0][lo..hi].iter().map(|&i| prims[i as usize].id),
                )
            };
        }
        if n == 1 {
            return leaf!();
        }
        let (axis, split) = if depth < MAX_SAH_DEPTH {
            // (cost, axis, left count) of the cheapest split.
            let mut best = (f32::INFINITY, 0, n / 2);
            for axis in 0..3 {
                let o = &self.order[axis][lo..hi];
                let mut acc = Aabb::EMPTY;
                for k in (1..n).rev() {
                    acc = acc.union(&prims[o[k] as usize].bounds);
                    self.right_area[k] = acc.area();
                }
                let mut acc = Aabb::EMPTY;
                for k in 1..n {
                    acc = acc.union(&prims[o[k - 1] as usize].bounds);
                    let cost = acc.area() * k as f32 + self.right_area[k] * (n - k) as f32;
                    if cost < best.0 {
                        best = (cost, axis, k);
                    }
                }
            }
            let leaf_cost = INTERSECT_COST * n as f32;
            let split_cost =
                TRAVERSAL_COST + INTERSECT_COST * best.0 / bounds.area().max(f32::MIN_POSITIVE);
            if n <= MAX_LEAF && leaf_cost <= split_cost {
                return leaf!();
            }
            (best.1, best.2)
        } else {
            // Getting deep: median split on the widest centroid axis (depth ≤ 32 + log2 n).
            let c = |k: usize, a: usize| prims[self.order[a][k] as usize].centroid[a];
            let axis = (0..3)
                .max_by(|&a, &b| (c(hi - 1, a) - c(lo, a)).total_cmp(&(c(hi - 1, b) - c(lo, b))))
                .unwrap_or(0);
            (axis, n / 2)
        };
        // Partition the other orders stably: both halves stay sorted.
        for &i in &self.order[axis][lo..lo + split] {
            self.left[i as usize] = true;
        }
        for a in (0..3).filter(|&a| a != axis) {
            self.tmp.clear();
            let o = &mut self.order[a][lo..hi];
            let mut l = 0;
            for k in 0..n {
                let i = o[k];
                if self.left[i as usize] {
                    o[l] = i;
                    l += 1;
                } else {
                    self.tmp.push(i);
                }
            }
            o[l..].copy_from_slice(&self.tmp);
        }
        for &i in &self.order[axis][lo..lo + split] {
            self.left[i as usize] = false;
        }
        bvh.nodes[index].axis = axis as u16;
        self.build(bvh, lo, lo + split, depth + 1);
        let r = self.build(bvh, lo + split, hi, depth + 1);
        bvh.nodes[index].offset = r as u32;
        index
    }
}

/// Precomputed per-ray data for box tests.
#[derive(Clone, Copy)]
pub struct RayBoxData {
    o: Vec3,
    inv: Vec3,
    neg: [bool; 3],
}

impl RayBoxData {
    /// Prepares `ray` for box tests. A zero direction component gives an infinite inverse,
    /// and a NaN distance where the ray lies in a slab's plane, which the test ignores.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let inv = ray.d.recip();
        RayBoxData {
            o: ray.o,
            inv,
            neg: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
        }
    }

    /// Slab test: true when the ray overlaps `n`'s box within `(t_min, t_max)`.
    #[inline(always)]
    fn hit(&self, n: &Node, t_min: f32, t_max: f32) -> bool {
        let (mut near, mut far) = (t_min, t_max);
        for a in 0..3 {
            let (p0, p1) = if self.neg[a] {
                (n.max[a], n.min[a])
            } else {
                (n.min[a], n.max[a])
            };
            // NaN (a ray parallel to the slab, lying in one of its planes) fails both
            // comparisons: that slab then does not constrain the ray, as it should not.
            let t0 = (p0 - self.o[a]) * self.inv[a];
            let t1 = (p1 - self.o[a]) * self.inv[a];
            if t0 > near {
                near = t0;
            }
            if t1 < far {
                far = t1;
            }
        }
        // Conservative far distance (pbrt's 1 + 2γ₃ factor) so that rounding never culls a hit.
        near <= far * 1.000_000_4
    }
}

impl Bvh {
    /// Builds over the given primitive bounds; primitive `i` has id `i`. Empty bounds are skipped.
    pub fn build(bounds: &[Aabb]) -> Bvh {
        Self::build_with(bounds, SWEEP_MAX)
    }

    /// [`Bvh::build`] with subtrees of at most `sweep_max` primitives split by the full sweep
    /// (0: binning everywhere).
    fn build_with(bounds: &[Aabb], sweep_max: usize) -> Bvh {
        let mut prims: Vec<BuildPrim> = bounds
            .iter()
            .enumerate()
            .filter(|(_, b)| !b.is_empty() && b.min.is_finite() && b.max.is_finite())
            .map(|(i, b)| BuildPrim {
                bounds: *b,
                centroid: b.center(),
                id: i as u32,
            })
            .collect();
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * prims.len() / 2 + 1),
            prims: Vec::with_capacity(prims.len()),
        };
        if prims.is_empty() {
            // Traversal returns at once when there are no primitives.
            bvh.nodes.push(Node {
                min: [f32::INFINITY; 3],
                offset: 0,
                max: [f32::NEG_INFINITY; 3],
                count: 0,
                axis: 0,
            });
            return bvh;
        }
        bvh.build_rec(&mut prims, 0, sweep_max);
        bvh
    }

    fn build_rec(&mut self, prims: &mut [BuildPrim], depth: usize, sweep_max: usize) -> usize {
        if prims.len() <= sweep_max {
            return Sweep::new(prims).build(self, 0, prims.len(), depth);
        }
        let bounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(&p.bounds));
        let cbounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid));
        let index = self.push_interior(bounds);
        let n = prims.len();
        let make_leaf = |bvh: &mut Bvh, prims: &mut [BuildPrim]| {
            let node = &mut bvh.nodes[index];
            node.offset = bvh.prims.len() as u32;
            node.count = prims.len() as u16;
            bvh.prims.extend(prims.iter().map(|p| p.id));
            index
        };
        if n == 1 {
            return make_leaf(self, prims);
        }
        // Binned SAH over centroids on every axis.
        let extent = cbounds.extent();
        let mut best = (f32::INFINITY, 0usize, 0usize);
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            let scale = BINS as f32 / extent[axis];
            let bin_of = |c: Vec3| (((c[axis] - cbounds.min[axis]) * scale) as usize).min(BINS - 1);
            let mut bins = [(Aabb::EMPTY, 0usize); BINS];
            for p in prims.iter() {
                let b = &mut bins[bin_of(p.centroid)];
                b.0 = b.0.union(&p.bounds);
                b.1 += 1;
            }
            // Sweep from the right to get suffix areas and counts.
            let mut right_area = [0f32; BINS];
            let mut right_count = [0usize; BINS];
            let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
            for i in (1..BINS).rev() {
                acc = acc.union(&bins[i].0);
                cnt += bins[i].1;
                right_area[i] = acc.area();
                right_count[i] = cnt;
            }
            let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
            for i in 0..BINS - 1 {
                acc = acc.union(&bins[i].0);
                cnt += bins[i].1;
                if cnt == 0 || right_count[i + 1] == 0 {
                    continue;
                }
                let cost = acc.area() * cnt as f32 + right_area[i + 1] * right_count[i + 1] as f32;
                if cost < best.0 {
                    best = (cost, axis, i);
                }
            }
        }
        let leaf_cost = INTERSECT_COST * n as f32;
        let split_cost =
            TRAVERSAL_COST + INTERSECT_COST * best.0 / bounds.area().max(f32::MIN_POSITIVE);
        let mid = if best.0.is_finite() && depth < MAX_SAH_DEPTH {
            if n <= MAX_LEAF && leaf_cost <= split_cost {
                return make_leaf(self, prims);
            }
            let (axis, split) = (best.1, best.2);
            let scale = BINS as f32 / extent[axis];
            let cmin = cbounds.min[axis];
            let mut i = 0;
            for j in 0..n {
                let b = (((prims[j].centroid[axis] - cmin) * scale) as usize).min(BINS - 1);
                if b <= split {
                    prims.swap(i, j);
                    i += 1;
                }
            }
            self.nodes[index].axis = axis as u16;
            i
        } else {
            // All centroids coincide, or the tree is getting deep: median split on the widest
            // centroid axis, which bounds the depth by log2(n).
            if n <= MAX_LEAF && !best.0.is_finite() {
                return make_leaf(self, prims);
            }
            let axis = extent.max_position();
            prims.select_nth_unstable_by(n / 2, |a, b| {
                a.centroid[axis].total_cmp(&b.centroid[axis])
            });
            self.nodes[index].axis = axis as u16;
            n / 2
        };
        let (left, right) = prims.split_at_mut(mid);
        self.build_rec(left, depth + 1, sweep_max);
        let r = self.build_rec(right, depth + 1, sweep_max);
        self.nodes[index].offset = r as u32;
        index
    }

    /// Appends a node with `bounds`, interior until its children or primitives are set;
    /// returns its index.
    fn push_interior(&mut self, bounds: Aabb) -> usize {
        self.nodes.push(Node {
            min: bounds.min.into(),
            offset: 0,
            max: bounds.max.into(),
            count: 0,
            axis: 0,
        });
        self.nodes.len() - 1
    }

    /// The primitives' ids as a leaf node at `index`.
    fn leaf(&mut self, index: usize, ids: impl ExactSizeIterator<Item = u32>) -> usize {
        let node = &mut self.nodes[index];
        node.offset = self.prims.len() as u32;
        node.count = ids.len() as u16;
        self.prims.extend(ids);
        index
    }

    /// Closest-hit traversal. `test(prim, t_max)` returns the hit distance of `prim` if it is
    /// hit in `(ray.t_min, t_max)`; the closure may record hit details for the closest hit.
    /// Returns the closest distance found (or `ray.t_max`).
    #[inline]
    pub fn closest(&self, ray: &Ray, mut test: impl FnMut(u32, f32) -> Option<f32>) -> f32 {
        let mut t_max = ray.t_max;
        self.walk(ray, |p, t| {
            if let Some(hit) = test(p, *t) {
                *t = hit;
                t_max = hit;
            }
            false
        });
        t_max
    }

    /// Any-hit traversal: true as soon as `test(prim)` reports a hit in `(t_min, t_max)`.
    #[inline]
    pub fn any(&self, ray: &Ray, mut test: impl FnMut(u32) -> bool) -> bool {
        let mut found = false;
        self.walk(ray, |p, _| {
            found = test(p);
            found
        });
        found
    }

    /// Visits the primitives of every leaf whose box the ray overlaps within `(t_min, t)`,
    /// nearer child first. `visit(prim, &mut t)` may shrink `t` (closest hit) and returns true
    /// to stop the traversal (any hit).
    #[inline(always)]
    fn walk(&self, ray: &Ray, mut visit: impl FnMut(u32, &mut f32) -> bool) {
        if self.prims.is_empty() {
            return;
        }
        let rb = RayBoxData::new(ray);
        let mut t_max = ray.t_max;
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        let mut idx = 0usize;
        loop {
            let node = &self.nodes[idx];
            if rb.hit(node, ray.t_min, t_max) {
                if node.count > 0 {
                    let start = node.offset as usize;
                    for &p in &self.prims[start..start + node.count as usize] {
                        if visit(p, &mut t_max) {
                            return;
                        }
                    }
                } else if sp < STACK {
                    let (near, far) = if rb.neg[node.axis as usize] {
                        (node.offset as usize, idx + 1)
                    } else {
                        (idx + 1, node.offset as usize)
                    };
                    stack[sp] = far as u32;
                    sp += 1;
                    idx = near;
                    continue;
                }
            }
            if sp == 0 {
                return;
            }
            sp -= 1;
            idx = stack[sp] as usize;
        }
    }

    /// Checks the structural invariants: every node's bounds contain its children's (and its
    /// primitives'), every primitive id with non-empty bounds appears exactly once, depth fits
    /// the traversal stack. Returns a description of the first violation.
    pub fn check_invariants(&self, bounds: &[Aabb]) -> Result<(), String> {
        let mut seen = vec![0u32; bounds.len()];
        let mut stack = vec![(0usize, 0usize)];
        while let Some((i, depth)) = stack.pop() {
            if depth >= STACK {
                return Err(format!("depth {depth} exceeds the traversal stack"));
            }
            let n = &self.nodes[i];
            let nb = n.bounds();
            if n.count > 0 {
                for &p in &self.prims[n.offset as usize..n.offset as usize + n.count as usize] {
                    seen[p as usize] += 1;
                    if !nb.contains(&bounds[p as usize]) {
                        return Err(format!("leaf {i} does not contain primitive {p}"));
                    }
                }
            } else if self.prims.is_empty() {
                return Ok(());
            } else {
                for c in [i + 1, n.offset as usize] {
                    if c <= i || c >= self.nodes.len() {
                        return Err(format!("node {i} has child index {c} out of order"));
                    }
                    if !nb.contains(&self.nodes[c].bounds()) {
                        return Err(format!("node {i} does not contain child {c}"));
                    }
                    stack.push((c, depth + 1));
                }
            }
        }
        for (p, &s) in seen.iter().enumerate() {
            let expect = u32::from(!bounds[p].is_empty());
            if s != expect {
                return Err(format!("primitive {p} referenced {s} times"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sampling::{uniform_sphere, Rng};

    /// Reference slab test: the entry distance of `ray` into `b` within `(ray.t_min, t_max)`.
    pub(crate) fn slab(b: &Aabb, ray: &Ray, t_max: f32) -> Option<f32> {
        let inv = ray.d.recip();
        let t0 = (b.min - ray.o) * inv;
        let t1 = (b.max - ray.o) * inv;
        let lo = t0.min(t1).max_element().max(ray.t_min);
        let hi = t0.max(t1).min_element().min(t_max);
        (lo <= hi).then_some(lo)
    }

    /// SAH cost of a tree (traversal 1 per interior node, 1 per primitive, area-weighted).
    fn sah(b: &Bvh) -> f64 {
        let root = b.nodes[0].bounds().area() as f64;
        b.nodes
            .iter()
            .map(|n| {
                let w = n.bounds().area() as f64 / root;
                w * if n.count > 0 { n.count as f64 } else { 1.0 }
            })
            .sum()
    }

    /// Many small boxes inside a few large thin ones (a mesh inside a Cornell box's walls).
    fn walls_and_mesh(rng: &mut Rng) -> Vec<Aabb> {
        let mut boxes = Vec::new();
        for a in 0..3 {
            for side in [0.0, 10.0] {
                let mut min = Vec3::ZERO;
                let mut max = Vec3::splat(10.0);
                min[a] = side;
                max[a] = side;
                boxes.push(Aabb { min, max });
            }
        }
        for _ in 0..3000 {
            let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 3.0 + 3.5;
            let h = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.05;
            boxes.push(Aabb {
                min: c - h,
                max: c + h,
            });
        }
        boxes
    }

    #[test]
    fn sweep_and_binned_trees_are_valid_and_match_brute_force() {
        let mut rng = Rng::new(7, 0);
        let boxes = walls_and_mesh(&mut rng);
        let slab = |b: &Aabb, ray: &Ray, t_max: f32| slab(b, ray, t_max).filter(|&t| t > 0.0);
        for sweep_max in [0, 64, usize::MAX] {
            let bvh = Bvh::build_with(&boxes, sweep_max);
            bvh.check_invariants(&boxes).unwrap();
            for _ in 0..2000 {
                let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
                let ray = Ray::new(o, uniform_sphere(rng.next_2d()));
                let got = bvh.closest(&ray, |p, t| slab(&boxes[p as usize], &ray, t));
                let want = boxes
                    .iter()
                    .filter_map(|b| slab(b, &ray, ray.t_max))
                    .fold(ray.t_max, f32::min);
                assert_eq!(got.to_bits(), want.to_bits(), "sweep_max {sweep_max}");
            }
        }
    }

    #[test]
    fn full_sweep_finds_cheaper_trees_than_binning() {
        let boxes = walls_and_mesh(&mut Rng::new(3, 0));
        let (sweep, binned) = (sah(&Bvh::build(&boxes)), sah(&Bvh::build_with(&boxes, 0)));
        assert!(
            sweep < 0.95 * binned,
            "sweep {sweep:.2}, binned {binned:.2}"
        );
    }
}
