//! A* over a [`NavGraph`] (ISANA: A* with an L2 heuristic). Exact: the octile distance
//! is the length of the shortest obstacle-free lattice path, so it is admissible and
//! consistent, and the first time the goal is popped its length is optimal.
//!
//! Fast because nothing is hashed or cleared: g, parent and state are flat arrays over
//! the lattice, stamped with a generation number, so a new query only bumps the number
//! (arrays are reset once every 2^32 - 1 queries). Ties in f go to the larger g (the node
//! nearer the goal), which expands far fewer nodes on open floors.

use std::collections::BinaryHeap;
use std::f64::consts::SQRT_2;

use crate::nav_graph::{NavGraph, DIRS};

/// A heap entry packed in one integer so the heap compares one `u128`: from the most
/// significant bits, f (an f64 >= 0, whose bits order as the number), then u32::MAX
/// minus the bits of g as f32 (ties in f go to the larger g), then the vertex. Stored
/// complemented, so std's max-heap pops the smallest f first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Entry(u128);

impl Entry {
    #[inline]
    fn new(f: f64, g: f64, v: u32) -> Self {
        let key = ((f.to_bits() as u128) << 64) | (((u32::MAX - (g as f32).to_bits()) as u128) << 32) | v as u128;
        Entry(!key)
    }

    #[inline]
    fn vertex(self) -> u32 {
        (!self.0) as u32
    }
}

/// Per-vertex search state, together so one cache line serves a vertex.
#[derive(Clone, Copy, Debug, Default)]
struct NodeState {
    g: f64,
    parent: u32,
    /// `2 * generation` once reached in that query, `2 * generation + 1` once expanded
    stamp: u32,
}

/// A reusable A* search: keep one per graph and call [`AStar::search`] per query.
#[derive(Clone, Debug, Default)]
pub struct AStar {
    nodes: Vec<NodeState>,
    generation: u32,
    heap: BinaryHeap<Entry>,
    /// vertices expanded by the last search
    expanded: usize,
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
        if self.nodes.len() != n || self.generation >= u32::MAX / 2 - 1 {
            self.nodes = vec![NodeState::default(); n];
            self.generation = 0;
        }
        self.generation += 1;
        self.heap.clear();
        self.expanded = 0;
    }

    /// The shortest open path from `start` to `goal`: its length in metres, with the
    /// vertices (start first) written to `path`. `None` when the goal cannot be reached
    /// or either end is not an open vertex.
    ///
    /// With a consistent heuristic a popped vertex already has its optimal g: it is
    /// stamped closed, and any older (longer) heap entry for it is skipped when popped.
    pub fn search(&mut self, graph: &NavGraph, start: u32, goal: u32, path: &mut Vec<u32>) -> Option<f64> {
        path.clear();
        if !graph.is_open(start) || !graph.is_open(goal) {
            return None;
        }
        self.begin(graph.lattice_len());
        let (open, closed) = (2 * self.generation, 2 * self.generation + 1);
        let cols = graph.cols();
        let spacing = graph.spacing_m();
        let diag = spacing * SQRT_2;
        let (gi, gj) = ((goal as usize % cols) as i32, (goal as usize / cols) as i32);
        let h = |i: i32, j: i32| -> f64 {
            let (dx, dy) = ((i - gi).abs(), (j - gj).abs());
            let (lo, hi) = if dx < dy { (dx, dy) } else { (dy, dx) };
            spacing * (hi - lo) as f64 + diag * lo as f64
        };
        let offsets: [isize; 8] = std::array::from_fn(|d| graph.offset(d));
        let step_len: [f64; 8] = std::array::from_fn(|d| if d & 1 == 0 { spacing } else { diag });
        let nodes = &mut self.nodes[..];
        nodes[start as usize] = NodeState { g: 0.0, parent: u32::MAX, stamp: open };
        let (si, sj) = ((start as usize % cols) as i32, (start as usize / cols) as i32);
        self.heap.push(Entry::new(h(si, sj), 0.0, start));
        while let Some(entry) = self.heap.pop() {
            let v = entry.vertex();
            let vi = v as usize;
            if nodes[vi].stamp == closed {
                continue; // stale: v was expanded through a shorter entry
            }
            nodes[vi].stamp = closed;
            self.expanded += 1;
            let g = nodes[vi].g;
            if v == goal {
                let mut cur = goal;
                while cur != u32::MAX {
                    path.push(cur);
                    cur = nodes[cur as usize].parent;
                }
                path.reverse();
                return Some(g);
            }
            let (i, j) = ((vi % cols) as i32, (vi / cols) as i32);
            let mut mask = graph.open_mask(v);
            while mask != 0 {
                let d = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let n = (vi as isize + offsets[d]) as usize;
                let ng = g + step_len[d];
                let node = &mut nodes[n];
                if node.stamp == closed || (node.stamp == open && ng >= node.g) {
                    continue;
                }
                *node = NodeState { g: ng, parent: v, stamp: open };
                let (dx, dy) = DIRS[d];
                self.heap.push(Entry::new(ng + h(i + dx, j + dy), ng, n as u32));
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
