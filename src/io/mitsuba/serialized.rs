//! Mitsuba's `.serialized` meshes (file versions 3 and 4, as Mitsuba 0.5–3 write them).
//!
//! A file holds shapes one after another, each a little-endian header (`u16` 0x041C,
//! `u16` version) and a zlib stream: `u32` flags (normals 0x1, texture coordinates 0x2,
//! colours 0x8, face normals 0x10, single 0x1000 or double 0x2000 precision), in version 4
//! a NUL-terminated name, `u64` vertex and triangle counts, the positions, normals,
//! texture coordinates and colours (floats or doubles), and `u32` triangle indices. The
//! file ends with each shape's offset (`u64` in version 4, `u32` in 3) and the `u32` count.

use glam::{Vec2, Vec3};
use std::io::Read;

const MAGIC: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x1;
const HAS_TEXCOORDS: u32 = 0x2;
const HAS_COLORS: u32 = 0x8;
const FACE_NORMALS: u32 = 0x10;
const DOUBLE: u32 = 0x2000;
/// Largest vertex or triangle count accepted.
const MAX_COUNT: u64 = 1 << 31;

/// One shape of a `.serialized` file.
#[derive(Debug, Default)]
pub struct SerializedMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex normals, if stored (and the file does not ask for face normals).
    pub normals: Option<Vec<Vec3>>,
    /// Texture coordinates, one per vertex, or empty.
    pub uvs: Vec<Vec2>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
}

fn u16_at(b: &[u8], i: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(i..i + 2)?.try_into().ok()?))
}

fn u32_at(b: &[u8], i: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(i..i + 4)?.try_into().ok()?))
}

fn u64_at(b: &[u8], i: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(i..i + 8)?.try_into().ok()?))
}

/// Reads shape `index` of the file's `bytes`.
pub fn read(bytes: &[u8], index: usize) -> Result<SerializedMesh, String> {
    let bad = |what: &str| format!("not a Mitsuba serialized mesh ({what})");
    if u16_at(bytes, 0) != Some(MAGIC) {
        return Err(bad("wrong magic number"));
    }
    let version = u16_at(bytes, 2).ok_or_else(|| bad("truncated"))?;
    if version != 3 && version != 4 {
        return Err(format!(
            "serialized mesh version {version} is not supported (3 and 4 are)"
        ));
    }
    let start = if index == 0 {
        0
    } else {
        let n = bytes.len();
        let count = u32_at(bytes, n.saturating_sub(4)).ok_or_else(|| bad("truncated"))? as usize;
        if index >= count {
            return Err(format!(
                "shape_index {index} is out of range (the file holds {count} shapes)"
            ));
        }
        let offset = if version == 4 {
            let at = n
                .checked_sub(8 * (count - index) + 4)
                .ok_or_else(|| bad("truncated"))?;
            u64_at(bytes, at).ok_or_else(|| bad("truncated"))?
        } else {
            let at = n
                .checked_sub(4 * (count - index + 1))
                .ok_or_else(|| bad("truncated"))?;
            u32_at(bytes, at).ok_or_else(|| bad("truncated"))? as u64
        };
        usize::try_from(offset).map_err(|_| bad("offset out of range"))?
    };
    if u16_at(bytes, start) != Some(MAGIC) || u16_at(bytes, start + 2) != Some(version) {
        return Err(bad("a shape's header is damaged"));
    }
    let body = bytes.get(start + 4..).ok_or_else(|| bad("truncated"))?;
    decode(body, version)
}

/// Decompresses and decodes one shape's zlib stream.
fn decode(body: &[u8], version: u16) -> Result<SerializedMesh, String> {
    let mut z = flate2::read::ZlibDecoder::new(body);
    let mut exact = |n: usize| -> Result<Vec<u8>, String> {
        let mut v = Vec::with_capacity(n.min(1 << 20));
        (&mut z)
            .take(n as u64)
            .read_to_end(&mut v)
            .map_err(|e| format!("serialized mesh: {e}"))?;
        if v.len() != n {
            return Err("serialized mesh: the data ends early".into());
        }
        Ok(v)
    };
    let flags = u32::from_le_bytes(exact(4)?.try_into().unwrap_or_default());
    if version == 4 {
        let mut name_len = 0;
        while exact(1)?[0] != 0 {
            name_len += 1;
            if name_len > 4096 {
                return Err("serialized mesh: the shape name does not end".into());
            }
        }
    }
    let counts = exact(16)?;
    let vertices = u64_at(&counts, 0).unwrap_or(0);
    let triangles = u64_at(&counts, 8).unwrap_or(0);
    if vertices > MAX_COUNT || triangles > MAX_COUNT {
        return Err(format!(
            "serialized mesh: {vertices} vertices and {triangles} triangles are too many"
        ));
    }
    let (nv, nt) = (vertices as usize, triangles as usize);
    let size = if flags & DOUBLE != 0 { 8 } else { 4 };
    let mut floats = |count: usize| -> Result<Vec<f32>, String> {
        let raw = exact(count * size)?;
        Ok(raw
            .chunks_exact(size)
            .map(|c| {
                let v = if size == 8 {
                    f64::from_le_bytes(c.try_into().unwrap_or_default()) as f32
                } else {
                    f32::from_le_bytes(c.try_into().unwrap_or_default())
                };
                if v.is_finite() {
                    v
                } else {
                    0.0
                }
            })
            .collect())
    };
    let vec3s = |f: Vec<f32>| -> Vec<Vec3> { f.chunks_exact(3).map(Vec3::from_slice).collect() };
    let positions = vec3s(floats(nv * 3)?);
    let normals = if flags & HAS_NORMALS != 0 {
        Some(vec3s(floats(nv * 3)?))
    } else {
        None
    };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        floats(nv * 2)?
            .chunks_exact(2)
            .map(Vec2::from_slice)
            .collect()
    } else {
        Vec::new()
    };
    if flags & HAS_COLORS != 0 {
        floats(nv * 3)?;
    }
    let raw = exact(nt * 12)?;
    let mut tris = Vec::with_capacity(nt);
    for c in raw.chunks_exact(12) {
        let t = [0, 4, 8].map(|o| u32::from_le_bytes(c[o..o + 4].try_into().unwrap_or_default()));
        if t.iter().any(|&i| i as usize >= nv) {
            return Err(format!(
                "serialized mesh: a triangle refers to vertex {} of {nv}",
                t.iter().max().unwrap_or(&0)
            ));
        }
        tris.push(t);
    }
    Ok(SerializedMesh {
        positions,
        normals: normals.filter(|_| flags & FACE_NORMALS == 0),
        uvs,
        triangles: tris,
    })
}

/// Writes `meshes` as a version-4 `.serialized` file (single precision), for tests.
pub fn write(meshes: &[SerializedMesh]) -> Vec<u8> {
    use std::io::Write;
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for m in meshes {
        offsets.push(out.len() as u64);
        out.extend(MAGIC.to_le_bytes());
        out.extend(4u16.to_le_bytes());
        let mut flags = 0x1000;
        if m.normals.is_some() {
            flags |= HAS_NORMALS;
        }
        if !m.uvs.is_empty() {
            flags |= HAS_TEXCOORDS;
        }
        let mut raw = Vec::new();
        raw.extend(u32::to_le_bytes(flags));
        raw.extend(b"mesh\0");
        raw.extend((m.positions.len() as u64).to_le_bytes());
        raw.extend((m.triangles.len() as u64).to_le_bytes());
        let mut put = |v: &[f32]| v.iter().for_each(|x| raw.extend(x.to_le_bytes()));
        m.positions.iter().for_each(|p| put(&p.to_array()));
        if let Some(n) = &m.normals {
            n.iter().for_each(|p| put(&p.to_array()));
        }
        m.uvs.iter().for_each(|p| put(&p.to_array()));
        m.triangles
            .iter()
            .for_each(|t| t.iter().for_each(|i| raw.extend(i.to_le_bytes())));
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        let _ = z.write_all(&raw);
        out.extend(z.finish().unwrap_or_default());
    }
    for o in &offsets {
        out.extend(o.to_le_bytes());
    }
    out.extend((meshes.len() as u32).to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f32) -> SerializedMesh {
        SerializedMesh {
            positions: vec![
                Vec3::new(0.0, 0.0, z),
                Vec3::new(1.0, 0.0, z),
                Vec3::new(1.0, 1.0, z),
                Vec3::new(0.0, 1.0, z),
            ],
            normals: Some(vec![Vec3::Z; 4]),
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn round_trips_every_shape() {
        let bytes = write(&[quad(0.0), quad(2.0)]);
        for (i, z) in [(0, 0.0), (1, 2.0)] {
            let m = read(&bytes, i).unwrap();
            assert_eq!(m.positions, quad(z).positions);
            assert_eq!(m.triangles, quad(z).triangles);
            assert_eq!(m.uvs.len(), 4);
            assert_eq!(m.normals.as_ref().map(Vec::len), Some(4));
        }
        assert!(read(&bytes, 2).unwrap_err().contains("out of range"));
    }

    #[test]
    fn damaged_files_are_errors() {
        let bytes = write(&[quad(0.0)]);
        assert!(read(&bytes[..3], 0).is_err());
        assert!(read(&bytes[..bytes.len() / 2], 0).is_err());
        let mut wrong = bytes.clone();
        wrong[0] = 0;
        assert!(read(&wrong, 0).unwrap_err().contains("magic"));
        let mut flipped = bytes;
        flipped[20] ^= 0xFF;
        assert!(read(&flipped, 0).is_err());
    }
}
