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

/// `(sin a, cos a)` to within 1e-9 for |a| up to a few turns, without libm: the filter
/// takes two per particle per update (the motion and the scan), and libm's `sincos`
/// was 16 % of an update. Quadrant reduction, then Taylor polynomials to x^11 / x^12 on
/// [-pi/4, pi/4] (remainder below 1e-9 there).
#[inline]
pub fn fast_sin_cos(a: f64) -> (f64, f64) {
    use std::f64::consts::FRAC_PI_2;
    // the nearest quadrant, rounding half away from zero like `f64::round` (which is a
    // libm call on baseline x86-64: 1.6 % of an update)
    let t = a * (1.0 / FRAC_PI_2);
    let qi = (t + 0.5f64.copysign(t)) as i64;
    let x = a - qi as f64 * FRAC_PI_2;
    let x2 = x * x;
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0 + x2 * (-1.0 / 39_916_800.0))))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0
                    + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0 + x2 * (1.0 / 479_001_600.0))))));
    match qi & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn fast_sin_cos_matches_libm() {
        let mut worst: f64 = 0.0;
        for i in -40_000..=40_000 {
            let a = i as f64 * 1e-4 * PI; // -4 pi .. 4 pi
            let (s, c) = fast_sin_cos(a);
            worst = worst.max((s - a.sin()).abs()).max((c - a.cos()).abs());
        }
        assert!(worst < 1e-9, "worst error {worst}");
    }

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
