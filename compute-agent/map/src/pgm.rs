//! Netpbm graymaps (PGM), binary `P5` and ASCII `P2`, with `#` comments in the header:
//! the image format map_server reads and map_saver writes.

use std::path::Path;

use crate::error::MapError;
use crate::grid::check_size;

/// A decoded 8-bit grey image, row 0 at the top as in the file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GrayImage {
    /// width in pixels
    pub width: usize,
    /// height in pixels
    pub height: usize,
    /// grey values, row-major from the top row; 16-bit and other maxvals scaled to 0..=255
    pub pixels: Vec<u8>,
    /// alpha per pixel when the image had one (PNG only), else empty
    pub alpha: Vec<u8>,
}

struct Header<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl Header<'_> {
    /// Skips whitespace and `#` comments (to the end of their line).
    fn skip_space(&mut self) {
        while let Some(&b) = self.bytes.get(self.pos) {
            if b == b'#' {
                while let Some(&c) = self.bytes.get(self.pos) {
                    if c == b'\n' {
                        break;
                    }
                    self.pos += 1;
                }
            } else if b.is_ascii_whitespace() {
                if b == b'\n' {
                    self.line += 1;
                }
                self.pos += 1;
            } else {
                break;
            }
        }
    }

    fn number(&mut self, file: &Path, what: &str) -> Result<u64, MapError> {
        self.skip_space();
        let start = self.pos;
        while self.bytes.get(self.pos).is_some_and(u8::is_ascii_digit) {
            self.pos += 1;
        }
        let text = std::str::from_utf8(&self.bytes[start..self.pos]).unwrap_or("");
        text.parse::<u64>().map_err(|_| {
            let found = self.bytes.get(self.pos).map_or("end of file".to_string(), |b| format!("{:?}", *b as char));
            MapError::Pgm {
                file: file.to_path_buf(),
                line: self.line,
                message: format!("expected the {what} (a decimal number), found {found}"),
            }
        })
    }
}

/// Decodes a P5 or P2 PGM. The size is checked against [`crate::MAX_CELLS`] before the
/// pixels are allocated, and the pixel count against the header.
pub fn decode_pgm(bytes: &[u8], file: &Path) -> Result<GrayImage, MapError> {
    let pgm_err = |line: usize, message: String| MapError::Pgm { file: file.to_path_buf(), line, message };
    let binary = match bytes.get(..2) {
        Some(b"P5") => true,
        Some(b"P2") => false,
        _ => return Err(pgm_err(1, "not a graymap: the file must start with P5 (binary) or P2 (ASCII)".into())),
    };
    let mut h = Header { bytes, pos: 2, line: 1 };
    let width = h.number(file, "width")?;
    let height = h.number(file, "height")?;
    check_size(file, width, height)?;
    let maxval = h.number(file, "maxval")?;
    if maxval == 0 || maxval > 65535 {
        return Err(pgm_err(h.line, format!("maxval {maxval} must be in 1..=65535")));
    }
    let n = (width * height) as usize;
    let scale = |v: u64| -> u8 { ((v.min(maxval) * 255 + maxval / 2) / maxval) as u8 };
    // the pixels are allocated only once the file is known to hold them: a forged
    // header must not reserve MAX_CELLS bytes for a file of a few bytes
    let mut pixels = Vec::new();
    if binary {
        // exactly one whitespace byte separates maxval from the raster
        match bytes.get(h.pos) {
            Some(b) if b.is_ascii_whitespace() => h.pos += 1,
            _ => return Err(pgm_err(h.line, "expected one whitespace byte after maxval".into())),
        }
        let raster = &bytes[h.pos..];
        let per = if maxval > 255 { 2 } else { 1 };
        let found = raster.len() / per;
        if found != n {
            return Err(MapError::SizeMismatch {
                file: file.to_path_buf(),
                width,
                height,
                expected: n as u64,
                found: found as u64,
            });
        }
        pixels.reserve_exact(n);
        if per == 1 {
            if maxval == 255 {
                pixels.extend_from_slice(raster);
            } else {
                pixels.extend(raster.iter().map(|&v| scale(v as u64)));
            }
        } else {
            pixels.extend(raster.chunks_exact(2).map(|p| scale(u16::from_be_bytes([p[0], p[1]]) as u64)));
        }
    } else {
        // an ASCII value takes at least two bytes (a digit and a separator), the last one
        let room = bytes.len().saturating_sub(h.pos).div_ceil(2) as u64;
        if room < n as u64 {
            return Err(MapError::SizeMismatch {
                file: file.to_path_buf(),
                width,
                height,
                expected: n as u64,
                found: count_values(&bytes[h.pos..]),
            });
        }
        pixels.reserve_exact(n);
        for i in 0..n {
            h.skip_space();
            if h.pos >= bytes.len() {
                return Err(MapError::SizeMismatch {
                    file: file.to_path_buf(),
                    width,
                    height,
                    expected: n as u64,
                    found: i as u64,
                });
            }
            let v = h.number(file, "pixel value")?;
            if v > maxval {
                return Err(pgm_err(h.line, format!("pixel value {v} is above maxval {maxval}")));
            }
            pixels.push(scale(v));
        }
        h.skip_space();
        if h.pos < bytes.len() {
            let mut extra = 0u64;
            while h.pos < bytes.len() && h.number(file, "pixel value").is_ok() {
                extra += 1;
                h.skip_space();
            }
            return Err(MapError::SizeMismatch {
                file: file.to_path_buf(),
                width,
                height,
                expected: n as u64,
                found: n as u64 + extra.max(1),
            });
        }
    }
    Ok(GrayImage { width: width as usize, height: height as usize, pixels, alpha: Vec::new() })
}

/// The whitespace-separated words of an ASCII raster (what a truncated P2 holds).
fn count_values(raster: &[u8]) -> u64 {
    raster.split(u8::is_ascii_whitespace).filter(|w| !w.is_empty()).count() as u64
}

/// Encodes a binary P5 PGM (maxval 255) with one comment line, as map_saver does.
pub fn encode_pgm(image: &GrayImage, comment: &str) -> Vec<u8> {
    let comment = comment.replace(['\n', '\r'], " ");
    let mut out = format!("P5\n# {comment}\n{} {}\n255\n", image.width, image.height).into_bytes();
    out.extend_from_slice(&image.pixels);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(s: &str) -> &Path {
        Path::new(s)
    }

    #[test]
    fn ascii_pgm_with_comments_decodes() {
        let text = b"P2\n# a comment\n3 2 # trailing comment\n# another\n15\n0 15 7\n 15 0 15\n";
        let img = decode_pgm(text, p("a.pgm")).unwrap();
        assert_eq!((img.width, img.height), (3, 2));
        assert_eq!(img.pixels, vec![0, 255, 119, 255, 0, 255]);
    }

    #[test]
    fn binary_pgm_round_trips() {
        let img = GrayImage { width: 2, height: 2, pixels: vec![0, 205, 254, 10], alpha: vec![] };
        let bytes = encode_pgm(&img, "CREATOR: wearnav");
        assert_eq!(decode_pgm(&bytes, p("b.pgm")).unwrap(), img);
    }

    #[test]
    fn sixteen_bit_binary_pgm_scales_to_8_bit() {
        let mut bytes = b"P5 2 1 65535\n".to_vec();
        bytes.extend_from_slice(&[0xff, 0xff, 0x00, 0x00]);
        assert_eq!(decode_pgm(&bytes, p("c.pgm")).unwrap().pixels, vec![255, 0]);
    }

    #[test]
    fn truncated_and_padded_rasters_are_size_mismatches() {
        let short = b"P5\n4 4\n255\n\x00\x00\x00";
        assert!(matches!(decode_pgm(short, p("s.pgm")), Err(MapError::SizeMismatch { expected: 16, found: 3, .. })));
        let long = b"P2 2 1 255 1 2 3";
        assert!(matches!(decode_pgm(long, p("l.pgm")), Err(MapError::SizeMismatch { expected: 2, found: 3, .. })));
    }

    #[test]
    fn bad_headers_name_the_line() {
        let e = decode_pgm(b"P5\n# c\nabc 3\n255\n", p("h.pgm")).unwrap_err();
        assert!(matches!(e, MapError::Pgm { line: 3, .. }), "{e}");
        assert!(e.to_string().starts_with("h.pgm:3: malformed PGM: expected the width"), "{e}");
        assert!(matches!(decode_pgm(b"P6 1 1 255 abc", p("x.pgm")), Err(MapError::Pgm { line: 1, .. })));
        assert!(matches!(decode_pgm(b"", p("e.pgm")), Err(MapError::Pgm { .. })));
        assert!(matches!(decode_pgm(b"P5 0 0 255\n", p("z.pgm")), Err(MapError::Empty { .. })));
        assert!(matches!(decode_pgm(b"P5 100000 100000 255\n", p("big.pgm")), Err(MapError::TooLarge { .. })));
        assert!(matches!(decode_pgm(b"P2 1 1 255 300", p("v.pgm")), Err(MapError::Pgm { .. })));
    }
}
