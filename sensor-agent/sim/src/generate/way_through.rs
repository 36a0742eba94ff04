//! Is there a way through? The floor on a 5 cm grid, every static obstacle grown by
//! [`CLEARANCE_M`] (a 0.5 m wide body and 5 cm to spare), a breadth-first search from
//! the start to the goal, and the way found, straightened into the fewest legs that
//! stay on free cells. People are left out: they move.

use std::collections::VecDeque;

use crate::shape::Shape;

/// Grid cell side, metres.
pub const CELL_M: f64 = 0.05;
/// How far a free cell's centre keeps from every obstacle, metres: half a 0.5 m wide
/// body and 5 cm.
pub const CLEARANCE_M: f64 = 0.3;
/// Height of the body the way is for, metres: hanging obstacles below it are in the
/// way. The study's body is 1.8 m tall; 5 cm to spare here too.
pub const BODY_HEIGHT_M: f64 = 1.85;

/// Obstacles rasterised on a grid, each cell counting the obstacles that block it (so
/// one can be taken out again).
#[derive(Debug, Clone)]
pub struct Grid {
    origin: [f64; 2],
    nx: usize,
    ny: usize,
    blocked: Vec<u16>,
}

impl Grid {
    /// An empty grid covering `min`..`max`.
    pub fn covering(min: [f64; 2], max: [f64; 2]) -> Grid {
        let nx = ((max[0] - min[0]) / CELL_M).ceil().max(1.0) as usize;
        let ny = ((max[1] - min[1]) / CELL_M).ceil().max(1.0) as usize;
        Grid { origin: min, nx, ny, blocked: vec![0; nx * ny] }
    }

    fn centre(&self, k: usize) -> [f64; 2] {
        let (i, j) = (k % self.nx, k / self.nx);
        [self.origin[0] + (i as f64 + 0.5) * CELL_M, self.origin[1] + (j as f64 + 0.5) * CELL_M]
    }

    fn cell(&self, p: [f64; 2]) -> Option<usize> {
        let i = ((p[0] - self.origin[0]) / CELL_M).floor();
        let j = ((p[1] - self.origin[1]) / CELL_M).floor();
        (i >= 0.0 && j >= 0.0 && (i as usize) < self.nx && (j as usize) < self.ny)
            .then(|| j as usize * self.nx + i as usize)
    }

    /// The cells `shape`, grown by [`CLEARANCE_M`], blocks. A drop-off blocks where a
    /// body's feet would come within the clearance of its edge.
    pub fn cells_of(&self, shape: &Shape) -> Vec<usize> {
        let (centre, reach) = match shape {
            Shape::Box(b) => {
                let (s, c) = b.yaw_rad.sin_cos();
                let [hx, hy] = b.half_size_m;
                (b.center_m, [c.abs() * hx + s.abs() * hy, s.abs() * hx + c.abs() * hy])
            }
            Shape::Cylinder(c) => (c.center_m, [c.radius_m; 2]),
            Shape::DropOff(d) => {
                let (s, c) = d.yaw_rad.sin_cos();
                let [hx, hy] = d.half_size_m;
                (d.center_m, [c.abs() * hx + s.abs() * hy, s.abs() * hx + c.abs() * hy])
            }
        };
        let lo = |a: usize| {
            let v = ((centre[a] - reach[a] - CLEARANCE_M - self.origin[a]) / CELL_M).floor();
            v.max(0.0) as usize
        };
        let hi = |a: usize, n: usize| {
            let v = ((centre[a] + reach[a] + CLEARANCE_M - self.origin[a]) / CELL_M).ceil();
            (v.max(0.0) as usize).min(n)
        };
        let mut cells = Vec::new();
        for j in lo(1)..hi(1, self.ny) {
            for i in lo(0)..hi(0, self.nx) {
                let k = j * self.nx + i;
                let [x, y] = self.centre(k);
                let d = shape.body_distance_m(x, y, CLEARANCE_M, BODY_HEIGHT_M);
                let blocks = match shape {
                    Shape::DropOff(_) => d < CLEARANCE_M,
                    _ => d <= 0.0,
                };
                if blocks {
                    cells.push(k);
                }
            }
        }
        cells
    }

    /// Marks `cells` blocked by one more obstacle.
    pub fn add(&mut self, cells: &[usize]) {
        for &k in cells {
            self.blocked[k] = self.blocked[k].saturating_add(1);
        }
    }

    /// Takes back an [`Grid::add`].
    pub fn remove(&mut self, cells: &[usize]) {
        for &k in cells {
            self.blocked[k] = self.blocked[k].saturating_sub(1);
        }
    }

    fn free(&self, k: usize) -> bool {
        self.blocked[k] == 0
    }

    /// The cells from `from` to `to` by the fewest 4-connected steps over free cells,
    /// `None` when there is no way (or either end is off the grid or blocked).
    pub fn way(&self, from: [f64; 2], to: [f64; 2]) -> Option<Vec<usize>> {
        let (s, g) = (self.cell(from)?, self.cell(to)?);
        if !self.free(s) || !self.free(g) {
            return None;
        }
        let mut came_from = vec![usize::MAX; self.blocked.len()];
        came_from[s] = s;
        let mut queue = VecDeque::from([s]);
        while let Some(k) = queue.pop_front() {
            if k == g {
                let mut path = vec![g];
                let mut at = g;
                while at != s {
                    at = came_from[at];
                    path.push(at);
                }
                path.reverse();
                return Some(path);
            }
            let (i, j) = (k % self.nx, k / self.nx);
            let next = [
                (i > 0).then(|| k - 1),
                (i + 1 < self.nx).then(|| k + 1),
                (j > 0).then(|| k - self.nx),
                (j + 1 < self.ny).then(|| k + self.nx),
            ];
            for n in next.into_iter().flatten() {
                if came_from[n] == usize::MAX && self.free(n) {
                    came_from[n] = k;
                    queue.push_back(n);
                }
            }
        }
        None
    }

    /// True when every point of the segment (every fifth of a cell) is on a free cell.
    fn clear_line(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / (CELL_M / 5.0)).ceil().max(1.0) as usize;
        (0..=n).all(|t| {
            let f = t as f64 / n as f64;
            self.cell([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]).is_some_and(|k| self.free(k))
        })
    }

    /// A cell path from [`Grid::way`] as legs between `from` and `to`: each leg runs
    /// as far along the path as a straight line stays on free cells. The points after
    /// `from`, `to` last.
    pub fn straightened(&self, from: [f64; 2], path: &[usize], to: [f64; 2]) -> Vec<[f64; 2]> {
        let mut points: Vec<[f64; 2]> = path.iter().map(|&k| self.centre(k)).collect();
        if let Some(last) = points.last_mut() {
            *last = to;
        }
        let mut legs = Vec::new();
        let mut at = from;
        let mut i = 0;
        while i + 1 < points.len() {
            // the farthest point in a straight free line from `at`, walking the path on
            let mut j = i + 1;
            while j + 1 < points.len() && self.clear_line(at, points[j + 1]) {
                j += 1;
            }
            at = points[j];
            legs.push(at);
            i = j;
        }
        if legs.last() != Some(&to) {
            legs.push(to);
        }
        legs
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::{OrientedBox, VerticalCylinder};

    fn wall(x: f64, y0: f64, y1: f64) -> Shape {
        Shape::Box(OrientedBox {
            center_m: [x, (y0 + y1) / 2.0],
            half_size_m: [0.05, (y1 - y0) / 2.0],
            yaw_rad: 0.0,
            bottom_m: 0.0,
            top_m: 2.5,
        })
    }

    #[test]
    fn a_gap_of_0_65_m_lets_a_body_through_and_0_55_m_does_not() {
        for (gap, through) in [(0.65, true), (0.55, false)] {
            let mut g = Grid::covering([0.0, 0.0], [4.0, 4.0]);
            // a wall across the room at x = 2 with a gap between y = 2 and 2 + gap
            g.add(&g.cells_of(&wall(2.0, -1.0, 2.0)));
            g.add(&g.cells_of(&wall(2.0, 2.0 + gap, 5.0)));
            let way = g.way([0.5, 2.0], [3.5, 2.0]);
            assert_eq!(way.is_some(), through, "gap {gap}");
        }
    }

    #[test]
    fn a_table_taken_out_again_opens_the_way_and_the_straightened_way_keeps_clear() {
        let mut g = Grid::covering([0.0, 0.0], [6.0, 2.0]);
        let bin = Shape::Cylinder(VerticalCylinder { center_m: [3.0, 1.0], radius_m: 0.9, bottom_m: 0.0, top_m: 1.0 });
        let cells = g.cells_of(&bin);
        g.add(&cells);
        assert!(g.way([0.5, 1.0], [5.5, 1.0]).is_none());
        g.remove(&cells);
        let small =
            Shape::Cylinder(VerticalCylinder { center_m: [3.0, 0.5], radius_m: 0.3, bottom_m: 0.0, top_m: 1.0 });
        g.add(&g.cells_of(&small));
        let path = g.way([0.5, 1.0], [5.5, 1.0]).unwrap_or_else(|| panic!("no way past a small bin"));
        let legs = g.straightened([0.5, 1.0], &path, [5.5, 1.0]);
        assert_eq!(legs.last(), Some(&[5.5, 1.0]));
        assert!(legs.len() >= 2 && legs.len() <= 4, "{legs:?}");
        let mut at = [0.5, 1.0];
        for p in &legs {
            for t in 0..=20 {
                let f = t as f64 / 20.0;
                let (x, y) = (at[0] + f * (p[0] - at[0]), at[1] + f * (p[1] - at[1]));
                assert!(small.body_distance_m(x, y, 0.25, 1.8) > 0.0, "({x:.2}, {y:.2}) touches the bin");
            }
            at = *p;
        }
    }
}
