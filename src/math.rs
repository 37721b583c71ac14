//! Geometry primitives shared by every stage: rays, bounding boxes, orthonormal frames.
//!
//! Conventions: right-handed world space with +Y up (the CS184 convention after the up-axis fix),
//! distances in scene units, angles in radians unless a name says `_deg`.

use glam::Vec3;

/// RGB radiance or reflectance, linear, one `f32` per channel.
pub type Rgb = Vec3;

/// A ray `o + t·d` restricted to `t_min < t < t_max`. `d` need not be normalised, but the
/// renderer always passes unit directions so that `t` is a distance in scene units.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin, world space.
    pub o: Vec3,
    /// Direction, world space.
    pub d: Vec3,
    /// Smallest accepted hit distance.
    pub t_min: f32,
    /// Largest accepted hit distance.
    pub t_max: f32,
}

impl Ray {
    /// A ray from `o` along `d` accepting hits in `(0, ∞)`.
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray {
            o,
            d,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// Offsets a surface point along the geometric normal `ng` towards the side of `dir`, by an
/// amount that grows with the magnitude of the coordinates, so that a ray leaving `p` along
/// `dir` does not hit the surface it starts on.
#[inline]
pub fn offset_origin(p: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    crate::lanes::offset_origin(p.into(), ng.into(), dir.into()).into()
}

/// An axis-aligned bounding box; `EMPTY` has `min = +∞`, `max = −∞`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box, identity of `union`.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box holding exactly one point.
    pub fn from_point(p: Vec3) -> Self {
        Aabb { min: p, max: p }
    }

    /// Smallest box holding both boxes.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Smallest box holding this box and `p`.
    #[inline]
    pub fn grow(&self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// True when `min > max` on some axis.
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// `max − min`.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Surface area; 0 for an empty box.
    pub fn area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// True when `o` lies inside this box (boundary included).
    pub fn contains(&self, o: &Aabb) -> bool {
        o.is_empty() || (self.min.cmple(o.min).all() && self.max.cmpge(o.max).all())
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            Vec3::new(a.x, a.y, a.z),
            Vec3::new(b.x, a.y, a.z),
            Vec3::new(a.x, b.y, a.z),
            Vec3::new(b.x, b.y, a.z),
            Vec3::new(a.x, a.y, b.z),
            Vec3::new(b.x, a.y, b.z),
            Vec3::new(a.x, b.y, b.z),
            Vec3::new(b.x, b.y, b.z),
        ]
    }
}

/// An orthonormal frame; `local` maps world vectors into it with the normal as +Z.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// First tangent (local +X).
    pub s: Vec3,
    /// Second tangent (local +Y).
    pub t: Vec3,
    /// Normal (local +Z).
    pub n: Vec3,
}

impl Frame {
    /// A frame around the unit vector `n` (Duff et al. 2017, branchless).
    pub fn from_normal(n: Vec3) -> Self {
        let (s, t) = crate::lanes::frame_from_normal(n.into());
        Frame {
            s: s.into(),
            t: t.into(),
            n,
        }
    }

    /// A frame about unit normal `n` whose first axis is `tangent` made orthogonal to `n`
    /// (pbrt-v4's `Frame::FromXZ`); [`Frame::from_normal`]'s where the tangent is degenerate.
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Self {
        let s = (tangent - n * n.dot(tangent)).normalize_or_zero();
        if s == Vec3::ZERO || !s.is_finite() {
            return Frame::from_normal(n);
        }
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// World → local.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Rec. 709 luminance of a linear RGB value.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The rotation (or, for a mirroring `m`, the reflection) nearest the axes of `m`: its x
/// axis normalised, y made orthogonal to it, z their cross product (negated when `m`
/// mirrors). Degenerate axes fall back to any orthonormal completion.
pub fn orthonormal_axes(m: glam::Mat3) -> glam::Mat3 {
    let x = m.x_axis.normalize_or(Vec3::X);
    let y = (m.y_axis - x * x.dot(m.y_axis)).normalize_or(x.any_orthonormal_vector());
    let z = x.cross(y) * if m.determinant() < 0.0 { -1.0 } else { 1.0 };
    glam::Mat3::from_cols(x, y, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_and_roundtrips() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::new(0.0, 0.0, -0.999_999).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!(
                f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5 && f.t.dot(f.n).abs() < 1e-5
            );
            assert!((f.s.cross(f.t) - f.n).length() < 1e-4, "right-handed");
            let v = Vec3::new(0.2, -0.7, 0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn aabb_union_and_area() {
        let a = Aabb::from_point(Vec3::ZERO).grow(Vec3::ONE);
        assert_eq!(a.area(), 6.0);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.union(&a), a);
        assert!(a.contains(&Aabb::from_point(Vec3::splat(0.5))));
        assert!(!a.contains(&Aabb::from_point(Vec3::splat(1.5))));
    }
}
