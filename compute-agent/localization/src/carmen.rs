//! A reader for CARMEN logs (the robotics datasets of Freiburg/Intel/MIT: laser scans
//! with the robot's pose). Only `FLASER` and `ODOM` lines are read; comments (`#`) and
//! other messages (`PARAM`, `NEFF`, `RLASER`, ...) are skipped and counted.
//!
//! ```text
//! FLASER n r1 .. rn x y theta odom_x odom_y odom_theta timestamp hostname logger_timestamp
//! ODOM x y theta tv rv accel timestamp hostname logger_timestamp
//! ```
//!
//! The `n` beams of an `FLASER` span 180 degrees, first beam to the right (-90 deg).
//! A gzip file (magic bytes 1f 8b) is decompressed on the fly. Everything is bounded:
//! the decompressed size, a line's length, the beams per scan, the number of records.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use crate::pose::Pose2;

/// Refuse logs that decompress to more than this (256 MiB; the Intel log is 6 MiB).
pub const MAX_LOG_BYTES: u64 = 256 * 1024 * 1024;
/// Refuse lines longer than this (a 1080-beam scan is ~10 KiB).
pub const MAX_LINE_BYTES: usize = 64 * 1024;
/// Refuse scans with more beams than this.
pub const MAX_BEAMS: usize = 4096;
/// Refuse logs with more records than this.
pub const MAX_RECORDS: usize = 2_000_000;

/// A laser scan with the pose it was taken at.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserRecord {
    /// ranges, metres, first beam to the right
    pub ranges_m: Vec<f64>,
    /// the laser's pose (in a corrected log: the scan-matched reference)
    pub pose: Pose2,
    /// the robot's odometry pose at the scan
    pub odom: Pose2,
    /// the robot's timestamp, seconds
    pub timestamp_s: f64,
}

impl LaserRecord {
    /// The beam angle of beam `i` (180 degrees spread over the beams, first to the right).
    pub fn beam_angle_rad(&self, i: usize) -> f64 {
        let n = self.ranges_m.len();
        if n <= 1 {
            return 0.0;
        }
        -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * i as f64 / (n - 1) as f64
    }
}

/// An odometry reading.
#[derive(Clone, Debug, PartialEq)]
pub struct OdomRecord {
    /// odometry pose
    pub pose: Pose2,
    /// translational velocity, m/s
    pub tv_m_s: f64,
    /// rotational velocity, rad/s
    pub rv_rad_s: f64,
    /// the robot's timestamp, seconds
    pub timestamp_s: f64,
}

/// One record of a log.
#[derive(Clone, Debug, PartialEq)]
pub enum Record {
    /// `FLASER`
    Laser(LaserRecord),
    /// `ODOM`
    Odom(OdomRecord),
}

/// A whole log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CarmenLog {
    /// the records in file order
    pub records: Vec<Record>,
    /// lines skipped (comments, other messages, blank lines)
    pub skipped_lines: usize,
}

impl CarmenLog {
    /// The laser records only.
    pub fn lasers(&self) -> impl Iterator<Item = &LaserRecord> {
        self.records.iter().filter_map(|r| match r {
            Record::Laser(l) => Some(l),
            _ => None,
        })
    }
}

/// What is wrong with a log, and where.
#[derive(Debug, thiserror::Error)]
pub enum CarmenError {
    /// the file could not be opened or read
    #[error("{file}: cannot read: {source}")]
    Io {
        /// the file
        file: PathBuf,
        /// the cause
        source: std::io::Error,
    },
    /// a line that does not parse
    #[error("{file}:{line}: {message}")]
    Parse {
        /// the file
        file: PathBuf,
        /// 1-based line number
        line: usize,
        /// what is wrong
        message: String,
    },
    /// a limit was exceeded
    #[error("{file}: {message}")]
    TooLarge {
        /// the file
        file: PathBuf,
        /// which limit
        message: String,
    },
}

/// Reads a CARMEN log, plain or gzip.
pub fn read_log(path: &Path) -> Result<CarmenLog, CarmenError> {
    let io = |source| CarmenError::Io { file: path.to_path_buf(), source };
    let mut file = File::open(path).map_err(io)?;
    let mut magic = [0u8; 2];
    let got = file.read(&mut magic).map_err(io)?;
    drop(file);
    let file = File::open(path).map_err(io)?;
    let reader: Box<dyn Read> = if got == 2 && magic == [0x1f, 0x8b] {
        Box::new(flate2::read::MultiGzDecoder::new(file))
    } else {
        Box::new(file)
    };
    parse_log(reader, path)
}

/// Parses a CARMEN log from any reader; `file` names it in errors.
pub fn parse_log(reader: impl Read, file: &Path) -> Result<CarmenLog, CarmenError> {
    let too_large = |message: String| CarmenError::TooLarge { file: file.to_path_buf(), message };
    // one byte over the limit tells "too large" from "exactly at the limit"
    let mut reader = BufReader::new(reader.take(MAX_LOG_BYTES + 1));
    let mut log = CarmenLog::default();
    let mut buf = Vec::new();
    let mut total = 0u64;
    let mut line_no = 0usize;
    loop {
        buf.clear();
        // bounded line read: never buffers more than MAX_LINE_BYTES + 1 of one line
        let n = (&mut reader)
            .take(MAX_LINE_BYTES as u64 + 1)
            .read_until(b'\n', &mut buf)
            .map_err(|source| CarmenError::Io { file: file.to_path_buf(), source })?;
        if n == 0 {
            break;
        }
        line_no += 1;
        total += n as u64;
        if total > MAX_LOG_BYTES {
            return Err(too_large(format!("more than {MAX_LOG_BYTES} bytes (decompressed)")));
        }
        if buf.len() > MAX_LINE_BYTES && buf.last() != Some(&b'\n') {
            return Err(too_large(format!("line {line_no} is longer than {MAX_LINE_BYTES} bytes")));
        }
        let err = |message: String| CarmenError::Parse { file: file.to_path_buf(), line: line_no, message };
        let text = std::str::from_utf8(&buf).map_err(|_| err("not UTF-8 text".into()))?;
        let mut fields = text.split_ascii_whitespace();
        let record = match fields.next() {
            Some("FLASER") => Record::Laser(parse_flaser(fields).map_err(err)?),
            Some("ODOM") => Record::Odom(parse_odom(fields).map_err(err)?),
            _ => {
                log.skipped_lines += 1;
                continue;
            }
        };
        if log.records.len() >= MAX_RECORDS {
            return Err(too_large(format!("more than {MAX_RECORDS} records")));
        }
        log.records.push(record);
    }
    Ok(log)
}

fn number<'a>(fields: &mut impl Iterator<Item = &'a str>, what: &str) -> Result<f64, String> {
    let s = fields.next().ok_or_else(|| format!("missing {what}"))?;
    let v: f64 = s.parse().map_err(|_| format!("{what} is not a number: '{s}'"))?;
    if !v.is_finite() {
        return Err(format!("{what} is not finite: '{s}'"));
    }
    Ok(v)
}

fn parse_flaser<'a>(mut f: impl Iterator<Item = &'a str>) -> Result<LaserRecord, String> {
    let count = f.next().ok_or("FLASER without a beam count")?;
    let n: usize = count.parse().map_err(|_| format!("beam count is not a whole number: '{count}'"))?;
    if n > MAX_BEAMS {
        return Err(format!("{n} beams, more than {MAX_BEAMS}"));
    }
    let mut ranges_m = Vec::with_capacity(n);
    for i in 0..n {
        let r = number(&mut f, &format!("range {} of {n}", i + 1))?;
        if r < 0.0 {
            return Err(format!("range {} is negative: {r}", i + 1));
        }
        ranges_m.push(r);
    }
    let pose = Pose2::new(number(&mut f, "x")?, number(&mut f, "y")?, number(&mut f, "theta")?);
    let odom = Pose2::new(number(&mut f, "odom_x")?, number(&mut f, "odom_y")?, number(&mut f, "odom_theta")?);
    let timestamp_s = number(&mut f, "timestamp")?;
    Ok(LaserRecord { ranges_m, pose, odom, timestamp_s })
}

fn parse_odom<'a>(mut f: impl Iterator<Item = &'a str>) -> Result<OdomRecord, String> {
    let pose = Pose2::new(number(&mut f, "x")?, number(&mut f, "y")?, number(&mut f, "theta")?);
    let tv_m_s = number(&mut f, "tv")?;
    let rv_rad_s = number(&mut f, "rv")?;
    let _accel = number(&mut f, "accel")?;
    let timestamp_s = number(&mut f, "timestamp")?;
    Ok(OdomRecord { pose, tv_m_s, rv_rad_s, timestamp_s })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<CarmenLog, CarmenError> {
        parse_log(text.as_bytes(), Path::new("test.log"))
    }

    #[test]
    fn reads_flaser_and_odom_and_skips_the_rest() {
        let log = parse(
            "# comment\nPARAM robot_frontlaser_offset 0.0 nohost 0\n\
             ODOM 1 2 0.5 0.1 0.2 0 10.5 pippo 10.5\n\
             FLASER 3 1.0 2.0 3.0 0.5 -0.5 0.1 0.5 -0.5 0.1 11.0 pippo 11.0\nNEFF 15\n",
        )
        .expect("parses");
        assert_eq!(log.records.len(), 2);
        assert_eq!(log.skipped_lines, 3);
        let l = log.lasers().next().expect("a laser");
        assert_eq!(l.ranges_m, vec![1.0, 2.0, 3.0]);
        assert_eq!(l.pose, Pose2::new(0.5, -0.5, 0.1));
        assert!((l.beam_angle_rad(0) + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(l.beam_angle_rad(1).abs() < 1e-12);
    }

    #[test]
    fn errors_name_the_line_and_the_field() {
        let e = parse("ODOM 0 0 0 0 0 0 1 h 1\nFLASER 3 1.0 x 3.0 0 0 0 0 0 0 1 h 1\n").unwrap_err().to_string();
        assert!(e.contains("test.log:2") && e.contains("range 2 of 3") && e.contains("'x'"), "{e}");
        let e = parse("FLASER 2 1.0 2.0 0 0\n").unwrap_err().to_string();
        assert!(e.contains(":1:") && e.contains("missing theta"), "{e}");
        let e = parse("FLASER 99999 1\n").unwrap_err().to_string();
        assert!(e.contains("more than 4096"), "{e}");
        let e = parse("ODOM nan 0 0 0 0 0 1 h 1\n").unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
    }

    #[test]
    fn a_truncated_gzip_is_an_error_naming_the_file() {
        use std::io::Write;
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(b"ODOM 0 0 0 0 0 0 1 h 1\n".repeat(1000).as_slice()).expect("compress");
        let bytes = gz.finish().expect("compress");
        let dir = tempfile::Builder::new().prefix("carmen-test-").tempdir().expect("temp dir");
        let whole = dir.path().join("whole.log.gz");
        let cut = dir.path().join("cut.log.gz");
        std::fs::write(&whole, &bytes).expect("write");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
        assert_eq!(read_log(&whole).expect("reads").records.len(), 1000);
        let e = read_log(&cut).unwrap_err().to_string();
        assert!(e.contains("cut.log.gz"), "{e}");
        let e = read_log(&dir.path().join("missing.log")).unwrap_err().to_string();
        assert!(e.contains("missing.log") && e.contains("cannot read"), "{e}");
    }

    #[test]
    fn an_overlong_line_is_refused() {
        let long = format!("FLASER 1 {}\n", "1".repeat(MAX_LINE_BYTES + 10));
        let e = parse(&long).unwrap_err().to_string();
        assert!(e.contains("line 1 is longer"), "{e}");
    }
}
