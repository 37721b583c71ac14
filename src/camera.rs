//! The CS184 pinhole camera.
//!
//! CS184 takes only a viewing direction from the scene's camera node: `c_dir =
//! normalize(T·(0,0,−1,1))` (the node's translation is included). The eye is placed at the
//! centre of the scene's bounding box plus `r·c_dir` with `r = 1.5·|max − min|`, looking at the
//! centre with world +Y up. Fields of view are fitted to an 800×600 window (the narrower axis
//! is widened to 4:3), and the screen distance in pixels, `600 / (2·tan(vfov/2))`, is kept for
//! any render size: a 480×360 image is the centre crop of the 800×600 view.

use crate::error::{Error, Loc, Result};
use crate::io::desc::CameraDesc;
use crate::math::{Aabb, Ray};
use crate::sampling::concentric_disk;
use glam::{Vec2, Vec3, Vec4};
use std::path::Path;

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
    /// The point looked at (the scene centre for the CS184 placement).
    pub target: Vec3,
    /// Thin-lens radius in scene units (`-b`); 0 is a pinhole.
    pub lens_radius: f32,
    /// Distance from the eye to the plane of focus along `forward`, scene units (`-d`).
    pub focal_distance: f32,
    /// An orthographic camera (pbrt-v4's `orthographic`): rays leave the image plane
    /// parallel to `forward`, the shorter image axis spanning 2 scene units; otherwise a
    /// perspective one.
    pub orthographic: bool,
    /// Near clip distance (kept for camera files).
    pub near: f32,
    /// Far clip distance (kept for camera files).
    pub far: f32,
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
            target,
            lens_radius: 0.0,
            focal_distance: (target - pos).length().max(1e-6),
            orthographic: false,
            near: 0.001,
            far: 1000.0,
        }
    }

    /// A camera at `pos` looking at `target` with `up` as the up direction and a vertical
    /// field of view of `vfov_deg` over an image `height` pixels high (pbrt's and Mitsuba's
    /// convention, unlike CS184's fit to an 800×600 window). `None` if the view is degenerate
    /// (`up` along the view, `pos` at `target`, a field of view outside (0°, 180°)).
    pub fn look_at_up(
        pos: Vec3,
        target: Vec3,
        up: Vec3,
        vfov_deg: f64,
        height: u32,
    ) -> Option<Camera> {
        let forward = (target - pos).normalize_or_zero();
        let right = forward.cross(up).normalize_or_zero();
        if forward == Vec3::ZERO || right == Vec3::ZERO || !(vfov_deg > 0.0 && vfov_deg < 180.0) {
            return None;
        }
        let mut cam = Camera::look_at(pos, target, 50.0, 40.0);
        cam.right = right;
        cam.up = right.cross(forward);
        cam.set_vfov(vfov_deg, height);
        Some(cam)
    }

    /// Sets the vertical field of view to `vfov_deg` over an image `height` pixels high,
    /// keeping the position and direction. The window fields of view (what CS184 camera files
    /// record) are set to match, so that saving and loading keeps the view.
    pub fn set_vfov(&mut self, vfov_deg: f64, height: u32) {
        let f = height.max(1) as f64 / (2.0 * (vfov_deg.to_radians() / 2.0).tan());
        self.focal_px = f as f32;
        self.vfov_deg = 2.0 * (WINDOW_H / (2.0 * f)).atan().to_degrees();
        self.hfov_deg = 2.0 * (WINDOW_W / (2.0 * f)).atan().to_degrees();
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
        let dir = cs184_direction(desc);
        let (center, r) = if bounds.is_empty() {
            (Vec3::ZERO, 1.0)
        } else {
            (bounds.center(), 1.5 * bounds.extent().length())
        };
        let mut cam = Camera::look_at(center + dir * r.max(1e-3), center, h, v);
        if let Some(c) = desc {
            (cam.near, cam.far) = (c.znear, c.zfar);
        }
        cam
    }

    /// A camera looking along `forward` (world +Y up) at the centre of `bounds`, with a
    /// vertical field of view of `vfov_deg` over a `width × height` image, as near as it can
    /// be while every corner of the box projects inside the middle `fill` (0 < fill ≤ 1) of
    /// both image axes: the whole box, with a margin (Blender's "view all"). The CS184
    /// placement for an empty box.
    pub fn framing(
        bounds: &Aabb,
        forward: Vec3,
        vfov_deg: f64,
        width: u32,
        height: u32,
        fill: f32,
    ) -> Camera {
        if bounds.is_empty() {
            return Camera::cs184(None, bounds);
        }
        let center = bounds.center();
        let basis = Camera::look_at(center - forward, center, 50.0, 40.0);
        let tan_v = (vfov_deg.to_radians() / 2.0).tan() as f32 * fill;
        let tan_h = tan_v * width.max(1) as f32 / height.max(1) as f32;
        let size = bounds.extent().length();
        // The eye's distance from the centre: each corner within both half-angles, and in front.
        let mut distance = 1e-3 * size.max(1e-3);
        for corner in bounds.corners() {
            let corner = corner - center;
            let depth = corner.dot(basis.forward);
            let need_x = corner.dot(basis.right).abs() / tan_h;
            let need_y = corner.dot(basis.up).abs() / tan_v;
            distance = distance.max(need_x.max(need_y) - depth);
            distance = distance.max(1e-3 * size - depth);
        }
        let mut cam = Camera::look_at(center - basis.forward * distance, center, 50.0, 40.0);
        cam.set_vfov(vfov_deg, height);
        cam.far = cam.far.max(distance + size);
        cam
    }

    /// The ray through continuous pixel position `(x, y)` of a `width × height` image; `lens`
    /// is a uniform point of the unit square, used only when `lens_radius > 0`. Thin lens: the
    /// origin is uniform on the lens disk, and every ray of the pixel passes through the point
    /// its pinhole ray reaches on the plane of focus (`focal_distance` along `forward`).
    #[inline]
    pub fn ray(&self, x: f32, y: f32, width: u32, height: u32, lens: Vec2) -> Ray {
        let dx = x - width as f32 * 0.5;
        let dy = height as f32 * 0.5 - y;
        if self.orthographic {
            return self.ortho_ray(dx, dy, width.min(height), lens);
        }
        let d = (self.forward * self.focal_px + self.right * dx + self.up * dy).normalize();
        if self.lens_radius <= 0.0 {
            return Ray::new(self.pos, d);
        }
        let focus = self.pos + d * (self.focal_distance / d.dot(self.forward));
        let l = concentric_disk(lens) * self.lens_radius;
        let o = self.pos + self.right * l.x + self.up * l.y;
        Ray::new(o, (focus - o).normalize())
    }

    /// An orthographic ray through the point `(dx, dy)` pixels from the image's centre (the
    /// shorter side `short` pixels spanning 2 units), through a thin lens as
    /// [`Camera::ray`]'s.
    #[inline(never)]
    fn ortho_ray(&self, dx: f32, dy: f32, short: u32, lens: Vec2) -> Ray {
        let scale = 2.0 / short.max(1) as f32;
        let o = self.pos + (self.right * dx + self.up * dy) * scale;
        if self.lens_radius <= 0.0 {
            return Ray::new(o, self.forward);
        }
        let focus = o + self.forward * self.focal_distance;
        let l = concentric_disk(lens) * self.lens_radius;
        let o = o + self.right * l.x + self.up * l.y;
        Ray::new(o, (focus - o).normalize())
    }

    /// Writes the camera in the CS184 text format: line 1 `hFov vFov aspect nClip fClip`;
    /// line 2 position and target; line 3 `phi theta r minR maxR`; line 4 the 3×3
    /// camera-to-world matrix row by row (columns: right, up, backward); line 5
    /// `screenW screenH screenDist`; line 6 `focalDistance lensRadius`. Numbers are written in
    /// their shortest exact form, so that [`Camera::load_cs184`] restores the same camera.
    pub fn save_cs184(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        let back = -self.forward;
        let off = self.pos - self.target;
        let r = off.length();
        let phi = if r > 0.0 {
            (off.y / r).clamp(-1.0, 1.0).acos()
        } else {
            0.0
        };
        let theta = off.x.atan2(off.z);
        let aspect =
            (self.hfov_deg.to_radians() / 2.0).tan() / (self.vfov_deg.to_radians() / 2.0).tan();
        let text = format!(
            "{} {} {} {} {}\n{} {} {} {} {} {}\n{} {} {} {} {}\n{} {} {} {} {} {} {} {} {}\n{} {} {}\n{} {}\n",
            self.hfov_deg, self.vfov_deg, aspect, self.near, self.far,
            self.pos.x, self.pos.y, self.pos.z, self.target.x, self.target.y, self.target.z,
            phi, theta, r, 0.0, r * 100.0,
            self.right.x, self.up.x, back.x, self.right.y, self.up.y, back.y, self.right.z, self.up.z, back.z,
            width, height, self.focal_px,
            self.focal_distance, self.lens_radius
        );
        crate::io::atomic::write(path, "cannot write camera file", |w| {
            std::io::Write::write_all(w, text.as_bytes())
        })
    }

    /// Reads a camera in the CS184 text format (see [`Camera::save_cs184`]). The position, the
    /// matrix (orientation), the fields of view, the clip distances and the lens come from the
    /// file; line 3 and line 5 are checked but derived quantities (the screen distance follows
    /// from vFov as for every CS184 camera). Errors give the line.
    pub fn load_cs184(path: &Path) -> Result<Camera> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: file.clone(),
            what: "cannot read camera file",
            source,
        })?;
        Camera::parse_cs184(&text, &file)
    }

    /// Parses the text of a CS184 camera file (see [`Camera::load_cs184`]); `file` names it
    /// in errors.
    pub fn parse_cs184(text: &str, file: &str) -> Result<Camera> {
        let file = file.to_string();
        let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
        let expect = [
            (5, "hFov vFov aspect nClip fClip"),
            (6, "position and target"),
            (5, "phi theta r minR maxR"),
            (9, "a 3x3 camera-to-world matrix"),
            (3, "screenW screenH screenDist"),
            (2, "focalDistance lensRadius"),
        ];
        if lines.len() < expect.len() {
            return Err(Error::At {
                file,
                loc: Loc {
                    line: lines.len() as u32 + 1,
                    col: 0,
                },
                msg: format!("camera file ends early: {} lines, expected 6", lines.len()),
            });
        }
        let mut rows: Vec<Vec<f64>> = Vec::new();
        for (i, ((n, what), line)) in expect.iter().zip(&lines).enumerate() {
            let at = |msg: String| Error::At {
                file: file.clone(),
                loc: Loc {
                    line: i as u32 + 1,
                    col: 0,
                },
                msg,
            };
            let vals: Vec<f64> = line
                .split_whitespace()
                .map(|t| {
                    t.parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| at(format!("'{t}' is not a finite number")))
                })
                .collect::<Result<_>>()?;
            if vals.len() != *n {
                return Err(at(format!(
                    "expected {n} numbers ({what}), found {}",
                    vals.len()
                )));
            }
            rows.push(vals);
        }
        let v3 = |r: &[f64]| Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32);
        let (hfov, vfov) = (rows[0][0], rows[0][1]);
        if !(hfov > 0.0 && hfov < 180.0 && vfov > 0.0 && vfov < 180.0) {
            return Err(Error::At {
                file,
                loc: Loc { line: 1, col: 0 },
                msg: format!("fields of view must be in (0, 180) degrees, not {hfov} and {vfov}"),
            });
        }
        let m = &rows[3];
        let right = Vec3::new(m[0] as f32, m[3] as f32, m[6] as f32);
        let up = Vec3::new(m[1] as f32, m[4] as f32, m[7] as f32);
        let back = Vec3::new(m[2] as f32, m[5] as f32, m[8] as f32);
        if (right.length() - 1.0).abs() > 1e-3
            || (up.length() - 1.0).abs() > 1e-3
            || (back.length() - 1.0).abs() > 1e-3
            || right.dot(up).abs() > 1e-3
            || right.dot(back).abs() > 1e-3
        {
            return Err(Error::At {
                file,
                loc: Loc { line: 4, col: 0 },
                msg:
                    "the camera-to-world matrix is not a rotation (its columns must be orthonormal)"
                        .into(),
            });
        }
        let (focal_distance, lens_radius) = (rows[5][0] as f32, rows[5][1] as f32);
        if focal_distance <= 0.0 || lens_radius < 0.0 {
            return Err(Error::At { file, loc: Loc { line: 6, col: 0 }, msg: format!("focal distance must be positive and lens radius non-negative, not {focal_distance} and {lens_radius}") });
        }
        Ok(Camera {
            pos: v3(&rows[1][0..3]),
            right,
            up,
            forward: -back,
            focal_px: (WINDOW_H / (2.0 * (vfov.to_radians() / 2.0).tan())) as f32,
            hfov_deg: hfov,
            vfov_deg: vfov,
            target: v3(&rows[1][3..6]),
            lens_radius,
            focal_distance,
            orthographic: false,
            near: rows[0][3] as f32,
            far: rows[0][4] as f32,
        })
    }
}

/// The unit direction from the scene centre towards the CS184 eye: `normalize(T·(0,0,−1,1))`
/// of the camera node (+Z without a camera or for a degenerate transform).
pub fn cs184_direction(desc: Option<&CameraDesc>) -> Vec3 {
    let dir = desc
        .map(|c| (c.transform * Vec4::new(0.0, 0.0, -1.0, 1.0)).truncate())
        .unwrap_or(Vec3::Z);
    if dir.length_squared() > 0.0 && dir.is_finite() {
        dir.normalize()
    } else {
        Vec3::Z
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
            exact: false,
            fov_axis: crate::io::desc::FovAxis::Height,
            right_is_x: false,
            lens: None,
            orthographic: false,
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
        let c = cam.ray(400.0, 300.0, 800, 600, Vec2::ZERO);
        assert!((c.d + Vec3::Z).length() < 1e-6);
        let e = cam.ray(800.0, 300.0, 800, 600, Vec2::ZERO);
        let angle = e.d.dot(cam.forward).acos().to_degrees();
        assert!((angle - 30.0).abs() < 1e-3, "{angle}");
        // A 480×360 render is the centre crop: its edge ray is at 240 px from the axis.
        let e = cam.ray(480.0, 180.0, 480, 360, Vec2::ZERO);
        let expect = (240.0 / cam.focal_px as f64).atan().to_degrees();
        assert!((e.d.dot(cam.forward).acos().to_degrees() as f64 - expect).abs() < 1e-3);
        // Right is +X when looking down −Z; the top row looks up.
        assert!(cam.right.x > 0.99 && cam.ray(240.0, 0.0, 480, 360, Vec2::ZERO).d.y > 0.0);
    }
}
