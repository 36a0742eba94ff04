//! The Intel lab run shared by the tests and the bench: `localization::log_run` on the
//! log in `tests/data`, loaded and mapped once per test binary.

#![allow(dead_code, unused_imports)]

pub mod sim;

use std::path::Path;
use std::sync::OnceLock;
use std::time::Instant;

use localization::carmen::read_log;
use localization::log_run::LoggedRun;
pub use localization::log_run::{quantile, rmse, Run};
use localization::mapping::MappingConfig;
use localization::{FilterConfig, OdometryIncrement, ParticleFilter};

/// The log's scans, their reference poses and the map built from them.
pub fn intel() -> &'static LoggedRun {
    static INTEL: OnceLock<LoggedRun> = OnceLock::new();
    INTEL.get_or_init(|| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/intel-corrected.log.gz");
        let log = read_log(&path).unwrap_or_else(|e| panic!("the Intel log must be in the repo: {e}"));
        LoggedRun::new(&log, &MappingConfig::default()).expect("the Intel map fits")
    })
}

/// A filter on the Intel map.
pub fn filter(config: FilterConfig, seed: u64) -> ParticleFilter {
    intel().filter(config, seed).expect("filter")
}

/// The reference increments, perturbed with `alpha` on all four terms (seeded).
pub fn noisy_increments(alpha: f64, seed: u64) -> Vec<OdometryIncrement> {
    intel().noisy_increments([alpha; 4], seed)
}

/// Runs the filter over the log from its current state; every increment of the log is
/// plausible: none may be refused.
pub fn run(pf: &mut ParticleFilter, increments: &[OdometryIncrement]) -> Run {
    let start = Instant::now();
    intel().run(pf, increments, || start.elapsed().as_secs_f64() * 1e3).unwrap_or_else(|e| panic!("{e}"))
}
