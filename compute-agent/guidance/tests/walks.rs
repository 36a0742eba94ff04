//! Guided walks on planned routes: a virtual walker follows the route at 1 m/s, one pose
//! every 100 ms, and every instruction the guide gives is checked word for word, with
//! where and when it was given.
//!
//! The floor: a corridor 2 m wide along y 10.5..12.5 from x 0.5 to 26.5, and a corridor
//! down from it at x 18.5..20.5 to y 0.5. Walking east from the west end and down is a
//! straight corridor, then a right turn.

use std::path::Path;

use guidance::{
    Barometer, DirectionStyle, DistanceUnits, GuidanceProfile, Guide, Instruction, InstructionKind, UserPose,
};
use map::{Building, Cell, Floor, OccupancyGrid, Origin, SemanticLayer};
use planning::{BuildingPlanner, FloorPoint, NavGraphConfig, Planner, Route, UserProfile};
use schemas::Priority;

const RES_M: f64 = 0.05;
const TICK_MS: u64 = 100;
const STEP_M: f64 = 0.1;

/// A 27 x 13 m floor, free where `free(x, y)` says, walls elsewhere.
fn floor_where(free: impl Fn(f64, f64) -> bool) -> OccupancyGrid {
    let (w, h) = ((27.0 / RES_M) as usize, (13.0 / RES_M) as usize);
    let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
    let mut g = OccupancyGrid::filled(w, h, RES_M, o, Cell::Occupied).unwrap();
    for r in 0..h {
        for c in 0..w {
            let (x, y) = g.cell_center(c, r);
            if free(x, y) {
                g.set(c, r, Cell::Free);
            }
        }
    }
    g
}

fn corridor_floor() -> OccupancyGrid {
    floor_where(|x, y| {
        let across = (0.5..=26.5).contains(&x) && (10.5..=12.5).contains(&y);
        let down = (18.5..=20.5).contains(&x) && (0.5..=12.5).contains(&y);
        across || down
    })
}

fn planner() -> Planner {
    Planner::new(0, &corridor_floor(), &NavGraphConfig::default())
}

const LAYER: &str = r#"
[[door]]
number = "214"
x = 10.0
y = 12.5
floor = 0
normal = [0.0, -1.0]

[[area]]
name = "east wing"
floor = 0
polygon = [[0.0, 0.0], [27.0, 0.0], [27.0, 13.0], [0.0, 13.0]]

[[area]]
name = "corridor"
floor = 0
parent = "east wing"
polygon = [[0.5, 10.5], [26.5, 10.5], [26.5, 12.5], [0.5, 12.5]]
"#;

fn layer() -> SemanticLayer {
    SemanticLayer::parse(LAYER, Path::new("corridor.toml")).unwrap()
}

/// The straight-then-right route: from the west end of the corridor to the foot of the
/// corridor down.
fn l_route(planner: &mut Planner) -> Route {
    planner.plan([1.5, 11.5], [19.5, 1.5]).unwrap()
}

/// Poses every `STEP_M` along `path`, facing along the segment being walked.
fn poses_along(path: &[[f64; 2]]) -> Vec<([f64; 2], f64)> {
    let mut out = Vec::new();
    for s in path.windows(2) {
        let (a, b) = (s[0], s[1]);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let heading = (b[1] - a[1]).atan2(b[0] - a[0]);
        let n = (len / STEP_M).round().max(1.0) as usize;
        for k in 0..n {
            let t = k as f64 / n as f64;
            out.push(([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])], heading));
        }
    }
    if let (Some(&last), Some(&(_, h))) = (path.last(), out.last()) {
        out.push((last, h));
    }
    out
}

/// One instruction as the walker heard it.
#[derive(Debug)]
struct Said {
    t_ms: u64,
    at: [f64; 2],
    instruction: Instruction,
}

/// Walks the poses from `t0_ms`, one per tick, and collects what the guide said.
fn walk(
    guide: &mut Guide,
    poses: &[([f64; 2], f64)],
    floor: i32,
    t0_ms: u64,
    planner: Option<&Planner>,
    confident: impl Fn(usize) -> bool,
) -> Vec<Said> {
    let mut said = Vec::new();
    for (k, &(at, heading)) in poses.iter().enumerate() {
        let t_ms = t0_ms + k as u64 * TICK_MS;
        let pose = UserPose { x_m: at[0], y_m: at[1], heading_rad: heading, floor, confident: confident(k) };
        if let Some(i) = guide.step(&pose, t_ms, planner.map(|p| p.graph())) {
            said.push(Said { t_ms, at, instruction: i });
        }
    }
    said
}

fn texts(said: &[Said]) -> Vec<&str> {
    said.iter().map(|s| s.instruction.text.as_str()).collect()
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn pose(at: [f64; 2], heading_rad: f64) -> UserPose {
    UserPose { x_m: at[0], y_m: at[1], heading_rad, floor: 0, confident: true }
}

/// Every instruction goes out at Message priority, never interrupting, with a key; a
/// door in passing, an area entered and "position uncertain" at Text, which a turn cuts
/// off.
fn assert_priorities(said: &[Said]) {
    for s in said {
        let speech = s.instruction.speech();
        let tells_only = matches!(
            s.instruction.kind,
            InstructionKind::PassingDoor { .. }
                | InstructionKind::EnteringArea { .. }
                | InstructionKind::TurnThen { .. }
        ) || s.instruction.text.starts_with("Position uncertain:");
        let expected = if tells_only { Priority::Text } else { Priority::Message };
        assert_eq!(speech.priority, expected, "{s:?}");
        assert!(!speech.interrupt, "{s:?}");
        assert!(!speech.dedup_key.is_empty() && speech.ttl_ms > 0, "{s:?}");
    }
}

/// What the route itself said, and when: the doors and areas said in passing left out.
fn route_words(said: &[Said]) -> Vec<(u64, String)> {
    said.iter()
        .filter(|s| {
            !matches!(s.instruction.kind, InstructionKind::PassingDoor { .. } | InstructionKind::EnteringArea { .. })
        })
        .map(|s| (s.t_ms, s.instruction.text.clone()))
        .collect()
}

/// No two instructions closer than the spacing, except arrival (and the "then" after a
/// "now", which neither keeps the spacing nor counts for it).
fn assert_spaced(said: &[Said], min_ms: u64) {
    let said: Vec<&Said> =
        said.iter().filter(|s| !matches!(s.instruction.kind, InstructionKind::TurnThen { .. })).collect();
    for w in said.windows(2) {
        if w[1].instruction.kind != InstructionKind::Arrived {
            assert!(w[1].t_ms - w[0].t_ms >= min_ms, "{:?} then {:?}", w[0], w[1]);
        }
    }
}

#[test]
fn the_l_route_is_a_straight_corridor_then_a_right_turn() {
    let mut p = planner();
    let r = l_route(&mut p);
    let corner = r.waypoints[1];
    // one right turn; any other bend smoothing left is below the straight-on threshold
    let p = GuidanceProfile::default();
    let bends: Vec<guidance::Turn> = r
        .waypoints
        .windows(3)
        .map(|w| {
            let a = (w[1][1] - w[0][1]).atan2(w[1][0] - w[0][0]);
            let b = (w[2][1] - w[1][1]).atan2(w[2][0] - w[1][0]);
            guidance::Turn::of(-(b - a).to_degrees(), &p)
        })
        .collect();
    assert_eq!(bends[0], guidance::Turn::Normal(guidance::Side::Right), "{:?}", r.waypoints);
    assert!(bends[1..].iter().all(|&t| t == guidance::Turn::Straight), "{:?}", r.waypoints);
    assert!((18.5..19.5).contains(&corner[0]) && (10.5..11.5).contains(&corner[1]), "{corner:?}");
}

#[test]
fn straight_corridor_then_right_turn_is_announced_once_at_the_distance_then_now() {
    let mut p = planner();
    let route = l_route(&mut p);
    let corner = route.waypoints[1];
    let goal = route.goal();
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), GuidanceProfile::default());
    let said = walk(&mut guide, &poses_along(&route.waypoints), 0, 0, Some(&p), |_| true);
    assert_eq!(
        texts(&said),
        [
            "Route to the stairs: 25 metres. Go straight on.",
            "Passing door 214, on your left.",
            "In 6 metres, turn right.",
            "Turn right now.",
            "You have arrived at the stairs."
        ],
        "{said:#?}"
    );
    assert_eq!(said[0].t_ms, 0);
    // the door (x 10, in the corridor's north wall) as the user comes level with it: a
    // metre before it, the first pose of its window
    assert!((said[1].at[0] - 9.0).abs() < STEP_M, "{said:#?}");
    assert_eq!(said[1].instruction.kind, InstructionKind::PassingDoor { number: "214".into() });
    assert!(!said[1].instruction.vibrate_first, "it asks nothing: no notice tap");
    // the door keeps the spacing after the route's start, and the turn's words come
    // where they come without it
    assert_spaced(&said, 3000);
    assert_priorities(&said);
    let said: Vec<Said> =
        said.into_iter().filter(|s| !matches!(s.instruction.kind, InstructionKind::PassingDoor { .. })).collect();
    // announced at the first pose within 6 m of the corner, "now" at the first within 1.5 m
    let d_ahead = dist(said[1].at, corner);
    assert!(d_ahead <= 6.0 && d_ahead > 6.0 - STEP_M - 1e-9, "{d_ahead}");
    let d_now = dist(said[2].at, corner);
    assert!(d_now <= 1.5 && d_now > 1.5 - STEP_M - 1e-9, "{d_now}");
    // at 1 m/s, the times follow from the distances walked
    let first_leg = dist(route.waypoints[0], corner);
    let expect_ms = |d: f64| ((first_leg - d) / STEP_M).ceil() as u64 * TICK_MS;
    assert!(said[1].t_ms.abs_diff(expect_ms(6.0)) <= TICK_MS, "{} vs {}", said[1].t_ms, expect_ms(6.0));
    assert!(said[2].t_ms.abs_diff(expect_ms(1.5)) <= TICK_MS, "{} vs {}", said[2].t_ms, expect_ms(1.5));
    // arrival at the first pose within the arrival radius, and nothing after it
    let r = GuidanceProfile::default().arrival_radius_m;
    let d_goal = dist(said[3].at, goal);
    assert!(d_goal <= r && d_goal > r - STEP_M - 1e-9, "{d_goal}");
    assert!(guide.arrived());
    assert_eq!(said[3].instruction.kind, InstructionKind::Arrived);
    match said[1].instruction.kind {
        InstructionKind::TurnAhead { leg: 0, waypoint: 1, .. } => {}
        ref k => panic!("{k:?}"),
    }
    assert_priorities(&said);
    assert_spaced(&said, 3000);
    assert!(said.iter().all(|s| s.instruction.vibrate_first));
    // a "now" is dropped if it cannot be said within 1.5 s
    assert_eq!(said[2].instruction.speech().ttl_ms, 1500);
}

/// A corridor east along y 10.5..12.5 from x 0.5 to 12.5, one down from it at x
/// 10.5..12.5 to y 5.5, and one east again along y 5.5..7.5 to x 26.5: walked from the
/// west end, a right turn and 5 m on a left one.
fn jog_floor() -> OccupancyGrid {
    floor_where(|x, y| {
        let first = (0.5..=12.5).contains(&x) && (10.5..=12.5).contains(&y);
        let down = (10.5..=12.5).contains(&x) && (5.5..=12.5).contains(&y);
        let then = (10.5..=26.5).contains(&x) && (5.5..=7.5).contains(&y);
        first || down || then
    })
}

#[test]
fn a_turn_too_near_the_one_before_for_its_own_announcement_is_announced_with_that_one() {
    let mut p = Planner::new(0, &jog_floor(), &NavGraphConfig::default());
    let route = p.plan([1.5, 11.5], [25.5, 6.5]).unwrap();
    let w = &route.waypoints;
    assert_eq!(w.len(), 4, "a right turn and a left one: {w:?}");
    let gap = dist(w[1], w[2]);
    assert!((3.5..=5.5).contains(&gap), "{w:?}");
    let new_guide = |profile| Guide::single_floor(route.clone(), "the stairs", SemanticLayer::default(), profile);
    let mut guide = new_guide(GuidanceProfile::default());
    let poses = poses_along(w);
    let said = walk(&mut guide, &poses, 0, 0, Some(&p), |_| true);
    let both = |d: f64| format!("In {} metres, turn right, then turn left.", d.round());
    assert!(texts(&said)[0].starts_with("Route to the stairs: "), "{said:#?}");
    assert_eq!(
        texts(&said)[1..],
        [both(6.0).as_str(), "Turn right now.", "Turn left now.", "You have arrived at the stairs."],
        "{said:#?}"
    );
    // each "now" where it is due (the first pose within 1.5 m of its turn), alone: the
    // words after it would hold back the turn it asks for
    let d_now = |s: &Said, corner: [f64; 2]| dist(s.at, corner);
    assert!(d_now(&said[2], w[1]) <= 1.5 && d_now(&said[2], w[1]) > 1.5 - STEP_M - 1e-9, "{said:#?}");
    assert!(d_now(&said[3], w[2]) <= 1.5 && d_now(&said[3], w[2]) > 1.5 - STEP_M - 1e-9, "{said:#?}");
    assert_spaced(&said, 3000);
    assert_priorities(&said);
    match said[1].instruction.kind {
        InstructionKind::TurnAhead { leg: 0, waypoint: 1, .. } => {}
        ref k => panic!("{k:?}"),
    }

    // "repeat" says both with the distance of now; the announcement not heard is said
    // again, both turns in it, and the left turn is not announced on its own after
    let mut guide = new_guide(GuidanceProfile::default());
    let k_ahead = poses.iter().position(|&(at, _)| dist(at, w[1]) <= 6.0).unwrap();
    let said = walk(&mut guide, &poses[..=k_ahead + 5], 0, 0, Some(&p), |_| true);
    let ahead = said.last().unwrap();
    assert_eq!(ahead.instruction.text, both(6.0));
    let here = poses[k_ahead + 5];
    assert_eq!(guide.repeat(&pose(here.0, here.1), 20_000).text, both(dist(here.0, w[1])));
    assert!(guide.not_heard(&both(6.0)));
    let t0 = (k_ahead as u64 + 6) * TICK_MS;
    let rest = walk(&mut guide, &poses[k_ahead + 6..], 0, t0, Some(&p), |_| true);
    let again = both(dist(poses[k_ahead + 6].0, w[1]));
    assert_eq!(
        texts(&rest),
        [again.as_str(), "Turn right now.", "Turn left now.", "You have arrived at the stairs."],
        "{rest:#?}"
    );
    assert_eq!(rest[0].t_ms, t0, "not heard: no spacing to keep after it");

    // with a spacing of 1 s the left turn's own announcement has its time after the
    // right turn's "now": each is announced on its own
    let mut guide = new_guide(GuidanceProfile { min_spacing_ms: 1000, ..GuidanceProfile::default() });
    let said = walk(&mut guide, &poses, 0, 0, Some(&p), |_| true);
    let texts = texts(&said);
    assert_eq!(texts[1..3], ["In 6 metres, turn right.", "Turn right now."], "{said:#?}");
    assert!(texts[3].starts_with("In ") && texts[3].ends_with(" metres, turn left."), "{said:#?}");
    assert_eq!(texts[4], "Turn left now.");
}

#[test]
fn where_a_turns_announcement_is_left_out_the_turn_close_after_it_follows_its_now() {
    // the route starts 5.5 m before the right turn: its announcement would fall within
    // the spacing after the route's start, and the left turn's within the spacing after
    // the right turn's "now"
    let mut p = Planner::new(0, &jog_floor(), &NavGraphConfig::default());
    let route = p.plan([5.5, 11.5], [25.5, 6.5]).unwrap();
    let w = &route.waypoints;
    assert_eq!(w.len(), 4, "a right turn and a left one: {w:?}");
    assert!((5.0..=6.0).contains(&dist(w[0], w[1])), "{w:?}");
    let new_guide =
        || Guide::single_floor(route.clone(), "the stairs", SemanticLayer::default(), GuidanceProfile::default());
    let mut guide = new_guide();
    let poses = poses_along(w);
    let said = walk(&mut guide, &poses, 0, 0, Some(&p), |_| true);
    assert!(texts(&said)[0].starts_with("Route to the stairs: "), "{said:#?}");
    assert_eq!(
        texts(&said)[1..],
        ["Turn right now.", "Then turn left.", "Turn left now.", "You have arrived at the stairs."],
        "{said:#?}"
    );
    // the "now" where it would be alone: the first pose within 1.5 m of the turn once
    // the spacing after the start has passed; the "then" in the step after it, at the
    // priority of what asks nothing now (a "now" said again after a cut goes first),
    // no notice tap, and it does not hold back the left turn's "now"
    let d_now = dist(said[1].at, w[1]);
    assert!(d_now <= 1.5 && d_now > 1.5 - STEP_M - 1e-9, "{said:#?}");
    assert_eq!(said[2].t_ms, said[1].t_ms + TICK_MS);
    let then = &said[2].instruction;
    assert!(matches!(then.kind, InstructionKind::TurnThen { leg: 0, waypoint: 2, .. }), "{then:?}");
    assert!(!then.vibrate_first && then.speech().priority == Priority::Text && then.ttl_ms == 2000, "{then:?}");
    let d_left = dist(said[3].at, w[2]);
    assert!(d_left <= 1.5 && d_left > 1.5 - STEP_M - 1e-9, "{said:#?}");
    assert_spaced(&said, 3000);
    assert_priorities(&said);
    // "repeat" after it says the turn ahead, not the "then"
    let k_then = poses.iter().position(|&(at, _)| at == said[2].at).unwrap();
    assert_eq!(guide.last().map(|i| i.text.as_str()), Some("You have arrived at the stairs."));
    let mut guide = new_guide();
    let first = walk(&mut guide, &poses[..=k_then], 0, 0, Some(&p), |_| true);
    assert_eq!(first.last().unwrap().instruction.text, "Then turn left.");
    let here = poses[k_then];
    assert_eq!(guide.repeat(&pose(here.0, here.1), 20_000).text, "Turn right now.");

    // the right turn's "now" not heard: said again, the "then" after it, and the left
    // turn still not announced on its own
    let mut guide = new_guide();
    let k_now = k_then - 1;
    walk(&mut guide, &poses[..=k_now], 0, 0, Some(&p), |_| true);
    assert!(guide.not_heard("Turn right now."));
    let t0 = (k_now as u64 + 1) * TICK_MS;
    let rest = walk(&mut guide, &poses[k_now + 1..], 0, t0, Some(&p), |_| true);
    assert_eq!(
        texts(&rest),
        ["Turn right now.", "Then turn left.", "Turn left now.", "You have arrived at the stairs."],
        "{rest:#?}"
    );
    assert_eq!(rest[0].t_ms, t0, "not heard: no spacing to keep after it");

    // announced, the right turn takes the left one in its announcement and no "then"
    // follows its "now" (the walk from the route's usual start, 10 m before the turn)
    let route = p.plan([1.5, 11.5], [25.5, 6.5]).unwrap();
    let mut guide =
        Guide::single_floor(route.clone(), "the stairs", SemanticLayer::default(), GuidanceProfile::default());
    let said = walk(&mut guide, &poses_along(&route.waypoints), 0, 0, Some(&p), |_| true);
    assert!(!said.iter().any(|s| matches!(s.instruction.kind, InstructionKind::TurnThen { .. })), "{said:#?}");
}

/// The corridors of [`corridor_floor`] with a numbered door every 3 m in each wall:
/// the east-west corridor's north wall (y 12.5) and south wall (y 10.5), the corridor
/// down's west wall (x 18.5) and east wall (x 20.5).
fn doors_every_3_m() -> SemanticLayer {
    let mut toml = String::new();
    let mut door = |number: String, x: f64, y: f64, normal: [f64; 2]| {
        toml.push_str(&format!(
            "[[door]]\nnumber = \"{number}\"\nx = {x}\ny = {y}\nfloor = 0\nnormal = [{:.1}, {:.1}]\n\n",
            normal[0], normal[1]
        ));
    };
    for k in 0..8 {
        let x = 2.0 + 3.0 * k as f64;
        door(format!("N{k}"), x, 12.5, [0.0, -1.0]);
        door(format!("S{k}"), x + 1.5, 10.5, [0.0, 1.0]);
    }
    for k in 0..3 {
        let y = 8.0 - 3.0 * k as f64;
        door(format!("W{k}"), 18.5, y, [1.0, 0.0]);
        door(format!("E{k}"), 20.5, y - 1.5, [-1.0, 0.0]);
    }
    SemanticLayer::parse(&toml, Path::new("doors.toml")).unwrap()
}

#[test]
fn doors_passed_are_said_on_their_side_ten_metres_apart_and_never_hold_back_a_turn() {
    let mut p = planner();
    let route = l_route(&mut p);
    let corner = route.waypoints[1];
    let goal = route.goal();
    let poses = poses_along(&route.waypoints);
    let mut guide = Guide::single_floor(route.clone(), "the stairs", doors_every_3_m(), GuidanceProfile::default());
    let said = walk(&mut guide, &poses, 0, 0, Some(&p), |_| true);
    let doors: Vec<&Said> =
        said.iter().filter(|s| matches!(s.instruction.kind, InstructionKind::PassingDoor { .. })).collect();
    // 17.5 m east to the corner, 10 m down to the goal: doors where nothing else is
    // coming within 9 m (the turn's announcement at 6 m and the spacing after it)
    assert_eq!(
        doors.iter().map(|s| s.instruction.text.as_str()).collect::<Vec<_>>(),
        ["Passing door N1, on your left."],
        "{said:#?}"
    );
    for d in &doors {
        assert!(dist(d.at, corner) > 9.0 || d.at[1] < corner[1] - 1.0, "{d:?}");
        assert!(dist(d.at, goal) > 9.0, "{d:?}");
        assert_eq!(d.instruction.speech().ttl_ms, 1500);
    }
    assert_spaced(&said, 3000);
    assert_priorities(&said);
    // the route's words, where and when they were said without the doors
    let quiet = GuidanceProfile { passing_doors: false, ..GuidanceProfile::default() };
    let mut without = Guide::single_floor(route.clone(), "the stairs", doors_every_3_m(), quiet);
    let plain = walk(&mut without, &poses, 0, 0, Some(&p), |_| true);
    assert_eq!(route_words(&said), route_words(&plain));
    assert_eq!(plain.len(), 4, "{plain:#?}");

    // a long corridor: the route east along all of it, a door every 10 m or more (the
    // first, N0, comes level within the spacing after the route's start: S0 is the first)
    let route = p.plan([1.0, 11.5], [26.0, 11.5]).unwrap();
    let mut guide = Guide::single_floor(route.clone(), "the end", doors_every_3_m(), GuidanceProfile::default());
    let said = walk(&mut guide, &poses_along(&route.waypoints), 0, 0, Some(&p), |_| true);
    let doors: Vec<&Said> =
        said.iter().filter(|s| matches!(s.instruction.kind, InstructionKind::PassingDoor { .. })).collect();
    assert_eq!(
        doors.iter().map(|s| s.instruction.text.as_str()).collect::<Vec<_>>(),
        ["Passing door S0, on your right.", "Passing door N4, on your left."],
        "{said:#?}"
    );
    assert!(dist(doors[0].at, doors[1].at) >= 10.0, "{doors:?}");
    assert!(doors.iter().all(|d| dist(d.at, route.goal()) > 9.0), "{doors:?}");

    // the side is the way's: a user facing back along it (stepping backwards) is told none
    let backwards: Vec<([f64; 2], f64)> =
        poses_along(&route.waypoints).into_iter().map(|(at, h)| (at, h + std::f64::consts::PI)).collect();
    let mut guide = Guide::single_floor(route.clone(), "the end", doors_every_3_m(), GuidanceProfile::default());
    let said = walk(&mut guide, &backwards, 0, 0, Some(&p), |_| true);
    assert!(said.iter().all(|s| !matches!(s.instruction.kind, InstructionKind::PassingDoor { .. })), "{said:#?}");
}

/// The corridor's layer with a lobby in the corridor (x `west_x`-14, inside it: its
/// parent), and a hall at the foot of the corridor down (y 0.5-4).
fn lobby_and_hall(west_x: f64) -> SemanticLayer {
    let toml = format!(
        "{LAYER}
[[area]]
name = \"lobby\"
floor = 0
parent = \"corridor\"
polygon = [[{west_x}, 10.5], [14.0, 10.5], [14.0, 12.5], [{west_x}, 12.5]]

[[area]]
name = \"Hall B\"
floor = 0
parent = \"east wing\"
polygon = [[18.5, 0.5], [20.5, 0.5], [20.5, 4.0], [18.5, 4.0]]
"
    );
    SemanticLayer::parse(&toml, Path::new("areas.toml")).unwrap()
}

fn is_area(s: &Said) -> bool {
    matches!(s.instruction.kind, InstructionKind::EnteringArea { .. })
}

#[test]
fn an_area_entered_on_the_way_is_said_once_past_its_edge_and_never_holds_back_a_turn() {
    let mut p = planner();
    let route = l_route(&mut p);
    let poses = poses_along(&route.waypoints);
    let mut guide = Guide::single_floor(route.clone(), "the stairs", lobby_and_hall(3.0), GuidanceProfile::default());
    let said = walk(&mut guide, &poses, 0, 0, Some(&p), |_| true);
    // the lobby past its edge (x 3), the spacing after the route's start; leaving it for
    // the corridor that holds it enters nothing; the hall at the foot of the corridor
    // down is entered 2.5 m before the goal, where it would hold back the arrival: not
    // said
    assert_eq!(
        texts(&said),
        [
            "Route to the stairs: 25 metres. Go straight on.",
            "Entering the lobby.",
            "Passing door 214, on your left.",
            "In 6 metres, turn right.",
            "Turn right now.",
            "You have arrived at the stairs."
        ],
        "{said:#?}"
    );
    let lobby = &said[1];
    assert_eq!(lobby.instruction.kind, InstructionKind::EnteringArea { name: "lobby".into() });
    assert_eq!(lobby.t_ms, 3000, "{lobby:?}");
    assert!((lobby.at[0] - 4.5).abs() < STEP_M, "{lobby:?}");
    assert!(!lobby.instruction.vibrate_first, "it asks nothing: no notice tap");
    assert_eq!(lobby.instruction.speech().ttl_ms, 2000);
    assert!((said[2].at[0] - 9.0).abs() < STEP_M, "the door where it is said without the lobby: {said:#?}");
    assert_spaced(&said, 3000);
    assert_priorities(&said);
    // the route's words, where and when they were said without the lobby and the door
    let quiet = GuidanceProfile { passing_areas: false, passing_doors: false, ..GuidanceProfile::default() };
    let mut without = Guide::single_floor(route.clone(), "the stairs", lobby_and_hall(3.0), quiet);
    let plain = walk(&mut without, &poses, 0, 0, Some(&p), |_| true);
    assert_eq!(route_words(&said), route_words(&plain));
    assert_eq!(plain.len(), 4, "{plain:#?}");

    // a lobby from x 6 on the long corridor east: said at x 7, and the door in it (x 10)
    // waits the spacing after it
    let east = p.plan([1.0, 11.5], [26.0, 11.5]).unwrap();
    let mut guide = Guide::single_floor(east.clone(), "the end", lobby_and_hall(6.0), GuidanceProfile::default());
    let said = walk(&mut guide, &poses_along(&east.waypoints), 0, 0, Some(&p), |_| true);
    assert_eq!(texts(&said)[1..3], ["Entering the lobby.", "Passing door 214, on your left."], "{said:#?}");
    assert!((said[1].at[0] - 7.0).abs() < STEP_M, "{said:#?}");
    assert_eq!(said[2].t_ms - said[1].t_ms, 3000, "{said:#?}");

    // where the user starts enters nothing
    let inside = p.plan([8.0, 11.5], [26.0, 11.5]).unwrap();
    let mut guide = Guide::single_floor(inside.clone(), "the end", lobby_and_hall(3.0), GuidanceProfile::default());
    let said = walk(&mut guide, &poses_along(&inside.waypoints), 0, 0, Some(&p), |_| true);
    assert!(!said.iter().any(is_area), "{said:#?}");
    // walked west, the lobby's east edge (x 14) a metre behind; then east again on a new
    // route of the same trip: the lobby is not said twice, the door is
    let west = p.plan([26.0, 11.5], [1.0, 11.5]).unwrap();
    let mut guide = Guide::single_floor(west.clone(), "the west end", lobby_and_hall(3.0), GuidanceProfile::default());
    let there = walk(&mut guide, &poses_along(&west.waypoints), 0, 0, Some(&p), |_| true);
    assert_eq!(texts(&there)[1], "Entering the lobby.", "{there:#?}");
    assert!((there[1].at[0] - 13.0).abs() < STEP_M, "{there:#?}");
    let length_m = east.length_m;
    let legs = vec![planning::Leg { route: east.clone(), end: planning::LegEnd::Goal }];
    guide.set_route(planning::BuildingRoute { legs, walk_length_m: length_m, cost_m: length_m });
    let again = walk(&mut guide, &poses_along(&east.waypoints), 0, 30_000, Some(&p), |_| true);
    assert!(!again.iter().any(is_area), "{again:#?}");
    assert_eq!(texts(&again)[1], "Passing door 214, on your left.", "{again:#?}");

    // a place wavering across the lobby's edge enters it for no one: said only a metre
    // past where it was entered
    let edge: Vec<([f64; 2], f64)> = (0..40).map(|k| ([if k % 2 == 0 { 2.9 } else { 3.1 }, 11.5], 0.0)).collect();
    let mut guide = Guide::single_floor(route.clone(), "the stairs", lobby_and_hall(3.0), GuidanceProfile::default());
    let said = walk(&mut guide, &edge, 0, 0, Some(&p), |_| true);
    assert!(!said.iter().any(is_area), "{said:#?}");
}

#[test]
fn clock_directions_say_the_hour() {
    let mut p = planner();
    let route = l_route(&mut p);
    let profile = GuidanceProfile { directions: DirectionStyle::Clock, ..GuidanceProfile::default() };
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), profile);
    let said = walk(&mut guide, &poses_along(&route.waypoints), 0, 0, Some(&p), |_| true);
    assert_eq!(
        texts(&said),
        [
            "Route to the stairs: 25 metres. Go straight on.",
            "Passing door 214, at 9 o'clock.",
            "In 6 metres, turn to 3 o'clock.",
            "Turn to 3 o'clock now.",
            "You have arrived at the stairs."
        ]
    );
}

#[test]
fn steps_use_the_stride_length() {
    let mut p = planner();
    let route = l_route(&mut p);
    let profile = GuidanceProfile { units: DistanceUnits::Steps, stride_m: 0.75, ..GuidanceProfile::default() };
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), profile);
    let said = walk(&mut guide, &poses_along(&route.waypoints), 0, 0, Some(&p), |_| true);
    // 6 m / 0.75 m = 8 steps; the route's 26.6 m are 35 steps (rounded to 5)
    assert_eq!(
        texts(&said),
        [
            "Route to the stairs: 35 steps. Go straight on.",
            "Passing door 214, on your left.",
            "In 8 steps, turn right.",
            "Turn right now.",
            "You have arrived at the stairs."
        ]
    );
}

#[test]
fn spacing_drops_an_announcement_that_now_would_crowd_and_arrival_is_exempt() {
    // start 7 m before the corner, end 2.4 m after it
    let mut p = planner();
    let route = p.plan([12.5, 11.5], [19.5, 8.5]).unwrap();
    // arrival said 1 m out, so it falls due within the spacing after "now"
    let profile = GuidanceProfile { arrival_radius_m: 1.0, ..GuidanceProfile::default() };
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), profile);
    let said = walk(&mut guide, &poses_along(&route.waypoints), 0, 0, Some(&p), |_| true);
    // the announcement fell due at 6 m (t = 0.x s), had to wait for the spacing until 3 s
    // (4 m before the corner), and then "now" would have followed within the spacing
    assert_eq!(
        texts(&said),
        ["Route to the stairs: 9 metres. Go straight on.", "Turn right now.", "You have arrived at the stairs."],
        "{said:#?}"
    );
    assert!(said[1].t_ms >= 3000);
    // arrival came sooner than the spacing after "now", and was said anyway
    assert!(said[2].t_ms - said[1].t_ms < 3000, "{said:#?}");
    assert_spaced(&said, 3000);
}

#[test]
fn overshooting_the_corner_prompts_to_turn_back_then_says_which_way_to_face() {
    let mut p = planner();
    let route = l_route(&mut p);
    let corner = route.waypoints[1];
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), GuidanceProfile::default());
    // walk east past the corner for 3 m, then come back to it and go down
    let past = [corner[0] + 3.0, corner[1]];
    let mut path = vec![route.waypoints[0], corner, past];
    path.extend_from_slice(&route.waypoints[1..]);
    let said = walk(&mut guide, &poses_along(&path), 0, 0, Some(&p), |_| true);
    let t = texts(&said);
    assert_eq!(
        t,
        [
            "Route to the stairs: 25 metres. Go straight on.",
            "Passing door 214, on your left.",
            "In 6 metres, turn right.",
            "Turn right now.",
            "Off the route: turn back; the route is 1 metre away, behind you to the right.",
            "Back on the route. Turn left, then go straight on.",
            "You have arrived at the stairs."
        ],
        "{said:#?}"
    );
    match &said[4].instruction.kind {
        InstructionKind::OffRoute { rejoin } => assert!(rejoin.distance_m <= 4.0, "{rejoin:?}"),
        k => panic!("{k:?}"),
    }
    // off the route once farther than 1.5 m from it
    let off = dist(said[4].at, corner);
    assert!(off > 1.5 && off < 1.5 + 2.0 * STEP_M, "{off}");
    assert_spaced(&said, 3000);
}

#[test]
fn far_off_the_route_asks_for_a_replan_and_a_new_route_starts_afresh() {
    let mut p = planner();
    let route = l_route(&mut p);
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), GuidanceProfile::default());
    let start = guide.step(&pose(route.waypoints[0], 0.0), 0, Some(p.graph())).unwrap();
    assert_eq!(start.kind, InstructionKind::Start { leg: 0 });
    // localization puts the user 7 m past the corner: no route node within 4 m
    let far = pose([26.0, 11.5], 0.0);
    let i = guide.step(&far, 5000, Some(p.graph())).unwrap();
    assert_eq!(i.text, "Off the route: finding a new route.");
    assert!(i.needs_replan());
    assert_eq!(i.speech().priority, Priority::Message);
    // not again before the repeat interval, again after it
    assert_eq!(guide.step(&far, 9000, Some(p.graph())), None);
    let again = guide.step(&far, 13000, Some(p.graph())).unwrap();
    assert!(again.needs_replan());
    assert_ne!(again.dedup_key, i.dedup_key);
    // without a graph, any deviation is a replan request
    let mut blind = Guide::single_floor(route.clone(), "", layer(), GuidanceProfile::default());
    blind.step(&pose(route.waypoints[0], 0.0), 0, None).unwrap();
    assert!(blind.step(&pose([10.0, 8.0], 0.0), 5000, None).unwrap().needs_replan());
    // the caller replans and hands the new route over
    let new = p.replan(&route, [26.0, 11.5]).unwrap();
    let mut building = planning::BuildingRoute { legs: Vec::new(), walk_length_m: new.length_m, cost_m: new.length_m };
    building.legs.push(planning::Leg { route: new, end: planning::LegEnd::Goal });
    guide.set_route(building);
    let restart = guide.step(&far, 16000, Some(p.graph())).unwrap();
    assert_eq!(restart.text, "Route to the stairs: 15 metres. Turn around, then go straight on.");
}

#[test]
fn unconfident_pose_is_said_once_and_silences_turns() {
    let mut p = planner();
    let route = l_route(&mut p);
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), GuidanceProfile::default());
    let poses = poses_along(&route.waypoints);
    let corner_k = poses.iter().position(|(at, _)| dist(*at, route.waypoints[1]) < 1e-6).unwrap();
    // confident for the first metre, then unsure from 10 m before the corner until 2 m past it
    let unsure = |k: usize| k >= 10 && k < corner_k + 20;
    let said = walk(&mut guide, &poses, 0, 0, Some(&p), |k| !unsure(k));
    assert_eq!(
        texts(&said),
        [
            "Route to the stairs: 25 metres. Go straight on.",
            "Position uncertain: no turn instructions until I know where you are again.",
            "You have arrived at the stairs."
        ],
        "{said:#?}"
    );
    assert!(said
        .iter()
        .all(|s| !matches!(s.instruction.kind, InstructionKind::TurnAhead { .. } | InstructionKind::TurnNow { .. })));
    assert_priorities(&said);
}

#[test]
fn where_am_i_names_the_corridor_the_wing_and_the_door() {
    let mut p = planner();
    let route = l_route(&mut p);
    let mut guide = Guide::single_floor(route, "the stairs", layer(), GuidanceProfile::default());
    let i = guide.where_am_i(&pose([10.5, 11.5], 0.0), None, 1000);
    assert_eq!(i.text, "In the corridor, east wing, near door 214.");
    assert_eq!(i.kind, InstructionKind::WhereAmI);
    assert!(!i.vibrate_first, "the user asked: no vibration");
    assert_eq!(i.speech().priority, Priority::Message);
    assert_eq!(guide.where_am_i(&pose([19.5, 5.0], 0.0), None, 2000).text, "In the east wing.");
    let unsure = UserPose { confident: false, ..pose([10.5, 11.5], 0.0) };
    assert_eq!(guide.where_am_i(&unsure, None, 3000).text, "Position uncertain: I do not know where you are.");
}

#[test]
fn repeat_says_a_turn_with_the_distance_of_now_and_never_a_passed_turn() {
    let mut p = planner();
    let route = l_route(&mut p);
    let corner = route.waypoints[1];
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), GuidanceProfile::default());
    assert_eq!(guide.repeat(&pose(route.waypoints[0], 0.0), 0).text, "Nothing to repeat yet.");
    let start = guide.step(&pose(route.waypoints[0], 0.0), 0, Some(p.graph())).unwrap();
    let again = guide.repeat(&pose(route.waypoints[0], 0.0), 500);
    assert_eq!(again.text, start.text);
    assert_ne!(again.dedup_key, start.dedup_key, "a repeat must not be deduplicated away");
    assert!(!again.vibrate_first);
    // the user turned round since (or never heard it): the way to face from now
    let turned = guide.repeat(&pose(route.waypoints[0], std::f64::consts::PI), 600);
    assert_eq!(turned.text, "Route to the stairs: 25 metres. Turn around, then go straight on.");
    // walk to 6 m before the corner: the announcement
    let at6 = [corner[0] - 6.0, corner[1]];
    let ahead = guide.step(&pose(at6, 0.0), 10_000, Some(p.graph())).unwrap();
    assert_eq!(ahead.text, "In 6 metres, turn right.");
    // 2 m on, "repeat" gives the distance of now
    let at4 = [corner[0] - 4.0, corner[1]];
    assert_eq!(guide.step(&pose(at4, 0.0), 12_000, Some(p.graph())), None);
    assert_eq!(guide.repeat(&pose(at4, 0.0), 12_100).text, "In 4 metres, turn right.");
    // after the turn, "repeat" says how far to go straight on, not "turn right"
    let now = guide.step(&pose([corner[0] - 1.0, corner[1]], 0.0), 15_000, Some(p.graph())).unwrap();
    assert_eq!(now.text, "Turn right now.");
    let below = [corner[0], corner[1] - 3.0];
    assert_eq!(guide.step(&pose(below, -std::f64::consts::FRAC_PI_2), 18_000, Some(p.graph())), None);
    let passed = guide.repeat(&pose(below, -std::f64::consts::FRAC_PI_2), 18_100);
    let left = dist(below, route.goal());
    assert_eq!(passed.text, format!("Go straight on for {} metres.", left.round()));
    assert_eq!(passed.kind, InstructionKind::Continue);
    // facing back up the corridor (west): which way to face first
    let facing_west = guide.repeat(&pose(below, std::f64::consts::PI), 18_200);
    assert_eq!(facing_west.text, format!("Turn left, then go straight on for {} metres.", left.round()));
    // asking does not hold back guidance: the spacing counts spontaneous instructions only
    assert_eq!(guide.last().map(|i| i.text.as_str()), Some("Turn right now."));
    // the position lost for a while and found again: not a stale "uncertain"
    let lost = UserPose { confident: false, ..pose(below, -std::f64::consts::FRAC_PI_2) };
    let uncertain = guide.step(&lost, 19_000, Some(p.graph())).unwrap();
    assert_eq!(uncertain.kind, InstructionKind::PositionUncertain);
    assert_eq!(uncertain.speech().priority, Priority::Text, "what tells where things stand gives way to a turn");
    let found = guide.repeat(&pose(below, -std::f64::consts::FRAC_PI_2), 20_000);
    assert_eq!(found.text, format!("Go straight on for {} metres.", left.round()));
}

const ELEVATOR: &str = r#"
[[gateway]]
name = "main elevator"
type = "elevator"
stops = [ { floor = 0, x = 19.5, y = 1.5 }, { floor = 1, x = 19.5, y = 1.5 } ]
"#;

/// The corridors of [`corridor_floor`] on floors 0 and 1, joined by the elevator of
/// [`ELEVATOR`], and that semantic layer.
fn two_floors() -> (SemanticLayer, Building) {
    two_floors_joined_by("elevator")
}

/// [`two_floors`] with a gateway of this `type` ("stairs", "ramp") where the elevator is.
fn two_floors_joined_by(kind: &str) -> (SemanticLayer, Building) {
    let text = ELEVATOR.replace("\"elevator\"", &format!("\"{kind}\""));
    let layer = SemanticLayer::parse(&text, Path::new("gateway.toml")).unwrap();
    let floors = [0, 1].map(|level| Floor { level, grid: corridor_floor(), semantic: layer.floor(level) });
    let building = Building::new(floors.to_vec(), Path::new("two floors")).unwrap();
    (layer, building)
}

#[test]
fn two_floor_route_announces_the_elevator_and_continues_on_the_confirmed_floor() {
    let (layer, building) = two_floors();
    let mut bp = BuildingPlanner::new(&building, UserProfile::default());
    let from = FloorPoint { floor: 0, x: 1.5, y: 11.5 };
    let to = FloorPoint { floor: 1, x: 1.5, y: 11.5 };
    let route = bp.plan(from, to).unwrap();
    assert_eq!(route.legs.len(), 2);
    let legs: Vec<Route> = route.legs.iter().map(|l| l.route.clone()).collect();
    let mut guide = Guide::building(route, "room 214", layer.clone(), GuidanceProfile::default());

    let p0 = bp.floor(0).unwrap();
    let said = walk(&mut guide, &poses_along(&legs[0].waypoints), 0, 0, Some(p0), |_| true);
    assert_eq!(
        texts(&said),
        [
            "Route to room 214: 55 metres. Go straight on.",
            "In 6 metres, turn right.",
            "Turn right now.",
            "Elevator ahead; take it to floor 1; tell me when you are there.",
            "You are at the elevator. Take it to floor 1, then tell me when you are there."
        ],
        "{said:#?}"
    );
    let ahead_at = said[3].at;
    let left = dist(ahead_at, legs[0].goal());
    assert!(left <= 6.0 && left > 6.0 - STEP_M - 1e-9, "{left}");
    assert_eq!(said[3].instruction.kind, InstructionKind::GatewayAhead { leg: 0 });
    // waiting at the elevator: nothing more on floor 0
    let end0 = legs[0].goal();
    assert_eq!(guide.step(&pose(end0, -1.57), 60_000, Some(p0.graph())), None);
    // ... unless a warning cut it off: a user who did not hear which floor is told again
    assert!(guide.not_heard("You are at the elevator. Take it to floor 1, then tell me when you are there."));
    let again = guide.step(&pose(end0, -1.57), 61_000, Some(p0.graph())).expect("said again");
    assert_eq!(again.text, "You are at the elevator. Take it to floor 1, then tell me when you are there.");
    assert_eq!(again.kind, InstructionKind::AtGateway { leg: 0 });
    assert_ne!(again.dedup_key, said[4].instruction.dedup_key, "a key of its own: the feedback agent saw the first");
    assert_eq!(guide.step(&pose(end0, -1.57), 65_000, Some(p0.graph())), None);
    // a wrong floor is not confirmation
    assert!(!guide.floor_confirmed(2));
    assert!(guide.floor_confirmed(1));
    assert_eq!(guide.floor(), Some(1));
    let p1 = bp.floor(1).unwrap();
    let t1 = 70_000;
    let mut poses1 = poses_along(&legs[1].waypoints);
    // out of the elevator still facing down the corridor, as the user rode in
    poses1[0].1 = -std::f64::consts::FRAC_PI_2;
    let said1 = walk(&mut guide, &poses1, 1, t1, Some(p1), |_| true);
    assert_eq!(
        texts(&said1),
        [
            "Floor 1: 25 metres to room 214. Turn around, then go straight on.",
            "In 6 metres, turn left.",
            "Turn left now.",
            "You have arrived at room 214."
        ],
        "{said1:#?}"
    );
    let all: Vec<Said> = said.into_iter().chain(said1).collect();
    assert_priorities(&all);
    assert_spaced(&all, 3000);
}

/// The route from floor 0's (1.5, 11.5) to floor 1's, through the building's gateway: its
/// planner, legs, and the guide after the user walked the first leg to the gateway
/// (with what it said).
fn walked_to_the_gateway(layer: SemanticLayer, building: &Building) -> (BuildingPlanner, Vec<Route>, Guide, Vec<Said>) {
    let mut bp = BuildingPlanner::new(building, UserProfile::default());
    let route = bp.plan(FloorPoint { floor: 0, x: 1.5, y: 11.5 }, FloorPoint { floor: 1, x: 1.5, y: 11.5 }).unwrap();
    let legs: Vec<Route> = route.legs.iter().map(|l| l.route.clone()).collect();
    let mut guide = Guide::building(route, "room 214", layer, GuidanceProfile::default());
    let said = walk(&mut guide, &poses_along(&legs[0].waypoints), 0, 0, Some(bp.floor(0).unwrap()), |_| true);
    (bp, legs, guide, said)
}

#[test]
fn a_user_who_walks_away_from_the_elevator_is_told_where_it_is_and_back_at_it_what_to_do_there() {
    use std::f64::consts::FRAC_PI_2;
    let (layer, building) = two_floors();
    let (bp, legs, mut guide, said) = walked_to_the_gateway(layer, &building);
    let p0 = bp.floor(0).unwrap();
    let at_lift = "You are at the elevator. Take it to floor 1, then tell me when you are there.";
    assert_eq!(texts(&said).last(), Some(&at_lift), "{said:#?}");
    // the lift is at the south end of the corridor: the user walks back north, away from it
    let end = legs[0].goal();
    let north = |m: f64| pose([end[0], end[1] + m], FRAC_PI_2);
    for k in 0..6u32 {
        let m = 0.5 * f64::from(k);
        assert_eq!(guide.step(&north(m), 60_000 + u64::from(k) * 500, Some(p0.graph())), None, "{m} m away");
    }
    let away = guide.step(&north(3.0), 63_000, Some(p0.graph())).expect("where the lift is");
    assert_eq!(away.text, "The elevator is 3 metres away, behind you.");
    assert_eq!(away.kind, InstructionKind::AwayFromGateway { leg: 0 });
    assert_eq!(away.speech().priority, Priority::Message);
    // once, while they stay away; again if a warning cut it off
    assert_eq!(guide.step(&north(4.0), 66_000, Some(p0.graph())), None);
    assert!(guide.not_heard(&away.text));
    let again = guide.step(&north(5.0), 67_000, Some(p0.graph())).expect("said again");
    assert_eq!(again.text, "The elevator is 5 metres away, behind you.");
    assert_eq!(guide.step(&north(5.0), 70_000, Some(p0.graph())), None);
    // back at the lift: what to do there, again; then the floor is confirmed as before
    let mut back = None;
    for k in 0..60u32 {
        let at = north(5.0 - 0.1 * f64::from(k));
        let heading_south = UserPose { heading_rad: -FRAC_PI_2, ..at };
        if let Some(i) = guide.step(&heading_south, 72_000 + u64::from(k) * 100, Some(p0.graph())) {
            back = Some((i, 5.0 - 0.1 * f64::from(k)));
            break;
        }
    }
    let (back, m) = back.expect("told at the lift");
    assert_eq!(back.text, at_lift);
    assert!(m <= 1.5 + 1e-9, "said {m:.1} m from the lift");
    assert_eq!(guide.step(&north(0.0), 80_000, Some(p0.graph())), None);
    assert!(guide.floor_confirmed(1));
    assert_eq!(guide.floor(), Some(1));
}

#[test]
fn a_user_who_walks_away_from_the_stairs_is_told_where_they_are_only_when_a_barometer_holds_the_floor() {
    use std::f64::consts::FRAC_PI_2;
    // the same corridors, joined by stairs where the elevator was
    let (layer, building) = two_floors_joined_by("stairs");
    let (bp, legs, mut guide, said) = walked_to_the_gateway(layer, &building);
    let p0 = bp.floor(0).unwrap();
    let at_stairs = "You are at the stairs. Take them to floor 1, then tell me when you are there.";
    assert_eq!(texts(&said).last(), Some(&at_stairs), "{said:#?}");
    let end = legs[0].goal();
    let north = |m: f64| pose([end[0], end[1] + m], FRAC_PI_2);
    // no barometer: walking away from their foot is what taking the stairs looks like
    // on the plan, so nothing is said
    let mut blind = guide.clone();
    for k in 0..=10u32 {
        let m = 0.5 * f64::from(k);
        assert_eq!(blind.step(&north(m), 60_000 + u64::from(k) * 500, Some(p0.graph())), None, "{m} m away");
    }
    // a barometer holding the floor's height: the user is on the level, not on the stairs
    guide.set_barometer(Barometer::AtFloor);
    for k in 0..6u32 {
        let m = 0.5 * f64::from(k);
        assert_eq!(guide.step(&north(m), 60_000 + u64::from(k) * 500, Some(p0.graph())), None, "{m} m away");
    }
    let away = guide.step(&north(3.0), 63_000, Some(p0.graph())).expect("where the stairs are");
    assert_eq!(away.text, "The stairs are 3 metres away, behind you.");
    assert_eq!(away.kind, InstructionKind::AwayFromGateway { leg: 0 });
    // back at their foot: what to do there, again, now that the barometer will notice
    // the floor; climbing (the height moving) says nothing more, and the floor reached
    // goes on as before
    let back = guide.step(&north(0.0), 80_000, Some(p0.graph())).expect("told at the stairs");
    assert_eq!(
        back.text,
        "You are at the stairs. Take them to floor 1. I will notice the floor when you get there; you can also tell me."
    );
    guide.set_barometer(Barometer::OffFloor);
    for k in 1..=10u32 {
        let m = 0.5 * f64::from(k);
        assert_eq!(guide.step(&north(m), 80_000 + u64::from(k) * 500, Some(p0.graph())), None, "{m} m up");
    }
    assert!(guide.floor_confirmed(1));
    assert_eq!(guide.floor(), Some(1));
}

#[test]
fn a_user_told_the_barometer_would_notice_the_floor_is_asked_to_say_it_when_the_barometer_stops() {
    use std::f64::consts::FRAC_PI_2;
    let (layer, building) = two_floors_joined_by("stairs");
    let mut bp = BuildingPlanner::new(&building, UserProfile::default());
    let route = bp.plan(FloorPoint { floor: 0, x: 1.5, y: 11.5 }, FloorPoint { floor: 1, x: 1.5, y: 11.5 }).unwrap();
    let leg0 = route.legs[0].route.clone();
    let mut guide = Guide::building(route, "room 214", layer, GuidanceProfile::default());
    let p0 = bp.floor(0).unwrap();
    // the same walk without a barometer: the user is to say the floor from the start,
    // so nothing changes when none is read
    let mut without = guide.clone();
    let said = walk(&mut without, &poses_along(&leg0.waypoints), 0, 0, Some(p0), |_| true);
    assert_eq!(
        texts(&said).last(),
        Some(&"You are at the stairs. Take them to floor 1, then tell me when you are there.")
    );
    guide.set_barometer(Barometer::AtFloor);
    let said = walk(&mut guide, &poses_along(&leg0.waypoints), 0, 0, Some(p0), |_| true);
    assert_eq!(
        texts(&said).last(),
        Some(&"You are at the stairs. Take them to floor 1. I will notice the floor when you get there; you can also tell me.")
    );
    let end = leg0.goal();
    let up = |m: f64| pose([end[0], end[1] + m], FRAC_PI_2);
    // climbing: the height moves, nothing to say
    guide.set_barometer(Barometer::OffFloor);
    for k in 1..=4u32 {
        assert_eq!(guide.step(&up(0.5 * f64::from(k)), 90_000 + u64::from(k) * 500, Some(p0.graph())), None);
        assert_eq!(without.step(&up(0.5 * f64::from(k)), 90_000 + u64::from(k) * 500, Some(p0.graph())), None);
    }
    // the barometer stops sending on the way up: the user would wait at the top for
    // nothing, so they are told to say the floor, at once and once
    guide.set_barometer(Barometer::Unread);
    without.set_barometer(Barometer::Unread);
    let told = guide.step(&up(2.5), 93_000, Some(p0.graph())).expect("told to say the floor");
    let asked = "I can no longer measure the height, so I will not notice the floor: tell me when you are on floor 1.";
    assert_eq!(told.text, asked);
    assert_eq!(told.kind, InstructionKind::FloorNotNoticed { leg: 0 });
    assert_eq!(told.speech().priority, Priority::Message);
    assert_eq!(without.step(&up(2.5), 93_000, Some(p0.graph())), None, "nothing was promised without a barometer");
    for k in 1..=10u32 {
        assert_eq!(guide.step(&up(2.5 + 0.3 * f64::from(k)), 93_000 + u64::from(k) * 1000, Some(p0.graph())), None);
    }
    // cut off by a warning: said again, with a key of its own
    assert!(guide.not_heard(asked));
    let again = guide.step(&up(6.0), 104_000, Some(p0.graph())).expect("said again");
    assert_eq!(again.text, asked);
    assert_ne!(again.dedup_key, told.dedup_key);
    assert_eq!(guide.step(&up(6.0), 108_000, Some(p0.graph())), None);
    // the user says the floor: the next leg, as always
    assert!(guide.floor_confirmed(1));
    assert_eq!(guide.floor(), Some(1));
}

#[test]
fn an_elevator_ahead_the_user_did_not_hear_is_said_again_while_it_is_ahead() {
    let (layer, building) = two_floors();
    let mut bp = BuildingPlanner::new(&building, UserProfile::default());
    let route = bp.plan(FloorPoint { floor: 0, x: 1.5, y: 11.5 }, FloorPoint { floor: 1, x: 1.5, y: 11.5 }).unwrap();
    let leg0 = route.legs[0].route.clone();
    let guide = Guide::building(route, "room 214", layer, GuidanceProfile::default());
    let p0 = bp.floor(0).unwrap();
    let poses = poses_along(&leg0.waypoints);
    let said = walk(&mut guide.clone(), &poses, 0, 0, Some(p0), |_| true);
    let ahead = said.iter().find(|s| s.instruction.kind == InstructionKind::GatewayAhead { leg: 0 }).unwrap();
    // the same walk to where it was said, and the announcement cut off: said again at the
    // next step, the elevator still ahead
    let k = poses.iter().position(|(at, _)| *at == ahead.at).unwrap();
    let mut cut = guide.clone();
    let first = walk(&mut cut, &poses[..=k], 0, 0, Some(p0), |_| true);
    assert_eq!(first.last().map(|s| &s.instruction.kind), Some(&InstructionKind::GatewayAhead { leg: 0 }));
    assert!(cut.not_heard("Elevator ahead; take it to floor 1; tell me when you are there."));
    let (at, heading) = poses[k + 1];
    let again = cut.step(&pose(at, heading), (k as u64 + 1) * TICK_MS, Some(p0.graph())).expect("said again");
    assert_eq!(again.text, "Elevator ahead; take it to floor 1; tell me when you are there.");
    assert_ne!(again.dedup_key, ahead.instruction.dedup_key, "a key of its own: the feedback agent saw the first");
}

#[test]
fn reaching_the_next_floor_without_saying_so_starts_its_leg_too() {
    let (layer, building) = two_floors();
    let mut bp = BuildingPlanner::new(&building, UserProfile::default());
    let route = bp.plan(FloorPoint { floor: 0, x: 19.5, y: 5.0 }, FloorPoint { floor: 1, x: 1.5, y: 11.5 }).unwrap();
    let mut guide = Guide::building(route, "room 214", layer, GuidanceProfile::default());
    let up = UserPose { x_m: 19.5, y_m: 1.5, heading_rad: std::f64::consts::FRAC_PI_2, floor: 1, confident: true };
    let first = guide.step(&up, 0, None).unwrap();
    assert_eq!(first.text, "Floor 1: 25 metres to room 214. Go straight on.");
    // a floor the route does not use asks for a replan
    let lost = UserPose { floor: 3, ..up };
    let i = guide.step(&lost, 5000, None).unwrap();
    assert_eq!(i.text, "You are on floor 3, which this route does not take: finding a new route.");
    assert!(i.needs_replan());
}

#[test]
fn a_pose_with_nan_is_no_pose() {
    let mut p = planner();
    let route = l_route(&mut p);
    let mut guide = Guide::single_floor(route.clone(), "the stairs", layer(), GuidanceProfile::default());
    guide.step(&pose(route.waypoints[0], 0.0), 0, Some(p.graph())).unwrap();
    let corner = route.waypoints[1];
    let nan = pose([corner[0] - 1.0, f64::NAN], 0.0);
    let i = guide.step(&nan, 10_000, Some(p.graph())).unwrap();
    assert_eq!(i.kind, InstructionKind::PositionUncertain);
    assert_eq!(guide.step(&pose([corner[0] - 1.0, corner[1]], f64::NAN), 20_000, Some(p.graph())), None);
    assert_eq!(guide.where_am_i(&nan, None, 20_100).text, "Position uncertain: I do not know where you are.");
    // a finite pose again: the turn is said
    let back = guide.step(&pose([corner[0] - 1.0, corner[1]], 0.0), 30_000, Some(p.graph())).unwrap();
    assert_eq!(back.text, "Turn right now.");
}

#[test]
fn answers_to_the_user_neither_wait_for_nor_delay_guidance() {
    let mut p = planner();
    let route = l_route(&mut p);
    let poses = poses_along(&route.waypoints);
    let mut quiet = Guide::single_floor(route.clone(), "the stairs", layer(), GuidanceProfile::default());
    let expected = walk(&mut quiet, &poses, 0, 0, Some(&p), |_| true);
    // the same walk, with "where am I" asked every 700 ms, answered at once every time
    let mut asked = Guide::single_floor(route.clone(), "the stairs", layer(), GuidanceProfile::default());
    let mut said = Vec::new();
    for (k, &(at, heading)) in poses.iter().enumerate() {
        let t_ms = k as u64 * TICK_MS;
        let here = UserPose { heading_rad: heading, ..pose(at, 0.0) };
        if let Some(i) = asked.step(&here, t_ms, Some(p.graph())) {
            said.push((t_ms, i.text));
        }
        if t_ms.is_multiple_of(700) && !asked.arrived() {
            let a = asked.where_am_i(&here, None, t_ms);
            assert_eq!(a.issued_ms, t_ms);
            assert!(a.text.starts_with("In the ") || a.text.starts_with("Near door"), "{}", a.text);
        }
    }
    let expected: Vec<(u64, String)> = expected.into_iter().map(|s| (s.t_ms, s.instruction.text)).collect();
    assert_eq!(said, expected);
}

#[test]
fn the_way_to_face_waits_until_the_user_stops_turning() {
    let mut p = planner();
    let route = l_route(&mut p);
    let from = route.waypoints[0];
    let mut guide = Guide::single_floor(route, "the stairs", layer(), GuidanceProfile::default());
    // turning on the spot at 30 degrees a second for 3 s (as when the device looks for the
    // position) from east to north, then still, facing north (the route starts east: to
    // the user's right)
    let turning: Vec<([f64; 2], f64)> = (0..30).map(|k| (from, (3.0 + 3.0 * k as f64).to_radians())).collect();
    // (the position is known from the sixth pose on; a heading was there before it)
    let mut said = walk(&mut guide, &turning, 0, 0, Some(&p), |k| k >= 5);
    let still: Vec<([f64; 2], f64)> = (0..20).map(|_| (from, 90f64.to_radians())).collect();
    said.extend(walk(&mut guide, &still, 0, 3000, Some(&p), |_| true));
    assert_eq!(
        texts(&said),
        [
            "Position uncertain: no turn instructions until I know where you are again.",
            "Route to the stairs: 25 metres. Turn right, then go straight on."
        ],
        "{said:#?}"
    );
    let said = &said[1..];
    // nothing until the heading has held long enough that the last second turned less
    // than 15 degrees a second: 3 s of turning, then 0.5 s still
    assert!((3400..=3600).contains(&said[0].t_ms), "said at {} ms", said[0].t_ms);
}

#[test]
fn an_instruction_the_user_did_not_hear_is_given_again_with_the_words_of_then() {
    let mut p = planner();
    let route = l_route(&mut p);
    let corner = route.waypoints[1];
    let from = route.waypoints[0];
    let mut guide = Guide::single_floor(route, "the stairs", layer(), GuidanceProfile::default());
    let start = guide.step(&pose(from, 0.0), 0, Some(p.graph())).unwrap();
    assert_eq!(start.text, "Route to the stairs: 25 metres. Go straight on.");
    assert!(!guide.not_heard("some other words"), "only the last instruction");
    // dropped by the feedback agent (stale): said again at once, from where the user
    // is and faces then, with a key of its own (the agent remembers the first one's)
    assert!(guide.not_heard(&start.text));
    // (the user turned round meanwhile: the way to face waits until the heading holds)
    let back = pose([from[0] + 1.0, from[1]], std::f64::consts::PI);
    assert_eq!(guide.step(&back, 100, Some(p.graph())), None);
    let again = guide.step(&back, 1200, Some(p.graph())).unwrap();
    assert_eq!(again.text, "Route to the stairs: 25 metres. Turn around, then go straight on.");
    assert_ne!(again.dedup_key, start.dedup_key);
    assert!(!guide.not_heard(&start.text), "the old words are no longer the last");
    // a "now" cut off: again while the turn is within reach, never once it is passed
    let now = guide.step(&pose([corner[0] - 1.0, corner[1]], 0.0), 15_000, Some(p.graph())).unwrap();
    assert_eq!(now.text, "Turn right now.");
    assert!(guide.not_heard(&now.text));
    let again = guide.step(&pose([corner[0] - 0.5, corner[1]], 0.0), 15_500, Some(p.graph())).unwrap();
    assert_eq!(again.text, "Turn right now.");
    assert!(guide.not_heard(&again.text));
    let below = [corner[0], corner[1] - 2.0];
    assert_eq!(guide.step(&pose(below, -std::f64::consts::FRAC_PI_2), 16_000, Some(p.graph())), None);
}

#[test]
fn a_walker_passing_the_goal_a_stride_to_its_side_hears_that_they_have_arrived_there() {
    // the goal in the corridor's middle; the walker keeps 0.7 m to its left side all along
    let mut p = planner();
    let route = p.plan([1.5, 11.5], [12.0, 11.5]).unwrap();
    let end = *route.waypoints.last().unwrap();
    let mut guide = Guide::single_floor(route.clone(), "the lift", layer(), GuidanceProfile::default());
    let side = 0.7;
    let said = walk(&mut guide, &poses_along(&[[1.5, end[1] + side], [16.0, end[1] + side]]), 0, 0, Some(&p), |_| true);
    let arrived: Vec<&Said> = said.iter().filter(|s| s.instruction.kind == InstructionKind::Arrived).collect();
    assert_eq!(arrived.len(), 1, "{said:#?}");
    assert_eq!(arrived[0].instruction.text, "You have arrived at the lift.");
    // said as the walker comes level with it, within issue 31's metre
    let (at, away) = (arrived[0].at, dist(arrived[0].at, end));
    assert!(away <= guidance::guide::ARRIVAL_BESIDE_M && away > GuidanceProfile::default().arrival_radius_m, "{at:?}");
    assert!((end[0] - at[0]).abs() <= 0.5, "{at:?} against {end:?}");
    // and not told to turn back once past it
    assert!(!texts(&said).iter().any(|t| t.starts_with("Off the route")), "{said:#?}");
}

#[test]
fn a_position_uncertain_for_long_asks_the_user_to_stop_and_turn_and_its_return_says_so_then_the_way() {
    let mut p = planner();
    let route = l_route(&mut p);
    let from = route.waypoints[0];
    let profile = GuidanceProfile::default();
    let stop_ms = profile.stop_when_uncertain_ms;
    assert_eq!(stop_ms, 60_000);
    let mut guide = Guide::single_floor(route, "the stairs", layer(), profile);
    // 5 s at the start, facing east along the route, the position known
    let standing: Vec<([f64; 2], f64)> = (0..50).map(|_| (from, 0.0)).collect();
    let mut said = walk(&mut guide, &standing, 0, 0, Some(&p), |_| true);
    // then 65 s of slow walking on along the corridor (0.2 m/s), the position not known
    let on: Vec<([f64; 2], f64)> = (0..650).map(|k| ([from[0] + 0.02 * k as f64, from[1]], 0.0)).collect();
    said.extend(walk(&mut guide, &on, 0, 5000, Some(&p), |_| false));
    let stood = on.last().unwrap().0;
    // "repeat" while it is not known: the last request, not a turn
    let lost = UserPose { confident: false, ..pose(stood, 0.0) };
    assert_eq!(
        guide.repeat(&lost, 69_950).text,
        "Position still uncertain: please stop, and turn slowly on the spot until I find your position."
    );
    // turning on the spot at 30 degrees a second for 3 s (east to north), the position
    // known again from the first turning step, then still, facing north
    let turning: Vec<([f64; 2], f64)> = (0..30).map(|k| (stood, (3.0 * k as f64).to_radians())).collect();
    said.extend(walk(&mut guide, &turning, 0, 70_000, Some(&p), |_| true));
    let still: Vec<([f64; 2], f64)> = (0..20).map(|_| (stood, 90f64.to_radians())).collect();
    said.extend(walk(&mut guide, &still, 0, 73_000, Some(&p), |_| true));
    let at: Vec<(u64, &str)> = said.iter().map(|s| (s.t_ms, s.instruction.text.as_str())).collect();
    assert_eq!(
        at[..4],
        [
            (0, "Route to the stairs: 25 metres. Go straight on."),
            (5000, "Position uncertain: no turn instructions until I know where you are again."),
            // 60 s after the position was last known, once
            (
                5000 + stop_ms,
                "Position still uncertain: please stop, and turn slowly on the spot until I find your position."
            ),
            // at once, though the user still turns
            (70_000, "Position found."),
        ],
        "{said:#?}"
    );
    assert_eq!(said[3].instruction.kind, InstructionKind::PositionFound);
    // then which way to face, once the user stands still
    assert_eq!(at.len(), 5, "{said:#?}");
    assert_eq!(at[4].1, "Back on the route. Turn right, then go straight on.");
    assert!((73_400..=73_600).contains(&at[4].0), "said at {} ms", at[4].0);
}

#[test]
fn a_user_who_turned_on_the_spot_without_the_position_found_is_asked_to_stop_turning_and_for_a_door_number() {
    let mut p = planner();
    let route = l_route(&mut p);
    let from = route.waypoints[0];
    let profile = GuidanceProfile::default();
    let (stop_ms, search_ms) = (profile.stop_when_uncertain_ms, profile.search_for_ms);
    assert_eq!(search_ms, 25_000);
    let mut guide = Guide::single_floor(route, "the stairs", layer(), profile);
    let (known, lost) = (pose(from, 0.0), UserPose { confident: false, ..pose(from, 0.0) });
    guide.step(&known, 0, Some(p.graph())).unwrap();
    assert_eq!(guide.step(&lost, 5000, Some(p.graph())).unwrap().kind, InstructionKind::PositionUncertain);
    let stop_at = 5000 + stop_ms;
    let stop = guide.step(&lost, stop_at, Some(p.graph())).unwrap();
    assert!(stop.text.starts_with("Position still uncertain: please stop"), "{stop:?}");
    assert_eq!(stop.kind, InstructionKind::StopAndTurn);
    // turning on the spot, not found: nothing until the search's time is up
    for t in (stop_at + 100..stop_at + search_ms).step_by(100) {
        assert_eq!(guide.step(&lost, t, Some(p.graph())), None, "at {t} ms");
    }
    let failed = guide.step(&lost, stop_at + search_ms, Some(p.graph())).unwrap();
    let words = "I cannot find your position by turning. Please stop turning, and tell me the number of a door you are at, or ask someone nearby where you are and tell me the place.";
    assert_eq!(failed.text, words);
    assert_eq!(failed.kind, InstructionKind::SearchFailed);
    // asks something of the user: a turn's "now" does not cut it off, nor replace it waiting
    assert_eq!(failed.speech().priority, schemas::Priority::Message);
    // cut off by a warning: said again at the next step (the user still turns)
    assert!(guide.not_heard(&failed.text));
    let again = guide.step(&lost, stop_at + search_ms + 100, Some(p.graph())).unwrap();
    assert_eq!(again.text, words);
    assert_ne!(again.dedup_key, failed.dedup_key);
    // then nothing more while the place is not known (no new request to turn), and
    // "repeat" says it again
    for t in (stop_at + search_ms + 200..stop_at + search_ms + 3 * stop_ms).step_by(500) {
        assert_eq!(guide.step(&lost, t, Some(p.graph())), None, "at {t} ms");
    }
    let t = stop_at + search_ms + 3 * stop_ms;
    assert_eq!(guide.repeat(&lost, t).text, words);
    // a door number told (or the place found): said at once, as after the request to turn
    let found = guide.step(&known, t + 100, Some(p.graph())).unwrap();
    assert_eq!((found.kind, found.text.as_str()), (InstructionKind::PositionFound, "Position found."));
    // lost again later: a new episode, asked to turn again after the profile's minute
    let lost_again = t + 10_000;
    assert_eq!(
        guide.step(&lost, lost_again, Some(p.graph())).map(|i| i.kind),
        Some(InstructionKind::PositionUncertain)
    );
    let stop_again = guide.step(&lost, lost_again + stop_ms, Some(p.graph())).unwrap();
    assert_eq!(stop_again.text, stop.text);
}

#[test]
fn the_request_to_stop_and_the_position_found_again_are_said_again_when_not_heard() {
    let mut p = planner();
    let route = l_route(&mut p);
    let from = route.waypoints[0];
    let mut guide = Guide::single_floor(route, "the stairs", layer(), GuidanceProfile::default());
    let (known, lost) = (pose(from, 0.0), UserPose { confident: false, ..pose(from, 0.0) });
    guide.step(&known, 0, Some(p.graph())).unwrap();
    assert_eq!(guide.step(&lost, 5000, Some(p.graph())).unwrap().kind, InstructionKind::PositionUncertain);
    let t = 5000 + GuidanceProfile::default().stop_when_uncertain_ms;
    assert_eq!(guide.step(&lost, t - 100, Some(p.graph())), None);
    let stop = guide.step(&lost, t, Some(p.graph())).unwrap();
    assert!(stop.text.starts_with("Position still uncertain: please stop"), "{stop:?}");
    assert_eq!(guide.step(&lost, t + 100, Some(p.graph())), None);
    // cut off by a warning: said again at the next step, with a key of its own
    assert!(guide.not_heard(&stop.text));
    let again = guide.step(&lost, t + 200, Some(p.graph())).unwrap();
    assert_eq!(again.text, stop.text);
    assert_ne!(again.dedup_key, stop.dedup_key);
    let found = guide.step(&known, t + 5000, Some(p.graph())).unwrap();
    assert_eq!(found.text, "Position found.");
    assert!(guide.not_heard(&found.text));
    let found_again = guide.step(&known, t + 5100, Some(p.graph())).unwrap();
    assert_eq!((found_again.kind, found_again.text.as_str()), (InstructionKind::PositionFound, "Position found."));
}
