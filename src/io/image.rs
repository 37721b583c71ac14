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
    let texels = d
        .rgb
        .into_iter()
        .map(|c| {
            let c = super::image_file::finite_non_negative(c);
            if d.float {
                c
            } else {
                c.map(decode_stored)
            }
        })
        .collect();
    Ok((d.width, d.height, texels))
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
        let e = ext(path);
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
        Image::from_bytes(&bytes, &ext(path), &file)
    }

    /// Decodes an image held in memory; `ext` is the extension its file has (the format where
    /// its bytes do not say) and `file` names it in errors.
    pub fn from_bytes(bytes: &[u8], ext: &str, file: &str) -> Result<Image> {
        let name = if super::image_file::extension(file) == ext.to_ascii_lowercase() {
            file.to_string()
        } else {
            format!("{file}.{ext}")
        };
        let d = super::image_file::decode(bytes, &name).map_err(|msg| Error::File {
            file: file.to_string(),
            msg: msg
                .strip_prefix(&format!("{name}: "))
                .unwrap_or(&msg)
                .to_string(),
        })?;
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

/// Reads the first layer of an EXR, picking R, G, B (or Y for luminance-only files) by name,
/// with or without a layer prefix ("diffuse.R"); with the file's `chromaticities` attribute.
pub(super) fn load_exr(
    bytes: &[u8],
    file: &str,
) -> Result<(Image, Option<super::image_file::Chromaticities>)> {
    let err = |msg: String| Error::File {
        file: file.to_string(),
        msg,
    };
    use exr::prelude::{ReadChannels, ReadLayers};
    // The header says how much decoding will allocate: refuse more than a bound before any
    // pixel memory is taken (a few bytes can claim a window of billions of pixels).
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| err(format!("cannot read EXR: {e}")))?;
    let samples: u64 = meta
        .headers
        .iter()
        .map(|h| (h.layer_size.area() as u64).saturating_mul(h.channels.list.len() as u64))
        .fold(0u64, u64::saturating_add);
    let limit = exr_sample_limit(bytes.len());
    // The decoder also allocates a block's declared size before reading it.
    let block = meta
        .headers
        .iter()
        .map(|h| h.max_block_byte_size() as u64)
        .max()
        .unwrap_or(0);
    let block_limit = (64u64 << 20).max(16 * bytes.len() as u64);
    if block > block_limit {
        return Err(err(format!(
            "EXR blocks of up to {block} bytes: more than the {block_limit} this renderer \
             decodes from a file of {} bytes",
            bytes.len()
        )));
    }
    if samples > limit {
        let h = &meta.headers[0];
        return Err(err(format!(
            "EXR claims {}x{} pixels in {} channel(s) ({samples} samples): more than the {limit} \
             this renderer decodes from a file of {} bytes",
            h.layer_size.width(),
            h.layer_size.height(),
            h.channels.list.len(),
            bytes.len()
        )));
    }
    let img = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| err(format!("cannot read EXR: {e}")))?;
    let layer = &img.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let channels = &layer.channel_data.list;
    let find = |name: &str| {
        channels.iter().find(|c| {
            let n = c.name.to_string();
            n == name || n.ends_with(&format!(".{name}"))
        })
    };
    let values = |c: &exr::image::AnyChannel<exr::image::FlatSamples>| {
        c.sample_data.values_as_f32().collect::<Vec<f32>>()
    };
    let planes: [Vec<f32>; 3] = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => [values(r), values(g), values(b)],
        (_, _, _, Some(y)) => {
            let y = values(y);
            [y.clone(), y.clone(), y]
        }
        _ => {
            let names: Vec<String> = channels.iter().map(|c| c.name.to_string()).collect();
            return Err(err(format!(
                "EXR has neither R, G, B nor Y channels (it has {})",
                names.join(", ")
            )));
        }
    };
    if planes.iter().any(|p| p.len() != w * h) {
        return Err(err("EXR channel sizes do not match the image size".into()));
    }
    let pixels = (0..w * h)
        .map(|i| Vec3::new(planes[0][i], planes[1][i], planes[2][i]))
        .collect();
    let chromaticities = img
        .attributes
        .chromaticities
        .map(|c| super::image_file::Chromaticities {
            red: [c.red.x(), c.red.y()],
            green: [c.green.x(), c.green.y()],
            blue: [c.blue.x(), c.blue.y()],
            white: [c.white.x(), c.white.y()],
        });
    let image = Image {
        width: w,
        height: h,
        pixels,
    };
    Ok((image, chromaticities))
}

/// Most samples (pixels × channels) an EXR of `file_bytes` bytes may decode to: 64 Mi, or
/// 256 per byte of the file for larger files (compression rarely exceeds 10:1 on real
/// images), so that a large map reads while a small forged header cannot claim gigabytes.
fn exr_sample_limit(file_bytes: usize) -> u64 {
    (64u64 << 20).max(256 * file_bytes as u64)
}

fn ext(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
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
