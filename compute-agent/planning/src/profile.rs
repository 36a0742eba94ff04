//! What the user prefers, from their profile: how routes are weighed and how far from
//! walls they are laid.

use serde::{Deserialize, Serialize};

/// Route preferences (ISANA: user preferences for gateways; the distance to walls is
/// the inflation radius).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct UserProfile {
    /// never use stairs (a cane user with a walker, or by choice)
    pub avoid_stairs: bool,
    /// take an elevator when there is one, even if stairs are shorter
    pub prefer_elevator: bool,
    /// distance kept from walls and unmapped space, metres (the graph's clearance)
    pub wall_distance_m: f64,
    /// graph spacing, metres (ISANA: 0.2)
    pub spacing_m: f64,
    /// what one elevator ride costs, in metres of walking (waiting, calling, doors):
    /// default 20 m: our estimate of a ~15 s wait and ride at a walking pace of ~1.2 m/s
    pub elevator_cost_m: f64,
    /// what one flight of stairs costs, in metres of walking (default 8 m: ~20 steps)
    pub stairs_cost_m: f64,
    /// what one floor of ramp costs, in metres (default 12 m: a 1:12 ramp for 3 m rise is
    /// longer, but it is walked at walking speed)
    pub ramp_cost_m: f64,
    /// multiplies the stairs cost when `prefer_elevator` is set (default 10)
    pub prefer_elevator_factor: f64,
}

impl Default for UserProfile {
    fn default() -> Self {
        Self {
            avoid_stairs: false,
            prefer_elevator: false,
            wall_distance_m: 0.3,
            spacing_m: 0.2,
            elevator_cost_m: 20.0,
            stairs_cost_m: 8.0,
            ramp_cost_m: 12.0,
            prefer_elevator_factor: 10.0,
        }
    }
}

impl UserProfile {
    /// The graph layout this profile asks for.
    pub fn graph_config(&self) -> crate::NavGraphConfig {
        crate::NavGraphConfig { spacing_m: self.spacing_m, clearance_m: self.wall_distance_m }
    }
}
