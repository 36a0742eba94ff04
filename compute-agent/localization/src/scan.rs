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
    /// rays along which the sensor saw the floor free, each as far as `range_m` (a depth
    /// camera sees the floor, and no wall stands before floor it saw); empty: none
    /// known. Weighed only with [`crate::FilterConfig::free_space`] set.
    #[serde(default)]
    pub free: Vec<Beam>,
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

    /// Body-frame points every `step_m` along up to `max_rays` free rays (evenly spread
    /// over those reaching past `start_m + margin_m`), from `start_m` to `margin_m` short of
    /// each ray's free range; `ray_ends` gets the end index in `out` of each ray's points.
    pub fn free_points_into(&self, cfg: &crate::FreeSpaceConfig, out: &mut Vec<[f64; 2]>, ray_ends: &mut Vec<usize>) {
        out.clear();
        ray_ends.clear();
        let reach = |b: &Beam| {
            if b.angle_rad.is_finite() && b.range_m.is_finite() {
                b.range_m.min(self.max_range_m) - cfg.margin_m
            } else {
                0.0
            }
        };
        let long: Vec<&Beam> = self.free.iter().filter(|b| reach(b) > cfg.start_m).collect();
        let take = long.len().min(cfg.max_rays);
        if take == 0 || cfg.step_m <= 0.0 {
            return;
        }
        let sensor = self.sensor_yaw_rad.sin_cos();
        for k in 0..take {
            let b = long[k * long.len() / take];
            let end = reach(b);
            let mut r = cfg.start_m;
            while r <= end {
                out.push(self.endpoint(&Beam { angle_rad: b.angle_rad, range_m: r }, sensor));
                r += cfg.step_m;
            }
            ray_ends.push(out.len());
        }
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
    fn free_rays_are_tested_from_the_start_to_the_margin_short_of_the_floor_seen() {
        let cfg = crate::FreeSpaceConfig { max_rays: 3, ..Default::default() };
        let ray = |deg: f64, r: f64| Beam { angle_rad: deg.to_radians(), range_m: r };
        let scan = Scan {
            // one too short to test (0.3 + 0.25), one NaN, one past the range (cut to it)
            free: vec![ray(-20.0, 0.5), ray(-10.0, 1.0), ray(0.0, f64::NAN), ray(5.0, 2.0), ray(10.0, 9.0)],
            max_range_m: 5.0,
            sensor_forward_m: 0.25,
            sensor_yaw_rad: 0.0,
            ..Default::default()
        };
        let (mut points, mut ends) = (Vec::new(), Vec::new());
        scan.free_points_into(&cfg, &mut points, &mut ends);
        // -10 deg: 0.3..0.75 (5 points at 0.1); 5 deg: 0.3..1.75 (15); 10 deg: 0.3..4.75 (45)
        assert_eq!(ends, vec![5, 20, 65], "{ends:?}");
        let range = |p: [f64; 2]| (p[0] - 0.25).hypot(p[1]);
        assert!((range(points[0]) - 0.3).abs() < 1e-9 && (range(points[4]) - 0.7).abs() < 1e-9);
        assert!(points[0][1] < 0.0 && points[5][1] > 0.0, "bearings kept: {:?}", &points[..6]);
        assert!((range(points[64]) - 4.7).abs() < 1e-9, "cut at the range, less the margin: {}", range(points[64]));
        // two rays of three, evenly spread
        scan.free_points_into(&crate::FreeSpaceConfig { max_rays: 2, ..cfg }, &mut points, &mut ends);
        assert_eq!(ends, vec![5, 20]);
        // none free: nothing to test
        Scan::default().free_points_into(&cfg, &mut points, &mut ends);
        assert!(points.is_empty() && ends.is_empty());
    }

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
