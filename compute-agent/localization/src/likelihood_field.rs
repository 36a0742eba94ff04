//! The likelihood field of a range scan (Thrun, Burgard & Fox, *Probabilistic
//! Robotics*, 6.4; AMCL's `likelihood_field` model): a beam's end point is likely in
//! proportion to `z_hit * exp(-d^2 / 2 sigma_hit^2) + z_rand / max_range`, `d` the
//! distance from the end point to the nearest occupied cell, capped at `max_distance`
//! (AMCL's `laser_likelihood_max_dist`). The log of that is precomputed per cell from
//! `map::DistanceField`, so a beam costs one lookup. Beside it, per cell, the beam's
//! *fit*: its likelihood relative to a beam ending on a wall, in (0, 1]; the mean fit
//! over a scan's beams is how much of the scan the map explains (the status and the
//! recovery read it: a geometric mean would let a few beams through a window or past a
//! person drag a good pose down).

use map::{DistanceField, OccupancyGrid};
use serde::{Deserialize, Serialize};

/// AMCL's laser parameters (its names, its defaults).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LikelihoodFieldConfig {
    /// weight of the "hit" Gaussian (`laser_z_hit`, 0.95)
    pub z_hit: f64,
    /// weight of random readings (`laser_z_rand`, 0.05)
    pub z_rand: f64,
    /// standard deviation of a hit, metres (`laser_sigma_hit`, 0.2)
    pub sigma_hit_m: f64,
    /// distances beyond this count as this, metres (`laser_likelihood_max_dist`, 2.0)
    pub max_distance_m: f64,
    /// the range over which random readings spread, metres (the depth camera's useful
    /// range; AMCL takes the laser's)
    pub max_range_m: f64,
}

impl Default for LikelihoodFieldConfig {
    fn default() -> Self {
        Self { z_hit: 0.95, z_rand: 0.05, sigma_hit_m: 0.2, max_distance_m: 2.0, max_range_m: 30.0 }
    }
}

/// Log-likelihood of a beam end point per cell, with the grid's placement.
#[derive(Clone, Debug)]
pub struct LikelihoodField {
    width: usize,
    height: usize,
    resolution_m: f64,
    origin_x_m: f64,
    origin_y_m: f64,
    /// cos and sin of the grid's yaw
    cos_yaw: f64,
    sin_yaw: f64,
    /// per cell, the distance to the nearest wall quantised to 254 steps of
    /// `max_distance / 254` (code 255: off the map); one byte keeps the field of a
    /// 40 x 40 m floor at 5 cm (640 k cells) in the L2 cache, where 8 bytes per cell
    /// did not (2,000 particles x 61 beams: 1.14 -> see docs/localization.md)
    codes: Vec<u8>,
    /// (log-likelihood, fit) per code
    table: [[f32; 2]; 256],
    /// the best a beam can score (an end point on a wall)
    log_p_max: f64,
}

impl LikelihoodField {
    /// The field of `grid` (distances to its occupied cells).
    pub fn new(grid: &OccupancyGrid, config: &LikelihoodFieldConfig) -> Self {
        let field = DistanceField::to_occupied(grid);
        let s2 = 2.0 * config.sigma_hit_m * config.sigma_hit_m;
        let rand = config.z_rand / config.max_range_m.max(1e-3);
        let p = |d: f64| {
            let d = d.min(config.max_distance_m);
            (config.z_hit * (-d * d / s2).exp() + rand).ln()
        };
        let p_max = p(0.0);
        let step = config.max_distance_m / 254.0;
        let mut table = [[0.0f32; 2]; 256];
        for (code, entry) in table.iter_mut().enumerate() {
            let d = if code == 255 { f64::INFINITY } else { code as f64 * step };
            *entry = [p(d) as f32, (p(d) - p_max).exp() as f32];
        }
        let codes = field
            .distances_m()
            .iter()
            .map(|&d| if (d as f64) >= config.max_distance_m { 254 } else { ((d as f64) / step).round() as u8 })
            .collect();
        let o = grid.origin();
        Self {
            width: grid.width(),
            height: grid.height(),
            resolution_m: grid.resolution_m(),
            origin_x_m: o.x_m,
            origin_y_m: o.y_m,
            cos_yaw: o.yaw_rad.cos(),
            sin_yaw: o.yaw_rad.sin(),
            codes,
            table,
            log_p_max: p_max,
        }
    }

    /// Log-likelihood of an end point at map (x, y).
    #[inline]
    pub fn log_p(&self, x_m: f64, y_m: f64) -> f32 {
        self.at(x_m, y_m)[0]
    }

    /// (log-likelihood, fit) of an end point at map (x, y).
    #[inline]
    fn at(&self, x_m: f64, y_m: f64) -> [f32; 2] {
        let (dx, dy) = (x_m - self.origin_x_m, y_m - self.origin_y_m);
        let gx = (self.cos_yaw * dx + self.sin_yaw * dy) / self.resolution_m;
        let gy = (-self.sin_yaw * dx + self.cos_yaw * dy) / self.resolution_m;
        // `as usize` saturates negatives and NaN to 0, so test the sign first
        if gx >= 0.0 && gy >= 0.0 {
            let (c, r) = (gx as usize, gy as usize);
            if c < self.width && r < self.height {
                return self.table[self.codes[r * self.width + c] as usize];
            }
        }
        self.table[255]
    }

    /// Sum of the log-likelihoods and of the fits of body-frame end points seen from
    /// a pose (x, y, cos heading, sin heading). The pose is taken into grid units once,
    /// so a beam costs two multiply-adds per axis and a lookup.
    #[inline]
    pub fn scan_log_p(&self, x_m: f64, y_m: f64, cos_h: f64, sin_h: f64, endpoints: &[[f64; 2]]) -> (f64, f64) {
        let (dx, dy) = (x_m - self.origin_x_m, y_m - self.origin_y_m);
        let inv = 1.0 / self.resolution_m;
        let gx0 = (self.cos_yaw * dx + self.sin_yaw * dy) * inv;
        let gy0 = (-self.sin_yaw * dx + self.cos_yaw * dy) * inv;
        // heading relative to the grid: R(-yaw) R(h) = R(h - yaw), scaled to cells
        let c = (cos_h * self.cos_yaw + sin_h * self.sin_yaw) * inv;
        let s = (sin_h * self.cos_yaw - cos_h * self.sin_yaw) * inv;
        let (w, h) = (self.width as f64, self.height as f64);
        let (mut ll, mut fit) = (0.0f32, 0.0f32);
        for &[bx, by] in endpoints {
            let gx = gx0 + c * bx - s * by;
            let gy = gy0 + s * bx + c * by;
            let code = if gx >= 0.0 && gy >= 0.0 && gx < w && gy < h {
                self.codes[gy as usize * self.width + gx as usize]
            } else {
                255
            };
            let [l, f] = self.table[code as usize];
            ll += l;
            fit += f;
        }
        (ll as f64, fit as f64)
    }

    /// The best log-likelihood one beam can have (end point on an occupied cell).
    pub fn log_p_max(&self) -> f64 {
        self.log_p_max
    }

    /// The log-likelihood of an end point far from anything.
    pub fn log_p_min(&self) -> f64 {
        self.table[255][0] as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use map::{Cell, Origin};

    #[test]
    fn end_point_on_a_wall_scores_best_and_far_away_worst() {
        let mut g = OccupancyGrid::filled(100, 100, 0.05, Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, Cell::Free)
            .expect("grid");
        for r in 0..100 {
            g.set(50, r, Cell::Occupied);
        }
        let f = LikelihoodField::new(&g, &LikelihoodFieldConfig::default());
        let on = f.log_p(2.525, 1.0) as f64;
        let near = f.log_p(2.325, 1.0) as f64; // 0.2 m off: one sigma
        let far = f.log_p(-10.0, 1.0) as f64;
        assert!((on - f.log_p_max()).abs() < 1e-6);
        assert!((on - near - 0.5).abs() < 0.02, "one sigma costs 1/2 in log: {on} {near}");
        assert!((far - f.log_p_min()).abs() < 1e-6);
        assert!(far < near);
        // the whole-scan path agrees with the per-point one, here on a rotated heading
        let (s, c) = 0.7f64.sin_cos();
        let ends = [[0.5, 0.1], [1.0, -0.4], [30.0, 0.0]];
        let (ll, _) = f.scan_log_p(2.0, 1.0, c, s, &ends);
        let one_by_one: f64 =
            ends.iter().map(|[bx, by]| f.log_p(2.0 + c * bx - s * by, 1.0 + s * bx + c * by) as f64).sum();
        assert!((ll - one_by_one).abs() < 1e-4, "{ll} vs {one_by_one}");
    }
}
