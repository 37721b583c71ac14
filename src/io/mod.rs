//! Input and output: scene files to descriptions, images to and from disk.

pub mod atomic;
pub mod collada;
pub mod desc;
pub mod gltf;
pub mod image;
pub mod image_file;
pub mod mitsuba;
pub mod nvdb;
pub mod obj;
pub mod pbrt;
pub mod ply;
pub mod sheet;
pub mod tev;
pub mod vol;

use crate::error::{Error, Result};
use std::path::Path;

/// A scene file read whole: its path as given (for messages), its bytes, and its stem (the
/// scene's name; `fallback` when it has none).
pub(crate) fn read_scene_file(path: &Path, fallback: &str) -> Result<(String, Vec<u8>, String)> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: file.clone(),
        what: "cannot read scene file",
        source,
    })?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| fallback.into());
    Ok((file, bytes, name))
}

/// Where a file that a scene file in `dir` names by `named` is, when it is not at that path
/// relative to `dir` but `named` is a path from some other folder tree (`/` or `\\`
/// separated): the file of its bare name in `dir`, as Blender and tinyobjloader find it.
/// `None` when the named path exists, names no folder, or no such file is beside it.
pub(crate) fn found_beside(dir: &Path, named: &str) -> Option<std::path::PathBuf> {
    let bare = named.rsplit(['/', '\\']).next().unwrap_or(named);
    if bare.is_empty() || bare == named || dir.join(named).exists() {
        return None;
    }
    let beside = dir.join(bare);
    beside.is_file().then_some(beside)
}

/// Loads a scene file of any supported format, chosen by its extension: `.dae` (COLLADA with
/// CS184's CGL extensions), `.obj` (with its `.mtl`), `.ply` (or gzip-compressed `.ply.gz`),
/// `.gltf`/`.glb`, `.pbrt` (pbrt-v4), `.xml` (Mitsuba 3, or COLLADA by its root element).
pub fn load_scene(path: &Path) -> Result<desc::SceneDesc> {
    load_scene_with(path, &[])
}

/// [`load_scene`] with a Mitsuba scene's parameters `defines` (`-D name=value`, over the
/// file's `<default>`s); other formats ignore them.
pub fn load_scene_with(path: &Path, defines: &[(String, String)]) -> Result<desc::SceneDesc> {
    let lower = path.to_string_lossy().to_ascii_lowercase();
    let ext = if lower.ends_with(".ply.gz") {
        "ply".to_string()
    } else {
        path.extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default()
    };
    use desc::Format;
    let (desc, format) = match ext.as_str() {
        "xml" if sniff_mitsuba(path) => (mitsuba::load_file(path, defines), Format::Mitsuba),
        "dae" | "xml" => (collada::load_file(path), Format::Collada),
        "obj" => (obj::load_file(path), Format::Obj),
        "ply" => (ply::load_file(path), Format::Ply),
        "gltf" | "glb" => (gltf::load_file(path), Format::Gltf),
        "pbrt" => (pbrt::load_file(path), Format::Pbrt),
        _ => return Err(Error::File {
            file: path.display().to_string(),
            msg: "unknown scene format (use .dae, .obj, .ply, .ply.gz, .gltf, .glb, .pbrt or .xml)"
                .into(),
        }),
    };
    let mut desc = desc?;
    desc.format = format;
    desc.sources.insert(0, path.to_path_buf());
    Ok(desc)
}

/// Whether the `.xml` file at `path` is a Mitsuba scene (its root is `<scene>`), not COLLADA.
fn sniff_mitsuba(path: &Path) -> bool {
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(4096).read_to_end(&mut head))
        .is_ok_and(|_| mitsuba::is_mitsuba(&head))
}
