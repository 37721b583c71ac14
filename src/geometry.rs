//! Ray–triangle and ray–sphere intersection.
//!
//! Triangles use the watertight test of Woop, Benthin and Wald (2013): the ray is sheared to
//! +Z and edge functions are evaluated in 2D, falling back to `f64` when one is exactly zero,
//! so a ray through a shared edge or vertex hits at least one of the triangles that share it.

use crate::math::{Aabb, Ray};
use glam::{DVec3, Vec3};

/// A triangle's world-space vertices.
#[derive(Clone, Copy, Debug)]
pub struct Triangle {
    /// The three vertices, counter-clockwise as in the file.
    pub v: [Vec3; 3],
}

impl Triangle {
    /// Bounds of the three vertices.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_point(self.v[0]).grow(self.v[1]).grow(self.v[2])
    }

    /// Area in square scene units.
    pub fn area(&self) -> f32 {
        0.5 * (self.v[1] - self.v[0])
            .cross(self.v[2] - self.v[0])
            .length()
    }

    /// Unit geometric normal, `normalize((v1 − v0) × (v2 − v0))`; +Y for a degenerate triangle.
    pub fn unit_normal(&self) -> Vec3 {
        self.cross().normalize_or(Vec3::Y)
    }

    /// Unnormalised geometric normal `(v1 − v0) × (v2 − v0)`.
    pub fn cross(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }
}

/// Per-ray data for the watertight triangle test.
#[derive(Clone, Copy)]
pub struct RayTri {
    /// Axis permutation: `k[2]` is the direction's dominant axis.
    pub(crate) k: [usize; 3],
    /// Shear `(d[kx]/d[kz], d[ky]/d[kz], 1/d[kz])`.
    pub(crate) s: Vec3,
}

impl RayTri {
    /// Precomputes the permutation and shear for `ray`.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        // Branch-free: for scattered rays these choices are coin flips.
        use std::hint::select_unpredictable as sel;
        let a = ray.d.abs();
        // Arrays, not `Vec3` indexing (which branches on the index).
        let d = ray.d.to_array();
        let kz = sel(a.x > a.y, sel(a.x > a.z, 0, 2), sel(a.y > a.z, 1, 2));
        let dz = d[kz];
        let (k1, k2) = ([1, 2, 0][kz], [2, 0, 1][kz]);
        let neg = dz < 0.0;
        let kx = sel(neg, k2, k1);
        let ky = sel(neg, k1, k2);
        // One division: the shear uses the reciprocal of the dominant component.
        let inv = 1.0 / dz;
        RayTri {
            k: [kx, ky, kz],
            s: Vec3::new(d[kx] * inv, d[ky] * inv, inv),
        }
    }
}

/// Hit distance and barycentrics `(b1, b2)` (weights of `v1` and `v2`) of `ray` with `tri`, for
/// hits in `(ray.t_min, t_max)`.
#[inline]
pub fn intersect_triangle(
    ray: &Ray,
    rt: &RayTri,
    tri: &Triangle,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let [kx, ky, kz] = rt.k;
    // Arrays, not `Vec3` indexing (which branches on the index).
    let a = (tri.v[0] - ray.o).to_array();
    let b = (tri.v[1] - ray.o).to_array();
    let c = (tri.v[2] - ray.o).to_array();
    let ax = a[kx] - rt.s.x * a[kz];
    let ay = a[ky] - rt.s.y * a[kz];
    let bx = b[kx] - rt.s.x * b[kz];
    let by = b[ky] - rt.s.y * b[kz];
    let cx = c[kx] - rt.s.x * c[kz];
    let cy = c[ky] - rt.s.y * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (
            ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
        );
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let az = rt.s.z * a[kz];
    let bz = rt.s.z * b[kz];
    let cz = rt.s.z * c[kz];
    let t = u * az + v * bz + w * cz;
    let inv = 1.0 / det;
    let t = t * inv;
    if !(t > ray.t_min && t < t_max) {
        return None;
    }
    Some((t, v * inv, w * inv))
}

/// A sphere in world space.
#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
}

impl Sphere {
    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: self.center - Vec3::splat(self.radius),
            max: self.center + Vec3::splat(self.radius),
        }
    }

    /// Nearest hit distance in `(ray.t_min, t_max)`. Solved in `f64` with the numerically stable
    /// form of the quadratic (discriminant from the perpendicular offset, as in pbrt-v4).
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<f32> {
        if self.behind(ray) {
            return None;
        }
        self.roots(ray, t_max)
    }

    /// Whether the origin of `ray` is outside the sphere with the centre behind it: both roots
    /// are then negative (their product c/a > 0, their sum −2b/a < 0), and so are the computed
    /// ones of [`Sphere::roots`] (q < 0 there, so q/a and c/q are too), so nothing is hit
    /// beyond a non-negative `t_min`. Saves the divisions for most spheres a ray passes.
    #[inline(always)]
    fn behind(&self, ray: &Ray) -> bool {
        let o = (ray.o - self.center).as_dvec3();
        let r = self.radius as f64;
        let b = o.dot(ray.d.as_dvec3());
        let c = o.length_squared() - r * r;
        c > 0.0 && b > 0.0 && ray.t_min >= 0.0
    }

    /// [`Sphere::intersect`] without the [`Sphere::behind`] test.
    #[inline(always)]
    fn roots(&self, ray: &Ray, t_max: f32) -> Option<f32> {
        let o = (ray.o - self.center).as_dvec3();
        let d = ray.d.as_dvec3();
        let r = self.radius as f64;
        let a = d.length_squared();
        let b = o.dot(d);
        let c = o.length_squared() - r * r;
        // Clear misses leave before the division: b² − ac is the same discriminant, less
        // accurate only by rounding far below this margin.
        let rough = b * b - a * c;
        if rough < -1e-9 * (b * b + (a * c).abs()) {
            return None;
        }
        let f = o - d * (b / a);
        let disc = a * (r * r - f.length_squared());
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let q = -(b + root.copysign(b));
        let (mut t0, mut t1) = (c / q, q / a);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let (lo, hi) = (ray.t_min as f64, t_max as f64);
        if t0 > lo && t0 < hi {
            Some(t0 as f32)
        } else if t1 > lo && t1 < hi {
            Some(t1 as f32)
        } else {
            None
        }
    }

    /// Surface point closest to `p` (projects a hit point back onto the sphere) and the unit
    /// outward normal there (+Y at the centre), both computed in `f64`.
    pub fn project(&self, p: Vec3) -> (Vec3, Vec3) {
        let d = (p - self.center).as_dvec3();
        let n = if d.length_squared() > 0.0 {
            d.normalize()
        } else {
            DVec3::Y
        };
        (
            (self.center.as_dvec3() + n * self.radius as f64).as_vec3(),
            n.as_vec3(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn triangle_hit_and_miss() {
        let tri = Triangle {
            v: [
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
        };
        let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let (t, b1, b2) =
            intersect_triangle(&ray, &RayTri::new(&ray), &tri, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (b1 - 0.25).abs() < 1e-6 && (b2 - 0.25).abs() < 1e-6);
        let miss = Ray::new(Vec3::new(0.75, 0.75, 1.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(intersect_triangle(&miss, &RayTri::new(&miss), &tri, f32::INFINITY).is_none());
        assert!(
            intersect_triangle(&ray, &RayTri::new(&ray), &tri, 0.5).is_none(),
            "t_max respected"
        );
    }

    /// Rays aimed exactly at shared edges and vertices of a triangulated grid, from random
    /// origins, must hit some triangle: no leaks through the cracks.
    #[test]
    fn watertight_on_shared_edges() {
        let n = 8;
        let mut tris = Vec::new();
        // A bumpy grid so that edges are not axis-aligned in the sheared space.
        let h = |i: usize, j: usize| 0.3 * ((i * 7 + j * 3) % 5) as f32 / 5.0;
        let p = |i: usize, j: usize| Vec3::new(i as f32 * 0.37, h(i, j), j as f32 * 0.29);
        for i in 0..n {
            for j in 0..n {
                tris.push(Triangle {
                    v: [p(i, j), p(i + 1, j), p(i + 1, j + 1)],
                });
                tris.push(Triangle {
                    v: [p(i, j), p(i + 1, j + 1), p(i, j + 1)],
                });
            }
        }
        let mut rng = Rng::new(5, 6);
        let mut misses = 0;
        let mut total = 0;
        for _ in 0..20_000 {
            let i = 1 + (rng.next_u32() as usize % (n - 1));
            let j = 1 + (rng.next_u32() as usize % (n - 1));
            // Target: a vertex or the midpoint of one of its edges.
            let target = match rng.next_u32() % 4 {
                0 => p(i, j),
                1 => (p(i, j) + p(i + 1, j)) * 0.5,
                2 => (p(i, j) + p(i, j + 1)) * 0.5,
                _ => (p(i, j) + p(i + 1, j + 1)) * 0.5,
            };
            let origin = target
                + Vec3::new(
                    rng.next_f32() - 0.5,
                    1.0 + rng.next_f32() * 3.0,
                    rng.next_f32() - 0.5,
                ) * 10.0;
            let ray = Ray::new(origin, (target - origin).normalize());
            let rt = RayTri::new(&ray);
            total += 1;
            if !tris
                .iter()
                .any(|t| intersect_triangle(&ray, &rt, t, f32::INFINITY).is_some())
            {
                misses += 1;
            }
        }
        assert_eq!(
            misses, 0,
            "{misses} of {total} rays leaked through shared edges"
        );
    }

    /// Rays whose origin is outside a sphere with its centre behind get no hit from the full
    /// computation either (so skipping it changes nothing), for any `t_max`.
    #[test]
    fn a_sphere_behind_the_origin_is_never_hit() {
        let mut rng = Rng::new(3, 9);
        let mut behind = 0;
        for k in 0..200_000 {
            let mut p = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
            let s = Sphere {
                center: p() * 0.25,
                radius: 0.05 + 0.2 * (p().x + 2.0),
            };
            // Origins near the surface too, where c is tiny.
            let mut o = p();
            if k % 3 == 0 {
                o = s.center + (o - s.center).normalize_or(Vec3::Y) * s.radius * 1.000_001;
            }
            let ray = Ray::new(o, p().normalize_or(Vec3::X));
            let t_max = if k % 2 == 0 {
                f32::INFINITY
            } else {
                4.0 * rng.next_f32()
            };
            if s.behind(&ray) {
                behind += 1;
                assert_eq!(s.roots(&ray, t_max), None, "{s:?} {ray:?}");
            }
            assert_eq!(s.intersect(&ray, t_max), s.roots(&ray, t_max));
        }
        assert!(behind > 50_000, "{behind}");
    }

    #[test]
    fn sphere_hits_from_outside_and_inside() {
        let s = Sphere {
            center: Vec3::new(0.0, 0.0, -5.0),
            radius: 1.0,
        };
        let r = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0));
        assert!((s.intersect(&r, f32::INFINITY).unwrap() - 4.0).abs() < 1e-5);
        let inside = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::X);
        assert!((s.intersect(&inside, f32::INFINITY).unwrap() - 1.0).abs() < 1e-5);
        let miss = Ray::new(Vec3::ZERO, Vec3::new(0.0, 1.0, -1.0).normalize());
        assert!(s.intersect(&miss, f32::INFINITY).is_none());
        // Far-away sphere: precision of the stable quadratic.
        let far = Sphere {
            center: Vec3::new(0.0, 0.0, -1.0e4),
            radius: 0.01,
        };
        let t = far.intersect(&r, f32::INFINITY).unwrap();
        assert!((t - (1.0e4 - 0.01)).abs() < 1e-2);
    }
}
