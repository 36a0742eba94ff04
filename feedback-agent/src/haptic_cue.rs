//! Haptic cues: a validated haptic intent turned into motor levels at any instant.
//!
//! Taylor 2017 (§2.4, Table 2.1) drives two on/off rumble motors, one per hand; ISANA's
//! beep train carries distance in the pulse rate. Pulses are timed here, on the agent
//! side, from a `now` the caller gives: no clock is read, so every edge is testable.
//! Safety rule 2 (ARCHITECTURE.md): every cue expires; past `expires_ns` it is silent.
//!
//! The offline alert (rule 1) alternates left and right: no obstacle intent can say
//! that, since an intent drives both sides with one pattern in phase.

use schemas::{HapticIntent, HapticPattern};
use thiserror::Error;

/// Actuator levels in force, 0..1 per side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Levels {
    /// Left actuator.
    pub left: f32,
    /// Right actuator.
    pub right: f32,
}

impl Levels {
    /// Both motors off.
    pub const OFF: Levels = Levels { left: 0.0, right: 0.0 };

    /// True when neither side runs.
    pub fn is_off(&self) -> bool {
        self.left <= 0.0 && self.right <= 0.0
    }
}

/// Limits applied to incoming intents.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CueLimits {
    /// Longest TTL honoured, ms: a cue never outlives this, whatever it asks.
    pub max_ttl_ms: u32,
    /// Shortest pulse period, ms: an on/off motor cannot pulse faster than it spins up.
    pub min_period_ms: u32,
    /// Longest pulse period, ms.
    pub max_period_ms: u32,
}

impl Default for CueLimits {
    /// 2 s TTL cap (60 frames at 30 Hz), pulses between 60 ms (Wiimote motor spin-up is
    /// ~20-30 ms) and 5 s.
    fn default() -> Self {
        Self { max_ttl_ms: 2000, min_period_ms: 60, max_period_ms: 5000 }
    }
}

/// Why an intent cannot become a cue.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CueError {
    /// A level that is not a number cannot be clamped to anything meaningful.
    #[error("{side} level is NaN")]
    NanLevel {
        /// `left` or `right`.
        side: &'static str,
    },
    /// Pulses with a NaN duty.
    #[error("pulse duty is NaN")]
    NanDuty,
}

impl CueError {
    /// Short stable name for reject counters.
    pub fn kind(&self) -> &'static str {
        match self {
            CueError::NanLevel { .. } => "nan_level",
            CueError::NanDuty => "nan_duty",
        }
    }
}

/// How the levels move in time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shape {
    Steady,
    /// On for `on_ns` at the start of every `period_ns`, counted from `origin_ns`.
    Pulses {
        period_ns: u64,
        on_ns: u64,
        origin_ns: u64,
    },
    /// Left for `half_ns`, then right for `half_ns`, from `origin_ns`.
    Alternating {
        half_ns: u64,
        origin_ns: u64,
    },
}

/// A cue ready to drive motors until it expires.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HapticCue {
    levels: Levels,
    shape: Shape,
    /// The wire pattern reported in `feedback/applied`.
    pattern: HapticPattern,
    /// Past this instant the cue is silent.
    pub expires_ns: u64,
    /// Capture stamp of the intent (0 for the agent's own alerts).
    pub cause_capture_ns: u64,
}

/// A cue accepted from an intent, with a note when something had to be clamped.
#[derive(Debug, Clone, PartialEq)]
pub struct AcceptedCue {
    /// The cue.
    pub cue: HapticCue,
    /// What was clamped, if anything (counted as `clamped` by the caller).
    pub clamped: Option<String>,
}

fn clamp_unit(name: &str, v: f32, notes: &mut Vec<String>) -> f32 {
    if (0.0..=1.0).contains(&v) {
        v
    } else {
        notes.push(format!("{name} {v} clamped to 0..1"));
        v.clamp(0.0, 1.0)
    }
}

const MS: u64 = 1_000_000;

/// Motor level of the notice tap ([`HapticCue::notice`]).
pub const NOTICE_LEVEL: f32 = 0.35;

impl HapticCue {
    /// Turn `intent` (captured at `capture_ns`, arriving at `now_ns`) into a cue.
    ///
    /// Levels and duty outside 0..1 are clamped, periods to `limits`; NaN is refused.
    /// The cue expires `ttl_ms` after capture, but never later than `max_ttl_ms` after
    /// `now_ns` (a sender's clock far ahead must not make a cue immortal). When `previous`
    /// is a live pulse cue on the same side(s), its phase is kept: intents arrive at
    /// 30 Hz, and restarting the phase on each one would hold a 500 ms pulse on forever.
    /// A change of side starts the new train at once: "turn left" must not wait for the
    /// gap of a "turn right" pulse to end.
    pub fn from_intent(
        intent: &HapticIntent,
        capture_ns: u64,
        now_ns: u64,
        limits: &CueLimits,
        previous: Option<&HapticCue>,
    ) -> Result<AcceptedCue, CueError> {
        if intent.left.is_nan() {
            return Err(CueError::NanLevel { side: "left" });
        }
        if intent.right.is_nan() {
            return Err(CueError::NanLevel { side: "right" });
        }
        let mut notes = Vec::new();
        let levels = Levels {
            left: clamp_unit("left level", intent.left, &mut notes),
            right: clamp_unit("right level", intent.right, &mut notes),
        };
        let ttl_ms = if intent.ttl_ms > limits.max_ttl_ms {
            notes.push(format!("ttl {} ms capped to {} ms", intent.ttl_ms, limits.max_ttl_ms));
            limits.max_ttl_ms
        } else {
            intent.ttl_ms
        };
        let expires_ns =
            capture_ns.saturating_add(ttl_ms as u64 * MS).min(now_ns.saturating_add(limits.max_ttl_ms as u64 * MS));
        let (shape, pattern) = match intent.pattern {
            HapticPattern::Steady => (Shape::Steady, HapticPattern::Steady),
            HapticPattern::Pulses { period_ms, duty } => {
                if duty.is_nan() {
                    return Err(CueError::NanDuty);
                }
                let duty = clamp_unit("duty", duty, &mut notes);
                let period = period_ms.clamp(limits.min_period_ms, limits.max_period_ms);
                if period != period_ms {
                    notes.push(format!("pulse period {period_ms} ms clamped to {period} ms"));
                }
                let period_ns = period as u64 * MS;
                let on_ns = (period_ns as f64 * duty as f64).round() as u64;
                let sides = |l: &Levels| (l.left > 0.0, l.right > 0.0);
                let same_train = previous.is_some_and(|p| now_ns < p.expires_ns && sides(&p.levels) == sides(&levels));
                let origin_ns = match previous.map(|p| p.shape) {
                    Some(Shape::Pulses { origin_ns, .. }) if same_train => origin_ns,
                    _ => now_ns,
                };
                (Shape::Pulses { period_ns, on_ns, origin_ns }, HapticPattern::Pulses { period_ms: period, duty })
            }
        };
        let clamped = (!notes.is_empty()).then(|| notes.join("; "));
        Ok(AcceptedCue { cue: HapticCue { levels, shape, pattern, expires_ns, cause_capture_ns: capture_ns }, clamped })
    }

    /// The offline alert: full strength, left and right alternating every `half_ms`,
    /// for `cycles` left-right cycles from `now_ns`.
    pub fn offline_alert(now_ns: u64, half_ms: u32, cycles: u32) -> Self {
        let half_ns = half_ms.max(1) as u64 * MS;
        HapticCue {
            levels: Levels { left: 1.0, right: 1.0 },
            shape: Shape::Alternating { half_ns, origin_ns: now_ns },
            pattern: HapticPattern::Pulses { period_ms: 2 * half_ms.max(1), duty: 0.5 },
            expires_ns: now_ns + 2 * half_ns * cycles as u64,
            cause_capture_ns: 0,
        }
    }

    /// The notice tap before route guidance: two short taps on both sides (50 ms, 120 ms
    /// apart, over in 170 ms; level 0.35 where a motor can be driven lighter, on/off
    /// motors like the Wiimote's tap at full). Brief where an obstacle cue lasts, and
    /// the feedback step plays it only while no obstacle cue or alert drives the
    /// motors, so it cannot be taken for one.
    pub fn notice(now_ns: u64) -> Self {
        HapticCue {
            levels: Levels { left: NOTICE_LEVEL, right: NOTICE_LEVEL },
            shape: Shape::Pulses { period_ns: 120 * MS, on_ns: 50 * MS, origin_ns: now_ns },
            pattern: HapticPattern::Pulses { period_ms: 120, duty: 50.0 / 120.0 },
            expires_ns: now_ns + 170 * MS,
            cause_capture_ns: 0,
        }
    }

    /// The pattern to report in `feedback/applied`.
    pub fn pattern(&self) -> HapticPattern {
        self.pattern
    }

    /// True when the cue asks for no motion at all (an obstacle intent saying "clear").
    pub fn is_at_rest(&self) -> bool {
        self.levels.is_off()
    }

    /// True while the cue can still drive a motor.
    pub fn is_live(&self, now_ns: u64) -> bool {
        now_ns < self.expires_ns
    }

    /// Levels at `now_ns`: off once expired, off in the gaps of a pulse train.
    pub fn levels_at(&self, now_ns: u64) -> Levels {
        if !self.is_live(now_ns) {
            return Levels::OFF;
        }
        match self.shape {
            Shape::Steady => self.levels,
            Shape::Pulses { period_ns, on_ns, origin_ns } => {
                let phase = now_ns.saturating_sub(origin_ns) % period_ns;
                if phase < on_ns {
                    self.levels
                } else {
                    Levels::OFF
                }
            }
            Shape::Alternating { half_ns, origin_ns } => {
                if (now_ns.saturating_sub(origin_ns) / half_ns) % 2 == 0 {
                    Levels { left: self.levels.left, right: 0.0 }
                } else {
                    Levels { left: 0.0, right: self.levels.right }
                }
            }
        }
    }

    /// The next instant after `now_ns` at which the levels may change (an edge or the
    /// expiry), or `None` once expired.
    pub fn next_change_ns(&self, now_ns: u64) -> Option<u64> {
        if !self.is_live(now_ns) {
            return None;
        }
        let edge = match self.shape {
            Shape::Steady => None,
            Shape::Pulses { period_ns, on_ns, origin_ns } => {
                let since = now_ns.saturating_sub(origin_ns);
                let start = origin_ns + since - since % period_ns;
                let off_edge = start + on_ns;
                Some(if now_ns < off_edge && on_ns > 0 { off_edge } else { start + period_ns })
            }
            Shape::Alternating { half_ns, origin_ns } => {
                let since = now_ns.saturating_sub(origin_ns);
                Some(origin_ns + (since / half_ns + 1) * half_ns)
            }
        };
        Some(edge.map_or(self.expires_ns, |e| e.min(self.expires_ns)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T0: u64 = 1_700_000_000_000_000_000;

    fn intent(left: f32, right: f32, pattern: HapticPattern, ttl_ms: u32) -> HapticIntent {
        HapticIntent { left, right, pattern, ttl_ms }
    }

    fn accept(i: &HapticIntent, capture_ns: u64, now_ns: u64) -> AcceptedCue {
        HapticCue::from_intent(i, capture_ns, now_ns, &CueLimits::default(), None).unwrap()
    }

    #[test]
    fn steady_cue_holds_until_ttl_then_stops() {
        let c = accept(&intent(1.0, 0.0, HapticPattern::Steady, 200), T0, T0 + MS).cue;
        assert_eq!(c.levels_at(T0 + 2 * MS), Levels { left: 1.0, right: 0.0 });
        assert_eq!(c.levels_at(T0 + 199 * MS), Levels { left: 1.0, right: 0.0 });
        assert_eq!(c.levels_at(T0 + 200 * MS), Levels::OFF);
        assert_eq!(c.next_change_ns(T0 + 2 * MS), Some(T0 + 200 * MS));
        assert_eq!(c.next_change_ns(T0 + 200 * MS), None);
    }

    #[test]
    fn stale_intent_is_silent_on_arrival() {
        let c = accept(&intent(1.0, 1.0, HapticPattern::Steady, 100), T0, T0 + 150 * MS).cue;
        assert_eq!(c.levels_at(T0 + 150 * MS), Levels::OFF);
    }

    #[test]
    fn ttl_is_capped_even_when_the_sender_clock_is_ahead() {
        // Capture stamp 10 s in the future, ttl 60 s: must still stop 2 s after arrival.
        let a = accept(&intent(1.0, 1.0, HapticPattern::Steady, 60_000), T0 + 10_000 * MS, T0);
        assert_eq!(a.cue.expires_ns, T0 + 2000 * MS);
        assert!(a.clamped.unwrap().contains("ttl 60000 ms capped"));
    }

    #[test]
    fn out_of_range_levels_are_clamped_and_reported() {
        let a = accept(&intent(7.5, -3.0, HapticPattern::Steady, 100), T0, T0);
        assert_eq!(a.cue.levels_at(T0), Levels { left: 1.0, right: 0.0 });
        let note = a.clamped.unwrap();
        assert!(note.contains("left level 7.5"), "{note}");
        assert!(note.contains("right level -3"), "{note}");
    }

    #[test]
    fn nan_levels_are_refused() {
        let e = HapticCue::from_intent(
            &intent(f32::NAN, 0.0, HapticPattern::Steady, 100),
            T0,
            T0,
            &CueLimits::default(),
            None,
        );
        assert_eq!(e.unwrap_err().kind(), "nan_level");
        let p = HapticPattern::Pulses { period_ms: 200, duty: f32::NAN };
        let e = HapticCue::from_intent(&intent(0.5, 0.5, p, 100), T0, T0, &CueLimits::default(), None);
        assert_eq!(e.unwrap_err(), CueError::NanDuty);
    }

    #[test]
    fn pulses_turn_on_and_off_at_the_duty_edges() {
        let p = HapticPattern::Pulses { period_ms: 200, duty: 0.25 };
        let c = accept(&intent(0.0, 1.0, p, 1000), T0, T0).cue;
        let on = Levels { left: 0.0, right: 1.0 };
        assert_eq!(c.levels_at(T0), on);
        assert_eq!(c.levels_at(T0 + 49 * MS), on);
        assert_eq!(c.levels_at(T0 + 50 * MS), Levels::OFF);
        assert_eq!(c.levels_at(T0 + 199 * MS), Levels::OFF);
        assert_eq!(c.levels_at(T0 + 200 * MS), on);
        assert_eq!(c.next_change_ns(T0 + 10 * MS), Some(T0 + 50 * MS));
        assert_eq!(c.next_change_ns(T0 + 60 * MS), Some(T0 + 200 * MS));
    }

    #[test]
    fn repeated_pulse_intents_keep_the_phase_so_gaps_still_happen() {
        // 30 Hz intents with a 500 ms period: the motor must still go off in the gaps.
        let p = HapticPattern::Pulses { period_ms: 500, duty: 0.5 };
        let limits = CueLimits::default();
        let mut cue = accept(&intent(1.0, 1.0, p, 300), T0, T0).cue;
        let mut saw_off = false;
        for k in 1..30u64 {
            let now = T0 + k * 33 * MS;
            cue = HapticCue::from_intent(&intent(1.0, 1.0, p, 300), now, now, &limits, Some(&cue)).unwrap().cue;
            saw_off |= cue.levels_at(now).is_off();
        }
        assert!(saw_off, "a 500 ms pulse must switch off within a second of 30 Hz intents");
        // 300 ms in: inside the off half of the first period.
        assert!(cue.levels_at(T0 + 300 * MS).is_off());
    }

    #[test]
    fn a_change_of_side_starts_the_new_pulse_train_at_once() {
        let p = HapticPattern::Pulses { period_ms: 500, duty: 0.5 };
        let limits = CueLimits::default();
        let right = accept(&intent(0.0, 1.0, p, 300), T0, T0).cue;
        // 300 ms in the right-hand train is in its gap; a left intent arrives
        let now = T0 + 300 * MS;
        let left = HapticCue::from_intent(&intent(1.0, 0.0, p, 300), now, now, &limits, Some(&right)).unwrap().cue;
        assert_eq!(left.levels_at(now), Levels { left: 1.0, right: 0.0 }, "felt at arrival, not 200 ms later");
        // the same side again keeps the phase
        let later = now + 100 * MS;
        let again = HapticCue::from_intent(&intent(1.0, 0.0, p, 300), later, later, &limits, Some(&left)).unwrap().cue;
        assert!(again.levels_at(now + 260 * MS).is_off(), "gap of the train that started at {now}");
    }

    #[test]
    fn pulse_period_is_clamped_to_what_a_motor_can_do() {
        let p = HapticPattern::Pulses { period_ms: 1, duty: 0.5 };
        let a = accept(&intent(1.0, 1.0, p, 1000), T0, T0);
        assert_eq!(a.cue.pattern(), HapticPattern::Pulses { period_ms: 60, duty: 0.5 });
        assert!(a.clamped.is_some());
    }

    #[test]
    fn offline_alert_alternates_sides_then_ends() {
        let c = HapticCue::offline_alert(T0, 150, 3);
        assert_eq!(c.levels_at(T0), Levels { left: 1.0, right: 0.0 });
        assert_eq!(c.levels_at(T0 + 150 * MS), Levels { left: 0.0, right: 1.0 });
        assert_eq!(c.levels_at(T0 + 300 * MS), Levels { left: 1.0, right: 0.0 });
        assert_eq!(c.levels_at(T0 + 900 * MS), Levels::OFF);
        assert_eq!(c.next_change_ns(T0 + 10 * MS), Some(T0 + 150 * MS));
        // Never both at once: an obstacle cue (steady or pulsed, sides in phase) cannot
        // produce this sequence.
        for k in 0..90 {
            let l = c.levels_at(T0 + k * 10 * MS);
            assert!(!(l.left > 0.0 && l.right > 0.0));
        }
    }
}
