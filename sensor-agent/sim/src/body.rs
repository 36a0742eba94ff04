//! A simulated IMU worn on the body: a phone on a lanyard at the chest, tilted against
//! it, turning with the walker and swaying with each stride. The compute agent reads
//! the body's turn rate from it (`perception::body_rate`); the cane's IMU cannot give
//! that, it carries the sweep.

use super::pose::CameraPose;
use super::walker::Trajectory;

/// How the device is worn and how the torso sways.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyMount {
    /// Height of the device above the floor, metres.
    pub height_m: f64,
    /// Tilt of the device's z axis below the horizontal, degrees (a phone hanging
    /// against the chest, screen out, looks mostly ahead and a little down).
    pub pitch_deg: f64,
    /// Turn of the device off the body's heading, degrees (worn a little askew).
    pub yaw_offset_deg: f64,
    /// Torso sway each way at walking speed, degrees (scales with speed, capped there).
    pub sway_deg: f64,
    /// Sway frequency (one stride: a step each side), Hz.
    pub sway_hz: f64,
    /// Walking speed at which the sway has its full amplitude, m/s.
    pub sway_speed_m_s: f64,
}

impl Default for BodyMount {
    /// At the chest, 1.3 m up, tilted 20 degrees down and 10 degrees askew; the torso
    /// swings 3 degrees each way at 0.9 Hz when walking at 1 m/s.
    fn default() -> Self {
        BodyMount {
            height_m: 1.3,
            pitch_deg: 20.0,
            yaw_offset_deg: 10.0,
            sway_deg: 3.0,
            sway_hz: 0.9,
            sway_speed_m_s: 1.0,
        }
    }
}

impl BodyMount {
    /// The device's pose at `t_s` (in the same optical-style frame as a camera's: x
    /// right, y down, z out of the screen's back).
    pub fn pose_at(&self, walker: &(impl Trajectory + ?Sized), t_s: f64) -> CameraPose {
        let user = walker.pose_at(t_s);
        let scale = (walker.speed_at(t_s) / self.sway_speed_m_s).clamp(0.0, 1.0);
        let sway = self.sway_deg * scale * (std::f64::consts::TAU * self.sway_hz * t_s).sin();
        let yaw = user.yaw_rad + (self.yaw_offset_deg + sway).to_radians();
        CameraPose::from_yaw_pitch(user.x_m, user.y_m, self.height_m, yaw, self.pitch_deg.to_radians(), user.floor)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;
    use crate::imu::{ImuModel, ImuNoise};
    use crate::random::SimRng;
    use crate::scene::{AtEnd, WalkerSpec};
    use crate::walker::ScriptedWalker;
    use crate::world::UserPose;

    /// Mean rate about gravity over `n` samples from `t0_s`, rad/s positive left.
    fn mean_turn(mount: &BodyMount, walker: &ScriptedWalker, t0_s: f64, n: usize) -> f64 {
        let mut imu = ImuModel::new(ImuNoise::none(), SimRng::seed_from(1));
        let mut sum = 0.0;
        for k in 0..n {
            let t = t0_s + k as f64 * 0.01;
            let (g, a) = imu.sample(t, |t| mount.pose_at(walker, t));
            let up = Vector3::new(a[0] as f64, a[1] as f64, a[2] as f64).normalize();
            sum += Vector3::new(g[0] as f64, g[1] as f64, g[2] as f64).dot(&up);
        }
        sum / n as f64
    }

    #[test]
    fn standing_still_the_device_reads_no_turn_and_gravity_along_its_tilt() {
        let walker = ScriptedWalker::standing(UserPose { x_m: 1.0, y_m: 1.0, yaw_rad: 0.5, floor: 0 });
        let mount = BodyMount::default();
        let pose = mount.pose_at(&walker, 2.0);
        let g = pose.gravity_camera();
        // tilted 20 degrees down: gravity mostly along +y (down the screen), part +z
        assert!((g.y - 20f64.to_radians().cos()).abs() < 1e-9 && (g.z - 20f64.to_radians().sin()).abs() < 1e-9);
        assert!(mean_turn(&mount, &walker, 1.0, 100).abs() < 1e-6);
    }

    #[test]
    fn over_the_walk_the_device_reads_the_walkers_turn_and_the_sway_stays_below_a_turn() {
        // a metre east, a quarter turn left in place at 30 degrees/s, a metre north
        let spec = WalkerSpec {
            waypoints: vec![[1.0, 0.0], [1.0, 1.0]],
            speed_m_s: 1.0,
            turn_rate_deg_s: 30.0,
            at_end: AtEnd::Stop,
        };
        let walker = ScriptedWalker::new(UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 }, &spec);
        let mount = BodyMount::default();
        let n = ((walker.script_duration_s() + 0.5) * 100.0) as usize;
        let turned = mean_turn(&mount, &walker, 0.0, n) * n as f64 * 0.01;
        assert!((turned - std::f64::consts::FRAC_PI_2).abs() < 0.02, "read {turned} rad");
        // walking straight, the sway alone: up to 3 degrees x 2 pi x 0.9 Hz = 17 degrees/s
        let mut imu = ImuModel::new(ImuNoise::none(), SimRng::seed_from(1));
        let peak = (0..60)
            .map(|k| {
                let (g, a) = imu.sample(0.3 + k as f64 * 0.01, |t| mount.pose_at(&walker, t));
                let up = Vector3::new(a[0] as f64, a[1] as f64, a[2] as f64).normalize();
                Vector3::new(g[0] as f64, g[1] as f64, g[2] as f64).dot(&up).abs().to_degrees()
            })
            .fold(0.0, f64::max);
        assert!(peak > 10.0 && peak < 18.0, "sway peaks at {peak} degrees/s");
    }
}
