//! `cargo bench -p planning`: medians on one core for ISANA's figures (graph build,
//! longest route plan + smoothing, replan after an obstacle, restore) on a 29 x 22 m
//! floor at 20 cm, and our A* against the `pathfinding` crate's `astar` on the same
//! queries (the Moving AI files and the floor). Prints a table; no harness.

#[path = "../tests/support/mod.rs"]
mod support;

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use planning::movingai::{load_scenarios, median, run_scenarios, MovingAiMap};
use planning::{AStar, NavGraph, NavGraphConfig, Planner};
use support::floor::{isana_floor, LONGEST};

/// Median milliseconds of `runs` calls of `f`.
fn time_ms(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    median(&t)
}

/// The `pathfinding` crate's A* on the same graph: integer micrometres (its costs must
/// be `Ord`), octile heuristic rounded down so it stays admissible.
fn reference_astar(g: &NavGraph, s: u32, t: u32) -> Option<f64> {
    let cols = g.cols() as i64;
    let unit = g.spacing_m() * 1e6;
    let (ti, tj) = (t as i64 % cols, t as i64 / cols);
    pathfinding::directed::astar::astar(
        &s,
        |&v| g.neighbours(v).map(|(n, len)| (n, (len * 1e6).round() as u64)),
        |&v| {
            let (dx, dy) = (((v as i64 % cols) - ti).abs() as f64, ((v as i64 / cols) - tj).abs() as f64);
            (planning::astar::octile(dx, dy) * unit).floor() as u64
        },
        |&v| v == t,
    )
    .map(|(_, c)| c as f64 / 1e6)
}

struct Compare {
    ours_ms: Vec<f64>,
    theirs_ms: Vec<f64>,
    max_diff: f64,
}

fn compare(g: &NavGraph, queries: &[(u32, u32)], repeats: usize) -> Compare {
    let mut astar = AStar::new();
    let mut path = Vec::new();
    let mut c = Compare { ours_ms: vec![], theirs_ms: vec![], max_diff: 0.0 };
    for &(s, t) in queries {
        let mut ours = None;
        c.ours_ms.push(time_ms(repeats, || ours = black_box(astar.search(g, s, t, &mut path))));
        let mut theirs = None;
        c.theirs_ms.push(time_ms(repeats, || theirs = black_box(reference_astar(g, s, t))));
        if let (Some(a), Some(b)) = (ours, theirs) {
            c.max_diff = c.max_diff.max((a - b).abs());
        } else {
            assert_eq!(ours.is_some(), theirs.is_some(), "reachability differs for {s}->{t}");
        }
    }
    c.ours_ms.sort_by(f64::total_cmp);
    c.theirs_ms.sort_by(f64::total_cmp);
    c
}

fn print_compare(name: &str, c: &Compare) {
    let (mo, mt) = (median(&c.ours_ms), median(&c.theirs_ms));
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    println!(
        "{name:<28} {:>5} queries  ours median {mo:.4} ms (mean {:.4})  pathfinding::astar median {mt:.4} ms (mean {:.4})  speed-up {:.2}x (mean {:.2}x)  max length diff {:.1e}",
        c.ours_ms.len(),
        mean(&c.ours_ms),
        mean(&c.theirs_ms),
        mt / mo,
        mean(&c.theirs_ms) / mean(&c.ours_ms),
        c.max_diff
    );
}

fn main() {
    // `cargo bench` passes --bench; anything else (a filter) is ignored
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");

    println!("== ISANA-sized floor: 29 x 22 m, 5 cm grid, 20 cm graph, 0.3 m clearance ==");
    let grid = isana_floor();
    let config = NavGraphConfig::default();
    let build_ms = time_ms(30, || {
        black_box(NavGraph::build(black_box(&grid), &config));
    });
    let mut planner = Planner::new(0, &grid, &config);
    let g = planner.graph();
    println!("graph: {} x {} lattice, {} vertices, {} edges", g.cols(), g.rows(), g.vertex_count(), g.edge_count());
    let route = planner.plan(LONGEST.0, LONGEST.1).unwrap();
    println!(
        "longest route {:?} -> {:?}: graph {:.2} m, {} nodes -> {} waypoints, smoothed {:.2} m",
        LONGEST.0,
        LONGEST.1,
        route.graph_length_m,
        route.points.len(),
        route.waypoints.len(),
        route.length_m
    );
    let plan_ms = time_ms(300, || {
        black_box(planner.plan(LONGEST.0, LONGEST.1).unwrap());
    });
    {
        let g = planner.graph();
        let (s, t) = (route.vertices[0], *route.vertices.last().unwrap());
        let mut astar = AStar::new();
        let mut path = Vec::new();
        let astar_ms = time_ms(300, || {
            black_box(astar.search(g, s, t, &mut path));
        });
        let smooth_ms = time_ms(300, || {
            black_box(planning::smoothing::smooth(g.inflated(), &[], &route.points));
        });
        println!(
            "  of which A* {astar_ms:.3} ms ({} vertices expanded), smoothing {smooth_ms:.3} ms",
            astar.expanded()
        );
    }
    // an obstacle on the route halfway along, in the corridor across
    // a person (0.1 m radius + 0.3 m clearance) standing on the route in the corridor across
    let mid = route.points[route.points.iter().position(|p| p[1] > 10.4 && p[1] < 11.6 && p[0] > 18.0).unwrap()];
    let (ox, oy, orad) = (mid[0], mid[1], 0.1);
    let mut replanned = None;
    let mut replan_samples = Vec::new();
    let mut restore_samples = Vec::new();
    for _ in 0..300 {
        let t0 = Instant::now();
        let id = planner.add_obstacle(ox, oy, orad);
        assert!(planner.blocks(&route));
        let r = planner.replan(&route, LONGEST.0).unwrap();
        replan_samples.push(t0.elapsed().as_secs_f64() * 1e3);
        let t1 = Instant::now();
        planner.remove_obstacle(id);
        let back = planner.replan(&route, LONGEST.0).unwrap();
        restore_samples.push(t1.elapsed().as_secs_f64() * 1e3);
        assert_eq!(back.vertices, route.vertices);
        replanned = Some(r);
    }
    replan_samples.sort_by(f64::total_cmp);
    restore_samples.sort_by(f64::total_cmp);
    let replanned = replanned.unwrap();
    println!(
        "obstacle r = {orad} m at ({ox:.2}, {oy:.2}): replanned graph {:.2} m (was {:.2})",
        replanned.graph_length_m, route.graph_length_m
    );
    println!("graph build (inflation + lattice + edges)    median {build_ms:.3} ms   (target <= 10 ms)");
    println!("longest route plan + smoothing               median {plan_ms:.3} ms   (target <= 2 ms)");
    println!(
        "replan after an obstacle (block + A* + smooth) median {:.3} ms (target <= 1 ms)",
        median(&replan_samples)
    );
    println!(
        "restore (unblock + A* + smooth)              median {:.3} ms   (target <= 1 ms)",
        median(&restore_samples)
    );
    let rejoin_ms = time_ms(1000, || {
        black_box(route.rejoin(planner.graph(), mid[0], mid[1] + 0.4, 1.0));
    });
    println!("deviation recovery (rejoin within 1 m)       median {rejoin_ms:.4} ms");

    println!();
    println!("== our A* vs pathfinding::astar, same graph, same queries (median of 5 runs per query) ==");
    for name in ["arena.map", "den312d.map"] {
        let map = MovingAiMap::load(&data.join(name)).unwrap();
        let scen = load_scenarios(&data.join(format!("{name}.scen"))).unwrap();
        let start = Instant::now();
        let report = run_scenarios(&map, &scen, || start.elapsed().as_secs_f64() * 1e3);
        println!(
            "{name}: {} scenarios, max error {:.2e}, mean {:.4} ms, median {:.4} ms per query",
            report.results.len(),
            report.max_error,
            report.mean_ms,
            report.median_ms
        );
        let g = map.graph();
        let queries: Vec<(u32, u32)> = scen
            .iter()
            .filter_map(|s| Some((g.vertex_at(s.start.0, s.start.1)?, g.vertex_at(s.goal.0, s.goal.1)?)))
            .collect();
        print_compare(name, &compare(&g, &queries, 5));
    }
    // random pairs of vertices on the floor (a fixed LCG, so every run asks the same)
    let g = planner.graph();
    let open: Vec<u32> = (0..g.lattice_len() as u32).filter(|&v| g.is_open(v)).collect();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut pick = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        open[(seed >> 33) as usize % open.len()]
    };
    let queries: Vec<(u32, u32)> = (0..200).map(|_| (pick(), pick())).collect();
    print_compare("isana floor (random pairs)", &compare(g, &queries, 5));
}
