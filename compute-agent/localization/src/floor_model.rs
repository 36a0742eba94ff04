//! What the filter needs of one floor: the likelihood field of its occupancy grid, its
//! free cells (where recovery may put particles), its numbered doors, the corners of its
//! outline (found in the grid, [`crate::corners`]), and
//! its wall directions (for the wall-angle correction).

use map::{Cell, DistanceField, OccupancyGrid, SemanticLayer};

use std::sync::OnceLock;

use crate::corners::{corners_of_grid, CornerField, GridCornerConfig};
use crate::likelihood_field::{LikelihoodField, LikelihoodFieldConfig};
use crate::LocalizationError;

/// One floor, ready for the filter.
#[derive(Clone, Debug)]
pub struct FloorModel {
    /// the floor's level (0 = ground)
    pub level: i32,
    pub(crate) field: LikelihoodField,
    /// centres of the free cells, metres
    pub(crate) free_cells: Vec<[f64; 2]>,
    /// the grid, for "is this place free"
    grid: OccupancyGrid,
    pub(crate) cell_m: f64,
    /// (number as [`door_key`] has it, place)
    pub(crate) doors: Vec<(String, [f64; 2])>,
    /// the corners of its free space's outline ([`crate::corners`]), found when first
    /// asked for (only a corner seen needs them)
    corners: OnceLock<CornerField>,
    /// wall directions in the map frame, radians, each modulo pi
    pub(crate) wall_directions_rad: Vec<f64>,
}

impl FloorModel {
    /// A floor from its grid and semantic layer (doors of other floors are
    /// ignored). Wall directions are estimated from the grid
    /// ([`dominant_wall_directions`]); set others with [`Self::with_wall_directions`].
    /// Refuses a grid with no free cell: nothing could ever be localized on it.
    pub fn new(
        level: i32,
        grid: &OccupancyGrid,
        semantic: &SemanticLayer,
        config: &LikelihoodFieldConfig,
    ) -> Result<Self, LocalizationError> {
        let free_cells: Vec<[f64; 2]> = (0..grid.height())
            .flat_map(|r| (0..grid.width()).map(move |c| (c, r)))
            .filter(|&(c, r)| grid.get(c, r) == Some(Cell::Free))
            .map(|(c, r)| {
                let (x, y) = grid.cell_center(c, r);
                [x, y]
            })
            .collect();
        if free_cells.is_empty() {
            return Err(LocalizationError::NoFreeSpace { level });
        }
        let on_floor = semantic.floor(level);
        Ok(Self {
            level,
            field: LikelihoodField::new(grid, config),
            free_cells,
            grid: grid.clone(),
            cell_m: grid.resolution_m(),
            doors: on_floor.doors.iter().map(|d| (door_key(&d.number), [d.x, d.y])).collect(),
            corners: OnceLock::new(),
            wall_directions_rad: dominant_wall_directions(grid),
        })
    }

    /// Replaces the wall directions (radians in the map frame, each taken modulo pi).
    pub fn with_wall_directions(mut self, directions_rad: Vec<f64>) -> Self {
        self.wall_directions_rad = directions_rad;
        self
    }

    /// The corners a corner seen in a scan is matched against, map metres.
    pub fn corners(&self) -> &[[f64; 2]] {
        self.corner_field().corners()
    }

    /// The corners and the distance to the nearest, found in the grid on first use.
    pub fn corner_field(&self) -> &CornerField {
        self.corners
            .get_or_init(|| CornerField::new(&self.grid, corners_of_grid(&self.grid, &GridCornerConfig::default())))
    }

    /// The wall directions the wall-angle correction matches against.
    pub fn wall_directions_rad(&self) -> &[f64] {
        &self.wall_directions_rad
    }

    /// The map position of door `number` on this floor: matched without regard to case
    /// or spaces ("b1.07" is "B1.07", "lab 3" is "Lab3"), as a user types or says it.
    pub fn door(&self, number: &str) -> Option<[f64; 2]> {
        let wanted = door_key(number);
        self.doors.iter().find(|(n, _)| *n == wanted).map(|(_, p)| *p)
    }

    /// Whether map (x, y) is in a free cell (not a wall, not unknown, not off the map):
    /// somewhere a person can stand.
    pub fn is_free(&self, x_m: f64, y_m: f64) -> bool {
        self.grid.world_to_cell(x_m, y_m).and_then(|(c, r)| self.grid.get(c, r)) == Some(Cell::Free)
    }

    /// Whether the straight way from `from` to `to` (map metres) passes through a wall
    /// of the grid (an occupied cell; unknown cells and the map's outside are no wall):
    /// looked at every half cell along it, both ends included. Called for every
    /// particle at every correction of a person's filter: the way is skipped along by
    /// the likelihood field's distance to the nearest wall (less one cell) while that
    /// is more than a cell and a half, and looked along every half cell from there; a
    /// way shorter than its first skip (most of them) costs two cell lookups and no
    /// square root.
    pub fn crosses_wall(&self, from: [f64; 2], to: [f64; 2]) -> bool {
        let (x0, y0) = self.grid.world_to_grid(from[0], from[1]);
        let (x1, y1) = self.grid.world_to_grid(to[0], to[1]);
        let (w, h) = (self.grid.width(), self.grid.height());
        let cells = self.grid.cells();
        let index = |gx: f64, gy: f64| {
            (gx >= 0.0 && gy >= 0.0 && (gx as usize) < w && (gy as usize) < h).then(|| gy as usize * w + gx as usize)
        };
        // the distance in cells to step on from (gx, gy); None in a wall
        let step_from = |gx: f64, gy: f64| match index(gx, gy) {
            Some(i) if cells[i] == Cell::Occupied => None,
            Some(i) => {
                let d = self.field.distance_cells_at_index(i);
                Some(if d > 1.5 { d - 1.0 } else { 0.5 })
            }
            None => Some(0.5),
        };
        let end_in_wall = || index(x1, y1).is_some_and(|i| cells[i] == Cell::Occupied);
        let len2 = (x1 - x0) * (x1 - x0) + (y1 - y0) * (y1 - y0);
        // most ways end within the first step: no square root, no division
        let Some(first) = step_from(x0, y0) else { return true };
        if len2 <= first * first {
            return end_in_wall();
        }
        let len = len2.sqrt();
        if !len.is_finite() {
            return false;
        }
        let (ux, uy) = ((x1 - x0) / len, (y1 - y0) / len);
        // half a cell at a time near a wall, skipping by the distance to the nearest
        // (no occupied cell's centre within d cells) away from them; the end itself last
        let mut t = first;
        while t < len {
            match step_from(x0 + t * ux, y0 + t * uy) {
                Some(step) => t += step,
                None => return true,
            }
        }
        end_in_wall()
    }

    /// The likelihood field of the floor's grid.
    pub fn field(&self) -> &LikelihoodField {
        &self.field
    }
}

/// The dominant wall direction of a grid and the one at right angles to it (most
/// buildings are rectilinear; Zhang et al. correct heading modulo 90 degrees). From the
/// gradient of the distance to walls 4 to 12 cells away (nearer, the raster steps of a
/// slanted wall dominate): a wall's normal is that gradient.
/// Angles are folded modulo 90 degrees and averaged on the circle (angle x 4) within 5
/// degrees of the histogram peak. A grid with no walls gives the grid's own axes.
pub fn dominant_wall_directions(grid: &OccupancyGrid) -> Vec<f64> {
    let field = DistanceField::to_occupied(grid);
    let (w, h) = (field.width(), field.height());
    let res = field.resolution_m() as f32;
    let mut hist = [0.0f64; 90];
    let mut samples: Vec<f64> = Vec::new();
    for r in 2..h.saturating_sub(2) {
        for c in 2..w.saturating_sub(2) {
            let d = field.distances_m()[r * w + c];
            // 4 to 12 cells from a wall: the gradient there is the wall's normal, and
            // far enough from the wall's raster steps to be smooth
            if !(d > 4.0 * res && d < 12.0 * res) {
                continue;
            }
            let at = |cc: usize, rr: usize| field.distances_m()[rr * w + cc];
            let gx = (at(c + 2, r) - at(c - 2, r)) as f64;
            let gy = (at(c, r + 2) - at(c, r - 2)) as f64;
            if !(gx.is_finite() && gy.is_finite()) || gx.hypot(gy) < 1e-9 {
                continue;
            }
            let folded = gy.atan2(gx).rem_euclid(std::f64::consts::FRAC_PI_2);
            hist[(folded.to_degrees() as usize).min(89)] += 1.0;
            samples.push(folded);
        }
    }
    let yaw = grid.origin().yaw_rad;
    if samples.is_empty() {
        return vec![yaw, yaw + std::f64::consts::FRAC_PI_2];
    }
    // smooth over +-2 degrees (circularly) and take the peak
    let peak = (0..90)
        .max_by(|&a, &b| {
            let s = |i: usize| (0..5).map(|k| hist[(i + 88 + k) % 90]).sum::<f64>();
            s(a).total_cmp(&s(b))
        })
        .unwrap_or(0) as f64
        + 0.5;
    let (mut sx, mut sy) = (0.0, 0.0);
    for a in samples {
        let diff = ((a.to_degrees() - peak + 45.0).rem_euclid(90.0)) - 45.0;
        if diff.abs() <= 5.0 {
            sx += (4.0 * a).cos();
            sy += (4.0 * a).sin();
        }
    }
    let theta = (sy.atan2(sx) / 4.0).rem_euclid(std::f64::consts::FRAC_PI_2);
    // the normal's direction folded modulo 90 degrees is also the wall's
    vec![theta, theta + std::f64::consts::FRAC_PI_2]
}

/// A door number as lookups compare it: no spaces, lower case.
fn door_key(number: &str) -> String {
    number.chars().filter(|c| !c.is_whitespace()).flat_map(char::to_lowercase).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use map::Origin;

    #[test]
    fn finds_the_direction_of_a_rotated_rectangle_room() {
        let angle = 20f64.to_radians();
        let (w, h) = (200, 200);
        let mut g =
            OccupancyGrid::filled(w, h, 0.05, Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, Cell::Free).expect("grid");
        // a 6 x 4 m rectangle rotated by 20 degrees about (5, 5)
        for r in 0..h {
            for c in 0..w {
                let (x, y) = g.cell_center(c, r);
                let (dx, dy) = (x - 5.0, y - 5.0);
                let (u, v) = (angle.cos() * dx + angle.sin() * dy, -angle.sin() * dx + angle.cos() * dy);
                let inside = u.abs() < 3.0 && v.abs() < 2.0;
                let wall = inside && (u.abs() > 2.9 || v.abs() > 1.9);
                g.set(
                    c,
                    r,
                    if wall {
                        Cell::Occupied
                    } else if inside {
                        Cell::Free
                    } else {
                        Cell::Unknown
                    },
                );
            }
        }
        let dirs = dominant_wall_directions(&g);
        let err = crate::landmarks::wall_residual(angle, &dirs);
        assert!(err < 1f64.to_radians(), "found {:?} deg", dirs.iter().map(|d| d.to_degrees()).collect::<Vec<_>>());
    }
}
