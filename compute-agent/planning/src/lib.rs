//! Route planning for a blind walker (ISANA, Muñoz et al.): pure, no bus, no runtime,
//! no clock (benchmarks pass their clock in).
//!
//! | step | module | ISANA |
//! | --- | --- | --- |
//! | graph from the occupancy grid: a vertex every 20 cm where free after inflation, 8-connected, no corner cutting | [`nav_graph`] | navigation graph |
//! | exact A* (octile heuristic), flat arrays, generation counters | [`astar`] | A* with L2 heuristic |
//! | line-of-sight smoothing over the inflated grid | [`smoothing`] | path smoothing |
//! | snapping, obstacle-driven node removal, replanning, restore | [`planner`] | replanning |
//! | O(1) deviation recovery with cached remaining lengths | [`route`] | deviation recovery |
//! | floors joined by gateways, user preferences | [`multi_floor`], [`profile`] | multi-floor |
//! | Moving AI benchmark files and runner | [`movingai`] | (our check of exactness) |
//!
//! A start or goal inside a wall is snapped to the nearest walkable vertex within
//! [`planner::DEFAULT_SNAP_RADIUS_M`] or refused with the reason; an unreachable goal is
//! a [`PlanError`], never a panic.

pub mod astar;
pub mod error;
pub mod movingai;
pub mod multi_floor;
pub mod nav_graph;
pub mod planner;
pub mod profile;
pub mod route;
pub mod smoothing;

pub use astar::AStar;
pub use error::{End, PlanError};
pub use multi_floor::{BuildingPlanner, BuildingRoute, FloorPoint, Leg, LegEnd};
pub use nav_graph::{NavGraph, NavGraphConfig};
pub use planner::{ObstacleId, Planner};
pub use profile::UserProfile;
pub use route::{Rejoin, Route};
