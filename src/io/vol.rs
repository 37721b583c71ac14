//! Mitsuba's binary volume grids (`.vol`, version 3, the format `gridvolume` reads).
//!
//! Layout, little-endian: the bytes `VOL`, the version byte 3, an `i32` encoding (1: `f32`,
//! the only one Mitsuba 3 reads), `i32` sizes x, y, z, an `i32` channel count, six `f32` of a
//! bounding box (min x y z, max x y z), then the values, channels innermost, x fastest, then
//! y, then z. The size the header promises is checked against the file's length before
//! anything is allocated, so a short or lying file costs no memory.

use crate::medium::grid::{voxel_count, GridEdge, GridFilter, VoxelGrid};
use glam::Vec3;

/// Bytes before the values.
const HEADER_BYTES: usize = 48;

/// A `.vol` file's grid and the bounding box its header records.
#[derive(Clone, Debug)]
pub struct VolFile {
    /// The voxels.
    pub grid: VoxelGrid,
    /// The box the header gives, min and max (Mitsuba uses it only with `use_grid_bbox`).
    pub bbox: (Vec3, Vec3),
}

/// The header's sizes and channel count, and where it says its box is.
struct Header {
    res: [u32; 3],
    channels: u32,
    bbox: (Vec3, Vec3),
}

fn read_i32(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn read_f32(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// The header of `bytes`, checked (what is wrong otherwise).
fn header(bytes: &[u8]) -> Result<Header, String> {
    if bytes.len() < HEADER_BYTES || &bytes[..3] != b"VOL" {
        return Err(format!(
            "not a Mitsuba volume file (it needs a {HEADER_BYTES}-byte header starting \"VOL\")"
        ));
    }
    if bytes[3] != 3 {
        return Err(format!("volume file version {} (only 3 is read)", bytes[3]));
    }
    let encoding = read_i32(bytes, 4);
    if encoding != 1 {
        return Err(format!(
            "volume encoding {encoding} (only 1, 32-bit floats, is read, as in Mitsuba 3)"
        ));
    }
    let size = |at: usize, what: &str| -> Result<u32, String> {
        let n = read_i32(bytes, at);
        u32::try_from(n)
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("volume {what} {n} must be positive"))
    };
    let res = [size(8, "x size")?, size(12, "y size")?, size(16, "z size")?];
    let channels = size(20, "channel count")?;
    let f = |i: usize| read_f32(bytes, 24 + 4 * i);
    Ok(Header {
        res,
        channels,
        bbox: (Vec3::new(f(0), f(1), f(2)), Vec3::new(f(3), f(4), f(5))),
    })
}

/// Checks that a file of `len` bytes holds exactly the values header `h` promises.
fn check_length(h: &Header, len: u64) -> Result<(), String> {
    let expected = voxel_count(h.res)
        .and_then(|n| n.checked_mul(h.channels as usize * 4))
        .and_then(|n| n.checked_add(HEADER_BYTES))
        .ok_or_else(|| format!("volume size {:?} is too large", h.res))?;
    if len != expected as u64 {
        let why = if len < expected as u64 {
            "truncated"
        } else {
            "trailing data"
        };
        return Err(format!(
            "volume of {}×{}×{} voxels × {} channel(s) needs {expected} bytes; the file has \
             {len} ({why})",
            h.res[0], h.res[1], h.res[2], h.channels
        ));
    }
    Ok(())
}

/// Reads `.vol` bytes: the grid (an error naming what is wrong where the header is not
/// version 3 float data, the file is shorter or longer than its header says, there are
/// neither 1 nor 3 channels, or a value is negative or not finite).
pub fn read(bytes: &[u8], edge: GridEdge, filter: GridFilter) -> Result<VolFile, String> {
    let h = header(bytes)?;
    check_length(&h, bytes.len() as u64)?;
    let data = bytes[HEADER_BYTES..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let grid = VoxelGrid::new(h.res, h.channels, data, edge, filter)?;
    Ok(VolFile { grid, bbox: h.bbox })
}

/// Reads the `.vol` file at `path`, checking its length against its header before reading
/// the values (the message names the file).
pub fn read_file(
    path: &std::path::Path,
    edge: GridEdge,
    filter: GridFilter,
) -> Result<VolFile, String> {
    use std::io::Read;
    let at = |e: String| format!("{}: {e}", path.display());
    let mut file = std::fs::File::open(path).map_err(|e| at(e.to_string()))?;
    let len = file.metadata().map_err(|e| at(e.to_string()))?.len();
    let mut head = Vec::with_capacity(HEADER_BYTES);
    (&mut file)
        .take(HEADER_BYTES as u64)
        .read_to_end(&mut head)
        .map_err(|e| at(e.to_string()))?;
    check_length(&header(&head).map_err(at)?, len).map_err(at)?;
    let bytes = std::fs::read(path).map_err(|e| at(e.to_string()))?;
    read(&bytes, edge, filter).map_err(at)
}

/// Writes `grid`'s values as a `.vol` file's bytes with box `bbox` (for tests and tools).
pub fn write(res: [u32; 3], channels: u32, values: &[f32], bbox: (Vec3, Vec3)) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_BYTES + values.len() * 4);
    out.extend_from_slice(b"VOL\x03");
    for v in [
        1,
        res[0] as i32,
        res[1] as i32,
        res[2] as i32,
        channels as i32,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in bbox.0.to_array().into_iter().chain(bbox.1.to_array()) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<u8> {
        let values: Vec<f32> = (0..2 * 3 * 4).map(|i| i as f32 * 0.5).collect();
        write([2, 3, 4], 1, &values, (Vec3::ZERO, Vec3::ONE))
    }

    #[test]
    fn a_written_grid_reads_back() {
        let v = read(&sample(), GridEdge::Clamp, GridFilter::Trilinear).unwrap();
        assert_eq!(v.grid.res(), [2, 3, 4]);
        assert_eq!(v.grid.channels(), 1);
        assert_eq!(v.bbox, (Vec3::ZERO, Vec3::ONE));
        // Voxel (1, 2, 3) is value number 1 + 2·(2 + 2·3)·... = x + 2·(y + 3·z) = 23.
        let centre = Vec3::new(1.5 / 2.0, 2.5 / 3.0, 3.5 / 4.0);
        assert_eq!(v.grid.lookup(centre).x, 23.0 * 0.5);
    }

    #[test]
    fn malformed_files_are_refused_with_what_is_wrong() {
        let good = sample();
        let err = |b: &[u8]| read(b, GridEdge::Clamp, GridFilter::Trilinear).unwrap_err();
        assert!(err(&good[..good.len() - 1]).contains("truncated"));
        assert!(err(&good[..20]).contains("not a Mitsuba volume"));
        let mut extra = good.clone();
        extra.push(0);
        assert!(err(&extra).contains("trailing"));
        let mut version = good.clone();
        version[3] = 2;
        assert!(err(&version).contains("version 2"));
        let mut encoding = good.clone();
        encoding[4] = 3;
        assert!(err(&encoding).contains("encoding 3"));
        let mut huge = good.clone();
        huge[8..12].copy_from_slice(&i32::MAX.to_le_bytes());
        huge[12..16].copy_from_slice(&i32::MAX.to_le_bytes());
        let e = err(&huge);
        assert!(e.contains("too large"), "{e}");
        let mut negative = good.clone();
        negative[HEADER_BYTES..HEADER_BYTES + 4].copy_from_slice(&(-1.0f32).to_le_bytes());
        assert!(err(&negative).contains("negative"));
        let mut channels = good;
        channels[20..24].copy_from_slice(&2i32.to_le_bytes());
        assert!(err(&channels).contains("channel"));
    }
}
