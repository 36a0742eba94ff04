//! Behaviours of the filter on synthetic floors: a misread door number does not
//! teleport the estimate, a wall angle corrects a heading offset, a kidnap sends the
//! status to `Lost` and recovery brings it back, bad input is refused and counted.

mod support;

use localization::{
    FilterConfig, FloorModel, FreeSpaceConfig, Landmark, Observations, OdometryIncrement, ParticleFilter, Pose2,
    Rejected, Status, WallAngle,
};
use map::{Corner, Door, OccupancyGrid, SemanticLayer};
use support::sim::{cast, grid};

/// A 30 x 3 m corridor (walls at y = 0.5 and 2.5) with alcoves at irregular places, so
/// a scan tells where along it the user is. Doors 101 at x = 3 and 120 at x = 25.
fn corridor() -> (OccupancyGrid, SemanticLayer) {
    let alcoves = [(4.0, 5.0), (9.0, 11.5), (14.0, 14.6), (19.0, 21.0), (26.0, 27.5)];
    let g = grid(30.0, 3.0, |x, y| {
        let end = !(0.3..=29.7).contains(&x);
        let south = y < 0.55;
        let in_alcove = alcoves.iter().any(|&(a, b)| x > a && x < b);
        let north = y > 2.45 && !(in_alcove && y < 2.95) || y > 2.95;
        end || south || north
    });
    let door = |n: &str, x: f64| Door { number: n.into(), x, y: 0.55, floor: 0, normal: [0.0, 1.0] };
    let corner = |x: f64, y: f64| Corner { x, y, floor: 0 };
    let semantic = SemanticLayer {
        doors: vec![door("101", 3.0), door("120", 25.0)],
        corners: vec![corner(0.3, 0.55), corner(0.3, 2.45), corner(29.7, 0.55), corner(29.7, 2.45)],
        ..Default::default()
    };
    (g, semantic)
}

fn corridor_filter(config: FilterConfig, seed: u64) -> (ParticleFilter, OccupancyGrid) {
    let (g, s) = corridor();
    let floor = FloorModel::new(0, &g, &s, &Default::default()).expect("floor");
    (ParticleFilter::new(vec![floor], config, seed).expect("filter"), g)
}

/// One 0.3 m step forward along +x, exact odometry.
const STEP: OdometryIncrement = OdometryIncrement { forward_m: 0.3, left_m: 0.0, yaw_rad: 0.0, dt_s: 0.3 };

/// One [`STEP`] from `truth`, then a correction with a scan of `beams` beams over
/// `fov_deg` of `g` from where the step took the user; returns that place.
fn step_and_scan(pf: &mut ParticleFilter, g: &OccupancyGrid, truth: Pose2, beams: usize, fov_deg: f64) -> Pose2 {
    let truth = truth.compose(STEP.forward_m, 0.0, 0.0);
    pf.predict(&STEP, Some(0.0)).expect("plausible");
    let scan = cast(g, &truth, beams, fov_deg.to_radians(), 8.0);
    pf.correct(&Observations { scan: Some(&scan), ..Default::default() });
    truth
}

#[test]
fn a_misread_door_number_does_not_teleport_the_estimate() {
    let (mut pf, g) = corridor_filter(FilterConfig::default(), 5);
    let mut truth = Pose2::new(2.0, 1.5, 0.0);
    pf.init_pose(0, truth, 0.2, 0.05).expect("start");
    let mut worst: f64 = 0.0;
    for k in 0..30 {
        truth = truth.compose(STEP.forward_m, 0.0, 0.0);
        pf.predict(&STEP, Some(0.0)).expect("plausible");
        let scan = cast(&g, &truth, 61, 120f64.to_radians(), 8.0);
        // at the tenth step the sign reader reads "120" (20 m away) beside the user
        let misread = [Landmark::Door { number: "120".into(), forward_m: 0.0, left_m: -0.95 }];
        let landmarks: &[Landmark] = if k == 10 { &misread } else { &[] };
        pf.correct(&Observations { scan: Some(&scan), landmarks, ..Default::default() });
        let e = pf.estimate();
        worst = worst.max(e.pose.distance_m(&truth));
    }
    eprintln!("misread door: worst error {worst:.3} m");
    assert!(worst < 0.5, "the estimate jumped: worst error {worst} m");
    assert_eq!(pf.estimate().status, Status::Tracking);
}

#[test]
fn a_door_number_localizes_and_a_misread_one_is_recovered_from() {
    // no scans: only the door signs say where the user is along the corridor
    let (mut pf, _) = corridor_filter(FilterConfig::default(), 6);
    let truth = Pose2::new(3.0, 1.5, 0.0);
    pf.init_pose(0, Pose2::new(15.0, 1.5, 0.0), 8.0, 0.05).expect("start");
    let read = |n: &str| [Landmark::Door { number: n.into(), forward_m: 0.0, left_m: -0.95 }];
    // one reading shifts belief by at most 1 / p_misread: it takes two to be sure
    pf.correct(&Observations { landmarks: &read("101"), ..Default::default() });
    let after_one = pf.estimate().pose.distance_m(&truth);
    pf.correct(&Observations { landmarks: &read("101"), ..Default::default() });
    let after_correct = pf.estimate().pose.distance_m(&truth);
    // a misread of 120 now: belief must not move 22 m to the other door
    pf.correct(&Observations { landmarks: &read("120"), ..Default::default() });
    let after_misread = pf.estimate().pose.distance_m(&truth);
    pf.correct(&Observations { landmarks: &read("101"), ..Default::default() });
    let after_reread = pf.estimate().pose.distance_m(&truth);
    eprintln!("door only (start 12 m off): after one 101 {after_one:.2} m, after two {after_correct:.2} m, after misread 120 {after_misread:.2} m, after 101 again {after_reread:.2} m");
    // a door sign places the user within its sigma (0.5 m), not better
    assert!(after_correct < 0.75, "{after_correct}");
    assert!(after_misread < 0.75, "a misread teleported the estimate by {after_misread} m");
    assert!(after_reread < 0.75, "{after_reread}");
}

/// A 30 x 3 m corridor with nothing along it (walls at y = 0.5 and 2.5) and doors 101,
/// 110 and 120 at x = 3, 13 and 25: from a scan, nowhere along it differs from anywhere
/// else.
fn plain_corridor_filter(config: FilterConfig, seed: u64) -> (ParticleFilter, OccupancyGrid) {
    let g = grid(30.0, 3.0, |x, y| !(0.3..=29.7).contains(&x) || !(0.55..=2.45).contains(&y));
    let door = |n: &str, x: f64| Door { number: n.into(), x, y: 0.55, floor: 0, normal: [0.0, 1.0] };
    let semantic =
        SemanticLayer { doors: vec![door("101", 3.0), door("110", 13.0), door("120", 25.0)], ..Default::default() };
    let floor = FloorModel::new(0, &g, &semantic, &Default::default()).expect("floor");
    (ParticleFilter::new(vec![floor], config, seed).expect("filter"), g)
}

#[test]
fn walls_that_say_only_where_across_the_corridor_do_not_make_tracking_again_a_door_number_does() {
    // a known start 10 m into the plain corridor, stepping along it, the camera's 8 m
    // reaching neither end: the told start makes `Tracking`. Then the scans stop
    // fitting (the camera blocked by something the map does not have) and the status
    // leaves `Tracking`; when they fit again, nothing in them says where along the
    // corridor the user is: the told start no longer does either
    let statuses = |min_constraint: f64, door_at_step: Option<usize>| {
        let config = FilterConfig { tracking_min_constraint: min_constraint, ..Default::default() };
        let (mut pf, g) = plain_corridor_filter(config, 7);
        let mut truth = Pose2::new(5.0, 1.5, 0.0);
        pf.init_pose(0, truth, 0.1, 0.05).expect("start");
        let mut seen = Vec::new();
        for step in 0..40 {
            truth = truth.compose(STEP.forward_m, 0.0, 0.0);
            pf.predict(&STEP, Some(0.0)).expect("plausible");
            let mut scan = cast(&g, &truth, 61, 58f64.to_radians(), 8.0);
            if (12..20).contains(&step) {
                for b in &mut scan.beams {
                    b.range_m = 0.6; // a board held 0.6 m in front of the camera
                }
            }
            // door 110 at x = 13, read on the right
            let door = Landmark::Door { number: "110".into(), forward_m: 13.0 - truth.x_m, left_m: -0.95 };
            let landmarks = if door_at_step == Some(step) { vec![door] } else { Vec::new() };
            pf.correct(&Observations { scan: Some(&scan), landmarks: &landmarks, ..Default::default() });
            seen.push(pf.estimate().status);
        }
        seen
    };
    let min = FilterConfig::default().tracking_min_constraint;
    let walls_only = statuses(min, None);
    assert_eq!(walls_only[10], Status::Tracking, "the told start: {walls_only:?}");
    assert!(walls_only[12..20].iter().any(|s| *s != Status::Tracking), "the board: {walls_only:?}");
    assert!(walls_only[20..].iter().all(|s| *s != Status::Tracking), "{walls_only:?}");
    // the rule is what holds it back: without it the same walls make `Tracking`
    let unguarded = statuses(0.0, None);
    let tracked = |s: &[Status]| s.iter().filter(|s| **s == Status::Tracking).count();
    assert!(tracked(&unguarded[20..]) >= 10, "{unguarded:?}");
    // a door number read fixes the place along the corridor
    let with_door = statuses(min, Some(22));
    assert!(tracked(&with_door[22..30]) >= 4, "{with_door:?}");
}

#[test]
fn the_scan_constraint_is_nil_between_parallel_walls_and_counts_the_beams_on_an_end_wall() {
    let (pf, g) = plain_corridor_filter(FilterConfig::default(), 1);
    let field = pf.floors()[0].field();
    let endpoints = |pose: &Pose2, max_range_m: f64| -> Vec<[f64; 2]> {
        cast(&g, pose, 61, 58f64.to_radians(), max_range_m)
            .beams
            .iter()
            .filter(|b| b.range_m < max_range_m)
            .map(|b| [b.range_m * b.angle_rad.cos(), b.range_m * b.angle_rad.sin()])
            .collect()
    };
    // mid-corridor looking along it: only the side walls
    let along = Pose2::new(10.0, 1.5, 0.0);
    let k = localization::particle_filter::scan_constraint(field, &along, &endpoints(&along, 8.0), 0.2);
    assert!(k < 0.5, "{k}");
    // 3 m from the end wall, looking at it: the beams on it fix the place along
    let facing_end = Pose2::new(26.7, 1.5, 0.0);
    let beams = endpoints(&facing_end, 8.0);
    let on_end = beams.iter().filter(|[x, _]| (facing_end.x_m + x - 29.7).abs() < 0.1).count();
    let k = localization::particle_filter::scan_constraint(field, &facing_end, &beams, 0.2);
    // (the beams near the corners count in part: the wall's normal turns there)
    assert!(on_end >= 30 && k >= 0.5 * on_end as f64, "{k} for {on_end} beams on the end wall");
}

#[test]
fn a_few_beams_do_not_make_tracking() {
    // a known start in the corridor, stepping along it: with scans of 10 usable beams
    // the status never becomes `Tracking`; with 61 it does after the streak
    let status_after = |beams: usize, min_beams: usize| {
        let (mut pf, g) = corridor_filter(FilterConfig { tracking_min_beams: min_beams, ..Default::default() }, 4);
        let mut truth = Pose2::new(2.0, 1.5, 0.0);
        pf.init_pose(0, truth, 0.1, 0.05).expect("start");
        let mut seen = Vec::new();
        for _ in 0..12 {
            truth = truth.compose(STEP.forward_m, 0.0, 0.0);
            pf.predict(&STEP, Some(0.0)).expect("plausible");
            let scan = cast(&g, &truth, beams, 120f64.to_radians(), 8.0);
            pf.correct(&Observations { scan: Some(&scan), ..Default::default() });
            seen.push(pf.estimate().status);
        }
        seen
    };
    let min = FilterConfig::default().tracking_min_beams;
    let few = status_after(10, min);
    assert!(few.iter().all(|s| *s != Status::Tracking), "{few:?}");
    let many = status_after(61, min);
    assert_eq!(many.last(), Some(&Status::Tracking), "{many:?}");
    // the rule is what holds it back: without it the 10 beams make `Tracking`
    let unguarded = status_after(10, 0);
    assert_eq!(unguarded.last(), Some(&Status::Tracking), "{unguarded:?}");
}

#[test]
fn a_place_followed_from_a_told_start_guides_where_a_few_beams_cannot_make_tracking_and_a_jump_ends_it() {
    // a cane camera facing open pavement: scans of 10 usable beams, too few for a
    // `Tracking` streak, while the user walks on from a told start
    let (mut pf, g) = corridor_filter(FilterConfig::default(), 4);
    let mut truth = Pose2::new(2.0, 1.5, 0.0);
    pf.init_pose(0, truth, 0.1, 0.05).expect("start");
    assert!(pf.estimate().followed, "a told start is a known place");
    for step in 0..20 {
        truth = step_and_scan(&mut pf, &g, truth, 10, 120.0);
        let e = pf.estimate();
        assert_ne!(e.status, Status::Tracking, "step {step}: {e:?}");
        assert!(e.followed && e.guides(), "step {step}: {e:?}");
        assert!(e.pose.distance_m(&truth) < 0.3, "step {step}: {} m off", e.pose.distance_m(&truth));
    }
    // door 120, 17 m on, read beside the user twice: the particles seeded at the door
    // take the weight and the place jumps there; whether the reading or the walk was
    // right, it is no longer the place followed from the start
    let read = [Landmark::Door { number: "120".into(), forward_m: 0.0, left_m: -0.95 }];
    let mut jumped = false;
    for _ in 0..4 {
        let before = pf.estimate().pose;
        pf.correct(&Observations { landmarks: &read, ..Default::default() });
        let e = pf.estimate();
        if e.pose.distance_m(&before) > localization::particle_filter::FOLLOW_MAX_JUMP_M {
            jumped = true;
            assert!(!e.followed && !e.guides() || e.status == Status::Tracking, "after the jump: {e:?}");
        }
    }
    assert!(jumped, "two readings of a door 17 m away did not move the place: {:?}", pf.estimate());
    // a global start is no known place
    pf.init_global();
    assert!(!pf.estimate().followed);
}

#[test]
fn with_the_gate_on_the_beams_on_a_person_the_map_does_not_have_are_left_out_while_tracking() {
    // the corridor as the camera sees it: a person (0.4 m square) in its middle, 1 m
    // from both walls, stepping ahead of the user; the filter's map has no person
    let seen_with_person = |person_x: f64| {
        let (g, _) = corridor();
        let (w, h) = (g.width(), g.height());
        let mut world = g.clone();
        for r in 0..h {
            for c in 0..w {
                let (x, y) = g.cell_center(c, r);
                if (x - person_x).abs() < 0.2 && (y - 1.5).abs() < 0.2 {
                    world.set(c, r, map::Cell::Occupied);
                }
            }
        }
        (g, world)
    };
    let walk = |gate_m: f64| {
        let config = FilterConfig { unmapped_gate_m: gate_m, max_beams: 61, ..Default::default() };
        let (mut pf, _) = corridor_filter(config, 4);
        let mut truth = Pose2::new(2.0, 1.5, 0.0);
        pf.init_pose(0, truth, 0.1, 0.05).expect("start");
        let mut person_beams_while_tracking = 0;
        for _ in 0..20 {
            truth = truth.compose(STEP.forward_m, 0.0, 0.0);
            let (map_only, world) = seen_with_person(truth.x_m + 1.5);
            pf.predict(&STEP, Some(0.0)).expect("plausible");
            let scan = cast(&world, &truth, 61, 120f64.to_radians(), 8.0);
            let walls = cast(&map_only, &truth, 61, 120f64.to_radians(), 8.0);
            let on_person = scan.beams.iter().zip(&walls.beams).filter(|(b, w)| b.range_m + 0.5 < w.range_m).count();
            if pf.estimate().status == Status::Tracking {
                person_beams_while_tracking += on_person;
            }
            pf.correct(&Observations { scan: Some(&scan), ..Default::default() });
            assert!(pf.estimate().pose.distance_m(&truth) < 0.3, "gate {gate_m}: {:?}", pf.estimate().pose);
        }
        (pf.counters().beams_unmapped, person_beams_while_tracking)
    };
    let (left_out, on_person) = walk(0.5);
    assert!(on_person >= 20, "the person is in view while tracking: {on_person} beams");
    // every beam on the person, and only those, while `Tracking`; none before
    assert_eq!(left_out as usize, on_person);
    // off (the default): every beam is weighed
    assert_eq!(FilterConfig::default().unmapped_gate_m, 0.0);
    assert_eq!(walk(0.0).0, 0);
}

#[test]
fn corners_are_the_grids_and_two_seen_together_fix_a_corridors_end() {
    // The map's corners are where its free space's outline turns (found in the grid,
    // not the semantic layer's labels): the corridor's four ends and each alcove's.
    let (g, s) = corridor();
    let floor = FloorModel::new(0, &g, &s, &Default::default()).expect("floor");
    let near = |p: [f64; 2]| floor.corners().iter().any(|c| (c[0] - p[0]).hypot(c[1] - p[1]) < 0.05);
    for end in [[0.3, 0.55], [0.3, 2.45], [29.7, 0.55], [29.7, 2.45]] {
        assert!(near(end), "no corner at {end:?}: {:?}", floor.corners());
    }
    // each alcove's two mouth corners and two back corners, and nothing else
    assert!(near([9.0, 2.45]) && near([11.5, 2.95]), "{:?}", floor.corners());
    assert_eq!(floor.corners().len(), 4 + 5 * 4, "{:?}", floor.corners());

    // No scans; facing west 0.7 m from the corridor's west end, its two corners ahead.
    // Corners are not unique (each reading is matched to whichever map corner is nearest
    // each particle's prediction): one alone fits every alcove's corner too; two 1.9 m
    // apart across the corridor fit its ends only, and facing west, this one.
    let truth = Pose2::new(1.0, 1.5, std::f64::consts::PI);
    let seen = [Landmark::Corner { forward_m: 0.7, left_m: -0.95 }, Landmark::Corner { forward_m: 0.7, left_m: 0.95 }];
    let errors: Vec<f64> = (1..=10)
        .map(|seed| {
            let (mut pf, _) = corridor_filter(FilterConfig::default(), seed);
            pf.init_pose(0, Pose2::new(8.0, 1.5, std::f64::consts::PI), 5.0, 0.05).expect("start");
            for _ in 0..3 {
                pf.correct(&Observations { landmarks: &seen, ..Default::default() });
            }
            pf.estimate().pose.distance_m(&truth)
        })
        .collect();
    eprintln!("corners: error after three readings (start 7 m off), seeds 1-10: {errors:.2?}");
    assert!(errors.iter().all(|&e| e < 0.5), "{errors:?}");
}

/// A corridor 2 m wide (walls at y = 1 and 3) from x = 0 to 10, opening there into a
/// hall 14 m deep (its far wall out of a 5 m scan's reach from the corridor).
fn corridor_into_hall() -> OccupancyGrid {
    grid(26.0, 16.0, |x, y| {
        let corridor_wall = x < 10.0 && ((0.8..1.0).contains(&y) || (3.0..3.2).contains(&y));
        let hall_wall = (10.0..10.2).contains(&x) && !(1.0..3.0).contains(&y);
        let outer = !(0.2..=25.8).contains(&x) || !(0.2..=15.8).contains(&y);
        corridor_wall || hall_wall || outer
    })
}

#[test]
fn free_space_keeps_the_estimate_from_falling_back_from_an_opening_ahead() {
    // The user stands 2.5 m short of the corridor's end, facing the hall. The scan's hits
    // are on the side walls: a place farther back fits them as well (the walls go on
    // behind), a place farther forward puts some of them into the opening. The beams
    // into the hall saw nothing; the floor along them was seen free for 5 m, which a
    // place more than ~0.3 m back puts across a side wall.
    let g = corridor_into_hall();
    let truth = Pose2::new(7.5, 2.0, 0.0);
    let mut scan = cast(&g, &truth, 59, 58f64.to_radians(), 5.0);
    scan.free = scan.beams.clone();
    let start = Pose2::new(6.9, 2.0, 0.0);
    let along = |free_space: Option<FreeSpaceConfig>, seed: u64| {
        let floor = FloorModel::new(0, &g, &Default::default(), &Default::default()).expect("floor");
        let mut pf =
            ParticleFilter::new(vec![floor], FilterConfig { free_space, ..Default::default() }, seed).expect("filter");
        pf.init_pose(0, start, 0.5, 0.01).expect("start");
        for _ in 0..5 {
            pf.force_update();
            pf.correct(&Observations { scan: Some(&scan), ..Default::default() });
        }
        pf.estimate().pose.x_m - truth.x_m
    };
    let with: Vec<f64> = (1..=6).map(|s| along(Some(FreeSpaceConfig::default()), s)).collect();
    let without: Vec<f64> = (1..=6).map(|s| along(None, s)).collect();
    eprintln!("estimate minus truth along the corridor: with free space {with:.2?}, without {without:.2?}");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(with.iter().all(|d| d.abs() < 0.25), "{with:?}");
    assert!(mean(&without) < -0.35, "the hits alone let it fall back: {without:?}");
}

#[test]
fn a_wall_angle_corrects_a_heading_offset() {
    // no scans: the heading comes from odometry, 12 degrees off, and the wall beside
    // the user, measured at 0 degrees relative to the body (walking along the corridor)
    let (mut pf, _) = corridor_filter(FilterConfig::default(), 7);
    let truth_heading = 0.0f64;
    pf.init_pose(0, Pose2::new(2.0, 1.5, 12f64.to_radians()), 0.1, 8f64.to_radians()).expect("start");
    let walls = [WallAngle { angle_rad: 0.0 }];
    for _ in 0..15 {
        pf.predict(&STEP, None).expect("plausible");
        pf.correct(&Observations { wall_angles: &walls, ..Default::default() });
    }
    let err = localization::wrap_angle(pf.estimate().pose.heading_rad - truth_heading).abs().to_degrees();
    eprintln!("wall angle: heading error {err:.2} deg after 15 updates (started 12 deg off)");
    assert!(err < 2.0, "heading still {err} deg off");
}

/// Two halves of one floor: a 10 x 10 m room with two boxes (x < 10) and a hall with
/// boxes of different sizes scattered about and one corner cut off (x > 10.4; without
/// them the hall was its own look-alike turned 180 degrees about its centre, and the
/// filter tracked the mirror image with 60 % of the beams fitting), walled around. A scan from the hall never fits the
/// room.
fn room_and_hall() -> OccupancyGrid {
    let hall = [
        (11.5, 12.5, 1.0, 1.8),
        (13.5, 14.0, 6.0, 9.0),
        (15.5, 17.5, 2.5, 3.0),
        (18.0, 19.0, 7.0, 7.6),
        (12.0, 12.4, 7.5, 8.5),
        (19.5, 20.0, 1.5, 4.0),
        (16.0, 16.6, 8.0, 8.6),
        // beside the walk along y = 4.95, at irregular places
        (11.0, 11.8, 3.6, 4.2),
        (13.0, 13.3, 5.7, 6.0),
        (14.2, 15.4, 3.3, 4.1),
        (16.8, 17.2, 5.8, 6.9),
        (18.4, 18.7, 3.8, 4.3),
        (19.6, 20.4, 5.9, 6.3),
        // a corner cut off: a rectangular hall is its own look-alike turned 180 degrees
        (18.5, 20.8, 8.0, 9.8),
    ];
    grid(21.0, 10.0, |x, y| {
        let outer = !(0.2..=20.8).contains(&x) || !(0.2..=9.8).contains(&y);
        let divider = (10.0..10.4).contains(&x);
        let in_box = |&(x0, x1, y0, y1): &(f64, f64, f64, f64)| (x0..x1).contains(&x) && (y0..y1).contains(&y);
        let room = [(1.0, 2.0, 7.5, 8.5), (7.8, 8.8, 0.8, 1.4)];
        outer || divider || room.iter().any(in_box) || hall.iter().any(in_box)
    })
}

/// Statuses and errors of a walk in the room, a kidnap into the hall at update 40, and
/// a walk up and down the hall.
fn kidnap_walk(seed: u64) -> (Vec<Status>, Vec<f64>, u64) {
    let g = room_and_hall();
    let floor = FloorModel::new(0, &g, &SemanticLayer::default(), &Default::default()).expect("floor");
    let mut pf = ParticleFilter::new(vec![floor], FilterConfig::default(), seed).expect("filter");
    // circles of 2.5 m radius about (5, 4.5) in the room
    let mut truth = Pose2::new(5.0, 2.0, 0.0);
    pf.init_pose(0, truth, 0.1, 0.05).expect("start");
    let circle = OdometryIncrement { forward_m: 0.3, left_m: 0.0, yaw_rad: 0.12, dt_s: 0.3 };
    let lane = OdometryIncrement { forward_m: 0.25, left_m: 0.0, yaw_rad: 0.0, dt_s: 0.3 };
    let about_turn = OdometryIncrement { forward_m: 0.0, left_m: 0.0, yaw_rad: std::f64::consts::PI, dt_s: 1.0 };
    let mut statuses = Vec::new();
    let mut errors = Vec::new();
    for k in 0..140 {
        let step = if k < 40 {
            circle
        } else {
            if k == 40 {
                // kidnapped: carried into the hall without odometry
                truth = Pose2::new(11.6, 4.95, 0.0);
            }
            // up and down the hall along y = 4.95, 7.5 m each way
            if (k - 40) % 31 == 30 {
                about_turn
            } else {
                lane
            }
        };
        truth = truth.compose(step.forward_m, 0.0, step.yaw_rad);
        // the gyro gives the turns (an about-turn from odometry alone spreads the
        // heading by sqrt(alpha1) * 180 = 80 degrees)
        pf.predict(&step, Some(step.yaw_rad / step.dt_s)).expect("plausible");
        let scan = cast(&g, &truth, 61, 180f64.to_radians(), 8.0);
        pf.correct(&Observations { scan: Some(&scan), ..Default::default() });
        let e = pf.estimate();
        statuses.push(e.status);
        errors.push(e.pose.distance_m(&truth));
        // `Tracking` is wrong for a few updates after the kidnap (until `Lost`); a place
        // followed without it is never taken more than 1 m off
        let off = e.pose.distance_m(&truth);
        let followed_only = e.guides() && e.status != Status::Tracking;
        assert!(!(followed_only && off > 1.0), "seed {seed}, update {k}: followed {off:.2} m off: {e:?}");
    }
    (statuses, errors, pf.counters().particles_injected)
}

/// The update (after the kidnap) at which the estimate is back within 0.5 m for ten
/// updates and tracking.
fn recovered_after(statuses: &[Status], errors: &[f64]) -> Option<usize> {
    (40..errors.len() - 10)
        .find(|&k| errors[k..k + 10].iter().all(|&e| e < 0.5) && statuses[k] == Status::Tracking)
        .map(|k| k - 40)
}

#[test]
// diagnostics (the kidnap over twenty seeds): `cargo test -p localization --features diagnostics -- --nocapture NAME`
#[cfg(feature = "diagnostics")]
fn kidnap_seeds() {
    let mut line = String::new();
    for seed in 1..=20 {
        let (st, er, _) = kidnap_walk(seed);
        let lost = st[40..].iter().position(|s| *s == Status::Lost);
        let wrong = st[40..].iter().zip(&er[40..]).filter(|(s, e)| **s == Status::Tracking && **e > 1.0).count();
        line += &format!(" {:?}/{:?}/{wrong}", lost.unwrap_or(999), recovered_after(&st, &er).unwrap_or(999));
    }
    eprintln!("kidnap: lost after / back after (999: never) / tracking while > 1 m off, per seed:{line}");
}

/// A kidnap is a search: whether the injected particles land near the true place soon
/// is luck, so this asserts over ten seeds rather than one. Measured over seeds 1 to 20
/// (the `kidnap_seeds` diagnostic): lost at once in all 20; back within 0.5 m and
/// tracking after 17 to 72 updates in 18 (median 34), the other two not within the
/// 100-update walk.
#[test]
fn status_goes_lost_when_the_likelihood_collapses_and_recovers() {
    let mut back = Vec::new();
    for seed in 1..=10 {
        let (statuses, errors, injected) = kidnap_walk(seed);
        assert!(statuses[30..40].iter().all(|s| *s == Status::Tracking), "seed {seed}: not tracking before the kidnap");
        assert!(errors[..40].iter().all(|&e| e < 0.3), "seed {seed}: inaccurate before the kidnap");
        let lost_at = statuses[40..].iter().position(|s| *s == Status::Lost);
        let back_at = recovered_after(&statuses, &errors);
        eprintln!("kidnap into the hall, seed {seed}: lost after {lost_at:?} updates, back after {back_at:?}; {injected} injected");
        assert!(lost_at.is_some_and(|k| k <= 5), "seed {seed}: lost after {lost_at:?} updates");
        back.extend(back_at);
    }
    back.sort();
    assert!(back.len() >= 9, "only {} of 10 seeds recovered", back.len());
    assert!(back[back.len() / 2] <= 50, "median recovery {} updates", back[back.len() / 2]);
}

/// On the Intel lab a kidnap does not collapse the likelihood: the office rows look
/// alike and the scan fits the wrong place as well as the right one (measured:
/// docs/localization.md). A diagnostic, not a requirement.
#[test]
// diagnostics (a kidnap on the Intel log): `cargo test -p localization --features diagnostics -- --nocapture NAME`
#[cfg(feature = "diagnostics")]
fn intel_kidnap() {
    let i = support::intel();
    let mut pf = support::filter(FilterConfig::default(), 11);
    pf.init_pose(0, i.lasers[0].pose, 0.1, 0.05).expect("start");
    let inc = support::noisy_increments(0.1, 12);
    // track the first 60 scans, then the user is carried to scan 400's place without
    // odometry (a kidnap: the filter's belief is confidently wrong)
    let mut statuses = Vec::new();
    let mut errors = Vec::new();
    for k in (0..60).chain(400..520) {
        if k != 0 && k != 400 {
            let _ = pf.predict(&inc[k - 1], None);
        }
        pf.correct(&Observations { scan: Some(&i.scans[k]), ..Default::default() });
        let e = pf.estimate();
        statuses.push(e.status);
        errors.push(e.pose.distance_m(&i.lasers[k].pose));
        if (55..62).contains(&k) || (400..440).contains(&k) {
            let (f, s, raw) = pf.fit_averages();
            eprintln!(
                "{k}: err {:.2} fit {raw:.3} fast {f:.3} fast/slow {:.2} cluster {:.2} std {:.2} {:?}",
                errors.last().unwrap(),
                f / s,
                e.cluster_weight,
                e.position_std_m(),
                e.status
            );
        }
    }
    eprintln!(
        "statuses: {:?}",
        statuses.iter().map(|s| format!("{s:?}").chars().next().unwrap_or('?')).collect::<String>()
    );
    let tracking_before = statuses[..60].iter().filter(|s| **s == Status::Tracking).count();
    assert!(tracking_before >= 45, "tracking in {tracking_before} of 60 updates before the kidnap");
    assert!(statuses[50..60].iter().all(|s| *s != Status::Lost), "lost before the kidnap");
    let lost_at = statuses[60..].iter().position(|s| *s == Status::Lost).map(|k| k + 60);
    let back_at = lost_at.and_then(|l| {
        (l..errors.len().saturating_sub(10))
            .find(|&k| errors[k..k + 10].iter().all(|&e| e < 0.5) && statuses[k] == Status::Tracking)
    });
    eprintln!(
        "kidnap: lost after {:?} updates, back within 0.5 m and tracking after {:?} updates; {} particles injected",
        lost_at.map(|k| k - 60),
        back_at.map(|k| k - 60),
        pf.counters().particles_injected
    );
}

#[test]
fn bad_input_is_refused_counted_and_not_applied() {
    let (mut pf, _) = corridor_filter(FilterConfig::default(), 9);
    pf.init_pose(0, Pose2::new(2.0, 1.5, 0.0), 0.1, 0.05).expect("start");
    let before = pf.estimate().pose;
    let jump = OdometryIncrement { forward_m: 5.0, left_m: 0.0, yaw_rad: 0.0, dt_s: 0.03 };
    assert!(matches!(pf.predict(&jump, None), Err(Rejected::Odometry(_))));
    let nan = OdometryIncrement { forward_m: f64::NAN, ..STEP };
    assert!(pf.predict(&nan, None).is_err());
    assert!(matches!(pf.predict(&STEP, Some(f64::INFINITY)), Err(Rejected::ImuYawRate(_))));
    assert_eq!(pf.counters().odometry_rejected, 3);
    assert_eq!(pf.estimate().pose, before);
    // a door that is on no floor, a NaN corner, a NaN wall angle
    let lms = [
        Landmark::Door { number: "999".into(), forward_m: 0.0, left_m: -1.0 },
        Landmark::Corner { forward_m: f64::NAN, left_m: 0.0 },
    ];
    let walls = [WallAngle { angle_rad: f64::NAN }];
    pf.correct(&Observations { landmarks: &lms, wall_angles: &walls, ..Default::default() });
    assert_eq!(pf.counters().landmarks_rejected, 2);
    assert_eq!(pf.counters().wall_angles_rejected, 1);
    assert!(pf.estimate().pose.distance_m(&before) < 0.05);
}

#[test]
fn same_seed_same_particles() {
    let run = |seed| {
        let (mut pf, g) = corridor_filter(FilterConfig::default(), seed);
        pf.init_global();
        let mut truth = Pose2::new(2.0, 1.5, 0.0);
        for _ in 0..10 {
            truth = truth.compose(0.3, 0.0, 0.0);
            pf.predict(&STEP, None).expect("plausible");
            let scan = cast(&g, &truth, 61, 120f64.to_radians(), 8.0);
            pf.correct(&Observations { scan: Some(&scan), ..Default::default() });
        }
        pf.particles().to_vec()
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3), run(4));
}

#[test]
fn a_lift_ride_moves_the_belief_to_the_other_floor() {
    use map::{Gateway, GatewayKind, GatewayStop};
    // two floors: the corridor on 0 and the room-and-hall on 1; a lift at the
    // corridor's x = 5 and at (5, 5) on floor 1
    let (g0, s0) = corridor();
    let g1 = room_and_hall();
    let floors = vec![
        FloorModel::new(0, &g0, &s0, &Default::default()).expect("floor 0"),
        FloorModel::new(1, &g1, &SemanticLayer::default(), &Default::default()).expect("floor 1"),
    ];
    let lift = Gateway {
        name: "lift".into(),
        kind: GatewayKind::Elevator,
        stops: vec![GatewayStop { floor: 0, x: 5.0, y: 1.5 }, GatewayStop { floor: 1, x: 5.0, y: 5.0 }],
    };
    let mut pf = ParticleFilter::new(floors, FilterConfig::default(), 21).expect("filter");
    pf.init_pose(0, Pose2::new(4.6, 1.5, 0.0), 0.1, 0.05).expect("start");
    let near = pf.take_gateway(&lift, 1).expect("the lift serves floor 1");
    assert_eq!(near, pf.particles().len());
    let e = pf.estimate();
    assert_eq!(e.level, 1);
    assert!(e.pose.distance_m(&Pose2::new(4.6, 5.0, 0.0)) < 0.2, "{:?}", e.pose);
    assert_ne!(e.status, Status::Tracking, "a ride is a claim; scans must confirm it");
    // walking on floor 1 with its scans: tracked there
    let mut truth = Pose2::new(4.6, 5.0, 0.0);
    for _ in 0..12 {
        truth = step_and_scan(&mut pf, &g1, truth, 61, 180.0);
    }
    let e = pf.estimate();
    assert_eq!((e.level, e.status), (1, Status::Tracking));
    assert!(e.pose.distance_m(&truth) < 0.3, "{:?} vs {truth:?}", e.pose);
    let missing = Gateway { stops: vec![GatewayStop { floor: 0, x: 5.0, y: 1.5 }], ..lift };
    assert!(pf.take_gateway(&missing, 1).is_err());
    assert!(pf.take_gateway(&missing, 7).is_err());
}

#[test]
fn door_numbers_pick_the_floor_of_a_global_start() {
    let (g0, s0) = corridor();
    let g1 = room_and_hall();
    let floors = vec![
        FloorModel::new(1, &g1, &SemanticLayer::default(), &Default::default()).expect("floor 1"),
        FloorModel::new(0, &g0, &s0, &Default::default()).expect("floor 0"),
    ];
    let mut pf = ParticleFilter::new(floors, FilterConfig::default(), 22).expect("filter");
    let start_share: f64 = pf.particles().iter().filter(|p| p.level == 0).map(|p| p.weight).sum();
    let read = [Landmark::Door { number: "101".into(), forward_m: 0.0, left_m: -0.95 }];
    for _ in 0..3 {
        pf.correct(&Observations { landmarks: &read, ..Default::default() });
    }
    let e = pf.estimate();
    eprintln!("two floors, global start: floor 0 held {start_share:.2} of the weight; after three readings of 101: floor {} at {:?}", e.level, e.pose);
    assert_eq!(e.level, 0);
    // at the door, facing along the corridor with the door on the right
    assert!((e.pose.x_m - 3.0).abs() < 1.0 && (e.pose.y_m - 1.5).abs() < 1.0, "{:?}", e.pose);
}

/// Walk east along the corridor with scans; at step 10 the user is carried 11 m east
/// without odometry (a wrong start, a kidnap; the corridor looks alike enough that the
/// scans do not notice); at steps 22 and 26 the door sign "120" is read ahead. Returns
/// the steps after the first reading until the estimate is within 0.5 m for good (None:
/// not within the walk).
fn corridor_kidnap_then_door(config: FilterConfig, seed: u64) -> Option<usize> {
    let (mut pf, g) = corridor_filter(config, seed);
    let mut truth = Pose2::new(2.0, 1.5, 0.0);
    pf.init_pose(0, truth, 0.1, 0.05).expect("start");
    let mut errors = Vec::new();
    for k in 0..40 {
        if k == 10 {
            truth = Pose2::new(16.0, 1.5, 0.0);
        }
        truth = truth.compose(STEP.forward_m, 0.0, 0.0);
        pf.predict(&STEP, Some(0.0)).expect("plausible");
        let scan = cast(&g, &truth, 61, 120f64.to_radians(), 8.0);
        let sign = [Landmark::Door { number: "120".into(), forward_m: 25.0 - truth.x_m, left_m: -0.95 }];
        // the sign reader sees it twice on the way (one reading moves belief by at most
        // 1 / p_misread; Zhang et al. fix the pose from two unique landmarks)
        let landmarks: &[Landmark] = if k == 22 || k == 26 { &sign } else { &[] };
        pf.correct(&Observations { scan: Some(&scan), landmarks, ..Default::default() });
        errors.push(pf.estimate().pose.distance_m(&truth));
    }
    let last_bad = errors.iter().rposition(|&e| e >= 0.5)?;
    (last_bad + 1 < errors.len()).then(|| (last_bad + 1).saturating_sub(22))
}

#[test]
fn a_door_reading_recovers_a_kidnapped_user_within_5_m() {
    let mut with = Vec::new();
    let mut without = Vec::new();
    for seed in 1..=5 {
        with.push(corridor_kidnap_then_door(FilterConfig::default(), seed));
        let mut no_reset = FilterConfig::default();
        no_reset.landmarks.door_reset_fraction = 0.0;
        without.push(corridor_kidnap_then_door(no_reset, seed));
    }
    eprintln!(
        "kidnap in the corridor, steps of 0.3 m after the first reading of door 120 until within 0.5 m for good: \
         with sensor resetting {with:?}, without {without:?}"
    );
    for (seed, w) in (1..).zip(&with) {
        // 5 m of walking = 16 steps of 0.3 m (the figure for a misread door)
        assert!(w.is_some_and(|s| s <= 16), "seed {seed}: {w:?}");
    }
}
