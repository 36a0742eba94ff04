//! Depth camera models: resolution, field of view, range limits and noise of the
//! structured-light Asus Xtion Pro Live used by Taylor (2017, sec. 2.1) and of an
//! Intel RealSense D435 active stereo camera.
//!
//! Noise: the axial error of structured light and stereo grows with the square of the
//! range (Khoshelham & Elberink 2012, "Accuracy and resolution of Kinect depth data",
//! Sensors 12(2): sigma ~ 1.4 mm at 1 m, ~ 2.9 cm at 4.5 m for the Kinect-class Xtion),
//! because it is made in disparity: the simulated disparity gets Gaussian noise and is
//! rounded to the matcher's sub-pixel step (1/8 px for the PrimeSense chip of the
//! Xtion, Khoshelham & Elberink sec. 2), so depth comes in range-dependent layers.
//! Close to the range limits a growing share of pixels carries no depth; at depth
//! discontinuities the projector's shadow leaves a band without depth on the
//! background side, as wide as the disparity jump.

use schemas::Intrinsics;

/// A depth camera's geometry and error model.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraProfile {
    /// Profile name (`xtion`, `d435`).
    pub name: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Horizontal field of view, degrees.
    pub hfov_deg: f64,
    /// Vertical field of view, degrees.
    pub vfov_deg: f64,
    /// Nearer than this there is no depth at all, metres.
    pub min_depth_m: f64,
    /// Depth is reliable (only `dropout` missing) from here ...
    pub reliable_from_m: f64,
    /// ... to here, metres.
    pub reliable_to_m: f64,
    /// Farther than this there is no depth at all, metres.
    pub max_depth_m: f64,
    /// Axial noise sigma = `noise_per_m2` * depth^2, metres (before disparity rounding).
    pub noise_per_m2: f64,
    /// Share of pixels missing at random inside the reliable range.
    pub dropout: f64,
    /// Share missing at `min_depth_m` and at `max_depth_m` (linear ramp from `dropout`).
    pub edge_dropout: f64,
    /// Projector-to-camera baseline, metres (sets the width of shadow bands).
    pub baseline_m: f64,
    /// A neighbour farther by more than this share of the depth starts a shadow edge.
    pub edge_jump_ratio: f64,
    /// Disparity resolution, pixels (0 = continuous): depth comes in the steps the
    /// matcher's sub-pixel disparity allows, coarser with range.
    pub disparity_step_px: f64,
    /// Frames per second.
    pub rate_hz: f64,
}

impl CameraProfile {
    /// Asus Xtion Pro Live (Taylor 2017): 640x480, 58 x 45 degrees, reliable
    /// 0.8–3.5 m, nothing beyond 4.5 m or nearer than 0.5 m, 30 Hz, 7.5 cm baseline.
    pub fn xtion() -> Self {
        CameraProfile {
            name: "xtion".into(),
            width: 640,
            height: 480,
            hfov_deg: 58.0,
            vfov_deg: 45.0,
            min_depth_m: 0.5,
            reliable_from_m: 0.8,
            reliable_to_m: 3.5,
            max_depth_m: 4.5,
            noise_per_m2: 1.425e-3,
            dropout: 0.005,
            edge_dropout: 0.5,
            baseline_m: 0.075,
            edge_jump_ratio: 0.05,
            disparity_step_px: 0.125,
            rate_hz: 30.0,
        }
    }

    /// Intel RealSense D435 at 848x480 (its native depth aspect): 87 x 58 degrees,
    /// 0.3–6 m indoors (reliable to 3 m), about 1 % error at 2 m (datasheet: under 2 %),
    /// 5 cm baseline, 30 Hz.
    pub fn d435() -> Self {
        CameraProfile {
            name: "d435".into(),
            width: 848,
            height: 480,
            hfov_deg: 87.0,
            vfov_deg: 58.0,
            min_depth_m: 0.3,
            reliable_from_m: 0.4,
            reliable_to_m: 3.0,
            max_depth_m: 6.0,
            noise_per_m2: 5.0e-3,
            dropout: 0.01,
            edge_dropout: 0.5,
            baseline_m: 0.05,
            edge_jump_ratio: 0.05,
            disparity_step_px: 1.0 / 32.0,
            rate_hz: 30.0,
        }
    }

    /// A profile by name (`xtion`, `d435`).
    pub fn by_name(name: &str) -> Option<Self> {
        match name {
            "xtion" => Some(Self::xtion()),
            "d435" => Some(Self::d435()),
            _ => None,
        }
    }

    /// Pinhole intrinsics from the fields of view; the principal point is the image
    /// centre, pixel centres at integer coordinates.
    pub fn intrinsics(&self) -> Intrinsics {
        let fx = (self.width as f64 / 2.0) / (self.hfov_deg.to_radians() / 2.0).tan();
        let fy = (self.height as f64 / 2.0) / (self.vfov_deg.to_radians() / 2.0).tan();
        Intrinsics {
            fx: fx as f32,
            fy: fy as f32,
            cx: (self.width as f32 - 1.0) / 2.0,
            cy: (self.height as f32 - 1.0) / 2.0,
        }
    }

    /// Axial noise sigma at a depth, metres.
    pub fn noise_sigma_m(&self, depth_m: f64) -> f64 {
        self.noise_per_m2 * depth_m * depth_m
    }

    /// Probability a pixel at this depth has no reading.
    pub fn dropout_at(&self, depth_m: f64) -> f64 {
        if !(self.min_depth_m..=self.max_depth_m).contains(&depth_m) {
            1.0
        } else if depth_m < self.reliable_from_m {
            let f = (self.reliable_from_m - depth_m) / (self.reliable_from_m - self.min_depth_m);
            self.dropout + f * (self.edge_dropout - self.dropout)
        } else if depth_m > self.reliable_to_m {
            let f = (depth_m - self.reliable_to_m) / (self.max_depth_m - self.reliable_to_m);
            self.dropout + f * (self.edge_dropout - self.dropout)
        } else {
            self.dropout
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xtion_intrinsics_match_its_field_of_view() {
        let k = CameraProfile::xtion().intrinsics();
        assert!((k.fx - 577.3).abs() < 0.1, "{k:?}");
        assert!((k.fy - 579.4).abs() < 0.1, "{k:?}");
        assert_eq!((k.cx, k.cy), (319.5, 239.5));
    }

    #[test]
    fn dropout_ramps_outside_the_reliable_range_and_is_total_beyond_limits() {
        let c = CameraProfile::xtion();
        assert_eq!(c.dropout_at(2.0), 0.005);
        assert!((c.dropout_at(4.0) - (0.005 + 0.5 * 0.495)).abs() < 1e-9);
        assert_eq!(c.dropout_at(4.6), 1.0);
        assert_eq!(c.dropout_at(0.4), 1.0);
    }
}
