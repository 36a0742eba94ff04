//! Wall corners: where two straight walls meet. Zhang et al. (CCNY) correct the place
//! with corridor corners detected from depth, a landmark that is not unique (matched to
//! the nearest corner on the map, [`crate::Landmark::Corner`]). For a detection to be
//! matched, the map's corners must be the same kind of point, so both come from the
//! geometry and neither from a label:
//!
//! - **in a scan**, two of the walls [`crate::walls`] finds whose lines cross at
//!   [`CornerConfig::min_angle_deg`] or more, where each wall reaches within
//!   [`CornerConfig::reach_m`] of the crossing and one of them ends there (the walls
//!   meet; their lines extended across a doorway do not count). The corner is the
//!   crossing, where the two wall faces meet;
//! - **in a map**, Harris and Stephens' corner response on the map's free space (the
//!   structure tensor of its smoothed edge, at the scale of a few cells): the corners
//!   of the free space's outline, into a room or out of it, at any angle, but not the
//!   steps a slanting wall makes on a grid (smoothed away) and not along straight walls.
//!
//! The semantic layer's corners (a corridor junction's label) are for people and
//! guidance: a label placed mid-junction is not where a camera sees walls meet.

use map::{Cell, DistanceField, OccupancyGrid};
use serde::{Deserialize, Serialize};

use crate::walls::WallSegment;

/// What counts as a corner in a scan.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CornerConfig {
    /// smallest angle between the two walls' lines, degrees (a corridor's corner is 90;
    /// a wall and a slanted desk side at 30 are not a corner anyone maps)
    pub min_angle_deg: f64,
    /// each wall must reach this close to the crossing, and one must end this close to
    /// it, metres (the split between two walls leaves out the point between them, and
    /// the scan's points lie a few centimetres off a wall)
    pub reach_m: f64,
    /// corners closer than this are one (two wall pairs sharing a face), metres
    pub merge_m: f64,
}

impl Default for CornerConfig {
    fn default() -> Self {
        Self { min_angle_deg: 60.0, reach_m: 0.3, merge_m: 0.3 }
    }
}

/// The corners where two of `walls` meet (body frame, metres forward and left), see the
/// module documentation.
pub fn corners_of_walls(walls: &[WallSegment], config: &CornerConfig) -> Vec<[f64; 2]> {
    let min_sin = config.min_angle_deg.to_radians().sin();
    let mut out: Vec<[f64; 2]> = Vec::new();
    for (i, a) in walls.iter().enumerate() {
        for b in &walls[i + 1..] {
            let (ua, ub) = (direction(a), direction(b));
            let cross = ua[0] * ub[1] - ua[1] * ub[0];
            if cross.abs() < min_sin {
                continue;
            }
            // a.from + s ua = b.from + t ub
            let d = [b.from[0] - a.from[0], b.from[1] - a.from[1]];
            let s = (d[0] * ub[1] - d[1] * ub[0]) / cross;
            let x = [a.from[0] + s * ua[0], a.from[1] + s * ua[1]];
            let (ra, rb) = (beyond(a, x), beyond(b, x));
            let ends = end_distance(a, x).min(end_distance(b, x));
            let meet = ra <= config.reach_m && rb <= config.reach_m && ends <= config.reach_m;
            if meet && !out.iter().any(|c| (c[0] - x[0]).hypot(c[1] - x[1]) < config.merge_m) {
                out.push(x);
            }
        }
    }
    out
}

fn direction(w: &WallSegment) -> [f64; 2] {
    let l = w.length_m().max(1e-9);
    [(w.to[0] - w.from[0]) / l, (w.to[1] - w.from[1]) / l]
}

/// How far `x` (on the wall's line) lies beyond the wall's ends, 0 within it.
fn beyond(w: &WallSegment, x: [f64; 2]) -> f64 {
    let u = direction(w);
    let along = (x[0] - w.from[0]) * u[0] + (x[1] - w.from[1]) * u[1];
    (-along).max(along - w.length_m()).max(0.0)
}

fn end_distance(w: &WallSegment, x: [f64; 2]) -> f64 {
    let d = |p: [f64; 2]| (p[0] - x[0]).hypot(p[1] - x[1]);
    d(w.from).min(d(w.to))
}

/// What counts as a corner in a map.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GridCornerConfig {
    /// the outline is smoothed over this much before its gradient is taken, metres (a
    /// slanting wall's steps on a 5 cm grid vanish; a corner's do not)
    pub smoothing_m: f64,
    /// the gradients are summed over this much around each cell, metres
    pub window_m: f64,
    /// Harris and Stephens' k
    pub k: f64,
    /// a corner's response must reach this share of a right angle's
    pub min_response: f64,
    /// two corners are at least this far apart (the stronger is kept), metres
    pub separation_m: f64,
}

impl Default for GridCornerConfig {
    fn default() -> Self {
        Self { smoothing_m: 0.075, window_m: 0.1, k: 0.05, min_response: 0.1, separation_m: 0.15 }
    }
}

/// The corners of `grid`'s free space (map metres), see the module documentation. An
/// unknown cell counts as not free: the outside of a building has no corners to see.
pub fn corners_of_grid(grid: &OccupancyGrid, config: &GridCornerConfig) -> Vec<[f64; 2]> {
    let cell_m = grid.resolution_m();
    // a margin round the grid, wide enough for the blurs, that carries its edge on: a
    // corner by the grid's edge is found as one in its middle, and the edge of a wall
    // cut by the grid's is no corner
    let pad = (3.0 * (config.smoothing_m + config.window_m) / cell_m).ceil() as usize + 2;
    let (gw, gh) = (grid.width(), grid.height());
    let (w, h) = (gw + 2 * pad, gh + 2 * pad);
    let solid: Vec<f32> = (0..w * h)
        .map(|i| {
            let col = (i % w).saturating_sub(pad).min(gw - 1);
            let row = (i / w).saturating_sub(pad).min(gh - 1);
            if grid.get(col, row) == Some(Cell::Free) {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    let (response, gradient) = harris(&solid, w, h, cell_m, config);
    let reference = right_angle_response(cell_m, config);
    if reference.is_nan() || reference <= 0.0 {
        return Vec::new();
    }
    let threshold = (config.min_response * reference) as f32;
    let r = (config.separation_m / cell_m).ceil() as isize;
    let mut peaks: Vec<(f32, usize, usize)> = Vec::new();
    for row in 0..h {
        for col in 0..w {
            let v = response[row * w + col];
            if v < threshold {
                continue;
            }
            // the largest within the separation; ties go to the first in scan order
            let mut top = true;
            'window: for dr in -r..=r {
                for dc in -r..=r {
                    let (rr, cc) = (row as isize + dr, col as isize + dc);
                    if (dr, dc) == (0, 0) || rr < 0 || cc < 0 || rr >= h as isize || cc >= w as isize {
                        continue;
                    }
                    let u = response[rr as usize * w + cc as usize];
                    let earlier = (dr, dc) < (0, 0);
                    if u > v || (u == v && earlier) {
                        top = false;
                        break 'window;
                    }
                }
            }
            if top {
                peaks.push((v, col, row));
            }
        }
    }
    let reach = ((config.smoothing_m + 2.0 * config.window_m) / cell_m).ceil() as isize;
    let origin = grid.origin();
    let (s, c) = origin.yaw_rad.sin_cos();
    peaks
        .into_iter()
        .filter_map(|(_, col, row)| refine(&gradient, w, h, col, row, reach))
        .map(|[gx, gy]| {
            let (gx, gy) = ((gx - pad as f64) * cell_m, (gy - pad as f64) * cell_m);
            [origin.x_m + c * gx - s * gy, origin.y_m + s * gx + c * gy]
        })
        .collect()
}

/// Harris and Stephens' response of a 0/1 image (row-major, `w` x `h`), and the
/// smoothed image's gradient (x, y) at each cell.
fn harris(image: &[f32], w: usize, h: usize, cell_m: f64, config: &GridCornerConfig) -> (Vec<f32>, Vec<[f32; 2]>) {
    let smooth = blur(image, w, h, config.smoothing_m / cell_m);
    let at = |c: usize, r: usize| smooth[r * w + c];
    let mut xx = vec![0.0f32; w * h];
    let mut yy = vec![0.0f32; w * h];
    let mut xy = vec![0.0f32; w * h];
    let mut gradient = vec![[0.0f32; 2]; w * h];
    for r in 1..h.saturating_sub(1) {
        for c in 1..w.saturating_sub(1) {
            let gx = 0.5 * (at(c + 1, r) - at(c - 1, r));
            let gy = 0.5 * (at(c, r + 1) - at(c, r - 1));
            let i = r * w + c;
            (xx[i], yy[i], xy[i]) = (gx * gx, gy * gy, gx * gy);
            gradient[i] = [gx, gy];
        }
    }
    let sigma = config.window_m / cell_m;
    let (xx, yy, xy) = (blur(&xx, w, h, sigma), blur(&yy, w, h, sigma), blur(&xy, w, h, sigma));
    let k = config.k as f32;
    let response = (0..w * h)
        .map(|i| {
            let trace = xx[i] + yy[i];
            xx[i] * yy[i] - xy[i] * xy[i] - k * trace * trace
        })
        .collect();
    (response, gradient)
}

/// Where the outline's edges near a response peak at `(col, row)` meet, in cells: the
/// point nearest, in the least-squares sense, every edge line through the cells within
/// `radius` (each cell's gradient is the normal of the edge through it). The peak
/// itself lies a cell or two off the corner, inside the smaller of the two regions.
fn refine(gradient: &[[f32; 2]], w: usize, h: usize, col: usize, row: usize, radius: isize) -> Option<[f64; 2]> {
    let (mut a, mut b) = ([0.0f64; 3], [0.0f64; 2]);
    for dr in -radius..=radius {
        for dc in -radius..=radius {
            let (c, r) = (col as isize + dc, row as isize + dr);
            if c < 0 || r < 0 || c >= w as isize || r >= h as isize {
                continue;
            }
            let [gx, gy] = gradient[r as usize * w + c as usize].map(f64::from);
            let (px, py) = (c as f64 + 0.5, r as f64 + 0.5);
            a[0] += gx * gx;
            a[1] += gx * gy;
            a[2] += gy * gy;
            let gp = gx * px + gy * py;
            b[0] += gx * gp;
            b[1] += gy * gp;
        }
    }
    let det = a[0] * a[2] - a[1] * a[1];
    // nearly parallel edges (or none): no point where they meet
    if det.is_nan() || det <= 1e-9 * (a[0] + a[2]).powi(2) {
        return None;
    }
    let x = (a[2] * b[0] - a[1] * b[1]) / det;
    let y = (a[0] * b[1] - a[1] * b[0]) / det;
    // a refinement that runs off is a peak that was no corner
    ((x - col as f64 - 0.5).hypot(y - row as f64 - 0.5) <= radius as f64).then_some([x, y])
}

/// The response at a right-angled corner of free space on a grid of `cell_m`.
fn right_angle_response(cell_m: f64, config: &GridCornerConfig) -> f64 {
    let n = 41;
    let image: Vec<f32> = (0..n * n).map(|i| if i % n < n / 2 || i / n < n / 2 { 1.0 } else { 0.0 }).collect();
    harris(&image, n, n, cell_m, config).0.into_iter().fold(0.0f32, f32::max) as f64
}

/// A Gaussian blur of standard deviation `sigma` cells (separable, clamped at the edges).
fn blur(image: &[f32], w: usize, h: usize, sigma: f64) -> Vec<f32> {
    if sigma <= 0.0 || w == 0 || h == 0 {
        return image.to_vec();
    }
    let radius = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f32> = (-radius..=radius).map(|d| (-(d * d) as f64 / (2.0 * sigma * sigma)).exp() as f32).collect();
    let total: f32 = kernel.iter().sum();
    let kernel: Vec<f32> = kernel.iter().map(|k| k / total).collect();
    let across = blur_pass(image, w, h, &kernel, (1, w));
    blur_pass(&across, w, h, &kernel, (w, h))
}

/// One pass of [`blur`] along rows (`(step, len)` = `(1, w)`) or columns (`(w, h)`).
fn blur_pass(image: &[f32], w: usize, h: usize, kernel: &[f32], (step, len): (usize, usize)) -> Vec<f32> {
    let radius = (kernel.len() / 2) as isize;
    let mut out = vec![0.0f32; w * h];
    for (i, o) in out.iter_mut().enumerate() {
        // this cell's place along the pass, and the index of the pass's first cell
        let at = if step == 1 { i % w } else { i / w };
        let first = i - at * step;
        *o = kernel
            .iter()
            .enumerate()
            .map(|(k, kv)| {
                kv * image[first + (at as isize + k as isize - radius).clamp(0, len as isize - 1) as usize * step]
            })
            .sum();
    }
    out
}

/// The distance from any place on a floor to its nearest corner, looked up in a grid of
/// the map's own cells (a particle's weight for a corner seen is one lookup).
#[derive(Clone, Debug)]
pub struct CornerField {
    /// the corners marked on a grid of the map's geometry, and the distance to them
    marks: Option<(OccupancyGrid, DistanceField)>,
    corners: Vec<[f64; 2]>,
}

impl CornerField {
    /// The field of `corners` over `grid`'s extent.
    pub fn new(grid: &OccupancyGrid, corners: Vec<[f64; 2]>) -> Self {
        let blank = OccupancyGrid::filled(grid.width(), grid.height(), grid.resolution_m(), grid.origin(), Cell::Free);
        let marks = blank.ok().and_then(|mut marks| {
            let mut any = false;
            for c in &corners {
                if let Some((col, row)) = marks.world_to_cell(c[0], c[1]) {
                    any |= marks.set(col, row, Cell::Occupied);
                }
            }
            any.then(|| {
                let field = DistanceField::to_occupied(&marks);
                (marks, field)
            })
        });
        Self { marks, corners }
    }

    /// The corners, map metres.
    pub fn corners(&self) -> &[[f64; 2]] {
        &self.corners
    }

    /// Metres from `(x, y)` to the nearest corner (to a cell's centre); infinite off the
    /// map or with none.
    pub fn distance_m(&self, x_m: f64, y_m: f64) -> f64 {
        let Some((marks, field)) = &self.marks else { return f64::INFINITY };
        marks.world_to_cell(x_m, y_m).and_then(|(c, r)| field.get(c, r)).map_or(f64::INFINITY, f64::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use map::Origin;

    fn wall(from: [f64; 2], to: [f64; 2]) -> WallSegment {
        let angle = (to[1] - from[1]).atan2(to[0] - from[0]);
        WallSegment { from, to, points: 20, rms_m: 0.01, angle_rad: angle }
    }

    #[test]
    fn two_walls_meeting_make_a_corner_where_their_faces_meet() {
        // a corridor's end 3 m ahead, the left wall 1 m to the side; the split between
        // the walls leaves a few centimetres out of each
        let walls = [wall([0.5, 1.0], [2.95, 1.0]), wall([3.0, 0.95], [3.0, -1.0])];
        let c = corners_of_walls(&walls, &CornerConfig::default());
        assert_eq!(c.len(), 1, "{c:?}");
        assert!((c[0][0] - 3.0).abs() < 1e-9 && (c[0][1] - 1.0).abs() < 1e-9, "{c:?}");
    }

    #[test]
    fn parallel_walls_slanted_sides_and_lines_crossing_across_a_gap_are_no_corner() {
        let cfg = CornerConfig::default();
        // a corridor's two walls
        assert!(corners_of_walls(&[wall([0.5, 1.0], [4.0, 1.0]), wall([0.5, -1.0], [4.0, -1.0])], &cfg).is_empty());
        // a wall and a desk side 30 degrees off it, meeting
        let slant = wall([3.0, 1.0], [3.0 + 1.5 * 30f64.to_radians().cos(), 1.0 - 1.5 * 30f64.to_radians().sin()]);
        assert!(corners_of_walls(&[wall([0.5, 1.0], [3.0, 1.0]), slant], &cfg).is_empty());
        // an end wall and a side wall that stops 1 m short of it (a doorway between)
        assert!(corners_of_walls(&[wall([0.5, 1.0], [2.0, 1.0]), wall([3.0, 0.9], [3.0, -1.0])], &cfg).is_empty());
        // a T: the side wall ends on the middle of a long wall: a corner
        let t = corners_of_walls(&[wall([0.5, 1.0], [2.9, 1.0]), wall([3.0, 3.0], [3.0, -1.0])], &cfg);
        assert_eq!(t.len(), 1, "{t:?}");
    }

    /// A grid of 5 cm cells, `w` x `h` metres, not free where `solid` says so.
    fn grid(w: f64, h: f64, solid: impl Fn(f64, f64) -> bool) -> OccupancyGrid {
        let res = 0.05;
        let (cw, ch) = ((w / res).round() as usize, (h / res).round() as usize);
        let cells = (0..cw * ch)
            .map(|i| {
                let (x, y) = (((i % cw) as f64 + 0.5) * res, ((i / cw) as f64 + 0.5) * res);
                if solid(x, y) {
                    Cell::Occupied
                } else {
                    Cell::Free
                }
            })
            .collect();
        OccupancyGrid::new(cw, ch, res, Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, cells).expect("grid")
    }

    fn nearest(found: &[[f64; 2]], p: [f64; 2]) -> f64 {
        found.iter().map(|c| (c[0] - p[0]).hypot(c[1] - p[1])).fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn the_corners_of_an_l_shaped_corridor_are_found_in_its_grid_and_nothing_along_its_walls() {
        // corridor A along x (y 1-3, x 1-10), corridor B along y (x 8-10, y 1-9)
        let g = grid(11.0, 10.0, |x, y| {
            let a = (1.0..10.0).contains(&x) && (1.0..3.0).contains(&y);
            let b = (8.0..10.0).contains(&x) && (1.0..9.0).contains(&y);
            !(a || b)
        });
        let found = corners_of_grid(&g, &GridCornerConfig::default());
        let expected = [[1.0, 1.0], [1.0, 3.0], [10.0, 1.0], [8.0, 3.0], [8.0, 9.0], [10.0, 9.0]];
        for e in expected {
            assert!(nearest(&found, e) < 0.03, "no corner at {e:?}: {found:?}");
        }
        assert_eq!(found.len(), expected.len(), "{found:?}");
    }

    #[test]
    fn a_room_turned_17_degrees_has_four_corners_not_the_steps_of_its_walls() {
        let (s, c) = 17f64.to_radians().sin_cos();
        let centre = [5.0, 5.0];
        // 6 x 3 m, turned
        let g = grid(10.0, 10.0, |x, y| {
            let (dx, dy) = (x - centre[0], y - centre[1]);
            let (u, v) = (c * dx + s * dy, -s * dx + c * dy);
            !(u.abs() < 3.0 && v.abs() < 1.5)
        });
        let found = corners_of_grid(&g, &GridCornerConfig::default());
        for (u, v) in [(-3.0, -1.5), (3.0, -1.5), (3.0, 1.5), (-3.0, 1.5)] {
            let e = [centre[0] + c * u - s * v, centre[1] + s * u + c * v];
            assert!(nearest(&found, e) < 0.05, "no corner at {e:?}: {found:?}");
        }
        assert_eq!(found.len(), 4, "{found:?}");
    }

    #[test]
    fn the_corner_field_gives_the_distance_to_the_nearest_corner() {
        let g = grid(4.0, 4.0, |_, _| false);
        let f = CornerField::new(&g, vec![[1.025, 1.025], [3.025, 1.025]]);
        assert!((f.distance_m(1.025, 2.025) - 1.0).abs() < 1e-6);
        assert!((f.distance_m(2.525, 1.025) - 0.5).abs() < 1e-6);
        assert_eq!(f.distance_m(-1.0, 1.0), f64::INFINITY);
        assert_eq!(CornerField::new(&g, Vec::new()).distance_m(1.0, 1.0), f64::INFINITY);
    }
}
