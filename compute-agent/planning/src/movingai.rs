//! The Moving AI grid benchmarks (Sturtevant 2012, "Benchmarks for Grid-Based
//! Pathfinding"): `.map` files (`type octile`, `height`, `width`, `map`, then the rows;
//! `.`, `G` and `S` passable; anything after the rows, such as a citation, is ignored) and `.scen` files (`version 1`, then tab-separated
//! `bucket map width height start_x start_y goal_x goal_y optimal_length`, width before
//! height; lines without 9 fields are skipped). Optimal lengths are octile with no
//! corner cutting, exactly what [`NavGraph`] builds with a 1-cell spacing and no clearance.

use std::path::{Path, PathBuf};

use map::{Cell, OccupancyGrid, Origin};

use crate::astar::AStar;
use crate::nav_graph::{NavGraph, NavGraphConfig};

/// Why a benchmark file was refused.
#[derive(Debug, thiserror::Error)]
pub enum MovingAiError {
    /// The file could not be read.
    #[error("{file}: cannot read: {source}")]
    Io {
        /// the file
        file: PathBuf,
        /// the OS error
        source: std::io::Error,
    },
    /// The file is not in the format.
    #[error("{file}:{line}: {message}")]
    Format {
        /// the file
        file: PathBuf,
        /// 1-based line
        line: usize,
        /// what is wrong
        message: String,
    },
}

/// A benchmark map: passable cells, row 0 at the top as in the file.
#[derive(Clone, Debug, PartialEq)]
pub struct MovingAiMap {
    /// columns
    pub width: usize,
    /// rows
    pub height: usize,
    /// row-major, row 0 = first row of the file
    pub passable: Vec<bool>,
}

/// One query with its optimal length.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// difficulty bucket
    pub bucket: u32,
    /// start column, row
    pub start: (usize, usize),
    /// goal column, row
    pub goal: (usize, usize),
    /// the file's optimal octile length
    pub optimal: f64,
}

/// One scenario's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct ScenarioResult {
    /// the query
    pub scenario: Scenario,
    /// our length (`None`: no path found)
    pub length: Option<f64>,
    /// |length - optimal| (infinite when no path)
    pub error: f64,
    /// time for the query, milliseconds
    pub ms: f64,
}

/// Every scenario of a file, and the summary figures.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchmarkReport {
    /// per scenario
    pub results: Vec<ScenarioResult>,
    /// largest |length - optimal|
    pub max_error: f64,
    /// mean query time, milliseconds
    pub mean_ms: f64,
    /// median query time, milliseconds
    pub median_ms: f64,
}

fn read(path: &Path) -> Result<String, MovingAiError> {
    std::fs::read_to_string(path).map_err(|source| MovingAiError::Io { file: path.to_path_buf(), source })
}

impl MovingAiMap {
    /// Reads a `.map` file.
    pub fn load(path: &Path) -> Result<Self, MovingAiError> {
        Self::parse(&read(path)?, path)
    }

    /// Parses a `.map` file's text.
    pub fn parse(text: &str, file: &Path) -> Result<Self, MovingAiError> {
        let err = |line: usize, message: String| MovingAiError::Format { file: file.to_path_buf(), line, message };
        let mut lines = text.lines().enumerate();
        let (mut width, mut height) = (None, None);
        for (i, line) in lines.by_ref() {
            let mut f = line.split_whitespace();
            match (f.next(), f.next()) {
                (Some("type"), Some("octile")) => {}
                (Some("type"), t) => return Err(err(i + 1, format!("type {t:?} is not octile"))),
                (Some("height"), Some(h)) => height = h.parse::<usize>().ok(),
                (Some("width"), Some(w)) => width = w.parse::<usize>().ok(),
                (Some("map"), None) => break,
                _ => return Err(err(i + 1, format!("unexpected header line {line:?}"))),
            }
        }
        let (Some(width), Some(height)) = (width, height) else {
            return Err(err(1, "missing or invalid width / height".into()));
        };
        // checked: two forged 2^33 sizes overflowed the product (a panic in debug builds)
        if width == 0 || height == 0 || (width as u64).saturating_mul(height as u64) > map::MAX_CELLS {
            return Err(err(1, format!("map size {width} x {height} is empty or too large")));
        }
        // a forged size must not reserve MAX_CELLS: every cell is a byte of the text
        let mut passable = Vec::with_capacity((width * height).min(text.len()));
        let mut rows = 0;
        for (i, line) in lines {
            let line = line.trim_end_matches('\r');
            if rows == height {
                // some files carry a citation after the rows (arena.map does)
                break;
            }
            if line.len() != width {
                return Err(err(i + 1, format!("map row {} has {} cells, expected {width}", rows + 1, line.len())));
            }
            passable.extend(line.bytes().map(|b| matches!(b, b'.' | b'G' | b'S')));
            rows += 1;
        }
        if rows != height {
            return Err(err(text.lines().count(), format!("{rows} map rows, expected {height}")));
        }
        Ok(Self { width, height, passable })
    }

    /// The map as an occupancy grid at 1 m per cell (grid row = file row, so benchmark
    /// coordinates are grid cells as they are).
    pub fn to_grid(&self) -> OccupancyGrid {
        let cells = self.passable.iter().map(|&p| if p { Cell::Free } else { Cell::Occupied }).collect();
        let origin = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
        // size and resolution were checked on load
        OccupancyGrid::new(self.width, self.height, 1.0, origin, cells).unwrap_or_else(|_| unreachable!())
    }

    /// The octile, no-corner-cutting graph of the map (one vertex per passable cell).
    pub fn graph(&self) -> NavGraph {
        NavGraph::build(&self.to_grid(), &NavGraphConfig { spacing_m: 1.0, clearance_m: 0.0 })
    }
}

/// Reads a `.scen` file.
pub fn load_scenarios(path: &Path) -> Result<Vec<Scenario>, MovingAiError> {
    parse_scenarios(&read(path)?, path)
}

/// Parses a `.scen` file's text; lines without 9 tab-separated fields are skipped.
pub fn parse_scenarios(text: &str, file: &Path) -> Result<Vec<Scenario>, MovingAiError> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let f: Vec<&str> = line.trim_end_matches('\r').split('\t').collect();
        if f.len() != 9 {
            continue;
        }
        let bad = |what: &str| MovingAiError::Format {
            file: file.to_path_buf(),
            line: i + 1,
            message: format!("{what} is not a number in {line:?}"),
        };
        let n = |k: usize, what: &str| f[k].trim().parse::<usize>().map_err(|_| bad(what));
        let optimal = f[8].trim().parse::<f64>().map_err(|_| bad("optimal_length"))?;
        if !(optimal.is_finite() && optimal >= 0.0) {
            return Err(MovingAiError::Format {
                file: file.to_path_buf(),
                line: i + 1,
                message: format!("optimal_length {optimal} is not a length in {line:?}"),
            });
        }
        out.push(Scenario {
            bucket: f[0].trim().parse::<u32>().map_err(|_| bad("bucket"))?,
            start: (n(4, "start_x")?, n(5, "start_y")?),
            goal: (n(6, "goal_x")?, n(7, "goal_y")?),
            optimal,
        });
    }
    Ok(out)
}

/// Runs every scenario with A* on the map's graph. `clock_ms` is the caller's clock in
/// milliseconds (this crate reads none): each query is timed between two calls.
pub fn run_scenarios(map: &MovingAiMap, scenarios: &[Scenario], mut clock_ms: impl FnMut() -> f64) -> BenchmarkReport {
    let graph = map.graph();
    let mut astar = AStar::new();
    let mut path = Vec::new();
    let mut results = Vec::with_capacity(scenarios.len());
    // the grid is built with file row = grid row, so (x, y) is lattice (x, y)
    let vertex = |(x, y): (usize, usize)| graph.vertex_at(x, y);
    for s in scenarios {
        let t0 = clock_ms();
        let length = match (vertex(s.start), vertex(s.goal)) {
            (Some(a), Some(b)) => astar.search(&graph, a, b, &mut path),
            _ => None,
        };
        let ms = clock_ms() - t0;
        let error = length.map_or(f64::INFINITY, |l| (l - s.optimal).abs());
        results.push(ScenarioResult { scenario: s.clone(), length, error, ms });
    }
    let max_error = results.iter().map(|r| r.error).fold(0.0, f64::max);
    let mut times: Vec<f64> = results.iter().map(|r| r.ms).collect();
    let mean_ms = if times.is_empty() { 0.0 } else { times.iter().sum::<f64>() / times.len() as f64 };
    times.sort_by(f64::total_cmp);
    let median_ms = median(&times);
    BenchmarkReport { results, max_error, mean_ms, median_ms }
}

/// Median of sorted values (0 when empty).
pub fn median(sorted: &[f64]) -> f64 {
    match sorted.len() {
        0 => 0.0,
        n if n % 2 == 1 => sorted[n / 2],
        n => (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_map_and_scenarios_parse() {
        let m = MovingAiMap::parse("type octile\nheight 2\nwidth 3\nmap\n.@G\nS.T\n", Path::new("m.map")).unwrap();
        assert_eq!((m.width, m.height), (3, 2));
        assert_eq!(m.passable, vec![true, false, true, true, true, false]);
        let s = parse_scenarios("version 1\n0\tm.map\t3\t2\t0\t1\t2\t0\t2.41421356\ncitation line\n", Path::new("s"))
            .unwrap();
        assert_eq!(s, vec![Scenario { bucket: 0, start: (0, 1), goal: (2, 0), optimal: 2.41421356 }]);
        let r = run_scenarios(&m, &s, || 0.0);
        // (0,1) -> (1,1) -> (2,0): the diagonal (1,1)-(2,0) needs (2,1)='T' free: it is not,
        // and (1,0) '@' is not either, so no path exists at all
        assert_eq!(r.results[0].length, None);
        assert!(r.max_error.is_infinite());
    }

    #[test]
    fn bad_map_files_name_the_line() {
        let e = MovingAiMap::parse("type octile\nheight 2\nwidth 3\nmap\n...\n..\n", Path::new("m.map")).unwrap_err();
        assert!(e.to_string().starts_with("m.map:6:"), "{e}");
        let e = MovingAiMap::parse("type tile\n", Path::new("t.map")).unwrap_err();
        assert!(e.to_string().contains("octile"), "{e}");
        let e = parse_scenarios("0\tm\t1\t1\tx\t0\t0\t0\t1.0\n", Path::new("s.scen")).unwrap_err();
        assert!(e.to_string().starts_with("s.scen:1:"), "{e}");
        // an optimum that is no length, and a bucket past u32, are refused, not kept
        for (line, what) in [
            ("0\tm\t1\t1\t0\t0\t0\t0\tnan", "optimal_length"),
            ("0\tm\t1\t1\t0\t0\t0\t0\tinf", "optimal_length"),
            ("0\tm\t1\t1\t0\t0\t0\t0\t-1", "optimal_length"),
            ("4294967296\tm\t1\t1\t0\t0\t0\t0\t1", "bucket"),
        ] {
            let e = parse_scenarios(&format!("version 1\n{line}\n"), Path::new("s.scen")).unwrap_err();
            assert!(e.to_string().starts_with("s.scen:2:") && e.to_string().contains(what), "{line}: {e}");
        }
    }
}
