//! Beyond the thesis: memory of obstacles outside the field of view. Taylor's users
//! collided mostly with what the camera no longer saw: a divider beside them, a sign at
//! head height that left the top of the 45 deg vertical view as they came close. We keep
//! the scan's obstacles in a small egocentric grid, move it by the user's own motion
//! (odometry / IMU yaw) and forget cells after `ttl_ns`. Each frame a remembered cell is
//! either in view (the camera is authoritative there: the cell is dropped and re-added
//! only if the scan still sees it) or out of view (it is handed to the cost functions).

use std::f32::consts::PI;

use super::config::MemoryConfig;
use super::Motion;

/// Where the camera can see this frame, in user terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewCone {
    /// Half horizontal field of view, radians.
    pub half_hfov_rad: f32,
    /// Half vertical field of view, radians.
    pub half_vfov_rad: f32,
    /// Downward pitch of the optical axis, radians.
    pub pitch_down_rad: f32,
    /// Camera height above the floor, metres.
    pub camera_height_m: f32,
    /// Ranges beyond this are not seen.
    pub range_max_m: f32,
}

impl ViewCone {
    /// True when a point at user `(x, y)` and height `h` projects into the image.
    pub fn sees(&self, x: f32, y: f32, h: f32) -> bool {
        let r = (x * x + y * y).sqrt();
        if x <= 0.0 || r > self.range_max_m || y.abs() > x * self.half_hfov_rad.tan() {
            return false;
        }
        let elevation = (h - self.camera_height_m).atan2(r);
        (elevation + self.pitch_down_rad).abs() <= self.half_vfov_rad
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct Cell {
    // exact position: cells only bin it, so motion of less than a cell per frame adds up
    x_m: f32,
    y_m: f32,
    seen_ns: u64,
    height_m: f32,
    occupied: bool,
}

/// The egocentric grid.
#[derive(Debug, Default)]
pub struct ObstacleMemory {
    cells: Vec<Cell>,
    spare: Vec<Cell>,
    side: usize,
    nearest_by_degree: Vec<f32>,
    /// Remembered obstacles out of view this frame, user `(x, y)`, one per degree of
    /// bearing (the nearest), like the scan's own density.
    pub out_of_view: Vec<[f32; 2]>,
}

impl ObstacleMemory {
    fn ensure(&mut self, cfg: &MemoryConfig) {
        let side = ((2.0 * cfg.radius_m / cfg.cell_m).ceil() as usize).clamp(3, 400) | 1;
        if self.side != side {
            self.side = side;
            self.cells = vec![Cell::default(); side * side];
            self.spare = vec![Cell::default(); side * side];
        }
    }

    fn index(&self, x: f32, y: f32, cfg: &MemoryConfig) -> Option<usize> {
        let c = (self.side / 2) as f32;
        let i = (x / cfg.cell_m + c).round();
        let j = (y / cfg.cell_m + c).round();
        let s = self.side as f32;
        (i >= 0.0 && j >= 0.0 && i < s && j < s).then(|| i as usize * self.side + j as usize)
    }

    /// Moves the grid by the user's motion since the last frame, forgets old cells,
    /// hands out-of-view cells to `out_of_view`, drops in-view ones, and stores this
    /// frame's scan obstacles `(x, y, height)`.
    pub fn update(
        &mut self,
        stamp_ns: u64,
        motion: Option<Motion>,
        view: &ViewCone,
        scan_obstacles: impl Iterator<Item = [f32; 3]>,
        cfg: &MemoryConfig,
    ) {
        self.ensure(cfg);
        if let Some(m) = motion.filter(Motion::is_finite) {
            self.spare.iter_mut().for_each(|c| *c = Cell::default());
            let carry = m.to_current_frame();
            for idx in 0..self.cells.len() {
                let cell = self.cells[idx];
                if !cell.occupied {
                    continue;
                }
                let [nx, ny] = carry([cell.x_m, cell.y_m]);
                if let Some(j) = self.index(nx, ny, cfg) {
                    self.spare[j] = Cell { x_m: nx, y_m: ny, ..cell };
                }
            }
            std::mem::swap(&mut self.cells, &mut self.spare);
        }
        self.nearest_by_degree.clear();
        self.nearest_by_degree.resize(360, f32::INFINITY);
        for idx in 0..self.cells.len() {
            let cell = self.cells[idx];
            if !cell.occupied {
                continue;
            }
            let (x, y) = (cell.x_m, cell.y_m);
            if stamp_ns.saturating_sub(cell.seen_ns) > cfg.ttl_ns || view.sees(x, y, cell.height_m) {
                self.cells[idx] = Cell::default();
                continue;
            }
            let deg = ((y.atan2(x) + PI).to_degrees() as usize).min(359);
            let r = (x * x + y * y).sqrt();
            self.nearest_by_degree[deg] = self.nearest_by_degree[deg].min(r);
        }
        self.out_of_view.clear();
        for (deg, &r) in self.nearest_by_degree.iter().enumerate() {
            if r.is_finite() {
                let b = (deg as f32 + 0.5).to_radians() - PI;
                self.out_of_view.push([r * b.cos(), r * b.sin()]);
            }
        }
        for [x, y, h] in scan_obstacles {
            if let Some(j) = self.index(x, y, cfg) {
                self.cells[j] = Cell { x_m: x, y_m: y, seen_ns: stamp_ns, height_m: h, occupied: true };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view() -> ViewCone {
        ViewCone {
            half_hfov_rad: 29f32.to_radians(),
            half_vfov_rad: 22.5f32.to_radians(),
            pitch_down_rad: 10f32.to_radians(),
            camera_height_m: 1.0,
            range_max_m: 5.0,
        }
    }

    const FRAME_NS: u64 = 33_333_333;

    #[test]
    fn head_high_sign_that_leaves_the_view_is_remembered_as_the_user_walks() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        // sign 1.9 m high, 3.0 m ahead: in view (elevation 16.7 deg up, top of view 12.5 deg)?
        // at 3.0 m it is at atan(0.9/3.0)=16.7 deg > 12.5: start further, at 4.5 m (11.3 deg).
        let mut x = 4.5f32;
        assert!(view().sees(x, 0.0, 1.9));
        m.update(0, None, &view(), [[x, 0.0, 1.9]].into_iter(), &cfg);
        for k in 1..=30u64 {
            let step = 0.05; // 1.5 m/s
            x -= step;
            let visible = view().sees(x, 0.0, 1.9);
            let seen = visible.then_some([x, 0.0, 1.9]);
            m.update(
                k * FRAME_NS,
                Some(Motion { forward_m: step, left_m: 0.0, yaw_rad: 0.0 }),
                &view(),
                seen.into_iter(),
                &cfg,
            );
        }
        assert!(!view().sees(x, 0.0, 1.9), "sign left the view at {x}");
        let nearest = m.out_of_view.iter().map(|p| p[0]).fold(f32::INFINITY, f32::min);
        assert!((nearest - x).abs() < 0.12, "remembered at {nearest}, truly at {x}");
    }

    #[test]
    fn turning_left_moves_an_obstacle_ahead_to_the_right_and_it_decays() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        m.update(0, None, &view(), [[1.0, 0.0, 0.5]].into_iter(), &cfg);
        let turn = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 90f32.to_radians() };
        m.update(FRAME_NS, Some(turn), &view(), std::iter::empty(), &cfg);
        assert_eq!(m.out_of_view.len(), 1);
        let [x, y] = m.out_of_view[0];
        assert!(x.abs() < 0.1 && (y + 1.0).abs() < 0.1, "({x}, {y})");
        m.update(FRAME_NS + cfg.ttl_ns + 1, None, &view(), std::iter::empty(), &cfg);
        assert!(m.out_of_view.is_empty());
    }

    #[test]
    fn obstacle_still_in_view_but_gone_is_dropped() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        m.update(0, None, &view(), [[2.0, 0.0, 0.5]].into_iter(), &cfg);
        m.update(FRAME_NS, None, &view(), std::iter::empty(), &cfg);
        assert!(m.out_of_view.is_empty());
    }
}
