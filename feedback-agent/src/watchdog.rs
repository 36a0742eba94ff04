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
}
