//! Line-of-sight path smoothing (ISANA, "path smoothing": their 325 m route went from
//! 1475 graph nodes to 119). From each kept point, the path jumps to the farthest later
//! point it can see over the inflated grid; "see" means every cell the segment touches
//! (a supercover walk, Amanatides & Woo 1987, both cells at an exact corner) is free and
//! the segment keeps clear of every obstacle disc.

use map::{Cell, OccupancyGrid};

/// A circular obstacle seen at run time, already grown by the user's clearance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disc {
    /// centre, map frame, metres
    pub x: f64,
    /// centre, map frame, metres
    pub y: f64,
    /// radius including clearance, metres
    pub radius_m: f64,
}

/// True when every cell the segment a-b touches is free in `grid`.
pub fn grid_line_clear(grid: &OccupancyGrid, a: [f64; 2], b: [f64; 2]) -> bool {
    supercover(grid, a, b, |c| c == Cell::Free)
}

/// True when no cell the segment a-b touches is occupied in `grid` (unknown is allowed).
pub fn grid_line_not_occupied(grid: &OccupancyGrid, a: [f64; 2], b: [f64; 2]) -> bool {
    supercover(grid, a, b, |c| c != Cell::Occupied)
}

/// Walks the cells of segment a-b (map frame); false as soon as one fails `ok` or the
/// segment leaves the grid.
fn supercover(grid: &OccupancyGrid, a: [f64; 2], b: [f64; 2], ok: impl Fn(Cell) -> bool) -> bool {
    let (x0, y0) = grid.world_to_grid(a[0], a[1]);
    let (x1, y1) = grid.world_to_grid(b[0], b[1]);
    if !(x0.is_finite() && y0.is_finite() && x1.is_finite() && y1.is_finite()) {
        return false;
    }
    let cell_ok = |cx: i64, cy: i64| cx >= 0 && cy >= 0 && grid.get(cx as usize, cy as usize).is_some_and(&ok);
    let (mut cx, mut cy) = (x0.floor() as i64, y0.floor() as i64);
    let (ex, ey) = (x1.floor() as i64, y1.floor() as i64);
    if !cell_ok(cx, cy) {
        return false;
    }
    let (dx, dy) = (x1 - x0, y1 - y0);
    let sx: i64 = if dx > 0.0 { 1 } else { -1 };
    let sy: i64 = if dy > 0.0 { 1 } else { -1 };
    let t_delta_x = if dx != 0.0 { 1.0 / dx.abs() } else { f64::INFINITY };
    let t_delta_y = if dy != 0.0 { 1.0 / dy.abs() } else { f64::INFINITY };
    let next_x = if dx > 0.0 { cx as f64 + 1.0 - x0 } else { x0 - cx as f64 };
    let next_y = if dy > 0.0 { cy as f64 + 1.0 - y0 } else { y0 - cy as f64 };
    let mut t_max_x = if dx != 0.0 { next_x * t_delta_x } else { f64::INFINITY };
    let mut t_max_y = if dy != 0.0 { next_y * t_delta_y } else { f64::INFINITY };
    let steps = (ex - cx).abs() + (ey - cy).abs();
    let mut taken = 0;
    while (cx, cy) != (ex, ey) && taken <= steps {
        if (t_max_x - t_max_y).abs() < 1e-9 {
            // through a corner: both side cells must be fine too (no corner cutting)
            if !cell_ok(cx + sx, cy) || !cell_ok(cx, cy + sy) {
                return false;
            }
            cx += sx;
            cy += sy;
            t_max_x += t_delta_x;
            t_max_y += t_delta_y;
            taken += 2;
        } else if t_max_x < t_max_y {
            cx += sx;
            t_max_x += t_delta_x;
            taken += 1;
        } else {
            cy += sy;
            t_max_y += t_delta_y;
            taken += 1;
        }
        if !cell_ok(cx, cy) {
            return false;
        }
    }
    true
}

/// True when segment a-b stays outside every disc.
pub fn clear_of_discs(discs: &[Disc], a: [f64; 2], b: [f64; 2]) -> bool {
    discs.iter().all(|d| segment_point_distance(a, b, [d.x, d.y]) >= d.radius_m)
}

/// Distance from point p to segment a-b.
pub fn segment_point_distance(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    let (vx, vy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = vx * vx + vy * vy;
    let t = if len2 > 0.0 { (((p[0] - a[0]) * vx + (p[1] - a[1]) * vy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (a[0] + t * vx - p[0]).hypot(a[1] + t * vy - p[1])
}

/// Indices of the points kept by line-of-sight smoothing (always the first and the
/// last). Between kept points the straight segment is clear on `grid` and of `discs`.
pub fn smooth(grid: &OccupancyGrid, discs: &[Disc], points: &[[f64; 2]]) -> Vec<usize> {
    let n = points.len();
    if n <= 2 {
        return (0..n).collect();
    }
    let visible =
        |a: usize, b: usize| grid_line_clear(grid, points[a], points[b]) && clear_of_discs(discs, points[a], points[b]);
    let mut kept = vec![0];
    let mut anchor = 0;
    while anchor < n - 1 {
        // the graph edge to the next point is always allowed, seen or not
        let mut far = anchor + 1;
        while far + 1 < n && visible(anchor, far + 1) {
            far += 1;
        }
        kept.push(far);
        anchor = far;
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use map::Origin;

    fn grid_with_block() -> OccupancyGrid {
        let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        let mut g = OccupancyGrid::filled(10, 10, 1.0, o, Cell::Free).unwrap();
        g.set(5, 5, Cell::Occupied);
        g
    }

    #[test]
    fn segments_through_or_beside_a_block() {
        let g = grid_with_block();
        assert!(!grid_line_clear(&g, [0.5, 0.5], [9.5, 9.5]), "straight through (5,5)");
        assert!(grid_line_clear(&g, [0.5, 0.5], [9.5, 0.5]));
        // touching the block's corner exactly counts as blocked (no corner cutting)
        assert!(!grid_line_clear(&g, [4.0 - 0.5, 6.5], [6.5, 3.5]));
        assert!(!grid_line_clear(&g, [0.5, 0.5], [10.5, 0.5]), "leaves the grid");
        assert!(grid_line_clear(&g, [2.5, 2.5], [2.5, 2.5]));
    }

    #[test]
    fn smoothing_keeps_the_corner_of_an_l() {
        let g = grid_with_block();
        // an L around the block: right along y = 4.5, then up x = 6.5... via (6.5, 4.5)
        let pts: Vec<[f64; 2]> =
            (0..7).map(|i| [i as f64 + 0.5, 4.5]).chain((5..10).map(|j| [6.5, j as f64 + 0.5])).collect();
        let kept = smooth(&g, &[], &pts);
        // from (0.5, 4.5) the farthest visible point past the block is not the end
        assert_eq!(kept.first(), Some(&0));
        assert_eq!(kept.last(), Some(&(pts.len() - 1)));
        assert!(kept.len() >= 3 && kept.len() < pts.len());
        for w in kept.windows(2) {
            if w[1] > w[0] + 1 {
                assert!(grid_line_clear(&g, pts[w[0]], pts[w[1]]));
            }
        }
    }

    #[test]
    fn discs_block_segments_that_pass_too_close() {
        let d = [Disc { x: 5.0, y: 1.0, radius_m: 0.9 }];
        assert!(!clear_of_discs(&d, [0.0, 0.5], [9.0, 0.5]));
        assert!(clear_of_discs(&d, [0.0, 0.0], [9.0, 0.0]));
        assert!((segment_point_distance([0.0, 0.0], [2.0, 0.0], [3.0, 4.0]) - 17f64.sqrt()).abs() < 1e-12);
    }
}
