//! Landmark and wall-angle observations (Zhang et al., CCNY: door numbers are unique
//! landmarks, corridor corners are not; the angle of a wall beside the user corrects
//! heading).
//!
//! None of them is trusted outright. A door sign can be misread (by a person asked to
//! "verify door number", or by a sign reader), so a reading's likelihood is a mixture:
//! `(1 - p_misread) * g(d) + p_misread`, `g` an unnormalised Gaussian of the distance
//! `d` between where the particle predicts the sign and where the map has that door.
//! A particle far from the door keeps `p_misread` of its weight instead of nothing, so
//! one wrong number shifts belief by at most a factor `1 / p_misread` and the scans
//! can still win it back (their trial that "diverged after a misread door number"
//! trusted it). Corners and wall angles mix in an outlier probability the same way.

use serde::{Deserialize, Serialize};

use crate::pose::wrap_angle;

/// A landmark seen from the user, its position in the body frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Landmark {
    /// A door sign read as `number` (unique on its floor).
    Door {
        /// the number as read (may be wrong)
        number: String,
        /// metres ahead of the user
        forward_m: f64,
        /// metres to the user's left
        left_m: f64,
    },
    /// A corridor corner (not unique: it is matched to the nearest corner on the map).
    Corner {
        /// metres ahead of the user
        forward_m: f64,
        /// metres to the user's left
        left_m: f64,
    },
    /// A named place the user says they are near (someone nearby told them, or they
    /// know it), its name found on the map by the caller: where the user is within
    /// [`LandmarkConfig::place_sigma_m`], not which way they face.
    Place {
        /// the floor's level
        level: i32,
        /// map x of the place, metres
        x_m: f64,
        /// map y of the place, metres
        y_m: f64,
    },
}

impl Landmark {
    /// The body-frame position of the landmark.
    pub fn offset_m(&self) -> (f64, f64) {
        match self {
            Landmark::Door { forward_m, left_m, .. } | Landmark::Corner { forward_m, left_m } => (*forward_m, *left_m),
            Landmark::Place { .. } => (0.0, 0.0),
        }
    }
}

/// The direction of a wall beside the user, measured by the depth camera relative to
/// the body's forward axis (a wall is a line: `a` and `a + pi` are the same wall).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WallAngle {
    /// radians counter-clockwise from forward
    pub angle_rad: f64,
}

/// The body's heading as a worn phone's compass gives it, turned into the map's frame
/// with the map's north (`map::SemanticLayer::north_deg`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompassHeading {
    /// radians counter-clockwise from the map's +x axis
    pub heading_rad: f64,
}

/// How much to trust landmarks, wall angles and the compass.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LandmarkConfig {
    /// standard deviation of a landmark's measured position, metres (a door sign is read
    /// within arm's length; a corner from depth within half a metre)
    pub sigma_m: f64,
    /// probability that a door number is misread (Zhang et al. report a misread in one
    /// of their trials; 0.1 is a sign reader in poor light)
    pub door_misread_probability: f64,
    /// probability that a detected corner is not a map corner (clutter, an open door)
    pub corner_false_probability: f64,
    /// sensor resetting (Lenser & Veloso 2000; Zhang et al.'s first stage fixes the
    /// pose from unique landmarks): when the particles that agree with a door reading
    /// hold less than `door_reset_below_support` of the weight, this fraction of the
    /// next set is drawn where the reading puts the user (around the door, with
    /// headings drawn from the current particles). A misread puts them at the wrong
    /// door, where the scans drop them; the estimate follows the heaviest cluster, so
    /// they never move it on their own.
    pub door_reset_fraction: f64,
    /// see `door_reset_fraction`
    pub door_reset_below_support: f64,
    /// standard deviation of where a user who names a place stands from the place's
    /// point on the map, metres: "at room 204" or "in the lobby" is a few metres, not a
    /// door's arm's reach. A place is weighed as a door number is, with the same
    /// probability of being wrong, and always resets a share of the particles about it
    /// (our choice).
    pub place_sigma_m: f64,
    /// standard deviation of a measured wall angle, radians (3 degrees: a plane fit to
    /// a metre of wall in a depth image)
    pub wall_sigma_rad: f64,
    /// probability that a "wall" is not one of the map's wall directions (furniture)
    pub wall_outlier_probability: f64,
    /// a compass reading within this of a particle's heading says nothing about it,
    /// radians: indoors a phone's compass errs by 10-30 degrees near steel and wiring
    /// (more beside a lift), and the phone is worn a little askew. The compass is no
    /// heading sensor here; it tells a room's turned copy (90 or 180 degrees) apart,
    /// which the walls and the odometry cannot (docs/localization.md, "A compass")
    pub compass_tolerance_rad: f64,
    /// beyond the tolerance, the fall-off of a reading's likelihood, radians
    pub compass_sigma_rad: f64,
    /// probability that a reading is far off (a lift's steel, a phone taken out of its
    /// holder): a particle far off the reading keeps this share of its weight
    pub compass_outlier_probability: f64,
    /// `Tracking` needs the estimate's heading within this of the compass, when the
    /// last correction had a reading, radians
    pub compass_gate_rad: f64,
}

impl Default for LandmarkConfig {
    fn default() -> Self {
        Self {
            sigma_m: 0.5,
            door_misread_probability: 0.1,
            corner_false_probability: 0.2,
            door_reset_fraction: 0.1,
            door_reset_below_support: 0.1,
            place_sigma_m: 2.0,
            wall_sigma_rad: 3f64.to_radians(),
            wall_outlier_probability: 0.1,
            compass_tolerance_rad: 45f64.to_radians(),
            compass_sigma_rad: 15f64.to_radians(),
            compass_outlier_probability: 0.2,
            compass_gate_rad: 60f64.to_radians(),
        }
    }
}

/// `(1 - p_out) * exp(-d^2 / 2 sigma^2) + p_out`, as a log.
#[inline]
pub fn mixture_log_p(d: f64, sigma: f64, p_out: f64) -> f64 {
    ((1.0 - p_out) * (-d * d / (2.0 * sigma * sigma)).exp() + p_out).ln()
}

/// A compass reading's log-likelihood for a particle `error_rad` off it: flat within
/// the tolerance, then a Gaussian fall-off mixed with the outlier probability.
#[inline]
pub fn compass_log_p(error_rad: f64, config: &LandmarkConfig) -> f64 {
    let beyond = (wrap_angle(error_rad).abs() - config.compass_tolerance_rad).max(0.0);
    mixture_log_p(beyond, config.compass_sigma_rad, config.compass_outlier_probability)
}

/// The smallest angle between a wall direction `a` and any of `directions` (all lines,
/// so modulo pi), radians in [0, pi/2].
pub fn wall_residual(a: f64, directions: &[f64]) -> f64 {
    directions
        .iter()
        .map(|&d| {
            let r = wrap_angle(2.0 * (a - d)) / 2.0; // modulo pi
            r.abs()
        })
        .fold(std::f64::consts::FRAC_PI_2, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn wall_residual_is_modulo_pi_per_direction() {
        let dirs = [0.0, PI / 2.0];
        assert!(wall_residual(0.05, &dirs) - 0.05 < 1e-12);
        assert!((wall_residual(PI - 0.05, &dirs) - 0.05).abs() < 1e-12);
        assert!((wall_residual(PI / 2.0 + 0.1, &dirs) - 0.1).abs() < 1e-12);
        assert!((wall_residual(PI / 4.0, &dirs) - PI / 4.0).abs() < 1e-12);
    }

    #[test]
    fn a_compass_reading_says_nothing_within_its_tolerance_and_little_of_a_turned_copy() {
        let c = LandmarkConfig::default();
        for deg in [0.0, 30.0, -44.0] {
            assert_eq!(compass_log_p(f64::to_radians(deg), &c), 0.0, "{deg} degrees off");
        }
        // a quarter and a half turn keep about the outlier share (a quarter turn is 3
        // sigma past the tolerance: 0.8 exp(-4.5) more)
        for deg in [90.0, -90.0, 180.0] {
            let p = compass_log_p(f64::to_radians(deg), &c).exp();
            assert!((0.2..0.21).contains(&p), "{deg} degrees off: {p}");
        }
        // wrapped: 350 degrees is 10 degrees off
        assert_eq!(compass_log_p(350f64.to_radians(), &c), 0.0);
        let at_60 = compass_log_p(60f64.to_radians(), &c).exp();
        assert!((at_60 - (0.8 * (-0.5f64).exp() + 0.2)).abs() < 1e-9, "{at_60}");
    }

    #[test]
    fn a_misread_keeps_p_misread_of_the_weight() {
        let far = mixture_log_p(50.0, 0.5, 0.1);
        assert!((far - 0.1f64.ln()).abs() < 1e-9);
        assert!(mixture_log_p(0.0, 0.5, 0.1).abs() < 1e-12);
    }
}
