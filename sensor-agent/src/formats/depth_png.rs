//! 16-bit grayscale depth PNGs (TUM RGB-D: 5000 units per metre; Redwood: millimetres),
//! 0 = invalid. The scale is not in the file: the replay source is told it.

use std::path::Path;

use schemas::depth_codec::MAX_PIXELS;

use super::{in_file, read_bytes, FormatError, FormatProblem};

/// A depth image as stored: raw samples in the file's own units.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DepthPng {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Row-major samples, 0 = invalid.
    pub samples: Vec<u16>,
}

/// Reads a 16-bit grayscale PNG file.
pub fn read(path: &Path) -> Result<DepthPng, FormatError> {
    let bytes = read_bytes(path)?;
    in_file(path, parse(&bytes))
}

/// Parses a 16-bit grayscale PNG from memory.
pub fn parse(bytes: &[u8]) -> Result<DepthPng, FormatProblem> {
    let mut decoder = png::Decoder::new(bytes);
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder.read_info().map_err(|e| problem(&e))?;
    let (color, depth) = reader.output_color_type();
    if color != png::ColorType::Grayscale || depth != png::BitDepth::Sixteen {
        return Err(FormatProblem::Unsupported(format!(
            "PNG pixel format {color:?} {depth:?} (depth images are 16-bit grayscale)"
        )));
    }
    // The IHDR's size is the sender's word: refuse what no depth camera makes before
    // sizing the buffer for it (a forged 65536 x 65536 would reserve 8 GB).
    let (width, height) = reader.info().size();
    if width as u64 * height as u64 > MAX_PIXELS as u64 {
        return Err(FormatProblem::Unsupported(format!(
            "PNG of {width}x{height} pixels (a depth image has at most {MAX_PIXELS})"
        )));
    }
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(|e| problem(&e))?;
    let samples = buf[..info.buffer_size()].chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])).collect();
    Ok(DepthPng { width: info.width, height: info.height, samples })
}

fn problem(e: &png::DecodingError) -> FormatProblem {
    match e {
        png::DecodingError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            FormatProblem::Truncated(format!("PNG ends early ({io})"))
        }
        png::DecodingError::LimitsExceeded => FormatProblem::Unsupported("PNG larger than the decoder limits".into()),
        other => FormatProblem::Corrupt(format!("PNG: {other}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_data::real_capture_bytes;

    fn encode_png(width: u32, height: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(color);
        enc.set_depth(depth);
        enc.write_header().unwrap().write_image_data(data).unwrap();
        out
    }

    #[test]
    fn samples_are_big_endian_in_the_file() {
        let bytes = encode_png(2, 1, png::ColorType::Grayscale, png::BitDepth::Sixteen, &[0x13, 0x88, 0, 0]);
        let img = parse(&bytes).unwrap();
        assert_eq!((img.width, img.height, img.samples), (2, 1, vec![5000, 0]));
    }

    #[test]
    fn eight_bit_png_is_unsupported() {
        let bytes = encode_png(2, 1, png::ColorType::Grayscale, png::BitDepth::Eight, &[1, 2]);
        assert!(matches!(parse(&bytes), Err(FormatProblem::Unsupported(_))));
    }

    #[test]
    fn tum_frame_is_80_8_percent_valid_within_1_46_to_9_33_m() {
        let bytes = real_capture_bytes("tum_depth_640x480_u16_5000perm.png");
        let img = parse(&bytes).unwrap();
        assert_eq!((img.width, img.height), (640, 480));
        let valid: Vec<u16> = img.samples.iter().copied().filter(|&s| s > 0).collect();
        let frac = valid.len() as f64 / img.samples.len() as f64;
        assert!((frac - 0.808).abs() < 0.001, "{frac}");
        let lo = *valid.iter().min().unwrap() as f64 / 5000.0;
        let hi = *valid.iter().max().unwrap() as f64 / 5000.0;
        assert!((lo - 1.46).abs() < 0.01 && (hi - 9.33).abs() < 0.01, "{lo}..{hi}");
    }

    #[test]
    fn redwood_frame_is_87_percent_valid_within_955_to_2702_mm() {
        let bytes = real_capture_bytes("redwood_00000_depth_640x480_u16_mm.png");
        let img = parse(&bytes).unwrap();
        let valid: Vec<u16> = img.samples.iter().copied().filter(|&s| s > 0).collect();
        let frac = valid.len() as f64 / img.samples.len() as f64;
        assert!((frac - 0.870).abs() < 0.001, "{frac}");
        assert_eq!((*valid.iter().min().unwrap(), *valid.iter().max().unwrap()), (955, 2702));
    }

    /// Valid pixels and their range of a depth PNG in `tests/data/real/`.
    fn valid_range(name: &str) -> (usize, u16, u16) {
        let img = parse(&real_capture_bytes(name)).unwrap();
        assert_eq!((img.width, img.height), (640, 480));
        let valid: Vec<u16> = img.samples.into_iter().filter(|&s| s > 0).collect();
        (valid.len(), *valid.iter().min().unwrap(), *valid.iter().max().unwrap())
    }

    #[test]
    fn openni_desk_frame_is_271575_valid_within_671_to_1713_mm() {
        // the counts of the PCL grabber's PCD it was derived from
        assert_eq!(valid_range("desk_openni_depth_640x480_u16_mm.png"), (271_575, 671, 1713));
    }

    #[test]
    fn table_scene_frame_is_209280_valid_within_0_69_to_2_59_m() {
        assert_eq!(valid_range("table_scene_depth_640x480_u16_100um.png"), (209_280, 6900, 25_927));
    }

    #[test]
    fn truncated_and_corrupt_pngs_are_refused() {
        let bytes = real_capture_bytes("redwood_00000_depth_640x480_u16_mm.png");
        for cut in [bytes.len() - 20, bytes.len() / 2, 40, 8, 0] {
            assert!(parse(&bytes[..cut]).is_err(), "cut at {cut} accepted");
        }
        let mut corrupt = bytes.clone();
        for i in (100..corrupt.len()).step_by(501) {
            corrupt[i] ^= 0xa5;
        }
        assert!(parse(&corrupt).is_err(), "CRC mismatch must be refused");
    }

    #[test]
    fn read_names_the_file() {
        let dir = tempfile::Builder::new().prefix("wearnav-png-").tempdir().unwrap();
        let path = dir.path().join("broken.png");
        std::fs::write(&path, b"\x89PNG\r\n\x1a\nnope").unwrap();
        let err = read(&path).unwrap_err();
        assert_eq!(err.file, path);
        assert!(err.to_string().contains("broken.png: "), "{err}");
    }
}
