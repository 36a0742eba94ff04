//! Distance to the nearest obstacle: an exact Euclidean distance transform
//! (Felzenszwalb & Huttenlocher 2012, "Distance Transforms of Sampled Functions": the
//! lower envelope of parabolas, one pass over columns then one over rows, O(cells)),
//! the distance field localization's likelihood field reads (AMCL's `max_distance`),
//! and inflation by the user's preferred distance to walls (ISANA's free-space margin).

use crate::grid::{Cell, OccupancyGrid};

/// Squared distance, in cells, standing for "no obstacle on this line yet".
const FAR: f64 = 1e20;

/// Metres from each cell centre to the nearest obstacle cell centre.
#[derive(Clone, Debug, PartialEq)]
pub struct DistanceField {
    width: usize,
    height: usize,
    resolution_m: f64,
    distance_m: Vec<f32>,
}

impl DistanceField {
    /// Distance to the nearest [`Cell::Occupied`] cell (what a range sensor sees; the
    /// likelihood field's input). `f32::INFINITY` everywhere when nothing is occupied.
    pub fn to_occupied(grid: &OccupancyGrid) -> Self {
        Self::to_cells(grid, |c| c == Cell::Occupied)
    }

    /// Distance to the nearest cell that is not [`Cell::Free`] (occupied or unknown):
    /// where a blind user must not be guided, so what inflation measures from.
    pub fn to_non_free(grid: &OccupancyGrid) -> Self {
        Self::to_cells(grid, |c| c != Cell::Free)
    }

    /// Distance to the nearest cell for which `is_obstacle` holds.
    pub fn to_cells(grid: &OccupancyGrid, is_obstacle: impl Fn(Cell) -> bool) -> Self {
        let (w, h) = (grid.width(), grid.height());
        let mut sq: Vec<f64> = grid.cells().iter().map(|&c| if is_obstacle(c) { 0.0 } else { FAR }).collect();
        let mut scratch = Scratch::new(w.max(h));
        // columns (y), then rows (x): separable, exact
        let mut column = vec![0.0; h];
        for x in 0..w {
            for y in 0..h {
                column[y] = sq[y * w + x];
            }
            scratch.transform(&mut column);
            for y in 0..h {
                sq[y * w + x] = column[y];
            }
        }
        for row in sq.chunks_exact_mut(w) {
            scratch.transform(row);
        }
        let res = grid.resolution_m();
        let distance_m =
            sq.iter().map(|&d| if d >= FAR * 0.5 { f32::INFINITY } else { (d.sqrt() * res) as f32 }).collect();
        Self { width: w, height: h, resolution_m: res, distance_m }
    }

    /// Width in cells (as the grid's).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in cells (as the grid's).
    pub fn height(&self) -> usize {
        self.height
    }

    /// Metres per cell (as the grid's).
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// Metres to the nearest obstacle at (col, row); `None` outside the grid.
    pub fn get(&self, col: usize, row: usize) -> Option<f32> {
        (col < self.width && row < self.height).then(|| self.distance_m[row * self.width + col])
    }

    /// All distances, row-major, row 0 at the bottom (as the grid's cells).
    pub fn distances_m(&self) -> &[f32] {
        &self.distance_m
    }
}

/// Buffers for the 1-D transform, reused across lines.
struct Scratch {
    v: Vec<usize>,
    z: Vec<f64>,
    d: Vec<f64>,
}

impl Scratch {
    fn new(n: usize) -> Self {
        Self { v: vec![0; n], z: vec![0.0; n + 1], d: vec![0.0; n] }
    }

    /// In place: f[q] <- min_p (q - p)^2 + f[p].
    fn transform(&mut self, f: &mut [f64]) {
        let n = f.len();
        let (v, z, d) = (&mut self.v, &mut self.z, &mut self.d);
        let mut k = 0usize;
        v[0] = 0;
        z[0] = f64::NEG_INFINITY;
        z[1] = f64::INFINITY;
        for q in 1..n {
            let fq = f[q] + (q * q) as f64;
            loop {
                let p = v[k];
                let s = (fq - (f[p] + (p * p) as f64)) / (2.0 * (q - p) as f64);
                // z[0] is -inf, so k > 0 whenever s <= z[k]; the guard only keeps it panic-free
                if k > 0 && s <= z[k] {
                    k -= 1;
                    continue;
                }
                k += 1;
                v[k] = q;
                z[k] = s;
                z[k + 1] = f64::INFINITY;
                break;
            }
        }
        k = 0;
        for (q, dq_out) in d[..n].iter_mut().enumerate() {
            while z[k + 1] < q as f64 {
                k += 1;
            }
            let p = v[k];
            let dq = q as f64 - p as f64;
            *dq_out = dq * dq + f[p];
        }
        f.copy_from_slice(&d[..n]);
    }
}

/// The grid with every free cell closer than `radius_m` (centre to centre) to a
/// non-free cell made occupied: where a user who keeps `radius_m` from walls and from
/// unmapped space can stand. Unknown cells stay unknown.
pub fn inflate(grid: &OccupancyGrid, radius_m: f64) -> OccupancyGrid {
    inflate_with(grid, &DistanceField::to_non_free(grid), radius_m)
}

/// [`inflate`] with a distance field already computed for this grid.
pub fn inflate_with(grid: &OccupancyGrid, field: &DistanceField, radius_m: f64) -> OccupancyGrid {
    let r = radius_m as f32;
    let cells = grid
        .cells()
        .iter()
        .zip(field.distances_m())
        .map(|(&c, &d)| if c == Cell::Free && d < r { Cell::Occupied } else { c })
        .collect();
    grid.with_cells(cells)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Origin;

    fn grid(w: usize, h: usize, occupied: &[(usize, usize)]) -> OccupancyGrid {
        let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        let mut g = OccupancyGrid::filled(w, h, 0.1, o, Cell::Free).unwrap();
        for &(c, r) in occupied {
            g.set(c, r, Cell::Occupied);
        }
        g
    }

    fn brute(g: &OccupancyGrid, c: usize, r: usize) -> f32 {
        let mut best = f64::INFINITY;
        for rr in 0..g.height() {
            for cc in 0..g.width() {
                if g.get(cc, rr) == Some(Cell::Occupied) {
                    let d = ((cc as f64 - c as f64).powi(2) + (rr as f64 - r as f64).powi(2)).sqrt();
                    best = best.min(d);
                }
            }
        }
        (best * g.resolution_m()) as f32
    }

    #[test]
    fn transform_matches_brute_force_on_scattered_obstacles() {
        // a fixed pseudo-random scatter (LCG) so the test is deterministic
        let mut seed = 12345u64;
        let mut occ = vec![];
        for _ in 0..40 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            occ.push(((seed >> 33) as usize % 37, (seed >> 17) as usize % 23));
        }
        let g = grid(37, 23, &occ);
        let f = DistanceField::to_occupied(&g);
        for r in 0..23 {
            for c in 0..37 {
                assert!((f.get(c, r).unwrap() - brute(&g, c, r)).abs() < 1e-5, "cell {c},{r}");
            }
        }
    }

    #[test]
    fn single_obstacle_gives_exact_distances() {
        let g = grid(10, 10, &[(2, 3)]);
        let f = DistanceField::to_occupied(&g);
        assert_eq!(f.get(2, 3), Some(0.0));
        assert!((f.get(5, 7).unwrap() - 0.5).abs() < 1e-6); // 3-4-5 triangle, 0.1 m cells
        assert!((f.get(9, 3).unwrap() - 0.7).abs() < 1e-6);
    }

    #[test]
    fn no_obstacle_is_infinitely_far() {
        let f = DistanceField::to_occupied(&grid(4, 3, &[]));
        assert!(f.distances_m().iter().all(|d| d.is_infinite()));
    }

    #[test]
    fn inflation_occupies_exactly_the_cells_within_the_radius() {
        let g = grid(21, 21, &[(10, 10)]);
        // radius 0.25 m = 2.5 cells: cells with distance < 2.5 cells become occupied
        let inflated = inflate(&g, 0.25);
        let n = inflated.count(Cell::Occupied);
        let expected =
            (0..21).flat_map(|r| (0..21).map(move |c| (c, r))).filter(|&(c, r)| brute(&g, c, r) < 0.25).count();
        assert_eq!(n, expected);
        assert_eq!(n, 21); // 1 + 4 (d=1) + 4 (sqrt2) + 4 (2) + 8 (sqrt5)
        assert_eq!(inflated.get(12, 10), Some(Cell::Occupied));
        assert_eq!(inflated.get(13, 10), Some(Cell::Free));
    }

    #[test]
    fn inflation_keeps_away_from_unknown_space() {
        let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        let mut g = OccupancyGrid::filled(5, 1, 1.0, o, Cell::Free).unwrap();
        g.set(0, 0, Cell::Unknown);
        let inflated = inflate(&g, 1.5);
        assert_eq!(inflated.cells(), &[Cell::Unknown, Cell::Occupied, Cell::Free, Cell::Free, Cell::Free]);
    }
}
