//! A depth camera worn at the chest (on a harness strap, looking ahead): the second
//! device that sees what hangs at head height, which the cane camera, pitched down from
//! under the handle, never sees. It turns with the body, not with the cane's sweep,
//! and bobs with each step.

use super::pose::CameraPose;
use super::world::UserPose;

/// Where the chest camera is worn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChestMount {
    /// Height above the floor, metres.
    pub height_m: f64,
    /// How far in front of the body's axis, metres.
    pub forward_m: f64,
    /// Pitch below the horizontal, degrees.
    pub pitch_deg: f64,
    /// Vertical bob of the torso at walking speed, metres (amplitude).
    pub bob_m: f64,
}

impl Default for ChestMount {
    /// At the sternum of a 1.75 m adult (1.3 m up, 12 cm ahead of the body's axis),
    /// pitched 10 degrees down: a 45 degree tall view then reaches 1.9 m up 1.5 m ahead
    /// and the floor from 2.1 m on; the torso bobs +-1.5 cm at 1 m/s.
    fn default() -> Self {
        ChestMount { height_m: 1.3, forward_m: 0.12, pitch_deg: 10.0, bob_m: 0.015 }
    }
}

impl ChestMount {
    /// The camera's pose for a user pose and a walking bob (-1..1 of the full amplitude,
    /// as [`super::CaneMount::bob_at`] gives it).
    pub fn camera_pose(&self, user: &UserPose, bob: f64) -> CameraPose {
        let (s, c) = user.yaw_rad.sin_cos();
        CameraPose::from_yaw_pitch(
            user.x_m + c * self.forward_m,
            user.y_m + s * self.forward_m,
            self.height_m + bob * self.bob_m,
            user.yaw_rad,
            self.pitch_deg.to_radians(),
            user.floor,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_chest_camera_looks_along_the_body_from_its_sternum() {
        let user = UserPose { x_m: 2.0, y_m: 1.0, yaw_rad: std::f64::consts::FRAC_PI_2, floor: 1 };
        let pose = ChestMount::default().camera_pose(&user, 1.0);
        assert!((pose.position_m.x - 2.0).abs() < 1e-9 && (pose.position_m.y - 1.12).abs() < 1e-9);
        assert!((pose.position_m.z - 1.315).abs() < 1e-9);
        assert!((pose.yaw_rad() - user.yaw_rad).abs() < 1e-9);
        assert!((pose.pitch_down_rad().to_degrees() - 10.0).abs() < 1e-9);
        assert_eq!(pose.floor, 1);
    }
}
