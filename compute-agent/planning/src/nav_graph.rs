//! The navigation graph (ISANA, "navigation graph"): a vertex every `spacing_m` where the
//! floor is free after inflation by the user's distance to walls, 8-connected, with no
//! corner cutting (a diagonal edge needs both orthogonal neighbours to be vertices, and
//! every grid cell its thick line touches to be free).
//!
//! Vertices live on a regular lattice laid over the grid and are indexed by their
//! lattice index, so A* works on flat arrays with no hashing and a neighbour is an
//! offset. Obstacles seen at run time block vertices (a counter per vertex, so
//! overlapping obstacles restore correctly) without rebuilding anything.

use map::{Cell, DistanceField, OccupancyGrid};

/// How the graph is laid out.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct NavGraphConfig {
    /// distance between neighbouring vertices, metres (ISANA: 20 cm); rounded to whole grid cells
    pub spacing_m: f64,
    /// the user's distance to walls and unmapped space, metres: free cells closer than
    /// this are not walkable (default 0.3: half a shoulder width, 0.25 m, plus 5 cm)
    pub clearance_m: f64,
}

impl Default for NavGraphConfig {
    fn default() -> Self {
        Self { spacing_m: 0.2, clearance_m: 0.3 }
    }
}

/// Lattice directions: even are orthogonal, odd diagonal; `(dx, dy)` in lattice steps.
pub(crate) const DIRS: [(i32, i32); 8] = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)];

/// The graph over one floor.
#[derive(Clone, Debug)]
pub struct NavGraph {
    cols: usize,
    rows: usize,
    step_cells: usize,
    spacing_m: f64,
    /// bit d set: the static edge in direction `DIRS[d]` exists
    edges: Vec<u8>,
    /// the static edges still open now (obstacles applied), what A* reads
    open: Vec<u8>,
    /// static vertex (free after inflation)
    vertex: Vec<bool>,
    /// how many obstacles block each vertex now
    blocked: Vec<u16>,
    /// neighbour index offsets per direction
    offsets: [isize; 8],
    vertex_count: usize,
    /// the map as loaded (occupied walls), for snapping checks
    raw: OccupancyGrid,
    /// the map after inflation, for line of sight
    inflated: OccupancyGrid,
}

impl NavGraph {
    /// Builds the graph: inflation (one exact distance transform), vertices on the
    /// lattice, then each vertex's edges.
    pub fn build(grid: &OccupancyGrid, config: &NavGraphConfig) -> Self {
        let field = DistanceField::to_non_free(grid);
        let inflated = map::distance::inflate_with(grid, &field, config.clearance_m.max(0.0));
        let res = grid.resolution_m();
        let step = if config.spacing_m.is_finite() { (config.spacing_m / res).round().max(1.0) as usize } else { 1 };
        let (cols, rows) = (grid.width().div_ceil(step), grid.height().div_ceil(step));
        let mut g = Self {
            cols,
            rows,
            step_cells: step,
            spacing_m: step as f64 * res,
            edges: vec![0; cols * rows],
            open: vec![0; cols * rows],
            vertex: vec![false; cols * rows],
            blocked: vec![0; cols * rows],
            offsets: [0; 8],
            vertex_count: 0,
            raw: grid.clone(),
            inflated,
        };
        for (d, (dx, dy)) in DIRS.iter().enumerate() {
            g.offsets[d] = *dy as isize * cols as isize + *dx as isize;
        }
        let free = |c: usize, r: usize| g.inflated.get(c, r) == Some(Cell::Free);
        let mut vertex_count = 0;
        for j in 0..rows {
            for i in 0..cols {
                let (c, r) = g.lattice_cell(i, j);
                let v = free(c, r);
                g.vertex[j * cols + i] = v;
                vertex_count += usize::from(v);
            }
        }
        g.vertex_count = vertex_count;
        // edges E (0), NE (1), N (2), NW (3) decided once, mirrored to W, SW, S, SE
        let mut edges = vec![0u8; cols * rows];
        for j in 0..rows {
            for i in 0..cols {
                let a = j * cols + i;
                if !g.vertex[a] {
                    continue;
                }
                for (d, &(dx, dy)) in DIRS.iter().enumerate().take(4) {
                    let (ni, nj) = (i as i64 + dx as i64, j as i64 + dy as i64);
                    if ni < 0 || nj < 0 || ni >= cols as i64 || nj >= rows as i64 {
                        continue;
                    }
                    let b = nj as usize * cols + ni as usize;
                    if !g.vertex[b] {
                        continue;
                    }
                    let ok = if d % 2 == 0 {
                        g.straight_clear(i, j, dx, dy)
                    } else {
                        // no corner cutting: both orthogonal neighbours are vertices with edges
                        let (ox, oy) = (j * cols + ni as usize, nj as usize * cols + i);
                        g.vertex[ox]
                            && g.vertex[oy]
                            && g.straight_clear(i, j, dx, 0)
                            && g.straight_clear(i, j, 0, dy)
                            && g.diagonal_clear(i, j, dx, dy)
                    };
                    if ok {
                        edges[a] |= 1 << d;
                        edges[b] |= 1 << (d + 4);
                    }
                }
            }
        }
        g.open = edges.clone();
        g.edges = edges;
        g
    }

    /// Grid cell of lattice point (i, j).
    fn lattice_cell(&self, i: usize, j: usize) -> (usize, usize) {
        let off = self.step_cells / 2;
        let c = (i * self.step_cells + off).min(self.inflated.width() - 1);
        let r = (j * self.step_cells + off).min(self.inflated.height() - 1);
        (c, r)
    }

    /// Every grid cell between lattice point (i, j) and its orthogonal neighbour is free.
    fn straight_clear(&self, i: usize, j: usize, dx: i32, dy: i32) -> bool {
        let (c, r) = self.lattice_cell(i, j);
        let (nc, nr) = self.lattice_cell((i as i64 + dx as i64) as usize, (j as i64 + dy as i64) as usize);
        let (c0, c1) = (c.min(nc), c.max(nc));
        let (r0, r1) = (r.min(nr), r.max(nr));
        (r0..=r1).all(|rr| (c0..=c1).all(|cc| self.inflated.get(cc, rr) == Some(Cell::Free)))
    }

    /// The thick diagonal between lattice point (i, j) and (i+dx, j+dy): each cell on it
    /// and the two cells beside each corner it crosses are free.
    fn diagonal_clear(&self, i: usize, j: usize, dx: i32, dy: i32) -> bool {
        let (c, r) = self.lattice_cell(i, j);
        let (nc, nr) = self.lattice_cell((i as i64 + dx as i64) as usize, (j as i64 + dy as i64) as usize);
        let n = (nc as i64 - c as i64).abs().min((nr as i64 - r as i64).abs());
        let free =
            |cc: i64, rr: i64| cc >= 0 && rr >= 0 && self.inflated.get(cc as usize, rr as usize) == Some(Cell::Free);
        (0..n).all(|k| {
            let (x, y) = (c as i64 + k * dx as i64, r as i64 + k * dy as i64);
            free(x, y) && free(x + dx as i64, y) && free(x, y + dy as i64)
        })
    }

    /// Lattice columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Lattice rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Metres between orthogonal neighbours (the configured spacing rounded to cells).
    pub fn spacing_m(&self) -> f64 {
        self.spacing_m
    }

    /// How many vertices (free lattice points) the graph has, blocked or not.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// How many undirected edges the graph has (static, ignoring obstacles).
    pub fn edge_count(&self) -> usize {
        self.edges.iter().map(|e| e.count_ones() as usize).sum::<usize>() / 2
    }

    /// Size of the lattice: vertex ids are below this.
    pub fn lattice_len(&self) -> usize {
        self.cols * self.rows
    }

    /// The map as given, before inflation.
    pub fn grid(&self) -> &OccupancyGrid {
        &self.raw
    }

    /// The map after inflation: free cells are where the user may walk.
    pub fn inflated(&self) -> &OccupancyGrid {
        &self.inflated
    }

    /// Vertex id of lattice point (i, j), if it is a vertex.
    pub fn vertex_at(&self, i: usize, j: usize) -> Option<u32> {
        (i < self.cols && j < self.rows && self.vertex[j * self.cols + i]).then(|| (j * self.cols + i) as u32)
    }

    /// Lattice point (i, j) of a vertex id.
    pub fn lattice_of(&self, v: u32) -> (usize, usize) {
        (v as usize % self.cols, v as usize / self.cols)
    }

    /// True when `v` is a vertex and no obstacle blocks it now.
    pub fn is_open(&self, v: u32) -> bool {
        let v = v as usize;
        v < self.vertex.len() && self.vertex[v] && self.blocked[v] == 0
    }

    /// Map-frame position of a vertex (its grid cell's centre), metres.
    pub fn position(&self, v: u32) -> [f64; 2] {
        let (i, j) = self.lattice_of(v);
        let (c, r) = self.lattice_cell(i, j);
        let (x, y) = self.inflated.cell_center(c, r);
        [x, y]
    }

    /// Continuous lattice coordinates of a map point.
    pub(crate) fn to_lattice(&self, x: f64, y: f64) -> (f64, f64) {
        let (gx, gy) = self.inflated.world_to_grid(x, y);
        let off = (self.step_cells / 2) as f64 + 0.5;
        ((gx - off) / self.step_cells as f64, (gy - off) / self.step_cells as f64)
    }

    /// The open neighbours of `v` with their edge lengths (metres), obstacles honoured.
    pub fn neighbours(&self, v: u32) -> impl Iterator<Item = (u32, f64)> + '_ {
        let mask = self.open.get(v as usize).copied().unwrap_or(0);
        (0..8).filter(move |d| mask & (1 << d) != 0).map(move |d| {
            let len = if d & 1 == 0 { self.spacing_m } else { self.spacing_m * SQRT_2 };
            ((v as isize + self.offsets[d]) as u32, len)
        })
    }

    /// The edges of `v` open now (bit d: direction `DIRS[d]`): static edges whose target
    /// is unblocked and, for a diagonal, whose two orthogonal neighbours are too; 0 when
    /// `v` itself is blocked.
    #[inline]
    pub(crate) fn open_mask(&self, v: u32) -> u8 {
        self.open[v as usize]
    }

    /// Neighbour index offset of direction `d`.
    #[inline]
    pub(crate) fn offset(&self, d: usize) -> isize {
        self.offsets[d]
    }

    /// Recomputes the open mask of `v` from the static edges and the blocks.
    fn refresh(&mut self, v: usize) {
        if !self.vertex[v] {
            return;
        }
        if self.blocked[v] != 0 {
            self.open[v] = 0;
            return;
        }
        let free = |k: isize| self.blocked[(v as isize + k) as usize] == 0;
        let mut mask = self.edges[v];
        let mut bits = mask;
        while bits != 0 {
            let d = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let ok =
                free(self.offsets[d]) && (d & 1 == 0 || (free(self.offsets[d - 1]) && free(self.offsets[(d + 1) % 8])));
            if !ok {
                mask &= !(1 << d);
            }
        }
        self.open[v] = mask;
    }

    /// Recomputes the open masks of `v` and every vertex whose edges it can close.
    fn refresh_around(&mut self, v: u32) {
        let (i, j) = self.lattice_of(v);
        for nj in j.saturating_sub(1)..=(j + 1).min(self.rows - 1) {
            for ni in i.saturating_sub(1)..=(i + 1).min(self.cols - 1) {
                self.refresh(nj * self.cols + ni);
            }
        }
    }

    /// Blocks `v` once more (an obstacle covers it).
    pub(crate) fn block(&mut self, v: u32) {
        let b = &mut self.blocked[v as usize];
        *b = b.saturating_add(1);
        if *b == 1 {
            self.refresh_around(v);
        }
    }

    /// Releases one block of `v`.
    pub(crate) fn unblock(&mut self, v: u32) {
        let b = &mut self.blocked[v as usize];
        if *b == 1 {
            *b = 0;
            self.refresh_around(v);
        } else {
            *b = b.saturating_sub(1);
        }
    }

    /// The vertices (blocked or not) within `radius_m` of map point (x, y).
    pub fn vertices_within(&self, x: f64, y: f64, radius_m: f64) -> Vec<u32> {
        let mut out = Vec::new();
        self.for_each_within(x, y, radius_m, |v, _| out.push(v));
        out
    }

    /// Calls `f(v, distance_m)` for every vertex within `radius_m` of (x, y): a window of
    /// the lattice, so the cost depends on the radius, never on the map or route size.
    pub(crate) fn for_each_within(&self, x: f64, y: f64, radius_m: f64, mut f: impl FnMut(u32, f64)) {
        if !(x.is_finite() && y.is_finite() && radius_m >= 0.0) {
            return;
        }
        let (li, lj) = self.to_lattice(x, y);
        let reach = radius_m / self.spacing_m + 1.0;
        let i0 = (li - reach).floor().max(0.0) as usize;
        let j0 = (lj - reach).floor().max(0.0) as usize;
        let i1 = ((li + reach).ceil().max(-1.0) as i64).min(self.cols as i64 - 1);
        let j1 = ((lj + reach).ceil().max(-1.0) as i64).min(self.rows as i64 - 1);
        if i1 < 0 || j1 < 0 {
            return;
        }
        for j in j0..=j1 as usize {
            for i in i0..=i1 as usize {
                let v = (j * self.cols + i) as u32;
                if !self.vertex[v as usize] {
                    continue;
                }
                let p = self.position(v);
                let d = (p[0] - x).hypot(p[1] - y);
                if d <= radius_m {
                    f(v, d);
                }
            }
        }
    }
}

use std::f64::consts::SQRT_2;

#[cfg(test)]
mod tests {
    use super::*;
    use map::Origin;

    /// A 2 x 1 m room at 5 cm with a 5 cm wall around it.
    fn room() -> OccupancyGrid {
        let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        let mut g = OccupancyGrid::filled(40, 20, 0.05, o, Cell::Free).unwrap();
        for c in 0..40 {
            g.set(c, 0, Cell::Occupied);
            g.set(c, 19, Cell::Occupied);
        }
        for r in 0..20 {
            g.set(0, r, Cell::Occupied);
            g.set(39, r, Cell::Occupied);
        }
        g
    }

    #[test]
    fn vertices_every_20_cm_where_free_after_inflation() {
        let g = NavGraph::build(&room(), &NavGraphConfig { spacing_m: 0.2, clearance_m: 0.2 });
        assert_eq!((g.cols(), g.rows()), (10, 5));
        assert_eq!(g.spacing_m(), 0.2);
        // lattice cells 2, 6, ..., 38 (x) and 2, 6, 10, 14, 18 (y); walls at 0 and 39 / 19;
        // inflation 0.2 m = 4 cells: free cells are 4..=35 and 4..=15
        // -> columns 6..=34 (8 of them) and rows 6, 10, 14 (3 of them)
        assert_eq!(g.vertex_count(), 8 * 3);
        // 8-connected grid of 8 x 3: 7*3 + 8*2 orthogonal + 2 * 7*2 diagonal
        assert_eq!(g.edge_count(), 21 + 16 + 28);
        let v = g.vertex_at(1, 1).unwrap();
        let [x, y] = g.position(v);
        assert!((x - 0.325).abs() < 1e-9 && (y - 0.325).abs() < 1e-9, "{x} {y}");
    }

    #[test]
    fn diagonal_needs_both_orthogonal_neighbours() {
        // 3 x 3 cells at 1 m, spacing 1 m, no clearance: block the east cell
        let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        let mut grid = OccupancyGrid::filled(3, 3, 1.0, o, Cell::Free).unwrap();
        grid.set(1, 0, Cell::Occupied);
        let g = NavGraph::build(&grid, &NavGraphConfig { spacing_m: 1.0, clearance_m: 0.0 });
        let origin = g.vertex_at(0, 0).unwrap();
        let ne = g.vertex_at(1, 1).unwrap();
        assert!(g.neighbours(origin).all(|(n, _)| n != ne), "cut the corner past (1, 0)");
        let up = g.vertex_at(0, 1).unwrap();
        let n: Vec<(u32, f64)> = g.neighbours(up).collect();
        assert!(n.contains(&(g.vertex_at(1, 2).unwrap(), SQRT_2)));
        assert!(n.contains(&(ne, 1.0)));
    }

    #[test]
    fn blocking_a_vertex_closes_its_edges_and_the_diagonals_beside_it() {
        let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        let grid = OccupancyGrid::filled(3, 3, 1.0, o, Cell::Free).unwrap();
        let mut g = NavGraph::build(&grid, &NavGraphConfig { spacing_m: 1.0, clearance_m: 0.0 });
        let (a, e, ne) = (g.vertex_at(0, 0).unwrap(), g.vertex_at(1, 0).unwrap(), g.vertex_at(1, 1).unwrap());
        assert_eq!(g.neighbours(a).count(), 3);
        g.block(e);
        g.block(e);
        assert!(!g.is_open(e));
        let n: Vec<u32> = g.neighbours(a).map(|(n, _)| n).collect();
        assert_eq!(n, vec![g.vertex_at(0, 1).unwrap()]);
        assert!(!n.contains(&ne));
        g.unblock(e);
        assert!(!g.is_open(e), "two obstacles, one gone");
        g.unblock(e);
        assert_eq!(g.neighbours(a).count(), 3);
    }
}
