//! Obstacle perception: Taylor 2017 (BYU thesis, augmented white cane, ch. 2) and beyond.
//!
//! One depth frame from the cane camera becomes a nearest-point scan in the user frame,
//! Taylor's two cost functions and his 4-state rumble (none / left / right / both), plus
//! what the thesis lacked: memory of obstacles that left the view, drop-offs, time to
//! collision and a debounced rumble. One module per stage:
//!
//! | stage | module | thesis |
//! | --- | --- | --- |
//! | strided sample of the organized image | [`organized_cloud`] | 1 cm voxel grid |
//! | ground plane (RANSAC in a cone, least squares, false-ground guard) | [`ground_plane`] | sec. 2.2 |
//! | ground predicted from gravity while a near wall hides the floor | [`ground_prediction`] | beyond |
//! | ground removal, above-head removal, user frame, 1-degree scan | [`nearest_scan`] | sec. 2.2-2.3 |
//! | FICF / CACF costs and Table 2.1 | [`cost_function`] | sec. 2.4 |
//! | drop-offs, memory, TTC, debounce | [`dropoff`], [`obstacle_memory`], [`time_to_collision`], [`hysteresis`] | beyond |
//! | haptic intent | [`cue()`] | Table 2.1 + ISANA's beep rate |
//!
//! Around the pipeline: [`frame_step`], the compute agent's whole step on a frame as
//! the wire carries it (decode, [`odometry`] held until its frame, perceive, cue, the
//! blind state), which the agent, `wearnav perceive` and the study share; and
//! [`body_rate`], the body's turn rate from a body-worn IMU.
//!
//! Pure library (its own crate, so nothing else can creep in): no clock is read and no bus touched ([`InstantTimer`] is the shell's
//! tool, passed in). [`Pipeline`] owns every buffer and is reused frame after frame.
//! Bad input is an `Err` ([`PerceptionError::kind`] names a counter); a frame with no
//! ground is reported as such (`Lost`, then `Degraded`), never as a clear path.

pub mod body_rate;
pub mod config;
pub mod cost_function;
pub mod cue;
pub mod dropoff;
pub mod frame_step;
pub mod ground_plane;
pub mod ground_prediction;
pub mod hysteresis;
pub mod nearest_scan;
pub mod obstacle_memory;
pub mod odometry;
pub mod organized_cloud;
pub mod predictive;
pub mod rejections;
pub mod second_view;
pub mod synthetic_scene;
pub mod time_to_collision;
pub mod timing;
pub mod turn_ahead;
pub mod walking_frame;

use schemas::{CostFunction, GroundState, Intrinsics, Rumble, Scan, SideCosts};

pub use config::PerceptionConfig;
pub use cue::{cue, cue_unavailable, CueConfig};
pub use frame_step::{Blind, ComputeStep, FrameData, FrameIn, StepError, StepOutput};
pub use rejections::Rejections;
pub use timing::{InstantTimer, NoTimer, StageMedians, StageTimer};

use cost_function::{rumble, scan_points, side_costs};
use dropoff::PathGround;
use ground_plane::{GroundSearch, GroundTracker};
use ground_prediction::{blocked_view, GroundPrediction};
use hysteresis::RumbleDebounce;
use nearest_scan::{BinLayout, ScanBuilder, UserFrame};
use obstacle_memory::{ObstacleMemory, ViewCone};
use organized_cloud::SampledCloud;
use time_to_collision::ClosingSpeed;

/// One organized depth frame, borrowed.
#[derive(Debug, Clone, Copy)]
pub enum DepthInput<'a> {
    /// u16 depth image, row-major, 0 = invalid.
    Depth {
        /// Samples, `width * height` of them.
        samples: &'a [u16],
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// Metres per depth unit.
        depth_scale_m: f32,
        /// Pinhole intrinsics.
        intrinsics: Intrinsics,
    },
    /// Organized points in the camera optical frame, row-major, NaN = invalid.
    Xyz {
        /// Points, `width * height` of them.
        points: &'a [[f32; 3]],
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
    },
}

/// Planar motion of the user since the previous frame (user frame of the previous frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Forward translation, metres.
    pub forward_m: f32,
    /// Leftward translation, metres.
    pub left_m: f32,
    /// Heading change, radians, positive left.
    pub yaw_rad: f32,
}

impl Motion {
    /// True when every component is a number (a bad odometry message can carry NaN).
    pub fn is_finite(&self) -> bool {
        self.forward_m.is_finite() && self.left_m.is_finite() && self.yaw_rad.is_finite()
    }

    /// This motion and then `next` (given in the frame this one ends in), as one motion
    /// in this one's starting frame.
    pub fn then(self, next: Motion) -> Motion {
        let (s, c) = self.yaw_rad.sin_cos();
        Motion {
            forward_m: self.forward_m + c * next.forward_m - s * next.left_m,
            left_m: self.left_m + s * next.forward_m + c * next.left_m,
            yaw_rad: self.yaw_rad + next.yaw_rad,
        }
    }

    /// `before` (if any) and then this motion, as one.
    pub fn after(self, before: Option<Motion>) -> Motion {
        before.map_or(self, |b| b.then(self))
    }

    /// The map from a point `(x forward, y left)` of the previous frame's user frame to
    /// where a static point lies in the current one.
    pub fn to_current_frame(self) -> impl Fn([f32; 2]) -> [f32; 2] {
        let (s, c) = self.yaw_rad.sin_cos();
        move |[x, y]| {
            let (dx, dy) = (x - self.forward_m, y - self.left_m);
            [c * dx + s * dy, -s * dx + c * dy]
        }
    }
}

/// What else is known about the frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameContext {
    /// Capture stamp, ns.
    pub stamp_ns: u64,
    /// Gravity in the camera frame (pointing down, any length), from the IMU.
    pub gravity_camera: Option<[f32; 3]>,
    /// User motion since the previous frame (odometry / IMU).
    pub motion: Option<Motion>,
    /// The body's turn rate about gravity at capture, rad/s, positive left, from a
    /// body-worn gyro (not the cane's: that one carries the sweep). `None`: no such
    /// sensor; the costs are taken along the camera's heading only, as in the thesis.
    pub body_yaw_rate_rad_s: Option<f32>,
    /// The camera's height above the floor as the sender believes it (the frame's
    /// mount guess), metres: the ground is looked for only within
    /// [`config::GroundConfig::mount_tolerance_m`] of it. `None`: within
    /// [`config::GroundConfig::camera_height_range_m`].
    pub mount_height_m: Option<f32>,
    /// The camera's pitch below the horizontal as the sender believes it (the frame's
    /// mount guess), degrees: without gravity, the floor is looked for around the up
    /// axis it gives rather than the camera's down axis (a camera pitched 30 degrees
    /// down is outside the thesis's 20 degree cone around that). `None`: camera -y.
    pub mount_pitch_deg: Option<f32>,
}

/// Why a frame gave no perception. Each is counted by [`PerceptionError::kind`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PerceptionError {
    /// The sample count does not match width x height.
    #[error("frame is {width}x{height} but holds {len} samples")]
    SizeMismatch {
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// Samples present.
        len: usize,
    },
    /// Intrinsics non-finite or with non-positive focal lengths.
    #[error("unusable intrinsics {0:?}")]
    BadIntrinsics(Intrinsics),
    /// Depth scale non-finite or non-positive.
    #[error("unusable depth scale {0} m per unit")]
    BadDepthScale(f32),
    /// Not a single valid depth in the frame (all NaN / all zero).
    #[error("no valid depth in the frame")]
    NoValidPoints,
    /// No ground found, and none ever found to stand in for it.
    #[error("ground not found ({lost_frames} frames in a row) and no earlier ground to use")]
    GroundNotFound {
        /// Frames in a row without ground.
        lost_frames: u32,
    },
    /// The camera looks straight along the ground normal: no forward direction.
    #[error("camera looks straight down or up: no forward direction")]
    CameraAlongVertical,
}

impl PerceptionError {
    /// Short stable name for reject counters.
    pub fn kind(&self) -> &'static str {
        match self {
            PerceptionError::SizeMismatch { .. } => "size_mismatch",
            PerceptionError::BadIntrinsics(_) => "bad_intrinsics",
            PerceptionError::BadDepthScale(_) => "bad_depth_scale",
            PerceptionError::NoValidPoints => "no_valid_points",
            PerceptionError::GroundNotFound { .. } => "no_ground",
            PerceptionError::CameraAlongVertical => "camera_vertical",
        }
    }
}

/// Frames further apart than this do not give a speed, ns.
const SPEED_GAP_NS: u64 = 500_000_000;
/// The speed is smoothed over about this long, seconds.
const SPEED_SMOOTHING_S: f32 = 0.15;

/// Perception of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Perception {
    /// Ground plane `[a, b, c, d]`, unit normal pointing up, camera optical frame (`d` =
    /// camera height). While the ground is `Lost`/`Degraded`: the running plane in use.
    pub plane_camera: [f32; 4],
    /// Whether the ground was found in this frame.
    pub ground: GroundState,
    /// Valid depth pixels in the full frame, estimated from the strided sample.
    pub points_valid: usize,
    /// Nearest obstacle per bearing bin, user frame, angles positive left.
    pub scan: Scan,
    /// With `scan.floor_seen`, per scan bin, how far the floor was seen free, metres (0:
    /// no floor seen): the localization's evidence that no wall stands there
    /// ([`nearest_scan::ScanBuilder::floor_seen_m`]); empty without.
    pub floor_seen_m: Vec<f32>,
    /// Fully-Integrated costs.
    pub ficf: SideCosts,
    /// Cushioned Avoidance costs.
    pub cacf: SideCosts,
    /// Raw Table 2.1 state from the FICF costs.
    pub rumble_ficf: Rumble,
    /// Raw Table 2.1 state from the CACF costs.
    pub rumble_cacf: Rumble,
    /// State of the configured cost function, escalated by drop-off and TTC, after
    /// hysteresis: what the user should feel.
    pub rumble: Rumble,
    /// Nearest obstacle (scan or remembered), horizontal range, metres; `INFINITY` if none.
    pub nearest_m: f32,
    /// Bearing of the nearest obstacle, degrees, positive left (0 if none).
    pub nearest_bearing_deg: f32,
    /// Time to collision with the nearest obstacle in the path when it moves towards the
    /// user (its own motion, odometry taken out), seconds.
    pub ttc_s: Option<f32>,
    /// Ground ahead missing or lower than the plane, or lower ground (seen or guessed,
    /// see `dropoff::StepZone`) on the floor between the feet and the camera.
    pub dropoff_ahead: bool,
    /// What the rays into the path ahead found (drop-off evidence).
    pub path_ground: PathGround,
    /// Remembered obstacles out of view that the costs included (one per degree).
    pub remembered: usize,
    /// Obstacle points (above the band, below head height) in the sample.
    pub obstacle_points: usize,
    /// The path ahead was clear and the cue comes from the heading the body is turning
    /// to (`turn_ahead`).
    pub turn_ahead: bool,
    /// The body's turn rate this frame was given (`FrameContext::body_yaw_rate_rad_s`).
    pub body_yaw_rate_rad_s: Option<f32>,
    /// The camera's angle to the body's heading, radians, positive left: estimated
    /// whenever the body's turn rate is given (0 when it is not), and taken by the
    /// costs with `walking_frame` on.
    pub sweep_rad: f32,
    /// The camera's speed over the floor, from the odometry, smoothed over about 0.15 s,
    /// m/s (0 for a frame without odometry).
    pub speed_m_s: f32,
    /// `rumble` came from where the user heads ([`crate::predictive`], set by the frame
    /// step); false: from the costs.
    pub predictive: bool,
    /// The frame carried a usable gravity vector (`FrameContext::gravity_camera`): the
    /// floor was searched level with it, lower ground looked for across the view and the
    /// floor predicted at a near wall. Without one, only the thesis's search around the
    /// camera's down axis or the last floor, and lower ground along the path.
    pub gravity: bool,
}

impl Perception {
    /// The hazard message of this frame: what the bus carries to feedback and monitors.
    pub fn hazard(&self, frame_seq: u64, active: CostFunction, latency: Vec<schemas::StageLatency>) -> schemas::Hazard {
        schemas::Hazard {
            frame_seq,
            ficf: self.ficf,
            cacf: self.cacf,
            active,
            rumble: self.rumble,
            ground: self.ground,
            plane_camera: self.plane_camera,
            nearest_m: self.nearest_m,
            nearest_bearing_deg: self.nearest_bearing_deg,
            ttc_s: self.ttc_s,
            dropoff_ahead: self.dropoff_ahead,
            turn_ahead: self.turn_ahead,
            body_turn_deg_s: self.body_yaw_rate_rad_s.filter(|r| r.is_finite()).map(f32::to_degrees),
            predictive: self.predictive,
            gravity: self.gravity,
            latency,
        }
    }

    /// The state before any frame: ground `Degraded`, nothing measured.
    pub fn empty() -> Self {
        Self {
            plane_camera: [0.0; 4],
            ground: GroundState::Degraded,
            points_valid: 0,
            scan: Scan { angle_min_deg: 0.0, angle_increment_deg: 1.0, ranges_m: Vec::new(), range_max_m: 0.0 },
            floor_seen_m: Vec::new(),
            ficf: SideCosts::default(),
            cacf: SideCosts::default(),
            rumble_ficf: Rumble::None,
            rumble_cacf: Rumble::None,
            rumble: Rumble::None,
            nearest_m: f32::INFINITY,
            nearest_bearing_deg: 0.0,
            ttc_s: None,
            dropoff_ahead: false,
            path_ground: PathGround::default(),
            remembered: 0,
            obstacle_points: 0,
            turn_ahead: false,
            body_yaw_rate_rad_s: None,
            sweep_rad: 0.0,
            speed_m_s: 0.0,
            predictive: false,
            gravity: false,
        }
    }
}

/// The whole pipeline with its reusable buffers and the state carried between frames
/// (running ground, memory grid, closing speed, debounce).
#[derive(Debug)]
pub struct Pipeline {
    config: PerceptionConfig,
    cloud: SampledCloud,
    search: GroundSearch,
    tracker: GroundTracker,
    prediction: GroundPrediction,
    layout: Option<BinLayout>,
    scan: ScanBuilder,
    memory: ObstacleMemory,
    closing: ClosingSpeed,
    debounce: RumbleDebounce,
    cost_points: Vec<[f32; 2]>,
    /// Per `cost_points`, whether the cane would find it (see [`Pipeline::cane_finds`]).
    cane_finds: Vec<bool>,
    // this frame's edges of lower ground; the memory adds the unseen floor that may be
    // lower to `lower.edge`
    lower: dropoff::LowerGround,
    /// The camera's angle to the way the user walks.
    sweep: walking_frame::SweepEstimate,
    /// `cost_points` in the walking frame.
    walking_points: Vec<[f32; 2]>,
    /// The stamp of the last frame whose motion was applied, ns.
    moved_ns: Option<u64>,
    /// Motion since the last frame that got as far as the memory: a frame refused
    /// earlier passes its motion on, so what is remembered stays where it is.
    unapplied: Option<Motion>,
    out: Perception,
}

impl Pipeline {
    /// A pipeline with `config`.
    pub fn new(config: PerceptionConfig) -> Self {
        Self {
            search: GroundSearch::new(config.ground.seed),
            config,
            cloud: SampledCloud::default(),
            tracker: GroundTracker::default(),
            prediction: GroundPrediction::default(),
            layout: None,
            scan: ScanBuilder::default(),
            memory: ObstacleMemory::default(),
            closing: ClosingSpeed::default(),
            debounce: RumbleDebounce::default(),
            cost_points: Vec::new(),
            cane_finds: Vec::new(),
            lower: dropoff::LowerGround::default(),
            sweep: walking_frame::SweepEstimate::default(),
            walking_points: Vec::new(),
            moved_ns: None,
            unapplied: None,
            out: Perception::empty(),
        }
    }

    /// The configuration in use.
    pub fn config(&self) -> &PerceptionConfig {
        &self.config
    }

    /// Every obstacle point the cost functions took in the last frame processed: the
    /// scan's, the edges of lower ground and what the memory holds out of view; user
    /// frame, metres `(x forward, y left)`.
    pub fn obstacle_points(&self) -> &[[f32; 2]] {
        &self.cost_points
    }

    /// Per [`Pipeline::obstacle_points`], whether a cane sweeping the floor would find
    /// it: true for what reaches down to near the floor in view
    /// ([`nearest_scan::ScanBuilder::cane_finds`]) and for edges of lower ground; false
    /// for what overhangs (a table top, a sign); what the memory holds out of view, as
    /// it was when seen.
    pub fn cane_finds(&self) -> &[bool] {
        &self.cane_finds
    }

    /// Runs every stage on one frame.
    pub fn process(
        &mut self,
        input: DepthInput<'_>,
        ctx: &FrameContext,
        timer: &mut dyn StageTimer,
    ) -> Result<&Perception, PerceptionError> {
        if let Some(m) = ctx.motion.filter(Motion::is_finite) {
            self.unapplied = Some(m.after(self.unapplied));
        }
        let cfg = &self.config;
        timer.start("sample");
        let sampled = match input {
            DepthInput::Depth { samples, width, height, depth_scale_m, intrinsics } => {
                self.cloud.from_depth(samples, width, height, depth_scale_m, intrinsics, cfg.stride_for(width))
            }
            DepthInput::Xyz { points, width, height } => self.cloud.from_xyz(
                points,
                width,
                height,
                cfg.stride_for(width),
                cfg.scan.xyz_horizontal_fov_deg,
                cfg.memory.xyz_vertical_fov_deg,
            ),
        };
        timer.stop();
        sampled?;
        let gravity = ctx.gravity_camera.filter(|g| ground_plane::normalized(g).is_some());
        self.out.gravity = gravity.is_some();

        timer.start("ground_plane");
        let fit = if self.cloud.valid.len() >= 3 {
            let up = self.tracker.prior_up(gravity, ctx.mount_pitch_deg, &cfg.ground);
            let expected_offset_m = self.tracker.expected_offset_m(&cfg.ground);
            self.search.fit(&self.cloud, up, gravity.is_some(), expected_offset_m, ctx.mount_height_m, &cfg.ground)
        } else {
            None
        };
        let decision = self.tracker.update(fit, gravity, &cfg.ground);
        if let Some(d) = decision.filter(|d| d.state == GroundState::Found) {
            self.prediction.found(ctx.stamp_ns, d.plane.normal);
        }
        timer.stop();
        if self.cloud.valid.is_empty() {
            return Err(PerceptionError::NoValidPoints);
        }
        let decision = decision.ok_or(PerceptionError::GroundNotFound { lost_frames: self.tracker.lost_frames() })?;
        let frame = UserFrame::from_plane(&decision.plane).ok_or(PerceptionError::CameraAlongVertical)?;
        let view = self.cloud.view.unwrap_or(organized_cloud::ViewGeometry { half_hfov_rad: 0.5, half_vfov_rad: 0.4 });

        timer.start("nearest_scan");
        let layout = match self.layout.take() {
            Some(l) if l.fits(view.half_hfov_rad, cfg.scan.bin_deg) => l,
            _ => BinLayout::for_fov(view.half_hfov_rad, cfg.scan.bin_deg),
        };
        let band_scale = if decision.state == GroundState::Found { 1.0 } else { cfg.scan.fallback_band_scale };
        let out = &mut self.out;
        self.scan.build(&self.cloud, &frame, &layout, &cfg.scan, band_scale, &mut out.scan);
        out.floor_seen_m.clone_from(&self.scan.floor_seen_m);
        timer.stop();

        timer.start("dropoff");
        self.lower.clear();
        if cfg.dropoff.enabled && cfg.dropoff.edges {
            dropoff::edges(&self.cloud, &frame, gravity, &cfg.dropoff, &mut self.lower);
            if decision.state != GroundState::Found {
                // a plane kept from an earlier frame is a few centimetres off as the
                // cane moves: the whole floor reads as lower, and guessing the unseen
                // floor from it walled a user in at a wall (`step-down`, assisted, seed 39)
                self.lower.unseen.clear();
                self.lower.floor.clear();
            }
        }
        out.path_ground = if cfg.dropoff.enabled {
            dropoff::survey(&self.cloud, &frame, &cfg.dropoff)
        } else {
            PathGround::default()
        };
        out.dropoff_ahead = cfg.dropoff.enabled && out.path_ground.is_dropoff();
        timer.stop();

        timer.start("memory");
        let motion = self.unapplied.take();
        let since_ns = self.moved_ns.and_then(|t| ctx.stamp_ns.checked_sub(t));
        match (motion, since_ns) {
            (Some(m), Some(dt_ns)) if dt_ns > 0 && dt_ns <= SPEED_GAP_NS => {
                let dt_s = dt_ns as f32 * 1e-9;
                let k = dt_s / (dt_s + SPEED_SMOOTHING_S);
                out.speed_m_s += k * (m.forward_m.hypot(m.left_m) / dt_s - out.speed_m_s);
            }
            (Some(_), _) => {}
            (None, _) => out.speed_m_s = 0.0,
        }
        if motion.is_some() {
            self.moved_ns = Some(ctx.stamp_ns);
        }
        self.cost_points.clear();
        self.cost_points.extend(scan_points(&out.scan));
        let seen_points = self.cost_points.len();
        self.cane_finds.clear();
        let ranged = out.scan.ranges_m.iter().map(|r| r.is_finite());
        self.cane_finds.extend(ranged.zip(&self.scan.cane_finds).filter(|(r, _)| *r).map(|(_, &c)| c));
        if cfg.memory.enabled {
            let cone = ViewCone {
                half_hfov_rad: view.half_hfov_rad,
                half_vfov_rad: view.half_vfov_rad,
                pitch_down_rad: frame.pitch_down_rad(),
                camera_height_m: decision.plane.offset_m,
                range_max_m: cfg.scan.range_max_m,
            };
            let heights = &self.scan.heights_m;
            let seen = self
                .cost_points
                .iter()
                .zip(out.scan.ranges_m.iter().zip(heights).filter(|(r, _)| r.is_finite()).map(|(_, h)| *h))
                .zip(&self.cane_finds)
                .map(|((p, h), &cane)| ([p[0], p[1], h], cane))
                .chain(self.lower.edge.iter().map(|p| ([p[0], p[1], 0.0], true)));
            self.memory.update(ctx.stamp_ns, motion, &cone, seen, &cfg.memory);
            let lower = &mut self.lower;
            self.memory.unseen_lower(ctx.stamp_ns, &lower.floor, &lower.unseen, &cfg.memory, &mut lower.edge);
            self.cost_points.extend_from_slice(&lower.edge);
            self.cane_finds.resize(self.cost_points.len(), true);
            self.cost_points.extend_from_slice(&self.memory.out_of_view);
            self.cane_finds.extend_from_slice(&self.memory.out_of_view_cane);
            out.remembered = self.memory.out_of_view.len();
            if cfg.dropoff.enabled && cfg.dropoff.edges {
                let zone = dropoff::StepZone::new(&cfg.dropoff);
                out.dropoff_ahead |= self.memory.lower_ground_where(|p| zone.contains(p));
            }
        } else {
            // nothing tells the floor walked towards from floor never seen: all of it
            self.cost_points.extend_from_slice(&self.lower.edge);
            self.cost_points.extend_from_slice(&self.lower.unseen);
            self.cane_finds.resize(self.cost_points.len(), true);
            out.remembered = 0;
            let zone = dropoff::StepZone::new(&cfg.dropoff);
            out.dropoff_ahead |= self.lower.edge.iter().chain(&self.lower.unseen).any(|&p| zone.contains(p));
        }
        timer.stop();

        timer.start("cost_function");
        // estimated whenever the body's rate is given (the predictive cue needs it); the
        // costs take it only with the walking frame on
        let estimate = config::WalkingFrameConfig { enabled: true, ..cfg.walking_frame.clone() };
        out.sweep_rad = self.sweep.update(ctx.stamp_ns, motion, ctx.body_yaw_rate_rad_s, &estimate);
        let sweep = if cfg.walking_frame.enabled { out.sweep_rad } else { 0.0 };
        self.walking_points.clear();
        self.walking_points.extend(self.cost_points.iter().map(|&p| walking_frame::to_walking(sweep)(p)));
        out.ficf = side_costs(self.walking_points.iter().copied(), &cfg.ficf);
        out.cacf = side_costs(self.walking_points.iter().copied(), &cfg.cacf);
        out.rumble_ficf = rumble(&out.ficf, &cfg.ficf);
        out.rumble_cacf = rumble(&out.cacf, &cfg.cacf);
        let nearest = self.cost_points.iter().map(|p| (p[0].hypot(p[1]), p)).min_by(|a, b| a.0.total_cmp(&b.0));
        (out.nearest_m, out.nearest_bearing_deg) = match nearest {
            Some((r, p)) => (r, p[1].atan2(p[0]).to_degrees()),
            None => (f32::INFINITY, 0.0),
        };
        let approach = if cfg.ttc.enabled {
            self.closing.update(ctx.stamp_ns, motion, &self.cost_points[..seen_points], &cfg.ttc)
        } else {
            None
        };
        out.ttc_s = approach.map(|a| a.ttc_s);
        let (mut raw, costs) = match cfg.cost_function {
            CostFunction::Ficf => (out.rumble_ficf, &cfg.ficf),
            CostFunction::Cacf => (out.rumble_cacf, &cfg.cacf),
        };
        let ahead = (raw == Rumble::None)
            .then(|| turn_ahead::rumble_ahead(&self.walking_points, ctx.body_yaw_rate_rad_s, &cfg.turn_ahead, costs))
            .flatten();
        out.turn_ahead = ahead.is_some_and(|r| r != Rumble::None);
        out.body_yaw_rate_rad_s = ctx.body_yaw_rate_rad_s;
        raw = ahead.unwrap_or(raw);
        if let Some(a) = approach.filter(|a| raw == Rumble::None && a.ttc_s < cfg.ttc.warn_s) {
            // turn away from the side of the path the approaching obstacle is on
            raw = if a.point[1] > 0.0 { Rumble::Right } else { Rumble::Left };
        }
        if out.dropoff_ahead {
            raw = Rumble::Both;
        }
        out.rumble = self.debounce.update(raw, &cfg.hysteresis);
        out.plane_camera = decision.plane.coefficients();
        // A near wall hides the floor: the plane predicted from gravity (the tracker's
        // stand-in while lost) stays trusted within the bounds of `ground_prediction`.
        // Only while it warns: a predicted floor must never be the basis of a "clear"
        // lasting seconds (a floor the camera cannot see, e.g. black or shiny, ahead of
        // a far wall would otherwise be silent), unless this camera's clear is never
        // the user's (`while_clear`: the chest camera's).
        out.ground = if decision.state == GroundState::Degraded
            && (out.rumble != Rumble::None || cfg.ground_prediction.while_clear)
            && self.prediction.trusted(gravity, ctx.stamp_ns, &cfg.ground_prediction)
            && blocked_view(self.scan.obstacle_points, self.cloud.valid.len(), &cfg.ground_prediction)
        {
            GroundState::Lost
        } else {
            decision.state
        };
        out.points_valid = self.cloud.points_valid;
        out.obstacle_points = self.scan.obstacle_points;
        timer.stop();
        self.layout = Some(layout);
        Ok(&self.out)
    }
}

#[cfg(test)]
mod tests;
