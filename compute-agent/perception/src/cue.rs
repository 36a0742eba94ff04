//! Rumble state -> device-neutral haptic intent.
//!
//! Taylor's Table 2.1 rumbles the left controller for "turn left" (obstacle on the
//! right) and both for "stop". We keep that, and like ISANA's beep train let the pulse
//! period carry distance: it shortens linearly from `far_period_ms` at `far_m` to
//! `near_period_ms` at `near_m`. Every intent has a time to live, so a device stops on
//! its own when intents stop coming.
//!
//! Never a silent "clear" while not seeing: with the ground `Degraded` (or no
//! perception at all, [`cue_unavailable`]) and no obstacle warning, the cue is the
//! degraded pattern: both sides at `degraded_level`, slow short ticks
//! (`degraded_period_ms`, `degraded_duty`), distinct from any obstacle pattern (those
//! run at full level). An obstacle warning while degraded is still given as a warning.

use serde::Deserialize;

use schemas::{GroundState, HapticIntent, HapticPattern, Rumble};

use super::Perception;

/// Shape of the haptic cues.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default)]
pub struct CueConfig {
    /// Time to live of each intent, ms (about 10 frames at 30 Hz).
    pub ttl_ms: u32,
    /// Pulse period at or nearer than `near_m`, ms.
    pub near_period_ms: u32,
    /// Pulse period at or beyond `far_m`, ms.
    pub far_period_ms: u32,
    /// Near end of the distance scale, metres.
    pub near_m: f32,
    /// Far end of the distance scale, metres (the FICF path depth).
    pub far_m: f32,
    /// Fraction of each pulse the motor is on.
    pub duty: f32,
    /// Level of both sides in the degraded pattern.
    pub degraded_level: f32,
    /// Period of the degraded pattern, ms.
    pub degraded_period_ms: u32,
    /// Duty of the degraded pattern.
    pub degraded_duty: f32,
}

impl Default for CueConfig {
    fn default() -> Self {
        Self {
            ttl_ms: 300,
            near_period_ms: 150,
            far_period_ms: 700,
            near_m: 0.5,
            far_m: 3.5,
            duty: 0.5,
            degraded_level: 0.5,
            degraded_period_ms: 1000,
            degraded_duty: 0.15,
        }
    }
}

/// The haptic intent for one perception result.
pub fn cue(p: &Perception, cfg: &CueConfig) -> HapticIntent {
    let (left, right) = match p.rumble {
        Rumble::None if p.ground == GroundState::Degraded => return cue_unavailable(cfg),
        Rumble::None => {
            return HapticIntent { left: 0.0, right: 0.0, pattern: HapticPattern::Steady, ttl_ms: cfg.ttl_ms };
        }
        Rumble::Left => (1.0, 0.0),
        Rumble::Right => (0.0, 1.0),
        Rumble::Both => (1.0, 1.0),
    };
    HapticIntent {
        left,
        right,
        pattern: HapticPattern::Pulses { period_ms: period_ms(p.nearest_m, cfg), duty: cfg.duty },
        ttl_ms: cfg.ttl_ms,
    }
}

/// The degraded pattern: for a degraded ground, and for frames perception rejected.
pub fn cue_unavailable(cfg: &CueConfig) -> HapticIntent {
    HapticIntent {
        left: cfg.degraded_level,
        right: cfg.degraded_level,
        pattern: HapticPattern::Pulses { period_ms: cfg.degraded_period_ms, duty: cfg.degraded_duty },
        ttl_ms: cfg.ttl_ms,
    }
}

fn period_ms(nearest_m: f32, cfg: &CueConfig) -> u32 {
    let span = (cfg.far_m - cfg.near_m).max(1e-3);
    // unknown distance (NaN) counts as near: the warning is already on
    let t = if nearest_m.is_finite() { ((nearest_m - cfg.near_m) / span).clamp(0.0, 1.0) } else { 0.0 };
    let (near, far) = (cfg.near_period_ms as f32, cfg.far_period_ms as f32);
    (near + t * (far - near)).round() as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn perception(rumble: Rumble, ground: GroundState, nearest_m: f32) -> Perception {
        Perception { rumble, ground, nearest_m, ..Perception::empty() }
    }

    #[test]
    fn rumble_left_drives_the_left_side_with_faster_pulses_when_nearer() {
        let cfg = CueConfig::default();
        let far = cue(&perception(Rumble::Left, GroundState::Found, 3.0), &cfg);
        let near = cue(&perception(Rumble::Left, GroundState::Found, 0.8), &cfg);
        assert_eq!((far.left, far.right), (1.0, 0.0));
        let period = |i: &HapticIntent| match i.pattern {
            HapticPattern::Pulses { period_ms, .. } => period_ms,
            HapticPattern::Steady => 0,
        };
        assert_eq!(period(&near), 205);
        assert_eq!(period(&far), 608);
        assert_eq!(far.ttl_ms, 300);
    }

    #[test]
    fn degraded_ground_is_never_a_silent_clear() {
        let cfg = CueConfig::default();
        let i = cue(&perception(Rumble::None, GroundState::Degraded, f32::INFINITY), &cfg);
        assert_eq!((i.left, i.right), (0.5, 0.5));
        assert_eq!(i.pattern, HapticPattern::Pulses { period_ms: 1000, duty: 0.15 });
        assert_eq!(cue_unavailable(&cfg), i);
        let clear = cue(&perception(Rumble::None, GroundState::Found, f32::INFINITY), &cfg);
        assert_eq!((clear.left, clear.right, clear.pattern), (0.0, 0.0, HapticPattern::Steady));
    }

    #[test]
    fn both_blocks_with_full_level_distinct_from_degraded() {
        let cfg = CueConfig::default();
        let i = cue(&perception(Rumble::Both, GroundState::Degraded, 0.4), &cfg);
        assert_eq!((i.left, i.right), (1.0, 1.0));
        assert_eq!(i.pattern, HapticPattern::Pulses { period_ms: 150, duty: 0.5 });
    }
}
