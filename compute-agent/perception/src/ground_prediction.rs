//! Beyond the thesis: when may the ground predicted from gravity stand in for a floor
//! the camera cannot see?
//!
//! Taylor 2017 (sec. 2.2) falls back to the running-average plane when RANSAC fails and
//! has no rule for how long; we degrade after `GroundConfig::max_lost_frames`. Near a
//! wall that rule is wrong: the wall fills the view, the floor is out of it, and the
//! user is told "detection offline" instead of "stop" (measured in the simulator, see
//! [`GroundPredictionConfig`]). While the ground is lost, [`super::ground_plane`] already
//! classifies against the plane with normal `-gravity` and the running offset D. This
//! module decides whether that plane is trusted past the frame limit: gravity agrees with
//! the last ground found (the cane was not lifted or tilted), that ground is recent (the
//! hand's height has not drifted), and the frame shows obstacles (a blocked view, not an
//! empty one that could pass for a clear path). The caller trusts it only while the frame
//! warns, except for a camera whose "clear" is never the user's (the chest camera's,
//! `GroundPredictionConfig::while_clear`), which keeps seeing what overhangs before a
//! wall that hides its floor.

use super::config::GroundPredictionConfig;
use super::ground_plane::{dot, normalized};

/// The last ground found, which a predicted plane must agree with.
#[derive(Debug, Default)]
pub struct GroundPrediction {
    last_found: Option<LastFound>,
}

#[derive(Debug, Clone, Copy)]
struct LastFound {
    stamp_ns: u64,
    normal: [f32; 3],
}

impl GroundPrediction {
    /// Records a frame whose ground was found, with that plane's unit normal (up).
    pub fn found(&mut self, stamp_ns: u64, normal: [f32; 3]) {
        self.last_found = Some(LastFound { stamp_ns, normal });
    }

    /// Whether the plane predicted from `gravity_camera` (pointing down, any length) may
    /// stand in at `stamp_ns`: gravity present, within `max_tilt_deg` of the last found
    /// normal, and that ground found less than `max_age_ns` before. A stamp that does not
    /// advance past the last found ground proves no age bound: not trusted.
    pub fn trusted(&self, gravity_camera: Option<[f32; 3]>, stamp_ns: u64, cfg: &GroundPredictionConfig) -> bool {
        let (Some(last), Some(g)) = (self.last_found, gravity_camera) else {
            return false;
        };
        let Some(up) = normalized(&[-g[0], -g[1], -g[2]]) else {
            return false;
        };
        let fresh = stamp_ns > last.stamp_ns && stamp_ns - last.stamp_ns < cfg.max_age_ns;
        let cos_tilt = dot(&up, &last.normal);
        cfg.enabled && fresh && cos_tilt >= cfg.max_tilt_deg.to_radians().cos()
    }
}

/// Whether a frame with `obstacle_points` of `valid_points` sampled points shows a
/// blocked view (enough of what is seen stands above the ground).
pub fn blocked_view(obstacle_points: usize, valid_points: usize, cfg: &GroundPredictionConfig) -> bool {
    valid_points > 0 && obstacle_points as f32 >= cfg.min_obstacle_fraction * valid_points as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    const UP: [f32; 3] = [0.0, -0.866, -0.5]; // floor normal at 30 deg pitch
    const DOWN: [f32; 3] = [0.0, 8.496, 4.905]; // gravity there, m/s^2
    const S: u64 = 1_000_000_000;

    fn seen_at(stamp_ns: u64) -> GroundPrediction {
        let mut p = GroundPrediction::default();
        p.found(stamp_ns, UP);
        p
    }

    #[test]
    fn agreeing_gravity_within_the_age_is_trusted_and_not_after() {
        let cfg = GroundPredictionConfig::default();
        let p = seen_at(10 * S);
        assert!(p.trusted(Some(DOWN), 10 * S + S / 30, &cfg));
        assert!(p.trusted(Some(DOWN), 12 * S + S / 2, &cfg));
        assert!(!p.trusted(Some(DOWN), 13 * S, &cfg), "3 s after the last ground");
    }

    #[test]
    fn cane_tilted_beyond_the_limit_is_not_trusted() {
        let cfg = GroundPredictionConfig::default();
        let p = seen_at(S);
        let tilt = |deg: f32| {
            let a = (30.0 + deg).to_radians();
            Some([0.0, a.cos(), a.sin()])
        };
        assert!(p.trusted(tilt(4.0), 2 * S, &cfg));
        assert!(!p.trusted(tilt(6.0), 2 * S, &cfg));
        assert!(!p.trusted(tilt(-20.0), 2 * S, &cfg), "cane lifted");
    }

    #[test]
    fn no_gravity_no_ground_yet_unstamped_or_switched_off_is_not_trusted() {
        let cfg = GroundPredictionConfig::default();
        assert!(!seen_at(S).trusted(None, 2 * S, &cfg));
        assert!(!seen_at(S).trusted(Some([f32::NAN, 0.0, 0.0]), 2 * S, &cfg));
        assert!(!GroundPrediction::default().trusted(Some(DOWN), 2 * S, &cfg));
        assert!(!seen_at(0).trusted(Some(DOWN), 0, &cfg), "stamps that never advance");
        let off = GroundPredictionConfig { enabled: false, ..cfg };
        assert!(!seen_at(S).trusted(Some(DOWN), 2 * S, &off));
    }

    #[test]
    fn blocked_view_needs_a_quarter_of_the_points_to_be_obstacles() {
        let cfg = GroundPredictionConfig::default();
        assert!(blocked_view(9000, 10000, &cfg));
        assert!(blocked_view(2500, 10000, &cfg));
        assert!(!blocked_view(2499, 10000, &cfg));
        assert!(!blocked_view(0, 0, &cfg));
    }
}
