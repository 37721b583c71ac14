//! Image textures of pbrt-v4 scenes: PNG, JPEG and TGA (8-bit colour decoded from sRGB unless
//! the texture's `encoding` is `linear`), EXR and PFM (linear floats). A float texture's
//! value is, as in pbrt-v4, an image's alpha channel where it has one, else the mean of its
//! colour channels (returned in all three channels).

use crate::io::image::{decode_texture_as, Image};
use crate::math::Rgb;
use std::path::Path;

/// Most texels one image may hold (2³⁰).
const MAX_TEXELS: usize = 1 << 30;

/// Reads the image at `path` as `(width, height, texels)`, texels row-major from the top-left,
/// linear RGB (`float`: a float texture's value in every channel); `encoding` is pbrt-v4's
/// (`sRGB`, `linear`, or `gamma G`).
pub fn read(path: &Path, encoding: &str, float: bool) -> Result<(u32, u32, Vec<Rgb>), String> {
    let (w, h, texels, alpha) = read_channels(path, encoding, float)?;
    if !float {
        return Ok((w, h, texels));
    }
    let values = match alpha {
        Some(a) => a.into_iter().map(Rgb::splat).collect(),
        None => texels
            .iter()
            .map(|t| Rgb::splat((t.x + t.y + t.z) / 3.0))
            .collect(),
    };
    Ok((w, h, values))
}

/// The colour and (where the file has one) alpha channels of an image.
type Channels = (u32, u32, Vec<Rgb>, Option<Vec<f32>>);

/// The colour channels of an image, and (`with_alpha`: for a float texture) its alpha
/// channel where it has one.
fn read_channels(path: &Path, encoding: &str, with_alpha: bool) -> Result<Channels, String> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read texture {name}: {e}"))?;
    match ext.as_str() {
        "exr" => {
            let img = Image::from_bytes(&bytes, "exr", &name).map_err(|e| e.to_string())?;
            Ok((img.width as u32, img.height as u32, img.pixels, None))
        }
        "pfm" => read_pfm(&bytes, &name).map(|(w, h, t)| (w, h, t, None)),
        "png" | "jpg" | "jpeg" | "tga" => {
            let decode: fn(f32) -> f32 = match encoding {
                "sRGB" | "srgb" => crate::io::image::srgb_to_linear,
                "linear" => |v| v,
                other => match other
                    .strip_prefix("gamma ")
                    .and_then(|g| g.trim().parse::<f32>().ok())
                {
                    Some(_) => {
                        return Err(format!("{name}: \"gamma\" encodings are not supported yet"))
                    }
                    None => return Err(format!("{name}: unknown encoding \"{other}\"")),
                },
            };
            let (w, h, texels) = decode_texture_as(&bytes, &name, decode)?;
            let alpha = with_alpha.then(|| alpha_channel(&bytes, decode)).flatten();
            Ok((w, h, texels, alpha))
        }
        other => Err(format!(
            "{name}: unsupported texture format \".{other}\" (use PNG, JPEG, TGA, EXR or PFM)"
        )),
    }
}

/// The alpha channel of an 8- or 16-bit image that has one, decoded like its colours (as
/// pbrt-v4 decodes every channel with the image's encoding).
fn alpha_channel(bytes: &[u8], decode: fn(f32) -> f32) -> Option<Vec<f32>> {
    let img = image::load_from_memory(bytes).ok()?;
    if !img.color().has_alpha() {
        return None;
    }
    Some(
        img.to_rgba32f()
            .pixels()
            .map(|p| decode(p[3].clamp(0.0, 1.0)))
            .collect(),
    )
}

/// A Portable Float Map: `PF` (RGB) or `Pf` (grey), width and height, a scale whose sign
/// gives the byte order (negative: little-endian), then rows from the bottom up.
fn read_pfm(bytes: &[u8], name: &str) -> Result<(u32, u32, Vec<Rgb>), String> {
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
        .get(pos..pos + need)
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
    let mut texels = Vec::with_capacity(w * h);
    for row in (0..h).rev() {
        for x in 0..w {
            let i = (row * w + x) * channels;
            texels.push(if channels == 3 {
                Rgb::new(value(i), value(i + 1), value(i + 2))
            } else {
                Rgb::splat(value(i))
            });
        }
    }
    Ok((w as u32, h as u32, texels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_rows_run_bottom_up_and_scale_gives_byte_order() {
        let mut b = b"PF\n2 2\n-1.0\n".to_vec();
        for v in [
            1.0f32, 0.0, 0.0, 2.0, 0.0, 0.0, 3.0, 0.0, 0.0, 4.0, 0.0, 0.0,
        ] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let (w, h, t) = read_pfm(&b, "t.pfm").unwrap();
        assert_eq!((w, h), (2, 2));
        assert_eq!([t[0].x, t[1].x, t[2].x, t[3].x], [3.0, 4.0, 1.0, 2.0]);
        assert!(read_pfm(b"PF\n2 2\n-1.0\n", "t.pfm").is_err());
        assert!(read_pfm(b"P6\n2 2\n255\n", "t.pfm").is_err());
    }
}
