//! A simulated phone compass, the phone worn on a lanyard at the chest (the body IMU's
//! phone, [`crate::body::BodyMount`]): the body's heading, turned by how the phone
//! hangs, and by the building's magnetic disturbance, which depends on where the user
//! stands (steel in the floor and walls, wiring, radiators), plus each reading's noise.
//!
//! The disturbance is a smooth field (a sum of plane waves a few metres long) and,
//! scattered over the floor, strong local anomalies (a pillar's rebar, a lift's
//! machinery) that turn the reading by tens of degrees within a metre or so. The sizes
//! are assumptions of the order indoor studies of phone compasses report (errors of
//! 10-30 degrees common, far more beside steel), not a measurement of one building.

use super::random::SimRng;

/// Where north lies on a simulated world's map: its +y axis, degrees counter-clockwise
/// from +x (the floor plans `wearnav map` writes of a simulated world say so).
pub const SIM_NORTH_DEG: f64 = 90.0;

/// Error sizes of the simulated compass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompassNoise {
    /// Root mean square of the smooth disturbance, degrees.
    pub field_rms_deg: f64,
    /// Shortest and longest wavelength of the smooth disturbance, metres.
    pub wavelength_m: [f64; 2],
    /// Anomalies: one cell of this size, metres, holds one with `anomaly_probability`.
    pub anomaly_cell_m: f64,
    /// See `anomaly_cell_m`.
    pub anomaly_probability: f64,
    /// Largest turn an anomaly gives at its centre, degrees (each draws up to it).
    pub anomaly_peak_deg: f64,
    /// An anomaly's radius (Gaussian sigma), metres.
    pub anomaly_radius_m: f64,
    /// Each reading's noise, degrees (1 sigma).
    pub reading_deg: f64,
    /// The phone hangs up to this far off the body's heading, degrees (per walk).
    pub mount_deg: f64,
}

impl Default for CompassNoise {
    /// A smooth field of 12 degrees RMS over 3-15 m; an anomaly of up to 90 degrees
    /// (1 m sigma) in one 5 m square of four; readings 3 degrees apart; the phone up
    /// to 10 degrees askew.
    fn default() -> Self {
        CompassNoise {
            field_rms_deg: 12.0,
            wavelength_m: [3.0, 15.0],
            anomaly_cell_m: 5.0,
            anomaly_probability: 0.25,
            anomaly_peak_deg: 90.0,
            anomaly_radius_m: 1.0,
            reading_deg: 3.0,
            mount_deg: 10.0,
        }
    }
}

/// Plane waves of the smooth field.
const WAVES: usize = 6;

/// One walk's compass: its field, mount and noise drawn.
#[derive(Debug, Clone)]
pub struct CompassModel {
    noise: CompassNoise,
    /// (wave vector x, y in rad/m, phase, amplitude in rad)
    waves: [(f64, f64, f64, f64); WAVES],
    /// seed of the anomalies' places
    anomaly_seed: u64,
    mount_rad: f64,
    rng: SimRng,
}

impl CompassModel {
    /// A compass whose field and errors come from `rng`.
    pub fn new(noise: CompassNoise, mut rng: SimRng) -> Self {
        // each wave's amplitude sqrt(2 / WAVES) of the RMS: the sum has the RMS asked
        let amp = noise.field_rms_deg.to_radians() * (2.0 / WAVES as f64).sqrt();
        let [short, long] = noise.wavelength_m;
        let waves = std::array::from_fn(|_| {
            let wavelength = short + (long - short) * rng.uniform();
            let direction = rng.uniform() * std::f64::consts::TAU;
            let k = std::f64::consts::TAU / wavelength.max(1e-3);
            (k * direction.cos(), k * direction.sin(), rng.uniform() * std::f64::consts::TAU, amp)
        });
        let anomaly_seed = rng.next_u64();
        let mount_rad = (2.0 * rng.uniform() - 1.0) * noise.mount_deg.to_radians();
        CompassModel { noise, waves, anomaly_seed, mount_rad, rng }
    }

    /// The disturbance at (x, y), radians (the reading turns by it; positive:
    /// anticlockwise on the map).
    pub fn disturbance_rad(&self, x_m: f64, y_m: f64) -> f64 {
        let smooth: f64 = self.waves.iter().map(|(kx, ky, phase, amp)| amp * (kx * x_m + ky * y_m + phase).sin()).sum();
        let n = &self.noise;
        let cell = n.anomaly_cell_m.max(1e-3);
        let (cx, cy) = ((x_m / cell).floor() as i64, (y_m / cell).floor() as i64);
        let mut anomalies = 0.0;
        // the anomalies of this cell and its neighbours (one reaches ~3 sigma)
        for dy in -1..=1 {
            for dx in -1..=1 {
                let mut r = SimRng::seed_from(cell_seed(self.anomaly_seed, cx + dx, cy + dy));
                if r.uniform() >= n.anomaly_probability {
                    continue;
                }
                let (ax, ay) = (((cx + dx) as f64 + r.uniform()) * cell, ((cy + dy) as f64 + r.uniform()) * cell);
                let peak = (2.0 * r.uniform() - 1.0) * n.anomaly_peak_deg.to_radians();
                let d2 = (x_m - ax).powi(2) + (y_m - ay).powi(2);
                anomalies += peak * (-d2 / (2.0 * n.anomaly_radius_m.powi(2))).exp();
            }
        }
        smooth + anomalies
    }

    /// What the phone says for a body at (x, y) facing `yaw_rad` (map frame) in a
    /// building whose north is `north_rad` on the map: degrees clockwise from north,
    /// in [0, 360).
    pub fn read(&mut self, x_m: f64, y_m: f64, yaw_rad: f64, north_rad: f64) -> f32 {
        let phone = yaw_rad
            + self.mount_rad
            + self.disturbance_rad(x_m, y_m)
            + self.rng.gaussian() * self.noise.reading_deg.to_radians();
        let deg = (north_rad - phone).to_degrees().rem_euclid(360.0);
        // 359.99999 may round to 360.0 as f32
        if deg as f32 >= 360.0 {
            0.0
        } else {
            deg as f32
        }
    }
}

/// A seed for the anomaly of one cell.
fn cell_seed(seed: u64, cx: i64, cy: i64) -> u64 {
    seed ^ (cx as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (cy as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Disturbance statistics over a 60 x 60 m floor on a 0.25 m grid: (RMS, share of
    /// places beyond 45 degrees), degrees and fraction.
    fn field_stats(model: &CompassModel) -> (f64, f64) {
        let (mut sum2, mut beyond, mut n) = (0.0, 0, 0);
        for i in 0..240 {
            for j in 0..240 {
                let d = model.disturbance_rad(i as f64 * 0.25, j as f64 * 0.25).to_degrees();
                sum2 += d * d;
                beyond += usize::from(d.abs() > 45.0);
                n += 1;
            }
        }
        ((sum2 / n as f64).sqrt(), beyond as f64 / n as f64)
    }

    #[test]
    fn the_disturbance_is_tens_of_degrees_mostly_and_more_at_a_few_places() {
        for seed in 1..=3 {
            let model = CompassModel::new(CompassNoise::default(), SimRng::seed_from(seed));
            let (rms, beyond) = field_stats(&model);
            assert!((10.0..25.0).contains(&rms), "seed {seed}: RMS {rms:.1} deg");
            assert!((0.001..0.05).contains(&beyond), "seed {seed}: {:.2} % beyond 45 deg", beyond * 100.0);
            // the same place reads the same disturbance: it is the building's
            assert_eq!(model.disturbance_rad(12.3, 4.5), model.disturbance_rad(12.3, 4.5));
        }
        let quiet = CompassNoise { field_rms_deg: 12.0, anomaly_probability: 0.0, ..CompassNoise::default() };
        let (rms, beyond) = field_stats(&CompassModel::new(quiet, SimRng::seed_from(1)));
        assert!((8.0..16.0).contains(&rms) && beyond < 0.01, "smooth field alone: RMS {rms:.1}, {beyond}");
    }

    #[test]
    fn a_reading_is_clockwise_from_north_with_the_mount_and_the_disturbance() {
        let exact = CompassNoise {
            field_rms_deg: 0.0,
            anomaly_probability: 0.0,
            reading_deg: 0.0,
            mount_deg: 0.0,
            ..CompassNoise::default()
        };
        let mut c = CompassModel::new(exact, SimRng::seed_from(1));
        let north = 90f64.to_radians(); // north is +y
                                        // facing +y is north, +x east, -x west
        assert!(c.read(0.0, 0.0, 90f64.to_radians(), north).abs() < 1e-4);
        assert!((c.read(0.0, 0.0, 0.0, north) - 90.0).abs() < 1e-4);
        assert!((c.read(0.0, 0.0, 180f64.to_radians(), north) - 270.0).abs() < 1e-4);
        // a small turn west of north reads just under 360, never 360 itself
        let r = c.read(0.0, 0.0, 90.5f64.to_radians(), north);
        assert!((r - 359.5).abs() < 1e-3, "{r}");
        let mut c = CompassModel::new(CompassNoise::default(), SimRng::seed_from(2));
        let (x, y) = (3.0, 4.0);
        let expected = (90.0 - (c.disturbance_rad(x, y) + c.mount_rad).to_degrees()).rem_euclid(360.0);
        let reads: Vec<f64> = (0..200).map(|_| f64::from(c.read(x, y, 0.0, north))).collect();
        let mean = reads.iter().sum::<f64>() / reads.len() as f64;
        assert!((mean - expected).abs() < 1.0, "mean {mean:.1} vs {expected:.1}");
        assert!(reads.iter().all(|r| (0.0..360.0).contains(r)));
    }
}
