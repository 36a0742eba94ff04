//! Routes across two floors joined by an elevator and a staircase, weighed by the
//! user's profile.

mod support;

use std::path::Path;

use map::{Building, Floor, GatewayKind, SemanticLayer};
use planning::{BuildingPlanner, FloorPoint, LegEnd, PlanError, UserProfile};
use support::floor::isana_floor;

const GATEWAYS: &str = r#"
[[gateway]]
name = "west elevator"
type = "elevator"
stops = [ { floor = 0, x = 1.0, y = 11.0 }, { floor = 1, x = 1.0, y = 11.0 } ]

[[gateway]]
name = "east stairs"
type = "stairs"
stops = [ { floor = 0, x = 28.0, y = 11.0 }, { floor = 1, x = 28.0, y = 11.0 } ]
"#;

fn building(semantic: &str) -> Building {
    let layer = SemanticLayer::parse(semantic, Path::new("gateways.toml")).unwrap();
    let floors = [0, 1].map(|level| Floor { level, grid: isana_floor(), semantic: layer.floor(level) });
    Building::new(floors.to_vec(), Path::new("two floors")).unwrap()
}

const FROM: FloorPoint = FloorPoint { floor: 0, x: 27.0, y: 5.0 };
const TO: FloorPoint = FloorPoint { floor: 1, x: 27.0, y: 18.0 };

fn gateway_of(route: &planning::BuildingRoute) -> (&str, GatewayKind, i32) {
    match &route.legs[0].end {
        LegEnd::Gateway { name, kind, to_floor } => (name.as_str(), *kind, *to_floor),
        LegEnd::Goal => panic!("first leg ends at the goal"),
    }
}

#[test]
fn nearby_stairs_win_by_default_and_the_legs_join_there() {
    let mut p = BuildingPlanner::new(&building(GATEWAYS), UserProfile::default());
    let r = p.plan(FROM, TO).unwrap();
    assert_eq!(r.legs.len(), 2);
    assert_eq!(gateway_of(&r), ("east stairs", GatewayKind::Stairs, 1));
    assert_eq!(r.legs[1].end, LegEnd::Goal);
    assert_eq!((r.legs[0].route.floor, r.legs[1].route.floor), (0, 1));
    let end0 = *r.legs[0].route.points.last().unwrap();
    let start1 = r.legs[1].route.points[0];
    assert!((end0[0] - 28.0).hypot(end0[1] - 11.0) < 0.5, "{end0:?}");
    assert!((start1[0] - 28.0).hypot(start1[1] - 11.0) < 0.5, "{start1:?}");
    // cost = walking (graph lengths) + one flight (8 m)
    assert!(r.cost_m > r.walk_length_m + 8.0 - 1.0 && r.cost_m < r.walk_length_m + 8.0 + 1.0, "{r:?}");
}

#[test]
fn avoid_stairs_or_prefer_elevator_take_the_far_elevator() {
    for profile in [
        UserProfile { avoid_stairs: true, ..UserProfile::default() },
        UserProfile { prefer_elevator: true, ..UserProfile::default() },
    ] {
        let mut p = BuildingPlanner::new(&building(GATEWAYS), profile);
        let r = p.plan(FROM, TO).unwrap();
        assert_eq!(gateway_of(&r), ("west elevator", GatewayKind::Elevator, 1));
        // across the floor and back: over 50 m of walking
        assert!(r.walk_length_m > 50.0, "{}", r.walk_length_m);
    }
}

#[test]
fn stairs_only_building_has_no_route_for_a_user_who_avoids_stairs() {
    let stairs_only = &GATEWAYS[GATEWAYS.find("[[gateway]]\nname = \"east").unwrap()..];
    let mut p =
        BuildingPlanner::new(&building(stairs_only), UserProfile { avoid_stairs: true, ..UserProfile::default() });
    let e = p.plan(FROM, TO).unwrap_err();
    assert_eq!(e, PlanError::NoGatewayRoute { from: 0, to: 1, why: " that avoids stairs".into() });
    assert_eq!(e.to_string(), "no way from floor 0 to floor 1 that avoids stairs");
}

#[test]
fn same_floor_is_one_leg_and_unknown_floors_are_refused() {
    let mut p = BuildingPlanner::new(&building(GATEWAYS), UserProfile::default());
    let r = p.plan(FROM, FloorPoint { floor: 0, x: 2.0, y: 2.0 }).unwrap();
    assert_eq!(r.legs.len(), 1);
    assert_eq!(r.legs[0].end, LegEnd::Goal);
    assert_eq!(p.plan(FROM, FloorPoint { floor: 5, x: 1.0, y: 1.0 }).unwrap_err(), PlanError::NoSuchFloor(5));
}

#[test]
fn goal_off_the_other_floors_map_says_so() {
    let mut p = BuildingPlanner::new(&building(GATEWAYS), UserProfile::default());
    let e = p.plan(FROM, FloorPoint { floor: 1, x: 50.0, y: 5.0 }).unwrap_err();
    assert!(matches!(e, PlanError::OutsideMap { .. }), "{e}");
}
