//! Media: the file's participating media that are rendered, the camera's medium, and the
//! ids that material interfaces refer to.

use super::Builder;
use crate::io::desc::MediumInterfaceDesc;
use crate::medium::{Homogeneous, Medium, MediumInterface, NO_MEDIUM};

impl Builder<'_> {
    /// The media of the description (the loaders have warned about kinds not rendered: their
    /// space is left empty) and the camera's medium.
    pub(super) fn media(&mut self) {
        for m in &self.desc.media {
            let valid = m.sigma_a.is_finite()
                && m.sigma_s.is_finite()
                && m.sigma_a.min_element() >= 0.0
                && m.sigma_s.min_element() >= 0.0;
            let id = if m.kind == "homogeneous" && valid {
                self.media.push(Medium::Homogeneous(Homogeneous {
                    sigma_a: m.sigma_a,
                    sigma_s: m.sigma_s,
                    g: m.g.clamp(-0.999, 0.999),
                }));
                self.media.len() as u32 - 1
            } else {
                NO_MEDIUM
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
