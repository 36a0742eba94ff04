//! Simulated IMU on the camera: angular rate and specific force of the true camera
//! motion, in the camera optical frame, plus a constant per-run bias and white noise
//! of the size of a consumer MEMS part (MPU-6050 class: about 0.005 deg/s/sqrt(Hz)
//! gyro and 400 ug/sqrt(Hz) accelerometer noise density; biases of a few 0.1 deg/s
//! and a few 0.01 m/s^2 after factory calibration).

use nalgebra::{Rotation3, Vector3};

use super::pose::CameraPose;
use super::random::SimRng;

/// Standard gravity, m/s^2.
pub const GRAVITY_M_S2: f64 = 9.81;
/// Time step of the finite differences that recover rates from poses, seconds.
const DIFF_STEP_S: f64 = 1e-3;

/// Error sizes of the simulated IMU (1 sigma).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuNoise {
    /// Per-run constant gyro bias, rad/s.
    pub gyro_bias_rad_s: f64,
    /// White gyro noise per sample, rad/s.
    pub gyro_noise_rad_s: f64,
    /// Per-run constant accelerometer bias, m/s^2.
    pub accel_bias_m_s2: f64,
    /// White accelerometer noise per sample, m/s^2.
    pub accel_noise_m_s2: f64,
}

impl Default for ImuNoise {
    /// MPU-6050-class figures at 200 Hz (noise density times sqrt(bandwidth)).
    fn default() -> Self {
        ImuNoise { gyro_bias_rad_s: 0.005, gyro_noise_rad_s: 0.001, accel_bias_m_s2: 0.05, accel_noise_m_s2: 0.04 }
    }
}

impl ImuNoise {
    /// A perfect IMU.
    pub fn none() -> Self {
        ImuNoise { gyro_bias_rad_s: 0.0, gyro_noise_rad_s: 0.0, accel_bias_m_s2: 0.0, accel_noise_m_s2: 0.0 }
    }
}

/// One simulated IMU with its biases drawn for this run.
#[derive(Debug, Clone)]
pub struct ImuModel {
    noise: ImuNoise,
    gyro_bias: Vector3<f64>,
    accel_bias: Vector3<f64>,
    rng: SimRng,
}

impl ImuModel {
    /// An IMU whose biases and noise come from `rng`.
    pub fn new(noise: ImuNoise, mut rng: SimRng) -> Self {
        let mut draw = |s: f64| Vector3::new(rng.gaussian() * s, rng.gaussian() * s, rng.gaussian() * s);
        let gyro_bias = draw(noise.gyro_bias_rad_s);
        let accel_bias = draw(noise.accel_bias_m_s2);
        ImuModel { noise, gyro_bias, accel_bias, rng }
    }

    /// Gyro (rad/s) and accelerometer (m/s^2) readings at `t_s` for a camera moving
    /// along `pose_at`, in the camera frame. At rest the accelerometer reads +9.81
    /// pointing away from the floor.
    pub fn sample(&mut self, t_s: f64, pose_at: impl Fn(f64) -> CameraPose) -> ([f32; 3], [f32; 3]) {
        let h = DIFF_STEP_S;
        let (before, now, after) = (pose_at(t_s - h), pose_at(t_s), pose_at(t_s + h));
        let turn = before.camera_to_map.inverse() * after.camera_to_map;
        let gyro = rotation_vector(&turn) / (2.0 * h);
        let accel_map = (after.position_m - 2.0 * now.position_m + before.position_m) / (h * h);
        let specific_map = accel_map - Vector3::new(0.0, 0.0, -GRAVITY_M_S2);
        let accel = now.camera_to_map.inverse() * specific_map;
        let n = self.noise;
        let mut noisy = |v: Vector3<f64>, bias: Vector3<f64>, sigma: f64| {
            let r = v + bias;
            [
                (r.x + self.rng.gaussian() * sigma) as f32,
                (r.y + self.rng.gaussian() * sigma) as f32,
                (r.z + self.rng.gaussian() * sigma) as f32,
            ]
        };
        let g = noisy(gyro, self.gyro_bias, n.gyro_noise_rad_s);
        let a = noisy(accel, self.accel_bias, n.accel_noise_m_s2);
        (g, a)
    }
}

/// The rotation's axis times its angle. nalgebra takes the angle from the trace with an
/// arc cosine it does not clamp: for a turn of a few nanoradians (a walker starting or
/// ending a turn) the trace can round above 3 and the angle is NaN. There the skew part
/// alone is the rotation vector (sin θ = θ to far below rounding).
fn rotation_vector(r: &Rotation3<f64>) -> Vector3<f64> {
    let v = r.scaled_axis();
    if v.iter().all(|c| c.is_finite()) {
        return v;
    }
    let m = r.matrix();
    Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]) / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cane::CaneMount;
    use crate::world::UserPose;

    #[test]
    fn imu_at_rest_reads_gravity_away_from_the_floor() {
        let mount = CaneMount::default().still();
        let user = UserPose { x_m: 1.0, y_m: 2.0, yaw_rad: 0.4, floor: 0 };
        let pose = mount.camera_pose(&user, 0.0);
        let mut imu = ImuModel::new(ImuNoise::default(), SimRng::seed_from(3));
        let n = 200;
        let mut accel = Vector3::zeros();
        let mut gyro = Vector3::zeros();
        for k in 0..n {
            let (g, a) = imu.sample(k as f64 / 200.0, |_| pose);
            accel += Vector3::new(a[0] as f64, a[1] as f64, a[2] as f64) / n as f64;
            gyro += Vector3::new(g[0] as f64, g[1] as f64, g[2] as f64) / n as f64;
        }
        assert!((accel.norm() - GRAVITY_M_S2).abs() < 0.2, "|a| = {}", accel.norm());
        let up = -pose.gravity_camera();
        assert!(accel.normalize().dot(&up) > 0.999, "accel {accel} vs up {up}");
        // 30 degrees pitched down: gravity splits between image-down (y) and forward (z),
        // so the reading points image-up (-y) and backwards (-z).
        assert!(accel.y < -8.0 && accel.z < -4.0, "{accel}");
        assert!(gyro.norm() < 0.03, "gyro at rest {gyro}");
    }

    #[test]
    fn a_turn_of_a_few_nanoradians_reads_as_a_rate_and_never_as_nan() {
        // a walker that barely turns (starting or stopping a turn): over the 2 ms of the
        // difference the camera turns by nanoradians, where the rotation's trace rounds
        // above 3 for some headings
        let mut imu = ImuModel::new(ImuNoise::none(), SimRng::seed_from(1));
        for k in 0..20_000 {
            let yaw0 = k as f64 * 0.000_314;
            let rate = 1e-6 * (1 + k % 7) as f64;
            let pose = |t: f64| CameraPose::from_yaw_pitch(1.0, 2.0, 0.9, yaw0 + rate * t, 0.5, 0);
            let (g, _) = imu.sample(0.0, pose);
            let norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt() as f64;
            assert!(g.iter().all(|v| v.is_finite()), "heading {yaw0} rate {rate}: gyro {g:?}");
            // the rotation's angle comes from an arc cosine near 1: it resolves about
            // 2e-8 rad, 1e-5 rad/s over the difference's 2 ms
            assert!((norm - rate).abs() < 1e-5, "heading {yaw0} rate {rate}: gyro {g:?}");
        }
    }

    #[test]
    fn sweeping_cane_shows_up_as_rate_about_the_vertical() {
        let mount = CaneMount::default();
        let user = UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 };
        let mut imu = ImuModel::new(ImuNoise::none(), SimRng::seed_from(1));
        let (g, _) = imu.sample(0.0, |t| mount.camera_pose(&user, mount.sweep_rad(t)));
        // Peak sweep rate at t = 0: amplitude * 2 pi f, about the map's vertical axis,
        // which in the pitched camera frame is -y cos(pitch) - z sin(pitch).
        let rate = mount.sweep_amplitude_deg.to_radians() * std::f64::consts::TAU * mount.sweep_hz;
        let pitch = mount.pitch_deg.to_radians();
        assert!((g[1] as f64 + rate * pitch.cos()).abs() < 1e-3, "{g:?}");
        assert!((g[2] as f64 + rate * pitch.sin()).abs() < 1e-3, "{g:?}");
    }
}
