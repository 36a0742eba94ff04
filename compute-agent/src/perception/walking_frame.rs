//! Beyond the thesis: costs in the direction the user walks, not where the swept cane
//! points. Taylor's cost functions look down a path straight ahead of the camera; on a
//! cane swept +-17 deg (Taylor's users swept it as they walked) that path swings 0.6 m
//! to either side at 2 m, so a wall beside the way flickers into it and an obstacle in
//! the way flickers out of it — the rumble flaps with the sweep.
//!
//! The camera is fixed on the cane near the hand, so while the user walks it travels in
//! the walking direction whatever the sweep (the sweep itself moves it sideways by only a
//! few centimetres). The direction of its recent travel, seen in the current camera
//! frame, is where the user is going. Odometry gives the travel; it is smoothed over
//! `tau_s` (enough to damp the sweep's own sideways wobble, short against a real turn).
//! Standing still or turning in place (travel sideways, beyond `max_offset_deg`) there
//! is no walking direction and the camera's own heading is used, as in the thesis.

use super::config::WalkingFrameConfig;
use super::Motion;

/// Tracks the walking direction relative to the camera heading.
#[derive(Debug, Default, Clone)]
pub struct WalkingHeading {
    /// Recent travel, decayed, expressed in the current camera floor frame, metres.
    travel_m: [f32; 2],
    last_ns: Option<u64>,
    offset_rad: f32,
}

impl WalkingHeading {
    /// Feeds the motion since the previous frame (`None`: unknown, the travel is
    /// forgotten) at `stamp_ns`; returns the walking direction in the camera floor frame,
    /// radians, positive left (0: no walking direction, use the camera heading).
    pub fn update(&mut self, stamp_ns: u64, motion: Option<Motion>, cfg: &WalkingFrameConfig) -> f32 {
        let (Some(m), Some(last)) = (motion, self.last_ns.replace(stamp_ns)) else {
            self.travel_m = [0.0; 2];
            self.offset_rad = 0.0;
            return 0.0;
        };
        if !(cfg.enabled && m.forward_m.is_finite() && m.left_m.is_finite() && m.yaw_rad.is_finite()) {
            self.travel_m = [0.0; 2];
            self.offset_rad = 0.0;
            return 0.0;
        }
        let dt_s = stamp_ns.saturating_sub(last) as f32 * 1e-9;
        let keep = (-dt_s / cfg.tau_s.max(1e-3)).exp();
        // the increment and the kept travel are in the previous frame: add, then turn
        // both into the current frame (rotated by the yaw increment)
        let [x, y] = [self.travel_m[0] * keep + m.forward_m, self.travel_m[1] * keep + m.left_m];
        let (s, c) = (-m.yaw_rad).sin_cos();
        self.travel_m = [c * x - s * y, s * x + c * y];
        // steady walking at v leaves |travel| ~ v * tau
        let speed_m_s = self.travel_m[0].hypot(self.travel_m[1]) / cfg.tau_s.max(1e-3);
        let direction = self.travel_m[1].atan2(self.travel_m[0]);
        self.offset_rad = if speed_m_s >= cfg.min_speed_m_s && direction.abs() <= cfg.max_offset_deg.to_radians() {
            direction
        } else {
            0.0
        };
        self.offset_rad
    }

    /// The last walking direction returned, radians.
    pub fn offset_rad(&self) -> f32 {
        self.offset_rad
    }
}

/// Turns user-frame points by `-offset_rad`, so the walking direction becomes +x.
pub fn to_walking_frame(points: &mut [[f32; 2]], offset_rad: f32) {
    if offset_rad == 0.0 {
        return;
    }
    let (s, c) = (-offset_rad).sin_cos();
    for p in points {
        *p = [c * p[0] - s * p[1], s * p[0] + c * p[1]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAME_NS: u64 = 33_333_333;

    /// A walker at `speed` along the map +x axis with the camera swept by
    /// `amp_deg * sin(2 pi 0.7 t)`; returns (true sweep, estimated offset) per frame.
    fn swept_walk(speed: f32, amp_deg: f32, frames: u32) -> Vec<(f32, f32)> {
        let cfg = WalkingFrameConfig::default();
        let mut h = WalkingHeading::default();
        let sweep = |k: u32| amp_deg.to_radians() * (std::f32::consts::TAU * 0.7 * k as f32 / 30.0).sin();
        let mut out = Vec::new();
        for k in 0..frames {
            let motion = (k > 0).then(|| {
                // previous camera heading sweep(k-1); travel along map +x, seen from it
                let prev = sweep(k - 1);
                let d = speed / 30.0;
                Motion { forward_m: d * prev.cos(), left_m: -d * prev.sin(), yaw_rad: sweep(k) - prev }
            });
            let offset = h.update(k as u64 * FRAME_NS, motion, &cfg);
            // walking direction seen from the camera is minus the sweep
            out.push((-sweep(k), offset));
        }
        out
    }

    #[test]
    fn walking_direction_is_recovered_within_3_deg_under_a_17_deg_sweep() {
        let track = swept_walk(1.0, 17.0, 150);
        for &(want, got) in &track[30..] {
            assert!((want - got).abs().to_degrees() < 3.0, "want {} got {}", want.to_degrees(), got.to_degrees());
        }
    }

    #[test]
    fn standing_still_or_unknown_motion_uses_the_camera_heading() {
        let track = swept_walk(0.0, 17.0, 60);
        assert!(track.iter().all(|&(_, got)| got == 0.0));
        let mut h = WalkingHeading::default();
        let cfg = WalkingFrameConfig::default();
        h.update(0, None, &cfg);
        // walking 1 m/s, 18 deg left of the camera heading, for a third of a second
        let m = Motion { forward_m: 0.0317, left_m: 0.0103, yaw_rad: 0.0 };
        let mut got = 0.0;
        for k in 1..=10 {
            got = h.update(k * FRAME_NS, Some(m), &cfg);
        }
        assert!((got.to_degrees() - 18.0).abs() < 0.5, "{}", got.to_degrees());
        assert_eq!(h.update(11 * FRAME_NS, None, &cfg), 0.0, "lost odometry forgets the direction");
    }

    #[test]
    fn sideways_travel_of_a_turn_in_place_is_not_a_walking_direction() {
        let cfg = WalkingFrameConfig::default();
        let mut h = WalkingHeading::default();
        let mut last = 0.0;
        for k in 0..30u64 {
            // the camera 0.35 m ahead of the body swings left as the user turns at 60 deg/s
            let yaw = 2f32.to_radians();
            let m = Motion { forward_m: 0.0, left_m: 0.35 * yaw, yaw_rad: yaw };
            last = h.update(k * FRAME_NS, (k > 0).then_some(m), &cfg);
        }
        assert_eq!(last, 0.0);
    }

    #[test]
    fn points_turn_so_the_walking_direction_is_straight_ahead() {
        let mut pts = [[1.0f32, 1.0]];
        to_walking_frame(&mut pts, std::f32::consts::FRAC_PI_4);
        assert!((pts[0][0] - 2f32.sqrt()).abs() < 1e-6 && pts[0][1].abs() < 1e-6, "{pts:?}");
    }
}
