//! The CS184 pinhole camera.
//!
//! CS184 takes only a viewing direction from the scene's camera node: `c_dir =
//! normalize(T·(0,0,−1,1))` (the node's translation is included). The eye is placed at the
//! centre of the scene's bounding box plus `r·c_dir` with `r = 1.5·|max − min|`, looking at the
//! centre with world +Y up. Fields of view are fitted to an 800×600 window (the narrower axis
//! is widened to 4:3), and the screen distance in pixels, `600 / (2·tan(vfov/2))`, is kept for
//! any render size: a 480×360 image is the centre crop of the 800×600 view.

use crate::io::desc::CameraDesc;
use crate::math::{Aabb, Ray};
use glam::{Vec3, Vec4};

/// A pinhole camera; pixel coordinates run right and down from the top-left corner.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Eye position, world space.
    pub pos: Vec3,
    /// Unit right vector.
    pub right: Vec3,
    /// Unit up vector.
    pub up: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Distance from the eye to the image plane, in pixels.
    pub focal_px: f32,
    /// Horizontal field of view of the 800×600 window, degrees.
    pub hfov_deg: f64,
    /// Vertical field of view of the 800×600 window, degrees.
    pub vfov_deg: f64,
}

/// Width of the CS184 window that fields of view are fitted to, in pixels.
pub const WINDOW_W: f64 = 800.0;
/// Height of the CS184 window, in pixels.
pub const WINDOW_H: f64 = 600.0;

impl Camera {
    /// A camera at `pos` looking at `target` with world +Y up and the given window fields of view.
    pub fn look_at(pos: Vec3, target: Vec3, hfov_deg: f64, vfov_deg: f64) -> Camera {
        let forward = (target - pos).normalize_or(Vec3::NEG_Z);
        let world_up = if forward.cross(Vec3::Y).length_squared() < 1e-10 {
            Vec3::NEG_Z
        } else {
            Vec3::Y
        };
        let right = forward.cross(world_up).normalize();
        let up = right.cross(forward);
        let focal_px = (WINDOW_H / (2.0 * (vfov_deg.to_radians() / 2.0).tan())) as f32;
        Camera {
            pos,
            right,
            up,
            forward,
            focal_px,
            hfov_deg,
            vfov_deg,
        }
    }

    /// The CS184 placement for a scene whose geometry spans `bounds`.
    pub fn cs184(desc: Option<&CameraDesc>, bounds: &Aabb) -> Camera {
        let (mut h, mut v) = fovs(desc);
        // Fit to the 800×600 window: widen whichever axis is narrower than 4:3.
        let ar = WINDOW_W / WINDOW_H;
        let ar1 = (h.to_radians() / 2.0).tan() / (v.to_radians() / 2.0).tan();
        if ar1 < ar {
            h = 2.0 * ((v.to_radians() / 2.0).tan() * ar).atan().to_degrees();
        } else if ar1 > ar {
            v = 2.0 * ((h.to_radians() / 2.0).tan() / ar).atan().to_degrees();
        }
        let dir = desc
            .map(|c| (c.transform * Vec4::new(0.0, 0.0, -1.0, 1.0)).truncate())
            .unwrap_or(Vec3::Z);
        let dir = if dir.length_squared() > 0.0 && dir.is_finite() {
            dir.normalize()
        } else {
            Vec3::Z
        };
        let (center, r) = if bounds.is_empty() {
            (Vec3::ZERO, 1.0)
        } else {
            (bounds.center(), 1.5 * bounds.extent().length())
        };
        Camera::look_at(center + dir * r.max(1e-3), center, h, v)
    }

    /// The ray through continuous pixel position `(x, y)` of a `width × height` image.
    #[inline]
    pub fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> Ray {
        let dx = x - width as f32 * 0.5;
        let dy = height as f32 * 0.5 - y;
        let d = (self.forward * self.focal_px + self.right * dx + self.up * dy).normalize();
        Ray::new(self.pos, d)
    }
}

/// Horizontal and vertical field of view in degrees, as CS184 derives them from the file.
fn fovs(desc: Option<&CameraDesc>) -> (f64, f64) {
    let Some(c) = desc else {
        return (
            50.0,
            2.0 * ((25f64).to_radians().tan() / (4.0 / 3.0))
                .atan()
                .to_degrees(),
        );
    };
    let from =
        |fov: f64, ratio: f64| 2.0 * ((fov.to_radians() / 2.0).tan() * ratio).atan().to_degrees();
    let aspect = c.aspect.map(|a| a as f64).unwrap_or(WINDOW_W / WINDOW_H);
    match (c.xfov_deg, c.yfov_deg) {
        (Some(x), Some(y)) => (x as f64, y as f64),
        (Some(x), None) => (x as f64, from(x as f64, 1.0 / aspect)),
        (None, Some(y)) => (from(y as f64, aspect), y as f64),
        (None, None) => (50.0, from(50.0, 1.0 / aspect)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    #[test]
    fn cs184_placement_and_crop() {
        let bounds = Aabb {
            min: Vec3::new(-1.0, 0.0, -1.0),
            max: Vec3::new(1.0, 1.5, 1.0),
        };
        let desc = CameraDesc {
            name: "c".into(),
            xfov_deg: Some(60.0),
            yfov_deg: None,
            aspect: Some(4.0 / 3.0),
            znear: 0.1,
            zfar: 100.0,
            transform: Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0)),
            loc: Default::default(),
        };
        let cam = Camera::cs184(Some(&desc), &bounds);
        // T·(0,0,−1,1) = (0,0,4): the camera sits on +Z of the centre at 1.5 × the diagonal.
        let r = 1.5 * bounds.extent().length();
        assert!((cam.pos - (bounds.center() + Vec3::Z * r)).length() < 1e-4);
        assert!((cam.forward + Vec3::Z).length() < 1e-6);
        // The centre pixel looks at the centre; the edge of the 800-wide window is at hfov/2.
        let c = cam.ray(400.0, 300.0, 800, 600);
        assert!((c.d + Vec3::Z).length() < 1e-6);
        let e = cam.ray(800.0, 300.0, 800, 600);
        let angle = e.d.dot(cam.forward).acos().to_degrees();
        assert!((angle - 30.0).abs() < 1e-3, "{angle}");
        // A 480×360 render is the centre crop: its edge ray is at 240 px from the axis.
        let e = cam.ray(480.0, 180.0, 480, 360);
        let expect = (240.0 / cam.focal_px as f64).atan().to_degrees();
        assert!((e.d.dot(cam.forward).acos().to_degrees() as f64 - expect).abs() < 1e-3);
        // Right is +X when looking down −Z; the top row looks up.
        assert!(cam.right.x > 0.99 && cam.ray(240.0, 0.0, 480, 360).d.y > 0.0);
    }
}
