//! The TUM RGB-D benchmark layout (Sturm et al. 2012, "A benchmark for the evaluation
//! of RGB-D SLAM systems", section IV; file formats on the benchmark's web page):
//! `depth.txt` lists `timestamp filename` per frame (`#` comments), depth PNGs hold
//! 5000 units per metre, and `accelerometer.txt` lists `timestamp ax ay az` (m/s^2)
//! from the Kinect's accelerometer.
//!
//! The accelerometer axes are taken as the camera's optical axes (x right, y down,
//! z forward): a level, still Kinect reads about (0, -9.8, 0), the specific force
//! pointing up, so gravity (towards the floor) is the reading negated and normalised.

use std::path::Path;

use schemas::Intrinsics;

use super::{Entry, ReplayError};

/// TUM depth unit: 1/5000 m.
pub const DEPTH_SCALE_M: f32 = 0.0002;

/// The benchmark's default Kinect intrinsics (its "ROS default" calibration).
pub const KINECT_INTRINSICS: Intrinsics = Intrinsics { fx: 525.0, fy: 525.0, cx: 319.5, cy: 239.5 };

/// Accelerometer samples further than this from a frame give it no gravity.
const MAX_ACCEL_GAP_S: f64 = 0.1;

/// Reads `dir/depth.txt` (and `dir/accelerometer.txt` when present) into entries.
pub fn read_index(dir: &Path) -> Result<Vec<Entry>, ReplayError> {
    let index = dir.join("depth.txt");
    let text = std::fs::read_to_string(&index)
        .map_err(|e| ReplayError::Unreadable { path: index.clone(), reason: e.to_string() })?;
    let mut entries = Vec::new();
    for (i, line) in numbered_lines(&text) {
        let mut parts = line.split_whitespace();
        let (Some(t), Some(file), None) = (parts.next(), parts.next(), parts.next()) else {
            return Err(ReplayError::BadIndex { file: index, line: i, reason: "expected `timestamp filename`".into() });
        };
        let time_s = parse_time(t).ok_or_else(|| ReplayError::BadIndex {
            file: index.clone(),
            line: i,
            reason: format!("timestamp {t:?} is not a number"),
        })?;
        entries.push(Entry { path: dir.join(file), time_s: Some(time_s), gravity_camera: None });
    }
    if entries.is_empty() {
        return Err(ReplayError::Empty { path: index, what: "depth" });
    }
    let accel_path = dir.join("accelerometer.txt");
    if let Ok(text) = std::fs::read_to_string(&accel_path) {
        let accel = read_accelerometer(&text, &accel_path)?;
        for e in &mut entries {
            e.gravity_camera = e.time_s.and_then(|t| gravity_at(&accel, t));
        }
    }
    Ok(entries)
}

fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

fn parse_time(t: &str) -> Option<f64> {
    t.parse::<f64>().ok().filter(|t| t.is_finite())
}

/// `(time_s, [ax, ay, az])` in file order.
fn read_accelerometer(text: &str, file: &Path) -> Result<Vec<(f64, [f32; 3])>, ReplayError> {
    let mut samples = Vec::new();
    for (i, line) in numbered_lines(text) {
        let v: Vec<f64> = line.split_whitespace().filter_map(parse_time).collect();
        let [t, ax, ay, az] = v[..] else {
            return Err(ReplayError::BadIndex {
                file: file.to_path_buf(),
                line: i,
                reason: "expected `timestamp ax ay az`".into(),
            });
        };
        samples.push((t, [ax as f32, ay as f32, az as f32]));
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(samples)
}

/// Gravity direction from the accelerometer sample nearest `t`, if one is close and
/// the reading is not zero.
fn gravity_at(accel: &[(f64, [f32; 3])], t: f64) -> Option<[f32; 3]> {
    let i = accel.partition_point(|s| s.0 < t);
    let nearest = [i.checked_sub(1), Some(i)]
        .into_iter()
        .flatten()
        .filter_map(|j| accel.get(j))
        .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))?;
    if (nearest.0 - t).abs() > MAX_ACCEL_GAP_S {
        return None;
    }
    let a = nearest.1;
    let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (norm > 1.0).then(|| [-a[0] / norm, -a[1] / norm, -a[2] / norm])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::{open_source, ReplayOptions};
    use crate::source::SourceError;

    /// A TUM folder (its `depth/` made) of one test's own, removed when the test ends
    /// (failed too): the tests run side by side.
    fn temp_dir() -> tempfile::TempDir {
        let dir = tempfile::Builder::new().prefix("wearnav-tum-").tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("depth")).unwrap();
        dir
    }

    #[test]
    fn tum_folder_plays_at_recorded_spacing_with_gravity_and_skips_a_missing_png() {
        let png = crate::test_data::real_capture("tum_depth_640x480_u16_5000perm.png");
        let scratch = temp_dir();
        let dir = scratch.path();
        std::fs::copy(&png, dir.join("depth/1.000000.png")).unwrap();
        std::fs::copy(&png, dir.join("depth/1.100000.png")).unwrap();
        std::fs::write(
            dir.join("depth.txt"),
            "# depth maps\n# timestamp filename\n1.000000 depth/1.000000.png\n1.033000 depth/missing.png\n1.100000 depth/1.100000.png\n",
        )
        .unwrap();
        std::fs::write(dir.join("accelerometer.txt"), "# accel\n0.99 0.0 -9.0 -3.0\n1.5 0 -9.81 0\n").unwrap();
        let mut src = open_source(&format!("tum:{}", dir.display()), &ReplayOptions::default()).unwrap();
        let first = src.next_frame(0).unwrap().unwrap();
        assert_eq!((first.depth_scale_m, first.intrinsics), (DEPTH_SCALE_M, KINECT_INTRINSICS));
        let g = first.gravity_camera.unwrap();
        let n = (90.0f32).sqrt();
        assert!((g[1] - 9.0 / n).abs() < 1e-5 && (g[2] - 3.0 / n).abs() < 1e-5, "{g:?}");
        match src.next_frame(0) {
            Err(SourceError::Skipped { what, .. }) => {
                assert!(what.ends_with("missing.png"), "{what}")
            }
            other => panic!("expected a skip, got {other:?}"),
        }
        let third = src.next_frame(0).unwrap().unwrap();
        assert_eq!(third.stamp_ns, 100_000_000, "recorded spacing 1.0 -> 1.1 s");
        assert_eq!(third.gravity_camera, None, "no accelerometer sample within 0.1 s");
    }

    #[test]
    fn malformed_index_line_is_refused_with_its_number() {
        let scratch = temp_dir();
        let dir = scratch.path().join("bad");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("depth.txt"), "# x\n1.0 a.png\nnot-a-time b.png\n").unwrap();
        match read_index(&dir) {
            Err(ReplayError::BadIndex { line, .. }) => assert_eq!(line, 3),
            other => panic!("expected a bad index, got {other:?}"),
        }
    }
}
