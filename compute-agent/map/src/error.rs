//! Why a map, an image or a semantic file was refused.

use std::path::PathBuf;

/// Every way loading or writing a map can fail. Each names the file (and the line where
/// the parser has one) and says what to fix; none is a panic.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// The file could not be read or written.
    #[error("{file}: {action}: {source}")]
    Io {
        /// the file
        file: PathBuf,
        /// "cannot read", "cannot write", ...
        action: &'static str,
        /// the OS error
        source: std::io::Error,
    },
    /// A file is larger than we are willing to read.
    #[error("{file}: {bytes} bytes is more than the {limit}-byte limit for a map file")]
    FileTooLarge {
        /// the file
        file: PathBuf,
        /// its size
        bytes: u64,
        /// the limit
        limit: u64,
    },
    /// The map YAML is not YAML, or misses / mistypes a field.
    #[error("{file}:{line}: malformed map YAML: {message}")]
    Yaml {
        /// the YAML file
        file: PathBuf,
        /// 1-based line (0 when the parser gave none)
        line: usize,
        /// the parser's reason
        message: String,
    },
    /// A field of the map YAML has a value map_server would not accept.
    #[error("{file}: {field}: {message}")]
    BadField {
        /// the YAML file
        file: PathBuf,
        /// the field (`resolution`, `origin`, `mode`, ...)
        field: &'static str,
        /// what is wrong and what is allowed
        message: String,
    },
    /// Occupancy thresholds outside [0, 1] or not `free_thresh < occupied_thresh`.
    #[error("{file}: thresholds out of order: need 0 <= free_thresh ({free}) < occupied_thresh ({occupied}) <= 1")]
    Thresholds {
        /// the YAML file
        file: PathBuf,
        /// free_thresh
        free: f64,
        /// occupied_thresh
        occupied: f64,
    },
    /// Resolution not a number, <= 0 or above 10 m per cell.
    #[error("{file}: resolution {value} m/cell is absurd: it must be a number in (0, 10]")]
    Resolution {
        /// the YAML file (or `<memory>`)
        file: PathBuf,
        /// the value found
        value: f64,
    },
    /// The image extension is neither `.pgm` nor `.png`.
    #[error("{file}: unknown image format '{extension}': map images must be .pgm or .png")]
    UnknownImageFormat {
        /// the image file
        file: PathBuf,
        /// its extension
        extension: String,
    },
    /// The PGM header or pixel data is malformed.
    #[error("{file}:{line}: malformed PGM: {message}")]
    Pgm {
        /// the image file
        file: PathBuf,
        /// 1-based line of the header where it went wrong (the last header line for pixel data)
        line: usize,
        /// what is wrong
        message: String,
    },
    /// The PNG decoder refused the image.
    #[error("{file}: malformed PNG: {message}")]
    Png {
        /// the image file
        file: PathBuf,
        /// the decoder's reason
        message: String,
    },
    /// A 0 x 0 (or 0 x N) map.
    #[error("{file}: empty map ({width} x {height} cells)")]
    Empty {
        /// the file
        file: PathBuf,
        /// width in cells
        width: u64,
        /// height in cells
        height: u64,
    },
    /// More cells than [`crate::MAX_CELLS`]: refused before allocating them.
    #[error("{file}: {width} x {height} cells is more than the limit of {limit} cells")]
    TooLarge {
        /// the file
        file: PathBuf,
        /// width in cells
        width: u64,
        /// height in cells
        height: u64,
        /// the limit
        limit: u64,
    },
    /// The pixel data does not match the size in the header (or a grid's cells its size).
    #[error("{file}: size mismatch: the header says {width} x {height} = {expected} values, found {found}")]
    SizeMismatch {
        /// the file
        file: PathBuf,
        /// width from the header
        width: u64,
        /// height from the header
        height: u64,
        /// width * height
        expected: u64,
        /// values actually present
        found: u64,
    },
    /// The semantic layer TOML is malformed or inconsistent.
    #[error("{file}:{line}: malformed semantic layer: {message}")]
    Semantic {
        /// the semantic file
        file: PathBuf,
        /// 1-based line (0 when not tied to one line)
        line: usize,
        /// what is wrong
        message: String,
    },
    /// A DXF drawing is malformed (the line where it went wrong), or makes no floor
    /// map: no walls, no units, an extent no building has (line 0 unless one line says it).
    #[error("{file}{}: {message}", at_line(*.line))]
    Dxf {
        /// the DXF file
        file: PathBuf,
        /// 1-based line (0 when not tied to one line)
        line: usize,
        /// what is wrong and what to do
        message: String,
    },
    /// The building manifest is malformed or inconsistent.
    #[error("{file}:{line}: malformed building manifest: {message}")]
    Building {
        /// the manifest file
        file: PathBuf,
        /// 1-based line (0 when not tied to one line)
        line: usize,
        /// what is wrong
        message: String,
    },
}

/// `:line` after a file name, nothing for line 0 (not tied to a line).
fn at_line(line: usize) -> String {
    if line == 0 {
        String::new()
    } else {
        format!(":{line}")
    }
}

/// 1-based line of a byte offset in `text`.
pub(crate) fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
}
