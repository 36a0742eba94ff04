//! Odometry increments held until the frame they lead up to.
//!
//! Increments and frames arrive on separate keys, in any order. Each frame takes the
//! steps that end at or before its capture stamp, so a frame never gets a later frame's
//! motion nor loses its own to the order the two arrive in.

use schemas::OdomIncrement;

use super::Motion;

/// Largest step one odometry increment may report, metres and radians: far beyond
/// anything a walking user does between two frames (30 Hz), far below what would wreck
/// the memory's map (a finite but absurd step moves every remembered cell for good).
pub const MAX_STEP_M: f32 = 2.0;
/// Largest turn one increment may report, radians.
pub const MAX_STEP_RAD: f32 = std::f32::consts::PI;
/// Increments held for frames not yet arrived; beyond this the oldest two are merged.
pub const MAX_PENDING_STEPS: usize = 64;
/// A step ending this far after a frame's capture is on another clock: it is taken in
/// the order it arrived, as if it had no stamp.
const OTHER_CLOCK_NS: u64 = 1_000_000_000;

/// An odometry increment that cannot be a walking user's motion.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("odometry step of {forward_m} m forward, {left_m} m left, {yaw_rad} rad over {from_ns}..{to_ns} ns is not a walking user's")]
pub struct ImplausibleStep {
    from_ns: u64,
    to_ns: u64,
    forward_m: f32,
    left_m: f32,
    yaw_rad: f32,
}

impl ImplausibleStep {
    /// Reject counter name.
    pub fn kind(&self) -> &'static str {
        "odom_implausible"
    }
}

/// Planar motion reported by odometry, held until the frame it leads up to.
#[derive(Debug, Default, Clone)]
pub struct MotionSince {
    /// (end stamp, motion), in arrival order.
    pending: Vec<(u64, Motion)>,
}

impl MotionSince {
    /// Holds `inc` for the frame it leads up to; refuses (and forgets) a step no walking
    /// user makes.
    pub fn add(&mut self, inc: &OdomIncrement) -> Result<(), ImplausibleStep> {
        let m = Motion { forward_m: inc.forward_m, left_m: inc.left_m, yaw_rad: inc.yaw_rad };
        if !(m.is_finite() && m.forward_m.hypot(m.left_m) <= MAX_STEP_M && m.yaw_rad.abs() <= MAX_STEP_RAD) {
            let &OdomIncrement { from_ns, to_ns, forward_m, left_m, yaw_rad } = inc;
            return Err(ImplausibleStep { from_ns, to_ns, forward_m, left_m, yaw_rad });
        }
        if self.pending.len() >= MAX_PENDING_STEPS {
            // no frame for a while: keep the motion, in fewer pieces
            let (_, first) = self.pending.remove(0);
            self.pending[0].1 = first.then(self.pending[0].1);
        }
        self.pending.push((inc.to_ns, m));
        Ok(())
    }

    /// The motion of every step ending at or before `capture_ns`, composed in order.
    pub fn take_until(&mut self, capture_ns: u64) -> Option<Motion> {
        let mut total: Option<Motion> = None;
        self.pending.retain(|&(to_ns, m)| {
            let due = to_ns <= capture_ns || to_ns - capture_ns > OTHER_CLOCK_NS;
            if due {
                total = Some(m.after(total));
            }
            !due
        });
        total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odometry_increments_compose_in_the_first_frame() {
        let mut m = MotionSince::default();
        let quarter = std::f32::consts::FRAC_PI_2;
        m.add(&OdomIncrement { from_ns: 0, to_ns: 1, forward_m: 1.0, left_m: 0.0, yaw_rad: quarter }).unwrap();
        m.add(&OdomIncrement { from_ns: 1, to_ns: 2, forward_m: 1.0, left_m: 0.0, yaw_rad: 0.0 }).unwrap();
        let total = m.take_until(2).unwrap();
        assert!((total.forward_m - 1.0).abs() < 1e-5, "{total:?}");
        assert!((total.left_m - 1.0).abs() < 1e-5, "{total:?}");
        assert!((total.yaw_rad - quarter).abs() < 1e-6);
        assert!(m.take_until(2).is_none(), "taking resets the accumulator");
    }

    #[test]
    fn a_frame_takes_only_the_steps_that_end_by_its_capture() {
        let mut m = MotionSince::default();
        let step =
            |to_ns, forward_m| OdomIncrement { from_ns: to_ns - 33, to_ns, forward_m, left_m: 0.0, yaw_rad: 0.0 };
        // the step ending at frame 2 arrived before frame 1 was processed
        m.add(&step(33, 0.03)).unwrap();
        m.add(&step(66, 0.04)).unwrap();
        assert_eq!(m.take_until(33).map(|t| t.forward_m), Some(0.03));
        assert_eq!(m.take_until(66).map(|t| t.forward_m), Some(0.04));
        assert_eq!(m.take_until(99), None);
        // odometry on a clock seconds ahead of the camera's: taken as it comes
        m.add(&step(5_000_000_099, 0.05)).unwrap();
        assert_eq!(m.take_until(99).map(|t| t.forward_m), Some(0.05));
    }

    #[test]
    fn absurd_odometry_is_refused_and_leaves_the_motion_alone() {
        let mut m = MotionSince::default();
        let inc = |forward_m, yaw_rad| OdomIncrement { from_ns: 0, to_ns: 33, forward_m, left_m: 0.0, yaw_rad };
        m.add(&inc(0.03, 0.1)).unwrap();
        let e = m.add(&inc(1e17, 0.0)).unwrap_err();
        assert!(e.to_string().contains("not a walking user's"), "{e}");
        assert!(m.add(&inc(0.0, 7.0)).is_err());
        assert!(m.add(&inc(f32::NAN, 0.0)).is_err());
        let total = m.take_until(33).unwrap();
        assert_eq!((total.forward_m, total.yaw_rad), (0.03, 0.1));
    }

    #[test]
    fn steps_held_without_frames_are_merged_not_lost() {
        let mut m = MotionSince::default();
        for k in 1..=200u64 {
            m.add(&OdomIncrement { from_ns: k - 1, to_ns: k, forward_m: 0.01, left_m: 0.0, yaw_rad: 0.0 }).unwrap();
        }
        assert!(m.pending.len() <= MAX_PENDING_STEPS);
        let total = m.take_until(200).unwrap();
        assert!((total.forward_m - 2.0).abs() < 1e-4, "{total:?}");
    }
}
