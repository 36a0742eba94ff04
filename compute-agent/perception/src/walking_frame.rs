//! Beyond the thesis: the costs along the way the user walks, not along the swept
//! camera. Taylor's cost regions look along the camera's heading, and the cane sweeps
//! it 17 degrees each way: at each end of a swing a wall beside a 1.2-1.6 m corridor is
//! in the ±30 degree region of the side the cane points to, and the cues stop a user
//! who is walking past it (`docs/beyond-the-course.md`). The camera's angle to the body
//! (the sweep) is the difference between the camera's turn (its odometry) and the
//! body's (a body-worn gyro), integrated and leaked back to zero over a few seconds: a
//! sweep averages out over its period, a gyro bias does not grow into a lasting angle
//! (the localization tracker reads its scans with the same estimate). Without the
//! body's rate the sweep is not known and the costs look along the camera, as before.

use super::config::WalkingFrameConfig;
use super::Motion;

/// A gap between frames longer than this starts the estimate again, nanoseconds.
const MAX_GAP_NS: u64 = 500_000_000;

/// The camera's angle to the body's heading, from the turns of both.
#[derive(Debug, Default, Clone)]
pub struct SweepEstimate {
    sweep_rad: f32,
    /// The body's rate at the last frame (trapezoids between frames).
    body_rate: Option<f32>,
    last_ns: Option<u64>,
}

impl SweepEstimate {
    /// The sweep at the frame captured at `stamp_ns`, radians, positive when the camera
    /// points left of the body: `camera` is the camera's motion since the last frame
    /// (odometry), `body_rate` the body's turn rate now. 0 (along the camera) when off,
    /// when either is missing or not a number, or after a gap.
    pub fn update(
        &mut self,
        stamp_ns: u64,
        camera: Option<Motion>,
        body_rate: Option<f32>,
        cfg: &WalkingFrameConfig,
    ) -> f32 {
        let dt_ns = self.last_ns.map(|t| stamp_ns.checked_sub(t));
        self.last_ns = Some(stamp_ns);
        let body_rate = body_rate.filter(|r| r.is_finite());
        let camera_turn = camera.map(|m| m.yaw_rad).filter(|y| y.is_finite());
        let (before, now) = (self.body_rate, body_rate);
        self.body_rate = now;
        match (cfg.enabled, dt_ns, camera_turn, before, now) {
            (true, Some(Some(dt_ns)), Some(turn), Some(before), Some(now)) if dt_ns <= MAX_GAP_NS => {
                let dt_s = dt_ns as f32 * 1e-9;
                self.sweep_rad += turn - 0.5 * (before + now) * dt_s;
                self.sweep_rad *= (-dt_s / cfg.time_constant_s.max(1e-3)).exp();
                let max = cfg.max_sweep_deg.to_radians();
                self.sweep_rad = self.sweep_rad.clamp(-max, max);
            }
            // the first frame with both: the sweep is its mean until it moves
            (true, Some(Some(dt_ns)), Some(_), None, Some(_)) if dt_ns <= MAX_GAP_NS => {}
            _ => self.sweep_rad = 0.0,
        }
        self.sweep_rad
    }
}

/// The map from a camera user-frame point `(x forward, y left)` to the walking frame
/// (x along the body's heading) of a camera `sweep_rad` to the left of it.
pub fn to_walking(sweep_rad: f32) -> impl Fn([f32; 2]) -> [f32; 2] {
    let (s, c) = sweep_rad.sin_cos();
    move |[x, y]| [c * x - s * y, s * x + c * y]
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAME_NS: u64 = 33_333_333;

    fn on() -> WalkingFrameConfig {
        WalkingFrameConfig { enabled: true, ..WalkingFrameConfig::default() }
    }

    fn turn(yaw_rad: f32) -> Option<Motion> {
        Some(Motion { forward_m: 0.04, left_m: 0.0, yaw_rad })
    }

    /// A cane swept `amp` each way at `hz` by a user walking straight (body rate
    /// `body`, the camera turning with it), frame by frame: the worst error of the
    /// estimate after `settle_s`.
    fn worst_error(amp_deg: f32, hz: f32, body_deg_s: f32, settle_s: f32) -> f32 {
        let cfg = on();
        let mut e = SweepEstimate::default();
        let (amp, w, body) = (amp_deg.to_radians(), std::f32::consts::TAU * hz, body_deg_s.to_radians());
        let sweep = |t: f32| amp * (w * t).sin();
        let mut worst = 0f32;
        for k in 0..600u64 {
            let t = k as f32 / 30.0;
            let camera = if k == 0 { None } else { turn(sweep(t) - sweep(t - 1.0 / 30.0) + body / 30.0) };
            let est = e.update(k * FRAME_NS, camera, Some(body), &cfg);
            if t >= settle_s {
                worst = worst.max((est - sweep(t)).abs());
            }
        }
        worst
    }

    #[test]
    fn a_sweep_is_followed_within_two_degrees_walking_straight_or_turning() {
        // a 17-degree sweep at 0.7 Hz, the simulator's, starting at its middle
        assert!(worst_error(17.0, 0.7, 0.0, 0.0) < 2f32.to_radians(), "{}", worst_error(17.0, 0.7, 0.0, 0.0));
        // the body turning at 45 degrees/s all the while: the turn is the body's
        assert!(worst_error(17.0, 0.7, 45.0, 0.0) < 2f32.to_radians());
    }

    #[test]
    fn without_the_body_rate_or_after_a_gap_the_costs_look_along_the_camera() {
        let cfg = on();
        let mut e = SweepEstimate::default();
        e.update(0, None, Some(0.0), &cfg);
        assert!((e.update(FRAME_NS, turn(0.1), Some(0.0), &cfg) - 0.1).abs() < 0.01);
        assert_eq!(e.update(2 * FRAME_NS, turn(0.1), None, &cfg), 0.0);
        e.update(3 * FRAME_NS, turn(0.1), Some(0.0), &cfg);
        assert!(e.update(4 * FRAME_NS, turn(0.1), Some(0.0), &cfg) > 0.09);
        assert_eq!(e.update(4 * FRAME_NS + 2 * MAX_GAP_NS, turn(0.1), Some(0.0), &cfg), 0.0);
        assert_eq!(e.update(5 * FRAME_NS + 2 * MAX_GAP_NS, turn(f32::NAN), Some(0.0), &cfg), 0.0);
        let off = WalkingFrameConfig { enabled: false, ..cfg };
        assert_eq!(e.update(6 * FRAME_NS + 2 * MAX_GAP_NS, turn(0.1), Some(0.0), &off), 0.0);
    }

    #[test]
    fn a_bad_turn_never_turns_the_look_past_the_limit() {
        let cfg = on();
        let mut e = SweepEstimate::default();
        e.update(0, None, Some(0.0), &cfg);
        e.update(FRAME_NS, turn(0.0), Some(0.0), &cfg);
        let s = e.update(2 * FRAME_NS, turn(3.0), Some(0.0), &cfg);
        assert!((s - cfg.max_sweep_deg.to_radians()).abs() < 1e-6, "{s}");
    }

    #[test]
    fn a_point_ahead_of_a_camera_swept_left_lies_left_of_the_way_walked() {
        // the camera 20 degrees left of the body; a wall point 1 m ahead of the camera
        let p = to_walking(20f32.to_radians())([1.0, 0.0]);
        assert!((p[0] - 0.9397).abs() < 1e-3 && (p[1] - 0.342).abs() < 1e-3, "{p:?}");
        // a point straight ahead of the body, seen by that camera at -20 degrees
        let q = to_walking(20f32.to_radians())([20f32.to_radians().cos(), -20f32.to_radians().sin()]);
        assert!((q[0] - 1.0).abs() < 1e-5 && q[1].abs() < 1e-5, "{q:?}");
    }
}
