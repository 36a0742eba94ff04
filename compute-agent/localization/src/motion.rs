//! The motion model: odometry increments (visual odometry on the cane, wheel odometry
//! in the Intel log) and an optional IMU yaw rate move every particle, with noise that
//! grows with the motion. AMCL's odometry model (Thrun, Burgard & Fox, *Probabilistic
//! Robotics*, table 5.6; `amcl_odom.cpp`, model "diff"): a motion is split into a turn
//! towards the displacement (`rot1`), the displacement (`trans`) and a final turn
//! (`rot2`), perturbed by Gaussians whose standard deviations are
//! `sqrt(alpha_i * rot^2 + alpha_j * trans^2)`. A sideways step (a person can side-step)
//! is a `rot1` of +-90 degrees, taken the short way as AMCL does for reversing.
//!
//! One change from AMCL: the heading's noise grows with the *total* turn
//! (`rot1 + rot2`), not with `rot1` and `rot2` separately. On a turn on the spot with a
//! few centimetres of shuffle (a person turning; the Intel robot's 30-degree turns with
//! 4 cm of drift) AMCL's split makes `rot1` and `rot2` +-60 to 90 degrees each and the
//! heading noise ~28 degrees for a 30-degree turn; here it is `sqrt(alpha1) * 30`
//! degrees. `rot1`'s own noise still perturbs the direction of travel.
//!
//! The IMU (Zhang et al.: "IMU limits heading drift"): a gyro integrates yaw far better
//! over seconds than visual odometry does, so when a yaw rate comes with an increment
//! the heading change is the gyro's, and the rotation noise is the gyro's
//! (`imu_yaw_sigma_rad_per_sqrt_s * sqrt(dt)`) plus a fraction of the odometry's.

use serde::{Deserialize, Serialize};

use crate::pose::{fast_sin_cos, wrap_angle, Pose2};
use crate::rng::Rng;

/// One odometry increment, in the body frame at the start of the interval.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OdometryIncrement {
    /// metres moved forward
    pub forward_m: f64,
    /// metres moved to the left
    pub left_m: f64,
    /// radians turned counter-clockwise
    pub yaw_rad: f64,
    /// length of the interval, seconds (the caller's clock; used with the IMU rate)
    pub dt_s: f64,
}

impl OdometryIncrement {
    /// Why this increment must not be applied, if it must not: a non-finite value,
    /// a negative interval, or a jump faster than `max_speed_m_s` / `max_yaw_rate_rad_s`
    /// (the "5 m in 30 ms").
    pub fn implausible(&self, max_speed_m_s: f64, max_yaw_rate_rad_s: f64) -> Option<&'static str> {
        let v = [self.forward_m, self.left_m, self.yaw_rad, self.dt_s];
        if v.iter().any(|x| !x.is_finite()) {
            return Some("non-finite odometry increment");
        }
        if self.dt_s < 0.0 {
            return Some("negative odometry interval");
        }
        // a small floor on dt so a zero-length interval with no motion is fine
        let dt = self.dt_s.max(0.05);
        if self.forward_m.hypot(self.left_m) > max_speed_m_s * dt {
            return Some("odometry jump faster than a walking person");
        }
        if self.yaw_rad.abs() > max_yaw_rate_rad_s * dt {
            return Some("odometry turn faster than a person turns");
        }
        None
    }
}

/// AMCL's odometry noise parameters (its names and defaults: `odom_alpha1..4` = 0.2).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MotionNoise {
    /// rotation noise from rotation
    pub alpha1: f64,
    /// rotation noise from translation
    pub alpha2: f64,
    /// translation noise from translation
    pub alpha3: f64,
    /// translation noise from rotation
    pub alpha4: f64,
    /// gyro yaw noise, radians per sqrt(second) (a consumer MEMS gyro's angle random walk
    /// is ~0.3 deg/sqrt(s); we allow bias too)
    pub imu_yaw_sigma_rad_per_sqrt_s: f64,
    /// fraction of the odometry's rotation noise kept when the IMU gives the yaw
    pub imu_odometry_rotation_share: f64,
}

impl Default for MotionNoise {
    fn default() -> Self {
        Self {
            alpha1: 0.2,
            alpha2: 0.2,
            alpha3: 0.2,
            alpha4: 0.2,
            imu_yaw_sigma_rad_per_sqrt_s: 0.01,
            imu_odometry_rotation_share: 0.2,
        }
    }
}

/// A motion split AMCL's way: turn, move straight, turn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotTransRot {
    /// first turn, radians
    pub rot1: f64,
    /// straight displacement, metres (negative when walking backwards)
    pub trans: f64,
    /// second turn, radians
    pub rot2: f64,
}

impl RotTransRot {
    /// The split of a body-frame motion. Below 1 cm `rot1` is 0 (the direction of a
    /// tiny displacement is noise). Backwards and sideways are taken the short way.
    pub fn from_motion(forward_m: f64, left_m: f64, yaw_rad: f64) -> Self {
        let dist = forward_m.hypot(left_m);
        if dist < 0.01 {
            return Self { rot1: 0.0, trans: dist.copysign(forward_m), rot2: yaw_rad };
        }
        let mut rot1 = left_m.atan2(forward_m);
        let mut trans = dist;
        if rot1.abs() > std::f64::consts::FRAC_PI_2 {
            rot1 = wrap_angle(rot1 + std::f64::consts::PI);
            trans = -dist;
        }
        Self { rot1, trans, rot2: wrap_angle(yaw_rad - rot1) }
    }
}

/// Moves `pose` by a noisy draw of the motion. `imu_yaw_rad` is the gyro's integrated
/// yaw over the same interval, if any; `dt_s` its length.
pub fn sample_motion(
    pose: &Pose2,
    motion: &RotTransRot,
    imu_yaw_rad: Option<f64>,
    dt_s: f64,
    noise: &MotionNoise,
    rng: &mut Rng,
) -> Pose2 {
    MotionDraw::new(motion, imu_yaw_rad, dt_s, noise).sample(pose, rng)
}

/// One motion's means and spreads, worked out once for every particle of an update.
#[derive(Clone, Copy, Debug)]
pub struct MotionDraw {
    rot1: f64,
    trans: f64,
    total: f64,
    sd_trans: f64,
    sd_rot1: f64,
    sd_total: f64,
}

impl MotionDraw {
    /// The draw of `motion` (and the gyro's yaw over `dt_s`, if any) under `noise`.
    pub fn new(motion: &RotTransRot, imu_yaw_rad: Option<f64>, dt_s: f64, noise: &MotionNoise) -> Self {
        let RotTransRot { rot1, trans, rot2 } = *motion;
        // AMCL takes the smaller of a turn and its reverse, so reversing is not "a big turn"
        let small = |r: f64| r.abs().min((std::f64::consts::PI - r.abs()).abs());
        let t = trans.abs();
        let yaw = wrap_angle(rot1 + rot2);
        let sd_rot = |r: f64| (noise.alpha1 * r * r + noise.alpha2 * t * t).sqrt();
        let sd_trans = (noise.alpha3 * t * t + noise.alpha4 * yaw * yaw).sqrt();
        // the direction of travel is perturbed as AMCL's rot1; the total turn by a noise
        // that grows with the total turn (see the module doc)
        let sd_rot1 = sd_rot(small(rot1));
        let (total, sd_total) = match imu_yaw_rad {
            None => (yaw, sd_rot(yaw.abs())),
            Some(gyro) => {
                let share = noise.imu_odometry_rotation_share;
                (gyro, (noise.imu_yaw_sigma_rad_per_sqrt_s * dt_s.max(0.0).sqrt()).hypot(share * sd_rot(gyro.abs())))
            }
        };
        Self { rot1, trans, total, sd_trans, sd_rot1, sd_total }
    }

    /// `pose` moved by one noisy draw.
    #[inline]
    pub fn sample(&self, pose: &Pose2, rng: &mut Rng) -> Pose2 {
        let trans_hat = self.trans + rng.normal(self.sd_trans);
        let rot1_hat = self.rot1 + rng.normal(self.sd_rot1);
        let total = self.total + rng.normal(self.sd_total);
        // = pose.compose(0, 0, rot1_hat).compose(trans_hat, 0, total - rot1_hat), one sin_cos
        let (s, c) = fast_sin_cos(pose.heading_rad + rot1_hat);
        Pose2::new(pose.x_m + trans_hat * c, pose.y_m + trans_hat * s, pose.heading_rad + total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noiseless_motion_is_exact_forward_sideways_and_backwards() {
        let noise = MotionNoise { alpha1: 0.0, alpha2: 0.0, alpha3: 0.0, alpha4: 0.0, ..Default::default() };
        let mut rng = Rng::new(1);
        let p = Pose2::new(1.0, 2.0, 0.3);
        for (f, l, y) in [(1.0, 0.0, 0.2), (0.0, 0.5, 0.0), (-0.8, 0.1, -0.4), (0.001, 0.0, 1.0)] {
            let m = RotTransRot::from_motion(f, l, y);
            let q = sample_motion(&p, &m, None, 0.1, &noise, &mut rng);
            let want = p.compose(f, l, y);
            assert!(q.distance_m(&want) < 0.011, "{f} {l} {y}: {q:?} vs {want:?}");
            assert!(wrap_angle(q.heading_rad - want.heading_rad).abs() < 1e-9);
        }
    }

    #[test]
    fn imu_yaw_replaces_a_drifting_odometry_yaw() {
        let noise = MotionNoise::default();
        let mut rng = Rng::new(3);
        let p = Pose2::default();
        // odometry says it turned 0.5 rad, the gyro says 0.1
        let m = RotTransRot::from_motion(1.0, 0.0, 0.5);
        let n = 2000;
        let mean: f64 =
            (0..n).map(|_| sample_motion(&p, &m, Some(0.1), 1.0, &noise, &mut rng).heading_rad).sum::<f64>() / n as f64;
        assert!((mean - 0.1).abs() < 0.01, "mean heading {mean}");
    }

    #[test]
    fn jumps_and_nan_are_implausible() {
        let jump = OdometryIncrement { forward_m: 5.0, left_m: 0.0, yaw_rad: 0.0, dt_s: 0.03 };
        assert!(jump.implausible(3.0, 6.0).is_some());
        let nan = OdometryIncrement { forward_m: f64::NAN, ..Default::default() };
        assert!(nan.implausible(3.0, 6.0).is_some());
        let walk = OdometryIncrement { forward_m: 0.04, left_m: 0.0, yaw_rad: 0.01, dt_s: 0.03 };
        assert!(walk.implausible(3.0, 6.0).is_none());
    }
}
