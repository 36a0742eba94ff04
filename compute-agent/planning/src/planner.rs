//! Planning on one floor: snap the ends to walkable vertices, A*, smoothing; obstacles
//! seen at run time remove vertices (ISANA, "obstacle-driven node removal") and give
//! them back when they go, so replanning never rebuilds the graph.

use std::collections::BTreeMap;

use map::{Cell, OccupancyGrid};

use crate::astar::AStar;
use crate::error::{End, PlanError};
use crate::nav_graph::{NavGraph, NavGraphConfig};
use crate::route::{dist, Route};
use crate::smoothing::{clear_of_discs, grid_line_not_occupied, segment_point_distance, smooth, Disc};

/// How far an end that is not walkable may be moved to the nearest walkable vertex, by
/// default (1 m: about two strides; farther and the user should be told instead).
pub const DEFAULT_SNAP_RADIUS_M: f64 = 1.0;

/// Identifies an obstacle added to a [`Planner`], to remove it later.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ObstacleId(pub u64);

#[derive(Clone, Debug)]
struct Obstacle {
    disc: Disc,
    vertices: Vec<u32>,
}

/// One floor's graph, a reusable A* and the obstacles blocking vertices now.
#[derive(Clone, Debug)]
pub struct Planner {
    floor: i32,
    graph: NavGraph,
    astar: AStar,
    obstacles: BTreeMap<ObstacleId, Obstacle>,
    discs: Vec<Disc>,
    next_obstacle: u64,
    clearance_m: f64,
    /// how far a start or goal may be snapped, metres
    pub snap_radius_m: f64,
    path: Vec<u32>,
}

impl Planner {
    /// Builds the graph for `grid` (floor `floor`).
    pub fn new(floor: i32, grid: &OccupancyGrid, config: &NavGraphConfig) -> Self {
        Self::from_graph(floor, NavGraph::build(grid, config), config.clearance_m)
    }

    /// A planner over an already built graph.
    pub fn from_graph(floor: i32, graph: NavGraph, clearance_m: f64) -> Self {
        Self {
            floor,
            graph,
            astar: AStar::new(),
            obstacles: BTreeMap::new(),
            discs: Vec::new(),
            next_obstacle: 0,
            clearance_m,
            snap_radius_m: DEFAULT_SNAP_RADIUS_M,
            path: Vec::new(),
        }
    }

    /// The floor level.
    pub fn floor(&self) -> i32 {
        self.floor
    }

    /// The graph (with obstacles applied).
    pub fn graph(&self) -> &NavGraph {
        &self.graph
    }

    /// The nearest open vertex to (x, y) within the snap radius. A vertex behind a wall
    /// (the straight line to it crosses an occupied cell) is not taken unless (x, y) is
    /// itself inside a wall.
    pub fn snap(&self, end: End, x: f64, y: f64) -> Result<(u32, f64), PlanError> {
        let grid = self.graph.grid();
        let Some((c, r)) = grid.world_to_cell(x, y) else {
            return Err(PlanError::OutsideMap { end, x, y });
        };
        let cell = grid.get(c, r);
        let in_wall = cell == Some(Cell::Occupied);
        let mut best: Option<(f64, u32)> = None;
        self.graph.for_each_within(x, y, self.snap_radius_m, |v, d| {
            if self.graph.is_open(v)
                && best.is_none_or(|(bd, _)| d < bd)
                && (in_wall || grid_line_not_occupied(grid, [x, y], self.graph.position(v)))
            {
                best = Some((d, v));
            }
        });
        best.map(|(d, v)| (v, d)).ok_or_else(|| {
            let reason = match cell {
                Some(Cell::Occupied) => "inside a wall".to_string(),
                Some(Cell::Unknown) => "in unmapped space".to_string(),
                _ => format!(
                    "closer to a wall or an obstacle than the {:.2} m clearance, or walled in",
                    self.clearance_m
                ),
            };
            PlanError::NotWalkable { end, x, y, radius_m: self.snap_radius_m, reason }
        })
    }

    /// The shortest walkable route from `from` to `to` (map frame, metres), smoothed.
    pub fn plan(&mut self, from: [f64; 2], to: [f64; 2]) -> Result<Route, PlanError> {
        let (s, ds) = self.snap(End::Start, from[0], from[1])?;
        let (t, dt) = self.snap(End::Goal, to[0], to[1])?;
        let mut path = std::mem::take(&mut self.path);
        let result = self.astar.search(&self.graph, s, t, &mut path);
        let route = match result {
            Some(len) => {
                let points: Vec<[f64; 2]> = path.iter().map(|&v| self.graph.position(v)).collect();
                let kept = smooth(self.graph.inflated(), &self.discs, &points);
                Ok(Route::new(self.floor, path.clone(), points, kept, len, [ds, dt]))
            }
            None => Err(PlanError::Unreachable {
                floor: self.floor,
                from_x: from[0],
                from_y: from[1],
                to_x: to[0],
                to_y: to[1],
            }),
        };
        self.path = path;
        route
    }

    /// Length of the shortest graph path between two points (no smoothing, no route
    /// built): what the building planner weighs legs with.
    pub fn distance_m(&mut self, from: [f64; 2], to: [f64; 2]) -> Result<f64, PlanError> {
        let (s, ds) = self.snap(End::Start, from[0], from[1])?;
        let (t, dt) = self.snap(End::Goal, to[0], to[1])?;
        let mut path = std::mem::take(&mut self.path);
        let len = self.astar.search(&self.graph, s, t, &mut path);
        self.path = path;
        len.map(|l| l + ds + dt).ok_or(PlanError::Unreachable {
            floor: self.floor,
            from_x: from[0],
            from_y: from[1],
            to_x: to[0],
            to_y: to[1],
        })
    }

    /// Blocks the vertices within `radius_m` + the clearance of (x, y): an obstacle the
    /// user's camera saw. Cost: the vertices in that disc.
    pub fn add_obstacle(&mut self, x: f64, y: f64, radius_m: f64) -> ObstacleId {
        let disc = Disc { x, y, radius_m: radius_m.max(0.0) + self.clearance_m };
        let vertices = self.graph.vertices_within(x, y, disc.radius_m);
        for &v in &vertices {
            self.graph.block(v);
        }
        let id = ObstacleId(self.next_obstacle);
        self.next_obstacle += 1;
        self.obstacles.insert(id, Obstacle { disc, vertices });
        self.discs.push(disc);
        id
    }

    /// Gives back the vertices an obstacle blocked (it went away). False if unknown.
    pub fn remove_obstacle(&mut self, id: ObstacleId) -> bool {
        let Some(o) = self.obstacles.remove(&id) else {
            return false;
        };
        for &v in &o.vertices {
            self.graph.unblock(v);
        }
        if let Some(k) = self.discs.iter().position(|d| *d == o.disc) {
            self.discs.swap_remove(k);
        }
        true
    }

    /// How many obstacles are active.
    pub fn obstacle_count(&self) -> usize {
        self.obstacles.len()
    }

    /// True when an active obstacle blocks a node of `route` or crosses one of its
    /// smoothed segments: time to replan.
    pub fn blocks(&self, route: &Route) -> bool {
        route.vertices.iter().any(|&v| !self.graph.is_open(v))
            || route.waypoints.windows(2).any(|w| !clear_of_discs(&self.discs, w[0], w[1]))
    }

    /// True when an active obstacle stands on what is left of `route` for a user at
    /// `from` heading for its waypoint `next`: the line from `from` to that waypoint, or
    /// a segment after it, passes within `pass_m` of the obstacle itself (its radius,
    /// not its disc: `pass_m` is how near the user may pass, e.g. half the body's
    /// width; the planner's clearance keeps new routes farther). An obstacle `from` is
    /// already that near is left out: what the user stands beside is the obstacle
    /// cue's to warn of, and any way from there starts beside it. Cost: obstacles times
    /// segments.
    pub fn blocks_ahead(&self, route: &Route, from: [f64; 2], next: usize, pass_m: f64) -> bool {
        let reach = |d: &Disc| (d.radius_m - self.clearance_m).max(0.0) + pass_m;
        let Some(rest) = route.waypoints.get(next..) else {
            return false;
        };
        let mut a = from;
        for &b in rest {
            let touched = |d: &Disc| {
                let r = reach(d);
                dist(from, [d.x, d.y]) >= r && segment_point_distance(a, b, [d.x, d.y]) < r
            };
            if self.discs.iter().any(touched) {
                return true;
            }
            a = b;
        }
        false
    }

    /// Replans from where the user is to the goal of `route`.
    pub fn replan(&mut self, route: &Route, from: [f64; 2]) -> Result<Route, PlanError> {
        self.plan(from, route.goal())
    }
}

/// Straight-line distance, metres.
pub fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    dist(a, b)
}
