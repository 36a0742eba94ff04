//! A simulated barometer on the cane board: the air's pressure at the user's height
//! (the floor's elevation, and in a lift the car's, above the building's site), with
//! the weather's slow drift and each reading's noise.
//!
//! The sizes are assumptions of the order a BMP388's datasheet and the weather give,
//! not a measurement: readings 1.5 Pa apart (1 sigma; about 0.13 m), a drift drawn per
//! walk up to 60 Pa an hour either way (a falling or rising barometer, a front passing),
//! the site 120 m above the sea.

use super::random::SimRng;

/// Error sizes and the site of the simulated barometer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarometerNoise {
    /// Each reading's noise, pascals (1 sigma).
    pub reading_pa: f64,
    /// The weather drifts up to this either way (drawn per walk), pascals an hour.
    pub drift_pa_per_h: f64,
    /// The building's ground floor above the sea, metres.
    pub site_m: f64,
}

impl Default for BarometerNoise {
    /// 1.5 Pa a reading, up to 60 Pa an hour of drift, a site 120 m up.
    fn default() -> Self {
        Self { reading_pa: 1.5, drift_pa_per_h: 60.0, site_m: 120.0 }
    }
}

/// One walk's barometer: its drift drawn.
#[derive(Debug, Clone)]
pub struct BarometerModel {
    noise: BarometerNoise,
    drift_pa_s: f64,
    rng: SimRng,
}

/// Sea-level pressure of the standard atmosphere, pascals.
const SEA_LEVEL_PA: f64 = 101_325.0;

impl BarometerModel {
    /// A barometer whose drift and noise come from `rng`.
    pub fn new(noise: BarometerNoise, mut rng: SimRng) -> Self {
        let drift_pa_s = (2.0 * rng.uniform() - 1.0) * noise.drift_pa_per_h / 3600.0;
        Self { noise, drift_pa_s, rng }
    }

    /// The reading at `t_s` into the walk with the sensor `height_m` above the
    /// building's ground floor, pascals.
    pub fn read(&mut self, t_s: f64, height_m: f64) -> f32 {
        // the standard atmosphere's barometric formula
        let air = SEA_LEVEL_PA * (1.0 - 2.255_77e-5 * (self.noise.site_m + height_m)).powf(5.255_88);
        (air + self.drift_pa_s * t_s + self.rng.gaussian() * self.noise.reading_pa) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_storey_up_reads_about_forty_pascals_less_and_the_drift_stays_within_its_bound() {
        let quiet = BarometerNoise { reading_pa: 0.0, ..BarometerNoise::default() };
        let mut b = BarometerModel::new(quiet, SimRng::seed_from(4));
        let (ground, up) = (f64::from(b.read(0.0, 0.0)), f64::from(b.read(0.0, 3.5)));
        // 12 Pa a metre near sea level, a little less 120 m up
        assert!((ground - up - 41.5).abs() < 1.0, "{ground} - {up}");
        assert!((ground - 99_893.0).abs() < 5.0, "{ground}");
        let hour = f64::from(b.read(3600.0, 0.0));
        assert!((hour - ground).abs() <= 60.0, "{} Pa in an hour", hour - ground);
        // each reading's noise is the noise asked for
        let mut noisy = BarometerModel::new(BarometerNoise::default(), SimRng::seed_from(4));
        let r: Vec<f64> = (0..2000).map(|_| f64::from(noisy.read(0.0, 0.0))).collect();
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        let sd = (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / r.len() as f64).sqrt();
        assert!((sd - 1.5).abs() < 0.15, "{sd}");
    }
}
