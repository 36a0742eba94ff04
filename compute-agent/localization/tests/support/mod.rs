//! The Intel lab run shared by the tests and the bench: the log's scans at their
//! reference poses make the map; the filter then localizes on noisy odometry
//! increments between consecutive scans and the scans themselves.

#![allow(dead_code)]

pub mod sim;

use std::path::Path;
use std::sync::OnceLock;
use std::time::Instant;

use localization::carmen::{read_log, LaserRecord};
use localization::mapping::{build_grid, MappingConfig};
use localization::motion::{sample_motion, RotTransRot};
use localization::{
    Beam, Estimate, FilterConfig, FloorModel, MotionNoise, Observations, OdometryIncrement, ParticleFilter, Pose2, Rng,
    Scan, Status,
};
use map::{OccupancyGrid, SemanticLayer};

/// The Intel log's laser reports no return as 81.83 m; beyond 30 m nothing is useful.
pub const INTEL_MAX_RANGE_M: f64 = 30.0;

/// The log's scans, their reference poses and the map built from them.
pub struct Intel {
    pub lasers: Vec<LaserRecord>,
    pub scans: Vec<Scan>,
    pub grid: OccupancyGrid,
}

/// Loaded and mapped once per test binary.
pub fn intel() -> &'static Intel {
    static INTEL: OnceLock<Intel> = OnceLock::new();
    INTEL.get_or_init(|| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/intel-corrected.log.gz");
        let log = read_log(&path).unwrap_or_else(|e| panic!("the Intel log must be in the repo: {e}"));
        let lasers: Vec<LaserRecord> = log.lasers().cloned().collect();
        let scans: Vec<Scan> = lasers.iter().map(to_scan).collect();
        let grid = build_grid(lasers.iter().map(|l| l.pose).zip(scans.iter()), &MappingConfig::default())
            .expect("the Intel map fits");
        Intel { lasers, scans, grid }
    })
}

/// A laser record as a scan from the body origin.
pub fn to_scan(l: &LaserRecord) -> Scan {
    let beams =
        (0..l.ranges_m.len()).map(|i| Beam { angle_rad: l.beam_angle_rad(i), range_m: l.ranges_m[i] }).collect();
    Scan::at_body_origin(beams, INTEL_MAX_RANGE_M)
}

/// A filter on the Intel map.
pub fn filter(config: FilterConfig, seed: u64) -> ParticleFilter {
    let floor = FloorModel::new(0, &intel().grid, &SemanticLayer::default(), &Default::default()).expect("floor");
    ParticleFilter::new(vec![floor], config, seed).expect("filter")
}

/// The reference increments between consecutive scans, perturbed AMCL's way with
/// `alpha` on all four terms (seeded), as (increment, true pose after it).
pub fn noisy_increments(alpha: f64, seed: u64) -> Vec<OdometryIncrement> {
    let lasers = &intel().lasers;
    let noise = MotionNoise { alpha1: alpha, alpha2: alpha, alpha3: alpha, alpha4: alpha, ..Default::default() };
    let mut rng = Rng::new(seed);
    lasers
        .windows(2)
        .map(|w| {
            let (f, l, y) = w[0].pose.between(&w[1].pose);
            let m = RotTransRot::from_motion(f, l, y);
            let noisy = sample_motion(&Pose2::default(), &m, None, 0.0, &noise, &mut rng);
            let (f, l, y) = Pose2::default().between(&noisy);
            // the corrected log's stamps go backwards 4 times and advance 10-20 ms over
            // a 1 m step 6 times (the scan matcher's reordering): take the interval as at
            // least the time at 1 m/s and 1 rad/s, or the filter rightly refuses the step
            let logged = w[1].timestamp_s - w[0].timestamp_s;
            let dt_s = logged.max(f.hypot(l)).max(y.abs());
            OdometryIncrement { forward_m: f, left_m: l, yaw_rad: y, dt_s }
        })
        .collect()
}

/// Per-scan outcome of a run.
pub struct Run {
    pub position_error_m: Vec<f64>,
    pub heading_error_rad: Vec<f64>,
    pub status: Vec<Status>,
    pub particles: Vec<usize>,
    pub update_ms: Vec<f64>,
    pub walked_m: Vec<f64>,
    pub fit: Vec<f64>,
}

/// Runs the filter over the log from its current state; scan `i`'s estimate is
/// compared with the reference pose of scan `i`.
pub fn run(pf: &mut ParticleFilter, increments: &[OdometryIncrement]) -> Run {
    let intel = intel();
    let mut out = Run {
        position_error_m: vec![],
        heading_error_rad: vec![],
        status: vec![],
        particles: vec![],
        update_ms: vec![],
        walked_m: vec![],
        fit: vec![],
    };
    let mut walked = 0.0;
    for i in 0..intel.lasers.len() {
        let t0 = Instant::now();
        if i > 0 {
            let inc = &increments[i - 1];
            walked += inc.forward_m.hypot(inc.left_m);
            // every increment of the log is plausible: none may be dropped silently
            pf.predict(inc, None).unwrap_or_else(|e| panic!("increment {} refused: {e}", i - 1));
        }
        pf.correct(&Observations { scan: Some(&intel.scans[i]), ..Default::default() });
        out.update_ms.push(t0.elapsed().as_secs_f64() * 1e3);
        let e: Estimate = pf.estimate();
        let truth = intel.lasers[i].pose;
        out.position_error_m.push(e.pose.distance_m(&truth));
        out.heading_error_rad.push(localization::wrap_angle(e.pose.heading_rad - truth.heading_rad).abs());
        out.status.push(e.status);
        out.particles.push(e.particles);
        out.walked_m.push(walked);
        out.fit.push(e.fit);
    }
    out
}

/// The `q`-quantile (0..1) of `v` (nearest rank).
pub fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)]
}

/// Root mean square.
pub fn rmse(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}
