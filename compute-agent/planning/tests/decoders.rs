//! Property tests of the Moving AI benchmark readers (`MovingAiMap::parse`,
//! `parse_scenarios`): mutated valid files and random bytes must give a value or a
//! [`MovingAiError`] naming the file and a line in it: never a panic, never an
//! allocation beyond the size limits (`map::MAX_CELLS`, and the text's own size),
//! never a hang.
//!
//! Seeds: the benchmark files in `tests/data` (arena, den312d and their scenarios) and
//! small ones made here (CRLF lines, every terrain letter, a citation after the rows).
//! CI runs a bounded number of cases (`CASES`, see `docs/fuzzing.md`); `wearnav fuzz`
//! runs millions on demand. `PROPTEST_CASES=N` sets the cases per property.

use std::path::Path;
use std::sync::LazyLock;

use decoder_props::{config, measured, mutated, mutation_with, within, LargestAllocation};
use planning::movingai::{parse_scenarios, MovingAiError, MovingAiMap, Scenario};
use proptest::prelude::*;
use proptest::sample::Index;

#[global_allocator]
static ALLOCATOR: LargestAllocation = LargestAllocation;

/// Text that header and field parsers meet with edge cases.
static TOKENS: [&str; 20] = [
    "4294967295",
    "18446744073709551615",
    "99999999999999999999",
    "-1",
    "0",
    "nan",
    ".nan",
    "inf",
    "-1e400",
    "1e308",
    "\n",
    " ",
    "\"",
    "[",
    "]]",
    "=",
    "\nmap\n",
    "\t- ",
    "# ",
    "\theight 9\t",
];

/// Cases per property in CI (measured numbers in `docs/fuzzing.md`).
const CASES: u32 = 50_000;

// ---------------------------------------------------------------------------------
// Seeds.

fn map_seeds() -> Vec<Vec<u8>> {
    vec![
        include_bytes!("data/arena.map").to_vec(),
        include_bytes!("data/den312d.map").to_vec(),
        b"type octile\r\nheight 2\r\nwidth 3\r\nmap\r\n.@G\r\nS.T\r\n".to_vec(),
        b"type octile\nwidth 5\nheight 3\nmap\n..W..\nT@.GS\n.....\ncited: Sturtevant 2012\n".to_vec(),
    ]
}

fn scenario_seeds() -> Vec<Vec<u8>> {
    vec![
        include_bytes!("data/arena.map.scen").to_vec(),
        include_bytes!("data/den312d.map.scen").to_vec(),
        b"version 1\r\n0\tm.map\t3\t2\t0\t1\t2\t0\t2.41421356\r\ncitation line\n3\tm.map\t3\t2\t2\t1\t0\t0\t1e0\n"
            .to_vec(),
    ]
}

static MAP_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(map_seeds);
static SCENARIO_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(scenario_seeds);

// ---------------------------------------------------------------------------------
// Checks.

/// The error names the file and a line within the text.
fn check_error(e: &MovingAiError, file: &Path, text: &str) -> Result<(), String> {
    let message = e.to_string();
    if !message.starts_with(&format!("{}:", file.display())) {
        return Err(format!("error does not name {}: {message}", file.display()));
    }
    match e {
        MovingAiError::Format { line, .. } if *line == 0 || *line > text.lines().count().max(1) => {
            Err(format!("line {line} of a {}-line file: {message}", text.lines().count()))
        }
        _ => Ok(()),
    }
}

/// Largest single allocation a map parse may make: a `bool` a cell, every cell a byte
/// of the text, so about the text's size.
fn map_bound(len: usize) -> usize {
    2 * len + 64 * 1024
}

fn check_map(bytes: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz.map");
    let text = String::from_utf8_lossy(bytes);
    let (result, largest, took) = measured(|| MovingAiMap::parse(&text, file));
    within("map", largest, map_bound(text.len()), took)?;
    match result {
        Ok(m) if m.passable.len() != m.width * m.height || m.width * m.height > map::MAX_CELLS as usize => {
            Err(format!("{}x{} map of {} cells", m.width, m.height, m.passable.len()))
        }
        Ok(m) => {
            // a map that parses is a grid the planner can take
            let grid = m.to_grid();
            if grid.cells().len() == m.passable.len() {
                Ok(())
            } else {
                Err("grid size differs".into())
            }
        }
        Err(e) => check_error(&e, file, &text),
    }
}

/// Largest single allocation a scenario parse may make: a 48-byte scenario per line of
/// at least 18 bytes (the list doubles as it grows), a line's fields (16 bytes each, a
/// field per tab): a few times the text.
fn scenario_bound(len: usize) -> usize {
    16 * len + 64 * 1024
}

fn check_scenarios(bytes: &[u8]) -> Result<(), String> {
    let file = Path::new("fuzz.scen");
    let text = String::from_utf8_lossy(bytes);
    let (result, largest, took) = measured(|| parse_scenarios(&text, file));
    within("scenarios", largest, scenario_bound(text.len()), took)?;
    match result {
        Ok(list) if list.len() > text.lines().count() => Err(format!("{} scenarios from fewer lines", list.len())),
        Ok(_) => Ok(()),
        Err(e) => check_error(&e, file, &text),
    }
}

#[test]
fn every_seed_is_valid() {
    for (i, s) in map_seeds().iter().enumerate() {
        let m = MovingAiMap::parse(std::str::from_utf8(s).expect("UTF-8"), Path::new("seed.map"))
            .unwrap_or_else(|e| panic!("map seed {i}: {e}"));
        assert!(m.passable.iter().any(|&p| p), "map seed {i}");
    }
    for (i, s) in scenario_seeds().iter().enumerate() {
        let list = parse_scenarios(std::str::from_utf8(s).expect("UTF-8"), Path::new("seed.scen"))
            .unwrap_or_else(|e| panic!("scenario seed {i}: {e}"));
        assert!(!list.is_empty(), "scenario seed {i}");
    }
}

proptest! {
    #![proptest_config(config(CASES))]

    #[test]
    fn mutated_maps_parse_to_their_size_or_are_refused_with_the_line(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
    ) {
        let outcome = check_map(&mutated(&MAP_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_scenarios_parse_or_are_refused_with_the_line(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation_with(&TOKENS), 1..6),
    ) {
        let outcome = check_scenarios(&mutated(&SCENARIO_SEEDS, &seed, &mutations));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }
}

proptest! {
    // Random bytes rarely get past the first line: fewer cases.
    #![proptest_config(config(CASES / 4))]

    #[test]
    fn random_bytes_are_refused_by_both_readers(bytes in prop::collection::vec(any::<u8>(), 0..1024)) {
        for outcome in [check_map(&bytes), check_scenarios(&bytes)] {
            prop_assert!(outcome.is_ok(), "{:?}", outcome);
        }
    }
}

// ---------------------------------------------------------------------------------
// Forged sizes: refused before allocating, without overflowing.

#[test]
fn map_headers_declaring_huge_or_overflowing_sizes_are_refused_before_allocating() {
    for (h, w) in [
        ("8192", "8192"),
        ("67108864", "1"),
        ("8589934592", "8589934592"),
        ("18446744073709551615", "18446744073709551615"),
        ("100000", "100000"),
    ] {
        let text = format!("type octile\nheight {h}\nwidth {w}\nmap\n....\n");
        let (result, largest, _) = measured(|| MovingAiMap::parse(&text, Path::new("forged.map")));
        assert!(matches!(result, Err(MovingAiError::Format { .. })), "{h} x {w}: {result:?}");
        assert!(largest < 4096, "{h} x {w}: allocated {largest} bytes at once");
    }
}

#[test]
fn scenario_fields_out_of_range_are_refused_with_the_line() {
    let text = "version 1\n0\tm\t1\t1\t0\t0\t0\t0\t1.0\n0\tm\t1\t1\t18446744073709551616\t0\t0\t0\t1.0\n";
    let e = parse_scenarios(text, Path::new("big.scen")).unwrap_err();
    assert!(e.to_string().starts_with("big.scen:3:"), "{e}");
    let ok = parse_scenarios("0\tm\t1\t1\t1\t2\t3\t4\t5\n", Path::new("s.scen")).expect("parses");
    assert_eq!(ok, vec![Scenario { bucket: 0, start: (1, 2), goal: (3, 4), optimal: 5.0 }]);
}
