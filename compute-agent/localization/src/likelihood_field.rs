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

/// Free space: the floor a depth camera saw along a ray says that no wall of the map
/// stands there. A pose that puts a wall across floor the camera saw is unlikely; the
/// likelihood field alone cannot say so (a beam that saw nothing is skipped, and a pose
/// shifted back along a corridor, whose hits still land on its walls, fits as well as
/// the true one: docs/localization.md, "Why the estimate falls behind"). Each ray's
/// points are tested against the map; the nearest of them to a wall, `d` away, costs
/// `penalty * (1 - d / wall_m)` in log-likelihood (nothing from `wall_m` on): a ray
/// through a wall the whole penalty, one that passes a wall's face closely (the floor
/// seen up to a wall met at a slant) a little. Measured: docs/localization.md, "Free
/// space".
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FreeSpaceConfig {
    /// log-likelihood lost by a free ray through a wall (before the scan's exponent)
    pub penalty: f64,
    /// a ray is tested from this far from the sensor, metres
    pub start_m: f64,
    /// ... to this much short of where the floor was seen, metres
    pub margin_m: f64,
    /// ... at points this far apart, metres (no more than the map's thinnest wall, so a
    /// ray through a wall has a point in it)
    pub step_m: f64,
    /// a point this close to an occupied cell or closer costs part of the penalty, metres
    pub wall_m: f64,
    /// rays tested per scan, evenly spread over those long enough
    pub max_rays: usize,
}

impl Default for FreeSpaceConfig {
    fn default() -> Self {
        Self { penalty: 1.0, start_m: 0.3, margin_m: 0.25, step_m: 0.1, wall_m: 0.15, max_rays: 15 }
    }
}

/// A pose in a field's grid units: cell coordinates of the body origin, and the
/// heading's cos and sin scaled to cells per metre ([`LikelihoodField::grid_pose`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridPose {
    gx: f32,
    gy: f32,
    c: f32,
    s: f32,
}

/// Many poses in a field's grid units, one array per coordinate (so the arithmetic
/// over them vectorises), and a scratch array of the cells they look up.
#[derive(Clone, Debug, Default)]
pub struct GridPoses {
    gx: Vec<f32>,
    gy: Vec<f32>,
    c: Vec<f32>,
    s: Vec<f32>,
    cell: Vec<i32>,
}

impl GridPoses {
    /// Empties the set, keeping its memory.
    pub fn clear(&mut self) {
        self.gx.clear();
        self.gy.clear();
        self.c.clear();
        self.s.clear();
    }

    /// Adds a pose.
    pub fn push(&mut self, p: GridPose) {
        self.gx.push(p.gx);
        self.gy.push(p.gy);
        self.c.push(p.c);
        self.s.push(p.s);
    }

    /// How many poses.
    pub fn len(&self) -> usize {
        self.gx.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.gx.is_empty()
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
    /// metres per distance code
    step_m: f64,
    /// cells per distance code
    step_cells: f64,
    /// both sides under 2^22 cells, so [`cell_floor`] holds (any real floor: 209 km
    /// at 5 cm); a longer grid takes Rust's saturating casts, which do not vectorise
    narrow: bool,
}

/// `floor(v)` for 0 <= v < 2^22 (an exact integer may come out one less), as f32
/// arithmetic and a bit cast, which vectorise: `v as i32` saturates and tests for NaN
/// lane by lane, and was half of the scan's time at 2,000 particles x 61 beams. Out of
/// that range the result is meaningless (the callers test the range beside it).
#[inline]
fn cell_floor(v: f32) -> i32 {
    // adding 1.5 * 2^23 leaves round-to-nearest(v - 0.5) in the low mantissa bits
    const MAGIC: f32 = 12_582_912.0;
    ((v - 0.5) + MAGIC).to_bits() as i32 - MAGIC.to_bits() as i32
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
            step_m: step,
            step_cells: step / grid.resolution_m(),
            narrow: grid.width() < 1 << 22 && grid.height() < 1 << 22,
        }
    }

    /// Distance from map (x, y) to the nearest occupied cell, metres, capped at the
    /// field's `max_distance_m` (and that cap outside the grid).
    pub fn distance_m(&self, x_m: f64, y_m: f64) -> f64 {
        self.code_at(x_m, y_m).min(254) as f64 * self.step_m
    }

    /// [`Self::distance_m`] of the cell at `index` (row-major, as the grid it was made
    /// from numbers its cells), in cells.
    #[inline]
    pub(crate) fn distance_cells_at_index(&self, index: usize) -> f64 {
        self.codes[index].min(254) as f64 * self.step_cells
    }

    /// Whether the straight segment from map point `a` to `b` stays off every occupied
    /// cell (to within one cell), marched by the distance to the nearest wall.
    pub fn segment_free(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        if !len.is_finite() {
            return false;
        }
        let mut t = 0.0;
        while t < len {
            let f = t / len.max(1e-9);
            let d = self.distance_m(a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
            if d < self.resolution_m {
                return false;
            }
            t += d.max(self.resolution_m) * 0.9;
        }
        true
    }

    /// Log-likelihood of an end point at map (x, y).
    #[inline]
    pub fn log_p(&self, x_m: f64, y_m: f64) -> f32 {
        self.at(x_m, y_m)[0]
    }

    /// (log-likelihood, fit) of an end point at map (x, y).
    #[inline]
    fn at(&self, x_m: f64, y_m: f64) -> [f32; 2] {
        self.table[self.code_at(x_m, y_m) as usize]
    }

    /// The distance code of the cell at map (x, y); 255 outside the grid.
    #[inline]
    fn code_at(&self, x_m: f64, y_m: f64) -> u8 {
        let (dx, dy) = (x_m - self.origin_x_m, y_m - self.origin_y_m);
        let gx = (self.cos_yaw * dx + self.sin_yaw * dy) / self.resolution_m;
        let gy = (-self.sin_yaw * dx + self.cos_yaw * dy) / self.resolution_m;
        // `as usize` saturates negatives and NaN to 0, so test the sign first
        if gx >= 0.0 && gy >= 0.0 {
            let (c, r) = (gx as usize, gy as usize);
            if c < self.width && r < self.height {
                return self.codes[r * self.width + c];
            }
        }
        255
    }

    /// A pose (x, y, cos heading, sin heading) taken into the grid's units once (in
    /// f64, so a pose far from the origin keeps its centimetres; then f32: grid units
    /// are well inside f32's 24 bits).
    #[inline]
    pub fn grid_pose(&self, x_m: f64, y_m: f64, cos_h: f64, sin_h: f64) -> GridPose {
        let (dx, dy) = (x_m - self.origin_x_m, y_m - self.origin_y_m);
        let inv = 1.0 / self.resolution_m;
        // heading relative to the grid: R(-yaw) R(h) = R(h - yaw), scaled to cells
        GridPose {
            gx: ((self.cos_yaw * dx + self.sin_yaw * dy) * inv) as f32,
            gy: ((-self.sin_yaw * dx + self.cos_yaw * dy) * inv) as f32,
            c: ((cos_h * self.cos_yaw + sin_h * self.sin_yaw) * inv) as f32,
            s: ((sin_h * self.cos_yaw - cos_h * self.sin_yaw) * inv) as f32,
        }
    }

    /// The cell index of grid coordinates (gx, gy), `outside` for none, when both sides
    /// are under 2^22 cells: branch-free.
    #[inline]
    fn cell_narrow(&self, gx: f32, gy: f32, outside: i32) -> i32 {
        let inside = gx >= 0.0 && gy >= 0.0 && gx < self.width as f32 && gy < self.height as f32;
        let at = cell_floor(gy) * self.width as i32 + cell_floor(gx);
        if inside {
            at
        } else {
            outside
        }
    }

    /// The cell index of grid coordinates (gx, gy), `outside` for none, on any grid.
    #[inline]
    fn cell_wide(&self, gx: f32, gy: f32, outside: i32) -> i32 {
        if gx >= 0.0 && gy >= 0.0 && gx < self.width as f32 && gy < self.height as f32 {
            gy as i32 * self.width as i32 + gx as i32
        } else {
            outside
        }
    }

    /// Into `poses.cell` (sized to the poses), the cell index of body-frame point
    /// (`bx`, `by`) seen from each pose, `outside` for none: arithmetic only, with the
    /// grid-size test taken out of the loop so the narrow case's loop vectorises.
    #[inline]
    fn fill_cells(&self, poses: &mut GridPoses, bx: f32, by: f32, outside: i32) {
        let cells = poses.gx.iter().zip(&poses.gy).zip(poses.c.iter().zip(&poses.s)).zip(poses.cell.iter_mut());
        if self.narrow {
            for (((&gx0, &gy0), (&c, &s)), cell) in cells {
                *cell = self.cell_narrow(gx0 + c * bx - s * by, gy0 + s * bx + c * by, outside);
            }
        } else {
            for (((&gx0, &gy0), (&c, &s)), cell) in cells {
                *cell = self.cell_wide(gx0 + c * bx - s * by, gy0 + s * bx + c * by, outside);
            }
        }
    }

    /// Sums of the log-likelihoods and of the fits of body-frame end points seen from
    /// each pose, added into `sums` ((log-likelihood, fit), one per pose). Beam by beam
    /// over all poses, in two passes: the cells (arithmetic only,
    /// which the compiler vectorises over the poses), then the lookups (independent
    /// loads). Pose by pose, the compare-and-branch per beam kept one lookup at ~10
    /// cycles (2,000 particles x 61 beams: see docs/localization.md).
    pub fn add_scan_log_p(&self, poses: &mut GridPoses, endpoints: &[[f32; 2]], sums: &mut [[f32; 2]]) {
        let n = poses.gx.len();
        assert_eq!(sums.len(), n, "one sum per pose");
        poses.cell.resize(n, 0);
        // `map::MAX_CELLS` (64 M) keeps every cell index, and one past the last, in i32
        let outside = (self.width * self.height) as i32; // no cell: code 255
        for &[bx, by] in endpoints {
            self.fill_cells(poses, bx, by, outside);
            for (&cell, [l, f]) in poses.cell.iter().zip(sums.iter_mut()) {
                let code = self.codes.get(cell as usize).copied().unwrap_or(255);
                let [dl, df] = self.table[code as usize];
                *l += dl;
                *f += df;
            }
        }
    }

    /// For each pose, adds to `crossed` how far each free ray goes into a wall: ray `k` is
    /// the body-frame points of `points[ray_ends[k - 1]..ray_ends[k]]`; its nearest point to
    /// an occupied cell, `d` away, adds `1 - d / wall_m` (0 from `wall_m` on: a ray that
    /// passes a wall's face closely costs little, one through the wall the whole
    /// penalty). Pose-major arithmetic as in [`LikelihoodField::add_scan_log_p`].
    pub fn add_free_crossings(
        &self,
        poses: &mut GridPoses,
        points: &[[f32; 2]],
        ray_ends: &[usize],
        wall_m: f64,
        nearest: &mut Vec<u8>,
        crossed: &mut [f32],
    ) {
        let n = poses.gx.len();
        assert_eq!(crossed.len(), n, "one sum per pose");
        poses.cell.resize(n, 0);
        let outside = (self.width * self.height) as i32;
        // codes from this on are `wall_m` or more from a wall (255, off the map, too)
        let wall_code = (wall_m / self.step_m).round().clamp(1.0, 254.0) as u8;
        let mut depth = [0.0f32; 256];
        for (code, d) in depth.iter_mut().enumerate().take(wall_code as usize) {
            *d = 1.0 - code as f32 / f32::from(wall_code);
        }
        let mut start = 0;
        for &end in ray_ends {
            nearest.clear();
            nearest.resize(n, 255);
            for &[bx, by] in &points[start..end.min(points.len())] {
                self.fill_cells(poses, bx, by, outside);
                for (&cell, m) in poses.cell.iter().zip(nearest.iter_mut()) {
                    *m = (*m).min(self.codes.get(cell as usize).copied().unwrap_or(255));
                }
            }
            for (&m, c) in nearest.iter().zip(crossed.iter_mut()) {
                *c += depth[m as usize];
            }
            start = end;
        }
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
    fn cell_floor_is_floor_inside_a_cell() {
        for v in [0.25f32, 0.999, 1.5, 7.75, 813.2, 4_194_303.5] {
            assert_eq!(cell_floor(v), v.floor() as i32, "{v}");
        }
        // exact integers: that cell or the one before (a point on the boundary)
        for v in [0.0f32, 1.0, 2.0, 814.0] {
            assert!(cell_floor(v) == v as i32 || cell_floor(v) == v as i32 - 1, "{v}");
        }
    }

    #[test]
    fn a_free_ray_through_a_wall_costs_a_whole_one_one_short_of_it_nothing_one_along_its_face_part() {
        // a wall two cells thick at x = 2.5..2.6
        let f = field_with_walls(&[50, 51]);
        let ray = |from: f32, to: f32, left: f32| {
            let n = ((to - from) / 0.1).round() as usize;
            (0..=n).map(|k| [from + k as f32 * 0.1, left]).collect::<Vec<_>>()
        };
        // from a pose at (1, 2) facing +x: 0.3..1.2 m ahead ends 0.3 m short of the wall,
        // 0.3..2.0 m goes through it
        let short = ray(0.3, 1.2, 0.0);
        let through = ray(0.3, 2.0, 0.0);
        let mut points = short.clone();
        points.extend(&through);
        let ends = [short.len(), points.len()];
        let mut poses = GridPoses::default();
        poses.push(f.grid_pose(1.0, 2.0, 1.0, 0.0));
        // the same rays from a pose facing +y at (2.4, 0.5): both run along the wall in
        // the cells 0.1 m from its first cells' centres
        poses.push(f.grid_pose(2.4, 0.5, 0.0, 1.0));
        let mut crossed = [0.0f32; 2];
        let mut scratch = Vec::new();
        f.add_free_crossings(&mut poses, &points, &ends, 0.15, &mut scratch, &mut crossed);
        assert!((crossed[0] - 1.0).abs() < 1e-6, "only the ray through the wall, all of it: {crossed:?}");
        // alongside: each ray 0.1 m from the wall costs 1 - 0.1/0.15 = 1/3 (the distance
        // codes' quantisation: within 0.02 a ray)
        assert!((crossed[1] - 2.0 / 3.0).abs() < 0.04, "{crossed:?}");
        // sums add up: a second call adds the same again
        f.add_free_crossings(&mut poses, &points, &ends, 0.15, &mut scratch, &mut crossed);
        assert!((crossed[0] - 2.0).abs() < 1e-6, "{crossed:?}");
    }

    /// The default field of a 5 x 5 m grid at 5 cm with these columns walled.
    fn field_with_walls(columns: &[usize]) -> LikelihoodField {
        let mut g = OccupancyGrid::filled(100, 100, 0.05, Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, Cell::Free)
            .expect("grid");
        for r in 0..100 {
            for &c in columns {
                g.set(c, r, Cell::Occupied);
            }
        }
        LikelihoodField::new(&g, &LikelihoodFieldConfig::default())
    }

    #[test]
    fn end_point_on_a_wall_scores_best_and_far_away_worst() {
        let f = field_with_walls(&[50]);
        let on = f.log_p(2.525, 1.0) as f64;
        let near = f.log_p(2.325, 1.0) as f64; // 0.2 m off: one sigma
        let far = f.log_p(-10.0, 1.0) as f64;
        assert!((on - f.log_p_max()).abs() < 1e-6);
        assert!((on - near - 0.5).abs() < 0.02, "one sigma costs 1/2 in log: {on} {near}");
        assert!((far - f.log_p_min()).abs() < 1e-6);
        assert!(far < near);
        // the whole-scan path agrees with the per-point one, pose by pose, here on a
        // rotated heading and on a straight one
        let (s, c) = 0.7f64.sin_cos();
        let ends = [[0.5f32, 0.1], [1.0, -0.4], [30.0, 0.0]];
        let poses_m = [(2.0, 1.0, c, s), (-3.0, 0.5, 1.0, 0.0)];
        let mut poses = GridPoses::default();
        for &(x, y, c, s) in &poses_m {
            poses.push(f.grid_pose(x, y, c, s));
        }
        let mut sums = [[0.0f32; 2]; 2];
        f.add_scan_log_p(&mut poses, &ends, &mut sums);
        for (&(x, y, c, s), [ll, fit]) in poses_m.iter().zip(sums) {
            let (mut one_ll, mut one_fit) = (0.0, 0.0);
            for &[bx, by] in &ends {
                let (bx, by) = (bx as f64, by as f64);
                let [l, fi] = f.at(x + c * bx - s * by, y + s * bx + c * by);
                (one_ll, one_fit) = (one_ll + l as f64, one_fit + fi as f64);
            }
            assert!((ll as f64 - one_ll).abs() < 1e-4, "{ll} vs {one_ll}");
            assert!((fit as f64 - one_fit).abs() < 1e-4, "{fit} vs {one_fit}");
        }
    }
}
