//! Routes across floors (ISANA, "multi-floor"): a building graph whose nodes are the
//! gateway stops (an elevator or staircase on each floor it serves) plus the start and
//! the goal, with same-floor edges weighed by A* on that floor's graph and gateway edges
//! by the user's profile (avoid stairs, prefer the elevator). Dijkstra over it gives the
//! sequence of gateways; the route is then one smoothed leg per floor, joined at them.

use std::collections::BTreeMap;

use map::{Building, Gateway, GatewayKind};

use crate::error::PlanError;
use crate::planner::Planner;
use crate::profile::UserProfile;
use crate::route::Route;

/// A point on a floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloorPoint {
    /// floor level
    pub floor: i32,
    /// map frame of that floor, metres
    pub x: f64,
    /// map frame of that floor, metres
    pub y: f64,
}

/// How a leg ends.
#[derive(Clone, Debug, PartialEq)]
pub enum LegEnd {
    /// at a gateway, to be taken to another floor
    Gateway {
        /// its name ("main elevator")
        name: String,
        /// elevator, stairs or ramp
        kind: GatewayKind,
        /// the floor to take it to
        to_floor: i32,
    },
    /// at the goal
    Goal,
}

/// One floor's part of a building route.
#[derive(Clone, Debug, PartialEq)]
pub struct Leg {
    /// the route on that floor
    pub route: Route,
    /// what the user does at its end
    pub end: LegEnd,
}

/// A route that may span floors.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildingRoute {
    /// in walking order
    pub legs: Vec<Leg>,
    /// walking length, metres (smoothed legs)
    pub walk_length_m: f64,
    /// the cost Dijkstra minimised: walking plus gateway costs from the profile
    pub cost_m: f64,
}

/// A planner per floor plus the gateways between them.
#[derive(Clone, Debug)]
pub struct BuildingPlanner {
    floors: BTreeMap<i32, Planner>,
    gateways: Vec<Gateway>,
    profile: UserProfile,
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Node {
    Start,
    Goal,
    /// gateway index, floor
    Stop(usize, i32),
}

impl BuildingPlanner {
    /// Builds every floor's graph with the profile's spacing and wall distance.
    pub fn new(building: &Building, profile: UserProfile) -> Self {
        let config = profile.graph_config();
        let floors = building.floors().iter().map(|f| (f.level, Planner::new(f.level, &f.grid, &config))).collect();
        Self { floors, gateways: building.gateways().to_vec(), profile }
    }

    /// The planner of one floor (to add obstacles, rejoin, ...).
    pub fn floor_mut(&mut self, level: i32) -> Option<&mut Planner> {
        self.floors.get_mut(&level)
    }

    /// The planner of one floor.
    pub fn floor(&self, level: i32) -> Option<&Planner> {
        self.floors.get(&level)
    }

    /// The profile in use.
    pub fn profile(&self) -> &UserProfile {
        &self.profile
    }

    /// What taking gateway `g` from one floor to another costs, or `None` if the profile
    /// forbids it.
    fn transfer_cost(&self, g: &Gateway, from: i32, to: i32) -> Option<f64> {
        let floors = (from - to).unsigned_abs() as f64;
        let p = &self.profile;
        match g.kind {
            GatewayKind::Elevator => Some(p.elevator_cost_m + floors),
            GatewayKind::Stairs if p.avoid_stairs => None,
            GatewayKind::Stairs => {
                let factor = if p.prefer_elevator { p.prefer_elevator_factor } else { 1.0 };
                Some(p.stairs_cost_m * floors * factor)
            }
            GatewayKind::Ramp => Some(p.ramp_cost_m * floors),
        }
    }

    fn position(&self, node: Node, from: FloorPoint, to: FloorPoint) -> FloorPoint {
        match node {
            Node::Start => from,
            Node::Goal => to,
            Node::Stop(g, floor) => {
                let s = self.gateways[g].stop(floor).map_or((f64::NAN, f64::NAN), |s| (s.x, s.y));
                FloorPoint { floor, x: s.0, y: s.1 }
            }
        }
    }

    /// The cheapest route from `from` to `to`, across floors if they differ.
    pub fn plan(&mut self, from: FloorPoint, to: FloorPoint) -> Result<BuildingRoute, PlanError> {
        for p in [from, to] {
            if !self.floors.contains_key(&p.floor) {
                return Err(PlanError::NoSuchFloor(p.floor));
            }
        }
        if from.floor == to.floor {
            let planner = self.floors.get_mut(&from.floor).ok_or(PlanError::NoSuchFloor(from.floor))?;
            let route = planner.plan([from.x, from.y], [to.x, to.y])?;
            let len = route.length_m;
            return Ok(BuildingRoute { legs: vec![Leg { route, end: LegEnd::Goal }], walk_length_m: len, cost_m: len });
        }
        let mut nodes = vec![Node::Start, Node::Goal];
        for (gi, g) in self.gateways.iter().enumerate() {
            for s in &g.stops {
                if self.floors.contains_key(&s.floor) {
                    nodes.push(Node::Stop(gi, s.floor));
                }
            }
        }
        let floor_of = |n: Node| match n {
            Node::Start => from.floor,
            Node::Goal => to.floor,
            Node::Stop(_, f) => f,
        };
        // Dijkstra over the few nodes; same-floor edges cost one A* each, computed when needed
        let n = nodes.len();
        let mut dist = vec![f64::INFINITY; n];
        let mut prev = vec![usize::MAX; n];
        let mut done = vec![false; n];
        dist[0] = 0.0;
        let mut first_error: Option<PlanError> = None;
        while let Some(u) =
            (0..n).filter(|&i| !done[i] && dist[i].is_finite()).min_by(|&a, &b| dist[a].total_cmp(&dist[b]))
        {
            done[u] = true;
            if nodes[u] == Node::Goal {
                break;
            }
            let pu = self.position(nodes[u], from, to);
            for v in 0..n {
                if done[v] || nodes[v] == Node::Start {
                    continue;
                }
                let cost = if floor_of(nodes[v]) == pu.floor {
                    let pv = self.position(nodes[v], from, to);
                    let Some(planner) = self.floors.get_mut(&pu.floor) else { continue };
                    match planner.distance_m([pu.x, pu.y], [pv.x, pv.y]) {
                        Ok(d) => d,
                        Err(e) => {
                            // an unwalkable start or goal is the user's answer, say it as such
                            if matches!(nodes[u], Node::Start) || matches!(nodes[v], Node::Goal) {
                                first_error.get_or_insert(e);
                            }
                            continue;
                        }
                    }
                } else {
                    match (nodes[u], nodes[v]) {
                        (Node::Stop(a, fa), Node::Stop(b, fb)) if a == b => {
                            match self.transfer_cost(&self.gateways[a], fa, fb) {
                                Some(c) => c,
                                None => continue,
                            }
                        }
                        _ => continue,
                    }
                };
                if dist[u] + cost < dist[v] {
                    dist[v] = dist[u] + cost;
                    prev[v] = u;
                }
            }
        }
        if !dist[1].is_finite() {
            if let Some(e @ (PlanError::NotWalkable { .. } | PlanError::OutsideMap { .. })) = first_error {
                return Err(e);
            }
            let why = if self.profile.avoid_stairs { " that avoids stairs".to_string() } else { String::new() };
            return Err(PlanError::NoGatewayRoute { from: from.floor, to: to.floor, why });
        }
        let mut chain = vec![1usize];
        while let Some(&last) = chain.last() {
            if prev[last] == usize::MAX {
                break;
            }
            chain.push(prev[last]);
        }
        chain.reverse();
        // consecutive nodes on one floor are a leg; a change of floor is a gateway ride
        let mut legs = Vec::new();
        for w in chain.windows(2) {
            let (a, b) = (nodes[w[0]], nodes[w[1]]);
            if floor_of(a) != floor_of(b) {
                continue;
            }
            let (pa, pb) = (self.position(a, from, to), self.position(b, from, to));
            let planner = self.floors.get_mut(&pa.floor).ok_or(PlanError::NoSuchFloor(pa.floor))?;
            let route = planner.plan([pa.x, pa.y], [pb.x, pb.y])?;
            legs.push(Leg { route, end: LegEnd::Goal });
        }
        // name the gateway each leg but the last ends at
        let mut leg: usize = 0;
        for w in chain.windows(2) {
            let (a, b) = (nodes[w[0]], nodes[w[1]]);
            if floor_of(a) == floor_of(b) {
                leg += 1;
            } else if let (Node::Stop(g, _), Some(prev_leg)) = (a, leg.checked_sub(1)) {
                let gw = &self.gateways[g];
                legs[prev_leg].end = LegEnd::Gateway { name: gw.name.clone(), kind: gw.kind, to_floor: floor_of(b) };
            }
        }
        let walk_length_m = legs.iter().map(|l| l.route.length_m).sum();
        Ok(BuildingRoute { legs, walk_length_m, cost_m: dist[1] })
    }
}
