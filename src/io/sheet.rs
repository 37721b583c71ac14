//! Contact sheets: several renders side by side, downscaled, each labelled with a short text
//! drawn in a built-in 5×7 pixel font (digits, lower-case letters used by labels, `=`, space).

use super::image::Image;
use crate::math::Rgb;
use glam::Vec3;

/// Glyph rows (5 bits each, most significant bit leftmost), 7 rows per glyph.
fn glyph(c: char) -> Option<[u8; 7]> {
    Some(match c {
        '0' => [
            0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110,
        ],
        '1' => [
            0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
        '2' => [
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111,
        ],
        '3' => [
            0b11110, 0b00001, 0b00001, 0b01110, 0b00001, 0b00001, 0b11110,
        ],
        '4' => [
            0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010,
        ],
        '5' => [
            0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110,
        ],
        '6' => [
            0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110,
        ],
        '7' => [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000,
        ],
        '8' => [
            0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110,
        ],
        '9' => [
            0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100,
        ],
        'm' => [
            0b00000, 0b00000, 0b11010, 0b10101, 0b10101, 0b10001, 0b10001,
        ],
        '=' => [
            0b00000, 0b00000, 0b11111, 0b00000, 0b11111, 0b00000, 0b00000,
        ],
        ' ' => [0; 7],
        _ => return None,
    })
}

/// Draws `text` with its top-left corner at `(x0, y0)`, each font pixel `scale`×`scale` image
/// pixels, white with a black outline. Characters the font lacks are skipped.
pub fn draw_label(img: &mut Image, text: &str, x0: usize, y0: usize, scale: usize) {
    let mut put = |x: i64, y: i64, c: Rgb| {
        if x >= 0 && y >= 0 && (x as usize) < img.width && (y as usize) < img.height {
            img.pixels[y as usize * img.width + x as usize] = c;
        }
    };
    let glyphs: Vec<[u8; 7]> = text.chars().filter_map(glyph).collect();
    // Outline pass, then the white pass on top.
    for (pass, colour) in [(0, Vec3::ZERO), (1, Vec3::ONE)] {
        for (i, g) in glyphs.iter().enumerate() {
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0b10000 >> col) == 0 {
                        continue;
                    }
                    let px = (x0 + (i * 6 + col) * scale) as i64;
                    let py = (y0 + row * scale) as i64;
                    let s = scale as i64;
                    let grow = if pass == 0 { 1 } else { 0 };
                    for dy in -grow..s + grow {
                        for dx in -grow..s + grow {
                            put(px + dx, py + dy, colour);
                        }
                    }
                }
            }
        }
    }
}

/// Downscales by an integer factor with a box filter (partial blocks at the edges dropped).
pub fn downscale(img: &Image, factor: usize) -> Image {
    let f = factor.max(1);
    let (w, h) = (img.width / f, img.height / f);
    let mut out = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let mut acc = Vec3::ZERO;
            for dy in 0..f {
                for dx in 0..f {
                    acc += img.get(x * f + dx, y * f + dy);
                }
            }
            out.pixels[y * w + x] = acc / (f * f) as f32;
        }
    }
    out
}

/// Places labelled images in a grid of `cols` columns, each downscaled by `factor`; all
/// images must have the size of the first (smaller ones are padded with black).
pub fn contact_sheet(items: &[(String, Image)], cols: usize, factor: usize) -> Image {
    let Some((_, first)) = items.first() else {
        return Image::new(0, 0);
    };
    let (tw, th) = (first.width / factor.max(1), first.height / factor.max(1));
    let cols = cols.clamp(1, items.len());
    let rows = items.len().div_ceil(cols);
    let mut sheet = Image::new(tw * cols, th * rows);
    for (i, (label, img)) in items.iter().enumerate() {
        let mut tile = downscale(img, factor);
        draw_label(&mut tile, label, 4, 4, 2);
        let (ox, oy) = ((i % cols) * tw, (i / cols) * th);
        for y in 0..th.min(tile.height) {
            for x in 0..tw.min(tile.width) {
                sheet.pixels[(oy + y) * sheet.width + ox + x] = tile.get(x, y);
            }
        }
    }
    sheet
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sheet_layout_and_labels() {
        let mut a = Image::new(200, 100);
        a.pixels.iter_mut().for_each(|p| *p = Vec3::splat(0.5));
        let b = Image::new(200, 100);
        let sheet = contact_sheet(
            &[
                ("m=0".into(), a.clone()),
                ("m=1".into(), b.clone()),
                ("m=2".into(), a),
            ],
            2,
            2,
        );
        assert_eq!((sheet.width, sheet.height), (200, 100));
        // Tile 0 is grey away from its label, tile 1 black, tile 2 grey; tile 3 is empty.
        assert_eq!(sheet.get(90, 40), Vec3::splat(0.5));
        assert_eq!(sheet.get(190, 40), Vec3::ZERO);
        assert_eq!(sheet.get(90, 90), Vec3::splat(0.5));
        assert_eq!(sheet.get(190, 90), Vec3::ZERO);
        // The label draws white pixels in the first tile's corner.
        assert!((0..20).any(|y| (0..40).any(|x| sheet.get(x, y) == Vec3::ONE)));
        assert!(glyph('?').is_none());
    }
}
