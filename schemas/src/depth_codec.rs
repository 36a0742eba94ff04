//! Depth image packing for [`DepthFrame`](crate::DepthFrame): raw, lossless, or
//! bounded-error. Each frame decodes on its own (no inter-frame state), so a lost
//! packet costs one frame, never a stream.

use thiserror::Error;

use crate::messages::DepthEncoding;

/// Why a depth payload could not be packed or unpacked.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum CodecError {
    /// Sample count does not match width x height.
    #[error("{got} samples for a {width}x{height} image (expected {expected})")]
    SizeMismatch {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// width * height.
        expected: usize,
        /// Samples given or decoded.
        got: usize,
    },
    /// Compressed bytes that do not decode.
    #[error("corrupt depth payload: {0}")]
    Corrupt(String),
    /// A zero quantisation step.
    #[error("bounded encoding needs a step of at least 1 depth unit")]
    ZeroStep,
}

fn expected_len(width: u32, height: u32) -> usize {
    width as usize * height as usize
}

/// Pack `samples` (row-major, 0 = invalid) into `out` (cleared first).
pub fn encode(
    samples: &[u16],
    width: u32,
    height: u32,
    mode: DepthEncoding,
    out: &mut Vec<u8>,
) -> Result<(), CodecError> {
    let expected = expected_len(width, height);
    if samples.len() != expected {
        return Err(CodecError::SizeMismatch { width, height, expected, got: samples.len() });
    }
    out.clear();
    match mode {
        DepthEncoding::Raw => {
            out.reserve(expected * 2);
            for s in samples {
                out.extend_from_slice(&s.to_le_bytes());
            }
        }
        DepthEncoding::Lossless => {
            let raw: Vec<u8> = samples.iter().flat_map(|s| s.to_le_bytes()).collect();
            *out = zstd::bulk::compress(&raw, 1).map_err(|e| CodecError::Corrupt(e.to_string()))?;
        }
        DepthEncoding::Bounded { step } => {
            if step == 0 {
                return Err(CodecError::ZeroStep);
            }
            let half = step / 2;
            let raw: Vec<u8> = samples
                .iter()
                .flat_map(|&s| {
                    let q = if s == 0 { 0 } else { ((s as u32 + half as u32) / step as u32).max(1) as u16 };
                    q.to_le_bytes()
                })
                .collect();
            *out = zstd::bulk::compress(&raw, 1).map_err(|e| CodecError::Corrupt(e.to_string()))?;
        }
    }
    Ok(())
}

/// Unpack a payload into `out` (resized to width x height).
pub fn decode(
    data: &[u8],
    width: u32,
    height: u32,
    mode: DepthEncoding,
    out: &mut Vec<u16>,
) -> Result<(), CodecError> {
    let expected = expected_len(width, height);
    let bytes = match mode {
        DepthEncoding::Raw => data.to_vec(),
        DepthEncoding::Lossless | DepthEncoding::Bounded { .. } => {
            zstd::bulk::decompress(data, expected * 2).map_err(|e| CodecError::Corrupt(e.to_string()))?
        }
    };
    if bytes.len() != expected * 2 {
        return Err(CodecError::SizeMismatch { width, height, expected, got: bytes.len() / 2 });
    }
    out.clear();
    out.extend(bytes.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]])));
    if let DepthEncoding::Bounded { step } = mode {
        if step == 0 {
            return Err(CodecError::ZeroStep);
        }
        for s in out.iter_mut() {
            *s = s.saturating_mul(step);
        }
    }
    Ok(())
}
