//! Loop subdivision (pbrt-v4's `loopsubdiv`): each level splits every triangle in four, with
//! Loop's weights for the new edge points (`3/8` of the edge's ends and `1/8` of the two
//! opposite vertices; the midpoint on a boundary) and the moved old points (`1 − nβ` of the
//! point and `β` of each of its `n` neighbours, `β = 3/16` for `n = 3`, `3/(8n)` otherwise;
//! `3/4` and `1/8` of the two boundary neighbours on a boundary); after the last level points
//! move to the limit surface (`γ = 1 / (n + 3/(8β))` per neighbour; `1/5` per boundary
//! neighbour).

use glam::Vec3;
use std::collections::{BTreeMap, HashMap};

/// Most triangles subdivision may produce.
pub const MAX_TRIANGLES: usize = 1 << 26;

/// Edges, keyed by their sorted ends, with the vertices opposite them in their faces.
fn edges(tris: &[[u32; 3]]) -> BTreeMap<(u32, u32), Vec<u32>> {
    let mut map: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            map.entry((a.min(b), a.max(b))).or_default().push(c);
        }
    }
    map
}

/// Per vertex: its neighbours and the neighbours along boundary edges.
fn rings(n: usize, edges: &BTreeMap<(u32, u32), Vec<u32>>) -> Vec<(Vec<u32>, Vec<u32>)> {
    let mut rings = vec![(Vec::new(), Vec::new()); n];
    for (&(a, b), opposite) in edges {
        rings[a as usize].0.push(b);
        rings[b as usize].0.push(a);
        if opposite.len() == 1 {
            rings[a as usize].1.push(b);
            rings[b as usize].1.push(a);
        }
    }
    rings
}

fn beta(n: usize) -> f32 {
    if n == 3 {
        3.0 / 16.0
    } else {
        3.0 / (8.0 * n as f32)
    }
}

/// One vertex moved by the even rule (`limit`: to the limit surface instead).
fn even(p: &[Vec3], v: usize, ring: &(Vec<u32>, Vec<u32>), limit: bool) -> Vec3 {
    let (all, boundary) = ring;
    if boundary.len() == 2 {
        let w = if limit { 0.2 } else { 0.125 };
        let sum = p[boundary[0] as usize] + p[boundary[1] as usize];
        return p[v] * (1.0 - 2.0 * w) + sum * w;
    }
    if !boundary.is_empty() || all.is_empty() {
        return p[v];
    }
    let n = all.len();
    let w = if limit {
        1.0 / (n as f32 + 3.0 / (8.0 * beta(n)))
    } else {
        beta(n)
    };
    let sum: Vec3 = all.iter().map(|&u| p[u as usize]).sum();
    p[v] * (1.0 - n as f32 * w) + sum * w
}

/// `levels` levels of Loop subdivision of the mesh `(p, tris)`, its points then moved to the
/// limit surface; stops early rather than exceed [`MAX_TRIANGLES`].
pub fn subdivide(p: &[Vec3], tris: &[[u32; 3]], levels: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (mut p, mut tris) = (p.to_vec(), tris.to_vec());
    for _ in 0..levels {
        if tris.len() * 4 > MAX_TRIANGLES {
            break;
        }
        let e = edges(&tris);
        let r = rings(p.len(), &e);
        let mut next: Vec<Vec3> = (0..p.len()).map(|v| even(&p, v, &r[v], false)).collect();
        let mut index: HashMap<(u32, u32), u32> = HashMap::with_capacity(e.len());
        for (&(a, b), opposite) in &e {
            let (pa, pb) = (p[a as usize], p[b as usize]);
            let q = if opposite.len() == 2 {
                (pa + pb) * 0.375 + (p[opposite[0] as usize] + p[opposite[1] as usize]) * 0.125
            } else {
                (pa + pb) * 0.5
            };
            index.insert((a, b), next.len() as u32);
            next.push(q);
        }
        let mid = |a: u32, b: u32| index[&(a.min(b), a.max(b))];
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
        p = next;
    }
    let e = edges(&tris);
    let r = rings(p.len(), &e);
    let limit = (0..p.len()).map(|v| even(&p, v, &r[v], true)).collect();
    (limit, tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A subdivided octahedron: four times the triangles per level, and every point on the
    /// limit surface, which does not depend on the number of levels: an original vertex
    /// (valence 4, γ = 1/8, its neighbours summing to 0) has its limit at half its distance,
    /// after any number of levels.
    #[test]
    fn octahedron_subdivides_towards_a_smooth_surface() {
        let p = [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ];
        let t = [
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        let (q, tris) = subdivide(&p, &t, 3);
        assert_eq!(tris.len(), 8 * 64);
        let d: Vec<f32> = q.iter().map(|v| v.length()).collect();
        let (lo, hi) = d
            .iter()
            .fold((f32::MAX, 0.0f32), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi / lo < 1.25 && lo > 0.3, "{lo} {hi}");
        for levels in [0, 1, 3] {
            let (q, _) = subdivide(&p, &t, levels);
            assert!(
                (q[0] - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-5,
                "{levels}: {}",
                q[0]
            );
        }
        // A boundary stays where it is along a straight edge.
        let (q, _) = subdivide(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[[0, 1, 2]], 2);
        assert!(q.iter().all(|v| v.z == 0.0 && v.x >= -1e-6 && v.y >= -1e-6));
        // The same mesh subdivides to the same bits every time (the points' sums do not
        // depend on a hash map's order).
        let runs: Vec<_> = (0..4).map(|_| subdivide(&p, &t, 3)).collect();
        assert!(runs.windows(2).all(|w| w[0] == w[1]));
    }
}
