//! The occupancy grid: cells on a regular lattice placed in the map frame.
//!
//! Storage follows ROS `nav_msgs/OccupancyGrid`: row-major, row 0 at the *bottom*
//! (smallest y), so cell (col, row) covers `origin + ((col, row) + 0.5) * resolution`
//! rotated by the origin's yaw. The image rows of a map_server file run the other way
//! (row 0 at the top); the loader and the writer flip them.

use std::path::PathBuf;

use crate::error::MapError;

/// Refuse maps with more cells than this before allocating anything (64 M cells: a
/// 400 x 400 m floor at 5 cm; the largest building we plan for is far smaller).
pub const MAX_CELLS: u64 = 64 * 1024 * 1024;

/// The largest cell we accept, in metres (map_server has no limit; a 10 m cell is
/// no floor map).
pub const MAX_RESOLUTION_M: f64 = 10.0;

/// What one cell holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Cell {
    /// Known to be walkable floor.
    Free,
    /// Known to be an obstacle (wall, furniture).
    Occupied,
    /// Never observed, or between the thresholds.
    Unknown,
}

/// Where the grid's cell (0, 0) corner sits in the map frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Origin {
    /// x of the lower-left corner of cell (0, 0), metres
    pub x_m: f64,
    /// y of the lower-left corner of cell (0, 0), metres
    pub y_m: f64,
    /// rotation of the grid about that corner, radians (map_server's third origin value)
    pub yaw_rad: f64,
}

/// A floor map: `width * height` cells of `resolution_m` metres.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyGrid {
    width: usize,
    height: usize,
    resolution_m: f64,
    origin: Origin,
    /// sin and cos of the origin's yaw, taken once: every map point a filter or a
    /// planner turns into cells needs them
    yaw_sin_cos: (f64, f64),
    cells: Vec<Cell>,
}

impl OccupancyGrid {
    /// A grid from its cells (row 0 = bottom). Refuses an empty or oversized grid, an
    /// absurd resolution and a cell count that does not match the size.
    pub fn new(
        width: usize,
        height: usize,
        resolution_m: f64,
        origin: Origin,
        cells: Vec<Cell>,
    ) -> Result<Self, MapError> {
        let file = PathBuf::from("<memory>");
        check_size(&file, width as u64, height as u64)?;
        check_resolution(&file, resolution_m)?;
        if !(origin.x_m.is_finite() && origin.y_m.is_finite() && origin.yaw_rad.is_finite()) {
            return Err(MapError::BadField {
                file,
                field: "origin",
                message: format!("origin must be finite, got {origin:?}"),
            });
        }
        let expected = width as u64 * height as u64;
        if cells.len() as u64 != expected {
            return Err(MapError::SizeMismatch {
                file,
                width: width as u64,
                height: height as u64,
                expected,
                found: cells.len() as u64,
            });
        }
        Ok(Self { width, height, resolution_m, origin, yaw_sin_cos: origin.yaw_rad.sin_cos(), cells })
    }

    /// A grid of one value everywhere.
    pub fn filled(
        width: usize,
        height: usize,
        resolution_m: f64,
        origin: Origin,
        cell: Cell,
    ) -> Result<Self, MapError> {
        check_size(&PathBuf::from("<memory>"), width as u64, height as u64)?;
        Self::new(width, height, resolution_m, origin, vec![cell; width * height])
    }

    /// Width in cells (x).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in cells (y).
    pub fn height(&self) -> usize {
        self.height
    }

    /// Metres per cell side.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// The lower-left corner of cell (0, 0) in the map frame.
    pub fn origin(&self) -> Origin {
        self.origin
    }

    /// All cells, row-major, row 0 at the bottom.
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }

    /// The cell at (col, row), or `None` outside the grid.
    pub fn get(&self, col: usize, row: usize) -> Option<Cell> {
        (col < self.width && row < self.height).then(|| self.cells[row * self.width + col])
    }

    /// Sets the cell at (col, row); outside the grid it does nothing and returns false.
    pub fn set(&mut self, col: usize, row: usize, cell: Cell) -> bool {
        if col < self.width && row < self.height {
            self.cells[row * self.width + col] = cell;
            true
        } else {
            false
        }
    }

    /// How many cells hold `cell`.
    pub fn count(&self, cell: Cell) -> usize {
        self.cells.iter().filter(|&&c| c == cell).count()
    }

    /// The centre of cell (col, row) in the map frame, metres.
    pub fn cell_center(&self, col: usize, row: usize) -> (f64, f64) {
        let gx = (col as f64 + 0.5) * self.resolution_m;
        let gy = (row as f64 + 0.5) * self.resolution_m;
        let (s, c) = self.yaw_sin_cos;
        (self.origin.x_m + c * gx - s * gy, self.origin.y_m + s * gx + c * gy)
    }

    /// The cell containing map point (x, y), or `None` outside the grid (or for NaN).
    pub fn world_to_cell(&self, x_m: f64, y_m: f64) -> Option<(usize, usize)> {
        let (gx, gy) = self.world_to_grid(x_m, y_m);
        if !(gx >= 0.0 && gy >= 0.0) {
            return None;
        }
        let (col, row) = (gx as usize, gy as usize);
        (col < self.width && row < self.height).then_some((col, row))
    }

    /// Map point (x, y) in continuous cell units (cell (c, r) spans [c, c+1) x [r, r+1)).
    pub fn world_to_grid(&self, x_m: f64, y_m: f64) -> (f64, f64) {
        let (dx, dy) = (x_m - self.origin.x_m, y_m - self.origin.y_m);
        let (s, c) = self.yaw_sin_cos;
        ((c * dx + s * dy) / self.resolution_m, (-s * dx + c * dy) / self.resolution_m)
    }

    /// The same grid with other cells (same size), used by inflation.
    pub(crate) fn with_cells(&self, cells: Vec<Cell>) -> Self {
        debug_assert_eq!(cells.len(), self.cells.len());
        Self { cells, ..self.clone() }
    }
}

pub(crate) fn check_size(file: &std::path::Path, width: u64, height: u64) -> Result<(), MapError> {
    if width == 0 || height == 0 {
        return Err(MapError::Empty { file: file.to_path_buf(), width, height });
    }
    if width.saturating_mul(height) > MAX_CELLS {
        return Err(MapError::TooLarge { file: file.to_path_buf(), width, height, limit: MAX_CELLS });
    }
    Ok(())
}

pub(crate) fn check_resolution(file: &std::path::Path, resolution_m: f64) -> Result<(), MapError> {
    if resolution_m.is_nan() || resolution_m <= 0.0 || resolution_m > MAX_RESOLUTION_M {
        return Err(MapError::Resolution { file: file.to_path_buf(), value: resolution_m });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn origin(x: f64, y: f64, yaw: f64) -> Origin {
        Origin { x_m: x, y_m: y, yaw_rad: yaw }
    }

    #[test]
    fn cell_centre_and_back_agree_with_a_rotated_origin() {
        let g = OccupancyGrid::filled(10, 8, 0.5, origin(2.0, -1.0, 0.3), Cell::Free).unwrap();
        for (c, r) in [(0, 0), (9, 7), (3, 5)] {
            let (x, y) = g.cell_center(c, r);
            assert_eq!(g.world_to_cell(x, y), Some((c, r)));
        }
        assert_eq!(g.world_to_cell(f64::NAN, 0.0), None);
        assert_eq!(g.world_to_cell(1.9, -1.0), None);
    }

    #[test]
    fn unrotated_cell_centre_is_origin_plus_half_a_cell() {
        let g = OccupancyGrid::filled(4, 4, 0.05, origin(-10.0, -10.0, 0.0), Cell::Free).unwrap();
        let (x, y) = g.cell_center(0, 0);
        assert!((x + 9.975).abs() < 1e-12 && (y + 9.975).abs() < 1e-12);
    }

    #[test]
    fn empty_oversized_and_mismatched_grids_are_refused() {
        let o = origin(0.0, 0.0, 0.0);
        assert!(matches!(OccupancyGrid::new(0, 0, 0.05, o, vec![]), Err(MapError::Empty { .. })));
        assert!(matches!(OccupancyGrid::filled(100_000, 100_000, 0.05, o, Cell::Free), Err(MapError::TooLarge { .. })));
        assert!(matches!(
            OccupancyGrid::new(2, 2, 0.05, o, vec![Cell::Free; 3]),
            Err(MapError::SizeMismatch { expected: 4, found: 3, .. })
        ));
        for bad in [0.0, -1.0, f64::NAN, 10.5] {
            assert!(matches!(OccupancyGrid::filled(2, 2, bad, o, Cell::Free), Err(MapError::Resolution { .. })));
        }
    }
}
