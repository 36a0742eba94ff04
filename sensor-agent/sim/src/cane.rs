//! The cane the camera rides on: where the hand holds it, how the camera is mounted
//! below the handle, the side-to-side sweep (Taylor 2017, sec. 2.1 and 3.1: camera
//! a hand-width below the handle, pitched down, users sweeping a shoulder-width arc),
//! and the bob of the hand with each step while walking.

use super::pose::CameraPose;
use super::world::UserPose;

/// Cane geometry, camera mounting and sweep. Defaults from Taylor (2017) and
/// long-cane practice (cane reaching the sternum, tip a step ahead).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaneMount {
    /// Height of the hand on the handle above the floor, metres.
    pub handle_height_m: f64,
    /// How far in front of the body's axis the hand is, metres.
    pub hand_forward_m: f64,
    /// Cane length from handle to tip, metres.
    pub cane_length_m: f64,
    /// Camera distance below the handle along the cane, metres.
    pub camera_below_handle_m: f64,
    /// Camera pitch below the horizontal, degrees.
    pub pitch_deg: f64,
    /// Half the sweep arc, degrees (0 = cane held still).
    pub sweep_amplitude_deg: f64,
    /// Full left-right-left sweeps per second.
    pub sweep_hz: f64,
    /// Sweep phase at t = 0, radians.
    pub sweep_phase_rad: f64,
    /// Vertical bob of the hand at walking speed, metres (amplitude; scales with speed).
    pub bob_m: f64,
    /// Pitch wobble of the camera at walking speed, degrees (amplitude).
    pub bob_pitch_deg: f64,
    /// Steps per second at walking speed (the bob's frequency).
    pub step_hz: f64,
    /// Walking speed at which the bob has its full amplitude, m/s.
    pub bob_speed_m_s: f64,
}

impl Default for CaneMount {
    /// A 1.3 m cane held at 1 m, camera 15 cm below the handle pitched 30 degrees
    /// down, sweeping +-17 degrees (the tip covers a 0.5 m, shoulder-width arc) in
    /// step with a 1 m/s walk (0.7 Hz, one sweep per two steps); at 1 m/s the hand
    /// bobs +-1.5 cm and the camera wobbles +-1.5 degrees in pitch at 1.8 steps/s.
    fn default() -> Self {
        CaneMount {
            handle_height_m: 1.0,
            hand_forward_m: 0.25,
            cane_length_m: 1.3,
            camera_below_handle_m: 0.15,
            pitch_deg: 30.0,
            sweep_amplitude_deg: 17.0,
            sweep_hz: 0.7,
            sweep_phase_rad: 0.0,
            bob_m: 0.015,
            bob_pitch_deg: 1.5,
            step_hz: 1.8,
            bob_speed_m_s: 1.0,
        }
    }
}

impl CaneMount {
    /// The same mount with the cane held still, pointing straight ahead, no bob.
    pub fn still(self) -> Self {
        CaneMount { sweep_amplitude_deg: 0.0, bob_m: 0.0, bob_pitch_deg: 0.0, ..self }
    }

    /// Walking bob at time `t_s` for a walker moving at `speed_m_s`, -1..1 of the full
    /// amplitude at `bob_speed_m_s` (larger when faster, capped at 1.5).
    pub fn bob_at(&self, t_s: f64, speed_m_s: f64) -> f64 {
        let scale = (speed_m_s / self.bob_speed_m_s).clamp(0.0, 1.5);
        scale * (std::f64::consts::TAU * self.step_hz * t_s).sin()
    }

    /// Camera pose as [`CaneMount::camera_pose`], moved by a walking bob (from
    /// [`CaneMount::bob_at`]): the hand higher and the camera tipped less when positive.
    pub fn camera_pose_bobbing(&self, user: &UserPose, sweep_rad: f64, bob: f64) -> CameraPose {
        let still = self.camera_pose(user, sweep_rad);
        let pitch = (self.pitch_deg - bob * self.bob_pitch_deg).to_radians();
        CameraPose::from_yaw_pitch(
            still.position_m.x,
            still.position_m.y,
            still.position_m.z + bob * self.bob_m,
            user.yaw_rad + sweep_rad,
            pitch,
            user.floor,
        )
    }

    /// Sweep angle at time `t_s`, radians, positive left.
    pub fn sweep_rad(&self, t_s: f64) -> f64 {
        self.sweep_amplitude_deg.to_radians()
            * (std::f64::consts::TAU * self.sweep_hz * t_s + self.sweep_phase_rad).sin()
    }

    /// Angle of the cane below the horizontal, radians (tip on the floor).
    pub fn cane_angle_rad(&self) -> f64 {
        (self.handle_height_m / self.cane_length_m).clamp(-1.0, 1.0).asin()
    }

    /// Hand and tip of the cane (map x, y, height) for a user pose and sweep angle.
    pub fn cane_segment(&self, user: &UserPose, sweep_rad: f64) -> ([f64; 3], [f64; 3]) {
        let (sy, cy) = user.yaw_rad.sin_cos();
        let hand = [user.x_m + cy * self.hand_forward_m, user.y_m + sy * self.hand_forward_m, self.handle_height_m];
        let (ss, cs) = (user.yaw_rad + sweep_rad).sin_cos();
        let reach = self.cane_length_m * self.cane_angle_rad().cos();
        let tip =
            [hand[0] + cs * reach, hand[1] + ss * reach, hand[2] - self.cane_length_m * self.cane_angle_rad().sin()];
        (hand, tip)
    }

    /// Camera pose for a user pose and sweep angle: on the cane, looking along it.
    pub fn camera_pose(&self, user: &UserPose, sweep_rad: f64) -> CameraPose {
        let (hand, tip) = self.cane_segment(user, sweep_rad);
        let f = self.camera_below_handle_m / self.cane_length_m;
        let p = [hand[0] + f * (tip[0] - hand[0]), hand[1] + f * (tip[1] - hand[1]), hand[2] + f * (tip[2] - hand[2])];
        CameraPose::from_yaw_pitch(p[0], p[1], p[2], user.yaw_rad + sweep_rad, self.pitch_deg.to_radians(), user.floor)
    }

    /// Camera height above the floor with this mount, metres (the `MountGuess`).
    pub fn camera_height_m(&self) -> f64 {
        self.handle_height_m - self.camera_below_handle_m * self.cane_angle_rad().sin()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_camera_sits_about_88_cm_high_and_tip_touches_floor() {
        let m = CaneMount::default();
        let user = UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 };
        let (_, tip) = m.cane_segment(&user, 0.0);
        assert!(tip[2].abs() < 1e-12);
        let cam = m.camera_pose(&user, 0.0);
        assert!((cam.position_m.z - 0.8846).abs() < 1e-3, "{}", cam.position_m.z);
        assert!((cam.position_m.z - m.camera_height_m()).abs() < 1e-12);
        assert!((cam.pitch_down_rad() - 30f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn walking_bob_raises_the_camera_and_tips_it_up_only_while_moving() {
        let m = CaneMount::default();
        let user = UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 };
        let quarter_step_s = 0.25 / m.step_hz;
        assert_eq!(m.bob_at(quarter_step_s, 0.0), 0.0);
        let bob = m.bob_at(quarter_step_s, 1.0);
        assert!((bob - 1.0).abs() < 1e-12);
        let up = m.camera_pose_bobbing(&user, 0.0, bob);
        assert!((up.position_m.z - m.camera_height_m() - 0.015).abs() < 1e-12);
        assert!((up.pitch_down_rad().to_degrees() - 28.5).abs() < 1e-9);
    }

    #[test]
    fn sweep_moves_the_tip_across_a_shoulder_width_arc() {
        let m = CaneMount::default();
        let user = UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 };
        let (_, left) = m.cane_segment(&user, m.sweep_amplitude_deg.to_radians());
        let (_, right) = m.cane_segment(&user, -m.sweep_amplitude_deg.to_radians());
        let width = left[1] - right[1];
        assert!((0.45..0.55).contains(&width), "arc width {width}");
    }
}
