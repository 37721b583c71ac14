//! Bounding volume hierarchy: binned surface-area-heuristic build over primitive bounds,
//! flattened depth-first into 32-byte nodes, traversed iteratively near child first.
//!
//! The BVH knows only primitive ids and bounds; callers supply the primitive test as a closure.
//! It is the build stage of the wide trees the renderer traverses (`wide`, `tribvh`), and
//! the reference they are tested against.

use crate::math::{safe_recip, Aabb, Ray};
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

/// Precomputed per-ray data for box tests.
#[derive(Clone, Copy)]
pub struct RayBoxData {
    o: Vec3,
    inv: Vec3,
    neg: [bool; 3],
}

impl RayBoxData {
    /// Prepares `ray` for box tests (zero direction components become tiny, so no NaN arises).
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let inv = safe_recip(ray.d);
        RayBoxData {
            o: ray.o,
            inv,
            neg: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
        }
    }

    /// Slab test: true when the ray overlaps `n`'s box within `(t_min, t_max)`.
    #[inline(always)]
    fn hit(&self, n: &Node, t_min: f32, t_max: f32) -> bool {
        let t0 = (Vec3::from(n.min) - self.o) * self.inv;
        let t1 = (Vec3::from(n.max) - self.o) * self.inv;
        let near = t0.min(t1).max_element().max(t_min);
        // Conservative far distance (pbrt's 1 + 2γ₃ factor) so that rounding never culls a hit.
        let far = t0.max(t1).min_element().min(t_max) * 1.000_000_4;
        near <= far
    }
}

impl Bvh {
    /// Builds over the given primitive bounds; primitive `i` has id `i`. Empty bounds are skipped.
    pub fn build(bounds: &[Aabb]) -> Bvh {
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
        bvh.build_rec(&mut prims, 0);
        bvh
    }

    fn build_rec(&mut self, prims: &mut [BuildPrim], depth: usize) -> usize {
        let bounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(&p.bounds));
        let cbounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid));
        let index = self.nodes.len();
        self.nodes.push(Node {
            min: bounds.min.into(),
            offset: 0,
            max: bounds.max.into(),
            count: 0,
            axis: 0,
        });
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
        self.build_rec(left, depth + 1);
        let r = self.build_rec(right, depth + 1);
        self.nodes[index].offset = r as u32;
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
