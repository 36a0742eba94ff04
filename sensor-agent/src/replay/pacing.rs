//! Real-time pacing of a recording: capture stamps from recorded timestamps, scaled
//! by a rate multiplier, anchored at the moment playback starts. A pure function of
//! its inputs (the caller passes the time): no clock is read here.

/// Gaps larger than this (seconds) in a recording are treated as breaks, not waits.
const MAX_GAP_S: f64 = 5.0;

/// Turns recorded timestamps (seconds, any epoch) into publication stamps (ns).
#[derive(Debug, Clone)]
pub struct Pacing {
    rate: f64,
    nominal_period_s: f64,
    /// Recorded time and stamp of the previous frame.
    last: Option<(f64, u64)>,
    /// The next frame starts a new pass of a looped recording.
    restarted: bool,
}

impl Pacing {
    /// `rate` 1.0 is real time, 2.0 twice as fast; `nominal_period_s` spaces frames
    /// that carry no timestamp, the loop-around and breaks in a recording.
    pub fn new(rate: f64, nominal_period_s: f64) -> Pacing {
        let rate = if rate.is_finite() && rate > 0.0 { rate } else { 1.0 };
        Pacing { rate, nominal_period_s, last: None, restarted: false }
    }

    /// Nominal spacing of published frames, ns.
    pub fn period_ns(&self) -> u64 {
        (self.nominal_period_s / self.rate * 1e9) as u64
    }

    /// The next pass of a looped recording begins: time goes on, it does not jump back.
    pub fn restart(&mut self) {
        self.restarted = true;
    }

    /// Stamp of a frame recorded at `time_s` (if known), asked for at `now_ns`. The
    /// first frame is stamped `now_ns`; later ones keep their recorded spacing divided
    /// by the rate, but are never stamped before `now_ns` (a slow consumer delays the
    /// stream instead of back-dating frames).
    pub fn stamp(&mut self, time_s: Option<f64>, now_ns: u64) -> u64 {
        let stamp = match self.last {
            None => now_ns,
            Some((prev_s, prev_ns)) => {
                let gap_s = match time_s {
                    Some(t) if !self.restarted && t > prev_s && t - prev_s <= MAX_GAP_S => t - prev_s,
                    _ => self.nominal_period_s,
                };
                (prev_ns + (gap_s / self.rate * 1e9).round() as u64).max(now_ns)
            }
        };
        let recorded = time_s.unwrap_or_else(|| self.last.map_or(0.0, |(t, _)| t + self.nominal_period_s));
        self.last = Some((recorded, stamp));
        self.restarted = false;
        stamp
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recorded_spacing_is_kept_at_real_time() {
        let mut p = Pacing::new(1.0, 0.1);
        assert_eq!(p.stamp(Some(100.0), 1_000), 1_000);
        assert_eq!(p.stamp(Some(100.033), 1_000), 1_000 + 33_000_000);
    }

    #[test]
    fn rate_two_halves_the_spacing() {
        let mut p = Pacing::new(2.0, 0.1);
        p.stamp(Some(5.0), 0);
        assert_eq!(p.stamp(Some(5.5), 0), 250_000_000);
        assert_eq!(p.period_ns(), 50_000_000);
    }

    #[test]
    fn untimed_frames_use_the_nominal_period() {
        let mut p = Pacing::new(1.0, 0.1);
        p.stamp(None, 0);
        assert_eq!(p.stamp(None, 0), 100_000_000);
    }

    #[test]
    fn loop_restart_moves_forward_by_one_period() {
        let mut p = Pacing::new(1.0, 0.1);
        p.stamp(Some(10.0), 0);
        p.stamp(Some(12.0), 0);
        p.restart();
        assert_eq!(p.stamp(Some(10.0), 0), 2_100_000_000);
    }

    #[test]
    fn a_late_consumer_is_never_handed_back_dated_frames() {
        let mut p = Pacing::new(1.0, 0.1);
        p.stamp(Some(0.0), 0);
        assert_eq!(p.stamp(Some(0.1), 900_000_000), 900_000_000);
    }

    #[test]
    fn long_break_in_a_recording_is_not_waited_out() {
        let mut p = Pacing::new(1.0, 0.1);
        p.stamp(Some(0.0), 0);
        assert_eq!(p.stamp(Some(3600.0), 0), 100_000_000);
    }
}
