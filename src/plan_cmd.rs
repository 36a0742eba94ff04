//! `wearnav plan`: the route planner on files. Either every scenario of a Moving AI
//! benchmark (exactness and speed against the optimal lengths in the file), or one
//! route on a ROS `map_server` floor map, to a point or to a label of its semantic layer.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{anyhow, bail, Context};
use clap::Args;
use guidance::{GuidanceProfile, Guide, UserPose};
use map::SemanticLayer;
use planning::movingai::{self, MovingAiMap};
use planning::{NavGraphConfig, Planner};
use serde_json::json;

/// Plan routes on a Moving AI benchmark or a floor map.
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  \
    wearnav plan --movingai arena.map --scen arena.map.scen\n  \
    wearnav plan --map floor0.yaml --semantic floor0.semantic.toml --from 1.0,2.5 --to \"room 112\"")]
pub struct PlanArgs {
    /// A Moving AI `.map` file (octile grid): run every scenario of `--scen` on it with
    /// 8-connected moves and no corner cutting, and compare each length with the file's
    /// optimum.
    #[arg(long, value_name = "MAP", requires = "scen", conflicts_with_all = ["map", "from", "to"])]
    movingai: Option<PathBuf>,
    /// The Moving AI scenario file (`.scen`) for `--movingai`.
    #[arg(long, value_name = "SCEN")]
    scen: Option<PathBuf>,
    /// A ROS `map_server` map (YAML naming a PGM or PNG image) to plan one route on.
    #[arg(long, value_name = "YAML", requires_all = ["from", "to"])]
    map: Option<PathBuf>,
    /// The floor's semantic layer (TOML: labels, doors, areas, gateways), so `--to` may
    /// name a place.
    #[arg(long, value_name = "TOML", requires = "map")]
    semantic: Option<PathBuf>,
    /// Start, map metres: `X,Y`.
    #[arg(long, value_name = "X,Y", value_parser = parse_point, allow_hyphen_values = true)]
    from: Option<[f64; 2]>,
    /// Goal: map metres `X,Y`, or a label of `--semantic` ("room 112").
    #[arg(long, value_name = "X,Y|LABEL", allow_hyphen_values = true)]
    to: Option<String>,
    /// The user's distance to walls, metres: the route keeps at least this far from
    /// walls and unmapped space.
    #[arg(long, value_name = "M", default_value_t = NavGraphConfig::default().clearance_m)]
    clearance: f64,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

fn parse_point(s: &str) -> Result<[f64; 2], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y] = parts[..] else { return Err(format!("{s:?} is not X,Y (two numbers, metres)")) };
    let num = |v: &str| v.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or(format!("{v:?} is not a number"));
    Ok([num(x)?, num(y)?])
}

/// Run `wearnav plan`.
pub fn run(args: &PlanArgs) -> anyhow::Result<()> {
    match (&args.movingai, &args.map) {
        (Some(map), _) => benchmark(map, args.scen.as_deref().expect("clap requires --scen"), args.json),
        (None, Some(map)) => route(args, map),
        (None, None) => bail!("give --movingai MAP --scen FILE, or --map YAML --from X,Y --to X,Y|LABEL (see --help)"),
    }
}

fn benchmark(map_path: &Path, scen_path: &Path, json: bool) -> anyhow::Result<()> {
    let map = MovingAiMap::load(map_path)?;
    let scenarios = movingai::load_scenarios(scen_path)?;
    let start = Instant::now();
    let report = movingai::run_scenarios(&map, &scenarios, || start.elapsed().as_secs_f64() * 1e3);
    let unsolved = report.results.iter().filter(|r| r.length.is_none()).count();
    if json {
        let results: Vec<_> = report
            .results
            .iter()
            .map(|r| {
                json!({
                    "bucket": r.scenario.bucket,
                    "start": [r.scenario.start.0, r.scenario.start.1],
                    "goal": [r.scenario.goal.0, r.scenario.goal.1],
                    "optimal": r.scenario.optimal,
                    "length": r.length,
                    "error": if r.error.is_finite() { Some(r.error) } else { None },
                    "ms": r.ms,
                })
            })
            .collect();
        let summary = json!({
            "map": map_path, "scenarios": report.results.len(), "unsolved": unsolved,
            "max_error": report.max_error, "mean_ms": report.mean_ms, "median_ms": report.median_ms,
            "results": results,
        });
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!("{} ({}x{}), {} scenarios", map_path.display(), map.width, map.height, report.results.len());
        println!("{:>6} {:>14} {:>14} {:>12} {:>10}", "bucket", "length", "optimal", "error", "ms");
        for r in &report.results {
            let length = r.length.map_or("none".to_string(), |l| format!("{l:.6}"));
            println!(
                "{:>6} {:>14} {:>14.6} {:>12.2e} {:>10.4}",
                r.scenario.bucket, length, r.scenario.optimal, r.error, r.ms
            );
        }
        println!(
            "max_error {:.2e}, mean_ms {:.4}, median_ms {:.4}, unsolved {unsolved}",
            report.max_error, report.mean_ms, report.median_ms
        );
    }
    if unsolved > 0 || report.max_error > 1e-4 {
        bail!(
            "{unsolved} scenarios unsolved, largest error {:.2e} (expected every length within 1e-4)",
            report.max_error
        );
    }
    Ok(())
}

fn route(args: &PlanArgs, map_path: &Path) -> anyhow::Result<()> {
    let grid = map::load_map(map_path)?;
    let semantic = args.semantic.as_deref().map(SemanticLayer::load).transpose()?;
    let from = args.from.expect("clap requires --from");
    let to_text = args.to.as_deref().expect("clap requires --to");
    let (to, to_name) = match parse_point(to_text) {
        Ok(p) => (p, None),
        Err(_) => {
            let semantic = semantic.as_ref().ok_or_else(|| {
                anyhow!("--to {to_text:?} is not X,Y, and there is no --semantic file to look a label up in")
            })?;
            let label = semantic.label(to_text).ok_or_else(|| unknown_place(semantic, to_text))?;
            ([label.x, label.y], Some(label.name.clone()))
        }
    };
    if !(args.clearance.is_finite() && (0.0..=2.0).contains(&args.clearance)) {
        bail!("--clearance {} m: give a distance between 0 and 2 m", args.clearance);
    }
    let config = NavGraphConfig { clearance_m: args.clearance, ..NavGraphConfig::default() };
    let started = Instant::now();
    let mut planner = Planner::new(0, &grid, &config);
    let built_ms = started.elapsed().as_secs_f64() * 1e3;
    let started = Instant::now();
    let route = planner.plan(from, to).with_context(|| format!("planning on {}", map_path.display()))?;
    let plan_ms = started.elapsed().as_secs_f64() * 1e3;
    let destination = to_name.clone().unwrap_or_else(|| format!("{:.1}, {:.1}", to[0], to[1]));
    let spoken = walk_the_route(&route, &destination, semantic.unwrap_or_default(), planner.graph());
    if args.json {
        let out = json!({
            "map": map_path, "from": from, "to": to, "to_label": to_name,
            "length_m": route.length_m, "graph_length_m": route.graph_length_m,
            "snapped_m": route.snapped_m, "waypoints": route.waypoints,
            "instructions": spoken.iter().map(|(at_m, text)| json!({ "at_m": at_m, "text": text })).collect::<Vec<_>>(),
            "graph_ms": built_ms, "plan_ms": plan_ms,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        let goal =
            to_name.map_or(format!("({:.2}, {:.2})", to[0], to[1]), |n| format!("{n} ({:.2}, {:.2})", to[0], to[1]));
        println!("from ({:.2}, {:.2}) to {goal}: {:.2} m", from[0], from[1], route.length_m);
        for (k, w) in route.waypoints.iter().enumerate() {
            println!("  {k:>3}  ({:7.2}, {:7.2})  {:6.2} m left", w[0], w[1], route.remaining_from_waypoint_m(k));
        }
        // more than half a lattice diagonal: the asked place itself was not walkable
        if route.snapped_m.iter().any(|s| *s > 0.15) {
            println!(
                "start moved {:.2} m, goal {:.2} m, to the nearest place {:.2} m clear of walls",
                route.snapped_m[0], route.snapped_m[1], args.clearance
            );
        }
        println!("what a walker at 1 m/s would hear (default guidance profile):");
        for (at_m, text) in &spoken {
            println!("  {at_m:6.1} m  {text}");
        }
        println!("graph {built_ms:.1} ms, route {plan_ms:.2} ms");
    }
    Ok(())
}

/// "no place called X; closest: ..." with the labels that share the most words with it.
fn unknown_place(semantic: &SemanticLayer, asked: &str) -> anyhow::Error {
    let words = |s: &str| s.to_lowercase().split_whitespace().map(str::to_string).collect::<Vec<_>>();
    let asked_words = words(asked);
    let mut scored: Vec<(usize, &str)> = semantic
        .labels
        .iter()
        .map(|l| {
            let shared = words(&l.name).iter().filter(|w| asked_words.contains(w)).count();
            let prefix = l.name.to_lowercase().starts_with(&asked.to_lowercase()) as usize;
            (shared + prefix, l.name.as_str())
        })
        .collect();
    scored.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(b.1)));
    let close: Vec<&str> = scored.iter().take(5).map(|(_, n)| *n).collect();
    if close.is_empty() {
        anyhow!("no place called {asked:?}: the semantic layer has no labels")
    } else {
        anyhow!("no place called {asked:?}; places: {}", close.join(", "))
    }
}

/// Walks the smoothed route at 1 m/s, facing along it, with a confident pose, and
/// returns each instruction the guide gives with the metres walked when it came.
fn walk_the_route(
    route: &planning::Route,
    destination: &str,
    semantic: SemanticLayer,
    graph: &planning::NavGraph,
) -> Vec<(f64, String)> {
    const STEP_M: f64 = 0.05;
    let mut guide = Guide::single_floor(route.clone(), destination, semantic, GuidanceProfile::default());
    let mut heard = Vec::new();
    let mut walked = 0.0;
    let mut facing = 0.0;
    for pair in route.waypoints.windows(2) {
        let ([x0, y0], [x1, y1]) = (pair[0], pair[1]);
        let length = (x1 - x0).hypot(y1 - y0);
        let heading_rad = (y1 - y0).atan2(x1 - x0);
        facing = heading_rad;
        let steps = (length / STEP_M).ceil().max(1.0) as usize;
        for k in 0..steps {
            let f = k as f64 / steps as f64;
            let pose =
                UserPose { x_m: x0 + f * (x1 - x0), y_m: y0 + f * (y1 - y0), heading_rad, floor: 0, confident: true };
            let at = walked + f * length;
            if let Some(i) = guide.step(&pose, (at * 1000.0) as u64, Some(graph)) {
                heard.push((at, i.text));
            }
        }
        walked += length;
    }
    if let Some(&[x, y]) = route.waypoints.last() {
        // standing at the goal for a moment: arrival is said there
        let pose = UserPose { x_m: x, y_m: y, heading_rad: facing, floor: 0, confident: true };
        for extra_ms in [0, 1000, 2000] {
            if let Some(i) = guide.step(&pose, (walked * 1000.0) as u64 + extra_ms, Some(graph)) {
                heard.push((walked, i.text));
            }
        }
    }
    heard
}
