//! The floor plans of the built-in worlds (issue 31, `wearnav map`): every world
//! exported, written with `Building::write`, read back with `Building::load` and checked
//! against its scene file: walls where the TOML puts them, free floor at the start and
//! the goal and under the furniture, as many doors, rooms and gateways as the world has,
//! no gap in any wall, and routes that a planner finds on the plan and that stay out of
//! the walls.

use std::path::PathBuf;

use map::{Building, Cell, GatewayKind, OccupancyGrid};
use planning::{BuildingPlanner, FloorPoint, LegEnd, NavGraphConfig, Planner, UserProfile};
use sim::world::BUILTIN_WORLDS;
use sim::{ObstacleKind, World};
use study::floor_plan::{export, export_as_mapped, stair_stops, DEFAULT_RESOLUTION_M};

fn world(name: &str) -> World {
    World::load(name).unwrap_or_else(|e| panic!("{e}"))
}

/// A fresh directory under the system temp dir, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        // tests run in parallel, several on one world: one directory per call
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("wearnav-floor-plan-{tag}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("cannot create {}: {e}", dir.display()));
        Self(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The world's floor plan as `wearnav map` leaves it on disk, loaded back.
fn exported(name: &str) -> (World, Building) {
    let w = world(name);
    let building = export(&w, DEFAULT_RESOLUTION_M).unwrap_or_else(|e| panic!("{name}: {e}"));
    let dir = TempDir::new(name);
    let manifest = dir.0.join("building.toml");
    building.write(&manifest).unwrap_or_else(|e| panic!("{name}: {e}"));
    let loaded = Building::load(&manifest).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(loaded, building, "{name}: the files read back differ from what was written");
    (w, loaded)
}

fn cell_at(b: &Building, floor: i32, x: f64, y: f64) -> Option<Cell> {
    let g = &b.floor(floor)?.grid;
    g.world_to_cell(x, y).and_then(|(c, r)| g.get(c, r))
}

/// Points on walls and free points of each built-in world, read from its scene file:
/// (world, [(floor, x, y)] on walls, [(floor, x, y)] free).
type Known = (&'static str, &'static [(i32, f64, f64)], &'static [(i32, f64, f64)]);

const KNOWN: [Known; 10] = [
    (
        "taylor-course",
        // the four room walls, divider 1 (x 3.5, y 0..7), divider 2 (x 6.5, y 3..10)
        &[(0, 5.0, 0.0), (0, 10.0, 5.0), (0, 5.0, 10.0), (0, 0.0, 5.0), (0, 3.5, 3.0), (0, 3.5, 6.95), (0, 6.5, 9.0)],
        // the gaps the course winds through (north of divider 1, south of divider 2),
        // chair 1 (1.2, 7.6), the head-high sign (4.5, 5.6), the waist-high board (7.3, 6.0)
        &[(0, 3.5, 8.5), (0, 6.5, 1.5), (0, 1.2, 7.6), (0, 4.5, 5.6), (0, 7.3, 6.0)],
    ),
    (
        "open-course",
        // room walls, divider 1 (x 5, y 3.6..6.6), divider 2 (y 6.9, x 5.8..8.6)
        &[(0, 0.0, 2.0), (0, 10.0, 8.0), (0, 5.0, 5.0), (0, 7.0, 6.9)],
        // round both ends of divider 1; chair 1 (3.0, 4.6)
        &[(0, 5.0, 3.0), (0, 5.0, 7.2), (0, 3.0, 4.6)],
    ),
    (
        "corridor",
        // corridor A south (y 0) and north (y 2, x 0..28), corridor B east (x 30) and west (x 28, y 2..20)
        &[(0, 15.0, 0.0), (0, 15.0, 2.0), (0, 30.0, 10.0), (0, 28.0, 10.0), (0, 29.0, 20.0), (0, 0.0, 1.0)],
        // the corner, the bin (9.0, 0.3), the water fountain (17.0, 0.2), the coat stand (23.0, 0.25)
        &[(0, 29.0, 1.0), (0, 9.0, 0.3), (0, 17.0, 0.2), (0, 23.0, 0.25)],
    ),
    (
        "building",
        // both corridors' south walls (y 4) and stair hall north walls (y 9); the railings
        // (4 cm thick) beside the stair opening upstairs; the flight downstairs and the
        // opening upstairs (x 12.9..15.9, y 6.9..8.1)
        &[
            (0, 10.0, 4.0),
            (1, 10.0, 4.0),
            (0, 14.0, 9.0),
            (1, 14.0, 9.0),
            (1, 14.0, 6.85),
            (1, 14.0, 8.15),
            (0, 14.0, 7.5),
            (1, 14.0, 7.5),
        ],
        // corridors (the plant pot upstairs at (6.0, 4.35)), the elevator on both floors
        &[(0, 6.0, 5.0), (1, 6.0, 4.35), (0, 19.0, 5.0), (1, 19.0, 5.0), (0, 12.4, 7.5)],
    ),
    ("approach", &[(0, 4.0, 0.0), (0, 4.0, -2.9), (0, 4.0, 2.9)], &[(0, 2.0, 0.0)]),
    (
        "step-down",
        // room walls, and the sunken area (x 3.2..4.8, y 0..4.4) the route must go round
        &[(0, 4.0, 0.0), (0, 8.0, 3.0), (0, 4.0, 6.0), (0, 0.0, 3.0), (0, 4.0, 2.5), (0, 3.3, 4.3)],
        // north of the sunken area
        &[(0, 4.0, 5.2)],
    ),
    // no walls at all; the head-high sign is no wall
    ("sign-ahead", &[], &[(0, 5.0, 0.0), (0, 4.9, 0.5)]),
    (
        "corridor-narrow",
        // south, east, north (first leg) and west (second leg) walls
        &[(0, 7.0, -0.05), (0, 14.85, 6.0), (0, 5.0, 1.65), (0, 13.15, 6.0)],
        // the corner, the bin (5.0, 0.2), the wall cabinet (9.0, 1.45), the flag sign (13.35, 7.0)
        &[(0, 14.0, 0.8), (0, 5.0, 0.2), (0, 9.0, 1.45), (0, 13.35, 7.0)],
    ),
    (
        "lobby-bench",
        // the four walls, and the sunken area (x 5.2..8.4, y 1.5..4.5)
        &[(0, 6.0, -0.05), (0, 12.05, 5.0), (0, 6.0, 10.05), (0, -0.05, 5.0), (0, 6.8, 3.0)],
        // the bench (4.3, 5.25), bollard 2 (2.2, 5.2), the planter (9.6, 6.3)
        &[(0, 4.3, 5.25), (0, 2.2, 5.2), (0, 9.6, 6.3)],
    ),
    (
        "hanging-lamp",
        &[(0, 4.5, -0.05), (0, 9.05, 3.5), (0, 4.5, 7.05), (0, -0.05, 3.5)],
        // under the lamp (4.5, 3.55), the table (2.5, 5.8)
        &[(0, 4.5, 3.55), (0, 2.5, 5.8)],
    ),
];

#[test]
fn every_builtin_world_has_known_walls_occupied_and_start_goal_and_furniture_free() {
    assert_eq!(KNOWN.map(|k| k.0), BUILTIN_WORLDS.map(|b| b.0), "a built-in world without known points");
    for (name, walls, free) in KNOWN {
        let (w, b) = exported(name);
        for &(floor, x, y) in walls {
            assert_eq!(cell_at(&b, floor, x, y), Some(Cell::Occupied), "{name}: floor {floor} ({x}, {y}) is a wall");
        }
        let (start, goal) = (w.start(), w.goal());
        let ends = [(start.floor, start.x_m, start.y_m), (goal.floor, goal.x_m, goal.y_m)];
        for &(floor, x, y) in free.iter().chain(&ends) {
            assert_eq!(cell_at(&b, floor, x, y), Some(Cell::Free), "{name}: floor {floor} ({x}, {y}) is free");
        }
    }
}

#[test]
fn every_builtin_world_keeps_its_doors_rooms_gateways_and_goal() {
    for (name, _) in BUILTIN_WORLDS {
        let (w, b) = exported(name);
        assert_eq!(
            b.floors().iter().map(|f| f.level).collect::<Vec<_>>(),
            w.floors().iter().map(|f| f.index).collect::<Vec<_>>(),
            "{name}"
        );
        let sum = |f: &dyn Fn(&map::Floor) -> usize| b.floors().iter().map(f).sum::<usize>();
        assert_eq!(sum(&|f| f.semantic.doors.len()), w.doors().len(), "{name}: doors");
        assert_eq!(sum(&|f| f.semantic.areas.len()), w.rooms().len(), "{name}: rooms");
        assert_eq!(sum(&|f| f.semantic.corners.len()), w.corners().len(), "{name}: corners");
        assert_eq!(b.gateways().len(), w.elevators().len() + w.stairs().len(), "{name}: gateways");
        for d in w.doors() {
            let door = b.floor(d.floor).and_then(|f| f.semantic.door(d.floor, &d.number));
            let door = door.unwrap_or_else(|| panic!("{name}: door {} missing", d.number));
            assert_eq!([door.x, door.y], d.at, "{name}: door {}", d.number);
            let facing = d.facing_deg.to_radians();
            assert!((door.normal[0] - facing.cos()).abs() < 1e-9 && (door.normal[1] - facing.sin()).abs() < 1e-9);
        }
        for r in w.rooms() {
            let semantic = &b.floor(r.floor).unwrap_or_else(|| panic!("{name}: floor {}", r.floor)).semantic;
            let centre = [(r.min[0] + r.max[0]) / 2.0, (r.min[1] + r.max[1]) / 2.0];
            let here: Vec<&str> =
                semantic.areas_at(r.floor, centre[0], centre[1]).iter().map(|a| a.name.as_str()).collect();
            assert!(here.contains(&r.label.as_str()), "{name}: {} at its centre: {here:?}", r.label);
            assert!(semantic.label(&r.label).is_some(), "{name}: no label {}", r.label);
        }
        // the goal is a label, found by its name where the walk ends
        let goal = w.goal();
        let label = b.floor(goal.floor).and_then(|f| f.semantic.label(&goal.label));
        let label = label.unwrap_or_else(|| panic!("{name}: no label for the goal {}", goal.label));
        assert_eq!((label.x, label.y, label.floor), (goal.x_m, goal.y_m, goal.floor), "{name}");
    }
}

#[test]
fn building_elevator_joins_floors_0_and_1_and_the_stairs_stop_at_the_foot_and_the_top() {
    let (w, b) = exported("building");
    let gateway = |name: &str| b.gateways().iter().find(|g| g.name == name).unwrap_or_else(|| panic!("{name}"));
    let elevator = gateway("elevator");
    assert_eq!((elevator.kind, elevator.floors()), (GatewayKind::Elevator, vec![0, 1]));
    for floor in [0, 1] {
        let stop = elevator.stop(floor).unwrap_or_else(|| panic!("floor {floor}"));
        assert_eq!([stop.x, stop.y], [19.0, 5.0]);
        assert!(b.floor(floor).is_some_and(|f| f.semantic.gateways.iter().any(|g| g.name == "elevator")));
    }
    let stairs = gateway("main stairs");
    assert_eq!((stairs.kind, stairs.floors()), (GatewayKind::Stairs, vec![0, 1]));
    // the flight rises east from (12.9, 7.5), 10 steps of 0.3 m: the foot half a metre
    // west of the first step, the top half a metre east of the last
    let (foot, top) = stair_stops(&w.stairs()[0]);
    let near = |p: [f64; 2], q: [f64; 2]| (p[0] - q[0]).hypot(p[1] - q[1]) < 1e-9;
    assert!(near(foot, [12.4, 7.5]) && near(top, [16.4, 7.5]), "{foot:?} {top:?}");
    let (f0, f1) = (stairs.stop(0).map(|s| [s.x, s.y]), stairs.stop(1).map(|s| [s.x, s.y]));
    assert!(f0.is_some_and(|p| near(p, foot)) && f1.is_some_and(|p| near(p, top)), "{f0:?} {f1:?}");
}

/// Every cell along the centre line of every wall of every floor of `w` (sampled every
/// quarter cell, the ends left out: a wall's end may lie on a cell's edge).
/// (world, obstacle band, points occupied on the mapped map and free on the floor plan,
/// points free on both).
type MappedCase = (&'static str, [f64; 2], &'static [(f64, f64)], &'static [(f64, f64)]);

#[test]
fn the_mapped_map_adds_the_furniture_in_the_camera_band_but_not_chairs_or_people() {
    let cases: [MappedCase; 3] = [
        // the head-high sign (1.55-1.85 m) and the waist-high board; chair 1, the start
        // and the goal stay free
        ("taylor-course", [0.04, 2.0], &[(4.5, 5.6), (7.3, 6.0)], &[(1.2, 7.6), (0.7, 5.0), (8.8, 9.0)]),
        // a band that ends under the sign leaves it off
        ("taylor-course", [0.04, 1.5], &[(7.3, 6.0)], &[(4.5, 5.6), (1.2, 7.6)]),
        // the bin, the water fountain and the coat stand; the people's lane is free
        ("corridor", [0.04, 2.0], &[(9.0, 0.3), (17.0, 0.2), (23.0, 0.25)], &[(10.0, 1.55), (29.4, 10.0)]),
    ];
    for (name, band, added, free) in cases {
        let w = world(name);
        let plan = export(&w, DEFAULT_RESOLUTION_M).unwrap_or_else(|e| panic!("{name}: {e}"));
        let mapped = export_as_mapped(&w, DEFAULT_RESOLUTION_M, band).unwrap_or_else(|e| panic!("{name}: {e}"));
        for &(x, y) in added {
            assert_eq!(
                cell_at(&mapped, 0, x, y),
                Some(Cell::Occupied),
                "{name} {band:?}: ({x}, {y}) on the mapped map"
            );
            assert_eq!(cell_at(&plan, 0, x, y), Some(Cell::Free), "{name}: ({x}, {y}) on the floor plan");
        }
        for &(x, y) in free {
            assert_eq!(cell_at(&mapped, 0, x, y), Some(Cell::Free), "{name} {band:?}: ({x}, {y})");
        }
        // the walls are the floor plan's: every cell occupied there is occupied here
        let (p, m) = (&plan.floor(0).unwrap().grid, &mapped.floor(0).unwrap().grid);
        assert_eq!((p.width(), p.height()), (m.width(), m.height()), "{name}: same grid");
        let lost = (0..p.height())
            .flat_map(|r| (0..p.width()).map(move |c| (c, r)))
            .filter(|&(c, r)| p.get(c, r) == Some(Cell::Occupied) && m.get(c, r) != Some(Cell::Occupied))
            .count();
        assert_eq!(lost, 0, "{name}: wall cells missing from the mapped map");
    }
}

fn assert_no_wall_gap(w: &World, b: &Building) {
    for floor in w.floors() {
        let grid = &b.floor(floor.index).unwrap_or_else(|| panic!("floor {}", floor.index)).grid;
        for (wall, id) in &floor.boxes {
            let Some(o) = w.obstacle(*id).filter(|o| o.kind == ObstacleKind::Wall) else { continue };
            let (s, c) = wall.yaw_rad.sin_cos();
            let half = wall.half_size_m[0];
            let n = (8.0 * half / grid.resolution_m()).ceil() as usize;
            for i in 0..n {
                let t = -half + 2.0 * half * (i as f64 + 0.5) / n as f64;
                let (x, y) = (wall.center_m[0] + c * t, wall.center_m[1] + s * t);
                assert_eq!(
                    grid.world_to_cell(x, y).and_then(|(col, row)| grid.get(col, row)),
                    Some(Cell::Occupied),
                    "{}: {} has a gap at ({x:.3}, {y:.3}) on floor {}",
                    w.name(),
                    o.label,
                    floor.index
                );
            }
        }
    }
}

#[test]
fn no_wall_of_a_builtin_world_has_a_gap() {
    for (name, _) in BUILTIN_WORLDS {
        let (w, b) = exported(name);
        assert_no_wall_gap(&w, &b);
    }
}

#[test]
fn no_wall_of_a_generated_world_has_a_gap_at_any_angle_thickness_or_resolution() {
    // walls nobody looked at: random ends, angles and thicknesses (2 mm to 30 cm)
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut text =
        String::from("name = \"generated\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 1.0, y_m = 1.0 }\n");
    for _ in 0..40 {
        let from = [next() * 12.0 - 6.0, next() * 12.0 - 6.0];
        let (angle, length) = (next() * std::f64::consts::TAU, 0.2 + next() * 5.0);
        let to = [from[0] + length * angle.cos(), from[1] + length * angle.sin()];
        let thickness = 0.002 + next() * 0.3;
        text.push_str(&format!(
            "[[walls]]\nfrom = [{}, {}]\nto = [{}, {}]\nthickness_m = {thickness}\n",
            from[0], from[1], to[0], to[1]
        ));
    }
    let w = World::from_toml(&text, "generated").unwrap_or_else(|e| panic!("{e}"));
    for resolution_m in [0.02, 0.05, 0.1, 0.25] {
        let b = export(&w, resolution_m).unwrap_or_else(|e| panic!("{e}"));
        assert_no_wall_gap(&w, &b);
    }
}

/// True when the segment a-b crosses no occupied cell (sampled every fifth of a cell).
fn clear_of_walls(grid: &OccupancyGrid, a: [f64; 2], b: [f64; 2]) -> bool {
    let n = ((a[0] - b[0]).hypot(a[1] - b[1]) / (grid.resolution_m() / 5.0)).ceil().max(1.0) as usize;
    (0..=n).all(|i| {
        let f = i as f64 / n as f64;
        let (x, y) = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
        grid.world_to_cell(x, y).and_then(|(c, r)| grid.get(c, r)) == Some(Cell::Free)
    })
}

#[test]
fn taylor_course_route_from_start_to_goal_winds_through_both_gaps_clear_of_walls() {
    let (w, b) = exported("taylor-course");
    let grid = &b.floor(0).unwrap_or_else(|| panic!("floor 0")).grid;
    let mut planner = Planner::new(0, grid, &NavGraphConfig::default());
    let (start, goal) = (w.start(), w.goal());
    let route = planner.plan([start.x_m, start.y_m], [goal.x_m, goal.y_m]).unwrap_or_else(|e| panic!("{e}"));
    for p in &route.points {
        assert_eq!(grid.world_to_cell(p[0], p[1]).and_then(|(c, r)| grid.get(c, r)), Some(Cell::Free), "{p:?}");
    }
    for leg in route.waypoints.windows(2) {
        assert!(clear_of_walls(grid, leg[0], leg[1]), "{leg:?} crosses a wall");
    }
    // north of divider 1 (ends at y 7.0), south of divider 2 (starts at y 3.0)
    assert!(route.points.iter().any(|p| (3.0..4.0).contains(&p[0]) && p[1] > 7.0), "north gap");
    assert!(route.points.iter().any(|p| (6.0..7.0).contains(&p[0]) && p[1] < 3.0), "south gap");
    // the scene's own floor-plan route, laid by hand down the middle of each lane, is
    // 19.9 m; the shortest at 0.3 m from the walls cuts the corners
    println!("taylor-course: {:.1} m, {} waypoints", route.length_m, route.waypoints.len());
    assert!((15.0..20.0).contains(&route.length_m), "{}", route.length_m);
    let end = route.waypoints.last().copied().unwrap_or_default();
    assert!((end[0] - goal.x_m).hypot(end[1] - goal.y_m) < 0.2, "{end:?}");
}

#[test]
fn building_route_from_the_ground_floor_entrance_to_room_204_upstairs_changes_floor_at_a_gateway() {
    let (w, b) = exported("building");
    let (start, goal) = (w.start(), w.goal());
    let in_room = |floor: i32, x: f64, y: f64| {
        b.floor(floor).map(|f| f.semantic.areas_at(floor, x, y).iter().map(|a| a.name.clone()).collect::<Vec<_>>())
    };
    assert_eq!(in_room(start.floor, start.x_m, start.y_m), Some(vec!["entrance".to_string()]));
    assert_eq!((goal.floor, goal.label.as_str()), (1, "room 204"));
    let mut planner = BuildingPlanner::new(&b, UserProfile::default());
    let from = FloorPoint { floor: start.floor, x: start.x_m, y: start.y_m };
    let to = FloorPoint { floor: goal.floor, x: goal.x_m, y: goal.y_m };
    let route = planner.plan(from, to).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(route.legs.len(), 2, "{route:?}");
    assert_eq!(route.legs.iter().map(|l| l.route.floor).collect::<Vec<_>>(), [0, 1]);
    let LegEnd::Gateway { name, to_floor, .. } = &route.legs[0].end else { panic!("{:?}", route.legs[0].end) };
    assert_eq!(*to_floor, 1);
    let gateway = b.gateways().iter().find(|g| &g.name == name).unwrap_or_else(|| panic!("{name}"));
    for leg in &route.legs {
        let grid = &b.floor(leg.route.floor).unwrap_or_else(|| panic!("floor")).grid;
        for p in &leg.route.points {
            let cell = grid.world_to_cell(p[0], p[1]).and_then(|(c, r)| grid.get(c, r));
            assert_eq!(cell, Some(Cell::Free), "floor {}: {p:?}", leg.route.floor);
        }
        for seg in leg.route.waypoints.windows(2) {
            assert!(clear_of_walls(grid, seg[0], seg[1]), "floor {}: {seg:?} crosses a wall", leg.route.floor);
        }
    }
    // the first leg ends at the gateway's stop downstairs, the second starts at its stop upstairs
    let near = |p: Option<&[f64; 2]>, floor: i32| {
        let s = gateway.stop(floor).unwrap_or_else(|| panic!("{name} on {floor}"));
        p.is_some_and(|p| (p[0] - s.x).hypot(p[1] - s.y) < 0.3)
    };
    assert!(near(route.legs[0].route.waypoints.last(), 0), "{name}");
    assert!(near(route.legs[1].route.waypoints.first(), 1), "{name}");
    let end = route.legs[1].route.waypoints.last().copied().unwrap_or_default();
    assert!((end[0] - goal.x_m).hypot(end[1] - goal.y_m) < 0.2, "{end:?}");
    println!("building: {name}, {:.1} m walked", route.walk_length_m);
}

#[test]
fn the_sample_map_in_the_repo_is_what_wearnav_map_writes_for_the_building_world() {
    let committed = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../maps/building/building.toml");
    let loaded = Building::load(&committed).unwrap_or_else(|e| panic!("{e}"));
    let (_, fresh) = exported("building");
    assert!(
        loaded == fresh,
        "maps/building differs from the world's floor plan: run `cargo run --release -- map --world building --out maps/building`"
    );
}

#[test]
fn a_generated_streets_plan_ends_with_its_pavement_so_no_route_crosses_the_road_or_goes_behind_the_building() {
    for name in ["gen:street:1", "gen:street:2"] {
        let (w, b) = exported(name);
        let ([x0, y0], [x1, y1]) = w.plan_extent(0).unwrap_or_else(|| panic!("{name}: no plan extent"));
        let grid = &b.floor(0).unwrap_or_else(|| panic!("{name}: floor 0")).grid;
        let (start, goal) = (w.start(), w.goal());
        let mid = (x0 + x1) / 2.0;
        // behind the building wall, past the pavement's end, across the road: before,
        // the map's margin was free floor there (a route went round the wall's end and
        // along the far side of the road)
        for (what, x, y) in [("behind the building", mid, y0 - 0.7), ("past the end", x0 - 1.5, start.y_m)] {
            assert_eq!(cell_at(&b, 0, x, y), Some(Cell::Unknown), "{name}: {what} ({x}, {y})");
        }
        assert_ne!(cell_at(&b, 0, mid, y1 + 2.5), Some(Cell::Free), "{name}: across the road");
        assert_eq!(cell_at(&b, 0, start.x_m, start.y_m), Some(Cell::Free), "{name}: the start");
        let mut planner = Planner::new(0, grid, &NavGraphConfig::default());
        let from = [start.x_m, start.y_m];
        let route = planner.plan(from, [goal.x_m, goal.y_m]).unwrap_or_else(|e| panic!("{name}: {e}"));
        for p in &route.points {
            assert!((x0..=x1).contains(&p[0]) && (y0..=y1).contains(&p[1]), "{name}: {p:?} off the pavement");
        }
        for (what, to) in [("behind the building", [mid, y0 - 0.8]), ("across the road", [mid, y1 + 2.5])] {
            match planner.plan(from, to) {
                Ok(r) => panic!("{name}: a route {what}: {:?}", r.waypoints),
                Err(e) => println!("{name}: {what}: {e}"),
            }
        }
    }
}
