//! Straight walls in a range scan, for the wall-angle correction (Zhang et al.: the
//! angle of a wall beside the user, against the map's wall directions, corrects the
//! heading; see [`crate::landmarks::WallAngle`]).
//!
//! Split and merge over the scan's end points in bearing order: a run breaks where two
//! neighbouring points are farther apart than a step along a wall could put them, a
//! run splits at its point farthest from the chord while that is more than a few
//! centimetres, and a piece is a wall when a total-least-squares line fits it closely
//! over at least a metre. A person, a bin or a chair leg is short or round and fits no
//! such line; a desk's or a bench's long side does, and the map's furniture is mostly
//! square to its walls (a straight side that is not counts as an outlier,
//! [`crate::LandmarkConfig::wall_outlier_probability`]).

use serde::{Deserialize, Serialize};

use crate::landmarks::WallAngle;
use crate::scan::{Beam, Scan};

/// What counts as a wall.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct WallFitConfig {
    /// shortest wall, metres (a bench's side is 1.2-1.8 m; a person is 0.5 m)
    pub min_length_m: f64,
    /// fewest end points on it
    pub min_points: usize,
    /// largest RMS distance of its points from the fitted line, metres (the camera's
    /// depth noise at 3-5 m is a few centimetres)
    pub max_rms_m: f64,
    /// a run is split at a point farther than this from its chord, metres
    pub split_m: f64,
    /// neighbouring points farther apart than this are on different things, metres (a
    /// wall beside the user seen 15° off its line has points 0.25 m apart per degree
    /// of scan at 1 m to the side)
    pub max_gap_m: f64,
}

impl Default for WallFitConfig {
    fn default() -> Self {
        Self { min_length_m: 1.0, min_points: 10, max_rms_m: 0.03, split_m: 0.06, max_gap_m: 0.5 }
    }
}

/// A straight wall found in a scan, in the body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallSegment {
    /// its first end (metres forward, metres left), projected onto the fitted line
    pub from: [f64; 2],
    /// its other end
    pub to: [f64; 2],
    /// end points fitted
    pub points: usize,
    /// RMS distance of the points from the line, metres
    pub rms_m: f64,
    /// the line's direction, radians counter-clockwise from forward, in (-pi/2, pi/2]
    pub angle_rad: f64,
}

impl WallSegment {
    /// Its length, metres.
    pub fn length_m(&self) -> f64 {
        (self.to[0] - self.from[0]).hypot(self.to[1] - self.from[1])
    }
}

/// The walls in `scan` (see the module documentation), longest first.
pub fn wall_segments(scan: &Scan, config: &WallFitConfig) -> Vec<WallSegment> {
    let mut beams: Vec<&Beam> = scan.beams.iter().filter(|b| scan.usable(b)).collect();
    beams.sort_by(|a, b| a.angle_rad.total_cmp(&b.angle_rad));
    let sensor = scan.sensor_yaw_rad.sin_cos();
    let points: Vec<[f64; 2]> = beams.iter().map(|b| scan.endpoint(b, sensor)).collect();
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=points.len() {
        let gap = i == points.len() || dist(points[i - 1], points[i]) > config.max_gap_m;
        if gap {
            split_and_fit(&points[start..i], config, &mut out);
            start = i;
        }
    }
    out.sort_by(|a, b| b.length_m().total_cmp(&a.length_m()));
    out
}

/// The direction of the longest wall in `scan`, if it has one: what the filter's
/// wall-angle correction takes (one a scan: two walls of a corridor say the same).
pub fn longest_wall(scan: &Scan, config: &WallFitConfig) -> Option<WallAngle> {
    wall_segments(scan, config).first().map(|w| WallAngle { angle_rad: w.angle_rad })
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Splits a run of neighbouring points at its point farthest from the chord until every
/// piece lies within `split_m` of its chord, and keeps the pieces that fit a wall.
fn split_and_fit(run: &[[f64; 2]], config: &WallFitConfig, out: &mut Vec<WallSegment>) {
    if run.len() < config.min_points.max(2) {
        return;
    }
    let (a, b) = (run[0], run[run.len() - 1]);
    let chord = dist(a, b);
    let (far_i, far_d) = if chord < 1e-9 {
        (0, 0.0)
    } else {
        let (ux, uy) = ((b[0] - a[0]) / chord, (b[1] - a[1]) / chord);
        run.iter()
            .enumerate()
            .map(|(i, p)| (i, ((p[0] - a[0]) * uy - (p[1] - a[1]) * ux).abs()))
            .fold((0, 0.0), |best, x| if x.1 > best.1 { x } else { best })
    };
    if far_d > config.split_m && far_i > 0 && far_i < run.len() - 1 {
        // the split point itself is left out of both: at a corner it lies on both
        // lines only roughly, and a single stray point is on neither
        split_and_fit(&run[..far_i], config, out);
        split_and_fit(&run[far_i + 1..], config, out);
        return;
    }
    if let Some(w) = fit_line(run) {
        if w.points >= config.min_points && w.rms_m <= config.max_rms_m && w.length_m() >= config.min_length_m {
            out.push(w);
        }
    }
}

/// Total least squares: the line through the centroid along the points' principal axis.
fn fit_line(points: &[[f64; 2]]) -> Option<WallSegment> {
    let n = points.len() as f64;
    if points.len() < 2 {
        return None;
    }
    let (mx, my) = points.iter().fold((0.0, 0.0), |s, p| (s.0 + p[0] / n, s.1 + p[1] / n));
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in points {
        let (dx, dy) = (p[0] - mx, p[1] - my);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    // the principal axis of the scatter matrix, and the spread across it
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (s, c) = theta.sin_cos();
    let across: f64 = points.iter().map(|p| (-(p[0] - mx) * s + (p[1] - my) * c).powi(2)).sum();
    let along = |p: &[f64; 2]| (p[0] - mx) * c + (p[1] - my) * s;
    let (lo, hi) =
        points.iter().map(along).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| (lo.min(t), hi.max(t)));
    if !(lo.is_finite() && hi.is_finite() && across.is_finite()) {
        return None;
    }
    let angle_rad = if theta <= -std::f64::consts::FRAC_PI_2 { theta + std::f64::consts::PI } else { theta };
    Some(WallSegment {
        from: [mx + lo * c, my + lo * s],
        to: [mx + hi * c, my + hi * s],
        points: points.len(),
        rms_m: (across / n).sqrt(),
        angle_rad,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wrap_angle;

    /// Beams from a sensor at the body origin facing `yaw` onto the line through `p`
    /// with direction `dir` (both body frame), 1° apart over ±29°, plus `extra`.
    fn scan_of_line(p: [f64; 2], dir_rad: f64, yaw_rad: f64, noise: impl Fn(usize) -> f64) -> Scan {
        let (ds, dc) = dir_rad.sin_cos();
        let beams = (0..59)
            .map(|i| {
                let a = (i as f64 - 29.0).to_radians();
                let (bs, bc) = (a + yaw_rad).sin_cos();
                // p + t * dir = r * (bc, bs)  =>  r = cross(p, dir) / cross((bc, bs), dir)
                let den = bc * ds - bs * dc;
                let r = (p[0] * ds - p[1] * dc) / den;
                Beam { angle_rad: a, range_m: if r > 0.0 && den.abs() > 1e-6 { r + noise(i) } else { f64::INFINITY } }
            })
            .collect();
        Scan { beams, max_range_m: 5.0, sensor_yaw_rad: yaw_rad, ..Default::default() }
    }

    #[test]
    fn a_wall_beside_the_user_is_found_at_its_angle() {
        // a wall 1 m to the left, turned 7° from the walking direction, the sensor
        // turned 20° left (the cane's sweep), 1 cm of alternating depth noise
        let want = 7f64.to_radians();
        let scan = scan_of_line([0.0, 1.0], want, 20f64.to_radians(), |i| if i % 2 == 0 { 0.01 } else { -0.01 });
        let walls = wall_segments(&scan, &WallFitConfig::default());
        assert_eq!(walls.len(), 1, "{walls:?}");
        let w = walls[0];
        assert!(wrap_angle(w.angle_rad - want).abs() < 0.5f64.to_radians(), "{} deg", w.angle_rad.to_degrees());
        assert!(w.length_m() > 2.0 && w.rms_m < 0.02, "{w:?}");
        let a = longest_wall(&scan, &WallFitConfig::default()).expect("a wall");
        assert_eq!(a.angle_rad, w.angle_rad);
    }

    #[test]
    fn a_wall_ahead_is_across_the_way() {
        // an end wall 3 m ahead, square to the way: direction 90°
        let scan = scan_of_line([3.0, 0.0], 90f64.to_radians(), 0.0, |_| 0.0);
        let w = wall_segments(&scan, &WallFitConfig::default())[0];
        assert!((w.angle_rad.abs() - 90f64.to_radians()).abs() < 1e-6, "{} deg", w.angle_rad.to_degrees());
        assert!((w.from[0] - 3.0).abs() < 1e-6 && (w.to[0] - 3.0).abs() < 1e-6);
    }

    #[test]
    fn a_corner_splits_into_two_walls() {
        // the end wall 3 m ahead and the left wall 1 m to the left, meeting at (3, 1)
        let beams = (0..59)
            .map(|i| {
                let a = (i as f64 - 29.0f64).to_radians();
                let to_end = 3.0 / a.cos();
                let to_left = if a > 0.0 { 1.0 / a.sin() } else { f64::INFINITY };
                Beam { angle_rad: a, range_m: to_end.min(to_left) }
            })
            .collect();
        let scan = Scan::at_body_origin(beams, 5.0);
        let walls = wall_segments(&scan, &WallFitConfig::default());
        assert_eq!(walls.len(), 2, "{walls:?}");
        let mut angles: Vec<f64> = walls.iter().map(|w| w.angle_rad.abs().to_degrees()).collect();
        angles.sort_by(f64::total_cmp);
        assert!(angles[0] < 0.5 && (angles[1] - 90.0).abs() < 0.5, "{angles:?}");
    }

    #[test]
    fn round_or_short_things_and_junk_are_no_wall() {
        // a box face 1.5 m ahead (0.3 m of it seen), a person (a 0.25 m radius
        // cylinder 2 m ahead), NaN and max-range beams: nothing long and straight
        let beams: Vec<Beam> = (0..59)
            .map(|i| {
                let a = (i as f64 - 29.0f64).to_radians();
                let range_m = match i {
                    0..=9 => f64::NAN,
                    10..=20 => 1.5 / a.cos(),
                    22..=36 => {
                        // nearest intersection of the ray with the circle round (2, 0)
                        let b = 4.0 * a.cos();
                        let disc = b * b - 4.0 * (4.0 - 0.0625);
                        if disc >= 0.0 {
                            (b - disc.sqrt()) / 2.0
                        } else {
                            9.0
                        }
                    }
                    _ => 9.0,
                };
                Beam { angle_rad: a, range_m }
            })
            .collect();
        assert!(beams[29].range_m > 1.7 && beams[29].range_m < 1.8, "the person is seen");
        let scan = Scan::at_body_origin(beams, 5.0);
        assert!(wall_segments(&scan, &WallFitConfig::default()).is_empty());
        assert_eq!(longest_wall(&Scan::default(), &WallFitConfig::default()), None);
    }
}
