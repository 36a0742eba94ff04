//! Localization on simulated walks (issue 30, `wearnav localize --world`): the cane
//! camera's nearest-point scan, the simulator's visual odometry and a body gyro, on the
//! world's exported floor plan, against the simulator's truth. The bounds are what was
//! measured (docs/localization.md, "Simulated walks") with a margin; they are NOT the
//! issue's target (0.10 m, 3°), which the depth scan does not reach on these walks.

use sensor_agent::sim::World;
use study::localize_walk::{localize_walk, LocalizeWalkConfig, ScanUse, WalkLocalization};

fn run_with(name: &str, seed: u64, config: &LocalizeWalkConfig) -> WalkLocalization {
    let world = World::load(name).unwrap_or_else(|e| panic!("{e}"));
    let t0 = std::time::Instant::now();
    let r = localize_walk(&world, seed, config, || t0.elapsed().as_secs_f64() * 1e3).unwrap_or_else(|e| panic!("{e}"));
    eprint!("{}", r.summary_text());
    r
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
fn corridor_walk_is_tracked_within_half_a_metre_by_the_cane_scan() {
    let r = run_with("corridor", 1, &LocalizeWalkConfig::default());
    check_common(&r);
    let s = &r.summary;
    // measured: RMSE 0.315 m (along the corridor 0.291, across 0.119), p95 0.642 m,
    // heading RMSE 2.63°, Tracking 47 % of frames
    assert!(s.walked_m > 40.0);
    assert!(s.position_rmse_m < 0.45, "{}", r.summary_text());
    assert!(s.across_rmse_m < 0.2, "{}", r.summary_text());
    assert!(s.position_p95_m < 0.9, "{}", r.summary_text());
    assert!(s.heading_rmse_deg < 3.5, "{}", r.summary_text());
    assert!(s.tracking_fraction > 0.3, "{}", r.summary_text());
}

#[test]
fn building_ground_floor_walk_is_tracked_and_dead_reckoning_is_not() {
    let r = run_with("building", 1, &LocalizeWalkConfig::default());
    check_common(&r);
    let s = &r.summary;
    // measured: RMSE 0.239 m (along 0.229, across 0.068), p95 0.533 m, heading RMSE
    // 2.62°, Tracking 74 % of frames
    assert!(s.walked_m > 10.0);
    assert!(s.position_rmse_m < 0.35, "{}", r.summary_text());
    assert!(s.position_p95_m < 0.75, "{}", r.summary_text());
    assert!(s.heading_rmse_deg < 3.5, "{}", r.summary_text());
    assert!(s.tracking_fraction > 0.5, "{}", r.summary_text());
    // the same walk without the scans (odometry and gyro alone): measured 0.801 m, 6.5°
    let dead = run_with("building", 1, &LocalizeWalkConfig { scans: ScanUse::None, ..Default::default() });
    assert!(dead.summary.position_rmse_m > 2.0 * s.position_rmse_m, "{}", dead.summary_text());
    assert!(dead.summary.heading_rmse_deg > 1.5 * s.heading_rmse_deg, "{}", dead.summary_text());
}
