//! Readers for recorded depth data: organized point clouds in PCL's PCD format and
//! 16-bit depth PNGs (TUM RGB-D, Redwood). Each reader has a `read(path)` that names
//! the file in its error and a `parse(bytes)` that tests feed truncated or corrupt data.

pub mod depth_png;
pub mod lzf;
pub mod pcd;

use std::path::{Path, PathBuf};

/// What is wrong with a recorded file's contents (the file is named by [`FormatError`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FormatProblem {
    /// The file could not be read at all.
    #[error("cannot read: {0}")]
    Io(String),
    /// A header line is malformed or missing a required keyword.
    #[error("bad header line {line}: {reason}")]
    BadHeader {
        /// 1-based line number in the file.
        line: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// The header ended before a required keyword appeared.
    #[error("header has no {0} line")]
    MissingHeader(&'static str),
    /// A field or pixel format this reader does not handle.
    #[error("unsupported {0}")]
    Unsupported(String),
    /// The body stops before the header's declared size.
    #[error("truncated body: {0}")]
    Truncated(String),
    /// The body does not decode.
    #[error("corrupt body: {0}")]
    Corrupt(String),
}

/// A recorded file that could not be used, naming the file and the reason.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}: {problem}", file.display())]
pub struct FormatError {
    /// The file.
    pub file: PathBuf,
    /// Why it was refused.
    pub problem: FormatProblem,
}

/// Reads a whole file, mapping I/O failure to a [`FormatError`] that names it.
fn read_bytes(path: &Path) -> Result<Vec<u8>, FormatError> {
    std::fs::read(path).map_err(|e| FormatError { file: path.to_path_buf(), problem: FormatProblem::Io(e.to_string()) })
}

/// Attaches the file name to a parse result.
fn in_file<T>(path: &Path, parsed: Result<T, FormatProblem>) -> Result<T, FormatError> {
    parsed.map_err(|problem| FormatError { file: path.to_path_buf(), problem })
}
