//! The real captures the unit tests read, kept in the repository (`tests/data/real/` at
//! the workspace root; its README says where each came from). They are part of the
//! checkout, so a missing one is a failure, never a skip.

use std::path::PathBuf;

/// Path of `name` in `tests/data/real/`; panics, naming the path, if it is not there.
pub(crate) fn real_capture(name: &str) -> PathBuf {
    let path = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/real")).join(name);
    assert!(path.is_file(), "{} is missing from the checkout (see tests/data/README.md)", path.display());
    path
}

/// The bytes of `name` in `tests/data/real/`.
pub(crate) fn real_capture_bytes(name: &str) -> Vec<u8> {
    let path = real_capture(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
