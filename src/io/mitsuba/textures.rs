//! Textures as BSDF parameters: `bitmap` (`filename`, `wrap_mode`, `raw`, `filter_type`
//! bilinear or nearest) and `checkerboard` (`color0`, `color1`: 2×2 texels looked up
//! nearest), both under `to_uv`, as the description's image textures.
//!
//! An 8-bit image is sRGB-decoded unless `raw`; float images (EXR, HDR) are linear. Texture
//! coordinates follow Mitsuba's (v down the image, OBJ's v flipped by the loader, as ours).
//! A texture standing for a number (an opacity, a height, a roughness or weight) gives its
//! colour's luminance, and a checkerboard's two colours swap places there, as in Mitsuba's
//! `eval_1`; other texture plugins are a warning naming the stand-in.

use super::xml::Node;
use super::Interp;
use crate::bsdf::Param;
use crate::error::Result;
use crate::io::desc::{TextureDesc, TextureSlot, Wrap};
use crate::io::image::{decode_texture_as, srgb_to_linear};
use crate::math::{luminance, Rgb};

impl<'a> Interp<'a> {
    /// A colour parameter: a nested or referenced texture (as an image texture for `slot`,
    /// its colour factor 1), else a colour property, else `default`.
    pub(super) fn colour_or_texture(
        &mut self,
        node: &'a Node,
        name: &str,
        default: Rgb,
        slot: TextureSlot,
    ) -> Result<(Rgb, Option<TextureDesc>)> {
        if let Some(t) = self.named_child(node, name) {
            let tex = self.node(t);
            if tex.tag != "texture" {
                return Err(self.doc.error(
                    node,
                    tex.loc,
                    format!(
                        "\"{name}\" must be a texture or a colour, not a <{}>",
                        tex.tag
                    ),
                ));
            }
            return Ok(match self.texture(tex, slot)? {
                Some(t) => (Rgb::ONE, Some(t)),
                None => (default, None),
            });
        }
        Ok((self.colour_opt(node, name)?.unwrap_or(default), None))
    }

    /// A number parameter that a texture may set per shading point: a property, or a texture
    /// (of its colour's luminance) with its mean as the material's value, or `default`.
    pub(super) fn number_or_texture(
        &mut self,
        node: &'a Node,
        name: &str,
        default: f32,
        param: Param,
    ) -> Result<(f32, Option<TextureDesc>)> {
        let Some(t) = self.named_child(node, name) else {
            return Ok((self.float(node, name, default)?, None));
        };
        let Some(tex) = self.texture(self.node(t), TextureSlot::Number(param))? else {
            return Ok((default, None));
        };
        let mean = tex.texels.iter().map(|c| c.x).sum::<f32>() / tex.texels.len().max(1) as f32;
        Ok((mean, Some(tex)))
    }

    /// A texture object as an image texture for `slot` (material index unset); `None` (with
    /// a warning) for plugins not supported.
    pub(super) fn texture(
        &mut self,
        tex: &'a Node,
        slot: TextureSlot,
    ) -> Result<Option<TextureDesc>> {
        self.count(tex);
        let to_uv = self.transform(tex, "to_uv")?.as_mat4();
        let uv_transform = (to_uv != glam::Mat4::IDENTITY).then(|| {
            let column = |c: glam::Vec4| glam::Vec2::new(c.x, c.y);
            glam::Affine2::from_cols(
                column(to_uv.x_axis),
                column(to_uv.y_axis),
                column(to_uv.w_axis),
            )
        });
        let name = tex.id.clone().unwrap_or_else(|| tex.plugin.clone());
        let number = matches!(
            slot,
            TextureSlot::Alpha { .. } | TextureSlot::Bump { .. } | TextureSlot::Number(_)
        );
        let (width, height, texels, wrap, nearest) = match tex.plugin.as_str() {
            "bitmap" => {
                let (w, h, t) = self.bitmap(tex)?;
                (w, h, t, self.wrap(tex)?, self.nearest(tex)?)
            }
            "checkerboard" => {
                let c0 = self.colour_opt(tex, "color0")?.unwrap_or(Rgb::splat(0.4));
                let c1 = self.colour_opt(tex, "color1")?.unwrap_or(Rgb::splat(0.2));
                // Mitsuba's `eval_1` (a number) puts `color0` where its `eval` (a colour)
                // puts `color1`.
                let (c0, c1) = if number { (c1, c0) } else { (c0, c1) };
                (2, 2, vec![c0, c1, c1, c0], [Wrap::Repeat; 2], true)
            }
            _ => {
                self.unsupported(tex, "the parameter's default stands in");
                return Ok(None);
            }
        };
        // A number texture (an opacity) is the colour's luminance, as Mitsuba's `eval_1`.
        let texels = if number {
            texels
                .into_iter()
                .map(|c| Rgb::splat(luminance(c)))
                .collect()
        } else {
            texels
        };
        Ok(Some(TextureDesc {
            name,
            material: 0,
            slot,
            width,
            height,
            texels,
            wrap,
            nearest,
            uv_transform,
        }))
    }

    /// `bitmap`'s image: sRGB-decoded 8-bit colours unless `raw`.
    fn bitmap(&mut self, tex: &'a Node) -> Result<(u32, u32, Vec<Rgb>)> {
        let Some(file) = self.string(tex, "filename")? else {
            return Err(self.doc.error(tex, tex.loc, "bitmap needs a \"filename\""));
        };
        // As in Mitsuba's RGB variants, 8-bit images are sRGB-decoded for any use unless raw.
        let raw = self.bool(tex, "raw", false)?;
        self.string(tex, "format")?;
        let path = self.doc.folder(tex).join(file);
        let decoded = std::fs::read(&path)
            .map_err(|e| crate::error::Error::Io {
                path: path.display().to_string(),
                what: "cannot read texture",
                source: e,
            })
            .and_then(|bytes| {
                let name = path.display().to_string();
                decode_texture_as(&bytes, &name, if raw { identity } else { srgb_to_linear })
                    .map_err(|msg| crate::io::image_file::file_error(&name, &msg))
            });
        let (w, h, texels) =
            decoded.map_err(|e| self.doc.error(tex, tex.loc, format!("bitmap: {e}")))?;
        if !self.desc.sources.contains(&path) {
            self.desc.sources.push(path);
        }
        Ok((w, h, texels))
    }

    /// `filter_type`: whether the lookup is nearest (else bilinear).
    fn nearest(&self, tex: &'a Node) -> Result<bool> {
        match self.string(tex, "filter_type")? {
            None | Some("bilinear") => Ok(false),
            Some("nearest") => Ok(true),
            Some(other) => Err(self.doc.error(
                tex,
                tex.loc,
                format!("filter_type \"{other}\": must be bilinear or nearest"),
            )),
        }
    }

    fn wrap(&self, tex: &'a Node) -> Result<[Wrap; 2]> {
        let mode = |s: &str| match s {
            "repeat" => Some(Wrap::Repeat),
            "mirror" => Some(Wrap::Mirror),
            "clamp" => Some(Wrap::Clamp),
            _ => None,
        };
        let Some(s) = self.string(tex, "wrap_mode")? else {
            return Ok([Wrap::Repeat; 2]);
        };
        let w = mode(s).ok_or_else(|| {
            self.doc.error(
                tex,
                tex.loc,
                format!("wrap_mode \"{s}\": must be repeat, mirror or clamp"),
            )
        })?;
        Ok([w; 2])
    }
}

fn identity(v: f32) -> f32 {
    v
}
