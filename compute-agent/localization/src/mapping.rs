//! An occupancy grid from range scans taken at known poses (Moravec & Elfes; Thrun et
//! al. *Probabilistic Robotics* 9.2): each beam's cells get a "free" log-odds update up
//! to the end point and an "occupied" one at it. Used to make a floor map from a
//! recorded log's reference trajectory (the Intel log in the tests), and later from a
//! simulated walk.

use map::{Cell, MapError, OccupancyGrid, Origin};
use serde::{Deserialize, Serialize};

use crate::pose::Pose2;
use crate::scan::Scan;

/// How the grid is built.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MappingConfig {
    /// cell side, metres
    pub resolution_m: f64,
    /// beams longer than this are not used (far readings are sparse and noisy), metres
    pub max_range_m: f64,
    /// space around the scans' extent, metres
    pub margin_m: f64,
    /// log-odds added at a beam's end point
    pub log_odds_hit: f32,
    /// log-odds added along a beam (negative)
    pub log_odds_miss: f32,
    /// above this a cell is occupied
    pub occupied_above: f32,
    /// below this a cell is free
    pub free_below: f32,
}

impl Default for MappingConfig {
    fn default() -> Self {
        Self {
            resolution_m: 0.05,
            max_range_m: 20.0,
            margin_m: 1.0,
            log_odds_hit: 0.85,
            log_odds_miss: -0.4,
            occupied_above: 0.5,
            free_below: -0.5,
        }
    }
}

/// Builds the grid of `scans` taken at `poses` (body poses in the map frame; the
/// scan's own sensor offset applies). Refused by the map crate when it would be too
/// large ([`map::MAX_CELLS`]).
pub fn build_grid<'a>(
    scans: impl IntoIterator<Item = (Pose2, &'a Scan)> + Clone,
    config: &MappingConfig,
) -> Result<OccupancyGrid, MapError> {
    let res = config.resolution_m;
    let mut endpoints = Vec::new();
    // extent of sensor positions and used end points
    let (mut x0, mut y0, mut x1, mut y1) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    let mut grow = |x: f64, y: f64| {
        x0 = x0.min(x);
        y0 = y0.min(y);
        x1 = x1.max(x);
        y1 = y1.max(y);
    };
    for (pose, scan) in scans.clone() {
        let sensor = pose.compose(scan.sensor_forward_m, scan.sensor_left_m, scan.sensor_yaw_rad);
        grow(sensor.x_m, sensor.y_m);
        let limited = limited(scan, config.max_range_m);
        limited.endpoints_into(usize::MAX, &mut endpoints);
        for &[bx, by] in &endpoints {
            let p = pose.compose(bx, by, 0.0);
            grow(p.x_m, p.y_m);
        }
    }
    if !x0.is_finite() {
        x0 = 0.0;
        y0 = 0.0;
        x1 = 0.0;
        y1 = 0.0;
    }
    let origin = Origin { x_m: x0 - config.margin_m, y_m: y0 - config.margin_m, yaw_rad: 0.0 };
    let width = ((x1 - x0 + 2.0 * config.margin_m) / res).ceil().max(1.0) as usize;
    let height = ((y1 - y0 + 2.0 * config.margin_m) / res).ceil().max(1.0) as usize;
    // checks the size before we allocate the log-odds
    let grid = OccupancyGrid::filled(width, height, res, origin, Cell::Unknown)?;
    let mut odds = vec![0.0f32; width * height];
    let to_cell = |x: f64, y: f64| (((x - origin.x_m) / res).floor() as i64, ((y - origin.y_m) / res).floor() as i64);
    for (pose, scan) in scans {
        let sensor = pose.compose(scan.sensor_forward_m, scan.sensor_left_m, scan.sensor_yaw_rad);
        let (sc, sr) = to_cell(sensor.x_m, sensor.y_m);
        limited(scan, config.max_range_m).endpoints_into(usize::MAX, &mut endpoints);
        for &[bx, by] in &endpoints {
            let p = pose.compose(bx, by, 0.0);
            let (ec, er) = to_cell(p.x_m, p.y_m);
            trace(sc, sr, ec, er, |c, r| {
                if c >= 0 && r >= 0 && (c as usize) < width && (r as usize) < height {
                    odds[r as usize * width + c as usize] += config.log_odds_miss;
                }
            });
            if ec >= 0 && er >= 0 && (ec as usize) < width && (er as usize) < height {
                odds[er as usize * width + ec as usize] += config.log_odds_hit;
            }
        }
    }
    let cells = odds
        .iter()
        .map(|&l| {
            if l > config.occupied_above {
                Cell::Occupied
            } else if l < config.free_below {
                Cell::Free
            } else {
                Cell::Unknown
            }
        })
        .collect();
    OccupancyGrid::new(grid.width(), grid.height(), res, origin, cells)
}

/// The scan with beams beyond `max_range_m` dropped (as if at the sensor's maximum).
fn limited(scan: &Scan, max_range_m: f64) -> Scan {
    Scan { max_range_m: scan.max_range_m.min(max_range_m), ..scan.clone() }
}

/// Calls `visit` for the cells from (c0, r0) up to but not including (c1, r1)
/// (Bresenham's line).
fn trace(c0: i64, r0: i64, c1: i64, r1: i64, mut visit: impl FnMut(i64, i64)) {
    let (dc, dr) = ((c1 - c0).abs(), -(r1 - r0).abs());
    let (sc, sr) = (if c0 < c1 { 1 } else { -1 }, if r0 < r1 { 1 } else { -1 });
    let (mut c, mut r, mut err) = (c0, r0, dc + dr);
    while (c, r) != (c1, r1) {
        visit(c, r);
        let e2 = 2 * err;
        if e2 >= dr {
            err += dr;
            c += sc;
        }
        if e2 <= dc {
            err += dc;
            r += sr;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan::Beam;

    #[test]
    fn a_wall_ahead_is_occupied_and_the_way_to_it_free() {
        // a 2 m wall seen from 1.5 m, beams from -30 to +30 degrees
        let beams = (-30..=30)
            .map(|d| {
                let a = (d as f64).to_radians();
                Beam { angle_rad: a, range_m: 1.5 / a.cos() }
            })
            .collect();
        let scan = Scan::at_body_origin(beams, 10.0);
        let g = build_grid([(Pose2::new(0.0, 0.0, 0.0), &scan)], &MappingConfig::default()).expect("grid");
        let at = |x: f64, y: f64| g.world_to_cell(x, y).and_then(|(c, r)| g.get(c, r));
        assert_eq!(at(1.52, 0.0), Some(Cell::Occupied));
        assert_eq!(at(1.52, 0.5), Some(Cell::Occupied));
        assert_eq!(at(0.7, 0.0), Some(Cell::Free));
        assert_eq!(at(0.7, 0.1), Some(Cell::Free));
        assert_eq!(at(-0.5, 0.0), Some(Cell::Unknown));
    }
}
