//! Every scenario of the Moving AI files in tests/data solved to the optimal length.

use std::path::{Path, PathBuf};

use planning::movingai::{load_scenarios, run_scenarios, MovingAiMap};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn check(map_name: &str, expected_scenarios: usize) {
    let map = MovingAiMap::load(&data(map_name)).unwrap();
    let scen = load_scenarios(&data(&format!("{map_name}.scen"))).unwrap();
    assert_eq!(scen.len(), expected_scenarios);
    let report = run_scenarios(&map, &scen, || 0.0);
    assert_eq!(report.results.len(), expected_scenarios);
    for r in &report.results {
        assert!(r.error < 1e-4, "{map_name} {:?}: got {:?}, optimal {}", r.scenario, r.length, r.scenario.optimal);
    }
    assert!(report.max_error < 1e-4);
}

#[test]
fn arena_every_scenario_is_optimal() {
    let map = MovingAiMap::load(&data("arena.map")).unwrap();
    assert_eq!((map.width, map.height), (49, 49));
    check("arena.map", 130);
}

#[test]
fn den312d_every_scenario_is_optimal() {
    let map = MovingAiMap::load(&data("den312d.map")).unwrap();
    assert_eq!((map.width, map.height), (65, 81));
    check("den312d.map", 290);
}
