//! Planning on an ISANA-sized office floor: exactness against an independent Dijkstra,
//! smoothing, snapping, unreachable goals, obstacles and restore, deviation recovery.

mod support;

use map::{Cell, OccupancyGrid, Origin};
use planning::smoothing::grid_line_clear;
use planning::{End, NavGraphConfig, PlanError, Planner};
use support::floor::{isana_floor, LONGEST};

fn planner() -> Planner {
    Planner::new(0, &isana_floor(), &NavGraphConfig::default())
}

/// Dijkstra from the `pathfinding` crate over the same graph, integer micrometres.
fn reference_length(p: &Planner, a: u32, b: u32) -> Option<f64> {
    let g = p.graph();
    pathfinding::directed::dijkstra::dijkstra(
        &a,
        |&v| g.neighbours(v).map(|(n, len)| (n, (len * 1e6).round() as u64)).collect::<Vec<_>>(),
        |&v| v == b,
    )
    .map(|(_, c)| c as f64 / 1e6)
}

#[test]
fn graph_has_a_vertex_every_20_cm_of_inflated_free_floor() {
    let p = planner();
    let g = p.graph();
    assert_eq!(g.spacing_m(), 0.2);
    assert_eq!((g.cols(), g.rows()), (145, 110));
    // every vertex is free after inflation and at least 0.3 m from any wall cell
    let walls = map::DistanceField::to_non_free(g.grid());
    for v in 0..g.lattice_len() as u32 {
        if g.is_open(v) {
            let [x, y] = g.position(v);
            let (c, r) = g.grid().world_to_cell(x, y).unwrap();
            assert!(walls.get(c, r).unwrap() >= 0.3 - 1e-6);
        }
    }
    // the floor is 638 m2 less walls and margins: between a third and all of 145 x 110
    assert!(g.vertex_count() > 145 * 110 / 3 && g.vertex_count() < 145 * 110, "{}", g.vertex_count());
}

#[test]
fn astar_length_equals_an_independent_dijkstra() {
    let mut p = planner();
    let queries = [LONGEST, ([2.0, 2.0], [2.0, 20.0]), ([7.0, 15.0], [26.0, 4.0]), ([14.5, 1.0], [14.5, 21.0])];
    for (a, b) in queries {
        let route = p.plan(a, b).unwrap();
        let (s, t) = (route.vertices[0], *route.vertices.last().unwrap());
        let expected = reference_length(&p, s, t).unwrap();
        assert!((route.graph_length_m - expected).abs() < 1e-4, "{a:?}->{b:?}: {} vs {expected}", route.graph_length_m);
    }
}

#[test]
fn longest_route_is_smoothed_to_a_few_clear_segments() {
    let mut p = planner();
    let r = p.plan(LONGEST.0, LONGEST.1).unwrap();
    // bottom-left room -> its door -> corridor -> top-right room's door -> corner
    let straight = (LONGEST.1[0] - LONGEST.0[0]).hypot(LONGEST.1[1] - LONGEST.0[1]);
    assert!(r.length_m >= straight && r.length_m <= r.graph_length_m + 1e-9);
    assert!(r.graph_length_m < 45.0, "{}", r.graph_length_m);
    assert!(r.points.len() > 120);
    assert!(r.waypoints.len() <= 8, "{} waypoints", r.waypoints.len());
    for w in r.waypoints.windows(2) {
        assert!(grid_line_clear(p.graph().inflated(), w[0], w[1]));
    }
    // cached remaining lengths: whole route from node 0, zero at the goal
    assert!((r.remaining_from_node_m(0) - r.length_m).abs() < 1e-9);
    assert_eq!(r.remaining_from_node_m(r.points.len() - 1), 0.0);
}

#[test]
fn start_in_a_wall_is_snapped_within_a_metre() {
    let mut p = planner();
    // (4.5, 5.0) is inside the partition wall between the first two rooms
    let r = p.plan([4.5, 5.0], [2.0, 5.0]).unwrap();
    // the wall covers cells with centres 4.475 and 4.525; with 0.3 m clearance the nearest
    // vertex is lattice column 20 (x = 0.2 * 20 + 0.125 = 4.125), row 24 (y = 4.925)
    let [x, y] = r.points[0];
    assert!((x - 4.125).abs() < 1e-9 && (y - 4.925).abs() < 1e-9, "{x} {y}");
    assert!((r.snapped_m[0] - 0.375f64.hypot(0.075)).abs() < 1e-9, "{:?}", r.snapped_m);
}

#[test]
fn ends_deep_in_walls_or_off_the_map_are_refused_with_the_reason() {
    let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
    let mut g = OccupancyGrid::filled(100, 100, 0.05, o, Cell::Free).unwrap();
    // a 3 x 3 m pillar in a 5 x 5 m room
    support::floor::paint(&mut g, 1.0, 1.0, 4.0, 4.0, Cell::Occupied);
    let mut p = Planner::new(0, &g, &NavGraphConfig::default());
    match p.plan([2.5, 2.5], [4.6, 4.6]) {
        Err(PlanError::NotWalkable { end: End::Start, reason, radius_m, .. }) => {
            assert_eq!(reason, "inside a wall");
            assert_eq!(radius_m, 1.0);
        }
        other => panic!("{other:?}"),
    }
    let e = p.plan([4.6, 4.6], [9.0, 2.0]).unwrap_err();
    assert!(matches!(e, PlanError::OutsideMap { end: End::Goal, .. }), "{e}");
    assert_eq!(e.to_string(), "goal (9.00, 2.00) is outside the floor map");
    let e = p.plan([f64::NAN, 1.0], [4.6, 4.6]).unwrap_err();
    assert!(matches!(e, PlanError::OutsideMap { end: End::Start, .. }));
}

#[test]
fn goal_in_a_closed_room_is_unreachable() {
    let mut g = isana_floor();
    // close the top-right room's door
    support::floor::paint(&mut g, 26.0, 11.9, 27.5, 12.1, Cell::Occupied);
    let mut p = Planner::new(0, &g, &NavGraphConfig::default());
    let e = p.plan(LONGEST.0, LONGEST.1).unwrap_err();
    assert!(matches!(e, PlanError::Unreachable { floor: 0, .. }), "{e}");
    assert!(e.to_string().starts_with("no walkable path from (1.00, 1.00) to (28.00, 21.00)"), "{e}");
}

#[test]
fn obstacle_on_the_route_forces_a_detour_and_restore_brings_the_route_back() {
    let mut p = planner();
    let (a, b) = ([14.5, 1.0], [14.5, 21.0]); // straight up the corridor along
    let before = p.plan(a, b).unwrap();
    assert!((before.graph_length_m - 20.0).abs() < 0.3, "{}", before.graph_length_m);
    // a person standing in the corridor, left of its centre line
    let id = p.add_obstacle(14.2, 6.0, 0.2);
    assert!(p.blocks(&before));
    let after = p.replan(&before, a).unwrap();
    assert!(!p.blocks(&after));
    assert!(after.graph_length_m > before.graph_length_m);
    for v in &after.vertices {
        let [x, y] = p.graph().position(*v);
        assert!((x - 14.2).hypot(y - 6.0) > 0.5 - 1e-9);
    }
    assert!(p.remove_obstacle(id));
    assert!(!p.remove_obstacle(id));
    let restored = p.plan(a, b).unwrap();
    assert_eq!(restored.graph_length_m, before.graph_length_m);
    assert_eq!(restored.vertices, before.vertices);
}

#[test]
fn an_obstacle_blocks_the_way_ahead_only_where_the_body_would_touch_it_before_the_user() {
    let mut p = planner();
    let (a, b) = ([14.5, 1.0], [14.5, 21.0]);
    let route = p.plan(a, b).unwrap();
    // one straight segment up the corridor
    assert_eq!(route.waypoints.len(), 2, "{:?}", route.waypoints);
    // an obstacle 0.1 m across on the line, the body passing within 0.25 m of it
    p.add_obstacle(14.5, 6.0, 0.1);
    // the user at y = 3 heading up: the obstacle 3 m ahead is on the way
    assert!(p.blocks_ahead(&route, [14.5, 3.0], 1, 0.25));
    // past it (y = 8): behind the user, not on the way left
    assert!(!p.blocks_ahead(&route, [14.5, 8.0], 1, 0.25));
    // standing 0.3 m short of it: the cue's, not the plan's
    assert!(!p.blocks_ahead(&route, [14.5, 5.7], 1, 0.25));
    // beside the way, 0.4 m off the line: the body passes it (the clearance of 0.3 m
    // would not, but that is for new routes)
    let mut q = planner();
    q.add_obstacle(14.1, 6.0, 0.1);
    assert!(!q.blocks_ahead(&route, [14.5, 3.0], 1, 0.25));
    assert!(q.blocks_ahead(&route, [14.5, 3.0], 1, 0.35));
    // no waypoint left to head for: nothing ahead
    assert!(!p.blocks_ahead(&route, [14.5, 3.0], 2, 0.25));
}

#[test]
fn stray_user_rejoins_the_nearest_route_node_or_asks_for_a_replan() {
    let mut p = planner();
    let r = p.plan(LONGEST.0, LONGEST.1).unwrap();
    // the route crosses the corridor across; a user 0.4 m off it, in the corridor
    let k = r.points.iter().position(|q| q[1] > 10.5 && q[1] < 11.5 && q[0] > 8.0).unwrap();
    let q = r.points[k];
    let user = [q[0], q[1] + 0.4];
    let j = r.rejoin(p.graph(), user[0], user[1], 1.0).expect("route within 1 m");
    let node = r.points[j.node];
    assert!((j.distance_m - (node[0] - user[0]).hypot(node[1] - user[1])).abs() < 1e-9);
    assert!(j.distance_m <= 0.4 + 1e-9);
    assert!((j.remaining_m - (j.distance_m + r.remaining_from_node_m(j.node))).abs() < 1e-9);
    assert!(j.remaining_m < r.length_m);
    // in another room, behind a wall: nothing to rejoin, replan
    assert_eq!(r.rejoin(p.graph(), 7.0, 5.0, 1.0), None);
}
