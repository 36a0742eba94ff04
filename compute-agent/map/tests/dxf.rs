//! The sample floor plan `tests/data/floor.dxf` (written by ezdxf, see
//! `make_floor_dxf.py` there): walls, doors, rooms and labels where the generator put
//! them, and every room reachable from the corridor for a user who keeps 0.3 m from
//! walls, once the door swings are left out by layer.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use map::dxf::DxfImport;
use map::{inflate, write_map, Building, Cell, DxfFloor, Floor, OccupancyGrid, Units};

fn sample() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/floor.dxf")
}

fn walls_only() -> DxfImport {
    DxfImport { wall_layers: Some(vec!["WALLS".into()]), ..DxfImport::default() }
}

fn cell(floor: &DxfFloor, x: f64, y: f64) -> Cell {
    let (c, r) = floor.grid.world_to_cell(x, y).expect("inside the grid");
    floor.grid.get(c, r).expect("inside the grid")
}

/// Where the generator wrote each name (its `LABELS`), metres.
const LABELS: [(&str, f64, f64); 7] = [
    ("room 101", 3.5, 2.5),
    ("room 102", 10.5, 2.5),
    ("toilets", 17.0, 2.5),
    ("room 103", 5.0, 9.0),
    ("room 104", 16.5, 9.5),
    ("entrance", 1.0, 6.0),
    ("main corridor", 10.0, 6.0),
];

/// The door openings (wall y, from x, to x) and the entrance (x = 0, y 5.5 to 6.5).
const DOORS: [(f64, f64, f64); 5] =
    [(5.0, 3.0, 3.9), (5.0, 10.0, 10.9), (5.0, 16.0, 16.9), (7.0, 4.0, 4.9), (7.0, 14.0, 14.9)];

#[test]
fn sample_floor_has_its_walls_rooms_doors_and_columns() {
    let f = walls_only().load(&sample()).unwrap();
    assert_eq!(f.report.units, Units::Millimetres);
    assert_eq!(f.report.version, "AC1027");
    assert_eq!(f.report.extent_m, [0.0, 0.0, 20.0, 12.0]);
    assert_eq!(f.grid.resolution_m(), 0.05);
    // 20 x 12 m, 0.5 m margin and half a 0.15 m wall each side, on a 5 cm lattice
    assert_eq!((f.grid.width(), f.grid.height()), (424, 264));
    for (x, y) in [
        (0.0, 2.0),  // west outer wall
        (0.0, 9.0),  // west outer wall north of the entrance
        (20.0, 5.0), // east
        (10.0, 0.0), // south
        (10.0, 12.0),
        (7.0, 2.5), // partitions
        (14.0, 2.5),
        (10.0, 9.5),
        (1.5, 5.0), // corridor walls
        (8.0, 7.0),
        (18.0 + 2f64.sqrt(), 10.0 + 2f64.sqrt()), // the rounded corner
        (3.15, 10.5),                             // a column (an INSERT of a block)
        (6.85, 10.5),
    ] {
        assert_eq!(cell(&f, x, y), Cell::Occupied, "({x}, {y})");
    }
    for (wall_y, x0, x1) in DOORS {
        for k in 1..18 {
            let x = x0 + (x1 - x0) * k as f64 / 18.0;
            assert_eq!(cell(&f, x, wall_y), Cell::Free, "door at y = {wall_y}, x = {x}");
        }
    }
    for y in [5.55, 6.0, 6.45] {
        assert_eq!(cell(&f, 0.0, y), Cell::Free, "entrance at y = {y}");
    }
    // inside the rooms, the column's middle, under the table (furniture is not a wall)
    for (x, y) in [(3.0, 10.5), (13.0, 9.0), (19.0, 11.0), (12.0, 6.0)] {
        assert_eq!(cell(&f, x, y), Cell::Free, "({x}, {y})");
    }
    // beyond the drawing: unknown
    assert_eq!(cell(&f, -0.3, 6.0), Cell::Unknown);
    assert_eq!(cell(&f, 10.0, 12.3), Cell::Unknown);
    // what the plan holds that a floor map does not
    assert_eq!(f.report.skipped.get("DIMENSION"), Some(&1));
    assert_eq!(f.report.skipped.get("HATCH"), Some(&1));
    assert_eq!(f.report.layers, ["DOORS", "FURNITURE", "TEXT", "WALLS"]);
}

#[test]
fn sample_floor_labels_are_where_the_texts_are() {
    let f = walls_only().load(&sample()).unwrap();
    let mut names: Vec<&str> = f.semantic.labels.iter().map(|l| l.name.as_str()).collect();
    names.sort();
    let mut expected: Vec<&str> = LABELS.iter().map(|l| l.0).collect();
    expected.sort();
    assert_eq!(names, expected);
    for (name, x, y) in LABELS {
        let l = f.semantic.label(name).unwrap();
        assert!((l.x - x).abs() < 1e-9 && (l.y - y).abs() < 1e-9, "{name} at ({}, {})", l.x, l.y);
        assert_eq!(l.floor, 0);
        assert_eq!(cell(&f, x, y), Cell::Free, "{name}");
    }
}

/// Free cells reachable from (x, y) by 4-connected steps.
fn reachable(grid: &OccupancyGrid, x: f64, y: f64) -> Vec<bool> {
    let (w, h) = (grid.width(), grid.height());
    let mut seen = vec![false; w * h];
    let start = grid.world_to_cell(x, y).expect("inside");
    let mut queue = VecDeque::from([start]);
    seen[start.1 * w + start.0] = true;
    while let Some((c, r)) = queue.pop_front() {
        for (dc, dr) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
            let (nc, nr) = (c as i64 + dc, r as i64 + dr);
            if nc < 0 || nr < 0 || nc >= w as i64 || nr >= h as i64 {
                continue;
            }
            let (nc, nr) = (nc as usize, nr as usize);
            if !seen[nr * w + nc] && grid.get(nc, nr) == Some(Cell::Free) {
                seen[nr * w + nc] = true;
                queue.push_back((nc, nr));
            }
        }
    }
    seen
}

#[test]
fn every_room_is_reachable_through_its_door_once_door_swings_are_left_out() {
    let walls = walls_only().load(&sample()).unwrap();
    // a user keeping the planner's 0.3 m from walls and unmapped space
    let inflated = inflate(&walls.grid, 0.3);
    let seen = reachable(&inflated, 10.0, 6.0);
    for (name, x, y) in LABELS {
        let (c, r) = inflated.world_to_cell(x, y).unwrap();
        assert!(seen[r * inflated.width() + c], "{name} cannot be reached from the corridor");
    }
    // every layer (the default): the door swings close the rooms behind the doors
    let all = DxfImport::default().load(&sample()).unwrap();
    assert_eq!(cell(&all, 13.0, 9.0), Cell::Occupied, "the table's edge is a wall now");
    let seen = reachable(&inflate(&all.grid, 0.3), 10.0, 6.0);
    let (c, r) = all.grid.world_to_cell(3.5, 2.5).unwrap();
    assert!(!seen[r * all.grid.width() + c], "room 101 behind its door swing");
}

#[test]
fn sample_floor_writes_a_building_that_loads_back() {
    let f = walls_only().load(&sample()).unwrap();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("map-dxf-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let building =
        Building::new(vec![Floor { level: 0, grid: f.grid.clone(), semantic: f.semantic.clone() }], &sample()).unwrap();
    building.write(&dir.join("building.toml")).unwrap();
    let back = Building::load(&dir.join("building.toml")).unwrap();
    assert_eq!(back.floors()[0].grid, f.grid);
    assert_eq!(back.floors()[0].semantic, f.semantic);
    write_map(&f.grid, &dir.join("again.yaml")).unwrap();
}
