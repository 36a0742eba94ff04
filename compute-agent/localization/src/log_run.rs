//! A recorded laser log replayed through the filter, the way the figures are
//! measured (`wearnav localize --carmen`, the Intel tests and the bench): the log's
//! scans at their reference poses make the map; the filter sees the reference
//! increments between consecutive scans, perturbed AMCL's way with seeded noise, and
//! the scans; each estimate is compared with the reference pose of its scan.
//! No clock here: the caller passes one in to time the updates.

use map::{OccupancyGrid, SemanticLayer};

use crate::carmen::{CarmenLog, LaserRecord};
use crate::mapping::{build_grid, MappingConfig};
use crate::motion::{sample_motion, RotTransRot};
use crate::{
    wrap_angle, Beam, FilterConfig, FloorModel, LocalizationError, MotionNoise, Observations, OdometryIncrement,
    ParticleFilter, Pose2, Rng, Scan, Status,
};

/// Beyond this a laser return is not used (the Intel log's laser reports no return as
/// 81.83 m; beyond 30 m nothing is useful).
pub const MAX_RANGE_M: f64 = 30.0;

/// A log's scans, their reference poses and the map built from them.
pub struct LoggedRun {
    /// The laser records, in order.
    pub lasers: Vec<LaserRecord>,
    /// Each record as a scan from the body origin.
    pub scans: Vec<Scan>,
    /// The map the scans make at their reference poses.
    pub grid: OccupancyGrid,
}

/// What one replay gave, per scan.
#[derive(Clone, Debug, Default)]
pub struct Run {
    /// Distance of the estimate from the reference pose, metres.
    pub position_error_m: Vec<f64>,
    /// Heading error, radians (absolute).
    pub heading_error_rad: Vec<f64>,
    /// The filter's status.
    pub status: Vec<Status>,
    /// Particles after the update.
    pub particles: Vec<usize>,
    /// Time of the update (motion and correction), milliseconds, by the caller's clock.
    pub update_ms: Vec<f64>,
    /// Metres walked since the start (by the noisy odometry).
    pub walked_m: Vec<f64>,
    /// The scan's fit.
    pub fit: Vec<f64>,
}

/// A laser record as a scan from the body origin.
pub fn to_scan(l: &LaserRecord) -> Scan {
    let beams =
        (0..l.ranges_m.len()).map(|i| Beam { angle_rad: l.beam_angle_rad(i), range_m: l.ranges_m[i] }).collect();
    Scan::at_body_origin(beams, MAX_RANGE_M)
}

impl LoggedRun {
    /// The log's laser records and the map they make.
    pub fn new(log: &CarmenLog, mapping: &MappingConfig) -> Result<Self, LocalizationError> {
        let lasers: Vec<LaserRecord> = log.lasers().cloned().collect();
        if lasers.len() < 2 {
            return Err(LocalizationError::BadLog(format!(
                "it has {} laser scans: at least two are needed",
                lasers.len()
            )));
        }
        let scans: Vec<Scan> = lasers.iter().map(to_scan).collect();
        let grid = build_grid(lasers.iter().map(|l| l.pose).zip(scans.iter()), mapping)
            .map_err(|e| LocalizationError::BadLog(format!("its map: {e}")))?;
        Ok(Self { lasers, scans, grid })
    }

    /// A filter on the log's map.
    pub fn filter(&self, config: FilterConfig, seed: u64) -> Result<ParticleFilter, LocalizationError> {
        let floor = FloorModel::new(0, &self.grid, &SemanticLayer::default(), &Default::default())?;
        ParticleFilter::new(vec![floor], config, seed)
    }

    /// The reference increments between consecutive scans, perturbed AMCL's way with
    /// `alpha` (alpha1..alpha4), seeded.
    pub fn noisy_increments(&self, alpha: [f64; 4], seed: u64) -> Vec<OdometryIncrement> {
        let [alpha1, alpha2, alpha3, alpha4] = alpha;
        let noise = MotionNoise { alpha1, alpha2, alpha3, alpha4, ..Default::default() };
        let mut rng = Rng::new(seed);
        self.lasers
            .windows(2)
            .map(|w| {
                let (f, l, y) = w[0].pose.between(&w[1].pose);
                let m = RotTransRot::from_motion(f, l, y);
                let noisy = sample_motion(&Pose2::default(), &m, None, 0.0, &noise, &mut rng);
                let (f, l, y) = Pose2::default().between(&noisy);
                // the corrected Intel log's stamps go backwards 4 times and advance 10-20 ms
                // over a 1 m step 6 times (the scan matcher's reordering): take the interval
                // as at least the time at 1 m/s and 1 rad/s, or the filter rightly refuses
                let logged = w[1].timestamp_s - w[0].timestamp_s;
                let dt_s = logged.max(f.hypot(l)).max(y.abs());
                OdometryIncrement { forward_m: f, left_m: l, yaw_rad: y, dt_s }
            })
            .collect()
    }

    /// Runs `pf` over the log from its current state with `increments` (one fewer than
    /// the scans); `clock_ms` times each update. An increment the filter refuses is an
    /// error: every step of a real walk must be used, none dropped silently.
    pub fn run(
        &self,
        pf: &mut ParticleFilter,
        increments: &[OdometryIncrement],
        mut clock_ms: impl FnMut() -> f64,
    ) -> Result<Run, LocalizationError> {
        let mut out = Run::default();
        let mut walked = 0.0;
        for (i, (laser, scan)) in self.lasers.iter().zip(&self.scans).enumerate() {
            let t0 = clock_ms();
            if i > 0 {
                let inc = increments.get(i - 1).ok_or_else(|| {
                    LocalizationError::BadLog(format!("{} increments for {} scans", increments.len(), i))
                })?;
                walked += inc.forward_m.hypot(inc.left_m);
                pf.predict(inc, None)
                    .map_err(|e| LocalizationError::BadLog(format!("increment {} refused: {e}", i - 1)))?;
            }
            pf.correct(&Observations { scan: Some(scan), ..Default::default() });
            out.update_ms.push(clock_ms() - t0);
            let e = pf.estimate();
            out.position_error_m.push(e.pose.distance_m(&laser.pose));
            out.heading_error_rad.push(wrap_angle(e.pose.heading_rad - laser.pose.heading_rad).abs());
            out.status.push(e.status);
            out.particles.push(e.particles);
            out.walked_m.push(walked);
            out.fit.push(e.fit);
        }
        Ok(out)
    }
}

impl Run {
    /// The first update from which the position error stays below `bound_m` for `hold`
    /// updates.
    pub fn converged_at(&self, bound_m: f64, hold: usize) -> Option<usize> {
        let e = &self.position_error_m;
        (0..e.len().saturating_sub(hold)).find(|&k| e[k..k + hold].iter().all(|&x| x < bound_m))
    }
}

/// The `q`-quantile (0..1) of `v` (nearest rank); NaN when empty.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1)]
}

/// Root mean square; NaN when empty.
pub fn rmse(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}
