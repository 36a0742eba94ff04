//! LZF decompression (Marc Lehmann's liblzf format), as used by PCL's
//! `binary_compressed` PCD bodies. Written from the format description:
//!
//! - control byte `c < 32`: a literal run of `c + 1` bytes follows;
//! - otherwise a back-reference: length `c >> 5` (7 means "add the next byte"), plus 2;
//!   offset `((c & 0x1f) << 8 | next byte) + 1` bytes back in the output. The copy may
//!   overlap its own output (run-length style), so it goes byte by byte.

/// Why an LZF stream does not decode.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LzfError {
    /// The input ends inside a literal run or a back-reference.
    #[error("LZF stream ends inside an instruction at byte {0}")]
    InputEnds(usize),
    /// A back-reference points before the start of the output.
    #[error("LZF back-reference at byte {at} reaches {offset} bytes back with only {written} written")]
    BadReference {
        /// Input position of the instruction.
        at: usize,
        /// Distance back.
        offset: usize,
        /// Output bytes so far.
        written: usize,
    },
    /// The stream produces more bytes than announced.
    #[error("LZF stream exceeds the announced {0} bytes")]
    Overflow(usize),
    /// The stream produces fewer bytes than announced.
    #[error("LZF stream yields {got} bytes, {expected} announced")]
    Underflow {
        /// Bytes produced.
        got: usize,
        /// Bytes announced.
        expected: usize,
    },
}

/// Decompresses `input` into `out` (cleared first), which must end up exactly
/// `expected_len` bytes long.
pub fn decompress(input: &[u8], expected_len: usize, out: &mut Vec<u8>) -> Result<(), LzfError> {
    out.clear();
    out.reserve(expected_len);
    let mut i = 0;
    while i < input.len() {
        let at = i;
        let ctrl = input[i] as usize;
        i += 1;
        if ctrl < 32 {
            let run = ctrl + 1;
            let literal = input.get(i..i + run).ok_or(LzfError::InputEnds(at))?;
            if out.len() + run > expected_len {
                return Err(LzfError::Overflow(expected_len));
            }
            out.extend_from_slice(literal);
            i += run;
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                len += *input.get(i).ok_or(LzfError::InputEnds(at))? as usize;
                i += 1;
            }
            len += 2;
            let low = *input.get(i).ok_or(LzfError::InputEnds(at))? as usize;
            i += 1;
            let offset = (((ctrl & 0x1f) << 8) | low) + 1;
            let written = out.len();
            if offset > written {
                return Err(LzfError::BadReference { at, offset, written });
            }
            if written + len > expected_len {
                return Err(LzfError::Overflow(expected_len));
            }
            let start = written - offset;
            if offset >= len {
                out.extend_from_within(start..start + len);
            } else {
                for k in 0..len {
                    let b = out[start + k];
                    out.push(b);
                }
            }
        }
    }
    if out.len() != expected_len {
        return Err(LzfError::Underflow { got: out.len(), expected: expected_len });
    }
    Ok(())
}

/// Largest output one input byte of a valid LZF stream can yield: a three-byte
/// back-reference copies at most 264 bytes. Used to refuse absurd announced sizes
/// before allocating.
pub const MAX_EXPANSION: usize = 88;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literal_run_is_copied() {
        let mut out = Vec::new();
        decompress(&[2, b'a', b'b', b'c'], 3, &mut out).unwrap();
        assert_eq!(out, b"abc");
    }

    #[test]
    fn overlapping_reference_repeats_last_byte() {
        // literal "x", then length 3+2 = 5 copying from 1 back: "xxxxxx".
        let mut out = Vec::new();
        decompress(&[0, b'x', 3 << 5, 0], 6, &mut out).unwrap();
        assert_eq!(out, b"xxxxxx");
    }

    #[test]
    fn long_reference_uses_extra_length_byte() {
        // literal "ab", then length 7 + 10 + 2 = 19 from 2 back.
        let mut out = Vec::new();
        decompress(&[1, b'a', b'b', 7 << 5, 10, 1], 21, &mut out).unwrap();
        assert_eq!(out.len(), 21);
        assert!(out.chunks(2).all(|c| c[0] == b'a' && c.get(1).is_none_or(|&b| b == b'b')));
    }

    #[test]
    fn reference_before_start_is_refused() {
        let mut out = Vec::new();
        let err = decompress(&[0, b'x', 1 << 5, 5], 4, &mut out).unwrap_err();
        assert_eq!(err, LzfError::BadReference { at: 2, offset: 6, written: 1 });
    }

    #[test]
    fn truncated_literal_is_refused() {
        let mut out = Vec::new();
        assert_eq!(decompress(&[5, b'a'], 6, &mut out), Err(LzfError::InputEnds(0)));
    }

    #[test]
    fn output_past_announced_size_is_refused() {
        let mut out = Vec::new();
        assert_eq!(decompress(&[2, 1, 2, 3], 2, &mut out), Err(LzfError::Overflow(2)));
    }

    #[test]
    fn short_output_is_refused() {
        let mut out = Vec::new();
        assert_eq!(decompress(&[0, 1], 2, &mut out), Err(LzfError::Underflow { got: 1, expected: 2 }));
    }
}
