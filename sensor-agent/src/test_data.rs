//! The real captures the unit tests read, kept in the repository (`tests/data/real/` at
//! the workspace root; its README says where each came from). They are part of the
//! checkout, so a missing one is a failure, never a skip. And a stand-in camera for the
//! tests of what wraps a frame source.

use std::path::PathBuf;

use crate::source::{FrameSource, SourceError, SourceFrame};

/// Frames 33 ms apart, one pixel of depth alone (a camera like the Xtion: no IMU, no
/// gravity, no pressure); frame `k` (from 1) captured at `k` times 33,333,333 ns.
pub(crate) struct Camera(pub(crate) u64);

impl FrameSource for Camera {
    fn describe(&self) -> String {
        "openni2:test".into()
    }

    fn next_frame(&mut self, _now_ns: u64) -> Result<Option<SourceFrame>, SourceError> {
        self.0 += 1;
        let k = schemas::Intrinsics { fx: 1.0, fy: 1.0, cx: 0.0, cy: 0.0 };
        Ok(Some(SourceFrame::depth_only(self.0 * 33_333_333, (1, 1), 0.001, k, vec![1000])))
    }

    fn period_ns(&self) -> u64 {
        33_333_333
    }
}

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
