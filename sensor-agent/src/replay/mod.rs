//! Replay of recorded depth data as a [`FrameSource`]: `pcd:<file-or-dir>` (organized
//! PCD clouds), `tum:<dir>` (the TUM RGB-D benchmark layout: `depth.txt` listing
//! 16-bit PNGs at 5000 units per metre, `accelerometer.txt` when present) and
//! `png:<file-or-dir>` (16-bit depth PNGs with a given scale and intrinsics).
//!
//! Frames keep their recorded spacing (scaled by `rate`), or a nominal period when the
//! files carry no time. A missing or corrupt file is reported as
//! [`SourceError::Skipped`] naming it, and the next call moves on to the next file.

pub mod organized_depth;
pub mod pacing;
pub mod tum;

use std::path::{Path, PathBuf};

use schemas::Intrinsics;

use crate::formats::{depth_png, pcd};
use crate::source::{FrameSource, SourceError, SourceFrame};
use pacing::Pacing;

/// How a recording is played.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayOptions {
    /// Speed multiplier: 1.0 real time, 2.0 twice as fast.
    pub rate: f64,
    /// Start again from the first file after the last.
    pub loop_playback: bool,
    /// Metres per depth unit (required for `png:`; overrides TUM's 1/5000).
    pub depth_scale_m: Option<f32>,
    /// Pinhole intrinsics (required for `png:`; overrides TUM's Kinect defaults and
    /// the least-squares fit of `pcd:`).
    pub intrinsics: Option<Intrinsics>,
    /// Frame rate of files that carry no timestamp, Hz.
    pub untimed_fps: f64,
}

impl Default for ReplayOptions {
    /// Real time, once, 30 Hz for untimed files (the Kinect / Xtion frame rate).
    fn default() -> Self {
        ReplayOptions { rate: 1.0, loop_playback: false, depth_scale_m: None, intrinsics: None, untimed_fps: 30.0 }
    }
}

/// Why a replay source could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The spec is not `pcd:`, `tum:` or `png:`.
    #[error("unknown replay source {0:?}: use pcd:<file-or-dir>, tum:<dir> or png:<file-or-dir>")]
    UnknownKind(String),
    /// The path does not exist or cannot be listed.
    #[error("{}: {reason}", path.display())]
    Unreadable {
        /// The path.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// Nothing to play.
    #[error("{}: no {what} files", path.display())]
    Empty {
        /// The folder.
        path: PathBuf,
        /// Which files were looked for.
        what: &'static str,
    },
    /// A TUM index file is malformed.
    #[error("{}: line {line}: {reason}", file.display())]
    BadIndex {
        /// The index file.
        file: PathBuf,
        /// 1-based line.
        line: usize,
        /// Why.
        reason: String,
    },
    /// An option this source needs was not given.
    #[error("{0}")]
    MissingOption(String),
    /// An option is out of range.
    #[error("{0}")]
    BadOption(String),
}

/// Parses `fx,fy,cx,cy` (pixels).
pub fn parse_intrinsics(s: &str) -> Result<Intrinsics, ReplayError> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>().map_err(|e| ReplayError::BadOption(format!("intrinsics {p:?}: {e}"))))
        .collect::<Result<_, _>>()?;
    let [fx, fy, cx, cy] = v[..] else {
        return Err(ReplayError::BadOption(format!("intrinsics: expected fx,fy,cx,cy, got {} numbers", v.len())));
    };
    let k = Intrinsics { fx, fy, cx, cy };
    if !k.is_valid() {
        return Err(ReplayError::BadOption(format!("intrinsics {s}: focal lengths must be finite and positive")));
    }
    Ok(k)
}

/// Opens a `pcd:`, `tum:` or `png:` spec.
pub fn open_source(spec: &str, opts: &ReplayOptions) -> Result<Box<dyn FrameSource>, ReplayError> {
    if !(opts.untimed_fps.is_finite() && opts.untimed_fps > 0.0) {
        return Err(ReplayError::BadOption(format!("untimed frame rate {} Hz must be positive", opts.untimed_fps)));
    }
    if !(opts.rate.is_finite() && opts.rate > 0.0) {
        return Err(ReplayError::BadOption(format!("rate {} must be positive", opts.rate)));
    }
    if let Some(s) = opts.depth_scale_m {
        if !(s.is_finite() && s > 0.0) {
            return Err(ReplayError::BadOption(format!("depth scale {s} m must be positive")));
        }
    }
    let (kind, path) = spec.split_once(':').ok_or_else(|| ReplayError::UnknownKind(spec.to_string()))?;
    let path = Path::new(path);
    let (entries, format) = match kind {
        "pcd" => (list_files(path, "pcd")?, Format::Pcd { intrinsics: opts.intrinsics }),
        "png" => {
            let depth_scale_m = opts.depth_scale_m.ok_or_else(|| {
                ReplayError::MissingOption("png: sources need the depth scale (metres per unit, e.g. 0.001)".into())
            })?;
            let intrinsics = opts
                .intrinsics
                .ok_or_else(|| ReplayError::MissingOption("png: sources need intrinsics fx,fy,cx,cy".into()))?;
            (list_files(path, "png")?, Format::Png { depth_scale_m, intrinsics })
        }
        "tum" => {
            let entries = tum::read_index(path)?;
            let format = Format::Png {
                depth_scale_m: opts.depth_scale_m.unwrap_or(tum::DEPTH_SCALE_M),
                intrinsics: opts.intrinsics.unwrap_or(tum::KINECT_INTRINSICS),
            };
            (entries, format)
        }
        _ => return Err(ReplayError::UnknownKind(spec.to_string())),
    };
    let period_s = nominal_period_s(&entries, opts.untimed_fps);
    Ok(Box::new(ReplaySource {
        name: spec.to_string(),
        entries,
        format,
        next: 0,
        looped: opts.loop_playback,
        pacing: Pacing::new(opts.rate, period_s),
    }))
}

/// One recorded frame on disk.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The file.
    pub path: PathBuf,
    /// Recording time, seconds (any epoch), when the recording says.
    pub time_s: Option<f64>,
    /// Gravity in the camera frame (unit, towards the floor) at that time.
    pub gravity_camera: Option<[f32; 3]>,
}

#[derive(Debug, Clone, Copy)]
enum Format {
    Pcd { intrinsics: Option<Intrinsics> },
    Png { depth_scale_m: f32, intrinsics: Intrinsics },
}

/// A recording played back frame by frame.
pub struct ReplaySource {
    name: String,
    entries: Vec<Entry>,
    format: Format,
    next: usize,
    looped: bool,
    pacing: Pacing,
}

/// The files with extension `ext` in a folder (sorted by name), or the one file.
/// Timestamps come from names that are a number of seconds (TUM style
/// `1305031102.160407.png`) or PCL grabber names (`frame_20121214T142255.814212.pcd`).
fn list_files(path: &Path, ext: &str) -> Result<Vec<Entry>, ReplayError> {
    let unreadable = |e: std::io::Error| ReplayError::Unreadable { path: path.to_path_buf(), reason: e.to_string() };
    let meta = std::fs::metadata(path).map_err(unreadable)?;
    let mut paths = if meta.is_dir() {
        let mut v = Vec::new();
        for item in std::fs::read_dir(path).map_err(unreadable)? {
            let p = item.map_err(unreadable)?.path();
            if p.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext)) {
                v.push(p);
            }
        }
        v
    } else {
        vec![path.to_path_buf()]
    };
    paths.sort();
    if paths.is_empty() {
        return Err(ReplayError::Empty {
            path: path.to_path_buf(),
            what: if ext == "pcd" { "*.pcd" } else { "*.png" },
        });
    }
    Ok(paths.into_iter().map(|p| Entry { time_s: time_from_name(&p), path: p, gravity_camera: None }).collect())
}

/// Seconds encoded in a file name, if it has them.
fn time_from_name(path: &Path) -> Option<f64> {
    let stem = path.file_stem()?.to_str()?;
    if let Ok(t) = stem.parse::<f64>() {
        return t.is_finite().then_some(t);
    }
    // PCL grabber: ..._YYYYMMDDTHHMMSS.ffffff; seconds of the day are enough for gaps
    // (a recording across midnight just gets one nominal gap).
    let (_, clock) = stem.rsplit_once('T')?;
    let (hms, frac) = clock.split_once('.').unwrap_or((clock, "0"));
    if hms.len() != 6 || !hms.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let field = |r: std::ops::Range<usize>| hms[r].parse::<f64>().ok();
    let frac: f64 = format!("0.{frac}").parse().ok()?;
    Some(field(0..2)? * 3600.0 + field(2..4)? * 60.0 + field(4..6)? + frac)
}

/// Median recorded spacing, or the untimed rate's period.
fn nominal_period_s(entries: &[Entry], untimed_fps: f64) -> f64 {
    let mut gaps: Vec<f64> =
        entries.windows(2).filter_map(|w| Some(w[1].time_s? - w[0].time_s?)).filter(|g| *g > 0.0 && *g < 5.0).collect();
    if gaps.is_empty() {
        return 1.0 / untimed_fps;
    }
    gaps.sort_by(f64::total_cmp);
    gaps[gaps.len() / 2]
}

impl ReplaySource {
    fn load(&self, entry: &Entry, stamp_ns: u64) -> Result<SourceFrame, SourceError> {
        let skipped = |reason: String| SourceError::Skipped { what: entry.path.display().to_string(), reason };
        let (width, height, depth, depth_scale_m, intrinsics) = match self.format {
            Format::Pcd { intrinsics } => {
                let cloud = pcd::read(&entry.path).map_err(|e| skipped(e.problem.to_string()))?;
                let k = match intrinsics {
                    Some(k) => k,
                    None => organized_depth::fit_intrinsics(&cloud).map_err(skipped)?,
                };
                let mut depth = Vec::new();
                organized_depth::depth_mm(&cloud, &mut depth);
                (cloud.width, cloud.height, depth, organized_depth::CLOUD_DEPTH_SCALE_M, k)
            }
            Format::Png { depth_scale_m, intrinsics } => {
                let img = depth_png::read(&entry.path).map_err(|e| skipped(e.problem.to_string()))?;
                (img.width, img.height, img.samples, depth_scale_m, intrinsics)
            }
        };
        let frame = SourceFrame::depth_only(stamp_ns, (width, height), depth_scale_m, intrinsics, depth);
        Ok(SourceFrame { gravity_camera: entry.gravity_camera, ..frame })
    }
}

impl FrameSource for ReplaySource {
    fn describe(&self) -> String {
        format!("{} ({} frames{})", self.name, self.entries.len(), if self.looped { ", looped" } else { "" })
    }

    fn next_frame(&mut self, now_ns: u64) -> Result<Option<SourceFrame>, SourceError> {
        if self.next >= self.entries.len() {
            if !self.looped {
                return Ok(None);
            }
            self.next = 0;
            self.pacing.restart();
        }
        let entry = self.entries[self.next].clone();
        self.next += 1;
        let stamp_ns = self.pacing.stamp(entry.time_s, now_ns);
        self.load(&entry, stamp_ns).map(Some)
    }

    fn period_ns(&self) -> u64 {
        self.pacing.period_ns()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_data::real_capture;

    /// A folder for one test's files, removed when the test ends (failed too).
    fn temp_dir(tag: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("wearnav-replay-{tag}-")).tempdir().unwrap()
    }

    #[test]
    fn pcd_file_becomes_a_millimetre_depth_frame_with_fitted_intrinsics() {
        let path = real_capture("five_people.pcd");
        let mut src = open_source(&format!("pcd:{}", path.display()), &ReplayOptions::default()).unwrap();
        let f = src.next_frame(1_000).unwrap().unwrap();
        assert_eq!((f.width, f.height, f.stamp_ns, f.depth_scale_m), (640, 480, 1_000, 0.001));
        assert_eq!(f.depth.iter().filter(|&&d| d > 0).count(), 239_075);
        let (lo, hi) = f.depth.iter().filter(|&&d| d > 0).fold((u16::MAX, 0), |(lo, hi), &d| (lo.min(d), hi.max(d)));
        assert!((1750..=1770).contains(&lo) && (9750..=9770).contains(&hi), "{lo}..{hi} mm");
        assert!(f.intrinsics.is_valid());
        assert!(src.next_frame(2_000).unwrap().is_none(), "one file, no loop: the stream ends");
    }

    #[test]
    fn corrupt_file_in_a_folder_is_skipped_by_name_and_the_stream_goes_on() {
        let good = real_capture("tum_depth_640x480_u16_5000perm.png");
        let scratch = temp_dir("skip");
        let dir = scratch.path();
        std::fs::copy(&good, dir.join("001.png")).unwrap();
        std::fs::write(dir.join("002.png"), b"\x89PNG\r\n\x1a\ngarbage").unwrap();
        std::fs::copy(&good, dir.join("003.png")).unwrap();
        let opts = ReplayOptions {
            depth_scale_m: Some(0.0002),
            intrinsics: Some(tum::KINECT_INTRINSICS),
            ..Default::default()
        };
        let mut src = open_source(&format!("png:{}", dir.display()), &opts).unwrap();
        assert!(src.next_frame(0).unwrap().is_some());
        match src.next_frame(0) {
            Err(SourceError::Skipped { what, reason }) => {
                assert!(what.ends_with("002.png"), "{what}");
                assert!(!reason.is_empty());
            }
            other => panic!("expected a skip, got {other:?}"),
        }
        let third = src.next_frame(0).unwrap().unwrap();
        assert_eq!(third.depth_scale_m, 0.0002);
        assert!(src.next_frame(0).unwrap().is_none());
    }

    #[test]
    fn png_folder_without_scale_or_intrinsics_is_refused_at_open() {
        let dir = temp_dir("opts");
        let err = open_source(&format!("png:{}", dir.path().display()), &ReplayOptions::default()).err().unwrap();
        assert!(matches!(err, ReplayError::MissingOption(_)), "{err}");
    }

    #[test]
    fn looped_recording_starts_again_and_time_moves_forward() {
        let good = real_capture("redwood_00000_depth_640x480_u16_mm.png");
        let scratch = temp_dir("loop");
        let dir = scratch.path();
        std::fs::copy(&good, dir.join("a.png")).unwrap();
        let opts = ReplayOptions {
            depth_scale_m: Some(0.001),
            intrinsics: Some(tum::KINECT_INTRINSICS),
            loop_playback: true,
            untimed_fps: 10.0,
            rate: 2.0,
        };
        let mut src = open_source(&format!("png:{}", dir.display()), &opts).unwrap();
        assert_eq!(src.period_ns(), 50_000_000);
        let stamps: Vec<u64> = (0..3).map(|_| src.next_frame(0).unwrap().unwrap().stamp_ns).collect();
        assert_eq!(stamps, [0, 50_000_000, 100_000_000]);
    }

    #[test]
    fn unknown_kind_and_missing_path_are_refused() {
        assert!(matches!(open_source("bag:x", &ReplayOptions::default()), Err(ReplayError::UnknownKind(_))));
        assert!(matches!(
            open_source("pcd:/nonexistent/dir", &ReplayOptions::default()),
            Err(ReplayError::Unreadable { .. })
        ));
    }

    #[test]
    fn intrinsics_parse_from_four_numbers() {
        let k = parse_intrinsics("525, 525,319.5,239.5").unwrap();
        assert_eq!((k.fx, k.cy), (525.0, 239.5));
        assert!(parse_intrinsics("525,525,319.5").is_err());
        assert!(parse_intrinsics("0,525,319.5,239.5").is_err());
    }

    #[test]
    fn pcl_grabber_and_tum_names_carry_time() {
        let t = time_from_name(Path::new("frame_20121214T142255.814212.pcd")).unwrap();
        assert!((t - (14.0 * 3600.0 + 22.0 * 60.0 + 55.814212)).abs() < 1e-6);
        assert_eq!(time_from_name(Path::new("1305031102.160407.png")), Some(1305031102.160407));
        assert_eq!(time_from_name(Path::new("five_people.pcd")), None);
    }
}
