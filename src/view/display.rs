//! What the viewer shows besides the image itself: display-only exposure and false colours,
//! and CS184's BVH view (a binary BVH over the scene's primitives, boxes projected into the
//! image as line segments). Nothing here changes a pixel of the render.

use crate::accel::bvh::Bvh;
use crate::camera::Camera;
use crate::io::image::{false_colour, Image};
use crate::math::Aabb;
use crate::scene::Scene;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// What the image shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// The radiance, scaled by the exposure.
    #[default]
    Colour,
    /// Samples per pixel, relative to the largest count (CS184's rate image colours).
    Rate,
    /// Relative variance of each pixel's mean (variance over mean² + 0.01), on a log scale
    /// from 10⁻⁴ (blue) to 1 (red).
    Variance,
}

/// A [`Display`] as a cache key: mode, exposure bits, denoised.
pub type DisplayKey = (Mode, u32, bool);

/// How one client wants the image shown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Display {
    /// Exposure in stops (the radiance is multiplied by 2^exposure), within ±20.
    #[serde(default)]
    pub exposure: f32,
    /// What the image shows.
    #[serde(default)]
    pub mode: Mode,
    /// Show the denoised image of the latest pass (in the colour mode, where the viewer's
    /// `denoise` setting is on and one is ready).
    #[serde(default)]
    pub denoised: bool,
}

impl Display {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.exposure.is_finite() && self.exposure.abs() <= 20.0) {
            return Err(format!(
                "exposure must be within ±20 stops, not {}",
                self.exposure
            ));
        }
        Ok(())
    }

    /// A key for caching encoded frames.
    pub fn key(&self) -> DisplayKey {
        (self.mode, self.exposure.to_bits(), self.denoised)
    }

    /// Whether this display shows the denoised image, where there is one.
    pub fn wants_denoised(&self) -> bool {
        self.denoised && self.mode == Mode::Colour
    }
}

/// Per-pixel figures of the film, frame-sized and row-major.
#[derive(Clone, Debug, Default)]
pub struct Figures {
    /// Samples per pixel.
    pub rate: Vec<u32>,
    /// Relative variance of the pixel's mean.
    pub variance: Vec<f32>,
}

/// The image as `d` shows it. Without figures (a preview), false-colour modes show the colour.
pub fn shown(img: &Image, figures: Option<&Figures>, d: &Display) -> Image {
    let n = img.pixels.len();
    match (d.mode, figures) {
        (Mode::Rate, Some(f)) if f.rate.len() == n => {
            crate::io::image::sample_rate_image(&f.rate, img.width, img.height)
        }
        (Mode::Variance, Some(f)) if f.variance.len() == n => {
            let mut out = Image::new(img.width, img.height);
            for (p, &v) in out.pixels.iter_mut().zip(&f.variance) {
                let t = if v > 0.0 {
                    (v.log10() + 4.0) / 4.0
                } else {
                    0.0
                };
                *p = false_colour(t);
            }
            out
        }
        _ => {
            let mut out = img.clone();
            if d.exposure != 0.0 {
                let k = d.exposure.exp2();
                for p in &mut out.pixels {
                    *p *= k;
                }
            }
            out
        }
    }
}

/// A binary BVH over the scene's triangles and spheres, for CS184's BVH view.
pub struct BvhView {
    bvh: Bvh,
    /// Parent of each node (the root's is itself).
    parent: Vec<u32>,
    /// Primitives under each node.
    prims: Vec<u32>,
}

/// One node as the page shows it.
#[derive(Clone, Debug, Serialize)]
pub struct NodeView {
    /// Node index (0 is the root).
    pub node: u32,
    /// The parent's index, absent at the root.
    pub parent: Option<u32>,
    /// The two children of an interior node (none for a leaf).
    pub children: Vec<u32>,
    /// Primitives under the node.
    pub prims: u32,
    /// Primitives under each child.
    pub child_prims: Vec<u32>,
    /// The node's box projected into the image: segments `[x0, y0, x1, y1]` in pixels.
    pub lines: Vec<[f32; 4]>,
    /// The children's boxes, in the same form.
    pub child_lines: Vec<Vec<[f32; 4]>>,
}

impl BvhView {
    /// Builds the tree over `scene`'s primitives (triangles, then spheres).
    pub fn new(scene: &Scene) -> BvhView {
        let bounds: Vec<Aabb> = scene
            .tris
            .iter()
            .map(|t| t.bounds())
            .chain(scene.spheres.iter().map(|s| s.bounds()))
            .collect();
        let bvh = Bvh::build(&bounds);
        let n = bvh.nodes.len();
        let mut parent = vec![0u32; n];
        let mut prims = vec![0u32; n];
        // Children follow their parent in depth-first order, so a backward sweep sums them.
        for i in 0..n {
            let node = &bvh.nodes[i];
            if node.count == 0 {
                parent[i + 1] = i as u32;
                parent[node.offset as usize] = i as u32;
            }
        }
        for i in (0..n).rev() {
            let node = &bvh.nodes[i];
            prims[i] = if node.count == 0 {
                prims[i + 1] + prims[node.offset as usize]
            } else {
                node.count as u32
            };
        }
        BvhView { bvh, parent, prims }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.bvh.nodes.len()
    }

    /// Whether the tree has no node (a scene without primitives).
    pub fn is_empty(&self) -> bool {
        self.bvh.nodes.is_empty()
    }

    /// Node `i` seen through `cam` in a `w`×`h` image, or `None` if there is no such node.
    pub fn node(&self, i: u32, cam: &Camera, (w, h): (u32, u32)) -> Option<NodeView> {
        let node = self.bvh.nodes.get(i as usize)?;
        let children: Vec<u32> = if node.count == 0 {
            vec![i + 1, node.offset]
        } else {
            vec![]
        };
        let lines = |j: u32| box_lines(&self.bvh.nodes[j as usize].bounds(), cam, (w, h));
        Some(NodeView {
            node: i,
            parent: (i != 0).then(|| self.parent[i as usize]),
            prims: self.prims[i as usize],
            child_prims: children.iter().map(|&c| self.prims[c as usize]).collect(),
            lines: lines(i),
            child_lines: children.iter().map(|&c| lines(c)).collect(),
            children,
        })
    }
}

/// The 12 edges of `b` projected through the pinhole of `cam` into a `w`×`h` image (the
/// inverse of [`Camera::ray`]), each clipped to the part in front of the eye.
pub fn box_lines(b: &Aabb, cam: &Camera, (w, h): (u32, u32)) -> Vec<[f32; 4]> {
    const NEAR: f32 = 1e-3;
    let corner = |k: usize| {
        Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        )
    };
    // Camera space: x right, y up, z along the view.
    let to_cam = |p: Vec3| {
        let v = p - cam.pos;
        Vec3::new(v.dot(cam.right), v.dot(cam.up), v.dot(cam.forward))
    };
    let project = |v: Vec3| {
        [
            w as f32 * 0.5 + v.x * cam.focal_px / v.z,
            h as f32 * 0.5 - v.y * cam.focal_px / v.z,
        ]
    };
    let mut out = Vec::with_capacity(12);
    for a in 0..8usize {
        for bit in [1usize, 2, 4] {
            if a & bit != 0 {
                continue;
            }
            let (mut p, mut q) = (to_cam(corner(a)), to_cam(corner(a | bit)));
            if p.z < NEAR && q.z < NEAR {
                continue;
            }
            // Clip the segment to z >= NEAR.
            if p.z < NEAR {
                p = p + (q - p) * ((NEAR - p.z) / (q.z - p.z));
            } else if q.z < NEAR {
                q = q + (p - q) * ((NEAR - q.z) / (p.z - q.z));
            }
            let (s, e) = (project(p), project(q));
            if s.iter().chain(&e).all(|c| c.is_finite() && c.abs() < 1e7) {
                out.push([s[0], s[1], e[0], e[1]]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_projected_box_corner_is_where_the_camera_ray_of_that_pixel_goes() {
        let cam = Camera::look_at(
            Vec3::new(0.0, 1.0, 4.0),
            Vec3::new(0.0, 1.0, 0.0),
            50.0,
            40.0,
        );
        let b = Aabb {
            min: Vec3::new(-0.5, 0.5, -0.5),
            max: Vec3::new(0.3, 1.2, 0.4),
        };
        let lines = box_lines(&b, &cam, (480, 360));
        assert_eq!(lines.len(), 12);
        for l in &lines {
            for (x, y) in [(l[0], l[1]), (l[2], l[3])] {
                // The pixel's ray passes through one of the corners.
                let r = cam.ray(x, y, 480, 360, glam::Vec2::ZERO);
                let near_corner = (0..8).any(|k| {
                    let c = Vec3::new(
                        if k & 1 == 0 { b.min.x } else { b.max.x },
                        if k & 2 == 0 { b.min.y } else { b.max.y },
                        if k & 4 == 0 { b.min.z } else { b.max.z },
                    );
                    let t = (c - r.o).dot(r.d);
                    (r.o + r.d * t - c).length() < 1e-4
                });
                assert!(near_corner, "{x} {y}");
            }
        }
    }

    #[test]
    fn exposure_and_false_colours_are_for_display_only() {
        let mut img = Image::new(2, 1);
        img.pixels[0] = Vec3::splat(0.25);
        img.pixels[1] = Vec3::splat(1.0);
        let d = Display {
            exposure: 2.0,
            mode: Mode::Colour,
            denoised: false,
        };
        assert_eq!(shown(&img, None, &d).pixels[0], Vec3::splat(1.0));
        let f = Figures {
            rate: vec![1, 4],
            variance: vec![1e-4, 1.0],
        };
        let rate = shown(
            &img,
            Some(&f),
            &Display {
                mode: Mode::Rate,
                ..d
            },
        );
        assert_eq!(rate.pixels[1], Vec3::new(1.0, 0.0, 0.0));
        let var = shown(
            &img,
            Some(&f),
            &Display {
                mode: Mode::Variance,
                ..d
            },
        );
        assert_eq!(var.pixels[0], Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(var.pixels[1], Vec3::new(1.0, 0.0, 0.0));
        // Without figures (a preview) the colour is shown.
        assert_eq!(
            shown(
                &img,
                None,
                &Display {
                    mode: Mode::Rate,
                    ..d
                }
            )
            .pixels[0],
            Vec3::splat(1.0)
        );
        assert!(Display {
            exposure: f32::NAN,
            ..d
        }
        .validate()
        .is_err());
    }
}
