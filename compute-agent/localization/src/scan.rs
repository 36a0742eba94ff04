//! A planar range scan in the user's body frame: the depth camera's nearest-point scan
//! (perception, 1-degree bins) or a laser's beams (the Intel log's 180).

use serde::{Deserialize, Serialize};

/// One beam: where it points and how far it saw.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Beam {
    /// direction, radians counter-clockwise from the sensor's forward axis
    pub angle_rad: f64,
    /// measured range, metres; `>= max_range_m` means "nothing seen"
    pub range_m: f64,
}

/// A scan and the sensor's place on the body.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Scan {
    /// the beams, in any order
    pub beams: Vec<Beam>,
    /// the sensor's maximum range, metres: beams at or beyond it saw nothing and are
    /// skipped (AMCL does the same: a max-range reading says little in a likelihood field)
    pub max_range_m: f64,
    /// sensor x forward of the body origin, metres
    pub sensor_forward_m: f64,
    /// sensor y left of the body origin, metres
    pub sensor_left_m: f64,
    /// sensor yaw relative to the body's forward axis, radians
    pub sensor_yaw_rad: f64,
}

impl Scan {
    /// A scan from a sensor at the body origin, facing forward.
    pub fn at_body_origin(beams: Vec<Beam>, max_range_m: f64) -> Self {
        Self { beams, max_range_m, ..Default::default() }
    }

    /// Body-frame end points of up to `max_beams` usable beams (finite, positive, short
    /// of the maximum range), evenly spread over the usable ones (AMCL's `max_beams`:
    /// beams are correlated, a subset carries most of the information). Returns how
    /// many beams were unusable.
    pub fn endpoints_into(&self, max_beams: usize, out: &mut Vec<[f64; 2]>) -> usize {
        out.clear();
        let usable = |b: &&Beam| self.usable(b);
        let n_usable = self.beams.iter().filter(usable).count();
        let unusable = self.beams.len() - n_usable;
        if n_usable == 0 || max_beams == 0 {
            return unusable;
        }
        let take = n_usable.min(max_beams);
        let sensor = self.sensor_yaw_rad.sin_cos();
        // the k-th of `take` evenly spaced picks among the usable beams
        let mut next_pick = 0usize;
        let mut picked = 0usize;
        for (i, b) in self.beams.iter().filter(usable).enumerate() {
            if picked < take && i == next_pick {
                out.push(self.endpoint(b, sensor));
                picked += 1;
                next_pick = (picked * n_usable) / take;
            }
        }
        unusable
    }

    /// Whether a beam hit something: finite, positive, short of the maximum range.
    pub(crate) fn usable(&self, b: &Beam) -> bool {
        b.range_m.is_finite() && b.angle_rad.is_finite() && b.range_m > 0.0 && b.range_m < self.max_range_m
    }

    /// A beam's end point in the body frame; `sensor` is the sensor yaw's (sin, cos).
    pub(crate) fn endpoint(&self, b: &Beam, (s0, c0): (f64, f64)) -> [f64; 2] {
        let (s, c) = b.angle_rad.sin_cos();
        let (sx, sy) = (b.range_m * c, b.range_m * s);
        [self.sensor_forward_m + c0 * sx - s0 * sy, self.sensor_left_m + s0 * sx + c0 * sy]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subsamples_evenly_and_skips_max_range_and_nan() {
        let mut beams: Vec<Beam> =
            (0..180).map(|i| Beam { angle_rad: (i as f64 - 90.0).to_radians(), range_m: 2.0 }).collect();
        beams[5].range_m = 80.0;
        beams[6].range_m = f64::NAN;
        let scan = Scan::at_body_origin(beams, 50.0);
        let mut out = Vec::new();
        assert_eq!(scan.endpoints_into(30, &mut out), 2);
        assert_eq!(out.len(), 30);
        // first beam points right (-90 deg), last close to +90 deg
        assert!((out[0][1] + 2.0).abs() < 1e-9);
        assert!(out[29][1] > 1.9);
        assert_eq!(scan.endpoints_into(1000, &mut out), 2);
        assert_eq!(out.len(), 178);
    }
}
