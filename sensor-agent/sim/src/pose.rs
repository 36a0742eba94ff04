//! Where the depth camera is: position and orientation in the map frame of one floor.
//!
//! Camera optical frame: x right, y down, z forward. Map frame: x, y on the floor, z up,
//! z = 0 on the camera's floor.

use nalgebra::{Matrix3, Rotation3, Vector3};

/// Pose of the camera in the map frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPose {
    /// Optical centre: map x, y and height above the floor, metres.
    pub position_m: Vector3<f64>,
    /// Rotation taking camera-frame vectors to map-frame vectors.
    pub camera_to_map: Rotation3<f64>,
    /// Floor index.
    pub floor: i32,
}

impl CameraPose {
    /// A camera at (x, y, height) looking along `yaw_rad` (counter-clockwise from +x),
    /// tipped down by `pitch_down_rad`, without roll.
    pub fn from_yaw_pitch(x_m: f64, y_m: f64, height_m: f64, yaw_rad: f64, pitch_down_rad: f64, floor: i32) -> Self {
        let (sy, cy) = yaw_rad.sin_cos();
        let (sp, cp) = pitch_down_rad.sin_cos();
        let forward = Vector3::new(cp * cy, cp * sy, -sp);
        let right = Vector3::new(sy, -cy, 0.0);
        let down = forward.cross(&right);
        let m = Matrix3::from_columns(&[right, down, forward]);
        CameraPose {
            position_m: Vector3::new(x_m, y_m, height_m),
            camera_to_map: Rotation3::from_matrix_unchecked(m),
            floor,
        }
    }

    /// Unit gravity direction (towards the floor) in the camera frame.
    pub fn gravity_camera(&self) -> Vector3<f64> {
        self.camera_to_map.inverse() * Vector3::new(0.0, 0.0, -1.0)
    }

    /// Angle of the optical axis below the horizontal, radians.
    pub fn pitch_down_rad(&self) -> f64 {
        let forward = self.camera_to_map * Vector3::z();
        (-forward.z).clamp(-1.0, 1.0).asin()
    }

    /// Heading of the optical axis projected on the floor, radians.
    pub fn yaw_rad(&self) -> f64 {
        let forward = self.camera_to_map * Vector3::z();
        forward.y.atan2(forward.x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pitched_camera_sees_gravity_down_and_forward_in_its_frame() {
        let p = CameraPose::from_yaw_pitch(0.0, 0.0, 1.0, 0.7, 30f64.to_radians(), 0);
        let g = p.gravity_camera();
        // Tipped 30 degrees down: gravity is mostly +y (down in the image) and part +z.
        assert!((g.y - 30f64.to_radians().cos()).abs() < 1e-12, "{g}");
        assert!((g.z - 30f64.to_radians().sin()).abs() < 1e-12, "{g}");
        assert!(g.x.abs() < 1e-12);
        assert!((p.pitch_down_rad() - 30f64.to_radians()).abs() < 1e-12);
        assert!((p.yaw_rad() - 0.7).abs() < 1e-12);
    }
}
