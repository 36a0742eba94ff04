//! A* over a [`NavGraph`] (ISANA: A* with an L2 heuristic). Exact: the octile distance
//! is the length of the shortest obstacle-free lattice path, so it is admissible and
//! consistent, and the first time the goal is popped its length is optimal.
//!
//! Fast because nothing is hashed or cleared: g, parent and state are flat arrays over
//! the lattice, stamped with a generation number, so a new query only bumps the number
//! (arrays are reset once every 2^32 - 1 queries). Ties in f go to the larger g (the node
//! nearer the goal), which expands far fewer nodes on open floors.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f64::consts::SQRT_2;

use crate::nav_graph::NavGraph;

#[derive(Clone, Copy)]
struct Entry {
    f: f64,
    g: f64,
    v: u32,
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    /// Max-heap order: smallest f first, then largest g.
    fn cmp(&self, o: &Self) -> Ordering {
        o.f.total_cmp(&self.f).then(self.g.total_cmp(&o.g))
    }
}

/// A reusable A* search: keep one per graph and call [`AStar::search`] per query.
#[derive(Clone, Debug, Default)]
pub struct AStar {
    g: Vec<f64>,
    parent: Vec<u32>,
    /// generation in which g/parent were set
    seen: Vec<u32>,
    /// generation in which the vertex was closed
    closed: Vec<u32>,
    generation: u32,
    heap: BinaryHeap<Entry>,
    /// vertices expanded by the last search
    expanded: usize,
}

impl std::fmt::Debug for Entry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "({}, {}, {})", self.v, self.f, self.g)
    }
}

impl AStar {
    /// An empty search; its arrays grow to the graph on the first query.
    pub fn new() -> Self {
        Self::default()
    }

    /// How many vertices the last search expanded.
    pub fn expanded(&self) -> usize {
        self.expanded
    }

    fn begin(&mut self, n: usize) {
        if self.g.len() != n {
            self.g = vec![0.0; n];
            self.parent = vec![u32::MAX; n];
            self.seen = vec![0; n];
            self.closed = vec![0; n];
            self.generation = 0;
        }
        if self.generation == u32::MAX {
            self.seen.fill(0);
            self.closed.fill(0);
            self.generation = 0;
        }
        self.generation += 1;
        self.heap.clear();
        self.expanded = 0;
    }

    /// The shortest open path from `start` to `goal`: its length in metres, with the
    /// vertices (start first) written to `path`. `None` when the goal cannot be reached
    /// or either end is not an open vertex.
    pub fn search(&mut self, graph: &NavGraph, start: u32, goal: u32, path: &mut Vec<u32>) -> Option<f64> {
        path.clear();
        if !graph.is_open(start) || !graph.is_open(goal) {
            return None;
        }
        self.begin(graph.lattice_len());
        let gen = self.generation;
        let cols = graph.cols() as i64;
        let spacing = graph.spacing_m();
        let diag = spacing * SQRT_2;
        let (gi, gj) = ((goal as i64 % cols), (goal as i64 / cols));
        let h = |v: u32| -> f64 {
            let (i, j) = (v as i64 % cols, v as i64 / cols);
            let (dx, dy) = ((i - gi).abs() as f64, (j - gj).abs() as f64);
            let (lo, hi) = if dx < dy { (dx, dy) } else { (dy, dx) };
            spacing * (hi - lo) + diag * lo
        };
        let offsets: [isize; 8] = std::array::from_fn(|d| graph.offset(d));
        self.g[start as usize] = 0.0;
        self.parent[start as usize] = u32::MAX;
        self.seen[start as usize] = gen;
        self.heap.push(Entry { f: h(start), g: 0.0, v: start });
        while let Some(Entry { g, v, .. }) = self.heap.pop() {
            let vi = v as usize;
            if self.closed[vi] == gen {
                continue;
            }
            self.closed[vi] = gen;
            self.expanded += 1;
            if v == goal {
                let mut cur = goal;
                while cur != u32::MAX {
                    path.push(cur);
                    cur = self.parent[cur as usize];
                }
                path.reverse();
                return Some(g);
            }
            let mut mask = graph.edge_mask(v);
            while mask != 0 {
                let d = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if !graph.step_open(v, d) {
                    continue;
                }
                let n = (vi as isize + offsets[d]) as usize;
                if self.closed[n] == gen {
                    continue;
                }
                let ng = g + if d & 1 == 0 { spacing } else { diag };
                if self.seen[n] != gen || ng < self.g[n] {
                    self.seen[n] = gen;
                    self.g[n] = ng;
                    self.parent[n] = v;
                    self.heap.push(Entry { f: ng + h(n as u32), g: ng, v: n as u32 });
                }
            }
        }
        None
    }
}

/// Octile distance between two lattice points, in lattice steps.
pub fn octile(di: f64, dj: f64) -> f64 {
    let (dx, dy) = (di.abs(), dj.abs());
    let (lo, hi) = if dx < dy { (dx, dy) } else { (dy, dx) };
    hi - lo + SQRT_2 * lo
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nav_graph::NavGraphConfig;
    use map::{Cell, OccupancyGrid, Origin};

    fn grid(rows: &[&str]) -> OccupancyGrid {
        // rows given top first, like a picture; '#' occupied
        let (w, h) = (rows[0].len(), rows.len());
        let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        let mut g = OccupancyGrid::filled(w, h, 1.0, o, Cell::Free).unwrap();
        for (k, row) in rows.iter().enumerate() {
            for (c, ch) in row.chars().enumerate() {
                if ch == '#' {
                    g.set(c, h - 1 - k, Cell::Occupied);
                }
            }
        }
        g
    }

    fn graph(rows: &[&str]) -> NavGraph {
        NavGraph::build(&grid(rows), &NavGraphConfig { spacing_m: 1.0, clearance_m: 0.0 })
    }

    #[test]
    fn open_floor_path_is_octile_length() {
        let g = graph(&[".........."; 6]);
        let (s, t) = (g.vertex_at(0, 0).unwrap(), g.vertex_at(9, 5).unwrap());
        let mut path = vec![];
        let len = AStar::new().search(&g, s, t, &mut path).unwrap();
        assert!((len - (4.0 + 5.0 * SQRT_2)).abs() < 1e-12);
        assert_eq!(path.len(), 10);
        assert_eq!((path[0], *path.last().unwrap()), (s, t));
    }

    #[test]
    fn wall_with_a_gap_forces_the_detour_without_cutting_corners() {
        let g = graph(&["..#..", "..#..", ".....", "..#.."]);
        // from top-left (0, 3) to top-right (4, 3): down through the gap at row 1 (y = 1)
        let (s, t) = (g.vertex_at(0, 3).unwrap(), g.vertex_at(4, 3).unwrap());
        let mut path = vec![];
        let len = AStar::new().search(&g, s, t, &mut path).unwrap();
        // (0,3) -> (1,2) diag, (1,2)->(1,1)? no: must enter (2,1) orthogonally from (1,1)
        // (0,3)-(1,2) d, (1,2)-(1,1) o, (1,1)-(2,1) o, (2,1)-(3,1) o, (3,1)-(3,2) o, (3,2)-(4,3) d
        assert!((len - (4.0 + 2.0 * SQRT_2)).abs() < 1e-12, "{len}");
        assert!(path.contains(&g.vertex_at(2, 1).unwrap()));
    }

    #[test]
    fn unreachable_goal_is_none_and_search_is_reusable() {
        let g = graph(&["..#..", "..#..", "..#.."]);
        let mut a = AStar::new();
        let mut path = vec![];
        assert_eq!(a.search(&g, g.vertex_at(0, 0).unwrap(), g.vertex_at(4, 0).unwrap(), &mut path), None);
        assert!(path.is_empty());
        let len = a.search(&g, g.vertex_at(0, 0).unwrap(), g.vertex_at(1, 2).unwrap(), &mut path).unwrap();
        assert!((len - (1.0 + SQRT_2)).abs() < 1e-12);
    }

    #[test]
    fn octile_counts_diagonals_as_root_two() {
        assert!((octile(3.0, -5.0) - (2.0 + 3.0 * SQRT_2)).abs() < 1e-12);
    }
}
