//! What the camera finds that the floor plan does not have (a desk, a bench, a bin, a
//! person), as obstacles of the planner: ISANA's obstacle-driven node removal, fed by
//! the perception. A route laid on an architect's plan runs down the middle of a room
//! its furniture stands in; the obstacle cue keeps the body off a desk on that route,
//! but cannot take the user round it (`docs/beyond-the-course.md`, `gen:office:4`). With
//! the desk on the planner's graph, the route goes round it.
//!
//! Points are binned in [`CELL_M`] cells of the map. A cell within [`EXPLAINED_M`] of
//! a wall of the plan is that wall, seen (the plan keeps its clearance from it already);
//! any other cell blocks the graph's vertices within its disc (the cell's half
//! diagonal plus the planner's clearance) until it has not been seen for [`KEEP_MS`].

use std::collections::HashMap;

use map::{Cell, OccupancyGrid};
use planning::{BuildingPlanner, ObstacleId};

/// Side of the cells points are binned in, metres (the graph's vertex spacing).
pub const CELL_M: f64 = 0.2;
/// A point this near an occupied cell of the plan is that wall, metres (the plan's
/// walls as the camera and the position see them: a few centimetres of depth noise and
/// the position's error across a wall).
pub const EXPLAINED_M: f64 = 0.3;
/// A cell not seen again for this long is given back to the graph, ms: the perception's
/// memory holds what leaves the view for seconds, a person moves on.
pub const KEEP_MS: u64 = 15_000;
/// A route passing this near a cell (beyond its half diagonal: half a body's width)
/// would walk the body into it: a way round is looked for. One passing farther is
/// left to the cane and the obstacle cue (a bin beside the way is not worth a new
/// route).
pub const PASS_M: f64 = 0.23;
/// Points farther than this from the camera are not taken, metres (beyond the depth
/// camera's range: a misplaced point, not an obstacle).
pub const MAX_RANGE_M: f64 = 8.0;

#[derive(Clone, Copy, Debug)]
struct Seen {
    last_ms: u64,
    /// `None`: the plan's wall
    obstacle: Option<ObstacleId>,
}

/// What the camera found, on the planner ([`Perceived::update`]).
#[derive(Clone, Debug, Default)]
pub struct Perceived {
    cells: HashMap<(i32, i64, i64), Seen>,
    /// points refused: not finite, or farther than [`MAX_RANGE_M`] from the camera
    refused: u64,
}

impl Perceived {
    /// Takes the points the perception holds now (map frame of `floor`, metres; `from`:
    /// where the camera is) onto `planner`, and gives back to it what has not been seen
    /// for [`KEEP_MS`]. Returns how many obstacles were added.
    pub fn update(
        &mut self,
        planner: &mut BuildingPlanner,
        floor: i32,
        from: [f64; 2],
        points: &[[f64; 2]],
        now_ms: u64,
    ) -> usize {
        let mut added = 0;
        if let Some(p) = planner.floor_mut(floor) {
            for &[x, y] in points {
                let near = (x - from[0]).hypot(y - from[1]) <= MAX_RANGE_M;
                if !(x.is_finite() && y.is_finite() && near) {
                    self.refused += 1;
                    continue;
                }
                let (i, j) = ((x / CELL_M).floor() as i64, (y / CELL_M).floor() as i64);
                let seen = self.cells.entry((floor, i, j)).or_insert_with(|| {
                    let (cx, cy) = ((i as f64 + 0.5) * CELL_M, (j as f64 + 0.5) * CELL_M);
                    let obstacle = (!near_occupied(p.graph().grid(), cx, cy, EXPLAINED_M)).then(|| {
                        added += 1;
                        p.add_obstacle(cx, cy, CELL_M * std::f64::consts::FRAC_1_SQRT_2)
                    });
                    Seen { last_ms: now_ms, obstacle }
                });
                seen.last_ms = seen.last_ms.max(now_ms);
            }
        }
        self.cells.retain(|&(f, _, _), seen| {
            let keep = now_ms < seen.last_ms.saturating_add(KEEP_MS);
            if let (false, Some(id), Some(p)) = (keep, seen.obstacle, planner.floor_mut(f)) {
                p.remove_obstacle(id);
            }
            keep
        });
        added
    }

    /// Gives every cell back to the graph (a plan that found no way with them).
    pub fn clear(&mut self, planner: &mut BuildingPlanner) {
        for (&(f, _, _), seen) in &self.cells {
            if let (Some(id), Some(p)) = (seen.obstacle, planner.floor_mut(f)) {
                p.remove_obstacle(id);
            }
        }
        self.cells.clear();
    }

    /// How many cells block the graph now.
    pub fn obstacles(&self) -> usize {
        self.cells.values().filter(|s| s.obstacle.is_some()).count()
    }

    /// Points refused so far (not finite, or out of the camera's range).
    pub fn refused(&self) -> u64 {
        self.refused
    }
}

/// True when an occupied cell of `grid` lies within `radius_m` of (x, y); outside the
/// grid counts as occupied (the plan does not say the place is free).
fn near_occupied(grid: &OccupancyGrid, x: f64, y: f64, radius_m: f64) -> bool {
    let res = grid.resolution_m();
    let Some((c, r)) = grid.world_to_cell(x, y) else {
        return true;
    };
    let n = (radius_m / res).ceil() as i64;
    for dr in -n..=n {
        for dc in -n..=n {
            if ((dc * dc + dr * dr) as f64) * res * res > radius_m * radius_m {
                continue;
            }
            let (cc, rr) = (c as i64 + dc, r as i64 + dr);
            if cc < 0 || rr < 0 {
                return true;
            }
            match grid.get(cc as usize, rr as usize) {
                Some(Cell::Occupied) | None => return true,
                _ => {}
            }
        }
    }
    false
}
