//! Media: the file's participating media that are rendered, the camera's medium, and the
//! ids that material interfaces refer to.

use super::Builder;
use crate::io::desc::{MediumCoefficients, MediumDesc, MediumInterfaceDesc};
use crate::medium::grid::Temperature;
use crate::medium::{GridMedium, Homogeneous, Medium, MediumInterface, NO_MEDIUM};
use glam::Affine3A;

impl Builder<'_> {
    /// The media of the description (the loaders have warned about kinds not rendered: their
    /// space is left empty) and the camera's medium.
    pub(super) fn media(&mut self) {
        for m in &self.desc.media {
            let id = match medium(m) {
                Some(medium) => {
                    self.media.push(medium);
                    self.media.len() as u32 - 1
                }
                None => NO_MEDIUM,
            };
            self.medium_ids.push(id);
        }
        self.camera_medium = self.medium_id(self.desc.camera_medium);
    }

    /// The scene's id of description medium `i`.
    fn medium_id(&self, i: Option<u32>) -> u32 {
        i.and_then(|i| self.medium_ids.get(i as usize).copied())
            .unwrap_or(NO_MEDIUM)
    }

    /// The scene's interface of a description interface; `None` where both sides are the
    /// same (no boundary).
    pub(super) fn interface(&self, i: Option<MediumInterfaceDesc>) -> Option<MediumInterface> {
        let i = i?;
        let m = MediumInterface {
            inside: self.medium_id(i.inside),
            outside: self.medium_id(i.outside),
        };
        (m.inside != m.outside).then_some(m)
    }
}

/// The medium description `m` makes; `None` for kinds not rendered or invalid coefficients
/// (the loaders report those).
fn medium(m: &MediumDesc) -> Option<Medium> {
    let g = m.g.clamp(-0.999, 0.999);
    match m.coefficients.as_ref()? {
        MediumCoefficients::Homogeneous {
            sigma_a,
            sigma_s,
            le,
        } => {
            let valid = |c: &glam::Vec3| c.is_finite() && c.min_element() >= 0.0;
            (valid(sigma_a) && valid(sigma_s) && valid(le)).then_some(Medium::Homogeneous(
                Homogeneous {
                    sigma_a: *sigma_a,
                    sigma_s: *sigma_s,
                    g,
                    le: *le,
                },
            ))
        }
        MediumCoefficients::Grid(d) => {
            let to_unit = Affine3A::from_mat4(d.to_unit);
            let fields = (d.sigma_a, d.sigma_s, d.emission);
            let mut grid = GridMedium::new(to_unit, d.grids.clone(), fields, g).ok()?;
            if let Some((i, offset, scale)) = d.temperature {
                let hottest = (grid.grid_max(i as usize) - offset) * scale;
                let rgb = crate::io::pbrt::spectra::blackbody_peak_rgb;
                let t = Temperature::new((i, offset, scale), hottest, rgb);
                grid = grid.with_temperature(t).ok()?;
            }
            Some(Medium::Grid(Box::new(grid.clipped(d.bounds.0, d.bounds.1))))
        }
    }
}
