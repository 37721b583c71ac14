//! The built-in studio light: a soft, neutral environment that lights a model file without
//! lights of its own (OBJ, PLY, glTF), as model viewers do, so that a user's first image of a
//! scan or an asset is not black.
//!
//! It is a latitude-longitude map made here (`image`): a grey dome, brighter overhead than
//! below, and one round soft box up and to the left of the default view (which looks down
//! −Z from +Z). A white diffuse surface facing the view comes out at about 0.7.

use super::env::{uv_to_dir, EnvLight, EnvSampling};
use crate::io::image::Image;
use crate::math::Rgb;
use glam::{Vec2, Vec3};

/// Width of the map in texels (its height is half).
const WIDTH: usize = 256;
/// Radiance of the dome straight up, at the horizon and straight down.
const DOME: [f32; 3] = [0.45, 0.25, 0.08];
/// Radiance of the soft box.
const BOX_RADIANCE: f32 = 9.0;
/// Angular radius of the soft box's full-radiance core, and of its soft edge, degrees.
const BOX_RADII_DEG: [f32; 2] = [14.0, 20.0];

/// The direction from the model towards the soft box: up, left of and in front of the view.
fn box_direction() -> Vec3 {
    Vec3::new(-0.6, 0.8, 0.7).normalize()
}

/// The studio's radiance arriving from direction `towards` (unit, pointing away from the
/// model).
pub fn radiance(towards: Vec3) -> Rgb {
    let up = towards.y.clamp(-1.0, 1.0);
    let dome = if up >= 0.0 {
        DOME[1] + (DOME[0] - DOME[1]) * up
    } else {
        DOME[1] + (DOME[1] - DOME[2]) * up
    };
    let [core, edge] = BOX_RADII_DEG.map(|deg| deg.to_radians().cos());
    let cos = towards.dot(box_direction());
    let soft_box = ((cos - edge) / (core - edge)).clamp(0.0, 1.0);
    Rgb::splat(dome + BOX_RADIANCE * soft_box * soft_box * (3.0 - 2.0 * soft_box))
}

/// The studio as a latitude-longitude map: each texel the radiance at its centre.
pub fn image() -> Image {
    let (w, h) = (WIDTH, WIDTH / 2);
    let mut img = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let uv = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            img.pixels[y * w + x] = radiance(uv_to_dir(uv));
        }
    }
    img
}

/// The studio as an environment light sampled as `sampling`.
pub fn light(sampling: EnvSampling) -> EnvLight {
    EnvLight::new(image(), sampling)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_studio_is_neutral_soft_and_brighter_above() {
        let img = image();
        assert!(img
            .pixels
            .iter()
            .all(|p| p.x == p.y && p.y == p.z && p.x > 0.0));
        assert!(radiance(Vec3::Y).x > radiance(Vec3::NEG_Y).x);
        let peak = radiance(box_direction()).x;
        assert!((peak - DOME[1] - BOX_RADIANCE).abs() < 1.0, "{peak}");
        // Away from the soft box, the dome alone.
        assert_eq!(radiance(Vec3::NEG_Z).x, DOME[1]);
        // A white diffuse surface facing the default view (+Z) reflects E/π ≈ 0.7.
        let (w, h) = (img.width, img.height);
        let mut irradiance = 0.0;
        for y in 0..h {
            let theta = (y as f32 + 0.5) / h as f32 * std::f32::consts::PI;
            // dθ = π/h and dφ = 2π/w = π/h.
            let solid_angle = theta.sin() * (std::f32::consts::PI / h as f32).powi(2);
            for x in 0..w {
                let uv = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                let cos = uv_to_dir(uv).z.max(0.0);
                irradiance += img.pixels[y * w + x].x * cos * solid_angle;
            }
        }
        let white = irradiance / std::f32::consts::PI;
        assert!((0.65..0.75).contains(&white), "{white}");
    }
}
