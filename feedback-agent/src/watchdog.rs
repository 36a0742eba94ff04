//! The detection watchdog: safety rule 1 of ARCHITECTURE.md ("silence must never mean
//! path clear when the system is not actually seeing").
//!
//! Fed with each hazard's capture instant on the agent's own clock (the depth frame's
//! capture stamp with the sender's clock offset taken out, clamped between a deadline
//! before the hazard's arrival and the arrival: a clock stamping ahead counts from the
//! arrival, as before, and no stamp can stretch the deadline), the compute
//! agent's liveliness and the ground state, it decides when obstacle detection is
//! offline and when it is back. Counting from the capture makes "500 ms" mean 500 ms
//! since the newest frame the user was warned about was taken, the pipeline's own
//! latency included, as safety rule 1 asks. At start nothing has been seen:
//! once the deadline passes without a hazard, that too is "offline" (not yet running).

use schemas::GroundState;

/// Why obstacle detection is considered offline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OfflineReason {
    /// No hazard has arrived since start, and the deadline has passed.
    NotYetRunning,
    /// Hazards stopped arriving for longer than the deadline.
    HazardStale,
    /// The compute agent's liveliness token disappeared.
    ComputeGone,
    /// The perception says it cannot see the ground.
    GroundDegraded,
}

impl OfflineReason {
    /// Short text for `feedback/applied` and logs.
    pub fn describe(self) -> &'static str {
        match self {
            OfflineReason::NotYetRunning => "no hazard received since start",
            OfflineReason::HazardStale => "perception/hazard stale",
            OfflineReason::ComputeGone => "compute agent liveliness lost",
            OfflineReason::GroundDegraded => "ground degraded",
        }
    }

    /// What the user hears.
    pub fn utterance(self) -> &'static str {
        match self {
            OfflineReason::NotYetRunning => "obstacle detection not yet running",
            _ => "obstacle detection offline",
        }
    }
}

/// A change the user must be told about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transition {
    /// Detection went offline.
    Offline(OfflineReason),
    /// Detection is back.
    Back,
}

/// Where the watchdog stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DetectionState {
    /// Started, deadline not yet passed, nothing heard.
    Starting,
    /// Hazards fresh, compute alive, ground seen.
    Online,
    /// Offline, for this reason (the first one found).
    Offline(OfflineReason),
}

/// Offline/back state machine; every input carries its own `now`.
#[derive(Debug, Clone)]
pub struct DetectionWatchdog {
    started_ns: u64,
    deadline_ns: u64,
    /// Capture instant (own clock) of the newest hazard.
    last_hazard_ns: Option<u64>,
    ground_degraded: bool,
    compute_alive: Option<bool>,
    state: DetectionState,
}

impl DetectionWatchdog {
    /// A watchdog started at `started_ns` with the freshness deadline `deadline_ms`
    /// (ARCHITECTURE.md default 500 ms).
    pub fn new(started_ns: u64, deadline_ms: u64) -> Self {
        Self {
            started_ns,
            deadline_ns: deadline_ms.saturating_mul(1_000_000),
            last_hazard_ns: None,
            ground_degraded: false,
            compute_alive: None,
            state: DetectionState::Starting,
        }
    }

    /// A hazard reporting `ground` arrived at `arrival_ns`, from a frame captured at
    /// `captured_ns` (own clock; clamped into the deadline before arrival).
    pub fn on_hazard(&mut self, captured_ns: u64, arrival_ns: u64, ground: GroundState) {
        let captured = captured_ns.clamp(arrival_ns.saturating_sub(self.deadline_ns), arrival_ns);
        self.last_hazard_ns = Some(self.last_hazard_ns.map_or(captured, |t| t.max(captured)));
        self.ground_degraded = ground == GroundState::Degraded;
    }

    /// The compute agent's liveliness token appeared (`true`) or disappeared.
    pub fn on_compute_liveliness(&mut self, alive: bool) {
        self.compute_alive = Some(alive);
    }

    /// Current state (without advancing time).
    pub fn state(&self) -> DetectionState {
        self.state
    }

    fn problem(&self, now_ns: u64) -> Option<Option<OfflineReason>> {
        if self.compute_alive == Some(false) {
            return Some(Some(OfflineReason::ComputeGone));
        }
        match self.last_hazard_ns {
            None if now_ns.saturating_sub(self.started_ns) >= self.deadline_ns => {
                Some(Some(OfflineReason::NotYetRunning))
            }
            // Within the start-up grace period: nothing to say yet either way.
            None => None,
            Some(t) if now_ns.saturating_sub(t) > self.deadline_ns => Some(Some(OfflineReason::HazardStale)),
            Some(_) if self.ground_degraded => Some(Some(OfflineReason::GroundDegraded)),
            Some(_) => Some(None),
        }
    }

    /// Advance to `now_ns`; returns the transition to announce, if any.
    pub fn step(&mut self, now_ns: u64) -> Option<Transition> {
        let problem = self.problem(now_ns)?;
        match (self.state, problem) {
            (DetectionState::Offline(_), Some(_)) => None,
            (_, Some(reason)) => {
                self.state = DetectionState::Offline(reason);
                Some(Transition::Offline(reason))
            }
            (DetectionState::Offline(_), None) => {
                self.state = DetectionState::Online;
                Some(Transition::Back)
            }
            (_, None) => {
                self.state = DetectionState::Online;
                None
            }
        }
    }

    /// When `step` must next be called even if no input arrives: the instant the
    /// newest hazard (or the start-up grace) goes stale. `None` while offline: only a
    /// new input can bring detection back.
    pub fn next_check_ns(&self) -> Option<u64> {
        match (self.state, self.last_hazard_ns) {
            (DetectionState::Offline(_), _) => None,
            (_, None) => Some(self.started_ns + self.deadline_ns),
            (_, Some(t)) => Some(t + self.deadline_ns + 1),
        }
    }
}

/// How long the camera's frames must say the other thing about gravity before the user
/// is told (a hazard or two without it, a dropped IMU sample, is not news), ns.
pub const GRAVITY_HOLD_NS: u64 = 1_000_000_000;

/// Whether the camera's frames carry gravity (its IMU), as the user was last told.
///
/// Without gravity the perception still finds a floor near the camera's down axis, but
/// looks for lower ground only along the path ahead (not for the edge of a step beside
/// it) and cannot keep a floor a near wall hides: the user is told once, when hazards
/// that see the ground have come without gravity for [`GRAVITY_HOLD_NS`], and told again
/// when it is back as long. Degraded hazards are the detection watchdog's (their
/// `gravity` says nothing: no frame was perceived).
#[derive(Debug, Clone, Default)]
pub struct GravityWatch {
    told_missing: bool,
    /// Capture instant of the first hazard of the current run that disagrees with what
    /// the user was told.
    disagreeing_since_ns: Option<u64>,
}

impl GravityWatch {
    /// A hazard captured at `captured_ns` (own clock) with its `ground` and `gravity`.
    /// Returns what to say when the user must be told.
    pub fn on_hazard(&mut self, captured_ns: u64, ground: GroundState, gravity: bool) -> Option<&'static str> {
        if ground == GroundState::Degraded {
            return None;
        }
        if gravity != self.told_missing {
            self.disagreeing_since_ns = None;
            return None;
        }
        let since = *self.disagreeing_since_ns.get_or_insert(captured_ns);
        if captured_ns.saturating_sub(since) < GRAVITY_HOLD_NS {
            return None;
        }
        self.told_missing = !gravity;
        self.disagreeing_since_ns = None;
        Some(if gravity { GRAVITY_BACK } else { GRAVITY_MISSING })
    }

    /// True once the user was told the frames come without gravity (until told it is back).
    pub fn told_missing(&self) -> bool {
        self.told_missing
    }
}

/// What the user hears when the camera's frames come without gravity.
pub const GRAVITY_MISSING: &str = "No tilt sensor: steps down may be missed";
/// ... and when they carry it again.
pub const GRAVITY_BACK: &str = "Tilt sensor back";

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;
    const T0: u64 = 1_700_000_000_000_000_000;

    #[test]
    fn silence_at_start_becomes_not_yet_running_at_the_deadline() {
        let mut w = DetectionWatchdog::new(T0, 500);
        assert_eq!(w.step(T0 + 499 * MS), None);
        assert_eq!(w.state(), DetectionState::Starting);
        assert_eq!(w.next_check_ns(), Some(T0 + 500 * MS));
        assert_eq!(w.step(T0 + 500 * MS), Some(Transition::Offline(OfflineReason::NotYetRunning)));
        // Said once, not on every step.
        assert_eq!(w.step(T0 + 900 * MS), None);
    }

    #[test]
    fn the_deadline_counts_from_the_capture_not_the_arrival() {
        let mut w = DetectionWatchdog::new(T0, 500);
        // captured at 1000 ms, arrived 40 ms later (the pipeline's latency)
        w.on_hazard(T0 + 1000 * MS, T0 + 1040 * MS, GroundState::Found);
        assert_eq!(w.step(T0 + 1040 * MS), None);
        assert_eq!(w.next_check_ns(), Some(T0 + 1500 * MS + 1));
        assert_eq!(w.step(T0 + 1500 * MS), None);
        assert_eq!(w.step(T0 + 1500 * MS + 1), Some(Transition::Offline(OfflineReason::HazardStale)));
        // a stamp from the future (a clock ahead) counts from the arrival
        let mut w = DetectionWatchdog::new(T0, 500);
        w.on_hazard(T0 + 3000 * MS, T0 + 1000 * MS, GroundState::Found);
        assert_eq!(w.next_check_ns(), Some(T0 + 1500 * MS + 1));
        // and one from long ago at most a deadline back: stale at once, never later
        let mut w = DetectionWatchdog::new(T0, 500);
        w.on_hazard(T0, T0 + 5000 * MS, GroundState::Found);
        assert_eq!(w.next_check_ns(), Some(T0 + 5000 * MS + 1));
    }

    #[test]
    fn first_hazard_within_the_grace_period_goes_online_silently() {
        let mut w = DetectionWatchdog::new(T0, 500);
        w.on_hazard(T0 + 100 * MS, T0 + 100 * MS, GroundState::Found);
        assert_eq!(w.step(T0 + 100 * MS), None);
        assert_eq!(w.state(), DetectionState::Online);
    }

    #[test]
    fn first_hazard_after_not_yet_running_is_announced_as_back() {
        let mut w = DetectionWatchdog::new(T0, 500);
        w.step(T0 + 600 * MS);
        w.on_hazard(T0 + 700 * MS, T0 + 700 * MS, GroundState::Found);
        assert_eq!(w.step(T0 + 700 * MS), Some(Transition::Back));
    }

    #[test]
    fn hazards_stopping_for_more_than_500ms_is_offline_then_back_when_they_resume() {
        let mut w = DetectionWatchdog::new(T0, 500);
        for k in 0..10 {
            w.on_hazard(T0 + k * 33 * MS, T0 + k * 33 * MS, GroundState::Found);
            assert_eq!(w.step(T0 + k * 33 * MS), None);
        }
        let last = T0 + 9 * 33 * MS;
        assert_eq!(w.step(last + 500 * MS), None, "exactly at the deadline is still fresh");
        assert_eq!(w.next_check_ns(), Some(last + 500 * MS + 1));
        assert_eq!(w.step(last + 500 * MS + 1), Some(Transition::Offline(OfflineReason::HazardStale)));
        assert_eq!(w.next_check_ns(), None, "offline: nothing to wait for but a new hazard");
        w.on_hazard(last + 2000 * MS, last + 2000 * MS, GroundState::Found);
        assert_eq!(w.step(last + 2000 * MS), Some(Transition::Back));
        assert_eq!(w.state(), DetectionState::Online);
    }

    #[test]
    fn liveliness_loss_is_offline_at_once_even_with_fresh_hazards() {
        let mut w = DetectionWatchdog::new(T0, 500);
        w.on_compute_liveliness(true);
        w.on_hazard(T0 + 10 * MS, T0 + 10 * MS, GroundState::Found);
        assert_eq!(w.step(T0 + 10 * MS), None);
        w.on_compute_liveliness(false);
        assert_eq!(w.step(T0 + 20 * MS), Some(Transition::Offline(OfflineReason::ComputeGone)));
        // Token back but the last hazard is old: still offline until a fresh one.
        w.on_compute_liveliness(true);
        assert_eq!(w.step(T0 + 2000 * MS), None);
        assert_eq!(w.state(), DetectionState::Offline(OfflineReason::ComputeGone));
        w.on_hazard(T0 + 2010 * MS, T0 + 2010 * MS, GroundState::Found);
        assert_eq!(w.step(T0 + 2010 * MS), Some(Transition::Back));
    }

    #[test]
    fn degraded_ground_is_offline_and_found_ground_is_back() {
        let mut w = DetectionWatchdog::new(T0, 500);
        w.on_hazard(T0, T0, GroundState::Found);
        w.step(T0);
        w.on_hazard(T0 + 33 * MS, T0 + 33 * MS, GroundState::Lost);
        assert_eq!(w.step(T0 + 33 * MS), None, "one lost frame reuses the previous plane");
        w.on_hazard(T0 + 66 * MS, T0 + 66 * MS, GroundState::Degraded);
        assert_eq!(w.step(T0 + 66 * MS), Some(Transition::Offline(OfflineReason::GroundDegraded)));
        w.on_hazard(T0 + 99 * MS, T0 + 99 * MS, GroundState::Found);
        assert_eq!(w.step(T0 + 99 * MS), Some(Transition::Back));
    }

    #[test]
    fn late_arrival_stamp_does_not_move_freshness_backwards() {
        let mut w = DetectionWatchdog::new(T0, 500);
        w.on_hazard(T0 + 400 * MS, T0 + 400 * MS, GroundState::Found);
        w.on_hazard(T0 + 100 * MS, T0 + 100 * MS, GroundState::Found);
        assert_eq!(w.step(T0 + 800 * MS), None);
    }

    #[test]
    fn frames_without_gravity_for_a_second_are_told_once_and_its_return_too() {
        let mut w = GravityWatch::default();
        let at = |k: u64| T0 + k * 33 * MS;
        // present from the start: nothing to say
        assert!((0..60).all(|k| w.on_hazard(at(k), GroundState::Found, true).is_none()));
        // missing for 0.99 s, then back: still nothing (a dropped IMU is not news)
        assert!((60..90).all(|k| w.on_hazard(at(k), GroundState::Found, false).is_none()));
        assert!((90..120).all(|k| w.on_hazard(at(k), GroundState::Found, true).is_none()));
        // missing for a second: told once, at the hazard 1 s after the first without it
        let said: Vec<_> =
            (120..240).filter_map(|k| w.on_hazard(at(k), GroundState::Lost, false).map(|s| (k, s))).collect();
        assert_eq!(said, [(120 + 31, GRAVITY_MISSING)]);
        assert!(w.told_missing());
        // degraded hazards (no frame perceived) say nothing either way
        assert!((240..300).all(|k| w.on_hazard(at(k), GroundState::Degraded, true).is_none()));
        assert!(w.told_missing());
        let said: Vec<_> =
            (300..400).filter_map(|k| w.on_hazard(at(k), GroundState::Found, true).map(|s| (k, s))).collect();
        assert_eq!(said, [(300 + 31, GRAVITY_BACK)]);
        assert!(!w.told_missing());
    }
}
