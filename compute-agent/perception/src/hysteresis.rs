//! Beyond the thesis: debounce of the rumble state. Escalations (clear -> one side,
//! anything -> both) pass at once; a stop is released (to a side or to clear) only
//! once the calmer state has persisted for `relax_frames` frames. With `hold_sides`,
//! a side cue is held the same way against clear and against the other side. Off by default (see `HysteresisConfig`).

use schemas::Rumble;

use super::config::HysteresisConfig;

/// Debounced rumble state.
#[derive(Debug)]
pub struct RumbleDebounce {
    current: Rumble,
    candidate: Rumble,
    candidate_frames: u32,
}

impl Default for RumbleDebounce {
    fn default() -> Self {
        Self { current: Rumble::None, candidate: Rumble::None, candidate_frames: 0 }
    }
}

fn severity(r: Rumble) -> u8 {
    match r {
        Rumble::None => 0,
        Rumble::Left | Rumble::Right => 1,
        Rumble::Both => 2,
    }
}

impl RumbleDebounce {
    /// Feeds this frame's raw state; returns the state to show.
    pub fn update(&mut self, raw: Rumble, cfg: &HysteresisConfig) -> Rumble {
        let held = self.current == Rumble::Both || cfg.hold_sides;
        if !cfg.enabled || !held || severity(raw) > severity(self.current) {
            self.current = raw;
            self.candidate_frames = 0;
            return raw;
        }
        if raw == self.current {
            self.candidate_frames = 0;
            return raw;
        }
        if raw == self.candidate {
            self.candidate_frames += 1;
        } else {
            self.candidate = raw;
            self.candidate_frames = 1;
        }
        if self.candidate_frames >= cfg.relax_frames {
            self.current = raw;
            self.candidate_frames = 0;
        }
        self.current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn holding_sides() -> HysteresisConfig {
        HysteresisConfig { hold_sides: true, ..Default::default() }
    }

    #[test]
    fn a_stop_is_released_only_after_relax_frames_of_clear() {
        let cfg = HysteresisConfig::default();
        let mut d = RumbleDebounce::default();
        assert_eq!(d.update(Rumble::Both, &cfg), Rumble::Both, "a stop passes at once");
        assert_eq!(d.update(Rumble::None, &cfg), Rumble::Both);
        assert_eq!(d.update(Rumble::Both, &cfg), Rumble::Both);
        for _ in 1..cfg.relax_frames {
            assert_eq!(d.update(Rumble::None, &cfg), Rumble::Both);
        }
        assert_eq!(d.update(Rumble::None, &cfg), Rumble::None, "clear after relax_frames in a row");
    }

    #[test]
    fn side_cues_follow_the_raw_state_unless_held() {
        let raw = [Rumble::Left, Rumble::None, Rumble::Right, Rumble::Left, Rumble::None];
        let mut d = RumbleDebounce::default();
        let shown: Vec<_> = raw.iter().map(|&r| d.update(r, &HysteresisConfig::default())).collect();
        assert_eq!(shown, raw);
        let mut d = RumbleDebounce::default();
        let shown: Vec<_> = raw.iter().map(|&r| d.update(r, &holding_sides())).collect();
        assert_eq!(shown, vec![Rumble::Left; 5], "held: the first side stays");
        assert_eq!(d.update(Rumble::Both, &holding_sides()), Rumble::Both, "both escalates at once");
    }

    #[test]
    fn switched_off_passes_raw_states() {
        let cfg = HysteresisConfig { enabled: false, ..Default::default() };
        let mut d = RumbleDebounce::default();
        assert_eq!(d.update(Rumble::Both, &cfg), Rumble::Both);
        assert_eq!(d.update(Rumble::None, &cfg), Rumble::None);
    }
}
