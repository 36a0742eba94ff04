//! Beyond the thesis: time to collision with an obstacle that moves towards the user
//! (a person walking at them). Distance alone warns late for such an obstacle: it
//! closes at its own speed plus the user's.
//!
//! The obstacle's own speed comes from the scan: the previous frame's obstacle points
//! are moved into this frame by the user's motion (odometry), and the range along the
//! bearing of the nearest point in the path is compared with what it was. A static
//! obstacle gives 0 however the user walks or sweeps the cane; the distance-based cost
//! functions warn about it. Comparing raw ranges instead (no motion compensation)
//! reads every sweep of the cane across a wall as an approach: on the `taylor-course`
//! that made 4 of 5 rumble signals and halved the walks completed (measured with
//! `wearnav course --guide route`, TTC on vs off). Without odometry the previous points
//! are taken where they were, so the user's own walking counts as approach: the
//! conservative reading when nothing tells the two apart.

use std::collections::VecDeque;

use super::config::TtcConfig;
use super::Motion;

/// Oldest frame kept for comparison, ns.
const MAX_GAP_NS: u64 = 1_000_000_000;
/// Previous points within this bearing of the nearest point's give its earlier range,
/// radians (the scan has one point per degree).
const BEARING_TOLERANCE_RAD: f32 = 0.035;

/// An obstacle in the path closing in by its own motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Approach {
    /// Time to collision at the current closing speed (the obstacle's and the user's), s.
    pub ttc_s: f32,
    /// The obstacle's nearest point in the path, user frame `(x forward, y left)`, m.
    pub point: [f32; 2],
}

/// Closing-speed tracker.
#[derive(Debug, Default)]
pub struct ClosingSpeed {
    /// Earlier frames' obstacle points, moved into the current frame, oldest first.
    history: VecDeque<(u64, Vec<[f32; 2]>)>,
    /// The reference frame's points: (bearing, range), sorted by bearing.
    moved: Vec<(f32, f32)>,
    speed_m_s: Option<f32>,
    last_ns: Option<u64>,
}

impl ClosingSpeed {
    /// Feeds this frame's obstacle points (user frame, as seen by the camera: not
    /// remembered ones) at `stamp_ns`, with the user's motion since the previous frame;
    /// returns the approach of the nearest obstacle in the path when that obstacle
    /// itself moves towards the user.
    ///
    /// The range is compared with the newest frame at least `cfg.baseline_s` old: scan
    /// bins are a degree wide, and a bin's nearest point jumps by centimetres as the
    /// cane turns the bins over a wall seen at a slant, which from one frame to the next
    /// reads as a metre per second.
    pub fn update(
        &mut self,
        stamp_ns: u64,
        motion: Option<Motion>,
        points: &[[f32; 2]],
        cfg: &TtcConfig,
    ) -> Option<Approach> {
        let motion = motion.filter(Motion::is_finite);
        if self.history.back().is_some_and(|(t, _)| *t >= stamp_ns) {
            // the clock went back (a clock step, or frames out of order): nothing held
            // is older than this frame, so nothing can be compared with it
            self.history.clear();
            self.speed_m_s = None;
        }
        let frame_s = self.last_ns.replace(stamp_ns).map_or(0.0, |t| stamp_ns.saturating_sub(t) as f32 * 1e-9);
        if let Some(m) = motion {
            let carry = m.to_current_frame();
            for p in self.history.iter_mut().flat_map(|(_, earlier)| earlier.iter_mut()) {
                *p = carry(*p);
            }
        }
        while self.history.front().is_some_and(|(t, _)| stamp_ns - t > MAX_GAP_NS) {
            self.history.pop_front();
        }
        let baseline_ns = (cfg.baseline_s.max(0.0) * 1e9) as u64;
        let ahead = nearest_in_path(points.iter().copied(), cfg.path_width_m);
        let reference = self.history.iter().rposition(|(t, _)| stamp_ns - t >= baseline_ns.max(1));
        let earlier = match (ahead, reference) {
            (Some(a), Some(i)) => {
                let t = self.history[i].0;
                earlier_range(&self.history[i].1, a, &mut self.moved).map(|r| (r, (stamp_ns - t) as f32 * 1e-9))
            }
            _ => None,
        };
        // frames older than the reference are never a reference again
        let mut recycled = Vec::new();
        for _ in 0..reference.unwrap_or(0) {
            recycled = self.history.pop_front().map(|(_, v)| v).unwrap_or_default();
        }
        recycled.clear();
        recycled.extend_from_slice(points);
        self.history.push_back((stamp_ns, recycled));

        let (Some(a), Some((earlier_m, age_s))) = (ahead, earlier) else {
            self.speed_m_s = None;
            return None;
        };
        let range_m = a[0].hypot(a[1]);
        if (earlier_m - range_m).abs() > cfg.max_step_m {
            // a different obstacle, not motion
            self.speed_m_s = None;
            return None;
        }
        let measured = (earlier_m - range_m) / age_s;
        let speed = match self.speed_m_s {
            Some(s) => s + cfg.smoothing * (measured - s),
            None => measured,
        };
        self.speed_m_s = Some(speed);
        if speed < cfg.min_closing_speed_m_s {
            return None;
        }
        // the user's own walking towards the point adds to the closing speed
        let own_m_s = match motion {
            Some(m) if frame_s > 0.0 => ((m.forward_m * a[0] + m.left_m * a[1]) / range_m / frame_s).max(0.0),
            _ => 0.0,
        };
        Some(Approach { ttc_s: range_m / (speed + own_m_s), point: a })
    }
}

/// Range of `earlier` obstacle points (already in this frame) along the bearing of `a`,
/// interpolated between the two points around it.
fn earlier_range(earlier: &[[f32; 2]], a: [f32; 2], moved: &mut Vec<(f32, f32)>) -> Option<f32> {
    moved.clear();
    moved.extend(earlier.iter().map(|p| (p[1].atan2(p[0]), p[0].hypot(p[1]))));
    moved.sort_by(|p, q| p.0.total_cmp(&q.0));
    let bearing = a[1].atan2(a[0]);
    let after = moved.partition_point(|p| p.0 < bearing);
    let right = after.checked_sub(1).and_then(|i| moved.get(i)).copied();
    let left = moved.get(after).copied();
    match (right, left) {
        (Some(r), Some(l)) if bearing - r.0 <= BEARING_TOLERANCE_RAD && l.0 - bearing <= BEARING_TOLERANCE_RAD => {
            let span = l.0 - r.0;
            let f = if span > 0.0 { (bearing - r.0) / span } else { 0.0 };
            Some(r.1 + f * (l.1 - r.1))
        }
        (Some(r), _) if bearing - r.0 <= BEARING_TOLERANCE_RAD / 2.0 => Some(r.1),
        (_, Some(l)) if l.0 - bearing <= BEARING_TOLERANCE_RAD / 2.0 => Some(l.1),
        _ => None,
    }
}

/// The point with the nearest forward distance inside a path of `width_m`.
pub fn nearest_in_path(points: impl Iterator<Item = [f32; 2]>, width_m: f32) -> Option<[f32; 2]> {
    points.filter(|[x, y]| *x > 0.0 && y.abs() <= width_m * 0.5).min_by(|a, b| a[0].total_cmp(&b[0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAME_NS: u64 = 33_333_333;
    /// One scan point per degree over +-29 degrees.
    const BINS: std::ops::RangeInclusive<i32> = -29..=29;

    /// Scan of a wall across the view at forward distance `x_m` (user frame).
    fn wall_ahead(x_m: f32) -> Vec<[f32; 2]> {
        BINS.map(|d| {
            let b = (d as f32).to_radians();
            [x_m, x_m * b.tan()]
        })
        .collect()
    }

    /// Scan of a wall parallel to the walking direction, `side_m` to the left, seen by a
    /// camera yawed `yaw_rad` left of the walking direction.
    fn side_wall(side_m: f32, yaw_rad: f32) -> Vec<[f32; 2]> {
        BINS.filter_map(|d| {
            let b = (d as f32).to_radians();
            let world_bearing = b + yaw_rad;
            (world_bearing > 0.05).then(|| {
                let r = side_m / world_bearing.sin();
                [r * b.cos(), r * b.sin()]
            })
        })
        .filter(|p| p[0].hypot(p[1]) < 5.0)
        .collect()
    }

    /// A person 0.6 m wide at forward distance `x_m`, straight ahead.
    fn person(x_m: f32) -> Vec<[f32; 2]> {
        BINS.filter_map(|d| {
            let y = x_m * (d as f32).to_radians().tan();
            (y.abs() <= 0.3).then_some([x_m, y])
        })
        .collect()
    }

    #[test]
    fn person_walking_at_1_5_m_s_towards_a_standing_user_gives_2_s() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        let still = Some(Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 0.0 });
        let mut last = None;
        for k in 0..10u64 {
            let x = 3.0 + 0.05 * 9.0 - 0.05 * k as f32; // 1.5 m/s at 30 Hz, ending at 3.0 m
            last = c.update(k * FRAME_NS, still, &person(x), &cfg);
        }
        let a = last.expect("approaching");
        assert!((a.ttc_s - 2.0).abs() < 0.05, "{a:?}");
        assert!((a.point[0] - 3.0).abs() < 1e-3 && a.point[1].abs() <= 0.3, "on the person: {a:?}");
    }

    #[test]
    fn a_clock_going_back_starts_the_history_again_instead_of_panicking() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        let still = Some(Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 0.0 });
        c.update(0, still, &person(3.0), &cfg);
        c.update(100_000_000, still, &person(2.85), &cfg);
        // stamped between the two: the newest held frame is not older than this one
        assert_eq!(c.update(50_000_000, still, &person(2.8), &cfg), None);
        assert_eq!(c.history.len(), 1, "only this frame is held");
        // and an approach is measured again from there
        let mut last = None;
        for k in 1..10u64 {
            last = c.update(50_000_000 + k * FRAME_NS, still, &person(2.8 - 0.05 * k as f32), &cfg);
        }
        assert!(last.is_some_and(|a| (a.ttc_s - 2.35 / 1.5).abs() < 0.05), "{last:?}");
    }

    #[test]
    fn walking_user_adds_own_speed_to_an_approaching_person() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        // person at 1.5 m/s, user at 1 m/s towards each other: 2.5 m/s, 3 m apart at the end
        let walk = Some(Motion { forward_m: 1.0 / 30.0, left_m: 0.0, yaw_rad: 0.0 });
        let mut last = None;
        for k in 0..10u64 {
            let x = 3.0 + (2.5 / 30.0) * (9 - k) as f32;
            last = c.update(k * FRAME_NS, walk, &person(x), &cfg);
        }
        let a = last.expect("approaching");
        assert!((a.ttc_s - 3.0 / 2.5).abs() < 0.05, "{a:?}");
    }

    #[test]
    fn walking_at_a_wall_is_left_to_the_costs_with_odometry_and_reads_as_approach_without() {
        let cfg = TtcConfig::default();
        let step = 1.0 / 30.0;
        let walk = |motion: Option<Motion>| {
            let mut c = ClosingSpeed::default();
            (0..10u64).map(|k| c.update(k * FRAME_NS, motion, &wall_ahead(3.0 - step * k as f32), &cfg)).last()
        };
        assert_eq!(walk(Some(Motion { forward_m: step, left_m: 0.0, yaw_rad: 0.0 })), Some(None));
        let blind = walk(None).flatten().expect("no odometry: own walking counts");
        assert!((blind.ttc_s - 2.7).abs() < 0.1, "{blind:?}");
    }

    #[test]
    fn sweeping_the_cane_along_a_side_wall_is_not_an_approach() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        // the cane swings +-17 deg at 0.7 Hz while the user walks 1 m/s, 1 m from a wall
        let sweep = |k: u64| 17f32.to_radians() * (std::f32::consts::TAU * 0.7 * k as f32 / 30.0).sin();
        for k in 0..90u64 {
            let motion = (k > 0).then(|| {
                let dyaw = sweep(k) - sweep(k - 1);
                // body moves 1/30 m along the wall; in the previous camera frame that is
                // rotated by the previous sweep angle
                let yaw0 = sweep(k - 1);
                Motion { forward_m: yaw0.cos() / 30.0, left_m: -yaw0.sin() / 30.0, yaw_rad: dyaw }
            });
            let got = c.update(k * FRAME_NS, motion, &side_wall(1.0, sweep(k)), &cfg);
            assert_eq!(got, None, "frame {k}: sweep {:.1} deg", sweep(k).to_degrees());
        }
    }

    #[test]
    fn still_or_receding_obstacles_have_no_ttc() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        let still = Some(Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 0.0 });
        for k in 0..10u64 {
            assert_eq!(c.update(k * FRAME_NS, still, &person(2.0 + 0.01 * k as f32), &cfg), None);
        }
    }

    #[test]
    fn a_new_nearer_obstacle_is_not_a_speed() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        for k in 0..10u64 {
            assert_eq!(c.update(k * FRAME_NS, None, &wall_ahead(3.0), &cfg), None);
        }
        assert_eq!(c.update(10 * FRAME_NS, None, &wall_ahead(1.0), &cfg), None);
    }
}
