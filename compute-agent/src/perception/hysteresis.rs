//! Beyond the thesis: debounce of the rumble state. Taylor's users got 32-39 signals on
//! a short course, many of them flicker between frames. Escalations (clear -> one side,
//! anything -> both) pass at once; anything calmer, and a change of side, must persist
//! for `relax_frames` frames first. Off by default (see `HysteresisConfig`).

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
        if !cfg.enabled || severity(raw) > severity(self.current) {
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

    fn on() -> HysteresisConfig {
        HysteresisConfig { enabled: true, ..Default::default() }
    }

    #[test]
    fn single_clear_frame_does_not_drop_a_warning() {
        let cfg = on();
        let mut d = RumbleDebounce::default();
        assert_eq!(d.update(Rumble::Left, &cfg), Rumble::Left, "warning passes at once");
        assert_eq!(d.update(Rumble::None, &cfg), Rumble::Left);
        assert_eq!(d.update(Rumble::Left, &cfg), Rumble::Left);
        for _ in 1..cfg.relax_frames {
            assert_eq!(d.update(Rumble::None, &cfg), Rumble::Left);
        }
        assert_eq!(d.update(Rumble::None, &cfg), Rumble::None, "clear after relax_frames in a row");
    }

    #[test]
    fn flapping_sides_hold_the_first_side_and_both_escalates_at_once() {
        let cfg = on();
        let mut d = RumbleDebounce::default();
        let shown: Vec<_> =
            [Rumble::Left, Rumble::Right, Rumble::Left, Rumble::Right].iter().map(|&r| d.update(r, &cfg)).collect();
        assert_eq!(shown, vec![Rumble::Left; 4]);
        assert_eq!(d.update(Rumble::Both, &cfg), Rumble::Both);
    }

    #[test]
    fn switched_off_by_default_passes_raw_states() {
        let cfg = HysteresisConfig::default();
        assert!(!cfg.enabled);
        let mut d = RumbleDebounce::default();
        assert_eq!(d.update(Rumble::Left, &cfg), Rumble::Left);
        assert_eq!(d.update(Rumble::None, &cfg), Rumble::None);
    }
}
