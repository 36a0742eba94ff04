//! Localization on a simulated walk (issue 30, `wearnav localize --world`): the virtual
//! user walks the world's route with the cane camera sweeping; the compute agent's own
//! frame step perceives every frame; its nearest-point scan, the simulator's visual
//! odometry (never the truth) and a body-worn gyro drive the particle filter on the
//! world's exported floor plan (walls only, what a user's device would have); each
//! estimate is compared with the simulator's truth at that frame.
//!
//! The scan lives in the camera's floor frame, which turns with the sweep; the filter
//! tracks the body. Each scan goes in with the camera's place on the body at capture
//! (its offset and its yaw relative to the body, the sweep angle, which a cane IMU
//! gives; here taken from the simulator, so exact), and the odometry of the camera's
//! floor frame is turned into the body's with the sweep at both ends of the interval.
//!
//! A simulated door-sign reader ([`DoorSignReader`]: a chest camera reading each sign
//! as it comes into view, with noise and misreads) gives the filter door numbers, the
//! landmark that fixes the place along a corridor, which two parallel walls cannot.
//!
//! The walk is run first (recording its frames); the recorded frames are then replayed
//! through a fresh copy of the same frame step to get the scans (the walk keeps its
//! perception to itself; the step is deterministic, and every replayed hazard is
//! checked against the recorded one), then the filter runs frame by frame.

use localization::log_run::{quantile, rmse};
use localization::{
    corners_of_walls, wall_segments, wrap_angle, Beam, CornerConfig, FilterConfig, FloorModel, Landmark,
    LikelihoodFieldConfig, LocalizationError, Observations, OdometryIncrement, ParticleFilter, Pose2, RecoveryAnchor,
    Scan, Status, WallAngle, WallFitConfig, WALL_CROSSING_LOG_P,
};
use perception::{ComputeStep, FrameData, FrameIn, NoTimer, Perception, StepOutput};
use sim::{CaneMount, DoorSignReader, SignReaderConfig, SimRng, UserPose, World};

pub use crate::floor_plan::LocalizationMap;
use crate::floor_plan::{self, FloorPlanError};
use crate::walk::{BodyGyro, FedFrame, GuideKind, TraceRow, Walk, WalkConfig};

/// What a localized walk is made of.
#[derive(Debug, Clone)]
pub struct LocalizeWalkConfig {
    /// The walk (the world's route by default, see [`Default`]).
    pub walk: WalkConfig,
    /// The particle filter (AMCL's defaults, [`FilterConfig::default`]).
    pub filter: FilterConfig,
    /// The likelihood field of the floor plan.
    pub field: LikelihoodFieldConfig,
    /// Floor plan resolution, metres per cell.
    pub resolution_m: f64,
    /// Known start: the filter starts at the true pose plus an error drawn with this
    /// standard deviation per axis, metres, and is told this spread.
    pub start_sigma_m: f64,
    /// ... and this heading standard deviation, degrees.
    pub start_sigma_heading_deg: f64,
    /// Start from nothing instead (the filter's `global_particles` over the start
    /// floor's free space, any heading): as the agent does when no start is given.
    pub global_start: bool,
    /// Feed the body-worn gyro's yaw rate ([`BodyGyro`]) to the motion model (it then
    /// replaces the odometry's heading change).
    pub imu: bool,
    /// What of the scans the filter is corrected with.
    pub scans: ScanUse,
    /// The walk ends this close to the route's last point on the start floor, metres
    /// (the goal, or the foot of the stairs in `building`: the user takes no stairs).
    pub end_radius_m: f64,
    /// ... or when the user has moved less than 0.2 m in this many seconds (stuck).
    pub stuck_s: f64,
    /// The door-sign reader, `None` for no door numbers.
    pub signs: Option<SignReaderConfig>,
    /// The map the filter localizes on (the floor plan unless told otherwise).
    pub map: LocalizationMap,
    /// The first sign read after this many metres of walking is misread (another
    /// door's number): the injected misread.
    pub misread_after_m: Option<f64>,
    /// The wall-angle correction: at each update the direction of the longest straight
    /// wall in the frame's scan ([`localization::walls`]) against the map's wall
    /// directions; `None` leaves it out. Walls are looked for either way (the frames
    /// report how well they match the map at the true heading).
    pub wall_angles: Option<WallFitConfig>,
    /// The corner correction: at each update the corners where two of the scan's walls
    /// meet ([`localization::corners`]), matched against the corners of the map's
    /// outline; `None` leaves it out. Corners are looked for either way (the frames
    /// report how far they lie from the map's at the true pose).
    pub corners: Option<CornerConfig>,
}

impl Default for LocalizeWalkConfig {
    /// The study's default walk kept on the world's route, 120 s at most; AMCL's filter
    /// with a person's recovery (near where the user can be:
    /// [`FilterConfig::recovery_anchor`]) and walls
    /// ([`FilterConfig::wall_crossing_log_p`]); a 0.1 m / 2° known start; the gyro on;
    /// the door-sign reader's defaults; no wall-angle correction (docs/localization.md,
    /// "The wall angle").
    fn default() -> Self {
        Self {
            walk: WalkConfig { guide: GuideKind::Route, timeout_s: 120.0, ..WalkConfig::default() },
            filter: FilterConfig {
                recovery_anchor: Some(RecoveryAnchor::default()),
                wall_crossing_log_p: Some(WALL_CROSSING_LOG_P),
                ..FilterConfig::default()
            },
            field: LikelihoodFieldConfig::default(),
            resolution_m: floor_plan::DEFAULT_RESOLUTION_M,
            start_sigma_m: 0.1,
            start_sigma_heading_deg: 2.0,
            global_start: false,
            imu: true,
            scans: ScanUse::Frame,
            map: LocalizationMap::FloorPlan,
            end_radius_m: 0.5,
            stuck_s: 10.0,
            signs: Some(SignReaderConfig::default()),
            misread_after_m: None,
            wall_angles: None,
            corners: None,
        }
    }
}

/// What of the cane camera's scans corrects the filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum ScanUse {
    /// None: odometry and gyro alone (dead reckoning, the baseline).
    None,
    /// The frame's own scan at each update (AMCL's way: one scan per update, the
    /// frames between updates unused). The camera sees ~58° of a sweeping cane.
    Frame,
    /// Every frame's scan since the previous update, moved into the body frame of
    /// this one by the odometry between them: the sweep's frames together see ~120°.
    Sweep,
}

/// Why a walk could not be localized.
#[derive(Debug, thiserror::Error)]
pub enum LocalizeWalkError {
    /// The world's floor plan could not be made.
    #[error("the floor plan: {0}")]
    FloorPlan(#[from] FloorPlanError),
    /// The filter refused its map or its start.
    #[error("the filter: {0}")]
    Filter(#[from] LocalizationError),
    /// The start floor is not in the floor plan.
    #[error("world `{world}`: floor {level} of the start is not in its floor plan")]
    NoStartFloor {
        /// world name
        world: String,
        /// the start's floor
        level: i32,
    },
    /// The walk gave no camera frame.
    #[error("world `{0}`: the walk gave no camera frame")]
    NoFrames(String),
}

/// One camera frame of the walk and the filter's answer to it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrameLocalization {
    /// Seconds into the walk.
    pub t_s: f64,
    /// Metres walked so far (truth).
    pub walked_m: f64,
    /// Door signs read at this frame, as read (a misread number is shown as read).
    pub doors_read: Vec<String>,
    /// One of them was misread.
    pub misread: bool,
    /// The simulator's truth: x, y (metres), heading (degrees).
    pub truth: [f64; 3],
    /// The filter's estimate: x, y (metres), heading (degrees).
    pub estimate: [f64; 3],
    /// Distance between them, metres.
    pub position_error_m: f64,
    /// Heading error, degrees (absolute).
    pub heading_error_deg: f64,
    /// Position error along the true heading, metres (positive: the estimate ahead).
    pub along_error_m: f64,
    /// Position error across the true heading, metres (positive: to the left).
    pub across_error_m: f64,
    /// The filter's status.
    pub status: Status,
    /// Guidance may take the estimate ([`localization::Estimate::guides`]: `Tracking`
    /// or followed from a known place, and not a search's place unconfirmed).
    pub guides: bool,
    /// The filter corrected with this frame's scan (AMCL updates after 0.25 m or 0.2 rad).
    pub updated: bool,
    /// Usable beams in the scan (a hit short of the range limit).
    pub beams: usize,
    /// Median distance of the scan's end points, placed at the true pose, from the
    /// floor plan's nearest wall, metres (what the scan would fit if the filter were
    /// right: clutter and people that are not on the plan make it larger). NaN
    /// without beams.
    pub truth_fit_m: f64,
    /// Prediction and correction, milliseconds, by the caller's clock.
    pub update_ms: f64,
    /// The longest straight wall in the scan (with the walk's wall fit, or the
    /// default one): how far its direction at the true heading is from the nearest of
    /// the map's wall directions, degrees; `None` when the scan has no wall.
    pub wall_residual_deg: Option<f64>,
    /// The filter was given that wall's angle at this frame.
    pub wall_used: bool,
    /// Corners where two of the scan's walls meet: how far each, placed at the true
    /// pose, lies from the map's nearest corner, metres.
    pub corner_residuals_m: Vec<f64>,
    /// The filter was given those corners at this frame.
    pub corners_used: bool,
    /// Rays along which the frame saw the floor free (tested ones, as the free-space
    /// weighing picks them), and how many of them, laid from the true pose, pass
    /// through an occupied cell of the map (a map marking what overhangs the floor).
    pub free_rays: [usize; 2],
}

/// The figures of a localized walk.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LocalizeSummary {
    /// Camera frames.
    pub frames: usize,
    /// Filter updates (corrections with a scan).
    pub updates: u64,
    /// Seconds walked.
    pub duration_s: f64,
    /// Metres walked (truth).
    pub walked_m: f64,
    /// Position error: root mean square, median, 95th percentile, largest, metres.
    pub position_rmse_m: f64,
    /// Median position error, metres.
    pub position_median_m: f64,
    /// 95th percentile of the position error, metres.
    pub position_p95_m: f64,
    /// Largest position error, metres.
    pub position_max_m: f64,
    /// Heading error, root mean square, degrees.
    pub heading_rmse_deg: f64,
    /// Position error along the true heading, root mean square, metres.
    pub along_rmse_m: f64,
    /// Position error across the true heading, root mean square, metres.
    pub across_rmse_m: f64,
    /// Share of frames with status `Tracking`.
    pub tracking_fraction: f64,
    /// Frames with status `Tracking` while more than 1 m off.
    pub tracking_over_1m: usize,
    /// Frames guidance may take ([`FrameLocalization::guides`]), as a share.
    pub guiding_fraction: f64,
    /// Frames guidance may take while more than 1 m off.
    pub guiding_over_1m: usize,
    /// Median share of a frame's beams that are usable.
    pub beams_median: f64,
    /// Median of [`FrameLocalization::truth_fit_m`] over frames with beams, metres.
    pub truth_fit_median_m: f64,
    /// Frames whose scan had a straight wall.
    pub walls_found: usize,
    /// Of them, how far the wall's direction at the true heading is from the map's,
    /// degrees: median and 90th percentile (NaN without walls).
    pub wall_residual_median_deg: f64,
    /// See `wall_residual_median_deg`.
    pub wall_residual_p90_deg: f64,
    /// Wall angles the filter was given (at updates, with the correction on).
    pub wall_angles_used: usize,
    /// Corners seen in the frames' scans (two walls meeting).
    pub corners_found: usize,
    /// Of them, the share within 0.3 m of a corner of the map at the true pose, and the
    /// median distance of those (NaN without corners).
    pub corners_on_map_fraction: f64,
    /// See `corners_on_map_fraction`, metres.
    pub corner_residual_median_m: f64,
    /// Corners the filter was given (at updates, with the correction on).
    pub corners_used: usize,
    /// Free rays (the floor seen free along a bin) over the frames, as the free-space
    /// weighing picks them; weighed only with `FilterConfig::free_space`.
    pub free_rays: usize,
    /// Of them, the share that pass through a wall of the map at the true pose (0 on a
    /// map that agrees with the floor the camera sees; NaN without rays).
    pub free_rays_through_walls_fraction: f64,
    /// Median time of an update (frames that corrected), milliseconds.
    pub update_ms_median: f64,
    /// Odometry increments or gyro rates the filter refused.
    pub odometry_rejected: u64,
    /// Particles the recovery drew (near where the user can be, or anywhere:
    /// `FilterConfig::recovery_anchor`).
    pub particles_injected: u64,
    /// `Tracking` estimates out of the reach of where the user can be, refused as
    /// look-alikes (`FilterConfig::recovery_anchor`).
    pub look_alikes: u64,
    /// Particles whose motion passed through a wall of the map, weighed out
    /// (`FilterConfig::wall_crossing_log_p`).
    pub wall_crossings: u64,
    /// Beams left out as something the map does not have
    /// (`FilterConfig::unmapped_gate_m`; 0 with the gate off).
    pub beams_unmapped: u64,
    /// Door signs read, and how many of them misread.
    pub doors_read: usize,
    /// Misread door signs.
    pub doors_misread: usize,
    /// Landmarks the filter refused (a number not on its map).
    pub landmarks_rejected: u64,
    /// The largest error in the 5 m walked after a misread, metres (`None`: no misread).
    pub misread_worst_m: Option<f64>,
    /// Metres walked after a misread until the error was back within 0.5 m, if it left
    /// that bound within 5 m of the misread (0: it did not; the largest over the
    /// misreads; `None`: no misread, or not back by the walk's end).
    pub misread_back_within_m: Option<f64>,
    /// Replayed frames whose hazard differed from the walk's (0: the replay is exact).
    pub replay_mismatches: usize,
}

/// A localized walk: every frame and the figures.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WalkLocalization {
    /// World name.
    pub world: String,
    /// Seed of the walk and the filter.
    pub seed: u64,
    /// The figures.
    pub summary: LocalizeSummary,
    /// The filter weighed free space (`FilterConfig::free_space`).
    pub free_space: bool,
    /// Every camera frame.
    pub frames: Vec<FrameLocalization>,
}

impl WalkLocalization {
    /// The figures in one line per group, for a terminal.
    pub fn summary_text(&self) -> String {
        let s = &self.summary;
        format!(
            "world {} seed {}: {} frames, {:.1} s, {:.1} m walked, {} updates\n\
             position RMSE {:.3} m (along {:.3}, across {:.3}), median {:.3} m, p95 {:.3} m, max {:.3} m; heading RMSE {:.2}°\n\
             tracking {:.1} % of frames ({} while > 1 m off), guidance may take {:.1} % ({} while > 1 m off); {} particles drawn by the recovery, {} look-alikes refused, {} particles through a wall weighed out; update median {:.3} ms\n\
             door signs: {} read, {} misread, {} refused by the filter{}\n\
             scan: {:.0} usable beams per frame (median), {:.3} m median distance to the plan's walls at the true pose{}\n\
             walls: {} frames with a straight wall, {:.1}° median off the map's directions at the true heading (p90 {:.1}°), {} given to the filter\n\
             corners: {} seen (two walls meeting), {:.0} % within 0.3 m of the map's at the true pose ({:.2} m median), given to the filter at {} frames\n\
             free space: {} rays of floor seen free, {:.1} % through a wall of the map at the true pose, {}\n",
            self.world,
            self.seed,
            s.frames,
            s.duration_s,
            s.walked_m,
            s.updates,
            s.position_rmse_m,
            s.along_rmse_m,
            s.across_rmse_m,
            s.position_median_m,
            s.position_p95_m,
            s.position_max_m,
            s.heading_rmse_deg,
            100.0 * s.tracking_fraction,
            s.tracking_over_1m,
            100.0 * s.guiding_fraction,
            s.guiding_over_1m,
            s.particles_injected,
            s.look_alikes,
            s.wall_crossings,
            s.update_ms_median,
            s.doors_read,
            s.doors_misread,
            s.landmarks_rejected,
            match (s.misread_worst_m, s.misread_back_within_m) {
                (Some(w), Some(0.0)) => format!("; after a misread: worst error {w:.2} m within 5 m (within 0.5 m throughout)"),
                (Some(w), Some(b)) => format!("; after a misread: worst error {w:.2} m within 5 m, back within 0.5 m after {b:.1} m"),
                (Some(w), None) => format!("; after a misread: worst error {w:.2} m within 5 m, NOT back within 0.5 m by the end"),
                _ => String::new(),
            },
            s.beams_median,
            s.truth_fit_median_m,
            if s.beams_unmapped > 0 {
                format!("; {} beams left out as not on the map", s.beams_unmapped)
            } else {
                String::new()
            },
            s.walls_found,
            s.wall_residual_median_deg,
            s.wall_residual_p90_deg,
            s.wall_angles_used,
            s.corners_found,
            100.0 * s.corners_on_map_fraction,
            s.corner_residual_median_m,
            s.corners_used,
            s.free_rays,
            100.0 * s.free_rays_through_walls_fraction,
            if self.free_space { "weighed by the filter" } else { "not weighed" },
        )
    }
}

/// Walks `world` with `seed` and localizes the walk (see the module doc); `clock_ms`
/// times each update (e.g. `Instant` elapsed in ms; a constant gives 0).
pub fn localize_walk(
    world: &World,
    seed: u64,
    config: &LocalizeWalkConfig,
    clock_ms: impl FnMut() -> f64,
) -> Result<WalkLocalization, LocalizeWalkError> {
    PerceivedWalk::new(world, seed, config).localize(config, clock_ms)
}

/// One walk, run and perceived once, to be localized with one filter configuration or
/// several (the walk does not depend on the filter: the same seed gives the same walk,
/// frames and scans whatever the filter is told).
pub struct PerceivedWalk<'w> {
    world: &'w World,
    seed: u64,
    /// What it was walked with ([`LocalizeWalkConfig::walk`], `end_radius_m`, `stuck_s`).
    walk: WalkConfig,
    end_radius_m: f64,
    stuck_s: f64,
    trace: Vec<TraceRow>,
    scans: Vec<Option<CaneScan>>,
    odometry: Vec<Vec<schemas::OdomIncrement>>,
    replay_mismatches: usize,
}

impl<'w> PerceivedWalk<'w> {
    /// Walks `world` with `seed` as `config` says (its walk, end radius and stuck time)
    /// and perceives every frame.
    pub fn new(world: &'w World, seed: u64, config: &LocalizeWalkConfig) -> Self {
        let (trace, scans, odometry, replay_mismatches) = walk_and_perceive(world, seed, config);
        let (walk, end_radius_m, stuck_s) = (config.walk.clone(), config.end_radius_m, config.stuck_s);
        Self { world, seed, walk, end_radius_m, stuck_s, trace, scans, odometry, replay_mismatches }
    }

    /// Localizes the walk with `config`'s filter, map, scans, signs and corrections;
    /// the walk, end radius and stuck time are the walk's own, not `config`'s.
    pub fn localize(
        &self,
        config: &LocalizeWalkConfig,
        clock_ms: impl FnMut() -> f64,
    ) -> Result<WalkLocalization, LocalizeWalkError> {
        let config = &LocalizeWalkConfig {
            walk: self.walk.clone(),
            end_radius_m: self.end_radius_m,
            stuck_s: self.stuck_s,
            ..config.clone()
        };
        localize_perceived(self, config, clock_ms)
    }
}

fn localize_perceived(
    walk: &PerceivedWalk<'_>,
    config: &LocalizeWalkConfig,
    mut clock_ms: impl FnMut() -> f64,
) -> Result<WalkLocalization, LocalizeWalkError> {
    let (world, seed) = (walk.world, walk.seed);
    let level = world.start().floor;
    let building = config.map.export(world, config.resolution_m, &config.walk.perception)?;
    let floor = building
        .floor(level)
        .ok_or_else(|| LocalizeWalkError::NoStartFloor { world: world.name().to_string(), level })?;
    let model = FloorModel::new(level, &floor.grid, &floor.semantic, &config.field)?;
    let wall_directions = model.wall_directions_rad().to_vec();
    let wall_fit = config.wall_angles.unwrap_or_default();
    let walls = map::DistanceField::to_occupied(&floor.grid);
    let map_corners = model.corner_field().clone();
    let corner_fit = config.corners.unwrap_or_default();
    let free_fit = config.filter.free_space.unwrap_or_default();
    let (mut free_points, mut free_ray_ends) = (Vec::new(), Vec::new());

    let (trace, scans, odometry, replay_mismatches) =
        (&walk.trace, &walk.scans, &walk.odometry, walk.replay_mismatches);
    if trace.is_empty() || trace.len() != scans.len() {
        return Err(LocalizeWalkError::NoFrames(world.name().to_string()));
    }

    let mut pf = ParticleFilter::new(vec![model], config.filter.clone(), seed)?;
    let mut rng = SimRng::seed_from(seed ^ 0x10ca_112e);
    let mut gyro = config.imu.then(|| BodyGyro::new(rng.fork()));
    let first = truth_of(&trace[0]);
    let sigma_heading = config.start_sigma_heading_deg.to_radians();
    let start = Pose2::new(
        first.x_m + rng.gaussian() * config.start_sigma_m,
        first.y_m + rng.gaussian() * config.start_sigma_m,
        first.heading_rad + rng.gaussian() * sigma_heading,
    );
    // drawn either way, so that the streams forked after it are the same
    if config.global_start {
        pf.init_global();
    } else {
        pf.init_pose(level, start, config.start_sigma_m.max(0.01), sigma_heading.max(0.2f64.to_radians()))?;
    }

    let mut reader = config.signs.map(|c| DoorSignReader::new(c, world, rng.fork()));
    let mut misread_pending = config.misread_after_m;
    let mount = config.walk.mount;
    let mut frames = Vec::with_capacity(trace.len());
    let mut walked_m = 0.0;
    let mut ends = Vec::new();
    // with `ScanUse::Sweep`: the end points of the frames since the last update, in the
    // body frame at the last update, and the body's pose there by odometry
    let mut swept: Vec<[f64; 2]> = Vec::new();
    let mut since_update = Pose2::default();
    let mut merged = Scan::default();
    for (k, row) in trace.iter().enumerate() {
        let truth = truth_of(row);
        let sweep_rad = row.sweep_deg.to_radians();
        let scan = body_scan(&scans[k], &mount, sweep_rad, level);
        scan.endpoints_into(usize::MAX, &mut ends);
        let rate = gyro.as_mut().and_then(|g| {
            g.read(row.t_s, truth.heading_rad, row.speed_m_s / config.walk.user.walk_speed_m_s.max(1e-6))
        });
        let t0 = clock_ms();
        if k > 0 {
            let prev = &trace[k - 1];
            walked_m += (row.x_m - prev.x_m).hypot(row.y_m - prev.y_m);
            let inc = body_increment(&odometry[k], &mount, prev.sweep_deg.to_radians(), sweep_rad, level);
            let inc = OdometryIncrement { dt_s: row.t_s - prev.t_s, ..inc };
            // a refusal is counted by the filter and shows in the summary
            if pf.predict(&inc, rate.map(f64::from)).is_ok() {
                since_update = since_update.compose(inc.forward_m, inc.left_m, inc.yaw_rad);
            }
        }
        let (s0, c0) = since_update.heading_rad.sin_cos();
        swept.extend(
            ends.iter().map(|&[x, y]| [since_update.x_m + c0 * x - s0 * y, since_update.y_m + s0 * x + c0 * y]),
        );
        let observed = match config.scans {
            ScanUse::None => None,
            ScanUse::Frame => Some(&scan),
            ScanUse::Sweep => {
                if pf.update_due() {
                    merge_into(&swept, &since_update, &mut merged);
                }
                Some(&merged)
            }
        };
        let readings = match reader.as_mut() {
            Some(r) => {
                if misread_pending.is_some_and(|m| walked_m >= m) {
                    r.misread_next();
                    misread_pending = None;
                }
                let body = UserPose { x_m: truth.x_m, y_m: truth.y_m, yaw_rad: truth.heading_rad, floor: level };
                r.read(world, &body, row.t_s)
            }
            None => Vec::new(),
        };
        let landmarks: Vec<Landmark> = readings
            .iter()
            .map(|r| Landmark::Door { number: r.number.clone(), forward_m: r.forward_m, left_m: r.left_m })
            .collect();
        let segments = wall_segments(&scan, &wall_fit);
        let wall = segments.first().map(|w| WallAngle { angle_rad: w.angle_rad });
        let seen_corners = corners_of_walls(&segments, &corner_fit);
        let corners_used =
            config.corners.is_some() && observed.is_some() && pf.update_due() && !seen_corners.is_empty();
        let mut landmarks = landmarks;
        if corners_used {
            landmarks.extend(seen_corners.iter().map(|&[forward_m, left_m]| Landmark::Corner { forward_m, left_m }));
        }
        // one wall angle per update: the filter takes wall angles only when it updates
        let wall_used = config.wall_angles.is_some() && observed.is_some() && pf.update_due() && wall.is_some();
        let wall_angles: Vec<WallAngle> = wall.filter(|_| wall_used).into_iter().collect();
        let c = pf.correct(&Observations {
            scan: observed,
            landmarks: &landmarks,
            wall_angles: &wall_angles,
            compass: None,
        });
        if c.updated || config.scans != ScanUse::Sweep {
            swept.clear();
            since_update = Pose2::default();
        }
        let update_ms = clock_ms() - t0;
        let e = pf.estimate();
        let beams = ends.len();
        let (st, ct) = truth.heading_rad.sin_cos();
        let truth_fit_m = {
            let d: Vec<f64> = ends
                .iter()
                .map(|&[x, y]| {
                    floor
                        .grid
                        .world_to_cell(truth.x_m + ct * x - st * y, truth.y_m + st * x + ct * y)
                        .and_then(|(col, row)| walls.get(col, row))
                        .map_or(f64::INFINITY, f64::from)
                })
                .collect();
            quantile(&d, 0.5)
        };
        // the floor seen free along each ray, laid from the true pose: how much of it
        // the map puts a wall on (a map that marks what overhangs the floor does)
        let free_rays_through_walls = {
            scan.free_points_into(&free_fit, &mut free_points, &mut free_ray_ends);
            let field = pf.floors()[0].field();
            let mut start = 0;
            let mut through = 0;
            for &end in &free_ray_ends {
                through += usize::from(free_points[start..end].iter().any(|&[x, y]| {
                    field.distance_m(truth.x_m + ct * x - st * y, truth.y_m + st * x + ct * y)
                        < floor.grid.resolution_m()
                }));
                start = end;
            }
            [free_ray_ends.len(), through]
        };
        let (dx, dy) = (e.pose.x_m - truth.x_m, e.pose.y_m - truth.y_m);
        frames.push(FrameLocalization {
            t_s: row.t_s,
            walked_m,
            doors_read: readings.iter().map(|r| r.number.clone()).collect(),
            misread: readings.iter().any(|r| r.misread),
            truth: [truth.x_m, truth.y_m, truth.heading_rad.to_degrees()],
            estimate: [e.pose.x_m, e.pose.y_m, e.pose.heading_rad.to_degrees()],
            position_error_m: e.pose.distance_m(&truth),
            heading_error_deg: wrap_angle(e.pose.heading_rad - truth.heading_rad).abs().to_degrees(),
            along_error_m: ct * dx + st * dy,
            across_error_m: -st * dx + ct * dy,
            status: e.status,
            guides: e.guides(),
            updated: c.updated,
            beams,
            truth_fit_m,
            update_ms,
            wall_residual_deg: wall.map(|w| {
                localization::landmarks::wall_residual(truth.heading_rad + w.angle_rad, &wall_directions).to_degrees()
            }),
            wall_used,
            corner_residuals_m: seen_corners
                .iter()
                .map(|&[f, l]| map_corners.distance_m(truth.x_m + ct * f - st * l, truth.y_m + st * f + ct * l))
                .collect(),
            corners_used,
            free_rays: free_rays_through_walls,
        });
    }
    let summary = summarize(&frames, walked_m, pf.counters(), replay_mismatches);
    let free_space = config.filter.free_space.is_some();
    Ok(WalkLocalization { world: world.name().to_string(), seed, summary, free_space, frames })
}

/// End points gathered in the body frame of the last update, as a scan from the body
/// frame of now (`now`: where the body is, by odometry, in that frame).
fn merge_into(points: &[[f64; 2]], now: &Pose2, out: &mut Scan) {
    let (s, c) = now.heading_rad.sin_cos();
    out.beams.clear();
    out.beams.extend(points.iter().map(|&[x, y]| {
        let (dx, dy) = (x - now.x_m, y - now.y_m);
        let (fx, fy) = (c * dx + s * dy, -s * dx + c * dy);
        Beam { angle_rad: fy.atan2(fx), range_m: fx.hypot(fy) }
    }));
    // every point is a hit: nothing is at the range limit
    out.max_range_m = f64::INFINITY;
    (out.sensor_forward_m, out.sensor_left_m, out.sensor_yaw_rad) = (0.0, 0.0, 0.0);
}

/// The truth pose of a trace row.
fn truth_of(row: &TraceRow) -> Pose2 {
    Pose2::new(row.x_m, row.y_m, row.yaw_deg.to_radians())
}

/// The camera's floor frame in the body frame with the cane swept by `sweep_rad`.
fn camera_on_body(mount: &CaneMount, sweep_rad: f64, level: i32) -> Pose2 {
    let camera = mount.camera_pose(&UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: level }, sweep_rad);
    Pose2::new(camera.position_m.x, camera.position_m.y, camera.yaw_rad())
}

/// The perception's scan (camera floor frame, 1-degree bins) as a body-frame scan.
fn body_scan(scan: &Option<CaneScan>, mount: &CaneMount, sweep_rad: f64, level: i32) -> Scan {
    let on_body = camera_on_body(mount, sweep_rad, level);
    let bearing =
        |s: &schemas::Scan, i: usize| f64::from(s.angle_min_deg + i as f32 * s.angle_increment_deg).to_radians();
    let (beams, free, max_range_m) = match scan {
        Some(CaneScan { scan: s, floor_seen_m }) => (
            (0..s.ranges_m.len())
                .map(|i| Beam { angle_rad: bearing(s, i), range_m: f64::from(s.ranges_m[i]) })
                .collect(),
            floor_seen_m
                .iter()
                .enumerate()
                .map(|(i, &r)| Beam { angle_rad: bearing(s, i), range_m: f64::from(r) })
                .collect(),
            f64::from(s.range_max_m),
        ),
        // a refused frame: an empty scan, nothing to weigh
        None => (Vec::new(), Vec::new(), 1.0),
    };
    Scan {
        beams,
        free,
        max_range_m,
        sensor_forward_m: on_body.x_m,
        sensor_left_m: on_body.y_m,
        sensor_yaw_rad: on_body.heading_rad,
    }
}

/// The body's motion between two frames from the camera floor frame's odometry over the
/// same interval and the sweep at both ends: body1 = body0 * cam0 * odometry * cam1^-1.
fn body_increment(
    odometry: &[schemas::OdomIncrement],
    mount: &CaneMount,
    sweep0_rad: f64,
    sweep1_rad: f64,
    level: i32,
) -> OdometryIncrement {
    let cam0 = camera_on_body(mount, sweep0_rad, level);
    let cam1 = camera_on_body(mount, sweep1_rad, level);
    let camera_then =
        odometry.iter().fold(cam0, |p, o| p.compose(f64::from(o.forward_m), f64::from(o.left_m), f64::from(o.yaw_rad)));
    // undo the camera's place on the body at the end
    let (s, c) = cam1.heading_rad.sin_cos();
    let back = (-(c * cam1.x_m + s * cam1.y_m), s * cam1.x_m - c * cam1.y_m, -cam1.heading_rad);
    let body1 = camera_then.compose(back.0, back.1, back.2);
    let (forward_m, left_m, yaw_rad) = Pose2::default().between(&body1);
    OdometryIncrement { forward_m, left_m, yaw_rad, dt_s: 0.0 }
}

/// Camera frames of one walk: the trace row (truth, sweep), the perception's scan
/// (`None` when the frame was refused) and the odometry since the previous frame; and
/// how many replayed hazards differed from the walk's.
/// A frame's scan and how far its bins saw the floor free.
struct CaneScan {
    scan: schemas::Scan,
    floor_seen_m: Vec<f32>,
}

type Perceived = (Vec<TraceRow>, Vec<Option<CaneScan>>, Vec<Vec<schemas::OdomIncrement>>, usize);

/// Runs the walk (to the goal, the route's last point on the start floor, stuck, or the
/// time limit) and replays its frames through a fresh frame step for the scans.
fn walk_and_perceive(world: &World, seed: u64, config: &LocalizeWalkConfig) -> Perceived {
    let walk_config = WalkConfig { trace: true, ..config.walk.clone() };
    let start = world.start();
    let end = world
        .walker()
        .and_then(|w| w.waypoints.last().copied())
        .filter(|_| world.goal().floor != start.floor)
        .unwrap_or([world.goal().x_m, world.goal().y_m]);
    let mut w = Walk::new(world, &walk_config, seed);
    w.record_frames();
    let dt = 1.0 / crate::walk::PHYSICS_HZ as f64;
    let stuck_steps = (config.stuck_s / dt).ceil() as usize;
    let mut recent: std::collections::VecDeque<[f64; 2]> = std::collections::VecDeque::new();
    while w.step() {
        let p = w.pose();
        if p.floor != start.floor || (p.x_m - end[0]).hypot(p.y_m - end[1]) <= config.end_radius_m {
            break;
        }
        recent.push_back([p.x_m, p.y_m]);
        if recent.len() > stuck_steps {
            recent.pop_front();
            let a = recent[0];
            if recent.iter().all(|q| (q[0] - a[0]).hypot(q[1] - a[1]) < 0.2) {
                break;
            }
        }
    }
    // the replay also measures the floor seen free (free space); the hazards stay the walk's
    let mut perception = walk_config.perception.clone();
    perception.scan.floor_seen = true;
    let mut step = ComputeStep::new(perception, walk_config.cue.clone());
    let fed: &[FedFrame] = w.fed_frames();
    let mut scans = Vec::with_capacity(fed.len());
    let mut odometry = Vec::with_capacity(fed.len());
    let mut mismatches = 0;
    for f in fed {
        for inc in &f.odometry {
            // the walk fed these same increments; a refusal there is a refusal here
            let _ = step.add_odometry(inc);
        }
        let input = FrameIn {
            data: FrameData::Wire(&f.frame),
            seq: f.seq,
            capture_ns: f.capture_ns,
            body_yaw_rate_rad_s: None,
            way: None,
        };
        let (scan, hazard) = match step.process(input, &mut NoTimer) {
            StepOutput::Perceived { perception, hazard, .. } => {
                let Perception { scan, floor_seen_m, .. } = perception;
                (Some(CaneScan { scan, floor_seen_m }), Some(hazard))
            }
            StepOutput::Refused { .. } => (None, None),
        };
        mismatches += usize::from(hazard != f.hazard);
        scans.push(scan);
        odometry.push(f.odometry.clone());
    }
    let trace = w.finish().trace;
    (trace, scans, odometry, mismatches)
}

fn summarize(
    frames: &[FrameLocalization],
    walked_m: f64,
    counters: &localization::Counters,
    replay_mismatches: usize,
) -> LocalizeSummary {
    let pos: Vec<f64> = frames.iter().map(|f| f.position_error_m).collect();
    let along: Vec<f64> = frames.iter().map(|f| f.along_error_m).collect();
    let across: Vec<f64> = frames.iter().map(|f| f.across_error_m).collect();
    let head: Vec<f64> = frames.iter().map(|f| f.heading_error_deg).collect();
    let beams: Vec<f64> = frames.iter().map(|f| f.beams as f64).collect();
    let fit: Vec<f64> = frames.iter().map(|f| f.truth_fit_m).filter(|d| d.is_finite()).collect();
    let updates: Vec<f64> = frames.iter().filter(|f| f.updated).map(|f| f.update_ms).collect();
    let tracking = frames.iter().filter(|f| f.status == Status::Tracking).count();
    let walls: Vec<f64> = frames.iter().filter_map(|f| f.wall_residual_deg).collect();
    let corners: Vec<f64> = frames.iter().flat_map(|f| f.corner_residuals_m.iter().copied()).collect();
    let on_map: Vec<f64> = corners.iter().copied().filter(|&d| d <= 0.3).collect();
    let free_rays = frames.iter().map(|f| f.free_rays[0]).sum::<usize>();
    LocalizeSummary {
        frames: frames.len(),
        updates: counters.updates,
        duration_s: frames.last().map_or(0.0, |f| f.t_s) - frames.first().map_or(0.0, |f| f.t_s),
        walked_m,
        position_rmse_m: rmse(&pos),
        position_median_m: quantile(&pos, 0.5),
        position_p95_m: quantile(&pos, 0.95),
        position_max_m: pos.iter().copied().fold(0.0, f64::max),
        heading_rmse_deg: rmse(&head),
        along_rmse_m: rmse(&along),
        across_rmse_m: rmse(&across),
        tracking_fraction: tracking as f64 / frames.len().max(1) as f64,
        tracking_over_1m: frames.iter().filter(|f| f.status == Status::Tracking && f.position_error_m > 1.0).count(),
        guiding_fraction: frames.iter().filter(|f| f.guides).count() as f64 / frames.len().max(1) as f64,
        guiding_over_1m: frames.iter().filter(|f| f.guides && f.position_error_m > 1.0).count(),
        beams_median: quantile(&beams, 0.5),
        truth_fit_median_m: quantile(&fit, 0.5),
        walls_found: walls.len(),
        wall_residual_median_deg: quantile(&walls, 0.5),
        wall_residual_p90_deg: quantile(&walls, 0.9),
        wall_angles_used: frames.iter().filter(|f| f.wall_used).count(),
        corners_found: corners.len(),
        corners_on_map_fraction: if corners.is_empty() { f64::NAN } else { on_map.len() as f64 / corners.len() as f64 },
        corner_residual_median_m: quantile(&on_map, 0.5),
        corners_used: frames.iter().filter(|f| f.corners_used).count(),
        free_rays,
        free_rays_through_walls_fraction: if free_rays == 0 {
            f64::NAN
        } else {
            frames.iter().map(|f| f.free_rays[1]).sum::<usize>() as f64 / free_rays as f64
        },
        update_ms_median: quantile(&updates, 0.5),
        odometry_rejected: counters.odometry_rejected,
        particles_injected: counters.particles_injected,
        look_alikes: counters.look_alikes,
        wall_crossings: counters.wall_crossings,
        beams_unmapped: counters.beams_unmapped,
        doors_read: frames.iter().map(|f| f.doors_read.len()).sum(),
        doors_misread: frames.iter().filter(|f| f.misread).count(),
        landmarks_rejected: counters.landmarks_rejected,
        misread_worst_m: misread_worst(frames, 5.0),
        misread_back_within_m: misread_back_within(frames, 0.5, 5.0),
        replay_mismatches,
    }
}

/// The largest position error within `window_m` of walking after each misread.
fn misread_worst(frames: &[FrameLocalization], window_m: f64) -> Option<f64> {
    let starts: Vec<usize> = (0..frames.len()).filter(|&k| frames[k].misread).collect();
    starts
        .iter()
        .map(|&k| {
            frames[k..]
                .iter()
                .take_while(|f| f.walked_m - frames[k].walked_m <= window_m)
                .map(|f| f.position_error_m)
                .fold(0.0, f64::max)
        })
        .reduce(f64::max)
}

/// Metres walked after each misread until the error is back within `bound_m`, when it
/// left that bound within `window_m` of the misread (0: it did not); the largest over
/// the misreads. `None` when there was no misread, or the error had not come back by
/// the walk's end.
fn misread_back_within(frames: &[FrameLocalization], bound_m: f64, window_m: f64) -> Option<f64> {
    let starts: Vec<usize> = (0..frames.len()).filter(|&k| frames[k].misread).collect();
    let mut worst: Option<f64> = None;
    for &k in &starts {
        let w0 = frames[k].walked_m;
        let left =
            frames[k..].iter().take_while(|f| f.walked_m - w0 <= window_m).position(|f| f.position_error_m > bound_m);
        let back = match left {
            None => 0.0,
            Some(j) => frames[k + j..].iter().find(|f| f.position_error_m <= bound_m)?.walked_m - w0,
        };
        worst = Some(worst.map_or(back, |w: f64| w.max(back)));
    }
    worst
}
