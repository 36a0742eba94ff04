//! The navigator as the compute agent drives it: commands in, speech and route state out,
//! on a two-floor building (the corridor of `walks.rs` on both floors, an elevator at the
//! foot of the corridor down, and a closed room no door leads into).

use std::path::Path;

use guidance::{GuidanceProfile, Navigator, UserPose};
use map::{Building, Cell, Floor, OccupancyGrid, Origin, SemanticLayer};
use planning::UserProfile;
use schemas::{Command, Priority, RouteStatus};

const RES_M: f64 = 0.05;

/// The corridor of `walks.rs` (y 10.5..12.5, x 0.5..26.5, and down x 18.5..20.5 to y 0.5),
/// and a closed room at x 2..6, y 2..6.
fn floor_grid() -> OccupancyGrid {
    let (w, h) = ((27.0 / RES_M) as usize, (13.0 / RES_M) as usize);
    let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
    let mut g = OccupancyGrid::filled(w, h, RES_M, o, Cell::Occupied).unwrap();
    for r in 0..h {
        for c in 0..w {
            let (x, y) = g.cell_center(c, r);
            let across = (0.5..=26.5).contains(&x) && (10.5..=12.5).contains(&y);
            let down = (18.5..=20.5).contains(&x) && (0.5..=12.5).contains(&y);
            let closed = (2.0..=6.0).contains(&x) && (2.0..=6.0).contains(&y);
            if across || down || closed {
                g.set(c, r, Cell::Free);
            }
        }
    }
    g
}

const LAYER: &str = r#"
[[label]]
name = "entrance"
x = 1.5
y = 11.5
floor = 0

[[label]]
name = "room 214"
x = 1.5
y = 11.5
floor = 1

[[label]]
name = "room 204"
x = 25.5
y = 11.5
floor = 1

[[label]]
name = "store room"
x = 4.0
y = 4.0
floor = 0

[[area]]
name = "corridor"
floor = 0
polygon = [[0.5, 10.5], [26.5, 10.5], [26.5, 12.5], [0.5, 12.5]]

[[gateway]]
name = "main elevator"
type = "elevator"
stops = [ { floor = 0, x = 19.5, y = 1.5 }, { floor = 1, x = 19.5, y = 1.5 } ]
"#;

fn navigator() -> Navigator {
    let layer = SemanticLayer::parse(LAYER, Path::new("navigator.toml")).unwrap();
    let floors = [0, 1].map(|level| Floor { level, grid: floor_grid(), semantic: layer.floor(level) });
    let building = Building::new(floors.to_vec(), Path::new("two floors")).unwrap();
    Navigator::new(&building, UserProfile::default(), GuidanceProfile::default())
}

fn at(x: f64, y: f64, heading_rad: f64, floor: i32) -> UserPose {
    UserPose { x_m: x, y_m: y, heading_rad, floor, confident: true }
}

fn go(label: &str) -> Command {
    Command::Destination { label: label.into() }
}

fn texts(speech: &[schemas::SpeechIntent]) -> Vec<&str> {
    speech.iter().map(|s| s.text.as_str()).collect()
}

/// Walks from `from` to `to` in 0.1 m steps, 100 ms apart, from `t_ms`; what was said.
fn walk(nav: &mut Navigator, from: [f64; 2], to: [f64; 2], floor: i32, t_ms: &mut u64) -> Vec<String> {
    let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
    let n = ((dx.hypot(dy)) / 0.1).ceil().max(1.0) as usize;
    let heading = dy.atan2(dx);
    let mut said = Vec::new();
    for k in 0..=n {
        let f = k as f64 / n as f64;
        *t_ms += 100;
        if let Some(s) = nav.step(&at(from[0] + f * dx, from[1] + f * dy, heading, floor), *t_ms) {
            assert_eq!(s.priority, Priority::Message, "guidance never speaks over a warning");
            said.push(s.text);
        }
    }
    said
}

#[test]
fn destinations_are_every_label_by_floor_then_name() {
    let d = navigator().destinations();
    let names: Vec<(i32, &str)> = d.destinations.iter().map(|d| (d.at.floor, d.label.as_str())).collect();
    assert_eq!(names, [(0, "entrance"), (0, "store room"), (1, "room 204"), (1, "room 214")]);
    assert_eq!((d.destinations[2].at.x_m, d.destinations[2].at.y_m), (25.5, 11.5));
}

#[test]
fn an_unknown_destination_is_said_with_the_closest_names_and_starts_nothing() {
    let mut nav = navigator();
    let here = at(1.5, 11.5, 0.0, 0);
    let r = nav.command(&go("room 241"), &here, 0);
    assert_eq!(
        texts(&r.speech),
        ["I do not know a place called room 241. Places with a similar name: room 204, room 214, store room."]
    );
    assert_eq!(nav.state(&here).status, RouteStatus::Idle);
    // case and blanks do not matter
    assert!(nav.find("  ROOM 204 ").is_ok());
}

#[test]
fn a_place_the_user_names_goes_to_localization_with_its_floor_and_point_and_an_unknown_one_is_said() {
    let mut nav = navigator();
    let lost = UserPose { confident: false, ..at(3.0, 3.0, 0.0, 0) };
    let r = nav.command(&Command::Place { label: " Room 204 ".into() }, &lost, 0);
    assert_eq!(texts(&r.speech), Vec::<&str>::new(), "the agent answers once the filter has it");
    let (name, p) = r.place.expect("a place for localization");
    assert_eq!((name.as_str(), p.floor, p.x, p.y), ("room 204", 1, 25.5, 11.5));
    assert_eq!(nav.state(&lost).status, RouteStatus::Idle, "naming a place starts no trip");
    let r = nav.command(&Command::Place { label: "room 241".into() }, &lost, 10);
    assert_eq!(r.place, None);
    assert_eq!(
        texts(&r.speech),
        ["I do not know a place called room 241. Places with a similar name: room 204, room 214, store room."]
    );
}

#[test]
fn a_destination_waits_for_the_position_then_guides_across_floors_to_arrival() {
    let mut nav = navigator();
    let lost = UserPose { confident: false, ..at(1.5, 11.5, 0.0, 0) };
    let r = nav.command(&go("room 214"), &lost, 0);
    assert_eq!(texts(&r.speech), ["Going to room 214. Turn slowly on the spot until I find your position."]);
    let waiting = nav.state(&lost);
    assert_eq!(
        (waiting.status, waiting.destination.as_str(), waiting.route.len()),
        (RouteStatus::WaitingForPosition, "room 214", 0)
    );
    // nothing while the position is unknown: no route on a guess
    assert_eq!(nav.step(&lost, 100), None);

    let start = at(1.5, 11.5, 0.0, 0);
    let first = nav.step(&start, 200).expect("planned once the position is known");
    assert_eq!(first.text, "Route to room 214: 55 metres. Go straight on.");
    let s = nav.state(&start);
    assert_eq!(s.status, RouteStatus::Guiding);
    // the smoothed route: 53.3 m, said rounded to 5
    assert!((s.distance_left_m - 53.3).abs() < 0.5, "{}", s.distance_left_m);
    let last = s.route.last().unwrap();
    // the goal as the graph has it, a lattice point within a cell of the label
    assert!((last.x_m - 1.5).abs() <= 0.05 && (last.y_m - 11.5).abs() <= 0.05 && last.floor == 1, "{last:?}");
    assert!(s.route.iter().any(|p| p.floor == 0) && s.next_waypoint == s.route.first().copied());
    assert_eq!(s.instruction, first.text);

    let mut t = 200;
    let mut said = walk(&mut nav, [1.5, 11.5], [19.5, 11.5], 0, &mut t);
    said.extend(walk(&mut nav, [19.5, 11.5], [19.5, 1.5], 0, &mut t));
    assert_eq!(
        said,
        [
            "In 6 metres, turn right.",
            "Turn right now.",
            "Elevator ahead; take it to floor 1; tell me when you are there.",
            "You are at the elevator. Take it to floor 1, then tell me when you are there."
        ]
    );
    let at_lift = at(19.5, 1.5, -1.57, 0);
    assert_eq!(nav.state(&at_lift).status, RouteStatus::WaitingForFloor);

    // the user rides up and says so: localization is told, the guide starts floor 1
    let r = nav.command(&Command::Floor { floor: 1 }, &at_lift, t + 10_000);
    assert_eq!((r.floor_confirmed, r.speech.len()), (Some(1), 0));
    let up = at(19.5, 1.5, std::f64::consts::FRAC_PI_2, 1);
    let next = nav.step(&up, t + 11_000).unwrap();
    assert_eq!(next.text, "Floor 1: 25 metres to room 214. Go straight on.");
    assert_eq!(nav.state(&up).floor, 1);

    let mut t = t + 11_000;
    let mut said = walk(&mut nav, [19.5, 1.5], [19.5, 11.5], 1, &mut t);
    said.extend(walk(&mut nav, [19.5, 11.5], [1.5, 11.5], 1, &mut t));
    assert_eq!(said, ["In 6 metres, turn left.", "Turn left now.", "You have arrived at room 214."]);
    let done = nav.state(&at(1.5, 11.5, std::f64::consts::PI, 1));
    assert_eq!((done.status, done.distance_left_m, done.floor), (RouteStatus::Arrived, 0.0, 1));
}

#[test]
fn cancel_repeat_and_where_am_i_answer_with_or_without_a_route() {
    let mut nav = navigator();
    let here = at(10.0, 11.5, 0.0, 0);
    assert_eq!(texts(&nav.command(&Command::Repeat, &here, 0).speech), ["Nothing to repeat yet."]);
    assert_eq!(texts(&nav.command(&Command::WhereAmI, &here, 0).speech), ["In the corridor."]);
    let unsure = UserPose { confident: false, ..here };
    assert_eq!(
        texts(&nav.command(&Command::WhereAmI, &unsure, 0).speech),
        ["Position uncertain: I do not know where you are."]
    );
    // "repeat" says the navigator's own last answer again, with a key of its own
    let again = nav.command(&Command::Repeat, &here, 0).speech;
    assert_eq!(texts(&again), ["Position uncertain: I do not know where you are."]);

    let started = nav.command(&go("room 204"), &here, 1000);
    assert_eq!(texts(&started.speech), ["Route to room 204: 35 metres. Go straight on."]);
    let repeated = nav.command(&Command::Repeat, &here, 2000).speech;
    assert_eq!(texts(&repeated), ["Route to room 204: 35 metres. Go straight on."]);
    assert_ne!(repeated[0].dedup_key, started.speech[0].dedup_key, "a repeat is never deduplicated away");

    assert_eq!(texts(&nav.command(&Command::Cancel, &here, 3000).speech), ["Guidance to room 204 stopped."]);
    assert_eq!(nav.state(&here).status, RouteStatus::Idle);
    assert_eq!(nav.step(&here, 4000), None);
    assert_eq!(texts(&nav.command(&Command::Cancel, &here, 5000).speech), ["No guidance to stop."]);
    // mute is the feedback agent's
    assert_eq!(nav.command(&Command::Mute { muted: true }, &here, 6000), Default::default());
}

#[test]
fn a_user_whose_place_is_lost_hears_where_they_were_last_placed_and_how_far_they_walked_since() {
    let mut nav = navigator();
    let placed = at(10.0, 11.5, 0.0, 0);
    assert_eq!(nav.step(&placed, 0), None);
    let lost = UserPose { x_m: 14.0, confident: false, ..placed };
    for k in 1..=24u64 {
        nav.walked(0.5);
        nav.step(&lost, k * 100);
    }
    nav.walked(f64::NAN);
    nav.walked(-3.0);
    let said = nav.command(&Command::WhereAmI, &lost, 2500).speech;
    assert_eq!(
        texts(&said),
        ["Position uncertain: I do not know where you are. Last known: in the corridor, 12 metres walked since."]
    );
    // on a trip, the guide answers with the same words
    let mut guided = navigator();
    assert_eq!(
        texts(&guided.command(&go("room 204"), &placed, 0).speech),
        ["Route to room 204: 35 metres. Go straight on."]
    );
    guided.step(&placed, 100);
    for k in 2..=8u64 {
        guided.walked(1.0);
        guided.step(&lost, k * 100);
    }
    let said = guided.command(&Command::WhereAmI, &lost, 1000).speech;
    assert_eq!(
        texts(&said),
        ["Position uncertain: I do not know where you are. Last known: in the corridor, 7 metres walked since."]
    );
    // placed again: where they are, and the count starts anew
    let back = at(17.0, 11.5, 0.0, 0);
    guided.step(&back, 1100);
    assert_eq!(texts(&guided.command(&Command::WhereAmI, &back, 1200).speech), ["In the corridor."]);
    guided.walked(2.0);
    guided.step(&lost, 1300);
    assert_eq!(
        texts(&guided.command(&Command::WhereAmI, &lost, 1400).speech),
        ["Position uncertain: I do not know where you are. Last known: in the corridor, 2 metres walked since."]
    );
    // a place the map has no name for is not offered
    let mut unnamed = navigator();
    unnamed.step(&at(19.5, 5.0, 0.0, 0), 0);
    unnamed.walked(4.0);
    assert_eq!(
        texts(&unnamed.command(&Command::WhereAmI, &lost, 100).speech),
        ["Position uncertain: I do not know where you are."]
    );
}

#[test]
fn an_unreachable_destination_is_said_and_the_planner_reason_kept_for_the_log() {
    let mut nav = navigator();
    let here = at(1.5, 11.5, 0.0, 0);
    let r = nav.command(&go("store room"), &here, 0);
    assert_eq!(texts(&r.speech), ["I cannot find a way to store room from here."]);
    assert_eq!(nav.state(&here).status, RouteStatus::Unreachable);
    let why = nav.take_problem().unwrap();
    assert!(why.starts_with("no way to store room: no walkable path"), "{why}");
    assert_eq!(nav.take_problem(), None);
}

#[test]
fn repeat_after_no_way_plans_again_from_the_position_of_now() {
    // the position was (wrongly) inside the closed room: no way; found again in the
    // corridor, "repeat" plans from there
    let mut nav = navigator();
    let wrong = at(4.0, 4.0, 0.0, 0);
    let r = nav.command(&go("room 204"), &wrong, 0);
    assert_eq!(texts(&r.speech), ["I cannot find a way to room 204 from here."]);
    let again = nav.command(&Command::Repeat, &wrong, 1000);
    assert_eq!(texts(&again.speech), ["I cannot find a way to room 204 from here."]);
    let here = at(1.5, 11.5, 0.0, 0);
    let r = nav.command(&Command::Repeat, &here, 2000);
    assert_eq!(texts(&r.speech), ["Route to room 204: 40 metres. Go straight on."]);
    assert_eq!(nav.state(&here).status, RouteStatus::Guiding);
}

#[test]
fn with_no_way_the_route_is_planned_again_unasked_once_the_position_has_moved_on() {
    // the position (wrongly) inside the closed room: no way, said once
    let mut nav = navigator();
    let wrong = at(4.0, 4.0, 0.0, 0);
    let r = nav.command(&go("room 204"), &wrong, 0);
    assert_eq!(texts(&r.speech), ["I cannot find a way to room 204 from here."]);
    // still there, or 1 m on: not planned again, nothing said
    assert_eq!(nav.step(&wrong, 1000), None);
    assert_eq!(nav.step(&at(5.0, 4.0, 0.0, 0), 2000), None);
    assert_eq!(nav.state(&wrong).status, RouteStatus::Unreachable);
    // found again in the corridor: the route, without being asked
    let here = at(1.5, 11.5, 0.0, 0);
    let s = nav.step(&here, 3000).expect("the route from where the user is now");
    assert_eq!(s.text, "Route to room 204: 40 metres. Go straight on.");
    assert_eq!(nav.state(&here).status, RouteStatus::Guiding);
}

#[test]
fn with_no_way_and_the_position_lost_for_long_the_user_is_asked_to_stop_and_told_when_it_is_found() {
    // the position (wrongly) inside the closed room: no way; then lost while the user,
    // told to walk on while it is looked for, walks on
    let mut nav = navigator();
    let wrong = at(4.0, 4.0, 0.0, 0);
    assert_eq!(texts(&nav.command(&go("room 204"), &wrong, 0).speech), ["I cannot find a way to room 204 from here."]);
    let lost = UserPose { confident: false, ..wrong };
    let stop = GuidanceProfile::default().stop_when_uncertain_ms;
    assert_eq!(nav.step(&lost, 1000), None);
    assert_eq!(nav.step(&lost, 1000 + stop - 100), None);
    let s = nav.step(&lost, 1000 + stop).expect("asked to stop");
    assert_eq!(
        s.text,
        "Position still uncertain: please stop, and turn slowly on the spot until I find your position."
    );
    assert_eq!(s.priority, Priority::Message);
    assert_eq!(nav.step(&lost, 1000 + stop + 100), None, "once");
    // cut off by a warning: said again
    assert!(nav.not_heard(&s.text));
    assert_eq!(nav.step(&lost, 1000 + stop + 200).map(|s| s.text), Some(s.text.clone()));
    // found again where the user turned: said at once (once, when the localization's
    // news of the step said it already), then (far from where no way was found) the
    // route from there
    let here = at(1.5, 11.5, 0.0, 0);
    let mut told = nav.clone();
    assert_eq!(told.step_after_news(&here, Some("Position found."), 1000 + stop + 5000), None);
    assert_eq!(nav.step(&here, 1000 + stop + 5000).map(|s| s.text).as_deref(), Some("Position found."));
    let route = nav.step(&here, 1000 + stop + 5100).map(|s| s.text);
    assert_eq!(route.as_deref(), Some("Route to room 204: 40 metres. Go straight on."));
}

#[test]
fn a_preview_plans_without_starting_guidance() {
    let mut nav = navigator();
    let here = at(1.5, 11.5, 0.0, 0);
    let p = nav.preview(&here, "room 214").unwrap();
    assert_eq!(p.status, RouteStatus::Preview);
    assert_eq!(p.instruction, "55 metres, by the main elevator to floor 1");
    assert!((p.distance_left_m - 53.3).abs() < 0.5, "{}", p.distance_left_m);
    assert_eq!(nav.state(&here).status, RouteStatus::Idle);
    assert!(nav.preview(&here, "kitchen").unwrap_err().starts_with("I do not know a place called kitchen"));
    let unsure = UserPose { confident: false, ..here };
    assert_eq!(nav.preview(&unsure, "room 214").unwrap_err(), "the position is not known yet");
}

/// A room 10 x 6 m (free x 0.5..9.5, y 0.5..5.5) with "door A" at its west end and
/// "door B" at its east end: a floor plan, walls only.
fn room_navigator() -> Navigator {
    let (w, h) = ((10.0 / RES_M) as usize, (6.0 / RES_M) as usize);
    let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
    let mut g = OccupancyGrid::filled(w, h, RES_M, o, Cell::Occupied).unwrap();
    for r in 0..h {
        for c in 0..w {
            let (x, y) = g.cell_center(c, r);
            if (0.5..=9.5).contains(&x) && (0.5..=5.5).contains(&y) {
                g.set(c, r, Cell::Free);
            }
        }
    }
    let layer = r#"
[[label]]
name = "door A"
x = 1.0
y = 3.0
floor = 0

[[label]]
name = "door B"
x = 9.0
y = 3.0
floor = 0
"#;
    let layer = SemanticLayer::parse(layer, Path::new("room.toml")).unwrap();
    let building =
        Building::new(vec![Floor { level: 0, grid: g, semantic: layer.floor(0) }], Path::new("room")).unwrap();
    Navigator::new(&building, UserProfile::default(), GuidanceProfile::default())
}

/// A desk's front as the camera sees it: points every 5 cm along x = 5, y from `y0` to `y1`.
fn desk(y0: f64, y1: f64) -> Vec<[f64; 2]> {
    let n = ((y1 - y0) / 0.05).round() as usize;
    (0..=n).map(|k| [5.0, y0 + k as f64 * 0.05]).collect()
}

#[test]
fn a_desk_the_plan_lacks_on_the_route_ahead_gets_a_way_round_said_once() {
    let mut nav = room_navigator();
    let start = at(1.0, 3.0, 0.0, 0);
    let r = nav.command(&go("door B"), &start, 0);
    assert_eq!(texts(&r.speech), ["Route to door B: 8 metres. Go straight on."]);
    let straight = nav.state(&start);
    assert!(straight.route.iter().all(|p| (p.y_m - 3.0).abs() < 0.1), "{:?}", straight.route);

    // walking on, the camera 0.35 m ahead of the body sees a desk across the way
    // (y 2.0 to 4.0): not in the plan, so on the planner; a way round is laid
    let user = at(3.0, 3.0, 0.0, 0);
    nav.perceived(&user, [3.35, 3.0], &desk(2.0, 4.0), 1000);
    assert_eq!(nav.detours(), (1, 0, 0));
    // 41 points, 20 cm cells: 11 cells
    assert_eq!(nav.perceived_obstacles(), (11, 0));
    // (after the spacing since the last instruction)
    let said = nav.step(&user, 4000).expect("the new route's start").text;
    assert!(said.starts_with("Something stands in the way. A way round: "), "{said}");
    assert!(said.ends_with(", then go straight on."), "{said}");
    let round = nav.state(&user);
    assert_eq!(round.status, RouteStatus::Guiding);
    // every leg of the new route keeps the body (0.3 m clearance) off the desk
    let mut from = [user.x_m, user.y_m];
    for p in &round.route {
        let to = [f64::from(p.x_m), f64::from(p.y_m)];
        for d in desk(2.0, 4.0) {
            let gap = segment_distance(from, to, d);
            assert!(gap >= 0.3, "the route passes {gap:.2} m from the desk at {d:?}: {:?}", round.route);
        }
        from = to;
    }
    let last = round.route.last().unwrap();
    assert!((f64::from(last.x_m) - 9.0).abs() <= 0.1 && (f64::from(last.y_m) - 3.0).abs() <= 0.1);

    // the desk seen again from the new route: nothing new stands on it, no new route
    nav.perceived(&user, [3.35, 3.0], &desk(2.0, 4.0), 6000);
    assert_eq!(nav.detours(), (1, 0, 0));
    // not seen for 15 s: given back to the graph
    nav.perceived(&user, [3.35, 3.0], &[], 21_000);
    assert_eq!(nav.perceived_obstacles(), (0, 0));
}

#[test]
fn a_bin_on_the_route_is_a_sidestep_for_the_cane_not_a_new_route() {
    let mut nav = room_navigator();
    let start = at(1.0, 3.0, 0.0, 0);
    assert_eq!(nav.command(&go("door B"), &start, 0).speech.len(), 1);
    let user = at(3.0, 3.0, 0.0, 0);
    // a bin 0.3 m across on the route 2 m ahead: a way round exists, half a metre aside
    let bin: Vec<[f64; 2]> =
        (0..7).flat_map(|i| (0..7).map(move |j| [4.85 + 0.05 * f64::from(i), 2.85 + 0.05 * f64::from(j)])).collect();
    nav.perceived(&user, [3.35, 3.0], &bin, 1000);
    assert_eq!(nav.detours(), (0, 0, 1));
    assert_eq!(nav.step(&user, 4000), None, "nothing to say: the route is as it was");
    let kept = nav.state(&user);
    assert!(kept.route.iter().all(|p| (p.y_m - 3.0).abs() < 0.1), "{:?}", kept.route);
}

#[test]
fn what_the_plan_has_no_confident_position_and_no_way_round_leave_the_route_as_it_is() {
    let mut nav = room_navigator();
    let start = at(1.0, 3.0, 0.0, 0);
    assert_eq!(nav.command(&go("door B"), &start, 0).speech.len(), 1);
    let user = at(3.0, 3.0, 0.0, 0);
    // the room's walls, seen: the plan has them
    let walls: Vec<[f64; 2]> = (0..60).map(|k| [3.5 + k as f64 * 0.05, 0.45]).collect();
    nav.perceived(&user, [3.35, 3.0], &walls, 1000);
    assert_eq!((nav.perceived_obstacles(), nav.detours()), ((0, 0), (0, 0, 0)));
    // a desk while the position is not confident: nowhere to put it
    let lost = UserPose { confident: false, ..user };
    nav.perceived(&lost, [3.35, 3.0], &desk(2.0, 4.0), 2000);
    assert_eq!((nav.perceived_obstacles(), nav.detours()), ((0, 0), (0, 0, 0)));
    // points that are no points, or 30 m off: refused and counted
    nav.perceived(&user, [3.35, 3.0], &[[f64::NAN, 3.0], [33.0, 3.0]], 3000);
    assert_eq!(nav.perceived_obstacles(), (0, 2));
    // a desk across the whole room: no way round, the route is kept and the log told why
    nav.perceived(&user, [3.35, 3.0], &desk(0.5, 5.5), 4000);
    assert_eq!(nav.detours(), (0, 1, 0));
    let problem = nav.take_problem().expect("a reason for the log");
    assert!(problem.starts_with("something stands on the route ahead and there is no way round it"), "{problem}");
    let kept = nav.state(&user);
    assert_eq!(kept.status, RouteStatus::Guiding);
    assert!(kept.route.iter().all(|p| (p.y_m - 3.0).abs() < 0.1), "{:?}", kept.route);
    // and not looked for again before 4 s have passed
    nav.perceived(&user, [3.35, 3.0], &desk(0.5, 5.5), 5000);
    assert_eq!(nav.detours(), (0, 1, 0));
}

/// Distance from `p` to the segment `a`-`b`.
fn segment_distance(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    let (vx, vy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = vx * vx + vy * vy;
    let t = if len2 > 0.0 { (((p[0] - a[0]) * vx + (p[1] - a[1]) * vy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (a[0] + t * vx - p[0]).hypot(a[1] + t * vy - p[1])
}

#[test]
fn news_that_the_position_is_lost_is_not_followed_by_position_uncertain_and_the_request_to_stop_still_is() {
    const LOST: &str = "Position lost: walk on slowly while I look for it, or tell me the number of a door you are at.";
    const UNCERTAIN: &str = "Position uncertain: no turn instructions until I know where you are again.";
    let here = at(1.5, 11.5, 0.0, 0);
    let mut nav = navigator();
    assert_eq!(
        texts(&nav.command(&go("room 204"), &here, 0).speech),
        ["Route to room 204: 40 metres. Go straight on."]
    );
    let lost = UserPose { confident: false, ..here };
    // lost at t (past the guide's spacing after the route's announcement)
    let t = 10_000;
    // without the news the guide says it has no place (how `step` is called alone)
    let mut untold = nav.clone();
    assert_eq!(untold.step(&lost, t).map(|s| s.text).as_deref(), Some(UNCERTAIN));
    // with it, the news said so (and asked for a door number): not said in the same
    // step, nor while the news may still wait for the speaker
    let mut told = nav.clone();
    assert_eq!(told.step_after_news(&lost, Some(LOST), t), None);
    let mut later = nav.clone();
    assert_eq!(later.step_after_news(&lost, Some(LOST), t), None);
    let found = here;
    assert_eq!(later.step_after_news(&found, Some("Position found."), t + 1000), None, "found: the news said it");
    assert_eq!(later.step_after_news(&lost, None, t + 4900), None, "within the news's 5 s");
    // past the news's life (and the guide's spacing), lost again: said
    let mut after = nav.clone();
    assert_eq!(after.step_after_news(&lost, Some(LOST), t), None);
    assert_eq!(after.step_after_news(&found, Some("Position found."), t + 1000), None);
    let past = t + GuidanceProfile::default().min_spacing_ms.max(5000);
    assert_eq!(after.step_after_news(&lost, None, past).map(|s| s.text).as_deref(), Some(UNCERTAIN));
    // the request to stop and turn on the spot comes all the same
    let stop = GuidanceProfile::default().stop_when_uncertain_ms;
    let s = told.step_after_news(&lost, None, t + stop).expect("asked to stop");
    assert_eq!(
        s.text,
        "Position still uncertain: please stop, and turn slowly on the spot until I find your position."
    );
}

#[test]
fn a_user_waiting_for_a_first_position_whom_turning_does_not_place_is_asked_for_a_door_number() {
    const FAILED: &str = "I cannot find your position by turning. Please stop turning, and tell me the number of a door you are at, or ask someone nearby where you are and tell me the place.";
    let here = at(1.5, 11.5, 0.0, 0);
    let lost = UserPose { confident: false, ..here };
    let search = GuidanceProfile::default().search_for_ms;
    let mut nav = navigator();
    let r = nav.command(&go("room 204"), &lost, 1000);
    assert_eq!(texts(&r.speech), ["Going to room 204. Turn slowly on the spot until I find your position."]);
    for t in (1100..1000 + search).step_by(100) {
        assert_eq!(nav.step(&lost, t), None, "at {t} ms");
    }
    let failed = nav.step(&lost, 1000 + search).expect("turning did not place the user");
    assert_eq!(failed.text, FAILED);
    assert_eq!(failed.priority, Priority::Message);
    // once; cut off by a warning: said again
    assert_eq!(nav.step(&lost, 1100 + search), None);
    assert!(nav.not_heard(FAILED));
    assert_eq!(nav.step(&lost, 1200 + search).map(|s| s.text).as_deref(), Some(FAILED));
    for t in (1300 + search..1000 + 4 * search).step_by(500) {
        assert_eq!(nav.step(&lost, t), None, "at {t} ms");
    }
    // a door number told, the place known: the route
    let route = nav.step(&here, 1000 + 4 * search).map(|s| s.text);
    assert_eq!(route.as_deref(), Some("Route to room 204: 40 metres. Go straight on."));
}

/// What localization asks when it has found a place by a search
/// (`localization::SEARCHED_NEWS`), and what the guide asks again after it.
const SEARCHED: &str = "I may have found your position, but places here can look alike. To be sure, tell me the number of a door you are at, or the name of a place you are near.";
const CONFIRM: &str =
    "I am still not sure where you are: tell me the number of a door you are at, or the name of a place you are near.";

#[test]
fn a_place_a_search_found_is_asked_for_the_users_word_again_and_never_for_turning_on_the_spot() {
    // a trip under way, then a place the filter found by a search (the anchor lost):
    // not confident, and turning will not confirm it
    let here = at(1.5, 11.5, 0.0, 0);
    let search = GuidanceProfile::default().search_for_ms;
    let mut nav = navigator();
    assert_eq!(
        texts(&nav.command(&go("room 204"), &here, 0).speech),
        ["Route to room 204: 40 metres. Go straight on."]
    );
    let found = UserPose { confident: false, ..here };
    nav.set_awaiting_word(true);
    let t = 10_000;
    assert_eq!(nav.step_after_news(&found, Some(SEARCHED), t), None, "the news asked");
    let mut said = Vec::new();
    for now in (t + 100..t + 3 * search).step_by(100) {
        said.extend(nav.step_after_news(&found, None, now).map(|s| (now, s.text, s.priority)));
    }
    // asked again each `search_for_ms`, at `Message` (it asks something), never to turn
    assert_eq!(said.len(), 2, "{said:?}");
    for ((when, text, priority), k) in said.iter().zip(1..) {
        assert_eq!((text.as_str(), *priority), (CONFIRM, Priority::Message));
        assert!(when.abs_diff(t + k * search) <= 200, "asked at {when} ms");
    }
    // "repeat" and "where am I" say what is wanted
    let r = nav.command(&Command::Repeat, &found, t + 3 * search);
    assert_eq!(texts(&r.speech), [CONFIRM]);
    let r = nav.command(&Command::WhereAmI, &found, t + 3 * search);
    assert_eq!(texts(&r.speech), [CONFIRM]);
    // the user's word confirmed it: guided on, and asked nothing more
    nav.set_awaiting_word(false);
    let mut after = Vec::new();
    for now in (t + 3 * search..t + 5 * search).step_by(100) {
        after.extend(nav.step_after_news(&here, (now == t + 3 * search).then_some("Position found."), now));
    }
    assert!(after.iter().all(|s| s.text != CONFIRM && !s.text.contains("turn slowly")), "{:?}", texts(&after));
    // the same place not confident without a search's place waiting: asked to stop and
    // turn on the spot after `stop_when_uncertain_ms`
    let stop = GuidanceProfile::default().stop_when_uncertain_ms;
    let mut lost = nav.clone();
    let stops: Vec<_> = (t + 5 * search..t + 5 * search + stop + 1000)
        .step_by(100)
        .filter_map(|now| lost.step(&found, now))
        .filter(|s| s.text.contains("turn slowly on the spot"))
        .collect();
    assert_eq!(stops.len(), 1);
}

#[test]
fn a_user_waiting_for_a_first_position_a_search_found_is_asked_for_a_door_number_not_to_turn() {
    let here = at(1.5, 11.5, 0.0, 0);
    let found = UserPose { confident: false, ..here };
    let search = GuidanceProfile::default().search_for_ms;
    let mut nav = navigator();
    nav.set_awaiting_word(true);
    let r = nav.command(&go("room 204"), &found, 1000);
    assert_eq!(texts(&r.speech), [format!("Going to room 204. {CONFIRM}").as_str()]);
    let said: Vec<_> =
        (1100..1000 + 2 * search + 500).step_by(100).filter_map(|t| nav.step(&found, t).map(|s| (t, s.text))).collect();
    assert_eq!(said, [(1000 + search, CONFIRM.to_string()), (1000 + 2 * search, CONFIRM.to_string())]);
    // confirmed: the route
    nav.set_awaiting_word(false);
    let route = nav.step(&here, 1000 + 3 * search).map(|s| s.text);
    assert_eq!(route.as_deref(), Some("Route to room 204: 40 metres. Go straight on."));
}
