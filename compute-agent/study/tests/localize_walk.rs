//! Localization on simulated walks (issue 30): the cane camera's nearest-point scan,
//! the simulator's odometry and a body gyro, on the exported floor plan, against the truth.

use sensor_agent::sim::World;
use study::localize_walk::{localize_walk, LocalizeWalkConfig, WalkLocalization};

fn run(name: &str, seed: u64) -> WalkLocalization {
    let world = World::load(name).unwrap_or_else(|e| panic!("{e}"));
    let t0 = std::time::Instant::now();
    let r = localize_walk(&world, seed, &LocalizeWalkConfig::default(), || t0.elapsed().as_secs_f64() * 1e3)
        .unwrap_or_else(|e| panic!("{e}"));
    eprint!("{}", r.summary_text());
    r
}

#[test]
#[ignore]
fn explore() {
    for name in ["corridor", "building"] {
        for seed in 1..=3 {
            run(name, seed);
        }
    }
}
