//! The virtual user study (issue 6) on small worlds: the closed loop stops the user
//! before a wall, counts a head-high contact as such, stops the user before a sign a
//! 10-degree camera saw from afar and tells one left behind and come back to, stays
//! quiet in a clear corridor
//! however the cane sweeps, gives a verdict on an unreachable goal, is deterministic per
//! seed, reacts later with a slower user and swings further with a faster-turning one.
//!
//! The full 20-run table is a CLI run (`wearnav course`).

use clap::Parser;
use sim::World;
use study::compare::compare;
use study::contacts::Part;
use study::hands::Felt;
use study::study::{study, LeadTimes, Row};
use study::walk::{walk, GuideKind, WalkConfig};
use study::CourseArgs;

fn world(items: &str) -> World {
    match World::from_toml(items, "test") {
        Ok(w) => w,
        Err(e) => panic!("{e}"),
    }
}

/// A 3 m wide corridor along +x, closed behind the start, with `items` (TOML tables)
/// in it; the goal's sound comes from x = 9.
fn corridor(name: &str, items: &str) -> World {
    corridor_of_width(name, 3.0, items)
}

/// [`corridor`], `width_m` wide.
fn corridor_of_width(name: &str, width_m: f64, items: &str) -> World {
    let half = width_m / 2.0;
    world(&format!(
        r#"
name = "{name}"
start = {{ x_m = 0.0, y_m = 0.0 }}
goal = {{ x_m = 9.0, y_m = 0.0 }}
[[walls]]
label = "north wall"
from = [-1.0, {half:.2}]
to = [12.0, {half:.2}]
[[walls]]
label = "south wall"
from = [-1.0, -{half:.2}]
to = [12.0, -{half:.2}]
[[walls]]
label = "back wall"
from = [-1.0, -{half:.2}]
to = [-1.0, {half:.2}]
{items}"#
    ))
}

/// The corridor closed by a wall across it at `end_x_m`: the goal is unreachable.
fn closed_corridor(name: &str, end_x_m: f64) -> World {
    corridor(name, &format!("[[walls]]\nlabel = \"end wall\"\nfrom = [{end_x_m:.2}, -1.5]\nto = [{end_x_m:.2}, 1.5]\n"))
}

/// The corridor closed 6 m ahead.
fn dead_end() -> World {
    closed_corridor("dead-end", 6.0)
}

fn quick(timeout_s: f64) -> WalkConfig {
    WalkConfig { timeout_s, ..WalkConfig::default() }
}

#[test]
fn user_stops_and_turns_before_touching_the_wall_across_a_corridor() {
    let w = dead_end();
    for seed in [1, 2] {
        let out = walk(&w, &quick(12.0), seed);
        assert_eq!(out.count(Part::Body, None), 0, "seed {seed}: {:?}", out.contacts);
        assert!(out.min_clearance_m > 0.05, "seed {seed}: came within {} m", out.min_clearance_m);
        assert!(out.end_xy_m[0] < 5.6, "seed {seed}: never got past the wall, ended at {:?}", out.end_xy_m);
        assert!(out.signals >= 1, "seed {seed}: the wall was signalled");
        assert!(!out.completed);
    }
}

#[test]
fn unreachable_goal_ends_with_a_timeout_and_says_there_is_no_way_through() {
    let out = walk(&dead_end(), &quick(8.0), 3);
    assert!(!out.completed);
    assert_eq!(out.way_through, Some(false));
    assert_eq!(out.verdict(), "goal not reached: there is no way through (0.5 m wide) from the start to the goal");
    assert_eq!(out.time_s, 8.0);
    assert_eq!(out.frames, 8 * 30, "frames at 30 Hz of simulated time, from t = 0 to the last before 8 s");
    assert!(out.contacts.iter().all(|c| c.t_s <= 8.0), "nothing counted past the limit: {:?}", out.contacts);
}

#[test]
fn frames_refused_in_a_row_are_felt_as_blind_not_as_a_clear_path() {
    // the user starts with a wall 0.3 m ahead of the camera, nearer than an Xtion can
    // range: every frame is refused until the user has turned away. Perception must
    // say it is blind (the compute agent's third refusal in a row) rather than let the
    // hands go quiet, which the user would read as a clear path into the wall.
    let w = closed_corridor("blind-start", 0.69);
    let mut config = exact(3.0);
    config.user.reaction_s = 0.1;
    config.trace = true;
    let out = walk(&w, &config, 1);
    let refused_first = out.trace.iter().take_while(|r| r.rumble.is_none()).count();
    assert!(refused_first >= 25, "most of the first second of frames is refused: {refused_first}");
    assert_eq!(out.count(Part::Body, None), 0, "{:?}", out.contacts);
    assert!(out.end_xy_m[0] < 0.1, "the user stopped where they stood: {:?}", out.end_xy_m);
    let offline_from = out.trace.iter().find(|r| r.felt == Felt::Offline).map(|r| r.t_s);
    assert!(offline_from.is_some_and(|t| t < 0.15), "blind felt from {offline_from:?} s");
    let blind_until = out.trace[refused_first - 1].t_s;
    let quiet = out.trace.iter().filter(|r| r.t_s > 0.2 && r.t_s <= blind_until && r.felt == Felt::None).count();
    assert_eq!(quiet, 0, "frames with nothing felt while blind");
}

#[test]
fn same_seed_gives_the_same_row_and_another_seed_differs() {
    let w = dead_end();
    let a = walk(&w, &quick(6.0), 7);
    let b = walk(&w, &quick(6.0), 7);
    let c = walk(&w, &quick(6.0), 8);
    assert_eq!(Row::of(&a), Row::of(&b));
    assert_eq!(a, b);
    assert_ne!(a.end_xy_m, c.end_xy_m);
}

#[test]
fn study_spread_over_threads_gives_the_walks_in_seed_order_as_walked_alone() {
    let w = dead_end();
    let ended = std::sync::Mutex::new(Vec::new());
    let s = study::study::study_with_progress(&w, &quick(3.0), 3, 5, |o| {
        ended.lock().unwrap_or_else(|e| e.into_inner()).push((o.seed, o.time_s))
    });
    let seeds: Vec<u64> = s.walks.iter().map(|o| o.seed).collect();
    assert_eq!(seeds, [5, 6, 7]);
    assert_eq!(s.walks[1], walk(&w, &quick(3.0), 6));
    assert_eq!(s.rows.len(), 3);
    // each walk was reported once as it ended, whatever the order the threads ended in
    let mut ended = ended.into_inner().unwrap_or_else(|e| e.into_inner());
    ended.sort_by_key(|&(seed, _)| seed);
    assert_eq!(ended, s.walks.iter().map(|o| (o.seed, o.time_s)).collect::<Vec<_>>());
}

/// A sign (0.3 x 1.2 m, 1.55-1.85 m high) hanging at head height at `(x_m, 0)`, across
/// the x axis (a TOML table).
fn head_high_sign(x_m: f64) -> String {
    format!(
        "[[hanging]]\nlabel = \"sign\"\ncenter = [{x_m:.1}, 0.0]\nsize_m = [0.3, 1.2]\nbottom_m = 1.55\ntop_m = 1.85\n"
    )
}

/// Open room with [`head_high_sign`] `sign_x_m` straight ahead of the start, on the way
/// to the goal at `goal_x_m`.
fn sign_ahead(name: &str, sign_x_m: f64, goal_x_m: f64) -> World {
    world(&format!(
        "name = \"{name}\"\nstart = {{ x_m = 0.0, y_m = 0.0 }}\ngoal = {{ x_m = {goal_x_m:.1}, y_m = 0.0 }}\n{}",
        head_high_sign(sign_x_m)
    ))
}

#[test]
fn head_high_sign_in_the_path_is_a_body_contact_outside_the_field_of_view() {
    let out = walk(&sign_ahead("sign", 3.0, 6.0), &quick(12.0), 1);
    let body: Vec<_> = out.contacts.iter().filter(|c| c.part == Part::Body).collect();
    assert!(!body.is_empty(), "walked into the sign: {:?}", out.contacts);
    for c in &body {
        assert_eq!(c.label, "sign");
        assert!(c.head_high, "{c:?}");
        assert!(!c.in_fov, "a camera pitched 30 deg down never sees above its own height: {c:?}");
        assert_eq!(c.seen_ago_s, None);
        assert_eq!(c.warned_ago_s, None, "nothing warned of it: {c:?}");
    }
    let lead = LeadTimes::of(std::slice::from_ref(&out), Part::Body);
    assert_eq!(lead, LeadTimes { not_warned: body.len() as u32, too_late: 0, in_time: 0 });
    assert_eq!(out.count(Part::Cane, None), 0, "the cane passes under the sign");
}

#[test]
fn head_high_sign_seen_from_afar_is_remembered_and_the_user_stops_before_it() {
    // 5 m ahead: far enough for a camera pitched 10 degrees down to see it before it
    // leaves the top of the view; the memory used to drop the sign while it was in the
    // image's top rows and weigh what it kept at a quarter of the sign in view: 10 of
    // 10 walks ran into it
    let mut config = quick(12.0);
    config.mount.pitch_deg = 10.0;
    for seed in [1, 2, 3] {
        let out = walk(&sign_ahead("sign-ahead", 5.0, 9.0), &config, seed);
        assert_eq!(out.count(Part::Body, None), 0, "seed {seed}: {:?}", out.contacts);
        assert!(out.signals >= 1, "seed {seed}: the sign was signalled");
    }
}

#[test]
fn a_sign_left_behind_and_come_back_to_from_the_side_is_still_told() {
    // The camera, 10 degrees down, sees the sign from the start (3.65 m ahead). The
    // route (laid, as a floor-plan route would be, by a map without the sign) turns
    // south 1 m on, east 2.5 m further, and north under the sign. Facing away down the
    // south leg the sign moves more than 5 m in the user's frame, and at the last
    // corner it is 2.5 m ahead, nearer than this camera sees anything 1.55 m up.
    // Forgotten after 5 m as a low obstacle is, the user walked under it with nothing
    // felt in each of these walks (13.5-15.5 s in); overhead, it is kept, and every
    // touch of it comes with a cue felt.
    let w = world(&format!(
        r#"
name = "sign-return"
start = {{ x_m = 0.0, y_m = 0.0 }}
goal = {{ x_m = 4.0, y_m = 3.0 }}
[walker]
waypoints = [[1.0, 0.0], [1.0, -2.5], [4.0, -2.5], [4.0, 3.0]]
at_end = "stop"
{}"#,
        head_high_sign(4.0)
    ));
    let mut config = quick(20.0);
    config.mount.pitch_deg = 10.0;
    config.guide = GuideKind::Route;
    for seed in [1, 5, 7, 8, 10] {
        let out = walk(&w, &config, seed);
        let unwarned: Vec<_> =
            out.contacts.iter().filter(|c| c.part == Part::Body && c.warned_ago_s.is_none()).collect();
        assert!(unwarned.is_empty(), "seed {seed}: {unwarned:?}");
        // not for want of coming near it: the body came within 0.3 m of the sign
        assert!(out.min_clearance_m < 0.3, "seed {seed}: {:.2} m", out.min_clearance_m);
    }
}

#[test]
fn sweeping_the_cane_along_the_walls_of_a_clear_corridor_raises_no_rumble() {
    // 2 m wide: every sweep points the camera's path at a wall 3.4 m ahead, which a time
    // to collision without the user's own motion taken out reads as an approach
    let w = corridor_of_width("narrow", 2.0, "");
    for seed in [1, 2, 3] {
        let out = walk(&w, &quick(20.0), seed);
        assert!(out.completed, "seed {seed}: ended at {:?}", out.end_xy_m);
        assert_eq!(out.signals, 0, "seed {seed}: rumble in a clear corridor");
        assert!(out.contacts.is_empty(), "seed {seed}: {:?}", out.contacts);
    }
}

#[test]
fn user_who_ignores_the_rumble_walks_into_a_bench_that_was_in_view() {
    let w = world(
        r#"
name = "bench"
start = { x_m = 0.0, y_m = 0.0 }
goal = { x_m = 6.0, y_m = 0.0 }
[[boxes]]
label = "bench"
center = [3.0, 0.0]
size_m = [1.0, 2.0]
top_m = 0.4
"#,
    );
    let mut config = quick(6.0);
    config.user.reaction_s = 1000.0;
    let out = walk(&w, &config, 1);
    let body: Vec<_> = out.contacts.iter().filter(|c| c.part == Part::Body).collect();
    assert_eq!(body.len(), 1, "{:?}", out.contacts);
    assert!(body[0].in_fov && !body[0].head_high, "{:?}", body[0]);
    assert!(body[0].seen_ago_s.is_some_and(|s| s < 0.1), "{:?}", body[0]);
    // the rumble began about 1.2 m before the bench (1 m/s): felt for over a second
    assert!(body[0].warned_ago_s.is_some_and(|s| s > 1.0), "{:?}", body[0]);
    let lead = LeadTimes::of(std::slice::from_ref(&out), Part::Body);
    // ... which is too late for a user who takes 1000 s to react
    assert_eq!(lead, LeadTimes { not_warned: 0, too_late: 1, in_time: 0 });
    assert!(out.count(Part::Cane, None) >= 1, "the cane found it first");
}

#[test]
fn user_standing_at_a_step_down_is_never_let_walk_off_it_unwarned() {
    // the sound leads across the sunken area of `step-down`: the user stops at its edge
    // again and again, turns in place and walks on. The thesis's ground guard (0.2 m
    // either way) took the floor 18 cm below for the ground once it filled the view,
    // the drop-off vanished and the user stepped off the edge with nothing felt.
    let w = World::builtin("step-down").and_then(Result::ok).unwrap_or_else(|| panic!("step-down"));
    // The guard alone is compared with edges off (remembered, they would warn of the
    // edge too) and side cues debounced (not, seed 2 also cuts the area's corner beside
    // the path: `a_step_corner_beside_the_path_is_steered_round_and_remembered`).
    let unwarned = |max_offset_drop_m: f32, guard_alone: bool| {
        let mut config = quick(40.0);
        config.perception.ground.max_offset_drop_m = max_offset_drop_m;
        config.perception.dropoff.edges = !guard_alone;
        config.perception.hysteresis.hold_sides = guard_alone;
        (1..=2)
            .map(|seed| walk(&w, &config, seed))
            .flat_map(|out| out.contacts)
            .filter(|c| c.part == Part::Body && c.kind == "DropOff" && c.warned_ago_s.is_none())
            .count()
    };
    assert_eq!(unwarned(0.08, false), 0, "the defaults");
    assert_eq!(unwarned(0.08, true), 0, "our guard");
    assert!(unwarned(0.2, true) >= 2, "the thesis's guard lets the user off the edge unwarned");
}

#[test]
fn a_step_corner_beside_the_path_is_steered_round_and_remembered() {
    // with the raw rumble the user of seed 2 turned back towards the sound past the
    // sunken area's corner and grazed it 37.5 s in, the corner long out of the path
    // ahead that the drop-off survey watches. Since the ground is looked for only near
    // the mount's height, the survey alone no longer lets seeds 1-6 cut it (measured);
    // with the edges in the costs and the memory none touches it either.
    let w = World::builtin("step-down").and_then(Result::ok).unwrap_or_else(|| panic!("step-down"));
    for seed in 1..=6 {
        let mut config = quick(40.0);
        config.perception.hysteresis.enabled = false;
        let out = walk(&w, &config, seed);
        let drop: Vec<_> = out.contacts.iter().filter(|c| c.part == Part::Body && c.kind == "DropOff").collect();
        assert!(drop.is_empty(), "seed {seed}: {drop:?}");
    }
}

#[test]
fn a_user_turning_at_a_step_edge_is_never_told_clear_along_it() {
    // seed 4 follows the sound to the sunken area's north edge, is stopped there with
    // the feet 1 cm from it and turns in place. The edge under the feet was never in
    // view (the view begins 0.72 m ahead) and only the far floor of the area was seen:
    // facing along the edge it was "clear", and 60.3 s in the user stepped off it.
    // Seed 18 is stopped with the feet 4 cm from the area's north-west corner, turns in
    // place and faces south-west, off the corner: the corner lies between the feet and
    // the camera, where the cost functions do not look (they take what lies ahead of
    // the camera), and 55.7 s in the user stepped off it with nothing felt.
    let w = World::builtin("step-down").and_then(Result::ok).unwrap_or_else(|| panic!("step-down"));
    for (seed, timeout_s) in [(4, 64.0), (18, 58.0)] {
        let out = walk(&w, &quick(timeout_s), seed);
        let drop: Vec<_> = out.contacts.iter().filter(|c| c.part == Part::Body && c.kind == "DropOff").collect();
        assert!(drop.is_empty(), "seed {seed}: {drop:?}");
    }
}

/// An open floor with a wall across the way at `x_m`, from `y_from_m` to `y_to_m`; the
/// goal's sound comes from x = 9.
fn wall_across(name: &str, x_m: f64, y_from_m: f64, y_to_m: f64) -> World {
    world(&format!(
        r#"
name = "{name}"
start = {{ x_m = 0.0, y_m = 0.0 }}
goal = {{ x_m = 9.0, y_m = 0.0 }}
[[walls]]
label = "wall"
from = [{x_m:.1}, {y_from_m:.1}]
to = [{x_m:.1}, {y_to_m:.1}]
"#
    ))
}

/// [`quick`] for a user with no jitter: the start and the reaction time as given.
fn exact(timeout_s: f64) -> WalkConfig {
    WalkConfig { reaction_jitter: 0.0, start_jitter: (0.0, 0.0), ..quick(timeout_s) }
}

#[test]
fn slower_reaction_brings_the_user_closer_to_a_wall_ahead() {
    let w = wall_across("wall", 5.0, -4.0, 4.0);
    let clearance = |reaction_s: f64| {
        let mut c = exact(5.5);
        c.user.reaction_s = reaction_s;
        walk(&w, &c, 1).min_clearance_m
    };
    let (fast, medium, slow) = (clearance(0.2), clearance(0.8), clearance(1.6));
    assert!(fast > medium && medium > slow, "clearances {fast} > {medium} > {slow}");
    assert!(fast > 0.3, "a quick user stays well clear: {fast}");
}

#[test]
fn faster_turning_user_swings_further_past_the_clear_heading() {
    // a wall across the way, open to the north: the rumble turns the user left until
    // the path is clear, and they stop turning only a reaction time after it stops
    let w = wall_across("wall-open-north", 4.0, -4.0, 1.0);
    let swing = |turn_rate_deg_s: f64| {
        let mut c = exact(6.0);
        c.user.turn_rate_deg_s = turn_rate_deg_s;
        c.trace = true;
        let out = walk(&w, &c, 1);
        assert_eq!(out.count(Part::Body, None), 0, "{turn_rate_deg_s} deg/s: {:?}", out.contacts);
        out.trace.iter().map(|r| r.yaw_deg.abs()).fold(0.0, f64::max)
    };
    let (slow, fast) = (swing(30.0), swing(90.0));
    assert!(slow > 15.0, "the slow user turned away too: {slow:.0} deg");
    assert!(fast > slow + 30.0, "90 deg/s swung {fast:.0} deg, 30 deg/s {slow:.0} deg");
}

#[test]
fn a_shorter_cane_keeps_its_tip_off_a_wall_the_long_cane_touches() {
    // the cane alone (no rumble) straight at a wall: the user walks until the tip
    // touches, then turns away; the body is then a tip's reach from the wall
    let w = wall_across("wall", 5.0, -4.0, 4.0);
    let first_touch = |cane_length_m: f64| {
        let mut c = exact(8.0);
        c.rumble = false;
        c.mount.cane_length_m = cane_length_m;
        c.trace = true;
        let out = walk(&w, &c, 1);
        let touch = out.contacts.iter().find(|k| k.part == Part::Cane).map(|k| k.t_s);
        let t = touch.unwrap_or_else(|| panic!("{cane_length_m} m cane never touched: {:?}", out.contacts));
        let at = out.trace.iter().take_while(|r| r.t_s <= t).last().map(|r| r.x_m).unwrap_or(f64::NAN);
        // the wall's face is 5 cm short of its centre line
        4.95 - at
    };
    let (thesis, long) = (first_touch(1.1), first_touch(1.3));
    println!("first cane touch with the body {thesis:.3} m (1.1 m cane) and {long:.3} m (1.3 m) from the wall");
    // tip ahead of the body: 0.25 m to the hand, then sqrt(L^2 - 1) along the floor
    // (swept +-17 degrees, the tip reaches a little less far straight ahead)
    assert!((0.60..=0.75).contains(&thesis), "1.1 m cane touched with the body {thesis:.2} m from the wall");
    assert!((0.97..=1.10).contains(&long), "1.3 m cane touched with the body {long:.2} m from the wall");
}

/// The corridor with its floor one stair step (0.18 m) lower from x = 4 to 6, wall
/// to wall; the goal's sound comes from beyond it.
fn step_down_ahead() -> World {
    corridor(
        "step-ahead",
        r#"
[[floor_regions]]
label = "step down"
center = [5.0, 0.0]
size_m = [2.0, 2.9]
height_m = -0.18
"#,
    )
}

#[test]
fn dropoff_detection_stops_the_user_before_a_step_down_that_the_thesis_pipeline_walks_into() {
    let w = step_down_ahead();
    // first time the body steps over the edge, within 9 s (the edge is 3.8 m ahead)
    let stepped_in = |dropoff: bool, seed: u64| {
        let mut c = quick(9.0);
        c.perception.dropoff.enabled = dropoff;
        let out = walk(&w, &c, seed);
        out.contacts.iter().find(|c| c.part == Part::Body && c.label == "step down").map(|c| c.t_s)
    };
    for seed in [1, 3] {
        assert_eq!(stepped_in(true, seed), None, "seed {seed}: warned and stopped before the edge");
        let t = stepped_in(false, seed);
        assert!(t.is_some(), "seed {seed}: without the switch the user steps down");
    }
}

#[derive(Debug, Parser)]
struct Cli {
    #[command(flatten)]
    args: CourseArgs,
}

#[test]
fn options_and_worlds_the_course_cannot_serve_are_refused_before_walking() {
    let run = |line: &str| {
        let argv = std::iter::once("course").chain(line.split_whitespace());
        study::run(&Cli::parse_from(argv).args).map_err(|e| format!("{e:#}"))
    };
    let err = run("--world corridor --guide route --route-map floor-plan --runs 1").unwrap_err();
    assert!(err.contains("world `corridor` has no floor-plan route") && err.contains("[floor_plan_route]"), "{err}");
    let err = run("--guide route --route-lookahead-m=25 --runs 1").unwrap_err();
    assert!(err.contains("--route-lookahead-m must be between 0"), "{err}");
    let err = run("--world building --runs 1").unwrap_err();
    assert!(err.contains("goal on floor 1 and its start on floor 0") && err.contains("no stairs or lifts"), "{err}");
    let err = run("--cane-length-m 2 --runs 1").unwrap_err();
    assert!(err.contains("--cane-length-m must be between 1.05 and 1.6 m"), "{err}");
    let err = run("--oracle-sees perception --runs 1").unwrap_err();
    assert!(err.contains("go with --oracle"), "{err}");
    let err = run("--oracle goal --oracle-turn-rate-deg-s 0 --runs 1").unwrap_err();
    assert!(err.contains("--oracle-turn-rate-deg-s must be in (0, 720]"), "{err}");
}

#[test]
fn the_cues_model_is_the_typical_user_unless_told_to_know_this_one() {
    // the compute agent's cue models the typical user whoever walks; the study does the
    // same unless --cue-model user gives it this user's mean (a device that had learnt it)
    let user =
        "--runs 1 --body-gyro --predictive --pose truth --reaction-s 0.8 --walk-speed-m-s 1.3 --turn-rate-deg-s 40";
    let config = |line: &str| {
        let cli = Cli::parse_from(std::iter::once("course").chain(line.split_whitespace()));
        cli.args.walk_config().unwrap_or_else(|e| panic!("{line}: {e:#}"))
    };
    let modelled = |line: &str| {
        let c = config(line);
        let m = c.predictive.unwrap_or_else(|| panic!("{line}: no predictive cue")).user;
        ((c.user.reaction_s, c.user.walk_speed_m_s), (m.reaction_s, m.walk_speed_m_s, m.turn_rate_deg_s))
    };
    assert_eq!(
        modelled(user),
        ((0.8, 1.3), (0.5, 1.0, 60.0)),
        "the user walks as told, the cue models the typical one"
    );
    assert_eq!(modelled(&format!("{user} --cue-model user")), ((0.8, 1.3), (0.8, 1.3, 40.0)));
    // learnt: the typical user's to begin with, the turning rate learnt on the walk
    assert_eq!(modelled(&format!("{user} --cue-model learnt")), ((0.8, 1.3), (0.5, 1.0, 60.0)));
    let learns = |line: &str| config(line).predictive.is_some_and(|p| p.learn_turn_rate);
    assert!(
        learns(&format!("{user} --cue-model learnt")) && !learns(user) && !learns(&format!("{user} --cue-model user"))
    );
    let guard = "--runs 1 --body-gyro --body-guard --reaction-s 0.8 --cue-model user";
    assert_eq!(config(guard).predictive.map(|p| p.user.reaction_s), Some(0.8));
    let parsed = |line: &str| Cli::parse_from(std::iter::once("course").chain(line.split_whitespace())).args;
    let v = parsed(user).with_flags("--cue-model user").unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(v.walk_config().ok().and_then(|c| c.predictive).map(|p| p.user.reaction_s), Some(0.8));
    let e = parsed("--runs 1 --reaction-s 0.8 --cue-model user").walk_config().map(|_| ()).unwrap_err();
    assert!(format!("{e:#}").contains("--cue-model goes with --predictive or --body-guard"), "{e:#}");
}

#[test]
fn versus_walks_the_same_seeds_and_tells_a_switch_that_matters_from_the_spread() {
    let parsed = |line: &str| Cli::parse_from(std::iter::once("course").chain(line.split_whitespace())).args;
    let base = parsed("--runs 4 --cost cacf");
    let v = base.with_flags("--no-rumble --timeout-s 20").unwrap();
    assert!(v.no_rumble && !base.no_rumble);
    assert_eq!((v.runs, v.seed, v.cost, v.timeout_s), (4, 1, base.cost, 20.0), "the rest is kept");
    let refused = |flags: &str| match base.with_flags(flags) {
        Ok(a) => panic!("{flags}: accepted as {a:?}"),
        Err(e) => format!("{e:#}"),
    };
    assert!(refused("--seed 5").contains("must stay the same"));
    assert!(refused("--world corridor").contains("must stay the same"));
    assert!(refused("--versus=--no-ttc").contains("cannot be given inside"));
    assert!(refused("--json").contains("cannot be given inside"));
    let e = refused("--no-such-switch");
    assert!(e.contains("--versus \"--no-such-switch\"") && e.contains("--no-such-switch'"), "{e}");
    // what a flag needs may have been given before --versus; what it excludes too
    assert!(refused("--predictive").contains("--body-gyro"), "the cue needs the body gyro");
    let gyro = parsed("--runs 4 --body-gyro");
    let v = gyro.with_flags("--predictive --pose truth").unwrap();
    assert!(v.predictive && v.body_gyro && v.pose == study::walk::PoseSource::Truth, "{v:?}");
    assert!(gyro.with_flags("--body-gyro --predictive").is_ok_and(|v| v.predictive), "given again");
    let v = parsed("--runs 4 --body-gyro --predictive").with_flags("--localization-map mapped --odometry-noise 2");
    assert!(v.is_ok_and(|v| v.localization_map != base.localization_map && v.odometry_noise == 2.0));
    assert!(gyro.with_flags("--body-guard").is_ok_and(|v| v.body_guard));
    let e = parsed("--runs 4 --body-gyro --oracle goal").with_flags("--predictive").unwrap_err();
    assert!(format!("{e:#}").contains("--oracle and --predictive, which exclude each other"), "{e:#}");
    let e = parsed("--runs 4 --chest").with_flags("--chest-pitch-deg 20").map(|v| v.chest_pitch_deg);
    assert_eq!(e.ok(), Some(20.0), "the chest camera given before");

    // the device on and off, seed by seed, in a dead end: with it off no rumble, and the
    // body walks into the wall in every walk
    let w = dead_end();
    let on = study(&w, &quick(10.0), 4, 1);
    let off = study(&w, &WalkConfig { rumble: false, ..quick(10.0) }, 4, 1);
    let diffs = compare(&on.rows, &off.rows).expect("same seeds");
    let get = |name: &str| diffs.iter().find(|(n, _)| *n == name).map(|d| d.1).unwrap();
    let signals = get("signals");
    assert!(signals.is_clear() && signals.high < 0.0 && signals.lower == 4, "{signals:?}");
    let body = |r: &Row| r.body_in_fov + r.body_out_fov;
    assert!(on.rows.iter().all(|r| body(r) == 0.0), "{:?}", on.rows);
    assert!(off.rows.iter().all(|r| body(r) >= 1.0), "{:?}", off.rows);
    assert_eq!(get("body_in_fov").higher + get("body_out_fov").higher, 4, "{diffs:?}");
    assert_eq!((get("completed_pct").low, get("completed_pct").high), (0.0, 0.0), "neither reaches the goal");
}

#[test]
fn course_over_generated_corridors_walks_every_world_on_the_same_seeds_with_the_device_on_and_off() {
    // walks of 4 s: the argument plumbing, not the figures (docs/beyond-the-course.md)
    let parsed = |line: &str| Cli::parse_from(std::iter::once("course").chain(line.split_whitespace())).args;
    let args = parsed(
        "--worlds gen:corridor --count 2 --runs 1 --timeout-s 4 --guide route --route-map floor-plan --versus=--no-rumble",
    );
    let report = study::world_groups::walk_groups(&args).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!((report.groups.len(), report.walks), (1, 4), "2 worlds, each walked once with the device on and off");
    let g = &report.groups[0];
    assert_eq!(g.group.worlds, ["gen:corridor:1", "gen:corridor:2"]);
    assert_eq!(g.this.worlds.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(), g.group.worlds);
    let off = g.versus.as_ref().unwrap_or_else(|| panic!("no versus walks"));
    for rows in [&g.this.rows, &off.rows] {
        assert_eq!(rows.iter().map(|r| r.seed).collect::<Vec<_>>(), [Some(1), Some(1)]);
        assert!(rows.iter().all(|r| r.time_s <= 4.0 + 1e-9 && r.completed == 0.0), "{rows:?}");
    }
    assert!(off.rows.iter().all(|r| r.signals == 0.0), "the device off gives no signal: {:?}", off.rows);
    let simulated: f64 = g.this.rows.iter().chain(&off.rows).map(|r| r.time_s).sum();
    assert!((report.simulated_s - simulated).abs() < 1e-9);

    let text = study::world_groups::text(&args, &report).unwrap_or_else(|e| panic!("{e:#}"));
    let walks_of = |label: &str| {
        text.lines()
            .filter(|l| l.starts_with(label))
            .map(|l| l[label.len()..].split_whitespace().next().unwrap_or_default().to_string())
            .collect::<Vec<_>>()
    };
    assert_eq!(walks_of("gen:corridor (mean) "), ["2", "2"], "{text}");
    assert_eq!(walks_of("gen:corridor:2 "), ["1", "1"], "{text}");
    assert_eq!(walks_of("overall "), ["2"], "{text}");
    assert!(text.contains("versus `--no-rumble`, the same walks:") && text.contains("4 walks, "), "{text}");
    let json = study::world_groups::json(&args, &report).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(json["groups"][0]["this"]["walks"], 2);
    assert_eq!(json["groups"][0]["versus"]["worlds"][1]["world"], "gen:corridor:2");
    assert_eq!(json["groups"][0]["difference"]["signals"]["n"], 2);
    assert_eq!(json["versus"]["configuration"]["rumble"], false);
}

#[test]
fn worlds_that_are_not_there_or_flags_that_do_not_fit_groups_are_refused_before_walking() {
    let run = |line: &str| {
        let argv = std::iter::once("course").chain(line.split_whitespace());
        match Cli::try_parse_from(argv) {
            Ok(cli) => study::run(&cli.args).map_err(|e| format!("{e:#}")),
            Err(e) => Err(e.to_string()),
        }
    };
    let err = run("--worlds gen:corridor,gen:lobby:x --runs 1").unwrap_err();
    assert!(err.contains("gen:lobby:x: seed must be a whole number"), "{err}");
    let err = run("--worlds gen:cave --runs 1").unwrap_err();
    assert!(
        err.contains("gen:cave: unknown kind `cave`: use gen:corridor, gen:office, gen:lobby or gen:street"),
        "{err}"
    );
    let err = run("--world corridor --worlds gen:corridor").unwrap_err();
    assert!(err.contains("cannot be used with"), "{err}");
    let err = run("--worlds gen:street --trace /tmp/x.csv").unwrap_err();
    assert!(err.contains("--trace and --contacts go with --world"), "{err}");
    let err = run("--worlds gen:office,corridor --guide route --route-map floor-plan --runs 1").unwrap_err();
    assert!(err.contains("world `corridor` has no floor-plan route"), "{err}");
    // the device's place: --pose with what uses it; the filter's map with the filter
    let err = run("--world corridor --pose truth").unwrap_err();
    assert!(err.contains("--pose goes with --predictive or --guide spoken"), "{err}");
    let err = run("--world corridor --guide spoken --pose truth --localization-map mapped").unwrap_err();
    assert!(err.contains("--localization-map goes with --pose filter"), "{err}");
    let err = run("--world corridor --localization-map mapped").unwrap_err();
    assert!(err.contains("(and --predictive or --guide spoken)"), "{err}");
    // the odometry made worse: only where the filter runs, and a factor in reason
    let err = run("--world corridor --odometry-noise 2").unwrap_err();
    assert!(err.contains("--odometry-noise goes with --pose filter"), "{err}");
    let err = run("--world corridor --guide spoken --odometry-noise 11").unwrap_err();
    assert!(err.contains("--odometry-noise must be between 0 (perfect odometry) and 10"), "{err}");
    let err = run("--world corridor --guide spoken --odometry-noise nan").unwrap_err();
    assert!(err.contains("--odometry-noise must be between"), "{err}");
    // ways round are the navigator's: only with its spoken guide
    let err = run("--world corridor --guide route --ways-round").unwrap_err();
    assert!(err.contains("--ways-round goes with --guide spoken"), "{err}");
    let base = Cli::parse_from(["course", "--worlds", "gen:office", "--count", "3"]).args;
    let refused = base.with_flags("--count 4").err().map(|e| format!("{e:#}")).unwrap_or_default();
    assert!(refused.contains("--count, --seed and --runs must stay the same"), "{refused}");
}

/// The built-in world `name` (issue 29's `lobby-bench`: a bench, bollards and a sunken
/// area by the floor-plan route; `corridor-narrow`), walked along its floor-plan route
/// with the body's gyro.
fn builtin_by_route(name: &str, timeout_s: f64) -> (World, WalkConfig) {
    let w = match World::builtin(name) {
        Some(Ok(w)) => w,
        other => panic!("{name}: {:?}", other.map(|r| r.err())),
    };
    let config = WalkConfig {
        guide: GuideKind::Route,
        route_map: study::walk::RouteMap::FloorPlan,
        body_gyro: true,
        ..quick(timeout_s)
    };
    (w, config)
}

#[test]
fn the_predictive_cue_takes_the_user_past_the_bench_where_the_cost_functions_hold_them_back() {
    // the cue from the route and the user's place (issue 32) lets the user walk the
    // route past the bench it keeps clear of; the cost functions, which look at what
    // stands ahead of the swept camera, turn the same user back and forth before it
    // (`docs/predictive-cue.md`: 4 walks 27 s and 19 signals against 193 s and 179)
    let (w, base) = builtin_by_route("lobby-bench", 60.0);
    // the user's true place (the filter is lost in this open lobby: next test)
    let predictive = WalkConfig {
        predictive: Some(study::walk::predictive_for(&base)),
        pose: study::walk::PoseSource::Truth,
        ..base.clone()
    };
    for seed in 1..=4 {
        let out = walk(&w, &predictive, seed);
        assert!(out.completed && out.time_s < 55.0, "seed {seed}: {}", out.verdict());
        assert_eq!(out.count(Part::Body, None), 0, "seed {seed}: {:?}", out.contacts);
        assert!(out.count(Part::Cane, None) <= 3, "seed {seed}: {:?}", out.contacts);
        assert!(out.signals <= 50, "seed {seed}: {} signals", out.signals);
    }
    // since the ground is looked for only near the mount's height (the bench top is
    // never the floor) the cost functions let 3 of these 4 walks through in 60 s, 1 of 4
    // before; the fourth they still hold back
    let held: Vec<_> = (1..=4).map(|seed| walk(&w, &base, seed)).collect();
    let through: Vec<_> = held.iter().map(|o| o.completed).collect();
    assert!(through.contains(&false), "the cost functions let every walk through: {through:?}");
}

#[test]
fn the_cue_learns_how_fast_the_user_turns_on_the_rumble_from_the_body_gyro() {
    // --cue-model learnt: the typical user's model (60°/s) to begin with; the body gyro
    // (sway, noise, bias) read while the user acts on a rumble gives the user's own rate
    // Taylor's course, the user heading for the music's sound: a rumble every 2 s or so
    let w = match World::builtin("taylor-course") {
        Some(Ok(w)) => w,
        other => panic!("taylor-course: {:?}", other.map(|r| r.err())),
    };
    let base = WalkConfig { body_gyro: true, ..quick(30.0) };
    for turn_rate_deg_s in [30.0, 60.0] {
        let user = study::virtual_user::UserParams { turn_rate_deg_s, ..base.user };
        let typical = study::walk::predictive_for(&base);
        let config = WalkConfig {
            user,
            predictive: Some(perception::predictive::PredictiveConfig { learn_turn_rate: true, ..typical }),
            pose: study::walk::PoseSource::Truth,
            ..base.clone()
        };
        for seed in 1..=2 {
            let out = walk(&w, &config, seed);
            let learnt = out
                .learnt_turn_rate_deg_s
                .unwrap_or_else(|| panic!("seed {seed}: nothing learnt: {} signals, {}", out.signals, out.verdict()));
            assert!((learnt - turn_rate_deg_s).abs() < 3.0, "seed {seed}: {learnt:.1}°/s for {turn_rate_deg_s}°/s");
        }
    }
}

/// The walk config of `--body-guard`: the predictive cue guarding the body alone on the
/// user's own way (no route, no place).
fn body_guard(base: &WalkConfig) -> WalkConfig {
    use perception::predictive::{Guards, PredictiveConfig};
    let cue = PredictiveConfig { guards: Guards::Body, own_way: true, ..study::walk::predictive_for(base) };
    WalkConfig { predictive: Some(cue), ..base.clone() }
}

#[test]
fn guarding_the_body_leaves_a_narrow_corridor_to_the_cane_and_keeps_the_body_off_a_corridors_bins() {
    // `corridor-narrow`: the cane alone walks it touching nothing; the cost functions
    // signal 17 times a walk there (`docs/beyond-the-course.md`). Guarding the body, the
    // device has nothing to say
    let (w, base) = builtin_by_route("corridor-narrow", 40.0);
    for seed in 1..=2 {
        let out = walk(&w, &body_guard(&base), seed);
        assert!(out.completed, "seed {seed}: {}", out.verdict());
        assert!(out.contacts.is_empty(), "seed {seed}: {:?}", out.contacts);
        assert!(out.signals <= 2, "seed {seed}: {} signals", out.signals);
    }
    // `gen:corridor:3` (a world nothing was tuned on): with the cane alone the body meets
    // what stands in the corridor 19 times in these two walks, taking 52 s a walk;
    // guarding the body, once, in 19 s
    let w = World::load("gen:corridor:3").unwrap_or_else(|e| panic!("{e}"));
    let base = WalkConfig { timeout_s: 90.0, ..base };
    let off = WalkConfig { rumble: false, ..base.clone() };
    let (mut guarded, mut alone) = (0, 0);
    for seed in 1..=2 {
        let out = walk(&w, &body_guard(&base), seed);
        assert!(out.completed && out.time_s < 40.0, "seed {seed}: {}", out.verdict());
        guarded += out.count(Part::Body, None);
        let out = walk(&w, &off, seed);
        assert!(out.completed, "seed {seed}, device off: {}", out.verdict());
        alone += out.count(Part::Body, None);
    }
    assert!(guarded <= 2 && alone >= 10, "body contacts: {guarded} guarded, {alone} with the cane alone");
}

#[test]
fn guarding_the_body_with_a_chest_camera_keeps_the_head_off_a_hanging_lamp() {
    // `hanging-lamp`: the route passes under a lamp 1.55 m up that the cane camera never
    // sees and its cane passes under: guarding the body, the head meets it on every walk.
    // With the chest camera (its obstacles in the look-ahead as what only the body can
    // touch, its state joined) once in four walks, a sign beside the lamp (measured:
    // seed 1, warned 1.6 s before)
    let (w, base) = builtin_by_route("hanging-lamp", 40.0);
    let guard = body_guard(&base);
    let with_chest = WalkConfig { chest: Some(sim::ChestMount::default()), ..guard.clone() };
    let head = |out: &study::walk::WalkOutcome| out.contacts.iter().filter(|c| c.head_high).count();
    let mut chest_head = 0;
    for seed in 1..=4 {
        let out = walk(&w, &guard, seed);
        assert!(out.completed, "seed {seed}, cane camera alone: {}", out.verdict());
        assert_eq!(head(&out), 1, "seed {seed}, cane camera alone: {:?}", out.contacts);
        let out = walk(&w, &with_chest, seed);
        assert!(out.completed, "seed {seed}, with the chest: {}", out.verdict());
        assert_eq!(out.count(Part::Body, None), head(&out), "seed {seed}, with the chest: {:?}", out.contacts);
        chest_head += head(&out);
    }
    assert!(chest_head <= 1, "{chest_head} head-high contacts in four walks with the chest camera");
}

#[test]
fn the_predictive_cue_on_the_particle_filters_place_walks_a_narrow_corridor_untouched() {
    // `corridor-narrow` (1.6 m, its bin, cabinet and sign kept clear of by the route): the
    // device's own filter on the floor plan, told where the walk starts, tracks within a
    // few decimetres and the cue from it lets the user walk the corridor touching nothing
    let (w, base) = builtin_by_route("corridor-narrow", 40.0);
    let config = WalkConfig { predictive: Some(study::walk::predictive_for(&base)), ..base };
    assert_eq!(config.pose, study::walk::PoseSource::Filter);
    for seed in 1..=2 {
        let out = walk(&w, &config, seed);
        assert!(out.completed, "seed {seed}: {}", out.verdict());
        assert!(out.contacts.is_empty(), "seed {seed}: {:?}", out.contacts);
        let e = out.localization.unwrap_or_else(|| panic!("seed {seed}: no filter"));
        let (rmse_m, tracked) = (e.position_rmse_m, e.frames);
        assert!(
            rmse_m < 0.4 && tracked * 10 >= out.frames * 9,
            "seed {seed}: {tracked} of {} frames, RMSE {rmse_m:.2} m",
            out.frames
        );
        assert_eq!(e.frames_over_1m, 0, "seed {seed}: frames tracked more than 1 m off");
    }
}

#[test]
fn on_the_mapped_map_the_filter_places_the_spoken_guides_user_in_the_open_lobby() {
    // lobby-bench: on the floor plan the filter is metres off on every walk (walls far
    // away, the bench, bollards and planter not on it: RMSE 5.9-7.1 m over seeds 1-4);
    // on the map a mapping run would record it is not (0.21-0.22 m)
    let (w, base) = builtin_by_route("lobby-bench", 40.0);
    let config =
        WalkConfig { guide: GuideKind::Spoken, localization_map: study::floor_plan::LocalizationMap::Mapped, ..base };
    let out = walk(&w, &WalkConfig { trace: true, ..config }, 2);
    let e = out.localization.expect("the guide speaks from the filter's place");
    let (rmse_m, tracked) = (e.position_rmse_m, e.frames);
    assert!(
        rmse_m < 0.4 && tracked * 10 >= out.frames * 6,
        "{tracked} of {} frames tracked, RMSE {rmse_m:.2} m",
        out.frames
    );
    // the trace carries the filter's estimate of each frame
    assert!(out.trace.iter().all(|r| r.estimate.is_some()), "a frame without the filter's estimate");
    let tracking: Vec<f64> = out
        .trace
        .iter()
        .filter_map(|r| r.estimate.map(|(e, s)| (r, e, s)))
        .filter(|(_, _, s)| *s == localization::Status::Tracking)
        .map(|(r, [x, y, _], _)| (x - r.x_m).hypot(y - r.y_m))
        .collect();
    let near = tracking.iter().filter(|&&e| e < 1.0).count();
    assert!(tracking.len() * 10 >= out.frames as usize * 6 && near == tracking.len(), "{near} of {}", tracking.len());
    // the walk's own count agrees with its trace (the walk counts the place each frame is
    // guided from, before the frame's correction; the trace shows it after: a frame apart)
    assert!(e.frames.abs_diff(tracking.len() as u32) <= 1, "{} frames against {}", e.frames, tracking.len());
    assert_eq!(e.frames_over_1m as usize, tracking.len() - near);
}

#[test]
fn the_spoken_guide_walks_the_user_down_the_narrow_corridor_and_round_its_corner() {
    // `--guide spoken`: no route handed to the user; the compute agent's navigator on
    // the floor plan, from the filter's place (followed from the told start until the
    // scans confirm it), speaks through the feedback step; the user walks by the words
    let (w, base) = builtin_by_route("corridor-narrow", 70.0);
    let config = WalkConfig { guide: GuideKind::Spoken, ..base };
    let out = walk(&w, &config, 1);
    assert!(out.completed && out.time_s < 60.0, "{} in {:.1} s", out.verdict(), out.time_s);
    assert_eq!(out.count(Part::Body, None), 0, "{:?}", out.contacts);
    assert!(out.count(Part::Cane, None) <= 2, "{:?}", out.contacts);
    // the route, the position found, the corner ahead and now; at most one prompt back
    // to the route
    let (heard, prompts) = out.heard.expect("the spoken guide counts what was heard");
    assert!(heard >= 4, "heard {heard} utterances");
    assert!(prompts <= 1, "{prompts} off-route prompts");
    let e = out.localization.expect("the guide speaks from the filter's place");
    let (rmse_m, tracked) = (e.position_rmse_m, e.frames);
    assert!(rmse_m < 0.4 && tracked > 0, "{tracked} frames tracked, RMSE {rmse_m:.2} m");
    assert_eq!(e.frames_over_1m, 0, "frames tracked more than 1 m off");
    // the heading the guide's turns are called from (measured 2.4-2.7° on seeds 1-3)
    assert!(e.heading_rmse_deg < 5.0, "heading RMSE {:.1}°", e.heading_rmse_deg);
}

#[test]
fn a_user_the_device_cannot_place_for_a_minute_is_asked_to_stop_and_is_not_left_to_walk_on() {
    // `gen:street:13`, walk seed 11: the cane camera sees open pavement, too few beams
    // for the filter, which loses the place 14 s in (docs/guidance.md, "Walking on
    // untold"). Told "position lost: walk on slowly while I look for it" and nothing
    // more, the user walked on along the street, 274 m in 300 s; asked to stop and turn
    // on the spot a minute after guidance last had a place, 55 m at most (measured).
    let cli = Cli::parse_from("course --guide spoken --body-gyro --compass --timeout-s 150".split_whitespace());
    let config = cli.args.walk_config().unwrap_or_else(|e| panic!("{e:#}"));
    let w = match World::load("gen:street:13") {
        Ok(w) => w,
        Err(e) => panic!("{e}"),
    };
    let out = walk(&w, &config, 11);
    let (unguided_m, longest_m) = out.unguided_m.expect("the spoken guide counts the metres walked unguided");
    // a minute at the walking pace at most, and standing (turning) after it
    assert!(longest_m <= 70.0, "{longest_m:.0} m walked at a stretch with no place for guidance");
    assert!(out.path_m <= 80.0 && unguided_m <= out.path_m, "{unguided_m:.0} of {:.0} m unguided", out.path_m);
    assert!(longest_m >= 30.0, "the filter lost the place early: {longest_m:.0} m (the walk changed)");
}

#[test]
fn the_worn_phones_compass_keeps_the_spoken_guide_out_of_a_lobbys_turned_copy() {
    // `gen:lobby:3`, walk seed 1 (docs/localization.md, "A compass"): on the floor plan
    // alone the filter steps, one `Tracking` estimate at a time, into a copy of the
    // lobby turned round and guides from there; the compass, averaged over the walking
    // and read within 45°, rules that copy out. Walks change with what the user hears
    // and where the filter's particles may go: the walks this test first measured
    // (`gen:lobby:10` seed 6, then `gen:office:7` seed 3) no longer go into a turned
    // copy without the compass, and since particles may not walk through walls few
    // walks do (docs/localization.md, "A person does not walk through walls"); the
    // compass's own test is the tracker's square room.
    let parsed = |line: &str| {
        let cli = Cli::parse_from(std::iter::once("course").chain(line.split_whitespace()));
        cli.args.walk_config().unwrap_or_else(|e| panic!("{e:#}"))
    };
    let w = match World::load("gen:lobby:3") {
        Ok(w) => w,
        Err(e) => panic!("{e}"),
    };
    let flags = "--guide spoken --body-gyro";
    let with = walk(&w, &parsed(&format!("{flags} --compass")), 1);
    let e = with.localization.expect("the guide speaks from the filter's place");
    // measured: none of 1,619 frames tracked more than 45 degrees off (RMSE 2.3 m: a
    // place shifted along the lobby, which no heading rules out)
    assert!(e.frames_turned <= 20, "frames tracked more than 45 degrees off with the compass: {e:?}");
    assert!(e.position_rmse_m < 3.5, "with the compass: {e:?}");
    let without = walk(&w, &parsed(flags), 1);
    let e = without.localization.expect("the guide speaks from the filter's place");
    // measured: 618 of 955 frames more than 45 degrees off, RMSE 7.4 m
    assert!(e.frames_turned >= 300 && e.position_rmse_m > 4.0, "without the compass: {e:?}");
}
