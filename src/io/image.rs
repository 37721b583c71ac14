//! Linear RGB images: writing 8-bit sRGB PNG and float EXR, reading EXR/PNG, comparing images.

use crate::error::{Error, Result};
use crate::math::Rgb;
use glam::Vec3;
use std::path::Path;

/// Decodes a colour texture (any format [`super::image_file::decode`] reads; `name` gives its
/// format and names it in messages) to `(width, height, texels)`, texels row-major from the
/// top-left, linear RGB: 8- and 16-bit images are sRGB-decoded, float images taken as linear,
/// alpha dropped, negative and non-finite values 0.
pub fn decode_texture(
    bytes: &[u8],
    name: &str,
) -> std::result::Result<(u32, u32, Vec<Rgb>), String> {
    decode_texture_as(bytes, name, srgb_to_linear)
}

/// [`decode_texture`] with `decode_stored` turning 8- and 16-bit values in [0, 1] into linear
/// ones.
pub fn decode_texture_as(
    bytes: &[u8],
    name: &str,
    decode_stored: fn(f32) -> f32,
) -> std::result::Result<(u32, u32, Vec<Rgb>), String> {
    let d = super::image_file::decode(bytes, name)?;
    let (width, height) = (d.width, d.height);
    let texels = d.linear_rgb(decode_stored);
    Ok((width, height, texels))
}

/// A linear-RGB float image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width × height` pixels, row-major from the top-left corner.
    pub pixels: Vec<Rgb>,
}

impl Image {
    /// A black image.
    pub fn new(width: usize, height: usize) -> Self {
        Image {
            width,
            height,
            pixels: vec![Vec3::ZERO; width * height],
        }
    }

    /// Pixel at column `x`, row `y` (from the top).
    pub fn get(&self, x: usize, y: usize) -> Rgb {
        self.pixels[y * self.width + x]
    }

    /// Mean of each channel.
    pub fn mean(&self) -> Rgb {
        let s = self.pixels.iter().fold([0f64; 3], |a, p| {
            [a[0] + p.x as f64, a[1] + p.y as f64, a[2] + p.z as f64]
        });
        let n = self.pixels.len().max(1) as f64;
        Vec3::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32)
    }

    /// Number of pixels with a NaN or infinite channel.
    pub fn count_non_finite(&self) -> usize {
        self.pixels.iter().filter(|p| !p.is_finite()).count()
    }

    /// Writes the image; the format follows the extension: `.exr` linear float RGB, `.png`
    /// 8-bit sRGB (values clamped to [0, 1]).
    pub fn save(&self, path: &Path) -> Result<()> {
        let file = path.display().to_string();
        let e = super::image_file::extension(path);
        let what = match e.as_str() {
            "exr" => "cannot write EXR",
            "png" => "cannot write PNG",
            other => {
                return Err(Error::Usage(format!(
                    "{file}: unsupported output format '.{other}' (use .png or .exr)"
                )))
            }
        };
        let bytes = self.encode(&e).map_err(|msg| Error::File {
            file: file.clone(),
            msg: format!("{what}: {msg}"),
        })?;
        super::atomic::write(path, what, |w| std::io::Write::write_all(w, &bytes))
    }

    /// The file bytes of the image in format `ext`: `exr` (linear float RGB) or `png` (8-bit
    /// sRGB, clamped); the error is the encoder's message.
    pub fn encode(&self, ext: &str) -> std::result::Result<Vec<u8>, String> {
        let mut out = std::io::Cursor::new(Vec::new());
        match ext {
            "exr" => {
                use exr::prelude::{SpecificChannels, WritableImage};
                let (w, px) = (self.width, &self.pixels);
                let channels = SpecificChannels::rgb(|p: exr::math::Vec2<usize>| {
                    let v = px[p.y() * w + p.x()];
                    (v.x, v.y, v.z)
                });
                exr::image::Image::from_channels((self.width, self.height), channels)
                    .write()
                    .to_buffered(&mut out)
                    .map_err(|e| e.to_string())?;
            }
            "png" => {
                let bytes: Vec<u8> = self
                    .pixels
                    .iter()
                    .flat_map(|p| [srgb8(p.x), srgb8(p.y), srgb8(p.z)])
                    .collect();
                image::write_buffer_with_format(
                    &mut out,
                    &bytes,
                    self.width as u32,
                    self.height as u32,
                    image::ExtendedColorType::Rgb8,
                    image::ImageFormat::Png,
                )
                .map_err(|e| e.to_string())?;
            }
            other => return Err(format!("unsupported format '.{other}'")),
        }
        Ok(out.into_inner())
    }

    /// Reads an image as linear RGB: OpenEXR (first layer; scanline or tiled; half, float or
    /// uint; R, G, B channels, or luminance-only Y; every compression the `exr` crate decodes,
    /// PIZ, ZIP and DWAA/DWAB included), Radiance `.hdr`, PFM (float formats converted from
    /// the primaries their headers name), or PNG, JPEG and TGA (decoded from sRGB). Errors
    /// name the file.
    pub fn load(path: &Path) -> Result<Image> {
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: file.clone(),
            what: "cannot read image",
            source,
        })?;
        Image::from_bytes(&bytes, &super::image_file::extension(path), &file)
    }

    /// Decodes an image held in memory; `ext` is the extension its file has (the format where
    /// its bytes do not say) and `file` names it in errors (as `file.ext` where `file` does
    /// not end in `.ext`).
    pub fn from_bytes(bytes: &[u8], ext: &str, file: &str) -> Result<Image> {
        let name = if super::image_file::extension(file) == ext.to_ascii_lowercase() {
            file.to_string()
        } else {
            format!("{file}.{ext}")
        };
        let d = super::image_file::decode(bytes, &name)
            .map_err(|msg| super::image_file::file_error(&name, &msg))?;
        let pixels = if d.float {
            d.rgb
        } else {
            d.rgb.into_iter().map(|c| c.map(srgb_to_linear)).collect()
        };
        Ok(Image {
            width: d.width as usize,
            height: d.height as usize,
            pixels,
        })
    }
}

/// Linear → sRGB-encoded 8-bit value (clamped).
pub fn srgb8(v: f32) -> u8 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// sRGB-encoded value in [0, 1] → linear.
pub fn srgb_to_linear(s: f32) -> f32 {
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Error metrics between a test image `a` and a reference `b`.
#[derive(Clone, Debug)]
pub struct DiffStats {
    /// Root-mean-square error over all pixels and channels.
    pub rmse: f64,
    /// Relative MSE: mean over pixels and channels of `(a − b)² / (b² + 0.01)`.
    pub rel_mse: f64,
    /// `mean(a) / mean(b)` per channel.
    pub ratio_of_means: [f64; 3],
    /// `mean(a) / mean(b)` over all channels.
    pub ratio_of_means_all: f64,
    /// Block metric per channel: the mean over 16×16-pixel blocks (partial blocks at the right
    /// and bottom edges included) of `|mean_A − mean_B| / (mean_B + 0.01)`.
    pub block: [f64; 3],
}

impl DiffStats {
    /// The largest per-channel block metric.
    pub fn block_max(&self) -> f64 {
        self.block.iter().cloned().fold(0.0, f64::max)
    }

    /// The per-channel ratio of means farthest from 1.
    pub fn ratio_worst(&self) -> f64 {
        self.ratio_of_means.iter().cloned().fold(1.0, |w, r| {
            if (r - 1.0).abs() > (w - 1.0).abs() {
                r
            } else {
                w
            }
        })
    }
}

/// Side of the square blocks of the block metric, in pixels.
pub const BLOCK: usize = 16;

/// Compares `a` against reference `b`; `Err` when their sizes differ.
pub fn diff(a: &Image, b: &Image) -> Result<DiffStats> {
    if a.width != b.width || a.height != b.height {
        return Err(Error::Usage(format!(
            "images differ in size: {}x{} vs {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    let n = (a.pixels.len() * 3).max(1) as f64;
    let (mut se, mut rel) = (0f64, 0f64);
    let (mut sa, mut sb) = ([0f64; 3], [0f64; 3]);
    for (pa, pb) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let (x, y) = (pa[c] as f64, pb[c] as f64);
            let d = x - y;
            se += d * d;
            rel += d * d / (y * y + 0.01);
            sa[c] += x;
            sb[c] += y;
        }
    }
    let ratio = |x: f64, y: f64| {
        if y != 0.0 {
            x / y
        } else if x == 0.0 {
            1.0
        } else {
            f64::INFINITY
        }
    };
    let mut block = [0f64; 3];
    let mut nblocks = 0usize;
    for by in (0..a.height).step_by(BLOCK) {
        for bx in (0..a.width).step_by(BLOCK) {
            let (mut ma, mut mb, mut cnt) = ([0f64; 3], [0f64; 3], 0usize);
            for y in by..(by + BLOCK).min(a.height) {
                for x in bx..(bx + BLOCK).min(a.width) {
                    let (pa, pb) = (a.get(x, y), b.get(x, y));
                    for c in 0..3 {
                        ma[c] += pa[c] as f64;
                        mb[c] += pb[c] as f64;
                    }
                    cnt += 1;
                }
            }
            for c in 0..3 {
                let (ma, mb) = (ma[c] / cnt as f64, mb[c] / cnt as f64);
                block[c] += (ma - mb).abs() / (mb + 0.01);
            }
            nblocks += 1;
        }
    }
    for b in &mut block {
        *b /= nblocks.max(1) as f64;
    }
    Ok(DiffStats {
        rmse: (se / n).sqrt(),
        rel_mse: rel / n,
        ratio_of_means: [
            ratio(sa[0], sb[0]),
            ratio(sa[1], sb[1]),
            ratio(sa[2], sb[2]),
        ],
        ratio_of_means_all: ratio(sa.iter().sum(), sb.iter().sum()),
        block,
    })
}

/// Sample counts as colours, relative to the largest count: blue (few) through green to red
/// (many), as CS184's rate image.
pub fn sample_rate_image(counts: &[u32], w: usize, h: usize) -> Image {
    let max = counts.iter().copied().max().unwrap_or(1).max(1) as f32;
    let mut img = Image::new(w, h);
    for (p, &n) in img.pixels.iter_mut().zip(counts) {
        *p = false_colour(n as f32 / max);
    }
    img
}

/// The rate image's colour map: `t` in [0, 1] from blue (0) through green to red (1), full
/// saturation, linear RGB (hue 240° down to 0°).
pub fn false_colour(t: f32) -> Rgb {
    let c = |x: f32| x.clamp(0.0, 1.0);
    let t = if t.is_finite() { t } else { 0.0 };
    Rgb::new(
        c(2.0 * t - 1.0),
        c(1.0 - (2.0 * t - 1.0).abs()),
        c(1.0 - 2.0 * t),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_roundtrip() {
        for v in [0.0, 0.001, 0.2, 0.5, 1.0] {
            let s = srgb8(v) as f32 / 255.0;
            assert!((srgb_to_linear(s) - v).abs() < 0.01);
        }
        assert_eq!(srgb8(f32::NAN), 0);
        assert_eq!(srgb8(7.0), 255);
    }

    #[test]
    fn diff_metrics() {
        let mut a = Image::new(20, 20);
        let mut b = Image::new(20, 20);
        for p in &mut a.pixels {
            *p = Vec3::splat(1.1);
        }
        for p in &mut b.pixels {
            *p = Vec3::splat(1.0);
        }
        let d = diff(&a, &b).unwrap();
        assert!((d.rmse - 0.1).abs() < 1e-6);
        assert!((d.ratio_of_means_all - 1.1).abs() < 1e-6);
        assert!((d.block_max() - 0.1 / 1.01).abs() < 1e-6);
        assert!(diff(&a, &Image::new(10, 20)).is_err());
    }

    #[test]
    fn exr_and_png_roundtrip() {
        let dir = std::env::temp_dir().join(format!("pt-img-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut img = Image::new(7, 5);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::new(i as f32 * 0.01, 0.5, 3.0);
        }
        img.save(&dir.join("a.exr")).unwrap();
        assert_eq!(Image::load(&dir.join("a.exr")).unwrap(), img);
        img.save(&dir.join("a.png")).unwrap();
        let back = Image::load(&dir.join("a.png")).unwrap();
        assert_eq!((back.width, back.height), (7, 5));
        assert!((back.get(3, 2).y - 0.5).abs() < 0.01 && back.get(0, 0).z == 1.0);
        std::fs::remove_dir_all(&dir).ok();
    }
}
