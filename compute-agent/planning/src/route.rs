//! A planned route on one floor and deviation recovery (ISANA, "deviation recovery":
//! O(1), with the remaining length cached per route node).
//!
//! A route keeps the graph path (dense, one node every graph step) and the smoothed
//! waypoints the user is guided along. Each dense node caches the index of the next
//! waypoint and the length left from it along the smoothed route, and a hash map finds a
//! vertex's place on the route. When the user strays, [`Route::rejoin`] looks only at the
//! graph vertices within a radius of the user (a window of the lattice whose size
//! depends on the radius, not on the route) and picks the nearest route node there:
//! O(1) in the route's length, no replanning. Only when none is near does the caller
//! replan.

use std::collections::HashMap;

use crate::nav_graph::NavGraph;
use crate::smoothing::grid_line_not_occupied;

/// A route on one floor.
#[derive(Clone, Debug, PartialEq)]
pub struct Route {
    /// floor level
    pub floor: i32,
    /// graph vertices from start to goal
    pub vertices: Vec<u32>,
    /// their positions, map frame, metres
    pub points: Vec<[f64; 2]>,
    /// indices into `points` of the smoothed waypoints (first and last included)
    pub waypoint_nodes: Vec<usize>,
    /// the smoothed waypoints, map frame, metres
    pub waypoints: Vec<[f64; 2]>,
    /// length of the graph path (A*'s optimum), metres
    pub graph_length_m: f64,
    /// length along the smoothed waypoints, metres
    pub length_m: f64,
    /// how far the asked start / goal were moved to reach walkable vertices, metres
    pub snapped_m: [f64; 2],
    /// per dense node: index of the next waypoint (itself when it is one)
    next_waypoint: Vec<u32>,
    /// per dense node: metres left along the smoothed route
    remaining_m: Vec<f64>,
    /// per waypoint: metres left from it
    waypoint_remaining_m: Vec<f64>,
    /// vertex -> its index in `vertices`
    index_of: HashMap<u32, u32>,
}

/// Where a user who left the route joins it again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rejoin {
    /// index of the route node (into `points`)
    pub node: usize,
    /// index of the waypoint to head for after it
    pub next_waypoint: usize,
    /// metres from the user to the node
    pub distance_m: f64,
    /// metres from the user to the goal: to the node, then along the route
    pub remaining_m: f64,
}

impl Route {
    /// A route from a graph path and the indices smoothing kept; caches every length.
    pub(crate) fn new(
        floor: i32,
        vertices: Vec<u32>,
        points: Vec<[f64; 2]>,
        waypoint_nodes: Vec<usize>,
        graph_length_m: f64,
        snapped_m: [f64; 2],
    ) -> Self {
        let waypoints: Vec<[f64; 2]> = waypoint_nodes.iter().map(|&k| points[k]).collect();
        let mut waypoint_remaining_m = vec![0.0; waypoints.len()];
        for w in (0..waypoints.len().saturating_sub(1)).rev() {
            waypoint_remaining_m[w] = waypoint_remaining_m[w + 1] + dist(waypoints[w], waypoints[w + 1]);
        }
        let mut next_waypoint = vec![0u32; points.len()];
        let mut remaining_m = vec![0.0; points.len()];
        let mut w = 0;
        for (k, p) in points.iter().enumerate() {
            while w + 1 < waypoint_nodes.len() && waypoint_nodes[w] < k {
                w += 1;
            }
            next_waypoint[k] = w as u32;
            remaining_m[k] = dist(*p, waypoints[w]) + waypoint_remaining_m[w];
        }
        let index_of = vertices.iter().enumerate().map(|(k, &v)| (v, k as u32)).collect();
        Self {
            floor,
            length_m: waypoint_remaining_m.first().copied().unwrap_or(0.0),
            vertices,
            points,
            waypoint_nodes,
            waypoints,
            graph_length_m,
            snapped_m,
            next_waypoint,
            remaining_m,
            waypoint_remaining_m,
            index_of,
        }
    }

    /// Metres left along the smoothed route from dense node `node` (cached, O(1)).
    pub fn remaining_from_node_m(&self, node: usize) -> f64 {
        self.remaining_m.get(node).copied().unwrap_or(0.0)
    }

    /// Metres left from waypoint `w` (cached, O(1)).
    pub fn remaining_from_waypoint_m(&self, w: usize) -> f64 {
        self.waypoint_remaining_m.get(w).copied().unwrap_or(0.0)
    }

    /// Index of the waypoint that follows dense node `node`.
    pub fn next_waypoint_of(&self, node: usize) -> usize {
        self.next_waypoint.get(node).map_or(0, |&w| w as usize)
    }

    /// The route node at graph vertex `v`, if the route passes there (O(1)).
    pub fn node_of_vertex(&self, v: u32) -> Option<usize> {
        self.index_of.get(&v).map(|&k| k as usize)
    }

    /// The goal, map frame.
    pub fn goal(&self) -> [f64; 2] {
        self.points.last().copied().unwrap_or([f64::NAN; 2])
    }

    /// Rejoins a user at (x, y) who left the route: the nearest route node within
    /// `radius_m` with no wall in between (ties go to the node further along), or
    /// `None`, when the caller should replan. Cost: the lattice window of the radius.
    pub fn rejoin(&self, graph: &NavGraph, x: f64, y: f64, radius_m: f64) -> Option<Rejoin> {
        let mut best: Option<(f64, usize)> = None;
        graph.for_each_within(x, y, radius_m, |v, d| {
            if let Some(k) = self.node_of_vertex(v) {
                let better = match best {
                    None => true,
                    Some((bd, bk)) => d < bd - 1e-9 || (d <= bd + 1e-9 && k > bk),
                };
                if better && grid_line_not_occupied(graph.grid(), [x, y], self.points[k]) {
                    best = Some((d, k));
                }
            }
        });
        best.map(|(d, k)| Rejoin {
            node: k,
            next_waypoint: self.next_waypoint_of(k),
            distance_m: d,
            remaining_m: d + self.remaining_m[k],
        })
    }
}

pub(crate) fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remaining_lengths_are_cached_along_the_smoothed_route() {
        // an L: right 2 m, up 2 m; smoothing kept the corner
        let points = vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [2.0, 2.0]];
        let r = Route::new(0, vec![10, 11, 12, 22, 32], points, vec![0, 2, 4], 4.0, [0.0, 0.0]);
        assert_eq!(r.length_m, 4.0);
        assert_eq!(r.waypoints, vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]]);
        let remaining: Vec<f64> = (0..5).map(|k| r.remaining_from_node_m(k)).collect();
        assert_eq!(remaining, vec![4.0, 3.0, 2.0, 1.0, 0.0]);
        let next: Vec<usize> = (0..5).map(|k| r.next_waypoint_of(k)).collect();
        assert_eq!(next, vec![0, 1, 1, 2, 2]);
        assert_eq!(r.node_of_vertex(22), Some(3));
        assert_eq!(r.node_of_vertex(99), None);
        assert_eq!(r.remaining_from_waypoint_m(1), 2.0);
        assert_eq!(r.goal(), [2.0, 2.0]);
    }
}
