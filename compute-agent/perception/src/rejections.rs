//! When rejected frames mean the user must be told perception is blind.
//!
//! One corrupt frame keeps the previous cue (its time to live covers about ten
//! frames). Frames rejected in a row are different: the intent's time to live runs out
//! and the hands go quiet, which a user reads as "clear". So the third rejection in a
//! row (100 ms at 30 Hz) and every 30th after it publish the blind state: rumble
//! `Both` in the hazard, the distinct "unavailable" cue on the hands. The compute
//! agent and the virtual user study both use this, so the study feels what a user
//! would.

use schemas::Rumble;

use super::Perception;

/// Rejections in a row before the blind state is published.
pub const REJECTIONS_BEFORE_BLIND: u32 = 3;
/// While rejections go on, the blind state is published again every this many frames.
pub const BLIND_REPEAT_FRAMES: u32 = 30;

/// Counts rejected frames in a row.
#[derive(Debug, Clone, Default)]
pub struct Rejections {
    in_a_row: u32,
}

impl Rejections {
    /// Records one frame's outcome; `true` when the blind state must be published now.
    pub fn record(&mut self, accepted: bool) -> bool {
        self.in_a_row = if accepted { 0 } else { self.in_a_row + 1 };
        self.in_a_row == REJECTIONS_BEFORE_BLIND
            || (self.in_a_row > REJECTIONS_BEFORE_BLIND && self.in_a_row.is_multiple_of(BLIND_REPEAT_FRAMES))
    }

    /// The refusals in a row mean perception is blind (from the
    /// [`REJECTIONS_BEFORE_BLIND`]th on).
    pub fn blind(&self) -> bool {
        self.in_a_row >= REJECTIONS_BEFORE_BLIND
    }

    /// Frames rejected in a row so far.
    pub fn in_a_row(&self) -> u32 {
        self.in_a_row
    }
}

/// What perception reports while blind: ground `Degraded`, rumble `Both` (stop).
pub fn blind() -> Perception {
    Perception { rumble: Rumble::Both, ..Perception::empty() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn third_rejection_in_a_row_and_every_thirtieth_after_publish_blind() {
        let mut r = Rejections::default();
        let outcomes = [false, false, true, false, false, false];
        let published: Vec<bool> = outcomes.iter().map(|&ok| r.record(ok)).collect();
        assert_eq!(published, [false, false, false, false, false, true]);
        let mut again = Vec::new();
        for _ in 4..=70 {
            if r.record(false) {
                again.push(r.in_a_row());
            }
        }
        assert_eq!(again, [30, 60]);
        assert!(r.blind());
        assert!(!r.record(true));
        assert_eq!(r.in_a_row(), 0);
        assert!(!r.blind());
    }

    #[test]
    fn blind_is_a_degraded_stop() {
        let b = blind();
        assert_eq!(b.rumble, Rumble::Both);
        assert_eq!(b.ground, schemas::GroundState::Degraded);
    }
}
