//! Localization on simulated walks (issue 30, `wearnav localize --world`): the cane
//! camera's nearest-point scan, the simulator's visual odometry and a body gyro, on the
//! world's exported floor plan, against the simulator's truth. The bounds are what was
//! measured (docs/localization.md, "Simulated walks") with a margin; they are NOT the
//! issue's target of 0.10 m, which the depth scan and the door signs do not reach on
//! these walks. Its 3° of heading is reached with the wall angle, which is off by
//! default (it moves the place along a corridor without signs).

use localization::{CornerConfig, FilterConfig, FreeSpaceConfig, WallFitConfig};
use sim::World;
use study::localize_walk::{LocalizationMap, LocalizeWalkConfig, PerceivedWalk, ScanUse, WalkLocalization};

/// One walk of `name` with `seed` (walked as the configurations' walk says: they share
/// it), localized with each configuration.
fn run_each<const N: usize>(name: &str, seed: u64, configs: [&LocalizeWalkConfig; N]) -> [WalkLocalization; N] {
    let world = World::load(name).unwrap_or_else(|e| panic!("{e}"));
    let walk = PerceivedWalk::new(&world, seed, configs[0]);
    configs.map(|config| {
        let t0 = std::time::Instant::now();
        let r = walk.localize(config, || t0.elapsed().as_secs_f64() * 1e3).unwrap_or_else(|e| panic!("{e}"));
        eprint!("{}", r.summary_text());
        r
    })
}

/// What every localized walk must show: the replay of the walk's frames is exact, the
/// scan placed at the true pose lies on the plan's walls (the camera-to-body conversion
/// is right), and the filter never says `Tracking` while more than 1 m off.
fn check_common(r: &WalkLocalization) {
    let s = &r.summary;
    assert_eq!(s.replay_mismatches, 0, "the frame step's replay differs from the walk");
    assert_eq!(s.odometry_rejected, 0);
    assert!(s.truth_fit_median_m <= 0.1, "scan at the true pose is {:.3} m from the walls", s.truth_fit_median_m);
    assert_eq!(s.tracking_over_1m, 0, "Tracking while more than 1 m off");
}

#[test]
fn corridor_walk_is_tracked_within_half_a_metre_by_the_cane_scan_and_door_signs() {
    // the same walk with the signs, without them, and with one misread
    let blind = LocalizeWalkConfig { signs: None, ..Default::default() };
    let misread = LocalizeWalkConfig { misread_after_m: Some(20.0), ..Default::default() };
    let [r, blind, misread] = run_each("corridor", 1, [&LocalizeWalkConfig::default(), &blind, &misread]);
    check_common(&r);
    let s = &r.summary;
    // measured: RMSE 0.245 m (along the corridor 0.207, across 0.131), p95 0.589 m,
    // heading RMSE 2.57°, Tracking 63 % of frames, 15 door signs read
    assert!(s.walked_m > 40.0);
    assert!(s.doors_read >= 10, "{}", r.summary_text());
    assert!(s.position_rmse_m < 0.35, "{}", r.summary_text());
    assert!(s.across_rmse_m < 0.2, "{}", r.summary_text());
    assert!(s.position_p95_m < 0.8, "{}", r.summary_text());
    assert!(s.heading_rmse_deg < 3.5, "{}", r.summary_text());
    assert!(s.tracking_fraction > 0.4, "{}", r.summary_text());

    // without the door signs the place along the corridor wanders further (measured:
    // along 0.339 m against 0.207 m)
    check_common(&blind);
    assert_eq!(blind.summary.doors_read, 0);
    assert!(blind.summary.along_rmse_m > 1.3 * s.along_rmse_m, "{}", blind.summary_text());

    // a sign misread as another door's number after 20 m: the issue asks the estimate
    // back within 0.5 m in at most 5 m of walking (measured: it never left 0.5 m; the
    // worst error in the 5 m after the misread 0.48 m)
    check_common(&misread);
    let m = &misread.summary;
    assert!(m.doors_misread >= 1, "{}", misread.summary_text());
    let first = misread.frames.iter().find(|f| f.misread).expect("a misread frame");
    assert!(first.walked_m >= 20.0, "misread at {} m", first.walked_m);
    assert!(m.misread_back_within_m.is_some_and(|b| b <= 5.0), "{}", misread.summary_text());
}

#[test]
fn in_a_furnished_office_the_filter_tracks_on_the_mapped_map_and_not_on_the_walls_alone() {
    // gen:office:1, seed 1: the cane camera sees desks, tables and columns far more
    // than walls (at the true pose the scan's median distance to the floor plan's walls
    // is 2.65 m). Measured over seeds 1-12 (docs/localization.md): on the floor plan
    // every walk more than 1 m off (median RMSE 5.1 m), `Tracking` while > 1 m off on
    // all 12; on the mapped map (no chairs) median 0.24 m, none more than 1 m off
    // the first 60 s of the walk (it ends at 94 s), on either map
    let d = LocalizeWalkConfig::default();
    let first_minute = LocalizeWalkConfig { walk: study::walk::WalkConfig { timeout_s: 60.0, ..d.walk.clone() }, ..d };
    let mapped = LocalizeWalkConfig { map: LocalizationMap::Mapped, ..first_minute.clone() };
    let [plan, mapped] = run_each("gen:office:1", 1, [&first_minute, &mapped]);
    assert!(plan.summary.truth_fit_median_m > 1.0, "{}", plan.summary_text());
    assert!(plan.summary.position_rmse_m > 2.0, "{}", plan.summary_text());
    check_common(&mapped);
    let s = &mapped.summary;
    assert!(s.position_rmse_m < 0.4 && s.position_p95_m < 0.8, "{}", mapped.summary_text());
    assert!(s.tracking_fraction > 0.7, "{}", mapped.summary_text());
}

#[test]
fn among_furniture_the_floor_plan_lacks_a_persons_recovery_keeps_the_place_the_uniform_one_loses() {
    // gen:office:4, seed 1, on the floor plan: the scans fit the user's place badly
    // (desks, tables, columns), the recovery injects, and particles drawn anywhere on the
    // plan found places where the furniture's beams met walls. Measured, the first
    // minute of the walk: drawn anywhere, RMSE 3.74 m, heading 56°, 907 frames
    // `Tracking` more than 1 m off; drawn near where the user can be (the default),
    // 0.62 m, 11°, none (the whole walk: 5.25 m and 1890 frames against 0.65 m and
    // none). Over gen:<kind>:1-10 (docs/localization.md, "A person does not jump"):
    // offices median 4.49 -> 0.66 m, streets 3.65 -> 0.86 m.
    let d = LocalizeWalkConfig::default();
    let first_minute = LocalizeWalkConfig { walk: study::walk::WalkConfig { timeout_s: 60.0, ..d.walk.clone() }, ..d };
    let anywhere = LocalizeWalkConfig {
        filter: FilterConfig { recovery_anchor: None, ..first_minute.filter.clone() },
        ..first_minute.clone()
    };
    let [uniform, near] = run_each("gen:office:4", 1, [&anywhere, &first_minute]);
    assert!(uniform.summary.position_rmse_m > 2.0, "{}", uniform.summary_text());
    assert!(uniform.summary.tracking_over_1m > 100, "{}", uniform.summary_text());
    let s = &near.summary;
    assert_eq!((s.replay_mismatches, s.odometry_rejected), (0, 0));
    assert_eq!(s.tracking_over_1m, 0, "Tracking while more than 1 m off: {}", near.summary_text());
    assert!(s.position_rmse_m < 1.0 && s.heading_rmse_deg < 25.0, "{}", near.summary_text());
    assert!(s.particles_injected > 0, "the recovery never ran: {}", near.summary_text());
}

#[test]
fn the_wall_angle_holds_the_heading_within_3_degrees_where_the_scan_alone_does_not() {
    // building, seed 8 (measured): heading RMSE 3.45° with the scan and the door signs
    // alone, 1.83° with the direction of the longest straight wall of each update's scan
    // against the plan's wall directions; position RMSE 0.17 m both ways (seed 6, 3.81°
    // -> 2.53° when written, is 2.94° alone since the ground is looked for near the
    // mount's height: seeds 1-10 alone 2.05-3.45°, with the wall 1.65-2.54°). The walls found
    // lie a median 0.5° off the plan at the true heading (a 1° bin's nearest point is
    // at the bin's edge, not its centre). Off by default: along a corridor without door
    // signs it moves the place (docs/localization.md, "The wall angle").
    let walls = LocalizeWalkConfig { wall_angles: Some(WallFitConfig::default()), ..Default::default() };
    let [with, without] = run_each("building", 8, [&walls, &LocalizeWalkConfig::default()]);
    check_common(&with);
    let s = &with.summary;
    assert!(s.walls_found * 2 > s.frames, "{}", with.summary_text());
    assert!(s.wall_residual_median_deg < 1.0 && s.wall_residual_p90_deg < 2.0, "{}", with.summary_text());
    assert!(s.wall_angles_used >= 20, "{}", with.summary_text());
    assert!(s.heading_rmse_deg < 3.0, "{}", with.summary_text());
    assert!(s.position_rmse_m < 0.3, "{}", with.summary_text());
    assert_eq!(without.summary.wall_angles_used, 0);
    assert_eq!(without.summary.walls_found, s.walls_found, "the same walk, the same scans");
    assert!(without.summary.heading_rmse_deg > 3.0, "{}", without.summary_text());
}

#[test]
fn the_corners_two_walls_of_a_scan_meet_at_are_the_corners_of_the_maps_outline() {
    // corridor, seed 1 (measured): 157 corners seen in the frames' scans, at the
    // corridor's ends and its L, every one within 0.3 m of a corner found in the floor
    // plan's grid when placed at the true pose (median 0.18 m: on a wall two cells thick
    // the map's corner is on the wall's line, 0.07 m from its faces' corner, and the
    // scan's walls lie a few centimetres in front of the faces); given
    // to the filter at 20 updates. The place on this walk: RMSE 0.232 -> 0.168 m; over
    // other walks and worlds mixed, so off by default (docs/localization.md, "Corners").
    let corners = LocalizeWalkConfig { corners: Some(CornerConfig::default()), ..Default::default() };
    let [r] = run_each("corridor", 1, [&corners]);
    check_common(&r);
    let s = &r.summary;
    assert!(s.corners_found >= 50, "{}", r.summary_text());
    assert!(s.corners_on_map_fraction >= 0.95, "{}", r.summary_text());
    assert!(s.corner_residual_median_m < 0.25, "{}", r.summary_text());
    assert!(s.corners_used >= 10, "{}", r.summary_text());
    assert!(s.position_rmse_m < 0.3, "{}", r.summary_text());
}

#[test]
fn building_ground_floor_walk_is_tracked_and_dead_reckoning_is_not() {
    // with the scans and signs, and the same walk without them (odometry and gyro alone)
    let dead = LocalizeWalkConfig { scans: ScanUse::None, signs: None, ..Default::default() };
    let [r, dead] = run_each("building", 1, [&LocalizeWalkConfig::default(), &dead]);
    check_common(&r);
    let s = &r.summary;
    // measured: RMSE 0.199 m (along 0.191, across 0.057), p95 0.441 m, heading RMSE
    // 2.67°, Tracking 87 % of frames, 3 door signs read
    assert!(s.walked_m > 10.0);
    assert!(s.position_rmse_m < 0.35, "{}", r.summary_text());
    assert!(s.position_p95_m < 0.75, "{}", r.summary_text());
    assert!(s.heading_rmse_deg < 3.5, "{}", r.summary_text());
    assert!(s.tracking_fraction > 0.5, "{}", r.summary_text());
    assert!(dead.summary.position_rmse_m > 2.0 * s.position_rmse_m, "{}", dead.summary_text());
    assert!(dead.summary.heading_rmse_deg > 1.5 * s.heading_rmse_deg, "{}", dead.summary_text());
}

#[test]
fn free_space_holds_the_building_walk_nearer_and_the_floor_plan_agrees_with_the_floor_seen() {
    // The floor the cane camera saw free along each bearing, which the plan must not put
    // a wall across: on the building's ground floor the scan's walls end at halls and
    // openings, where the hits alone let the estimate fall back.
    let free = LocalizeWalkConfig {
        filter: FilterConfig { free_space: Some(FreeSpaceConfig::default()), ..Default::default() },
        ..Default::default()
    };
    let [without, with] = run_each("building", 1, [&LocalizeWalkConfig::default(), &free]);
    check_common(&with);
    let (a, b) = (&without.summary, &with.summary);
    // measured: RMSE 0.199 -> 0.118 m (along 0.191 -> 0.112), heading 2.67 -> 1.67°;
    // 1.6 % of the rays through a wall of the plan at the true pose, either way
    assert!(
        b.position_rmse_m < 0.14 && b.position_rmse_m < a.position_rmse_m - 0.05,
        "{}\n{}",
        without.summary_text(),
        with.summary_text()
    );
    assert!(b.heading_rmse_deg < a.heading_rmse_deg - 0.5, "{}\n{}", without.summary_text(), with.summary_text());
    assert!(b.tracking_fraction > 0.85, "{}", with.summary_text());
    assert!(b.free_rays > 5_000 && b.free_rays == a.free_rays, "{} vs {}", b.free_rays, a.free_rays);
    assert!(b.free_rays_through_walls_fraction < 0.03, "{}", with.summary_text());
    assert!(with.free_space && !without.free_space);
}

#[test]
fn from_a_global_start_guidance_takes_no_place_the_search_found_until_door_signs_confirm_it() {
    // no start told: the filter searches the whole floor plan. Taylor's course is a
    // room the same turned a half turn, and the search settles on the turned copy
    // and calls it `Tracking` (measured: 402 of 722 frames more than 1 m off); with
    // no door, nothing confirms it, and guidance never takes it
    let global = LocalizeWalkConfig { global_start: true, ..Default::default() };
    let [course] = run_each("taylor-course", 1, [&global]);
    let s = &course.summary;
    assert!(s.tracking_over_1m > 100, "the search found the place itself: {}", course.summary_text());
    assert_eq!((s.guiding_over_1m, s.guiding_fraction), (0, 0.0), "{}", course.summary_text());
    // the building's corridor: the door signs the chest camera reads confirm the place
    // (measured: guidance takes 86 % of the frames, none more than 1 m off); without
    // them, guidance takes none
    let unsigned = LocalizeWalkConfig { signs: None, ..global.clone() };
    let [signs, none] = run_each("building", 1, [&global, &unsigned]);
    assert_eq!(signs.summary.guiding_over_1m, 0, "{}", signs.summary_text());
    assert!(signs.summary.guiding_fraction > 0.5, "{}", signs.summary_text());
    assert!(signs
        .frames
        .iter()
        .all(|f| !f.guides || f.status == localization::Status::Tracking || f.position_error_m < 1.0));
    assert_eq!(none.summary.guiding_fraction, 0.0, "{}", none.summary_text());
}
