//! Simulated visual odometry: the user's true planar motion between frames, in the
//! user frame at the start of the interval, with the errors of a VO front end — a
//! per-run scale error, noise proportional to the motion, and a slow heading drift
//! (Zhang et al.'s VO + IMU motion model expects drift of this kind).

use schemas::OdomIncrement;

use super::random::SimRng;
use super::walker::wrap_pi;
use super::world::UserPose;

/// Error sizes of the simulated odometry (1 sigma).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryNoise {
    /// Per-run scale error of translations (0.01 = 1 %).
    pub scale: f64,
    /// Translation noise per metre moved, metres.
    pub translation_per_m: f64,
    /// Heading noise per radian turned, radians.
    pub yaw_per_rad: f64,
    /// Heading noise per metre moved, radians.
    pub yaw_per_m: f64,
    /// Per-run constant heading drift rate, rad/s.
    pub yaw_drift_rad_s: f64,
}

impl Default for OdometryNoise {
    /// Typical indoor VO: 1 % scale, 2 % noise per step, about 1 degree of heading
    /// drift per minute.
    fn default() -> Self {
        OdometryNoise {
            scale: 0.01,
            translation_per_m: 0.02,
            yaw_per_rad: 0.01,
            yaw_per_m: 0.002,
            yaw_drift_rad_s: 3e-4,
        }
    }
}

impl OdometryNoise {
    /// Perfect odometry.
    pub fn none() -> Self {
        OdometryNoise { scale: 0.0, translation_per_m: 0.0, yaw_per_rad: 0.0, yaw_per_m: 0.0, yaw_drift_rad_s: 0.0 }
    }

    /// Every error `factor` times as large (2: a front end half as good).
    pub fn scaled(self, factor: f64) -> Self {
        OdometryNoise {
            scale: self.scale * factor,
            translation_per_m: self.translation_per_m * factor,
            yaw_per_rad: self.yaw_per_rad * factor,
            yaw_per_m: self.yaw_per_m * factor,
            yaw_drift_rad_s: self.yaw_drift_rad_s * factor,
        }
    }
}

/// One simulated odometry source with its per-run errors drawn.
#[derive(Debug, Clone)]
pub struct OdometryModel {
    noise: OdometryNoise,
    scale: f64,
    yaw_drift_rad_s: f64,
    rng: SimRng,
}

impl OdometryModel {
    /// Odometry whose errors come from `rng`.
    pub fn new(noise: OdometryNoise, mut rng: SimRng) -> Self {
        let scale = 1.0 + rng.gaussian() * noise.scale;
        let yaw_drift_rad_s = rng.gaussian() * noise.yaw_drift_rad_s;
        OdometryModel { noise, scale, yaw_drift_rad_s, rng }
    }

    /// The measured motion from `from` (at `from_ns`) to `to` (at `to_ns`).
    pub fn increment(&mut self, from: &UserPose, to: &UserPose, from_ns: u64, to_ns: u64) -> OdomIncrement {
        let (s, c) = from.yaw_rad.sin_cos();
        let (dx, dy) = (to.x_m - from.x_m, to.y_m - from.y_m);
        let forward = c * dx + s * dy;
        let left = -s * dx + c * dy;
        let yaw = wrap_pi(to.yaw_rad - from.yaw_rad);
        let moved = dx.hypot(dy);
        let dt_s = to_ns.saturating_sub(from_ns) as f64 * 1e-9;
        let n = self.noise;
        let trans_sigma = n.translation_per_m * moved;
        let yaw_sigma = n.yaw_per_rad * yaw.abs() + n.yaw_per_m * moved;
        OdomIncrement {
            from_ns,
            to_ns,
            forward_m: (forward * self.scale + self.rng.gaussian() * trans_sigma) as f32,
            left_m: (left * self.scale + self.rng.gaussian() * trans_sigma) as f32,
            yaw_rad: (yaw + self.yaw_drift_rad_s * dt_s + self.rng.gaussian() * yaw_sigma) as f32,
        }
    }
}

/// Applies an increment to a pose (dead reckoning), the inverse of
/// [`OdometryModel::increment`] without noise.
pub fn integrate(pose: &UserPose, inc: &OdomIncrement) -> UserPose {
    let (s, c) = pose.yaw_rad.sin_cos();
    let (f, l) = (inc.forward_m as f64, inc.left_m as f64);
    UserPose {
        x_m: pose.x_m + c * f - s * l,
        y_m: pose.y_m + s * f + c * l,
        yaw_rad: wrap_pi(pose.yaw_rad + inc.yaw_rad as f64),
        floor: pose.floor,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{AtEnd, WalkerSpec};
    use crate::walker::ScriptedWalker;

    /// Dead-reckons a walk of the taylor-course shape sampled at 30 Hz; returns the
    /// final position error and the distance walked.
    fn dead_reckoning_error(noise: OdometryNoise, seed: u64) -> (f64, f64) {
        let start = UserPose { x_m: 0.7, y_m: 5.0, yaw_rad: 0.0, floor: 0 };
        let spec = WalkerSpec {
            waypoints: vec![[2.0, 5.0], [2.0, 8.5], [5.4, 8.5], [5.4, 1.5], [8.0, 1.5], [8.8, 9.0]],
            speed_m_s: 1.0,
            turn_rate_deg_s: 90.0,
            at_end: AtEnd::Stop,
        };
        let walker = ScriptedWalker::new(start, &spec);
        let mut odom = OdometryModel::new(noise, SimRng::seed_from(seed));
        let frame_ns = 33_333_333u64;
        let frames = (walker.script_duration_s() * 1e9 / frame_ns as f64).ceil() as u64;
        let mut estimate = start;
        let mut walked = 0.0;
        let mut prev = start;
        for k in 1..=frames {
            let now = walker.pose_at((k * frame_ns) as f64 * 1e-9);
            let inc = odom.increment(&prev, &now, (k - 1) * frame_ns, k * frame_ns);
            estimate = integrate(&estimate, &inc);
            walked += (now.x_m - prev.x_m).hypot(now.y_m - prev.y_m);
            prev = now;
        }
        ((estimate.x_m - prev.x_m).hypot(estimate.y_m - prev.y_m), walked)
    }

    #[test]
    fn perfect_odometry_integrates_to_the_true_path() {
        let (error_m, walked_m) = dead_reckoning_error(OdometryNoise::none(), 1);
        assert!(walked_m > 20.0, "{walked_m}");
        assert!(error_m < 1e-4, "error {error_m} m");
    }

    #[test]
    fn noisy_odometry_drifts_within_five_percent_of_distance() {
        let mut worst: f64 = 0.0;
        for seed in 1..=8 {
            let (error_m, walked_m) = dead_reckoning_error(OdometryNoise::default(), seed);
            worst = worst.max(error_m / walked_m);
        }
        assert!(worst < 0.05, "worst drift {:.1} % of distance", worst * 100.0);
        // And it does drift: the noise is not silently off.
        let (error_m, _) = dead_reckoning_error(OdometryNoise::default(), 2);
        assert!(error_m > 0.01, "{error_m}");
    }

    #[test]
    fn scaled_noise_drifts_that_many_times_as_far() {
        // the same draws with every error doubled: each walk's error near twice as
        // large (the errors are linear in the noise for small angles)
        let doubled = OdometryNoise::default().scaled(2.0);
        assert_eq!(doubled.scale, 0.02);
        assert_eq!(OdometryNoise::default().scaled(0.0), OdometryNoise::none());
        for seed in 1..=8 {
            let (once, _) = dead_reckoning_error(OdometryNoise::default(), seed);
            let (twice, _) = dead_reckoning_error(doubled, seed);
            assert!((twice / once - 2.0).abs() < 0.2, "seed {seed}: {once:.3} m -> {twice:.3} m");
        }
    }
}
