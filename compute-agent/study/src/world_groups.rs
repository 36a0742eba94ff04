//! `wearnav course --worlds`: the study over groups of worlds (issue 29). The cues were
//! tuned on a few hand-written worlds; generated ones (`gen:<kind>`, see
//! [`sim::generate`]) nobody looked at say whether what was learnt holds.
//! Each group is walked world by world with the same seeds as one world would be
//! (`--runs` walks from `--seed`), summed up per group and overall, and with `--versus`
//! walked again with the flags added, compared walk by walk ([`compare`]) per group and
//! overall: does the device (`--versus=--no-rumble`) make completion or contacts worse in
//! some kind of place?

use std::fmt::Write;

use anyhow::Context;
use sim::generate;
use sim::World;

use crate::compare::{self, Difference};
use crate::study::{study_with_progress, Row, Study};
use crate::walk::{WalkConfig, WalkOutcome};
use crate::{check_world, config_json, config_lines, versus_of, CourseArgs};

/// Worlds walked and summed up together.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Group {
    /// As given to `--worlds` (`gen:corridor`, `taylor-course`).
    pub name: String,
    /// The world names it stands for.
    pub worlds: Vec<String>,
}

/// The groups `--worlds` names: `gen:<kind>` stands for `count` generated worlds of that
/// kind, seeds `seed`, `seed + 1`, ...; any other name for that one world.
pub fn groups(entries: &[String], count: u32, seed: u64) -> anyhow::Result<Vec<Group>> {
    entries
        .iter()
        .map(|entry| {
            let name = entry.trim();
            anyhow::ensure!(!name.is_empty(), "--worlds: an empty name (two commas in a row?)");
            match name.strip_prefix(generate::PREFIX) {
                Some(kind) if !kind.contains(':') => {
                    let kind = generate::kind_named(kind, name)?;
                    anyhow::ensure!(count > 0, "--count must be at least 1 (generated worlds per kind)");
                    let worlds = (0..count).map(|i| generate::world_name(kind, seed.wrapping_add(u64::from(i))));
                    Ok(Group { name: name.into(), worlds: worlds.collect() })
                }
                _ => Ok(Group { name: name.into(), worlds: vec![name.into()] }),
            }
        })
        .collect()
}

/// A group's walks in one configuration.
#[derive(Debug, Clone)]
pub struct GroupWalks {
    /// Each world by name, with its walks.
    pub worlds: Vec<(String, Study)>,
    /// Every walk's row, world after world.
    pub rows: Vec<Row>,
    /// Column means over the walks (`None` without walks).
    pub average: Option<Row>,
}

impl GroupWalks {
    fn of(worlds: Vec<(String, Study)>) -> GroupWalks {
        let rows: Vec<Row> = worlds.iter().flat_map(|(_, s)| s.rows.iter().cloned()).collect();
        let average = Row::mean(&rows);
        GroupWalks { worlds, rows, average }
    }

    fn walks(&self) -> impl Iterator<Item = &WalkOutcome> {
        self.worlds.iter().flat_map(|(_, s)| s.walks.iter())
    }
}

/// One group walked in both configurations.
#[derive(Debug, Clone)]
pub struct GroupReport {
    /// Which worlds.
    pub group: Group,
    /// The walks with the arguments as given.
    pub this: GroupWalks,
    /// The same walks with the `--versus` flags added.
    pub versus: Option<GroupWalks>,
}

/// Paired differences (versus minus this) of every compared column.
pub type Differences = Vec<(&'static str, Difference)>;

impl GroupReport {
    /// The walk-by-walk comparison of the two configurations, when there are both and at
    /// least two walks.
    pub fn difference(&self) -> Option<Differences> {
        self.versus.as_ref().and_then(|v| compare::compare(&self.this.rows, &v.rows))
    }
}

/// Everything a study over groups gives.
#[derive(Debug, Clone)]
pub struct Report {
    /// Per group.
    pub groups: Vec<GroupReport>,
    /// Every walk of every group with the arguments as given.
    pub overall: Vec<Row>,
    /// Every walk again with the `--versus` flags.
    pub overall_versus: Option<Vec<Row>>,
    /// Walks in both configurations.
    pub walks: usize,
    /// Simulated time of all walks, seconds.
    pub simulated_s: f64,
    /// Wall time of all walks, seconds.
    pub wall_time_s: f64,
}

impl Report {
    /// The overall walk-by-walk comparison.
    pub fn difference(&self) -> Option<Differences> {
        self.overall_versus.as_ref().and_then(|v| compare::compare(&self.overall, v))
    }
}

/// Walks every group the arguments name (every world loaded and checked first).
pub fn walk_groups(args: &CourseArgs) -> anyhow::Result<Report> {
    anyhow::ensure!(
        args.trace.is_none() && !args.contacts,
        "--trace and --contacts go with --world (one world), not with --worlds"
    );
    let config = args.walk_config()?;
    let versus = versus_of(args)?;
    let configs: Vec<&WalkConfig> = std::iter::once(&config).chain(versus.as_ref().map(|v| &v.2)).collect();
    let groups = groups(&args.worlds, args.count, args.seed)?;
    let mut loaded = Vec::with_capacity(groups.len());
    for g in &groups {
        let mut worlds = Vec::with_capacity(g.worlds.len());
        for name in &g.worlds {
            let world = World::load(name).with_context(|| format!("loading world `{name}`"))?;
            check_world(&world, &configs)?;
            worlds.push(world);
        }
        loaded.push(worlds);
    }

    let per_config = loaded.iter().map(Vec::len).sum::<usize>() * args.runs as usize;
    let total = per_config * configs.len();
    let started = std::time::Instant::now();
    let ended = std::sync::atomic::AtomicUsize::new(0);
    let progress = |world: &str, w: &WalkOutcome| {
        let n = ended.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        tracing::info!(
            "{n} of {total} walks done; {world} {} ({:.0} s elapsed)",
            crate::walk_done(w),
            started.elapsed().as_secs_f64()
        );
    };
    let walk_all = |worlds: &[World], c: &WalkConfig| {
        GroupWalks::of(
            worlds
                .iter()
                .map(|w| {
                    let study = study_with_progress(w, c, args.runs, args.seed, |o| progress(w.name(), o));
                    (w.name().to_string(), study)
                })
                .collect(),
        )
    };
    let mut reports = Vec::with_capacity(groups.len());
    for (group, worlds) in groups.into_iter().zip(&loaded) {
        let this = walk_all(worlds, &config);
        let versus = versus.as_ref().map(|(_, _, c)| walk_all(worlds, c));
        reports.push(GroupReport { group, this, versus });
    }
    let wall_time_s = started.elapsed().as_secs_f64();
    let overall: Vec<Row> = reports.iter().flat_map(|g| g.this.rows.iter().cloned()).collect();
    let overall_versus = versus
        .as_ref()
        .map(|_| reports.iter().flat_map(|g| g.versus.iter().flat_map(|v| v.rows.iter().cloned())).collect());
    let simulated_s = reports
        .iter()
        .flat_map(|g| std::iter::once(&g.this).chain(g.versus.as_ref()))
        .flat_map(GroupWalks::walks)
        .map(|w| w.time_s)
        .sum();
    Ok(Report { groups: reports, overall, overall_versus, walks: total, simulated_s, wall_time_s })
}

/// Runs the study over groups and prints the tables (or JSON).
pub fn run(args: &CourseArgs) -> anyhow::Result<()> {
    let report = walk_groups(args)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&json(args, &report)?)?);
    } else {
        print!("{}", text(args, &report)?);
    }
    Ok(())
}

const HEADER: &str =
    "walks  completed   time_s  signals   cane  body_in_fov  body_out_fov  (head_high)  reorient  assists\n";

/// One line of a group table: a label, how many walks, their means.
fn line(label: &str, walks: usize, r: &Row) -> String {
    format!(
        "{label:<28} {walks:>5} {:>8.0} % {:>8.1} {:>8.1} {:>6.2} {:>12.2} {:>13.2} {:>12.2} {:>9.2} {:>8.2}\n",
        100.0 * r.completed,
        r.time_s,
        r.signals,
        r.cane,
        r.body_in_fov,
        r.body_out_fov,
        r.body_head_high,
        r.reorientations,
        r.assists
    )
}

/// A group's walks as a table: a line per world (the mean of its walks), the group's
/// mean; and what the filter and the cue's model learnt (`config`'s) did on them.
fn group_table(name: &str, walks: &GroupWalks, config: &WalkConfig) -> String {
    let mut s = format!("{:<28} {HEADER}", "world");
    for (world, study) in &walks.worlds {
        if let Some(avg) = &study.average {
            s.push_str(&line(world, study.rows.len(), avg));
        }
    }
    if let Some(avg) = &walks.average {
        s.push_str(&line(&format!("{name} (mean)"), walks.rows.len(), avg));
    }
    if let Some(l) = crate::study::localization_line(walks.walks()) {
        s.push_str(&l);
    }
    let learning = config.predictive.is_some_and(|p| p.learn_turn_rate);
    if let Some(l) = crate::study::learnt_turn_line(walks.walks(), learning) {
        s.push_str(&l);
    }
    s
}

/// The report as text: the configuration, a table per group (and its versus table and
/// walk-by-walk difference), the per-group summary and the time taken.
pub fn text(args: &CourseArgs, report: &Report) -> anyhow::Result<String> {
    let config = args.walk_config()?;
    let versus = versus_of(args)?;
    let names: Vec<&str> = report.groups.iter().map(|g| g.group.name.as_str()).collect();
    let mut s = config_lines(args, &config, &names.join(", "));
    if let Some((flags, v, c)) = &versus {
        let _ = writeln!(s, "versus `{flags}`:");
        s.push_str(&config_lines(v, c, &names.join(", ")));
    }
    for g in &report.groups {
        let _ = writeln!(
            s,
            "\n{}: {} world(s), {} walk(s) each, {} walks",
            g.group.name,
            g.group.worlds.len(),
            args.runs,
            g.this.rows.len()
        );
        s.push_str(&group_table(&g.group.name, &g.this, &config));
        if let (Some((flags, _, c)), Some(v)) = (&versus, &g.versus) {
            let _ = writeln!(s, "versus `{flags}`, the same walks:");
            s.push_str(&group_table(&g.group.name, v, c));
            let _ = writeln!(s, "difference walk by walk (versus minus this), {} walks:", g.this.rows.len());
            match g.difference() {
                Some(d) => s.push_str(&compare::lines(&d)),
                None => s.push_str("too few walks to compare (at least 2)\n"),
            }
        }
    }
    let _ = write!(s, "\nper group, mean per walk\n{:<28} {HEADER}", "group");
    let label = |name: &str, which: &str| if which.is_empty() { name.to_string() } else { format!("{name} {which}") };
    let vs = versus.as_ref().map_or(String::new(), |(flags, _, _)| format!("`{flags}`"));
    for g in &report.groups {
        if let Some(avg) = &g.this.average {
            s.push_str(&line(&g.group.name, g.this.rows.len(), avg));
        }
        if let Some(avg) = g.versus.as_ref().and_then(|v| v.average.as_ref()) {
            s.push_str(&line(&label("  versus", &vs), g.this.rows.len(), avg));
        }
    }
    if let Some(avg) = Row::mean(&report.overall) {
        s.push_str(&line("overall", report.overall.len(), &avg));
    }
    if let Some(avg) = report.overall_versus.as_deref().and_then(Row::mean) {
        s.push_str(&line(&label("  versus", &vs), report.overall.len(), &avg));
    }
    if let Some(d) = report.difference() {
        let _ = writeln!(s, "all groups, difference walk by walk (versus minus this), {} walks:", report.overall.len());
        s.push_str(&compare::lines(&d));
    }
    let _ = writeln!(
        s,
        "{} walks, {:.0} s simulated in {:.1} s wall time: {:.2} walks/s, {:.0} x real time",
        report.walks,
        report.simulated_s,
        report.wall_time_s,
        report.walks as f64 / report.wall_time_s.max(1e-9),
        report.simulated_s / report.wall_time_s.max(1e-9)
    );
    Ok(s)
}

fn differences_json(d: Option<Differences>) -> serde_json::Value {
    serde_json::json!(d
        .iter()
        .flatten()
        .map(|(name, d)| (name.to_string(), serde_json::json!(d)))
        .collect::<serde_json::Map<_, _>>())
}

fn walks_json(walks: &GroupWalks) -> serde_json::Value {
    serde_json::json!({
        "walks": walks.rows.len(),
        "average": walks.average,
        "worlds": walks
            .worlds
            .iter()
            .map(|(name, s)| serde_json::json!({ "world": name, "rows": s.rows, "average": s.average }))
            .collect::<Vec<_>>(),
    })
}

/// The report as JSON: the configuration(s), per group the rows of every world and the
/// means (and the versus walks and differences), overall, and the time taken.
pub fn json(args: &CourseArgs, report: &Report) -> anyhow::Result<serde_json::Value> {
    let config = args.walk_config()?;
    let mut doc = serde_json::json!({
        "configuration": config_json(args, &config),
        "worlds": args.worlds,
        "count": args.count,
        "runs": args.runs,
    });
    if let Some((flags, v, c)) = versus_of(args)? {
        doc["versus"] = serde_json::json!({ "flags": flags, "configuration": config_json(&v, &c) });
    }
    doc["groups"] = serde_json::json!(report
        .groups
        .iter()
        .map(|g| {
            let mut group = serde_json::json!({ "group": g.group.name, "this": walks_json(&g.this) });
            if let Some(v) = &g.versus {
                group["versus"] = walks_json(v);
                group["difference"] = differences_json(g.difference());
            }
            group
        })
        .collect::<Vec<_>>());
    doc["overall"] = serde_json::json!({
        "walks": report.overall.len(),
        "average": Row::mean(&report.overall),
        "versus_average": report.overall_versus.as_deref().and_then(Row::mean),
        "difference": differences_json(report.difference()),
    });
    doc["walks"] = serde_json::json!(report.walks);
    doc["simulated_s"] = serde_json::json!(report.simulated_s);
    doc["wall_time_s"] = serde_json::json!(report.wall_time_s);
    Ok(doc)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kind_stands_for_count_seeds_and_a_name_for_itself() {
        let entries: Vec<String> = ["gen:corridor", " taylor-course", "gen:lobby:9"].map(String::from).to_vec();
        let g = groups(&entries, 3, 7).unwrap_or_else(|e| panic!("{e:#}"));
        assert_eq!(g[0].worlds, ["gen:corridor:7", "gen:corridor:8", "gen:corridor:9"]);
        assert_eq!((g[1].name.as_str(), g[1].worlds.as_slice()), ("taylor-course", &["taylor-course".to_string()][..]));
        assert_eq!(g[2].worlds, ["gen:lobby:9"]);
        let err = |e: &[&str], count| {
            let entries: Vec<String> = e.iter().map(|s| s.to_string()).collect();
            groups(&entries, count, 1).err().map(|e| format!("{e:#}")).unwrap_or_default()
        };
        assert!(err(&["gen:cave"], 3).starts_with("gen:cave: unknown kind `cave`"), "{}", err(&["gen:cave"], 3));
        assert!(err(&["gen:office"], 0).contains("--count must be at least 1"));
        assert!(err(&["gen:office", ""], 2).contains("an empty name"));
    }
}
