//! Why a route could not be planned.

/// Which end of a query.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    /// where the user is
    Start,
    /// where the user wants to go
    Goal,
}

impl std::fmt::Display for End {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            End::Start => "start",
            End::Goal => "goal",
        })
    }
}

/// Every way planning can fail; each says what was asked and why it cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// The point is not a finite number or lies outside the floor map.
    #[error("{end} ({x:.2}, {y:.2}) is outside the floor map")]
    OutsideMap {
        /// start or goal
        end: End,
        /// map frame, metres
        x: f64,
        /// map frame, metres
        y: f64,
    },
    /// No walkable graph vertex within the snap radius (inside a wall, or too near walls
    /// for the user's clearance).
    #[error("{end} ({x:.2}, {y:.2}) is not walkable ({reason}) and no walkable place is within {radius_m:.2} m of it")]
    NotWalkable {
        /// start or goal
        end: End,
        /// map frame, metres
        x: f64,
        /// map frame, metres
        y: f64,
        /// the snap radius searched
        radius_m: f64,
        /// "inside a wall", "closer to a wall than the 0.30 m clearance", ...
        reason: String,
    },
    /// Start and goal are both walkable but no path joins them.
    #[error("no walkable path from ({from_x:.2}, {from_y:.2}) to ({to_x:.2}, {to_y:.2}) on floor {floor}")]
    Unreachable {
        /// floor level
        floor: i32,
        /// start, metres
        from_x: f64,
        /// start, metres
        from_y: f64,
        /// goal, metres
        to_x: f64,
        /// goal, metres
        to_y: f64,
    },
    /// The building has no floor at this level.
    #[error("the building has no floor {0}")]
    NoSuchFloor(i32),
    /// No chain of gateways allowed by the profile joins the two floors.
    #[error("no way from floor {from} to floor {to}{why}")]
    NoGatewayRoute {
        /// start floor
        from: i32,
        /// goal floor
        to: i32,
        /// e.g. " that avoids stairs"
        why: String,
    },
}
