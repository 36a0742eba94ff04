//! Synthetic floors and scans for behaviour tests: a grid from a predicate and a
//! ray-cast scan against it.

use localization::{Beam, Pose2, Scan};
use map::{Cell, OccupancyGrid, Origin};

/// A `width_m` x `height_m` grid at 5 cm whose cells are occupied where `wall` holds
/// and free elsewhere.
pub fn grid(width_m: f64, height_m: f64, wall: impl Fn(f64, f64) -> bool) -> OccupancyGrid {
    let res = 0.05;
    let (w, h) = ((width_m / res).round() as usize, (height_m / res).round() as usize);
    let mut g =
        OccupancyGrid::filled(w, h, res, Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, Cell::Free).expect("grid");
    for r in 0..h {
        for c in 0..w {
            let (x, y) = g.cell_center(c, r);
            if wall(x, y) {
                g.set(c, r, Cell::Occupied);
            }
        }
    }
    g
}

/// A scan from `pose`: `beams` beams over `fov_rad`, ray-cast in 2.5 cm steps to the
/// first occupied cell; nothing within `max_range_m` reads as `max_range_m`.
pub fn cast(grid: &OccupancyGrid, pose: &Pose2, beams: usize, fov_rad: f64, max_range_m: f64) -> Scan {
    let beams = (0..beams)
        .map(|i| {
            let a = -fov_rad / 2.0 + fov_rad * i as f64 / (beams - 1) as f64;
            let (s, c) = (pose.heading_rad + a).sin_cos();
            let mut r = 0.0;
            while r < max_range_m {
                let (x, y) = (pose.x_m + c * r, pose.y_m + s * r);
                match grid.world_to_cell(x, y).and_then(|(cc, rr)| grid.get(cc, rr)) {
                    Some(Cell::Occupied) | None => break,
                    _ => r += 0.025,
                }
            }
            Beam { angle_rad: a, range_m: r.min(max_range_m) }
        })
        .collect();
    Scan::at_body_origin(beams, max_range_m)
}
