//! Crash-safe file writing: every file the program writes goes to a temporary file beside its
//! destination (`.NAME.PID.tmp`), is flushed to disk and then renamed over the destination.
//! A process killed at any moment (SIGKILL, power loss) leaves either the previous file or
//! the complete new one at the destination, never a truncated one; at worst a temporary file
//! remains beside it.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// The temporary name beside `path`.
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes `path` through `fill`, crash-safe. `what` is the error's wording ("cannot write
/// image"); errors name `path`, and no partial file is left at `path` or beside it.
pub fn write(
    path: &Path,
    what: &'static str,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<()> {
    let tmp = temp_path(path);
    let err = |source: std::io::Error| Error::Io {
        path: path.display().to_string(),
        what,
        source,
    };
    let result = (|| {
        // A new file (never one a link points to); a stale one of a killed run is replaced.
        let open = || File::options().write(true).create_new(true).open(&tmp);
        let file = match open() {
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                std::fs::remove_file(&tmp)?;
                open()?
            }
            r => r?,
        };
        let mut w = BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(e));
    }
    // Make the rename itself durable (best effort: not every file system allows it).
    if let Some(dir) = path.parent() {
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

/// Checks, before any work, that a file can be created in the directory of `path`: the
/// directory exists and is writable. The error names the directory.
pub fn check_writable(path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let err = |source: std::io::Error| Error::Io {
        path: dir.display().to_string(),
        what: "cannot write output there",
        source,
    };
    if !dir.is_dir() {
        return Err(err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "no such directory",
        )));
    }
    if path.is_dir() {
        return Err(Error::Io {
            path: path.display().to_string(),
            what: "cannot write output there",
            source: std::io::Error::other("it is a directory"),
        });
    }
    let probe = temp_path(path);
    File::create(&probe).map_err(err)?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn replaces_whole_files_and_cleans_up_on_failure() {
        let dir = std::env::temp_dir().join(format!("pt-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.txt");
        write(&p, "cannot write", |w| w.write_all(b"first")).unwrap();
        write(&p, "cannot write", |w| w.write_all(b"second")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        let e = write(&p, "cannot write", |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("disk full"))
        })
        .unwrap_err();
        assert!(
            e.to_string().contains("a.txt: cannot write: disk full"),
            "{e}"
        );
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        assert!(check_writable(&p).is_ok());
        let e = check_writable(&dir.join("missing").join("x.png")).unwrap_err();
        assert!(
            e.to_string().contains("missing: cannot write output there"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
