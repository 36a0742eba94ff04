//! The loader, the writer and every refusal, on a map that ROS map_saver wrote.

use std::path::{Path, PathBuf};

use map::{load_map, write_map, Building, Cell, DistanceField, MapError, OccupancyGrid, SemanticLayer};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

/// A fresh folder per test under the target directory (no temp-file crate needed).
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("map-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const YAML: &str = "image: m.pgm\nresolution: 0.05\norigin: [-10.0, -10.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";

fn load_pair(name: &str, yaml: &str, image_name: &str, image: &[u8]) -> Result<OccupancyGrid, MapError> {
    let dir = scratch(name);
    std::fs::write(dir.join("m.yaml"), yaml).unwrap();
    std::fs::write(dir.join(image_name), image).unwrap();
    load_map(&dir.join("m.yaml"))
}

#[test]
fn turtlebot3_world_loads_with_the_values_map_saver_wrote() {
    let g = load_map(&data("map.yaml")).unwrap();
    assert_eq!((g.width(), g.height()), (384, 384));
    assert_eq!(g.resolution_m(), 0.05);
    assert_eq!((g.origin().x_m, g.origin().y_m, g.origin().yaw_rad), (-10.0, -10.0, 0.0));
    assert_eq!(g.count(Cell::Free), 7939);
    assert_eq!(g.count(Cell::Occupied), 795);
    assert_eq!(g.count(Cell::Unknown), 138_722);
    // the first occupied pixel in file order is image row 132, column 184: the top of
    // the map, so grid row 383 - 132 = 251
    assert_eq!(g.get(184, 383 - 132), Some(Cell::Occupied));
    assert_eq!(g.get(183, 383 - 132), Some(Cell::Unknown));
    // free cells span image rows 132..=233, i.e. grid rows 150..=251
    let free_rows: Vec<usize> = (0..384).filter(|&r| (0..384).any(|c| g.get(c, r) == Some(Cell::Free))).collect();
    assert_eq!((free_rows[0], *free_rows.last().unwrap()), (150, 251));
    // and the robot's start (0, 0) in the world is free, as in the TurtleBot3 tutorial
    let (c, r) = g.world_to_cell(0.0, 0.0).unwrap();
    assert_eq!((c, r), (200, 200));
}

#[test]
fn written_map_reads_back_identical() {
    let g = load_map(&data("map.yaml")).unwrap();
    let dir = scratch("roundtrip");
    let pgm = write_map(&g, &dir.join("copy.yaml")).unwrap();
    assert_eq!(pgm, dir.join("copy.pgm"));
    let back = load_map(&dir.join("copy.yaml")).unwrap();
    assert_eq!(back, g);
    // byte for byte the pixels map_saver wrote (its header comment differs)
    let ours = std::fs::read(&pgm).unwrap();
    let theirs = std::fs::read(data("map.pgm")).unwrap();
    assert_eq!(ours[ours.len() - 384 * 384..], theirs[theirs.len() - 384 * 384..]);
}

#[test]
fn png_image_gives_the_same_grid_as_the_pgm() {
    let g = load_map(&data("map.yaml")).unwrap();
    let theirs = std::fs::read(data("map.pgm")).unwrap();
    let pixels = &theirs[theirs.len() - 384 * 384..];
    let mut png_bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png_bytes, 384, 384);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        enc.write_header().unwrap().write_image_data(pixels).unwrap();
    }
    let yaml = std::fs::read_to_string(data("map.yaml")).unwrap().replace("map.pgm", "m.png");
    assert_eq!(load_pair("png", &yaml, "m.png", &png_bytes).unwrap(), g);
}

#[test]
fn distance_field_on_turtlebot3_world() {
    let g = load_map(&data("map.yaml")).unwrap();
    let f = DistanceField::to_occupied(&g);
    assert_eq!(f.get(184, 251), Some(0.0));
    // every free cell is within 2 m of a wall in this small arena, none is on one
    let free_d: Vec<f32> =
        g.cells().iter().zip(f.distances_m()).filter(|(c, _)| **c == Cell::Free).map(|(_, d)| *d).collect();
    assert!(free_d.iter().all(|&d| d > 0.0 && d < 2.0));
    let inflated = map::inflate(&g, 0.2);
    assert!(inflated.count(Cell::Free) < g.count(Cell::Free));
    assert_eq!(inflated.count(Cell::Unknown), g.count(Cell::Unknown));
}

#[test]
fn every_bad_input_is_refused_with_a_clear_error() {
    let pgm_2x2 = b"P5\n2 2\n255\n\x00\xfe\xcd\xfe";
    assert!(load_pair("ok", YAML, "m.pgm", pgm_2x2).is_ok());

    let e = load_pair("yaml", "image: m.pgm\nresolution: [oops\n", "m.pgm", pgm_2x2).unwrap_err();
    assert!(matches!(e, MapError::Yaml { line: 2.., .. }), "{e}");
    assert!(e.to_string().contains("m.yaml:"), "{e}");

    let e = load_pair("empty", YAML, "m.pgm", b"P5\n0 0\n255\n").unwrap_err();
    assert!(matches!(e, MapError::Empty { width: 0, height: 0, .. }), "{e}");

    for res in ["0", "-0.05", ".nan", "11.0"] {
        let e = load_pair("res", &YAML.replace("0.05", res), "m.pgm", pgm_2x2).unwrap_err();
        assert!(matches!(e, MapError::Resolution { .. }), "{res}: {e}");
    }

    let e = load_pair("short", YAML, "m.pgm", b"P5\n3 3\n255\n\x00\x00").unwrap_err();
    assert!(matches!(e, MapError::SizeMismatch { expected: 9, found: 2, .. }), "{e}");
    assert!(e.to_string().contains("m.pgm"), "{e}");

    let e = load_pair("thresh", &YAML.replace("free_thresh: 0.196", "free_thresh: 0.8"), "m.pgm", pgm_2x2).unwrap_err();
    assert!(matches!(e, MapError::Thresholds { .. }), "{e}");

    let e = load_pair("ext", &YAML.replace("m.pgm", "m.bmp"), "m.bmp", b"BM").unwrap_err();
    assert!(matches!(e, MapError::UnknownImageFormat { ref extension, .. } if extension == "bmp"), "{e}");

    let e = load_pair("pgm", YAML, "m.pgm", b"P5\n# comment\n2 x\n255\n").unwrap_err();
    assert!(matches!(e, MapError::Pgm { line: 3, .. }), "{e}");
    assert!(e.to_string().contains("m.pgm:3:"), "{e}");

    let e = load_pair("png", &YAML.replace("m.pgm", "m.png"), "m.png", b"\x89PNG\r\n\x1a\nnot really").unwrap_err();
    assert!(matches!(e, MapError::Png { .. }), "{e}");

    let e = load_pair("huge", YAML, "m.pgm", b"P5\n60000 60000\n255\n").unwrap_err();
    assert!(matches!(e, MapError::TooLarge { .. }), "{e}");

    let e = load_pair("missing", &YAML.replace("m.pgm", "gone.pgm"), "m.pgm", pgm_2x2).unwrap_err();
    assert!(matches!(e, MapError::Io { .. }) && e.to_string().contains("gone.pgm"), "{e}");
}

#[test]
fn building_written_and_loaded_keeps_floors_and_gateways() {
    let dir = scratch("building");
    let g = load_map(&data("map.yaml")).unwrap();
    let layer = SemanticLayer::parse(
        r#"
[[label]]
name = "lobby"
x = 0.0
y = 0.0
floor = 0

[[label]]
name = "room 101"
x = 1.0
y = 0.5
floor = 1

[[gateway]]
name = "lift"
type = "elevator"
stops = [ { floor = 0, x = 0.5, y = 0.0 }, { floor = 1, x = 0.5, y = 0.0 } ]
"#,
        Path::new("inline.toml"),
    )
    .unwrap();
    let floors = [0, 1].map(|level| map::Floor { level, grid: g.clone(), semantic: layer.floor(level) });
    let b = Building::new(floors.to_vec(), Path::new("inline")).unwrap();
    b.write(&dir.join("building.toml")).unwrap();
    let back = Building::load(&dir.join("building.toml")).unwrap();
    assert_eq!(back, b);
    assert_eq!(back.gateways().len(), 1);
    assert_eq!(back.floor(1).unwrap().semantic.labels[0].name, "room 101");

    // a stop on a floor the building lacks is refused
    let mut one = floors[0].clone();
    one.semantic.gateways[0].stops[1].floor = 7;
    let e = Building::new(vec![one], Path::new("b.toml")).unwrap_err();
    assert!(e.to_string().contains("floor 7"), "{e}");
}

#[test]
fn floors_heights_are_written_and_read_back_and_bad_ones_refused_with_the_floor_named() {
    let dir = scratch("elevations");
    let g = load_map(&data("map.yaml")).unwrap();
    let floors: Vec<map::Floor> =
        [0, 1, 2].map(|level| map::Floor { level, grid: g.clone(), semantic: Default::default() }).to_vec();
    let file = Path::new("inline");
    let b = Building::new(floors.clone(), file).unwrap();
    assert_eq!(b.elevation(1), None, "no heights unless given");
    let b = b.with_elevations(&[(0, 0.0), (1, 3.6), (2, 7.0)], file).unwrap();
    b.write(&dir.join("building.toml")).unwrap();
    let text = std::fs::read_to_string(dir.join("building.toml")).unwrap();
    assert!(text.contains("elevation_m = 3.6"), "{text}");
    let back = Building::load(&dir.join("building.toml")).unwrap();
    assert_eq!(back, b);
    assert_eq!((back.elevation(0), back.elevation(2), back.elevation(5)), (Some(0.0), Some(7.0), None));

    let refused = |e: &[(i32, f64)]| Building::new(floors.clone(), file).unwrap().with_elevations(e, file).unwrap_err();
    for (given, says) in [
        (&[(0, 0.0), (1, 3.6)][..], "floor 2 has no elevation_m"),
        (&[(0, 0.0), (1, 3.6), (2, 3.0)][..], "floor 2 (3 m) is not above floor 1 (3.6 m)"),
        (&[(0, 0.0), (1, f64::NAN), (2, 7.0)][..], "floor 1's elevation NaN is no height"),
        (&[(0, 0.0), (1, 3.6), (2, 7.0), (4, 9.0)][..], "floor 4, which the building lacks"),
    ] {
        let e = refused(given).to_string();
        assert!(e.contains(says), "{e}");
    }
    // in a manifest too
    std::fs::write(
        dir.join("building.toml"),
        text.replace("elevation_m = 3.6", "elevation_m = 30.0").replace("elevation_m = 7.0", "elevation_m = 20.0"),
    )
    .unwrap();
    let e = Building::load(&dir.join("building.toml")).unwrap_err().to_string();
    assert!(e.contains("floor 2 (20 m) is not above floor 1 (30 m)"), "{e}");
}
