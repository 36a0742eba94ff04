//! Poses on a floor map (the `map` frame) and the small angle arithmetic they need.

use serde::{Deserialize, Serialize};

/// A user's pose in the map frame of one floor: position in metres, heading in
/// radians counter-clockwise from the map's x axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose2 {
    /// map x, metres
    pub x_m: f64,
    /// map y, metres
    pub y_m: f64,
    /// heading, radians in (-pi, pi]
    pub heading_rad: f64,
}

impl Pose2 {
    /// A pose; the heading is wrapped into (-pi, pi].
    pub fn new(x_m: f64, y_m: f64, heading_rad: f64) -> Self {
        Self { x_m, y_m, heading_rad: wrap_angle(heading_rad) }
    }

    /// `self` followed by a motion expressed in `self`'s body frame.
    pub fn compose(&self, forward_m: f64, left_m: f64, yaw_rad: f64) -> Self {
        let (s, c) = self.heading_rad.sin_cos();
        Self::new(
            self.x_m + c * forward_m - s * left_m,
            self.y_m + s * forward_m + c * left_m,
            self.heading_rad + yaw_rad,
        )
    }

    /// The motion (forward, left, yaw) in `self`'s body frame that leads to `to`.
    pub fn between(&self, to: &Pose2) -> (f64, f64, f64) {
        let (dx, dy) = (to.x_m - self.x_m, to.y_m - self.y_m);
        let (s, c) = self.heading_rad.sin_cos();
        (c * dx + s * dy, -s * dx + c * dy, wrap_angle(to.heading_rad - self.heading_rad))
    }

    /// Euclidean distance between positions, metres.
    pub fn distance_m(&self, other: &Pose2) -> f64 {
        (self.x_m - other.x_m).hypot(self.y_m - other.y_m)
    }
}

/// `a` wrapped into (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    if a > -PI && a <= PI {
        return a;
    }
    let w = a.rem_euclid(TAU);
    if w > PI {
        w - TAU
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn between_inverts_compose() {
        let a = Pose2::new(1.0, -2.0, 2.5);
        let b = a.compose(0.7, -0.3, 1.2);
        let (f, l, y) = a.between(&b);
        assert!((f - 0.7).abs() < 1e-12 && (l + 0.3).abs() < 1e-12 && (y - 1.2).abs() < 1e-12);
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-0.5) + 0.5).abs() < 1e-15);
    }
}
