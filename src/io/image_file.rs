//! Reading image files: which format a file is (its magic number where the format has one,
//! else its extension), decoding it in bounded memory, and bringing colours stored in other
//! RGB primaries (OpenEXR's `chromaticities`, Radiance's `PRIMARIES`) to the renderer's
//! linear Rec. 709 / sRGB primaries.
//!
//! Every image a scene names goes through [`decode`]: textures of every format reader,
//! environment maps, alpha and bump maps.

use crate::math::Rgb;
use glam::{DMat3, DVec3, Vec3};

/// Most bytes a decoder may allocate for one image (1 GiB).
pub const MAX_DECODE_BYTES: u64 = 1 << 30;

/// Most texels one image may hold (2³⁰).
const MAX_TEXELS: usize = 1 << 30;

/// The image file formats the renderer reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// PNG (8 or 16 bits per channel).
    Png,
    /// JPEG.
    Jpeg,
    /// Truevision TGA: uncompressed or RLE, true-colour, grey or colour-mapped.
    Tga,
    /// OpenEXR (floats).
    Exr,
    /// Radiance RGBE (`.hdr`, `.pic`; floats).
    Hdr,
    /// Portable Float Map (floats).
    Pfm,
}

impl ImageFormat {
    /// The format of the file `name` holding `bytes`: the one its magic number says (PNG,
    /// JPEG, OpenEXR, Radiance, PFM, a TGA 2.0 footer), else the one its extension names
    /// (TGA has no magic number). The error says what is wrong: an unknown extension, or
    /// a file whose bytes are not the format its extension names.
    pub fn of(name: &str, bytes: &[u8]) -> Result<ImageFormat, String> {
        if let Some(format) = Self::by_magic(bytes) {
            return Ok(format);
        }
        let ext = extension(name);
        match ext.as_str() {
            "tga" | "targa" | "icb" | "vda" | "vst" => Ok(ImageFormat::Tga),
            "png" | "jpg" | "jpeg" | "exr" | "hdr" | "pic" | "rgbe" | "pfm" => {
                let what = match ext.as_str() {
                    "png" => "a PNG image",
                    "jpg" | "jpeg" => "a JPEG image",
                    "exr" => "an OpenEXR image",
                    "pfm" => "a PFM image",
                    _ => "a Radiance HDR image",
                };
                Err(format!(
                    "{name}: the file is not {what} (its first bytes are not the format's \
                     signature)"
                ))
            }
            "" => Err(format!(
                "{name}: the image format could not be determined (no extension, and the \
                 bytes are none of PNG, JPEG, OpenEXR, Radiance HDR or PFM)"
            )),
            other => Err(format!(
                "{name}: unsupported image format \".{other}\" (use PNG, JPEG, TGA, OpenEXR, \
                 Radiance HDR or PFM)"
            )),
        }
    }

    /// The format a file's first (or, for TGA 2.0, last) bytes identify.
    fn by_magic(bytes: &[u8]) -> Option<ImageFormat> {
        let pfm = |b: &[u8]| {
            (b.starts_with(b"PF") || b.starts_with(b"Pf"))
                && b.get(2).is_some_and(u8::is_ascii_whitespace)
        };
        if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
            Some(ImageFormat::Png)
        } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
            Some(ImageFormat::Jpeg)
        } else if bytes.starts_with(&[0x76, 0x2F, 0x31, 0x01]) {
            Some(ImageFormat::Exr)
        } else if bytes.starts_with(b"#?") {
            Some(ImageFormat::Hdr)
        } else if pfm(bytes) {
            Some(ImageFormat::Pfm)
        } else if bytes.ends_with(b"TRUEVISION-XFILE.\0") {
            Some(ImageFormat::Tga)
        } else {
            None
        }
    }
}

/// An image file's pixels as decoded, rows from the top: for 8- and 16-bit formats the
/// stored values in [0, 1] (not yet colour-decoded), for float formats linear values in
/// Rec. 709 primaries.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` colours, row-major from the top-left (grey images in all three).
    pub rgb: Vec<Rgb>,
    /// The alpha channel, where the file has one.
    pub alpha: Option<Vec<f32>>,
    /// The values are linear floats (EXR, HDR, PFM), not stored integers.
    pub float: bool,
}

impl Decoded {
    /// The colours as linear values, finite and non-negative: float formats as they are,
    /// 8- and 16-bit ones through `decode_stored` (sRGB decoding, say).
    pub fn linear_rgb(self, decode_stored: fn(f32) -> f32) -> Vec<Rgb> {
        let float = self.float;
        self.rgb
            .into_iter()
            .map(|c| {
                let c = finite_non_negative(c);
                if float {
                    c
                } else {
                    c.map(decode_stored)
                }
            })
            .collect()
    }
}

/// Decodes the image file `name` (for its format and for messages) held in `bytes`. Errors
/// name the file and say what is wrong; memory stays within [`MAX_DECODE_BYTES`].
pub fn decode(bytes: &[u8], name: &str) -> Result<Decoded, String> {
    let format = ImageFormat::of(name, bytes)?;
    let decoded = match format {
        ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::Tga => {
            decode_integer(bytes, name, format)?
        }
        ImageFormat::Hdr => decode_hdr(bytes, name)?,
        ImageFormat::Exr => decode_exr(bytes, name)?,
        ImageFormat::Pfm => read_pfm(bytes, name)?,
    };
    if decoded.width == 0 || decoded.height == 0 {
        return Err(format!(
            "{name}: an empty image ({}x{})",
            decoded.width, decoded.height
        ));
    }
    Ok(decoded)
}

/// A [`decode`] error of the file `name` (its message begins `name: `) as the crate's error
/// naming that file.
pub fn file_error(name: &str, msg: &str) -> crate::error::Error {
    crate::error::Error::File {
        file: name.to_string(),
        msg: msg
            .strip_prefix(name)
            .and_then(|m| m.strip_prefix(": "))
            .unwrap_or(msg)
            .to_string(),
    }
}

/// PNG, JPEG and TGA through the `image` crate, with the format given (never guessed) and
/// its allocation bounded.
fn decode_integer(bytes: &[u8], name: &str, format: ImageFormat) -> Result<Decoded, String> {
    let (crate_format, what) = match format {
        ImageFormat::Png => (image::ImageFormat::Png, "PNG"),
        ImageFormat::Jpeg => (image::ImageFormat::Jpeg, "JPEG"),
        _ => (image::ImageFormat::Tga, "TGA"),
    };
    let img =
        decode_with(bytes, crate_format).map_err(|e| format!("{name}: cannot read {what}: {e}"))?;
    let (width, height) = (img.width(), img.height());
    let (rgb, alpha) = if img.color().has_alpha() {
        let rgba = img.to_rgba32f();
        let rgb = rgba.pixels().map(|p| Rgb::new(p[0], p[1], p[2])).collect();
        (rgb, Some(rgba.pixels().map(|p| p[3]).collect()))
    } else {
        let rgb = img.to_rgb32f();
        (
            rgb.pixels().map(|p| Rgb::new(p[0], p[1], p[2])).collect(),
            None,
        )
    };
    Ok(Decoded {
        width,
        height,
        rgb,
        alpha,
        float: false,
    })
}

/// Decodes `bytes` as `format` with the allocation limit.
fn decode_with(
    bytes: &[u8],
    format: image::ImageFormat,
) -> image::ImageResult<image::DynamicImage> {
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    reader.limits(limits);
    reader.decode()
}

/// A Radiance RGBE image, converted from the primaries of its `PRIMARIES=` header line where
/// it has one.
fn decode_hdr(bytes: &[u8], name: &str) -> Result<Decoded, String> {
    let img = decode_with(bytes, image::ImageFormat::Hdr)
        .map_err(|e| format!("{name}: cannot read Radiance HDR: {e}"))?
        .to_rgb32f();
    let mut rgb: Vec<Rgb> = img.pixels().map(|p| Rgb::new(p[0], p[1], p[2])).collect();
    if let Some(primaries) = hdr_primaries(bytes) {
        to_rec709(&mut rgb, &primaries);
    }
    Ok(Decoded {
        width: img.width(),
        height: img.height(),
        rgb,
        alpha: None,
        float: true,
    })
}

/// The chromaticities of a Radiance header's `PRIMARIES= rx ry gx gy bx by wx wy` line.
fn hdr_primaries(bytes: &[u8]) -> Option<Chromaticities> {
    let header_end = bytes.windows(2).position(|w| w == b"\n\n")?;
    let header = String::from_utf8_lossy(&bytes[..header_end]);
    let line = header
        .lines()
        .find_map(|l| l.trim().strip_prefix("PRIMARIES="))?;
    let v: Vec<f32> = line
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .ok()?;
    let v: [f32; 8] = v.try_into().ok()?;
    Some(Chromaticities {
        red: [v[0], v[1]],
        green: [v[2], v[3]],
        blue: [v[4], v[5]],
        white: [v[6], v[7]],
    })
}

/// An OpenEXR image (see [`read_exr`]), converted from the primaries of its
/// `chromaticities` attribute where it has one.
fn decode_exr(bytes: &[u8], name: &str) -> Result<Decoded, String> {
    let (width, height, mut rgb, chromaticities) = read_exr(bytes, name)?;
    if let Some(c) = chromaticities {
        to_rec709(&mut rgb, &c);
    }
    Ok(Decoded {
        width: width as u32,
        height: height as u32,
        rgb,
        alpha: None,
        float: true,
    })
}

/// Reads the first layer of an EXR, picking R, G, B (or Y for luminance-only files) by name,
/// with or without a layer prefix ("diffuse.R"); with the file's `chromaticities` attribute.
fn read_exr(
    bytes: &[u8],
    file: &str,
) -> Result<(usize, usize, Vec<Rgb>, Option<Chromaticities>), String> {
    let err = |msg: String| format!("{file}: {msg}");
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
    let chromaticities = img.attributes.chromaticities.map(|c| Chromaticities {
        red: [c.red.x(), c.red.y()],
        green: [c.green.x(), c.green.y()],
        blue: [c.blue.x(), c.blue.y()],
        white: [c.white.x(), c.white.y()],
    });
    Ok((w, h, pixels, chromaticities))
}

/// Most samples (pixels × channels) an EXR of `file_bytes` bytes may decode to: 64 Mi, or
/// 256 per byte of the file for larger files (compression rarely exceeds 10:1 on real
/// images), so that a large map reads while a small forged header cannot claim gigabytes.
fn exr_sample_limit(file_bytes: usize) -> u64 {
    (64u64 << 20).max(256 * file_bytes as u64)
}

/// The CIE xy chromaticities of an RGB colour space's primaries and white point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chromaticities {
    /// The red primary.
    pub red: [f32; 2],
    /// The green primary.
    pub green: [f32; 2],
    /// The blue primary.
    pub blue: [f32; 2],
    /// The white point (RGB (1, 1, 1)).
    pub white: [f32; 2],
}

impl Chromaticities {
    /// ITU-R BT.709 / sRGB primaries with the D65 white point: the renderer's own, and
    /// OpenEXR's default.
    pub const REC709: Chromaticities = Chromaticities {
        red: [0.64, 0.33],
        green: [0.30, 0.60],
        blue: [0.15, 0.06],
        white: [0.3127, 0.3290],
    };

    /// Whether these are Rec. 709's to within Mitsuba's tolerance (a summed squared
    /// distance of 10⁻⁶), so that such files are left exactly as stored.
    pub fn is_rec709(&self) -> bool {
        let d2 = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
        let r = Self::REC709;
        d2(self.red, r.red)
            + d2(self.green, r.green)
            + d2(self.blue, r.blue)
            + d2(self.white, r.white)
            < 1e-6
    }

    /// The matrix from RGB in these primaries to CIE XYZ, scaled so that white has Y = 1;
    /// `None` for degenerate primaries.
    pub fn rgb_to_xyz(&self) -> Option<DMat3> {
        let xyz = |c: [f32; 2]| {
            let (x, y) = (c[0] as f64, c[1] as f64);
            (y > 0.0).then(|| DVec3::new(x / y, 1.0, (1.0 - x - y) / y))
        };
        let primaries = DMat3::from_cols(xyz(self.red)?, xyz(self.green)?, xyz(self.blue)?);
        if primaries.determinant().abs() < 1e-12 {
            return None;
        }
        let scale = primaries.inverse() * xyz(self.white)?;
        Some(primaries * DMat3::from_diagonal(scale))
    }

    /// The matrix from RGB in these primaries to linear Rec. 709 RGB, through XYZ without
    /// chromatic adaptation (as OpenEXR's `RGBtoXYZ · XYZtoRGB`, which Mitsuba 3 applies,
    /// and pbrt-v4's `ConvertRGBColorSpace`); `None` for degenerate primaries.
    pub fn to_rec709(&self) -> Option<DMat3> {
        let rec709 = Self::REC709.rgb_to_xyz()?;
        Some(rec709.inverse() * self.rgb_to_xyz()?)
    }
}

/// Converts `rgb` from `primaries` to Rec. 709 in place; nothing changes where they are
/// Rec. 709's already or degenerate.
fn to_rec709(rgb: &mut [Rgb], primaries: &Chromaticities) {
    if primaries.is_rec709() {
        return;
    }
    let Some(m) = primaries.to_rec709() else {
        return;
    };
    let m = m.as_mat3();
    for c in rgb {
        *c = m * *c;
    }
}

/// A Portable Float Map: `PF` (RGB) or `Pf` (grey), width and height, a scale whose sign
/// gives the byte order (negative: little-endian), then rows from the bottom up. Non-finite
/// and negative values become 0.
pub fn read_pfm(bytes: &[u8], name: &str) -> Result<Decoded, String> {
    let bad = |what: &str| format!("{name}: malformed PFM ({what})");
    let mut fields = Vec::new();
    let mut pos = 0;
    while fields.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err(bad("short header"));
        }
        fields.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1;
    let channels = match fields[0].as_str() {
        "PF" => 3,
        "Pf" => 1,
        _ => return Err(bad("not PF or Pf")),
    };
    let w: usize = fields[1].parse().map_err(|_| bad("width"))?;
    let h: usize = fields[2].parse().map_err(|_| bad("height"))?;
    let scale: f32 = fields[3].parse().map_err(|_| bad("scale"))?;
    if w == 0 || h == 0 || w.saturating_mul(h) > MAX_TEXELS || !scale.is_finite() || scale == 0.0 {
        return Err(bad("size or scale"));
    }
    let need = w * h * channels * 4;
    let data = bytes
        .get(pos..pos.saturating_add(need))
        .ok_or_else(|| bad("short data"))?;
    let value = |i: usize| {
        let b = [
            data[4 * i],
            data[4 * i + 1],
            data[4 * i + 2],
            data[4 * i + 3],
        ];
        let v = if scale < 0.0 {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        };
        if v.is_finite() {
            v.max(0.0)
        } else {
            0.0
        }
    };
    let mut rgb = Vec::with_capacity(w * h);
    for row in (0..h).rev() {
        for x in 0..w {
            let i = (row * w + x) * channels;
            rgb.push(if channels == 3 {
                Rgb::new(value(i), value(i + 1), value(i + 2))
            } else {
                Rgb::splat(value(i))
            });
        }
    }
    Ok(Decoded {
        width: w as u32,
        height: h as u32,
        rgb,
        alpha: None,
        float: true,
    })
}

/// The lower-case extension of a file name or path (empty without one).
pub fn extension(name: impl AsRef<std::path::Path>) -> String {
    name.as_ref()
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// Keeps a texel colour finite and non-negative.
fn finite_non_negative(c: Rgb) -> Rgb {
    let f = |v: f32| if v.is_finite() { v.max(0.0) } else { 0.0 };
    Vec3::new(f(c.x), f(c.y), f(c.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Red, green / blue, white: the 2×2 test image, rows from the top, as BGR(A) bytes.
    const TOP: [[u8; 3]; 2] = [[0, 0, 255], [0, 255, 0]];
    const BOTTOM: [[u8; 3]; 2] = [[255, 0, 0], [255, 255, 255]];

    /// The 18-byte TGA header: `kind` (1 colour-mapped, 2 true-colour, 3 grey; +8 RLE),
    /// a colour map of `map_len` entries of `map_bits`, a 2×2 image of `depth` bits, the
    /// descriptor byte `desc` (bits 0-3 alpha bits, bit 5 top-to-bottom rows).
    fn header(kind: u8, map_len: u16, map_bits: u8, depth: u8, desc: u8) -> Vec<u8> {
        let mut h = vec![0u8, (map_len > 0) as u8, kind];
        h.extend_from_slice(&0u16.to_le_bytes());
        h.extend_from_slice(&map_len.to_le_bytes());
        h.push(map_bits);
        h.extend_from_slice(&[0, 0, 0, 0]);
        h.extend_from_slice(&2u16.to_le_bytes());
        h.extend_from_slice(&2u16.to_le_bytes());
        h.extend_from_slice(&[depth, desc]);
        h
    }

    /// The test image's rows in file order: top first when `top`, else bottom first.
    fn rows(top: bool) -> [[[u8; 3]; 2]; 2] {
        if top {
            [TOP, BOTTOM]
        } else {
            [BOTTOM, TOP]
        }
    }

    /// The expected texels: stored values in [0, 1].
    fn expected() -> Vec<Rgb> {
        vec![Rgb::X, Rgb::Y, Rgb::Z, Rgb::ONE]
    }

    fn decode_tga(bytes: &[u8]) -> Decoded {
        decode(bytes, "t.tga").unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn tga_uncompressed_24_bit_bottom_up() {
        let mut b = header(2, 0, 0, 24, 0);
        b.extend(rows(false).iter().flatten().flatten());
        let d = decode_tga(&b);
        assert_eq!((d.width, d.height, d.float), (2, 2, false));
        assert_eq!(d.rgb, expected());
        assert_eq!(d.alpha, None);
    }

    #[test]
    fn tga_uncompressed_32_bit_top_down_with_alpha() {
        let mut b = header(2, 0, 0, 32, 8 | 0x20);
        for (i, px) in rows(true).iter().flatten().enumerate() {
            b.extend_from_slice(px);
            b.push([255, 128, 0, 64][i]);
        }
        let d = decode_tga(&b);
        assert_eq!(d.rgb, expected());
        let alpha = d.alpha.expect("alpha");
        let want = [1.0, 128.0 / 255.0, 0.0, 64.0 / 255.0];
        assert!(
            alpha.iter().zip(want).all(|(a, w)| (a - w).abs() < 1e-6),
            "{alpha:?}"
        );
    }

    #[test]
    fn tga_rle_true_colour_24_and_32_bit() {
        // 24-bit: the bottom row as a run of one and a raw packet, the top row raw.
        let mut b = header(10, 0, 0, 24, 0);
        b.push(0x80);
        b.extend_from_slice(&BOTTOM[0]);
        b.push(0x00);
        b.extend_from_slice(&BOTTOM[1]);
        b.push(0x01);
        b.extend(TOP.iter().flatten());
        assert_eq!(decode_tga(&b).rgb, expected());
        // 32-bit, top-down: a grey run of four.
        let mut b = header(10, 0, 0, 32, 8 | 0x20);
        b.extend_from_slice(&[0x83, 10, 20, 30, 255]);
        let d = decode_tga(&b);
        let c = Rgb::new(30.0, 20.0, 10.0) / 255.0;
        assert!(d.rgb.iter().all(|t| (*t - c).abs().max_element() < 1e-6));
        assert_eq!(d.alpha, Some(vec![1.0; 4]));
    }

    #[test]
    fn tga_grey_8_bit_raw_and_rle() {
        let mut b = header(3, 0, 0, 8, 0x20);
        b.extend_from_slice(&[0, 51, 102, 255]);
        let grey = |values: [u8; 4]| -> Vec<Rgb> {
            values
                .iter()
                .map(|&v| Rgb::splat(v as f32 / 255.0))
                .collect()
        };
        let close = |a: &[Rgb], b: &[Rgb]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| (*x - *y).abs().max_element() < 1e-6)
        };
        assert!(close(&decode_tga(&b).rgb, &grey([0, 51, 102, 255])));
        let mut b = header(11, 0, 0, 8, 0x20);
        b.extend_from_slice(&[0x81, 0, 0x01, 102, 255]);
        assert!(close(&decode_tga(&b).rgb, &grey([0, 0, 102, 255])));
    }

    #[test]
    fn tga_colour_mapped_raw_and_rle() {
        // A palette of red, green, blue, white (BGR entries); indices 0..4 bottom-up.
        let palette: Vec<u8> = [TOP[0], TOP[1], BOTTOM[0], BOTTOM[1]]
            .iter()
            .flatten()
            .copied()
            .collect();
        let mut b = header(1, 4, 24, 8, 0);
        b.extend_from_slice(&palette);
        b.extend_from_slice(&[2, 3, 0, 1]);
        assert_eq!(decode_tga(&b).rgb, expected());
        let mut b = header(9, 4, 24, 8, 0x20);
        b.extend_from_slice(&palette);
        b.extend_from_slice(&[0x03, 0, 1, 2, 3]);
        assert_eq!(decode_tga(&b).rgb, expected());
    }

    #[test]
    fn tga_2_footer_is_read_and_names_the_format() {
        let mut b = header(2, 0, 0, 24, 0);
        b.extend(rows(false).iter().flatten().flatten());
        b.extend_from_slice(&[0; 8]);
        b.extend_from_slice(b"TRUEVISION-XFILE.\0");
        assert_eq!(decode_tga(&b).rgb, expected());
        // The footer identifies the format even without the extension.
        assert_eq!(ImageFormat::of("texture.img", &b), Ok(ImageFormat::Tga));
        assert_eq!(decode(&b, "texture").unwrap().rgb, expected());
    }

    #[test]
    fn formats_follow_magic_numbers_then_extensions() {
        assert_eq!(
            ImageFormat::of("a.tga", b"\x00\x00\x02"),
            Ok(ImageFormat::Tga)
        );
        assert_eq!(
            ImageFormat::of("A.TGA", b"\x00\x00\x02"),
            Ok(ImageFormat::Tga)
        );
        assert_eq!(
            ImageFormat::of("a.tga", b"\x89PNG\r\n\x1a\n"),
            Ok(ImageFormat::Png)
        );
        assert_eq!(
            ImageFormat::of("a.png", b"#?RADIANCE\n"),
            Ok(ImageFormat::Hdr)
        );
        assert_eq!(
            ImageFormat::of("a.jpg", &[0xFF, 0xD8, 0xFF, 0xE0]),
            Ok(ImageFormat::Jpeg)
        );
        assert_eq!(ImageFormat::of("a", b"PF\n1 1\n-1\n"), Ok(ImageFormat::Pfm));
        let e = ImageFormat::of("x/a.png", b"GIF89a").unwrap_err();
        assert!(e.contains("x/a.png") && e.contains("not a PNG"), "{e}");
        let e = ImageFormat::of("a.bmp", b"BM").unwrap_err();
        assert!(e.contains("unsupported image format \".bmp\""), "{e}");
    }

    #[test]
    fn rec709_chromaticities_leave_values_alone_and_others_convert() {
        let mut rgb = vec![Rgb::new(0.25, 0.5, 0.75)];
        to_rec709(&mut rgb, &Chromaticities::REC709);
        assert_eq!(rgb, vec![Rgb::new(0.25, 0.5, 0.75)]);
        // Adobe RGB (1998): D65 white stays white; its pure green is outside Rec. 709
        // (negative red and blue).
        let adobe = Chromaticities {
            red: [0.64, 0.33],
            green: [0.21, 0.71],
            blue: [0.15, 0.06],
            white: [0.3127, 0.3290],
        };
        let m = adobe.to_rec709().unwrap();
        let white = m * DVec3::ONE;
        assert!((white - DVec3::ONE).abs().max_element() < 1e-6, "{white}");
        let green = m * DVec3::Y;
        assert!(
            green.x < 0.0 && green.z < 0.0 && (green.y - 1.0).abs() < 1e-6,
            "{green}"
        );
        // The published Adobe RGB → sRGB matrix's first row.
        assert!(
            (m.row(0) - DVec3::new(1.3982, -0.3982, 0.0))
                .abs()
                .max_element()
                < 1e-3
        );
    }
}
