//! The virtual user study: N walks of one world with one configuration, one seed each,
//! summarised in the columns of Taylor's Tables 3.1-3.3 (completion time, rumble
//! signals, cane contacts, body contacts, reorientations, completion), with body
//! contacts split by whether the obstacle was in the camera's field of view.

use serde::Serialize;
use sim::World;

use super::contacts::Part;
use super::walk::{walk, WalkConfig, WalkOutcome};

/// One table row: a walk, or the average of several.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// Seed of the walk (`None` for the average).
    pub seed: Option<u64>,
    /// Completion time (timeout when not completed), seconds.
    pub time_s: f64,
    /// Rumble signals.
    pub signals: f64,
    /// Cane contacts.
    pub cane: f64,
    /// Body contacts with obstacles in the camera's field of view at that moment.
    pub body_in_fov: f64,
    /// Body contacts with obstacles outside it.
    pub body_out_fov: f64,
    /// Body contacts with head-high obstacles (included in the two above).
    pub body_head_high: f64,
    /// Reorientations.
    pub reorientations: f64,
    /// Times an experimenter led the user back on course.
    pub assists: f64,
    /// Completed (1) or not (0); the average is the completion rate.
    pub completed: f64,
}

impl Row {
    /// The row of one walk.
    pub fn of(w: &WalkOutcome) -> Row {
        Row {
            seed: Some(w.seed),
            time_s: w.time_s,
            signals: w.signals as f64,
            cane: w.count(Part::Cane, None) as f64,
            body_in_fov: w.count(Part::Body, Some(true)) as f64,
            body_out_fov: w.count(Part::Body, Some(false)) as f64,
            body_head_high: w.contacts.iter().filter(|c| c.part == Part::Body && c.head_high).count() as f64,
            reorientations: w.reorientations as f64,
            assists: w.assists as f64,
            completed: if w.completed { 1.0 } else { 0.0 },
        }
    }

    /// Column means of `rows` (`None` when empty).
    pub fn mean(rows: &[Row]) -> Option<Row> {
        if rows.is_empty() {
            return None;
        }
        let n = rows.len() as f64;
        let avg = |f: fn(&Row) -> f64| rows.iter().map(f).sum::<f64>() / n;
        Some(Row {
            seed: None,
            time_s: avg(|r| r.time_s),
            signals: avg(|r| r.signals),
            cane: avg(|r| r.cane),
            body_in_fov: avg(|r| r.body_in_fov),
            body_out_fov: avg(|r| r.body_out_fov),
            body_head_high: avg(|r| r.body_head_high),
            reorientations: avg(|r| r.reorientations),
            assists: avg(|r| r.assists),
            completed: avg(|r| r.completed),
        })
    }
}

/// The walks of a study and their rows.
#[derive(Debug, Clone, Serialize)]
pub struct Study {
    /// Each walk in full (contacts listed).
    pub walks: Vec<WalkOutcome>,
    /// One row per walk.
    pub rows: Vec<Row>,
    /// Column means (`None` for zero runs).
    pub average: Option<Row>,
}

/// With the particle filter's place (`--pose filter`): how many walks it guided from a
/// place more than a metre off (frames it said `Tracking` while that far from the
/// truth), as a line; `None` when the walks ran without the filter.
pub fn localization_line<'a>(walks: impl Iterator<Item = &'a WalkOutcome>) -> Option<String> {
    let errors: Vec<_> = walks.filter_map(|w| w.localization).collect();
    if errors.is_empty() {
        return None;
    }
    let off: Vec<u64> = errors.iter().map(|e| u64::from(e.frames_over_1m)).filter(|&n| n > 0).collect();
    let turned: Vec<u64> = errors.iter().map(|e| u64::from(e.frames_turned)).filter(|&n| n > 0).collect();
    let tracked: u64 = errors.iter().map(|e| u64::from(e.frames)).sum();
    Some(format!(
        "the filter: {} of {} walks tracked more than 1 m off ({} of {} frames tracked), {} turned more than 45° ({} frames)\n",
        off.len(),
        errors.len(),
        off.iter().sum::<u64>(),
        tracked,
        turned.len(),
        turned.iter().sum::<u64>()
    ))
}

/// With the predictive cue learning the user's turning rate (`learning`), one line: the
/// rates its model had learnt by the end of each walk (median and range), and in how
/// many walks the user turned too little on a rumble to learn it.
pub fn learnt_turn_line<'a>(walks: impl Iterator<Item = &'a WalkOutcome>, learning: bool) -> Option<String> {
    if !learning {
        return None;
    }
    let (mut learnt, mut none) = (Vec::new(), 0);
    for w in walks {
        match w.learnt_turn_rate_deg_s {
            Some(r) => learnt.push(r),
            None => none += 1,
        }
    }
    learnt.sort_by(f64::total_cmp);
    let unlearnt = format!("{none} of {} walks learnt nothing", learnt.len() + none);
    Some(match (learnt.first(), learnt.last()) {
        (Some(lo), Some(hi)) => {
            let median = planning::movingai::median(&learnt);
            format!(
                "the cue's model learnt a turning rate of {median:.1}°/s (median; {lo:.1}-{hi:.1}°/s), {unlearnt}\n"
            )
        }
        _ => format!("the cue's model learnt no turning rate: {unlearnt}\n"),
    })
}

/// Contacts of one part by how long before them the user felt a cue: the warning's
/// lead time against the walk's reaction time says whether a contact was the cue's
/// fault (none, or too late to act on) or the user's reaction to it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct LeadTimes {
    /// Nothing was felt when the contact began.
    pub not_warned: u32,
    /// A cue had been felt for less than the walk's reaction time.
    pub too_late: u32,
    /// A cue had been felt for the reaction time or longer.
    pub in_time: u32,
}

impl LeadTimes {
    /// Counts the contacts of `part` over `walks`.
    pub fn of(walks: &[WalkOutcome], part: Part) -> LeadTimes {
        let mut n = LeadTimes::default();
        for w in walks {
            for c in w.contacts.iter().filter(|c| c.part == part) {
                match c.warned_ago_s {
                    None => n.not_warned += 1,
                    Some(ago) if ago < w.reaction_s => n.too_late += 1,
                    Some(_) => n.in_time += 1,
                }
            }
        }
        n
    }

    /// One line: `cane contacts 12: 2 with nothing felt, 7 felt too late to act on
    /// (less than the reaction time before), 3 felt in time`.
    pub fn line(&self, part: &str) -> String {
        format!(
            "{part} contacts {}: {} with nothing felt, {} felt too late to act on (less than the reaction time before), {} felt in time",
            self.not_warned + self.too_late + self.in_time,
            self.not_warned,
            self.too_late,
            self.in_time
        )
    }
}

/// Seed of run `i` of a study started at `seed`.
pub fn run_seed(seed: u64, i: u32) -> u64 {
    seed.wrapping_add(i as u64)
}

/// Runs `runs` walks of `world`, seeds `seed`, `seed + 1`, ..., spread over the
/// machine's cores. Each walk depends only on its seed, so the result is the same
/// whatever the number of threads.
pub fn study(world: &World, config: &WalkConfig, runs: u32, seed: u64) -> Study {
    study_with_progress(world, config, runs, seed, |_| ())
}

/// [`study`], calling `finished` with each walk as it ends (from the worker threads, in
/// the order they end).
pub fn study_with_progress(
    world: &World,
    config: &WalkConfig,
    runs: u32,
    seed: u64,
    finished: impl Fn(&WalkOutcome) + Sync,
) -> Study {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(runs.max(1) as usize);
    let next = std::sync::atomic::AtomicU32::new(0);
    let mut walks: Vec<(u32, WalkOutcome)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if i >= runs {
                            return done;
                        }
                        let outcome = walk(world, config, run_seed(seed, i));
                        finished(&outcome);
                        done.push((i, outcome));
                    }
                })
            })
            .collect();
        // a walk is plain arithmetic on owned data; a panic there is a bug to surface
        workers.into_iter().flat_map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
    });
    walks.sort_by_key(|(i, _)| *i);
    let walks: Vec<WalkOutcome> = walks.into_iter().map(|(_, w)| w).collect();
    let rows: Vec<Row> = walks.iter().map(Row::of).collect();
    let average = Row::mean(&rows);
    Study { walks, rows, average }
}

/// The table as text: header, one line per run, the average line.
pub fn table(study: &Study) -> String {
    let mut s = String::from(
        "run   seed   time_s  signals  cane  body_in_fov  body_out_fov  (head_high)  reorient  assists  completed\n",
    );
    let line = |label: &str, r: &Row| {
        format!(
            "{label:<5} {:>5} {:>8.1} {:>8.1} {:>5.2} {:>12.2} {:>13.2} {:>12.2} {:>9.2} {:>8.2} {:>10}\n",
            r.seed.map_or("-".to_string(), |v| v.to_string()),
            r.time_s,
            r.signals,
            r.cane,
            r.body_in_fov,
            r.body_out_fov,
            r.body_head_high,
            r.reorientations,
            r.assists,
            if r.seed.is_some() {
                if r.completed > 0.0 {
                    "yes".to_string()
                } else {
                    "no".to_string()
                }
            } else {
                format!("{:.0} %", 100.0 * r.completed)
            },
        )
    };
    for (i, r) in study.rows.iter().enumerate() {
        s.push_str(&line(&(i + 1).to_string(), r));
    }
    if let Some(avg) = &study.average {
        s.push_str(&line("mean", avg));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(time_s: f64, completed: f64) -> Row {
        Row {
            seed: Some(1),
            time_s,
            signals: 2.0,
            cane: 1.0,
            body_in_fov: 0.0,
            body_out_fov: 1.0,
            body_head_high: 1.0,
            reorientations: 0.0,
            assists: 0.0,
            completed,
        }
    }

    #[test]
    fn average_of_two_runs_gives_completion_rate_and_mean_time() {
        let avg = Row::mean(&[row(100.0, 1.0), row(300.0, 0.0)]).unwrap();
        assert_eq!((avg.time_s, avg.completed, avg.seed), (200.0, 0.5, None));
        assert!(Row::mean(&[]).is_none());
        let text = table(&Study { walks: vec![], rows: vec![row(100.0, 1.0)], average: Some(avg) });
        assert!(text.contains("yes"), "{text}");
        assert!(text.contains("50 %"), "{text}");
    }

    fn walk_with(reaction_s: f64, contacts: &[(Part, Option<f64>)]) -> WalkOutcome {
        WalkOutcome {
            seed: 1,
            completed: true,
            time_s: 10.0,
            signals: 0,
            offline_signals: 0,
            contacts: contacts
                .iter()
                .map(|&(part, warned_ago_s)| crate::contacts::Contact {
                    t_s: 5.0,
                    part,
                    obstacle: 0,
                    label: "wall".into(),
                    kind: "Wall".into(),
                    in_fov: true,
                    seen_ago_s: Some(0.0),
                    warned_ago_s,
                    head_high: false,
                })
                .collect(),
            reorientations: 0,
            assists: 0,
            perception_errors: 0,
            frames: 300,
            min_clearance_m: 0.0,
            path_m: 8.0,
            reaction_s,
            end_xy_m: [0.0, 0.0],
            way_through: Some(true),
            localization: None,
            heard: None,
            missed: None,
            unguided_m: None,
            ways_round: None,
            learnt_turn_rate_deg_s: None,
            trace: Vec::new(),
        }
    }

    #[test]
    fn lead_times_split_contacts_at_each_walks_own_reaction_time() {
        let walks = [
            walk_with(0.5, &[(Part::Cane, None), (Part::Cane, Some(0.3)), (Part::Cane, Some(0.5)), (Part::Body, None)]),
            // a slower user: 0.6 s of warning is too late for them
            walk_with(0.8, &[(Part::Cane, Some(0.6)), (Part::Cane, Some(2.0))]),
        ];
        let cane = LeadTimes::of(&walks, Part::Cane);
        assert_eq!(cane, LeadTimes { not_warned: 1, too_late: 2, in_time: 2 });
        assert_eq!(LeadTimes::of(&walks, Part::Body), LeadTimes { not_warned: 1, too_late: 0, in_time: 0 });
        assert_eq!(
            cane.line("cane"),
            "cane contacts 5: 1 with nothing felt, 2 felt too late to act on (less than the reaction time before), 2 felt in time"
        );
    }

    #[test]
    fn the_filters_line_counts_the_walks_and_frames_tracked_more_than_a_metre_or_45_degrees_off() {
        use crate::walk::TrackedError;
        let with = |frames, frames_over_1m, frames_turned| WalkOutcome {
            localization: Some(TrackedError {
                position_rmse_m: 0.3,
                heading_rmse_deg: 2.0,
                frames,
                frames_over_1m,
                frames_turned,
            }),
            ..walk_with(0.5, &[])
        };
        assert_eq!(localization_line([walk_with(0.5, &[])].iter()), None, "walks without the filter");
        let walks = [with(900, 0, 0), with(1200, 40, 12), with(0, 0, 0), with(600, 7, 0)];
        assert_eq!(
            localization_line(walks.iter()).as_deref(),
            Some("the filter: 2 of 4 walks tracked more than 1 m off (47 of 2700 frames tracked), 1 turned more than 45° (12 frames)\n")
        );
    }

    #[test]
    fn the_learnt_turn_line_gives_the_median_and_range_of_the_rates_learnt_and_the_walks_that_learnt_none() {
        let with = |rate| WalkOutcome { learnt_turn_rate_deg_s: rate, ..walk_with(0.5, &[]) };
        let walks = [with(Some(31.0)), with(None), with(Some(29.0)), with(Some(30.5)), with(Some(28.0))];
        assert_eq!(learnt_turn_line(walks.iter(), false), None, "the cue does not learn");
        assert_eq!(
            learnt_turn_line(walks.iter(), true).as_deref(),
            Some("the cue's model learnt a turning rate of 29.8°/s (median; 28.0-31.0°/s), 1 of 5 walks learnt nothing\n")
        );
        assert_eq!(
            learnt_turn_line(walks[1..2].iter(), true).as_deref(),
            Some("the cue's model learnt no turning rate: 1 of 1 walks learnt nothing\n")
        );
    }

    #[test]
    fn a_spoken_walks_line_says_what_the_user_did_not_hear_to_its_end() {
        let spoken = |missed| WalkOutcome {
            heard: Some((16, 2)),
            missed: Some(missed),
            unguided_m: Some((6.0, 3.0)),
            ..walk_with(0.5, &[])
        };
        let line = crate::walk_done(&spoken((6, 2)));
        assert!(
            line.ends_with(
                "heard 16 utterances, 2 off-route prompts in 8 m, 6 m of them with no place for guidance \
                 (at most 3 m at a stretch); 6 not heard to their end (2 turns \"now\")"
            ),
            "{line}"
        );
        assert!(crate::walk_done(&spoken((0, 0))).ends_with("(at most 3 m at a stretch)"), "all heard: nothing said");
    }
}
