//! Stage 6: Taylor's two cost functions over the nearest-point scan and the 4-state
//! rumble of his Table 2.1 (Taylor 2017, sec. 2.4, eq. 2.11-2.15).
//!
//! The thesis text and its appendix code disagree (a `/100` factor, angle conventions,
//! which bins count), so this is our reading, fixed here and proved by the thesis's own
//! calibration (tests below):
//!
//! - Every scan bin with a finite range gives one point `(x, y)` in the user frame (bin
//!   centre bearing, positive left). A point at forward distance `x` inside a region of
//!   depth `d` costs `scale * ((d - x) / x)^2`: zero at the region's far edge, growing
//!   fast as it nears. Because a nearer wall also fills more 1-degree bins, the total
//!   grows about like `1/x^3`: steep enough to separate "turn" from "stop" by 35 cm.
//! - Forward cost: points in the forward region, `|y| <= forward_width / 2`,
//!   `0 < x <= forward_depth`. Left (right) cost: points in the left (right) half of the
//!   side region (`0 <= y <= side_width / 2`, resp. `<= 0`), `0 < x <= side_depth`. FICF
//!   uses one region (0.75 m x 3.5 m) for all three; CACF an inner one (0.5 x 2.0) ahead
//!   and an outer cushion (1.5 x 2.0) for the sides.
//! - Table 2.1: forward below its threshold -> `None`; else left and right both at or
//!   above the side threshold -> `Both` (blocked: stop); else rumble the side to turn
//!   to, away from the larger cost: right cost > left -> `Left` (turn left), otherwise
//!   `Right`. A tie turns left.
//! - `scale` (our stand-in for the `/100`) is set per function so the forward threshold
//!   is crossed with the cane tip 75 cm from a wall in the thesis calibration (camera on
//!   the handle 1 m above the floor, 1.1 m cane, tip on the floor pointing at the wall).
//!   FICF's left-right threshold is then crossed at 39 cm (thesis: ~40 cm): the shape of
//!   the cost, not a second tuned constant, puts it there. CACF's (7.0 over its 1.5 m
//!   cushion) is crossed at 68 cm: the cushion stops the user earlier.

use schemas::{Rumble, SideCosts};

use super::config::CostConfig;

/// Closest forward distance a cost term is evaluated at (the weight diverges at 0).
const MIN_X_M: f32 = 0.05;

/// Left / forward / right costs of user-frame points `(x forward, y left)`.
pub fn side_costs(points: impl Iterator<Item = [f32; 2]>, cfg: &CostConfig) -> SideCosts {
    let mut c = SideCosts::default();
    let weight = |x: f32, d: f32| {
        let x = x.max(MIN_X_M);
        let q = (d - x) / x;
        q * q
    };
    for [x, y] in points {
        if !(x > 0.0 && y.is_finite()) {
            continue;
        }
        if x <= cfg.forward_depth_m && y.abs() <= cfg.forward_width_m * 0.5 {
            c.forward += weight(x, cfg.forward_depth_m);
        }
        if x <= cfg.side_depth_m && y.abs() <= cfg.side_width_m * 0.5 {
            let w = weight(x, cfg.side_depth_m);
            if y >= 0.0 {
                c.left += w;
            }
            if y <= 0.0 {
                c.right += w;
            }
        }
    }
    SideCosts { left: c.left * cfg.scale, forward: c.forward * cfg.scale, right: c.right * cfg.scale }
}

/// Taylor's Table 2.1.
pub fn rumble(c: &SideCosts, cfg: &CostConfig) -> Rumble {
    if c.forward.is_nan() || c.left.is_nan() || c.right.is_nan() {
        // unknown is never clear (the pipeline does not produce NaN scans; see tests)
        return Rumble::Both;
    }
    if c.forward < cfg.forward_threshold {
        return Rumble::None;
    }
    if c.left >= cfg.side_threshold && c.right >= cfg.side_threshold {
        Rumble::Both
    } else if c.left <= c.right {
        Rumble::Left
    } else {
        Rumble::Right
    }
}

/// User-frame points of the finite bins of a scan.
pub fn scan_points(scan: &schemas::Scan) -> impl Iterator<Item = [f32; 2]> + '_ {
    scan.ranges_m.iter().enumerate().filter(|(_, r)| r.is_finite()).map(move |(i, &r)| {
        let b = (scan.angle_min_deg + i as f32 * scan.angle_increment_deg).to_radians();
        [r * b.cos(), r * b.sin()]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scan of a wall perpendicular to the heading, `x_m` ahead, across 61 bins.
    fn wall(x_m: f32) -> Vec<[f32; 2]> {
        (-30..=30).map(|k| [x_m, x_m * (k as f32).to_radians().tan()]).collect()
    }

    #[test]
    fn nothing_in_range_costs_nothing_and_is_clear() {
        let c = side_costs(wall(4.0).into_iter(), &CostConfig::ficf());
        assert_eq!(c, SideCosts::default());
        assert_eq!(rumble(&c, &CostConfig::ficf()), Rumble::None);
    }

    #[test]
    fn obstacle_on_the_right_rumbles_left() {
        let cfg = CostConfig::ficf();
        let pts = [[0.5, -0.05], [0.5, -0.1], [0.5, -0.15], [0.5, -0.2], [0.5, -0.25], [0.5, -0.3]];
        let c = side_costs(pts.into_iter(), &cfg);
        assert!(c.right > c.left && c.forward >= cfg.forward_threshold, "{c:?}");
        assert_eq!(rumble(&c, &cfg), Rumble::Left);
        let mirrored = pts.map(|[x, y]| [x, -y]);
        assert_eq!(rumble(&side_costs(mirrored.into_iter(), &cfg), &cfg), Rumble::Right);
    }

    #[test]
    fn nan_costs_are_never_clear() {
        let c = SideCosts { left: 0.0, forward: f32::NAN, right: 0.0 };
        assert_eq!(rumble(&c, &CostConfig::ficf()), Rumble::Both);
    }

    #[test]
    fn near_wall_blocks_both_sides() {
        let cfg = CostConfig::ficf();
        let c = side_costs(wall(0.6).into_iter(), &cfg);
        assert_eq!(rumble(&c, &cfg), Rumble::Both, "{c:?}");
    }
}
