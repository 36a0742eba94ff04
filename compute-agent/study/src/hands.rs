//! What the virtual user feels in the hands: the feedback agent's own step
//! ([`feedback_agent::Feedback`]) drives a pair of simulated actuators, and the pulse
//! train it plays becomes one of Taylor's four rumble states (2017, Table 2.1) as a
//! person would perceive it.
//!
//! A pulsed cue switches the motor off between pulses; nobody reads the gap as "path
//! clear". A side is felt as rumbling while its motor runs and for one gap of the
//! pattern it last ran with (plus [`GAP_MARGIN_NS`]): the user notices the end of a
//! pulse train when the next pulse fails to come, or when a pulse comes on the other
//! side alone (a cue moving from left to right is felt as right at its first pulse,
//! not as both for a gap). The feedback agent's offline alert and the degraded pattern
//! (half level) are felt as "detection offline", distinct from the four obstacle
//! states, as the safety rules intend; each hand is judged on its own, so the tail of
//! either (the pulse gap after detection came back) is never felt as an obstacle.

use feedback_agent::device::{DeviceOutput, HapticDevice};
use feedback_agent::haptic_cue::Levels;
use schemas::{Applied, AppliedAction, HapticPattern};

/// Device name of the simulated hands in `feedback/applied` records.
pub const HANDS: &str = "hands";

/// Slack added to a pattern's gap before a side is felt as stopped, ns.
pub const GAP_MARGIN_NS: u64 = 20_000_000;

/// Levels below this are not an obstacle rumble (obstacle cues run at full level; the
/// degraded pattern at half).
const OBSTACLE_LEVEL: f32 = 0.75;

/// The rumble state a person perceives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Felt {
    /// Nothing: walk on.
    None,
    /// Left hand rumbles: turn left.
    Left,
    /// Right hand rumbles: turn right.
    Right,
    /// Both rumble: stop, turn in place until clear.
    Both,
    /// The system says it cannot see (offline alert, degraded pattern): stand still.
    Offline,
}

/// The simulated actuators: records every change of levels as an applied action.
#[derive(Debug, Default)]
pub struct Hands {
    last: Option<(Levels, HapticPattern)>,
}

impl HapticDevice for Hands {
    fn name(&self) -> &str {
        HANDS
    }

    fn set_levels(
        &mut self,
        levels: Levels,
        pattern: HapticPattern,
        cause_ns: u64,
        now_ns: u64,
        _refresh: bool,
        out: &mut DeviceOutput,
    ) {
        if self.last == Some((levels, pattern)) {
            return;
        }
        self.last = Some((levels, pattern));
        out.applied(HANDS, AppliedAction::Rumble { left: levels.left, right: levels.right, pattern }, now_ns, cause_ns);
    }

    fn off(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.set_levels(Levels::OFF, HapticPattern::Steady, 0, now_ns, false, out);
    }
}

/// One hand's recent sensation.
#[derive(Debug, Clone, Copy, Default)]
struct Side {
    level: f32,
    /// When the motor last ran (or still runs), and at what level.
    last_on_ns: Option<u64>,
    last_level: f32,
    /// Gap of the pattern the motor last ran with.
    gap_ns: u64,
    /// When the last two pulses began (the motor going from off to on).
    onsets_ns: [Option<u64>; 2],
    /// The motor last ran for the offline alert (detection offline), not an obstacle.
    alert: bool,
}

impl Side {
    /// The motor set to `level` at `now_ns`; `alert`: while detection is offline.
    /// Returns whether a pulse begins.
    fn set(&mut self, level: f32, pattern: HapticPattern, now_ns: u64, alert: bool) -> bool {
        let onset = level > 0.0 && self.level <= 0.0;
        if onset {
            self.onsets_ns = [self.onsets_ns[1], Some(now_ns)];
        }
        if level > 0.0 {
            self.last_on_ns = Some(now_ns);
            self.last_level = level;
            self.alert = alert;
            self.gap_ns = match pattern {
                HapticPattern::Steady => 0,
                HapticPattern::Pulses { period_ms, duty } => {
                    (period_ms as f64 * 1e6 * (1.0 - duty.clamp(0.0, 1.0) as f64)).round() as u64
                }
            };
        } else if self.level > 0.0 {
            // the motor ran until now
            self.last_on_ns = Some(now_ns);
        }
        self.level = level;
        onset
    }

    /// The train has ended (a pulse came on the other side alone): the gap left of
    /// it is no longer felt.
    fn end_train(&mut self) {
        if self.level <= 0.0 {
            self.last_on_ns = None;
        }
    }

    /// Felt at `now_ns` as an obstacle cue: a full-level pulse train of the obstacle
    /// cues, not the offline alert or the degraded pattern.
    fn obstacle(&self, now_ns: u64) -> bool {
        self.felt(now_ns) >= OBSTACLE_LEVEL && !self.alert
    }

    /// The time between the last two pulses while the side is felt rumbling, ns: what
    /// a person can tell of the pulse rate (nothing before the second pulse).
    fn pulse_period_ns(&self, now_ns: u64) -> Option<u64> {
        match self.onsets_ns {
            [Some(a), Some(b)] if self.felt(now_ns) > 0.0 && b > a => Some(b - a),
            _ => None,
        }
    }

    /// The level felt at `now_ns` (0 once a gap has passed without a pulse).
    fn felt(&self, now_ns: u64) -> f32 {
        if self.level > 0.0 {
            return self.level;
        }
        match self.last_on_ns {
            Some(t) if now_ns.saturating_sub(t) <= self.gap_ns + GAP_MARGIN_NS => self.last_level,
            _ => 0.0,
        }
    }
}

/// Turns the applied records of [`Hands`] (and the offline warnings) into [`Felt`].
#[derive(Debug, Clone, Default)]
pub struct FeltRumble {
    left: Side,
    right: Side,
    offline: bool,
}

impl FeltRumble {
    /// Takes one applied action (others than the hands' rumble and offline warnings
    /// are ignored).
    pub fn apply(&mut self, a: &Applied) {
        match &a.action {
            AppliedAction::Rumble { left, right, pattern } if a.device == HANDS => {
                let left_onset = self.left.set(*left, *pattern, a.applied_ns, self.offline);
                let right_onset = self.right.set(*right, *pattern, a.applied_ns, self.offline);
                if left_onset && !right_onset {
                    self.right.end_train();
                }
                if right_onset && !left_onset {
                    self.left.end_train();
                }
            }
            AppliedAction::OfflineWarning { offline, .. } => self.offline = *offline,
            _ => {}
        }
    }

    /// The state felt at `now_ns`.
    pub fn felt(&self, now_ns: u64) -> Felt {
        if self.offline {
            return Felt::Offline;
        }
        match (self.left.obstacle(now_ns), self.right.obstacle(now_ns)) {
            (true, true) => Felt::Both,
            (true, false) => Felt::Left,
            (false, true) => Felt::Right,
            // the degraded pattern, or the tail of the offline alert
            (false, false) if self.left.felt(now_ns) > 0.0 || self.right.felt(now_ns) > 0.0 => Felt::Offline,
            (false, false) => Felt::None,
        }
    }

    /// The pulse period felt at `now_ns` on the rumbling side(s), ms (the shorter of
    /// the two); `None` while nothing pulses or only one pulse has come.
    pub fn pulse_period_ms(&self, now_ns: u64) -> Option<f64> {
        let l = self.left.pulse_period_ns(now_ns);
        let r = self.right.pulse_period_ns(now_ns);
        l.into_iter().chain(r).min().map(|ns| ns as f64 / 1e6)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    fn rumble(left: f32, right: f32, pattern: HapticPattern, at_ms: u64) -> Applied {
        Applied {
            device: HANDS.into(),
            action: AppliedAction::Rumble { left, right, pattern },
            applied_ns: at_ms * MS,
            cause_capture_ns: 0,
        }
    }

    #[test]
    fn pulse_gap_is_felt_as_one_continuous_left_rumble_then_it_stops() {
        let p = HapticPattern::Pulses { period_ms: 400, duty: 0.5 };
        let mut f = FeltRumble::default();
        f.apply(&rumble(1.0, 0.0, p, 0));
        f.apply(&rumble(0.0, 0.0, p, 200));
        assert_eq!(f.felt(300 * MS), Felt::Left, "inside the 200 ms gap");
        assert_eq!(f.felt(419 * MS), Felt::Left);
        assert_eq!(f.felt(421 * MS), Felt::None, "the next pulse did not come");
    }

    #[test]
    fn pulse_rate_is_felt_from_the_second_pulse_on() {
        let fast = HapticPattern::Pulses { period_ms: 200, duty: 0.5 };
        let mut f = FeltRumble::default();
        f.apply(&rumble(1.0, 0.0, fast, 0));
        assert_eq!(f.pulse_period_ms(50 * MS), None, "one pulse tells no rate");
        f.apply(&rumble(0.0, 0.0, fast, 100));
        f.apply(&rumble(1.0, 0.0, fast, 200));
        assert_eq!(f.pulse_period_ms(250 * MS), Some(200.0));
        // the train stops: no rate once the side is no longer felt
        f.apply(&rumble(0.0, 0.0, fast, 300));
        assert_eq!(f.pulse_period_ms(300 * MS + 100 * MS + GAP_MARGIN_NS + MS), None);
        // a steady rumble has no pulses to count
        let mut g = FeltRumble::default();
        g.apply(&rumble(1.0, 1.0, HapticPattern::Steady, 0));
        assert_eq!(g.pulse_period_ms(500 * MS), None);
    }

    #[test]
    fn half_level_pattern_and_offline_warning_are_felt_as_offline() {
        let mut f = FeltRumble::default();
        f.apply(&rumble(0.5, 0.5, HapticPattern::Pulses { period_ms: 1000, duty: 0.15 }, 0));
        assert_eq!(f.felt(10 * MS), Felt::Offline);
        let mut g = FeltRumble::default();
        g.apply(&Applied {
            device: "feedback-agent".into(),
            action: AppliedAction::OfflineWarning { offline: true, reason: "perception/hazard stale".into() },
            applied_ns: 0,
            cause_capture_ns: 0,
        });
        assert_eq!(g.felt(0), Felt::Offline);
    }

    use feedback_agent::{Feedback, StepSettings};
    use schemas::{GroundState, HapticIntent, Hazard};

    const RT0: u64 = 1_000_000_000;

    fn clear() -> HapticIntent {
        HapticIntent { left: 0.0, right: 0.0, pattern: HapticPattern::Steady, ttl_ms: 300 }
    }

    fn degraded() -> HapticIntent {
        HapticIntent {
            left: 0.5,
            right: 0.5,
            pattern: HapticPattern::Pulses { period_ms: 1000, duty: 0.15 },
            ttl_ms: 300,
        }
    }

    /// The feedback agent's own step driving the hands: clear until 100 ms, ground
    /// degraded (detection offline, the degraded cue every frame) until `back_ms`, then
    /// fresh hazards with `intent`. The state felt every 8 ms for 400 ms after `back_ms`.
    fn offline_then_back(back_ms: u64, intent: HapticIntent) -> Vec<(u64, Felt)> {
        let mut fb = Feedback::new(StepSettings::default(), vec![Box::new(Hands::default())], Vec::new(), RT0);
        let mut f = FeltRumble::default();
        let mut out = Vec::new();
        let mut ms = 0;
        while ms < back_ms + 400 {
            let now = RT0 + ms * MS;
            if ms % 32 == 0 {
                let (ground, i) = match ms {
                    _ if ms < 100 => (GroundState::Found, clear()),
                    _ if ms < back_ms => (GroundState::Degraded, degraded()),
                    _ => (GroundState::Found, intent),
                };
                fb.on_hazard(&Hazard::nothing_ahead(ms, ground), now, now);
                let _ = fb.on_haptic(&i, now, now);
            }
            fb.tick(now);
            for a in fb.drain_applied() {
                f.apply(&a);
            }
            if ms > 150 && ms < back_ms {
                assert_eq!(f.felt(now), Felt::Offline, "offline at {ms} ms");
            }
            if ms >= back_ms {
                out.push((ms - back_ms, f.felt(now)));
            }
            ms += 8;
        }
        out
    }

    #[test]
    fn the_tail_of_the_offline_alert_is_never_felt_as_an_obstacle() {
        // back after 0.4 s offline, while the alert (alternating hands at full level)
        // still plays, and nothing ahead: its last gap is felt as offline, then nothing
        let after = offline_then_back(512, clear());
        let phantom: Vec<_> =
            after.iter().filter(|(_, s)| matches!(s, Felt::Left | Felt::Right | Felt::Both)).collect();
        assert!(phantom.is_empty(), "nothing ahead, yet felt: {phantom:?}");
        assert_eq!(after.last().map(|&(_, s)| s), Some(Felt::None));
    }

    #[test]
    fn a_side_cue_after_the_degraded_pattern_is_felt_on_its_side_alone() {
        // back after 2 s offline (the degraded half-level pulses playing) with an
        // obstacle on the right: the left cue, not both
        let p = HapticPattern::Pulses { period_ms: 400, duty: 0.5 };
        let after = offline_then_back(2016, HapticIntent { left: 1.0, right: 0.0, pattern: p, ttl_ms: 300 });
        let wrong: Vec<_> = after.iter().filter(|(_, s)| *s != Felt::Left).collect();
        assert!(wrong.is_empty(), "a left cue felt as: {wrong:?}");
    }

    #[test]
    fn a_cue_moving_to_the_other_side_is_felt_there_at_its_first_pulse() {
        let p = HapticPattern::Pulses { period_ms: 700, duty: 0.5 };
        let mut f = FeltRumble::default();
        f.apply(&rumble(1.0, 0.0, p, 0));
        f.apply(&rumble(0.0, 0.0, p, 350));
        assert_eq!(f.felt(390 * MS), Felt::Left, "in the gap");
        f.apply(&rumble(0.0, 1.0, p, 400));
        for ms in [400, 600, 719, 721] {
            assert_eq!(f.felt(ms * MS), Felt::Right, "at {ms} ms");
        }
        // both pulsing together, then the right stops: felt both through the gap,
        // then left at the left's next pulse alone
        let mut g = FeltRumble::default();
        g.apply(&rumble(1.0, 1.0, p, 0));
        g.apply(&rumble(0.0, 0.0, p, 350));
        assert_eq!(g.felt(500 * MS), Felt::Both);
        g.apply(&rumble(1.0, 0.0, p, 700));
        assert_eq!(g.felt(701 * MS), Felt::Left);
    }

    #[test]
    fn full_level_on_both_sides_is_both() {
        let mut f = FeltRumble::default();
        f.apply(&rumble(1.0, 1.0, HapticPattern::Steady, 0));
        assert_eq!(f.felt(5 * MS), Felt::Both);
        f.apply(&rumble(0.0, 0.0, HapticPattern::Steady, 10));
        assert_eq!(f.felt(10 * MS + GAP_MARGIN_NS + 1), Felt::None);
    }
}
