//! Image textures of pbrt-v4 scenes: PNG, JPEG and TGA (8-bit colour decoded from sRGB unless
//! the texture's `encoding` is `linear`), EXR, HDR and PFM (linear floats, converted from the
//! primaries their headers name). A float texture's value is, as in pbrt-v4, an image's alpha
//! channel where it has one, else the mean of its colour channels (returned in all three
//! channels).

use crate::io::image_file;
use crate::math::Rgb;
use std::path::Path;

/// Reads the image at `path` as `(width, height, texels)`, texels row-major from the top-left,
/// linear RGB (`float`: a float texture's value in every channel); `encoding` is pbrt-v4's
/// (`sRGB`, `linear`, or `gamma G`).
pub fn read(path: &Path, encoding: &str, float: bool) -> Result<(u32, u32, Vec<Rgb>), String> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read texture {name}: {e}"))?;
    let mut decoded = image_file::decode(&bytes, &name)?;
    let decode: fn(f32) -> f32 = if decoded.float {
        |v| v
    } else {
        stored_decoding(encoding, &name)?
    };
    let (w, h) = (decoded.width, decoded.height);
    let texels = match (float, decoded.alpha.take()) {
        (false, _) => decoded.linear_rgb(decode),
        (true, Some(alpha)) => alpha
            .into_iter()
            .map(|a| Rgb::splat(decode(a.clamp(0.0, 1.0))))
            .collect(),
        (true, None) => decoded
            .linear_rgb(decode)
            .into_iter()
            .map(|t| Rgb::splat((t.x + t.y + t.z) / 3.0))
            .collect(),
    };
    Ok((w, h, texels))
}

/// How 8- and 16-bit values of an image with pbrt-v4's `encoding` become linear.
fn stored_decoding(encoding: &str, name: &str) -> Result<fn(f32) -> f32, String> {
    match encoding {
        "sRGB" | "srgb" => Ok(crate::io::image::srgb_to_linear),
        "linear" => Ok(|v| v),
        other => match other
            .strip_prefix("gamma ")
            .and_then(|g| g.trim().parse::<f32>().ok())
        {
            Some(_) => Err(format!("{name}: \"gamma\" encodings are not supported yet")),
            None => Err(format!("{name}: unknown encoding \"{other}\"")),
        },
    }
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
        let d = image_file::read_pfm(&b, "t.pfm").unwrap();
        assert_eq!((d.width, d.height), (2, 2));
        let t = &d.rgb;
        assert_eq!([t[0].x, t[1].x, t[2].x, t[3].x], [3.0, 4.0, 1.0, 2.0]);
        assert!(image_file::read_pfm(b"PF\n2 2\n-1.0\n", "t.pfm").is_err());
        assert!(image_file::read_pfm(b"P6\n2 2\n255\n", "t.pfm").is_err());
    }
}
