//! Beyond the thesis: warn of what a turning user is turning into. The cost regions
//! look along the camera's heading; a user turning (back towards the goal's sound, or
//! round a corner) sweeps the cane's tip across what is beside them before it is in
//! those regions, and the first cue came less than a reaction time before the cane
//! touched (`docs/study-notes.md`, "Warning the way the user turns"). With a body-worn
//! gyro's turn rate, the costs are also taken along the heading the body will face
//! `ahead_s` on; while the path ahead is clear, a warning there is the cue now.
//!
//! The rate must be the body's, not the cane's: the cane's own yaw rate carries the
//! sweep (17 degrees each way at 0.7 Hz, up to 75 degrees/s), and looking ahead along it
//! read the corridor's walls as obstacles at every swing (measured: `corridor`, route,
//! 40 walks, 88 % -> 35 % completed); averaging the sweep out of it lags by half a
//! sweep and came too late.

use schemas::Rumble;

use super::config::{CostConfig, TurnAheadConfig};
use super::cost_function::{rumble, side_costs};
use super::Motion;

/// The rumble for the heading the body faces `cfg.ahead_s` on, turning at
/// `body_yaw_rate_rad_s` (positive left), over user-frame points `(x forward, y left)`;
/// `None` when off, the rate unknown or not a number, or the turn too slow to matter.
pub fn rumble_ahead(
    points: &[[f32; 2]],
    body_yaw_rate_rad_s: Option<f32>,
    cfg: &TurnAheadConfig,
    costs: &CostConfig,
) -> Option<Rumble> {
    let rate = body_yaw_rate_rad_s.filter(|r| cfg.enabled && r.is_finite())?;
    if rate.abs() < cfg.min_rate_deg_s.to_radians() {
        return None;
    }
    let turn = (rate * cfg.ahead_s).clamp(-cfg.max_turn_deg.to_radians(), cfg.max_turn_deg.to_radians());
    let to_turned = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: turn }.to_current_frame();
    Some(rumble(&side_costs(points.iter().map(|&p| to_turned(p)), costs), costs))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall along the walking direction, `side_m` to the right, from beside the camera
    /// to 3 m ahead, every 5 cm (as the memory holds it once it has left the view).
    fn wall_on_the_right(side_m: f32) -> Vec<[f32; 2]> {
        (0..=60).map(|k| [k as f32 * 0.05, -side_m]).collect()
    }

    #[test]
    fn turning_towards_a_wall_beside_warns_to_turn_back_before_it_is_ahead() {
        let cfg = TurnAheadConfig::default();
        let wall = wall_on_the_right(0.7);
        // walking straight along it: clear now, and nothing ahead of the turn
        let ficf = CostConfig::ficf();
        assert_eq!(rumble(&side_costs(wall.iter().copied(), &ficf), &ficf), Rumble::None);
        assert_eq!(rumble_ahead(&wall, Some(0.0), &cfg, &ficf), None);
        // turning right into it at 60 degrees/s, 30 degrees already turned: clear along
        // the heading, but the heading 0.3 s on faces the wall: turn left
        let turned = rotate(&wall, -30f32.to_radians());
        assert_eq!(rumble(&side_costs(turned.iter().copied(), &ficf), &ficf), Rumble::None);
        let right = -60f32.to_radians();
        assert_eq!(rumble_ahead(&turned, Some(right), &cfg, &ficf), Some(Rumble::Left));
        // turning left, away from it: nothing to warn of
        assert_eq!(rumble_ahead(&turned, Some(-right), &cfg, &ficf), Some(Rumble::None));
    }

    #[test]
    fn an_unknown_rate_a_slow_one_or_the_switch_off_look_nowhere() {
        let wall = rotate(&wall_on_the_right(0.7), -30f32.to_radians());
        let ficf = CostConfig::ficf();
        let cfg = TurnAheadConfig::default();
        assert_eq!(rumble_ahead(&wall, None, &cfg, &ficf), None);
        assert_eq!(rumble_ahead(&wall, Some(f32::NAN), &cfg, &ficf), None);
        assert_eq!(rumble_ahead(&wall, Some(-(cfg.min_rate_deg_s * 0.9).to_radians()), &cfg, &ficf), None);
        let off = TurnAheadConfig { enabled: false, ..cfg };
        assert_eq!(rumble_ahead(&wall, Some(-1.0), &off, &ficf), None);
    }

    #[test]
    fn an_absurd_rate_turns_the_look_no_further_than_the_limit() {
        // a wall straight behind: only a turn of more than 90 degrees would face it
        let behind: Vec<[f32; 2]> = (-20..=20).map(|k| [-0.8, k as f32 * 0.05]).collect();
        let ficf = CostConfig::ficf();
        let cfg = TurnAheadConfig::default();
        assert_eq!(rumble_ahead(&behind, Some(100.0), &cfg, &ficf), Some(Rumble::None));
        let unlimited = TurnAheadConfig { max_turn_deg: 180.0, ..cfg };
        assert_ne!(rumble_ahead(&behind, Some(10.0), &unlimited, &ficf), Some(Rumble::None));
    }

    /// The points as seen after the user turned `by` radians to the left.
    fn rotate(points: &[[f32; 2]], by: f32) -> Vec<[f32; 2]> {
        let to_turned = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: by }.to_current_frame();
        points.iter().map(|&p| to_turned(p)).collect()
    }
}
