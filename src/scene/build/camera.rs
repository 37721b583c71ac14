//! The camera: where the file puts it, or CS184's placement from the scene's bounds.

use super::Builder;
use crate::camera::Camera;
use glam::Vec3;

impl Builder<'_> {
    /// The file's camera (its vertical field of view over a 600-pixel-high image here; the
    /// render sets it over the image's height, `Camera::set_vfov`), or CS184's placement.
    pub(super) fn camera(&mut self) -> Camera {
        let desc = self.desc;
        match &desc.camera {
            Some(c) if c.exact => {
                let t = c.transform;
                let pos = t.transform_point3(Vec3::ZERO);
                let forward = t.transform_vector3(Vec3::NEG_Z);
                let up = t.transform_vector3(Vec3::Y);
                Camera::look_at_up(
                    pos,
                    pos + forward,
                    up,
                    c.yfov_deg.unwrap_or(40.0) as f64,
                    600,
                )
                .map(|mut cam| {
                    (cam.near, cam.far) = (c.znear, c.zfar);
                    if c.right_is_x {
                        cam.right = t.transform_vector3(Vec3::X).normalize_or(cam.right);
                    }
                    if let Some((radius, distance)) = c.lens {
                        (cam.lens_radius, cam.focal_distance) = (radius, distance);
                    }
                    cam.orthographic = c.orthographic;
                    cam
                })
                .unwrap_or_else(|| {
                    self.warnings.push(format!(
                        "{}: camera {:?} has a degenerate transform; the default view is used",
                        desc.file, c.name
                    ));
                    Camera::cs184(None, &self.bounds)
                })
            }
            c => Camera::cs184(c.as_ref(), &self.bounds),
        }
    }
}
