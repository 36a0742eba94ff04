//! Localization on simulated walks (issue 30): the cane camera's nearest-point scan,
//! the simulator's odometry and a body gyro, on the exported floor plan, against the truth.

use sensor_agent::sim::World;
use study::localize_walk::{localize_walk, LocalizeWalkConfig, ScanUse, WalkLocalization};

fn run(name: &str, seed: u64) -> WalkLocalization {
    run_with(name, seed, &LocalizeWalkConfig::default())
}

fn run_with(name: &str, seed: u64, config: &LocalizeWalkConfig) -> WalkLocalization {
    let world = World::load(name).unwrap_or_else(|e| panic!("{e}"));
    let t0 = std::time::Instant::now();
    let r = localize_walk(&world, seed, config, || t0.elapsed().as_secs_f64() * 1e3).unwrap_or_else(|e| panic!("{e}"));
    eprint!("{}", r.summary_text());
    r
}

#[test]
#[ignore]
fn explore() {
    for name in ["corridor", "building"] {
        for seed in 1..=3 {
            for (scans, imu) in [(ScanUse::Frame, true), (ScanUse::Frame, false), (ScanUse::Sweep, true)] {
                let r = run_with(name, seed, &LocalizeWalkConfig { scans, imu, ..Default::default() });
                let s = &r.summary;
                println!(
                    "| {name} | {seed} | {scans:?} | {imu} | {:.1} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {:.0} % | {} | {:.2} |",
                    s.walked_m, s.position_rmse_m, s.along_rmse_m, s.across_rmse_m, s.position_median_m, s.position_p95_m,
                    s.heading_rmse_deg, 100.0 * s.tracking_fraction, s.tracking_over_1m, s.update_ms_median
                );
            }
        }
    }
}
