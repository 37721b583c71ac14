//! NanoVDB files (`.nvdb`), as pbrt-v4 reads them for its `nanovdb` medium: float grids of
//! NanoVDB's file format 32 (the version pbrt-v4 builds with), uncompressed or ZIP.
//!
//! Layout (NanoVDB's `IO.h` and `NanoVDB.h`, little-endian): segments, each a 16-byte header
//! (magic `NanoVDB0`, version, grid count, codec), one 176-byte record per grid (sizes, type,
//! class, boxes, name length, ...) followed by its name, then the grids' buffers. A buffer is
//! the grid as NanoVDB holds it in memory: a 672-byte grid record (its index-to-world map), a
//! 64-byte tree record (byte offsets of the node arrays), the root (a 64-byte header, then
//! 32-byte tiles keyed by the upper node they hold), upper nodes (32³ entries), lower nodes
//! (16³) and leaves (8³ values). Every offset read from the file is checked against the
//! buffer, so a damaged file is an error, never a read out of bounds; sizes are checked
//! against the file (and a ZIP grid's promised size against [`MAX_GRID_BYTES`]) before
//! anything is allocated for them.

use crate::medium::grid::{BlockMax, GridEdge, GridFilter, SparseVoxels, VoxelGrid};
use glam::{DVec3, IVec3, Mat3, Vec3};
use std::sync::Arc;

/// `NanoVDB0`, the file and grid magic number.
const MAGIC: u64 = 0x3042_4456_6f6e_614e;
/// The file format's major version this reader knows.
const MAJOR: u32 = 32;
/// Bytes of a segment header and of a grid's record in it.
const HEADER_BYTES: usize = 16;
const META_BYTES: usize = 176;
/// Largest grid buffer a ZIP grid may unpack to.
pub const MAX_GRID_BYTES: u64 = 1 << 32;
/// Most voxels a grid may span to be copied into a dense grid; larger ones are looked up in
/// their tree.
pub const MAX_DENSE_VOXELS: u64 = 1 << 24;
/// Most voxels a grid's box may span along an axis.
pub const MAX_SIDE: u32 = 1 << 20;

/// Little-endian reads from a byte slice that fail (`None`) past its end.
trait Bytes {
    fn at<const N: usize>(&self, pos: usize) -> Option<[u8; N]>;
    fn u16_at(&self, pos: usize) -> Option<u16> {
        self.at(pos).map(u16::from_le_bytes)
    }
    fn u32_at(&self, pos: usize) -> Option<u32> {
        self.at(pos).map(u32::from_le_bytes)
    }
    fn i32_at(&self, pos: usize) -> Option<i32> {
        self.at(pos).map(i32::from_le_bytes)
    }
    fn u64_at(&self, pos: usize) -> Option<u64> {
        self.at(pos).map(u64::from_le_bytes)
    }
    fn i64_at(&self, pos: usize) -> Option<i64> {
        self.at(pos).map(i64::from_le_bytes)
    }
    fn f32_at(&self, pos: usize) -> Option<f32> {
        self.at(pos).map(f32::from_le_bytes)
    }
    fn f64_at(&self, pos: usize) -> Option<f64> {
        self.at(pos).map(f64::from_le_bytes)
    }
}

impl Bytes for [u8] {
    fn at<const N: usize>(&self, pos: usize) -> Option<[u8; N]> {
        self.get(pos..pos.checked_add(N)?)?.try_into().ok()
    }
}

/// A float grid read from a NanoVDB file.
#[derive(Clone, Debug)]
pub struct NanoGrid {
    /// The grid's buffer (see the module's layout).
    buffer: Vec<u8>,
    /// Byte offset of the root node in `buffer`.
    root: usize,
    /// World to index space: `index = to_index · (world − origin)` (NanoVDB's single-precision
    /// inverse map, which pbrt-v4 uses).
    pub to_index: Mat3,
    /// The map's translation.
    pub origin: Vec3,
    /// The box of its active voxels in index space, both ends included.
    pub index_bbox: (IVec3, IVec3),
    /// Its box in world space: the index box's voxels, `min` to `max + 1`, mapped.
    pub world_bbox: (DVec3, DVec3),
}

/// The record of one grid in a segment.
struct Meta {
    grid_size: u64,
    file_size: u64,
    grid_type: u32,
    grid_class: u32,
    name: String,
}

/// Codecs of a segment's grids.
#[derive(Clone, Copy, PartialEq)]
enum Codec {
    None,
    Zip,
}

/// Reads grid `name` of the NanoVDB file `bytes`: `Ok(None)` where the file has no grid of
/// that name, an error naming what is wrong where the file is not one this reader takes.
pub fn read_grid(bytes: &[u8], name: &str) -> Result<Option<NanoGrid>, String> {
    match records(bytes)?.into_iter().find(|(m, ..)| m.name == name) {
        Some((m, codec, data)) => grid(&bytes[data], &m, codec).map(Some),
        None => Ok(None),
    }
}

/// The names of the file's grids (an error where its records do not read).
pub fn grid_names(bytes: &[u8]) -> Result<Vec<String>, String> {
    Ok(records(bytes)?.into_iter().map(|(m, ..)| m.name).collect())
}

/// Every grid record of the file, with its segment's codec and where its data lies.
fn records(bytes: &[u8]) -> Result<Vec<(Meta, Codec, std::ops::Range<usize>)>, String> {
    let mut out = Vec::new();
    let mut pos = 0usize;
    while pos < bytes.len() {
        let (codec, metas, mut data) = segment(bytes, pos)?;
        for m in metas {
            let end = usize::try_from(m.file_size)
                .ok()
                .and_then(|n| data.checked_add(n))
                .filter(|&e| e <= bytes.len())
                .ok_or_else(|| format!("grid \"{}\" runs past the end of the file", m.name))?;
            out.push((m, codec, data..end));
            data = end;
        }
        pos = data;
    }
    Ok(out)
}

/// The segment at `pos`: its codec, grid records and where its grids' data starts.
fn segment(bytes: &[u8], pos: usize) -> Result<(Codec, Vec<Meta>, usize), String> {
    let short = || "the file ends inside a segment header".to_string();
    let magic = bytes.u64_at(pos).ok_or_else(short)?;
    if magic != MAGIC {
        return Err("not a NanoVDB file (no \"NanoVDB0\" magic number)".into());
    }
    let version = bytes.u32_at(pos + 8).ok_or_else(short)?;
    let major = version >> 21;
    if major != MAJOR {
        return Err(format!(
            "NanoVDB file format {major}.{} (this reader, as pbrt-v4, reads {MAJOR}.x)",
            (version >> 10) & 0x7ff
        ));
    }
    let count = bytes.u16_at(pos + 12).ok_or_else(short)?;
    let codec = match bytes.u16_at(pos + 14).ok_or_else(short)? {
        0 => Codec::None,
        1 => Codec::Zip,
        2 => return Err("Blosc-compressed NanoVDB grids are not supported (ZIP is)".into()),
        c => return Err(format!("unknown NanoVDB codec {c}")),
    };
    let mut at = pos + HEADER_BYTES;
    let mut metas = Vec::new();
    for _ in 0..count {
        let short = || "the file ends inside a grid record".to_string();
        let record = bytes.get(at..at + META_BYTES).ok_or_else(short)?;
        let name_size = record.u32_at(136).ok_or_else(short)? as usize;
        let name_bytes = bytes
            .get(at + META_BYTES..at + META_BYTES + name_size)
            .ok_or_else(short)?;
        let name = String::from_utf8_lossy(name_bytes)
            .trim_end_matches('\0')
            .to_string();
        metas.push(Meta {
            grid_size: record.u64_at(0).ok_or_else(short)?,
            file_size: record.u64_at(8).ok_or_else(short)?,
            grid_type: record.u32_at(32).ok_or_else(short)?,
            grid_class: record.u32_at(36).ok_or_else(short)?,
            name,
        });
        at += META_BYTES + name_size;
    }
    Ok((codec, metas, at))
}

/// The grid stored as `data` (its bytes in the file) under record `m`.
fn grid(data: &[u8], m: &Meta, codec: Codec) -> Result<NanoGrid, String> {
    let name = &m.name;
    if m.grid_type != 1 {
        return Err(format!(
            "grid \"{name}\" has values of type {} (only 32-bit floats are read)",
            m.grid_type
        ));
    }
    if m.grid_class != 0 && m.grid_class != 2 {
        return Err(format!(
            "grid \"{name}\" is not a fog volume (class {})",
            m.grid_class
        ));
    }
    let buffer = match codec {
        Codec::None => data.to_vec(),
        Codec::Zip => unzip(data, m)?,
    };
    if buffer.len() as u64 != m.grid_size {
        return Err(format!(
            "grid \"{name}\" holds {} bytes, its record says {}",
            buffer.len(),
            m.grid_size
        ));
    }
    parse(buffer).map_err(|e| format!("grid \"{name}\": {e}"))
}

/// A ZIP grid's buffer: a `u64` of compressed bytes, then a zlib stream of `m.grid_size`.
fn unzip(data: &[u8], m: &Meta) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let name = &m.name;
    let size = data
        .u64_at(0)
        .ok_or_else(|| format!("grid \"{name}\" is truncated"))?;
    let body = usize::try_from(size)
        .ok()
        .and_then(|n| data.get(8..8usize.checked_add(n)?))
        .ok_or_else(|| format!("grid \"{name}\": its compressed size {size} runs past its data"))?;
    if m.grid_size > MAX_GRID_BYTES {
        return Err(format!(
            "grid \"{name}\" would unpack to {} bytes (at most {MAX_GRID_BYTES} are read)",
            m.grid_size
        ));
    }
    let mut out = Vec::new();
    flate2::read::ZlibDecoder::new(body)
        .take(m.grid_size)
        .read_to_end(&mut out)
        .map_err(|e| format!("grid \"{name}\": its ZIP data does not unpack: {e}"))?;
    Ok(out)
}

/// Byte offsets and sizes of the node records (NanoVDB 32's, checked by the test that reads
/// the file NanoVDB wrote: `tests/pbrt/nvdb`).
mod layout {
    /// The grid record, then the tree record.
    pub const GRID_BYTES: usize = 672;
    /// In the grid record: the map's single-precision inverse matrix and translation, the
    /// world box (doubles).
    pub const INV_MAT_F: usize = 332;
    pub const VEC_F: usize = 368;
    pub const WORLD_BBOX: usize = 560;
    /// The root: its index box, tile count, background; tiles after its 64-byte header.
    pub const ROOT_BBOX: usize = 0;
    pub const ROOT_TABLE_SIZE: usize = 24;
    pub const ROOT_BACKGROUND: usize = 28;
    pub const ROOT_BYTES: usize = 64;
    pub const TILE_BYTES: usize = 32;
    /// Internal nodes: child mask and table offsets (upper 32³, lower 16³ entries).
    pub const UPPER_CHILD_MASK: usize = 4128;
    pub const UPPER_TABLE: usize = 8256;
    pub const LOWER_CHILD_MASK: usize = 544;
    pub const LOWER_TABLE: usize = 1088;
    /// A leaf's 8³ values.
    pub const LEAF_VALUES: usize = 96;
    /// Node sizes: upper, lower, leaf.
    pub const UPPER_BYTES: usize = 270_400;
    pub const LOWER_BYTES: usize = 33_856;
    pub const LEAF_BYTES: usize = 2_144;
}

/// The grid in `buffer`, its records checked.
fn parse(buffer: Vec<u8>) -> Result<NanoGrid, String> {
    use layout::*;
    let bad = |what: &str| format!("damaged grid buffer ({what})");
    if buffer.u64_at(0) != Some(MAGIC) {
        return Err(bad("no magic number"));
    }
    let tree = GRID_BYTES;
    let root_offset = buffer.u64_at(tree + 24).ok_or_else(|| bad("tree record"))?;
    let root = usize::try_from(root_offset)
        .ok()
        .and_then(|r| tree.checked_add(r))
        .filter(|&r| r.checked_add(ROOT_BYTES).is_some_and(|e| e <= buffer.len()))
        .ok_or_else(|| bad("root offset"))?;
    let floats = |pos: usize, n: usize| -> Option<Vec<f32>> {
        (0..n).map(|i| buffer.f32_at(pos + 4 * i)).collect()
    };
    let inv = floats(INV_MAT_F, 9).ok_or_else(|| bad("map"))?;
    let vec = floats(VEC_F, 3).ok_or_else(|| bad("map"))?;
    let doubles: Option<Vec<f64>> = (0..6).map(|i| buffer.f64_at(WORLD_BBOX + 8 * i)).collect();
    let wb = doubles.ok_or_else(|| bad("world box"))?;
    let ints: Option<Vec<i32>> = (0..6)
        .map(|i| buffer.i32_at(root + ROOT_BBOX + 4 * i))
        .collect();
    let ib = ints.ok_or_else(|| bad("index box"))?;
    let to_index = Mat3::from_cols_array(&[
        inv[0], inv[3], inv[6], inv[1], inv[4], inv[7], inv[2], inv[5], inv[8],
    ]);
    let g = NanoGrid {
        buffer,
        root,
        to_index,
        origin: Vec3::new(vec[0], vec[1], vec[2]),
        index_bbox: (
            IVec3::new(ib[0], ib[1], ib[2]),
            IVec3::new(ib[3], ib[4], ib[5]),
        ),
        world_bbox: (
            DVec3::new(wb[0], wb[1], wb[2]),
            DVec3::new(wb[3], wb[4], wb[5]),
        ),
    };
    let finite = g.to_index.is_finite() && g.origin.is_finite();
    if !finite || g.to_index.determinant() == 0.0 {
        return Err(bad("its map has no inverse"));
    }
    Ok(g)
}

impl NanoGrid {
    /// The background value (that of voxels no node holds).
    pub fn background(&self) -> f32 {
        self.buffer
            .f32_at(self.root + layout::ROOT_BACKGROUND)
            .unwrap_or(0.0)
    }

    /// The value of voxel `ijk`; `None` where a node the walk reaches is damaged.
    pub fn value(&self, ijk: IVec3) -> Option<f32> {
        match self.block(ijk)? {
            Block::Leaf(leaf) => self
                .buffer
                .f32_at(leaf + layout::LEAF_VALUES + 4 * leaf_entry(ijk)),
            Block::Tile(v) => Some(v),
        }
    }

    /// The leaf or tile that holds voxel `ijk`; `None` where a node on the way is damaged.
    fn block(&self, ijk: IVec3) -> Option<Block> {
        use layout::*;
        let b = &self.buffer;
        let key = |v: i32| u64::from((v as u32) >> 12);
        let want = (key(ijk.x) << 42) | (key(ijk.y) << 21) | key(ijk.z);
        let tiles = b.u32_at(self.root + ROOT_TABLE_SIZE)? as usize;
        let first = self.root + ROOT_BYTES;
        let tile = (0..tiles)
            .map(|n| first + n * TILE_BYTES)
            .find(|&t| b.u64_at(t) == Some(want));
        let Some(tile) = tile else {
            return Some(Block::Tile(self.background()));
        };
        let child = b.i64_at(tile + 8)?;
        if child == 0 {
            return b.f32_at(tile + 20).map(Block::Tile);
        }
        let upper = offset(self.root, child)?;
        let n = |v: i32, mask: i32, shift: u32| ((v & mask) >> shift) as usize;
        let entry = (n(ijk.x, 4095, 7) << 10) | (n(ijk.y, 4095, 7) << 5) | n(ijk.z, 4095, 7);
        let Some(lower) = self.child(upper, (UPPER_CHILD_MASK, UPPER_TABLE), entry)? else {
            return b.f32_at(upper + UPPER_TABLE + 8 * entry).map(Block::Tile);
        };
        let entry = (n(ijk.x, 127, 3) << 8) | (n(ijk.y, 127, 3) << 4) | n(ijk.z, 127, 3);
        let Some(leaf) = self.child(lower, (LOWER_CHILD_MASK, LOWER_TABLE), entry)? else {
            return b.f32_at(lower + LOWER_TABLE + 8 * entry).map(Block::Tile);
        };
        Some(Block::Leaf(leaf))
    }

    /// Where table entry `entry` of the internal node at `node` points (`Some(None)` for a
    /// tile), given its child mask's and table's offsets.
    fn child(
        &self,
        node: usize,
        (mask, table): (usize, usize),
        entry: usize,
    ) -> Option<Option<usize>> {
        let word = self.buffer.u64_at(node + mask + 8 * (entry >> 6))?;
        if word >> (entry & 63) & 1 == 0 {
            return Some(None);
        }
        let child = self.buffer.i64_at(node + table + 8 * entry)?;
        offset(node, child).map(Some)
    }

    /// Its active box and one voxel beyond on every side: the first voxel and the voxels per
    /// axis; an error where the box is empty or a side exceeds [`MAX_SIDE`] voxels.
    pub fn extent(&self) -> Result<(IVec3, [u32; 3]), String> {
        let (lo, hi) = self.index_bbox;
        let size = hi.as_i64vec3() - lo.as_i64vec3() + 3;
        if size.min_element() <= 0 {
            return Err("its index box is empty".into());
        }
        if size.max_element() > i64::from(MAX_SIDE) {
            return Err(format!(
                "its box of {}×{}×{} voxels is wider than this renderer's grids ({MAX_SIDE} \
                 voxels a side)",
                size.x, size.y, size.z
            ));
        }
        Ok((
            lo - IVec3::ONE,
            [size.x as u32, size.y as u32, size.z as u32],
        ))
    }

    /// Its voxels `first + v` for `v` over `res`: copied into a dense grid where there are at
    /// most [`MAX_DENSE_VOXELS`], else looked up in the tree (see [`NanoGrid::sparse_over`]).
    pub fn voxels_over(
        self: &Arc<NanoGrid>,
        first: IVec3,
        res: [u32; 3],
    ) -> Result<VoxelGrid, String> {
        let count = res.iter().map(|&n| u64::from(n)).product::<u64>();
        if count <= MAX_DENSE_VOXELS {
            self.dense_over(first, res)
        } else {
            self.sparse_over(first, res)
        }
    }

    /// Its voxels `first + v` for `v` over `res`, looked up in the tree; every node is checked
    /// first, and the largest value of every leaf and tile is recorded for majorants. An error
    /// where a node is damaged or a value is negative or not finite.
    pub fn sparse_over(
        self: &Arc<NanoGrid>,
        first: IVec3,
        res: [u32; 3],
    ) -> Result<VoxelGrid, String> {
        let background = checked_value(self.background())?;
        let mut blocks = BlockMax::new(first, res, background);
        self.walk(|lo, size, max| blocks.add(lo, size, max))?;
        let source: Arc<dyn SparseVoxels> = self.clone();
        VoxelGrid::sparse(source, blocks)
    }

    /// Calls `block(first voxel, voxels per side, largest value)` for every tile and leaf of
    /// the tree; an error where a node lies outside the buffer, the nodes' sizes add up to
    /// more than the buffer (they overlap: a damaged file, and the bound on this walk's work)
    /// or a value is negative or not finite.
    fn walk(&self, block: impl FnMut(IVec3, i32, f32)) -> Result<(), String> {
        use layout::*;
        let b = &self.buffer;
        let mut walk = Walk {
            budget: b.len(),
            block,
        };
        let tiles = b.u32_at(self.root + ROOT_TABLE_SIZE).ok_or_else(damaged)? as usize;
        for n in 0..tiles {
            let tile = self.root + ROOT_BYTES + n * TILE_BYTES;
            let key = b.u64_at(tile).ok_or_else(damaged)?;
            let part = |shift: u32| ((((key >> shift) & 0x1f_ffff) as u32) << 12) as i32;
            let origin = IVec3::new(part(42), part(21), part(0));
            let child = b.i64_at(tile + 8).ok_or_else(damaged)?;
            if child == 0 {
                (walk.block)(origin, 4096, self.checked_f32(tile + 20)?);
                continue;
            }
            let upper = offset(self.root, child).ok_or_else(damaged)?;
            walk.take(b, upper, UPPER_BYTES)?;
            self.walk_internal(upper, origin, false, &mut walk)?;
        }
        Ok(())
    }

    /// [`NanoGrid::walk`] through the upper node (or, where `lower`, the lower node) at byte
    /// `node`, whose first voxel is `origin`.
    fn walk_internal<F: FnMut(IVec3, i32, f32)>(
        &self,
        node: usize,
        origin: IVec3,
        lower: bool,
        walk: &mut Walk<F>,
    ) -> Result<(), String> {
        use layout::*;
        let (mask, table, side, span) = if lower {
            (LOWER_CHILD_MASK, LOWER_TABLE, 16, 8)
        } else {
            (UPPER_CHILD_MASK, UPPER_TABLE, 32, 128)
        };
        for e in 0..side * side * side {
            let at = origin + entry_origin(e, side) * span;
            let Some(child) = self.child(node, (mask, table), e).ok_or_else(damaged)? else {
                (walk.block)(at, span, self.checked_f32(node + table + 8 * e)?);
                continue;
            };
            if !lower {
                walk.take(&self.buffer, child, LOWER_BYTES)?;
                self.walk_internal(child, at, true, walk)?;
                continue;
            }
            walk.take(&self.buffer, child, LEAF_BYTES)?;
            let mut max = 0.0f32;
            for v in 0..512 {
                max = max.max(self.checked_f32(child + LEAF_VALUES + 4 * v)?);
            }
            (walk.block)(at, 8, max);
        }
        Ok(())
    }

    /// The value at byte `pos`, checked to be finite and non-negative.
    fn checked_f32(&self, pos: usize) -> Result<f32, String> {
        self.buffer
            .f32_at(pos)
            .ok_or_else(damaged)
            .and_then(checked_value)
    }

    /// Its voxels `first + v` for `v` over `res` as a dense grid (`res` within
    /// [`MAX_DENSE_VOXELS`]); an error where a node is damaged.
    pub fn dense_over(&self, first: IVec3, res: [u32; 3]) -> Result<VoxelGrid, String> {
        let count = res.iter().map(|&n| n as usize).product::<usize>();
        if count as u64 > MAX_DENSE_VOXELS {
            return Err(format!(
                "{res:?} voxels are more than this renderer's grids take"
            ));
        }
        let mut values = Vec::with_capacity(count);
        for z in 0..res[2] as i32 {
            for y in 0..res[1] as i32 {
                for x in 0..res[0] as i32 {
                    let v = self
                        .value(first + IVec3::new(x, y, z))
                        .ok_or_else(damaged)?;
                    values.push(v);
                }
            }
        }
        VoxelGrid::new(res, 1, values, GridEdge::Zero, GridFilter::Trilinear)
    }
}

/// Where a voxel's value lives.
enum Block {
    /// In the leaf at this byte offset.
    Leaf(usize),
    /// In a tile (or the background): this value.
    Tile(f32),
}

/// The state of [`NanoGrid::walk`]: node bytes the buffer has left for nodes not yet visited,
/// and what to call for each tile and leaf.
struct Walk<F> {
    budget: usize,
    block: F,
}

impl<F> Walk<F> {
    /// Counts the node of `bytes` at byte `node` of `buffer` as visited; an error where it
    /// lies outside the buffer or the budget is spent.
    fn take(&mut self, buffer: &[u8], node: usize, bytes: usize) -> Result<(), String> {
        let inside = node
            .checked_add(bytes)
            .is_some_and(|end| end <= buffer.len());
        if !inside {
            return Err(damaged());
        }
        self.budget = self
            .budget
            .checked_sub(bytes)
            .ok_or("damaged grid buffer (its nodes overlap)")?;
        Ok(())
    }
}

/// The error of a node that lies outside the grid's buffer.
fn damaged() -> String {
    "damaged grid buffer (a node lies outside it)".to_string()
}

/// The place of table entry `e` of a node of `n³` entries (x slowest, z fastest).
fn entry_origin(e: usize, n: usize) -> IVec3 {
    IVec3::new((e / (n * n)) as i32, (e / n % n) as i32, (e % n) as i32)
}

/// `v` where it is finite and non-negative, else an error saying so.
fn checked_value(v: f32) -> Result<f32, String> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("voxel value {v} is negative or not finite"))
    }
}

impl SparseVoxels for NanoGrid {
    fn value(&self, ijk: IVec3) -> f32 {
        NanoGrid::value(self, ijk).unwrap_or(0.0)
    }

    fn cube(&self, ijk: IVec3) -> [f32; 8] {
        // Where the eight voxels share a leaf (or an 8³-aligned tile), one walk finds them.
        let one_block = (ijk & 7).cmplt(IVec3::splat(7)).all();
        let block = if one_block { self.block(ijk) } else { None };
        match block {
            Some(Block::Leaf(leaf)) => std::array::from_fn(|i| {
                let i = i as i32;
                let v = ijk + IVec3::new(i & 1, i >> 1 & 1, i >> 2);
                let at = leaf + layout::LEAF_VALUES + 4 * leaf_entry(v);
                self.buffer.f32_at(at).unwrap_or(0.0)
            }),
            Some(Block::Tile(v)) => [v; 8],
            _ => std::array::from_fn(|i| {
                let i = i as i32;
                SparseVoxels::value(self, ijk + IVec3::new(i & 1, i >> 1 & 1, i >> 2))
            }),
        }
    }
}

/// Voxel `ijk`'s place among its leaf's 8³ values.
fn leaf_entry(ijk: IVec3) -> usize {
    ((ijk.x & 7) << 6 | (ijk.y & 7) << 3 | (ijk.z & 7)) as usize
}

/// `base` moved by the signed byte offset `by`, if it stays addressable.
fn offset(base: usize, by: i64) -> Option<usize> {
    usize::try_from(i64::try_from(base).ok()?.checked_add(by)?).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blob() -> Vec<u8> {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/pbrt/scenes/blob.nvdb");
        std::fs::read(path).unwrap()
    }

    #[test]
    fn the_grid_nanovdb_wrote_reads_back() {
        // Values and boxes as NanoVDB's own accessor printed them (tests/pbrt/nvdb).
        let g = read_grid(&blob(), "density").unwrap().unwrap();
        assert_eq!(
            g.index_bbox,
            (IVec3::new(-12, 0, 0), IVec3::new(13, 19, 17))
        );
        assert_eq!(g.value(IVec3::new(-6, 15, 14)), Some(0.279_112_25));
        assert_eq!(g.value(IVec3::new(-1, 7, 3)), Some(0.922_262_3));
        assert_eq!(g.value(IVec3::new(12, 23, 18)), Some(0.0));
        assert_eq!(g.value(IVec3::new(-9000, 7, 3)), Some(0.0));
        // Voxel size 0.04, origin (−0.5, 0.1, −0.3); the world box spans min to max + 1.
        let p = g.to_index * (Vec3::new(-0.5 + 0.04 * -6.0, 0.1 + 0.6, -0.3 + 0.56) - g.origin);
        assert!(
            (p - Vec3::new(-6.0, 15.0, 14.0)).abs().max_element() < 1e-4,
            "{p}"
        );
        assert!(
            (g.world_bbox.0 - DVec3::new(-0.98, 0.1, -0.3))
                .abs()
                .max_element()
                < 1e-9
        );
        assert!(
            (g.world_bbox.1 - DVec3::new(0.06, 0.9, 0.42))
                .abs()
                .max_element()
                < 1e-9
        );
        let (first, res) = g.extent().unwrap();
        assert_eq!(first, IVec3::new(-13, -1, -1));
        assert_eq!(res, [28, 22, 20]);
        assert!(read_grid(&blob(), "velocity").unwrap().is_none());
        let t = read_grid(&blob(), "mask").unwrap().unwrap();
        assert_eq!(t.value(IVec3::ZERO), Some(1000.0));
    }

    use crate::medium::grid::tests::assert_majorants_bound;
    use crate::medium::grid::{Field, GridMedium};

    #[test]
    fn tree_lookups_equal_dense_ones() {
        // The "far" grid is the density plus one voxel 620 voxels away: its box is too large
        // to copy dense, so it is looked up in the tree; over the density's box its lookups
        // are the dense grid's, bit for bit, and its block maxima bound them.
        let dense_grid = Arc::new(read_grid(&blob(), "density").unwrap().unwrap());
        let far = Arc::new(read_grid(&blob(), "far").unwrap().unwrap());
        let (first, res) = far.extent().unwrap();
        assert_eq!(res, [615, 613, 623]);
        let sparse = far.voxels_over(first, res).unwrap();
        assert!(sparse.is_sparse());
        let (d_first, d_res) = dense_grid.extent().unwrap();
        let dense = dense_grid.voxels_over(d_first, d_res).unwrap();
        assert!(!dense.is_sparse());
        let n = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
        let dn = Vec3::new(d_res[0] as f32, d_res[1] as f32, d_res[2] as f32);
        let offset = (d_first - first).as_vec3();
        let mut rng = crate::sampling::Rng::new(7, 0);
        let mut checked = 0;
        for _ in 0..20_000 {
            // A point in the dense grid's cube, at a whole-voxel offset in the far grid's.
            let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * (dn - 1.0);
            let v = v.floor() + 0.5 + Vec3::new(0.25, 0.5, 0.75);
            let a = dense.lookup(v / dn);
            let b = sparse.lookup((v + offset) / n);
            if a != b {
                // The two cubes' coordinates round differently: equal within rounding.
                assert!(
                    (a - b).abs().max_element() <= 1e-5 * a.max_element(),
                    "{v}: {a} {b}"
                );
            } else {
                checked += 1;
            }
            let cell = (v + offset) / n;
            let (_, max) = sparse.range_in(cell - 0.5 / n, cell + 0.5 / n);
            assert!(b.cmple(max).all(), "{v}: {b} above {max}");
        }
        assert!(checked > 10_000, "{checked}");
        let far_voxel = (IVec3::new(600, 610, 620) - first).as_vec3() + 0.5;
        assert_eq!(sparse.lookup(far_voxel / n), Vec3::splat(0.5));
        let whole = sparse.range_in(Vec3::ZERO, Vec3::ONE).1.x;
        assert_eq!(whole, dense.range_in(Vec3::ZERO, Vec3::ONE).1.x);
        // As a medium (index space for world space): majorants bound σt along rays through
        // the blobs and the far voxel.
        let to_unit = glam::Affine3A::from_scale(n.recip())
            * glam::Affine3A::from_translation(-first.as_vec3());
        let field = Field::grid(Vec3::new(1.0, 2.0, 0.5), 0);
        let m = GridMedium::new(to_unit, vec![Arc::new(sparse)], (field, field, field), 0.0);
        let m = m.unwrap();
        for target in [IVec3::new(0, 10, 9), IVec3::new(600, 610, 620)] {
            assert_majorants_bound(&m, target.as_vec3() + 0.5, 40.0);
        }
        // A negative voxel anywhere in the tree is refused when the grid is made.
        let mut damaged = read_grid(&blob(), "far").unwrap().unwrap();
        let Some(Block::Leaf(leaf)) = damaged.block(IVec3::new(600, 610, 620)) else {
            panic!("the far voxel is in a leaf");
        };
        let at = leaf + layout::LEAF_VALUES + 4 * 17;
        damaged.buffer[at..at + 4].copy_from_slice(&(-1.0f32).to_le_bytes());
        let err = Arc::new(damaged).voxels_over(first, res).unwrap_err();
        assert!(err.contains("voxel value -1 is negative"), "{err}");
    }

    #[test]
    fn uncompressed_files_read_as_zip_ones() {
        // The same file with its grids unpacked (codec 0, each record's file size its grid
        // size): the same voxels.
        let zip = blob();
        let mut plain = zip[..HEADER_BYTES].to_vec();
        plain[14..16].copy_from_slice(&0u16.to_le_bytes());
        let records = records(&zip).unwrap();
        let mut at = HEADER_BYTES;
        for (m, ..) in &records {
            let len = META_BYTES + zip.u32_at(at + 136).unwrap() as usize;
            let mut record = zip[at..at + len].to_vec();
            record[8..16].copy_from_slice(&m.grid_size.to_le_bytes());
            plain.extend_from_slice(&record);
            at += len;
        }
        for (m, _, data) in &records {
            plain.extend_from_slice(&unzip(&zip[data.clone()], m).unwrap());
        }
        let a = read_grid(&zip, "density").unwrap().unwrap();
        let b = read_grid(&plain, "density").unwrap().unwrap();
        let (first, res) = a.extent().unwrap();
        assert_eq!(
            a.dense_over(first, res).unwrap(),
            b.dense_over(first, res).unwrap()
        );
        assert_eq!(
            grid_names(&plain).unwrap(),
            ["mask", "density", "heat", "far"]
        );
    }

    #[test]
    fn damaged_files_are_errors() {
        let good = blob();
        let err = |b: &[u8]| read_grid(b, "density").unwrap_err();
        assert!(err(&good[..100]).contains("inside a grid record"));
        assert!(err(&good[..good.len() - 10]).contains("past the end"));
        assert!(err(b"hello world, not a grid").contains("not a NanoVDB file"));
        let mut version = good.clone();
        version[8..12].copy_from_slice(&(31u32 << 21).to_le_bytes());
        assert!(err(&version).contains("format 31.0"));
        let mut blosc = good.clone();
        blosc[14] = 2;
        assert!(err(&blosc).contains("Blosc"));
        // Every single-byte change anywhere reads or fails cleanly.
        for i in (0..good.len()).step_by(97) {
            let mut b = good.clone();
            b[i] ^= 0x5a;
            if let Ok(Some(g)) = read_grid(&b, "density") {
                let g = Arc::new(g);
                if let Ok((first, res)) = g.extent() {
                    let _ = g.dense_over(first, res);
                    if let Ok(sparse) = g.sparse_over(first, res) {
                        sparse.lookup(Vec3::splat(0.5));
                    }
                }
            }
        }
    }
}
