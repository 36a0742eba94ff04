//! An ISANA-sized floor (29 x 22 m, as their test floor) at 5 cm: a corridor across, a
//! corridor along, twelve rooms with 1 m doors. Shared by the tests and the bench.

#![allow(dead_code)]

use map::{Cell, OccupancyGrid, Origin};

/// Floor size, metres.
pub const WIDTH_M: f64 = 29.0;
/// Floor size, metres.
pub const HEIGHT_M: f64 = 22.0;
/// Grid resolution, metres.
pub const RES_M: f64 = 0.05;
/// Wall thickness, metres.
pub const WALL_M: f64 = 0.1;

/// Sets every cell whose centre lies in [x0, x1] x [y0, y1] to `cell`.
pub fn paint(g: &mut OccupancyGrid, x0: f64, y0: f64, x1: f64, y1: f64, cell: Cell) {
    for r in 0..g.height() {
        for c in 0..g.width() {
            let (x, y) = g.cell_center(c, r);
            if x >= x0 && x <= x1 && y >= y0 && y <= y1 {
                g.set(c, r, cell);
            }
        }
    }
}

/// A wall from (x0, y0) to (x1, y1), axis-aligned, `WALL_M` thick.
pub fn wall(g: &mut OccupancyGrid, x0: f64, y0: f64, x1: f64, y1: f64) {
    let t = WALL_M / 2.0;
    paint(g, x0.min(x1) - t, y0.min(y1) - t, x0.max(x1) + t, y0.max(y1) + t, Cell::Occupied);
}

/// A 1 m door centred at (x, y) in a horizontal wall.
pub fn door(g: &mut OccupancyGrid, x: f64, y: f64) {
    paint(g, x - 0.5, y - 0.1, x + 0.5, y + 0.1, Cell::Free);
}

/// Room x-ranges on each side of the corridor across (the corridor along is 13.5..15.5).
pub const ROOMS_X: [(f64, f64); 6] = [(0.0, 4.5), (4.5, 9.0), (9.0, 13.5), (15.5, 20.0), (20.0, 24.5), (24.5, 29.0)];

/// The floor: outer walls; corridor across at y 10..12; corridor along at x 13.5..15.5
/// the whole height; six rooms below and six above, each with a door on the corridor.
pub fn isana_floor() -> OccupancyGrid {
    let (w, h) = ((WIDTH_M / RES_M).round() as usize, (HEIGHT_M / RES_M).round() as usize);
    let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
    let mut g = OccupancyGrid::filled(w, h, RES_M, o, Cell::Free).unwrap();
    let (x1, y1) = (WIDTH_M - 0.05, HEIGHT_M - 0.05);
    wall(&mut g, 0.05, 0.05, x1, 0.05);
    wall(&mut g, 0.05, y1, x1, y1);
    wall(&mut g, 0.05, 0.05, 0.05, y1);
    wall(&mut g, x1, 0.05, x1, y1);
    // corridor across: walls at y = 10 and y = 12, open where the corridor along crosses
    for y in [10.0, 12.0] {
        wall(&mut g, 0.05, y, 13.5, y);
        wall(&mut g, 15.5, y, x1, y);
    }
    // corridor along: walls at x = 13.5 and 15.5, open across the corridor across
    for x in [13.5, 15.5] {
        wall(&mut g, x, 0.05, x, 10.0);
        wall(&mut g, x, 12.0, x, y1);
    }
    // room partitions
    for x in [4.5, 9.0, 20.0, 24.5] {
        wall(&mut g, x, 0.05, x, 10.0);
        wall(&mut g, x, 12.0, x, y1);
    }
    for (a, b) in ROOMS_X {
        let cx = (a + b) / 2.0;
        door(&mut g, cx, 10.0);
        door(&mut g, cx, 12.0);
    }
    // the rooms beside the corridor along open onto it too? no: one door each, on the
    // corridor across, so routes between rooms all pass through it
    g
}

/// The far corners of the floor: bottom-left room to top-right room.
pub const LONGEST: ([f64; 2], [f64; 2]) = ([1.0, 1.0], [28.0, 21.0]);
