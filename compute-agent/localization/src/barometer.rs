//! Height from a barometer: how far the user has risen or sunk since they last stood on
//! a known floor, once the air pressure holds still.
//!
//! Air pressure falls about 12 Pa for every metre up near sea level (a storey is some
//! 35 Pa), and it also moves with the weather, slowly: up to about 100 Pa an hour in a
//! storm, 0.03 Pa a second, against 10-20 Pa a second in a lift and 2-4 Pa a second on
//! stairs. So:
//!
//! - each reading is smoothed as the median of the last [`BarometerConfig::median_s`]
//!   (a door slammed shut or a gust through a doorway lasts a fraction of a second);
//! - the user is *still* (in height) when those medians stayed within
//!   [`BarometerConfig::still_range_m`] over the last [`BarometerConfig::still_s`];
//! - the *reference* is the pressure where the user stood on the floor they are known
//!   to be on; [`Barometer::height_m`] is the height above it, given only while still;
//! - while still and within [`BarometerConfig::same_floor_m`] of the reference, the
//!   reference follows the pressure with a time constant of
//!   [`BarometerConfig::follow_s`]: the weather's drift, not a climb (which is never
//!   still for long on the way).
//!
//! Which floor a height is, the caller decides from the floors' elevations
//! ([`crate::Tracker::pressure`]); when a floor is taken (by this or by the user's
//! word), [`Barometer::rebase`] makes the next still pressure the reference.

use std::collections::VecDeque;

/// How the barometer's readings are taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarometerConfig {
    /// Each reading is the median of the readings this far back, seconds.
    pub median_s: f64,
    /// Still: the medians stayed within `still_range_m` over this, seconds.
    pub still_s: f64,
    /// See `still_s`, metres of height.
    pub still_range_m: f64,
    /// Still and this near the reference, the user is on the reference's floor, metres.
    pub same_floor_m: f64,
    /// The reference follows the pressure on its floor with this time constant, seconds.
    pub follow_s: f64,
    /// Readings further apart than this start the windows anew, seconds.
    pub max_gap_s: f64,
}

impl Default for BarometerConfig {
    /// Medians over 1 s, still within 0.3 m over 3 s, the same floor within 0.8 m, the
    /// weather followed over 30 s, a gap of 2 s starting anew. Our choices: a lift's
    /// ride is seen about 4 s after it stops; the weather's worst drift leaves the
    /// reference 0.07 m behind.
    fn default() -> Self {
        Self { median_s: 1.0, still_s: 3.0, still_range_m: 0.3, same_floor_m: 0.8, follow_s: 30.0, max_gap_s: 2.0 }
    }
}

/// Why a reading was not taken.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BarometerRefused {
    /// Not a pressure the air has where people go.
    #[error("pressure {0} Pa is no air pressure people stand in")]
    NotAPressure(f64),
    /// Stamped before the reading before it.
    #[error("reading stamped {stamp_ns} ns, before the last one ({last_ns} ns)")]
    Backwards {
        /// the reading's stamp
        stamp_ns: u64,
        /// the last reading's
        last_ns: u64,
    },
}

/// Pressures air has where people stand, pascals (the Dead Sea shore to a high pass).
const AIR_PA: std::ops::RangeInclusive<f64> = 30_000.0..=110_000.0;

/// Pressure falls by this share of itself per metre up (g M / (R T) at 15 °C).
const PER_M: f64 = 9.806_65 * 0.028_964_4 / (8.314_46 * 288.15);

/// One barometer's readings, turned into height.
#[derive(Debug, Clone)]
pub struct Barometer {
    config: BarometerConfig,
    /// (stamp, pressure) of the last `median_s`
    raw: VecDeque<(u64, f64)>,
    /// (stamp, median) of the last `still_s`
    medians: VecDeque<(u64, f64)>,
    /// the pressure of the known floor, pascals (`None`: the next still one)
    reference_pa: Option<f64>,
    /// the smoothed pressure of the last reading, when it held still ([`Self::add`])
    still_pa: Option<f64>,
    last_ns: Option<u64>,
    refused: u64,
    scratch: Vec<f64>,
}

impl Barometer {
    /// A barometer with nothing read yet.
    pub fn new(config: BarometerConfig) -> Self {
        Self {
            config,
            raw: VecDeque::new(),
            medians: VecDeque::new(),
            reference_pa: None,
            still_pa: None,
            last_ns: None,
            refused: 0,
            scratch: Vec::new(),
        }
    }

    /// One reading, `pressure_pa` at `stamp_ns`. A reading that is no air pressure, or
    /// stamped before the last one, is refused, counted and changes nothing.
    pub fn add(&mut self, stamp_ns: u64, pressure_pa: f64) -> Result<(), BarometerRefused> {
        if !AIR_PA.contains(&pressure_pa) {
            self.refused += 1;
            return Err(BarometerRefused::NotAPressure(pressure_pa));
        }
        if let Some(last_ns) = self.last_ns.filter(|&l| stamp_ns < l) {
            self.refused += 1;
            return Err(BarometerRefused::Backwards { stamp_ns, last_ns });
        }
        let ns = |s: f64| (s * 1e9) as u64;
        if self.last_ns.is_some_and(|l| stamp_ns - l > ns(self.config.max_gap_s)) {
            self.raw.clear();
            self.medians.clear();
        }
        let dt_s = self.last_ns.map_or(0.0, |l| (stamp_ns - l) as f64 * 1e-9);
        self.last_ns = Some(stamp_ns);
        self.raw.push_back((stamp_ns, pressure_pa));
        while self.raw.front().is_some_and(|&(t, _)| stamp_ns - t > ns(self.config.median_s)) {
            self.raw.pop_front();
        }
        self.scratch.clear();
        self.scratch.extend(self.raw.iter().map(|&(_, p)| p));
        self.scratch.sort_by(f64::total_cmp);
        let median = self.scratch[self.scratch.len() / 2];
        self.medians.push_back((stamp_ns, median));
        while self.medians.front().is_some_and(|&(t, _)| stamp_ns - t > ns(self.config.still_s)) {
            self.medians.pop_front();
        }
        self.still_pa = self.still();
        if self.still_pa.is_some() {
            match self.reference_pa {
                None => self.reference_pa = Some(median),
                Some(r) if (r - median).abs() <= self.config.same_floor_m * r * PER_M => {
                    let k = (dt_s / self.config.follow_s).min(1.0);
                    self.reference_pa = Some(r + (median - r) * k);
                }
                Some(_) => {}
            }
        }
        Ok(())
    }

    /// The smoothed pressure, when it has held within the still range for the still
    /// time (the window full), pascals.
    fn still(&self) -> Option<f64> {
        let (&(first, _), &(last, now)) = (self.medians.front()?, self.medians.back()?);
        // the window covers the still time, give or take one reading's spacing
        if ((last - first) as f64) < self.config.still_s * 1e9 * 0.9 {
            return None;
        }
        let (lo, hi) = self.medians.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &(_, p)| (lo.min(p), hi.max(p)));
        (hi - lo <= self.config.still_range_m * now * PER_M).then_some(now)
    }

    /// Height above where the user stood on the known floor, metres, while the
    /// pressure holds still and a reference is known; `None` otherwise (moving, or
    /// nothing still read since [`Self::rebase`]).
    pub fn height_m(&self) -> Option<f64> {
        let now = self.still_pa?;
        let reference = self.reference_pa?;
        // the pressure's log ratio is height over the scale height (isothermal air)
        Some((reference / now).ln() / PER_M)
    }

    /// The user is on a known floor from now: the next still pressure is its reference.
    pub fn rebase(&mut self) {
        self.reference_pa = self.still_pa;
    }

    /// How the readings are taken.
    pub fn config(&self) -> &BarometerConfig {
        &self.config
    }

    /// Readings refused so far.
    pub fn refused(&self) -> u64 {
        self.refused
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    const SEA_PA: f64 = 101_325.0;

    /// The standard atmosphere's pressure at `height_m` above sea level.
    fn air(height_m: f64, sea_pa: f64) -> f64 {
        sea_pa * (1.0 - 2.255_77e-5 * height_m).powf(5.255_88)
    }

    /// Feeds readings at 25 Hz of `height(t)` with the weather drifting `drift_pa_s`
    /// and noise of `noise_pa` (1 sigma); returns the heights given, one per reading.
    fn run(
        b: &mut Barometer,
        seconds: f64,
        height: impl Fn(f64) -> f64,
        drift_pa_s: f64,
        noise_pa: f64,
        seed: u64,
    ) -> Vec<(f64, Option<f64>)> {
        let mut rng = Rng::new(seed);
        let mut out = Vec::new();
        for i in 0..(seconds * 25.0) as u64 {
            let t = i as f64 / 25.0;
            let p = air(height(t), SEA_PA + drift_pa_s * t) + rng.normal(noise_pa);
            b.add((t * 1e9) as u64 + 1, p).unwrap();
            out.push((t, b.height_m()));
        }
        out
    }

    /// A lift's ride from 0 to `rise_m` between `from_s` and `to_s`, smooth.
    fn ride(t: f64, from_s: f64, to_s: f64, rise_m: f64) -> f64 {
        let f = ((t - from_s) / (to_s - from_s)).clamp(0.0, 1.0);
        rise_m * (3.0 * f * f - 2.0 * f * f * f)
    }

    #[test]
    fn a_lift_ride_of_one_storey_reads_its_height_seconds_after_the_doors_open_and_never_on_the_way() {
        for (seed, rise) in [(1, 3.5), (2, -3.5), (3, 4.2), (4, 2.8)] {
            let mut b = Barometer::new(BarometerConfig::default());
            // on a floor 160 m above the sea, 20 s standing, a 6 s ride, 20 s standing
            let out = run(&mut b, 46.0, |t| 160.0 + ride(t, 20.0, 26.0, rise), 0.03, 1.5, seed);
            for (t, h) in &out {
                // the ride's slow start may read still for a moment, a little off the
                // floor left; never near the floor reached before the doors open
                if let (true, Some(h)) = (*t < 26.0, h) {
                    assert!((h - rise).abs() > 2.0, "seed {seed}: {h:.2} m at {t:.1} s");
                }
            }
            let first_up = out.iter().find(|(t, h)| *t > 20.0 && h.is_some_and(|h| (h - rise).abs() < 0.3));
            let (t, h) = first_up.expect("the new height read");
            assert!(*t > 26.0 && *t < 31.0, "seed {seed}: read at {t:.2} s");
            assert!((h.unwrap() - rise).abs() < 0.2, "seed {seed}: {h:?} for {rise}");
            let (_, last) = out.last().unwrap();
            assert!(last.is_some_and(|h| (h - rise).abs() < 0.2), "seed {seed}: {last:?}");
        }
    }

    #[test]
    fn a_stormy_hour_on_one_floor_never_reads_as_far_as_another_floor() {
        // 100 Pa an hour (8 m of height if it were not followed), a door slammed (40 Pa
        // for 0.2 s) every minute; standing and walking, on the level and up and down a
        // ramp of 0.5 m (so slow a climb is not told from the weather: the ramp is
        // partly followed, as the weather is, and never taken for a floor)
        for ramp_m in [0.0, 0.5] {
            let mut b = Barometer::new(BarometerConfig::default());
            let mut rng = Rng::new(7);
            let (mut worst, mut worst_off_ramp): (f64, f64) = (0.0, 0.0);
            for i in 0..(3600.0 * 25.0) as u64 {
                let t = i as f64 / 25.0;
                let ramp = ramp_m * ((t / 120.0).sin()).max(0.0);
                let slam = if t % 60.0 < 0.2 { 40.0 } else { 0.0 };
                let p = air(20.0 + ramp, SEA_PA - 100.0 / 3600.0 * t) + slam + rng.normal(1.5);
                b.add((t * 1e9) as u64, p).unwrap();
                if let Some(h) = b.height_m() {
                    worst = worst.max(h.abs());
                    worst_off_ramp = worst_off_ramp.max((h - ramp).abs());
                }
            }
            if ramp_m == 0.0 {
                assert!(worst < 0.25, "the weather alone: {worst:.2} m");
            }
            assert!(worst < ramp_m + 0.25, "ramp {ramp_m} m: {worst:.2} m off the floor");
            assert!(worst_off_ramp < ramp_m + 0.25, "ramp {ramp_m} m: {worst_off_ramp:.2} m");
        }
    }

    #[test]
    fn stairs_climbed_with_a_rest_on_the_landing_read_the_landing_then_the_floor() {
        // 1.75 m up in 8 s, 6 s on the landing, 1.75 m more
        let mut b = Barometer::new(BarometerConfig::default());
        let height = |t: f64| ride(t, 10.0, 18.0, 1.75) + ride(t, 24.0, 32.0, 1.75);
        let out = run(&mut b, 45.0, height, -0.02, 1.0, 5);
        let at = |s: f64| out.iter().find(|(t, _)| (*t - s).abs() < 0.02).and_then(|(_, h)| *h);
        assert!(at(23.5).is_some_and(|h| (h - 1.75).abs() < 0.2), "{:?}", at(23.5));
        assert!(at(44.0).is_some_and(|h| (h - 3.5).abs() < 0.2), "{:?}", at(44.0));
        assert_eq!(at(28.0), None, "moving");
    }

    #[test]
    fn rebased_the_height_counts_from_the_floor_the_user_reached() {
        let mut b = Barometer::new(BarometerConfig::default());
        run(&mut b, 40.0, |t| ride(t, 10.0, 16.0, 3.5), 0.0, 1.0, 9);
        assert!(b.height_m().is_some_and(|h| (h - 3.5).abs() < 0.2));
        b.rebase();
        assert!(b.height_m().is_some_and(|h| h.abs() < 0.05), "{:?}", b.height_m());
    }

    #[test]
    fn readings_that_are_no_pressure_or_run_backwards_are_refused_and_counted() {
        let mut b = Barometer::new(BarometerConfig::default());
        b.add(2_000_000_000, SEA_PA).unwrap();
        assert!(matches!(b.add(2_100_000_000, f64::NAN), Err(BarometerRefused::NotAPressure(p)) if p.is_nan()));
        assert!(matches!(b.add(2_100_000_000, 0.0), Err(BarometerRefused::NotAPressure(_))));
        assert!(matches!(b.add(1_000_000_000, SEA_PA), Err(BarometerRefused::Backwards { .. })));
        assert_eq!(b.refused(), 3);
        // what was refused moved nothing: one reading, no still window yet
        assert_eq!(b.height_m(), None);
    }
}
