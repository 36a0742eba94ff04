//! `wearnav map` and `wearnav plan` as a user runs them: the real binary on files in
//! the repository and files it wrote.

use std::path::Path;
use std::process::Command;

fn wearnav(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("wearnav runs");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

#[test]
fn plan_runs_a_moving_ai_benchmark_and_every_length_is_optimal() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("compute-agent/planning/tests/data");
    let map = data.join("arena.map");
    let scen = data.join("arena.map.scen");
    let (ok, out, err) =
        wearnav(&["plan", "--movingai", map.to_str().unwrap(), "--scen", scen.to_str().unwrap(), "--json"]);
    assert!(ok, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).expect("JSON report");
    assert_eq!(report["scenarios"], 130);
    assert_eq!(report["unsolved"], 0);
    assert!(report["max_error"].as_f64().unwrap() < 1e-4, "{}", report["max_error"]);
    let first = &report["results"][0];
    assert!((first["length"].as_f64().unwrap() - first["optimal"].as_f64().unwrap()).abs() < 1e-4);
}

#[test]
fn map_mapped_writes_the_furniture_a_mapping_run_would_record_and_the_plan_does_not() {
    let occupied_at = |mapped: bool, x: f64, y: f64| {
        let dir = tempfile::Builder::new().prefix(&format!("wearnav-map-mapped-{mapped}-")).tempdir().unwrap();
        let mut args = vec!["map", "--world", "taylor-course", "--out", dir.path().to_str().unwrap()];
        if mapped {
            args.push("--mapped");
        }
        let (ok, _, err) = wearnav(&args);
        assert!(ok, "{err}");
        let building = map::Building::load(&dir.path().join("building.toml")).unwrap_or_else(|e| panic!("{e}"));
        let g = &building.floor(0).expect("floor 0").grid;
        let cell = g.world_to_cell(x, y).and_then(|(c, r)| g.get(c, r));
        cell == Some(map::Cell::Occupied)
    };
    // the head-high sign over the middle lane: on the mapped map only
    assert!(occupied_at(true, 4.5, 5.6) && !occupied_at(false, 4.5, 5.6));
    // chair 1 on neither (it moves)
    assert!(!occupied_at(true, 1.2, 7.6));
    let (ok, _, err) = wearnav(&["map", "--dxf", "x.dxf", "--mapped", "--out", "/tmp/never"]);
    assert!(!ok && err.contains("cannot be used with"), "{err}");
}

#[test]
fn a_world_exported_by_map_is_planned_on_by_label_and_unknown_places_are_named() {
    let scratch = tempfile::Builder::new().prefix("wearnav-plan-cli-").tempdir().unwrap();
    let dir = scratch.path();
    let (ok, out, err) = wearnav(&["map", "--world", "building", "--out", dir.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(out.contains("floor 0: 442x240 cells at 0.05 m"), "{out}");
    for file in
        ["building.toml", "floor0.yaml", "floor0.pgm", "floor0.toml", "floor1.yaml", "floor1.pgm", "floor1.toml"]
    {
        assert!(dir.join(file).is_file(), "{file} not written");
    }
    let yaml = dir.join("floor0.yaml");
    let semantic = dir.join("floor0.toml");
    let plan = |to: &str| {
        wearnav(&[
            "plan",
            "--map",
            yaml.to_str().unwrap(),
            "--semantic",
            semantic.to_str().unwrap(),
            "--from",
            "1,5",
            "--to",
            to,
            "--json",
        ])
    };
    let (ok, out, err) = plan("stair hall");
    assert!(ok, "{err}");
    let route: serde_json::Value = serde_json::from_str(&out).expect("JSON route");
    assert_eq!(route["to_label"], "stair hall");
    let length = route["length_m"].as_f64().unwrap();
    // the straight line is 13.1 m; the route keeps 0.3 m from the walls
    assert!((13.0..14.5).contains(&length), "{length} m");
    // what a walker would hear along it, from the guidance crate
    let heard: Vec<&str> =
        route["instructions"].as_array().unwrap().iter().map(|i| i["text"].as_str().unwrap()).collect();
    assert!(heard.first().is_some_and(|t| t.starts_with("Route to stair hall")), "{heard:?}");
    assert_eq!(heard.last(), Some(&"You have arrived at stair hall."), "{heard:?}");
    assert!(heard.iter().any(|t| t.contains("turn slightly left")), "{heard:?}");
    let (ok, _, err) = plan("room 999");
    assert!(!ok);
    assert!(err.contains("no place called \"room 999\"") && err.contains("stair hall"), "{err}");
    let (ok, _, err) = plan("-3,5");
    assert!(!ok);
    assert!(err.contains("outside the floor map") || err.contains("not walkable"), "{err}");
}
