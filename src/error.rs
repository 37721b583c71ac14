//! The error type of the library: every failure a user can cause names the file and, where
//! there is one, the line and column.

use std::fmt;

/// A position in a text file, 1-based.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Loc {
    /// Line number, starting at 1 (0 = unknown).
    pub line: u32,
    /// Column number, starting at 1 (0 = unknown).
    pub col: u32,
}

impl fmt::Display for Loc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, self.col) {
            (0, _) => Ok(()),
            (l, 0) => write!(f, "{l}"),
            (l, c) => write!(f, "{l}:{c}"),
        }
    }
}

/// Everything that can go wrong when loading input or writing output.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be opened, read or written.
    #[error("{path}: {what}: {source}")]
    Io {
        /// The file.
        path: String,
        /// What was being done ("cannot read", "cannot write").
        what: &'static str,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// Invalid content at a known place in a file.
    #[error("{file}:{loc}: {msg}")]
    At {
        /// The file.
        file: String,
        /// Where in it.
        loc: Loc,
        /// What is wrong.
        msg: String,
    },
    /// Invalid content of a file, without a position.
    #[error("{file}: {msg}")]
    File {
        /// The file.
        file: String,
        /// What is wrong.
        msg: String,
    },
    /// Invalid options or arguments.
    #[error("{0}")]
    Usage(String),
}

/// Result alias for the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;
