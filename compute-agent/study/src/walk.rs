//! One closed-loop walk, in simulated time (no wall-clock sleeping): the user's pose
//! puts the cane camera somewhere; the ray-cast frame goes (optionally through the
//! wire codec) into the perception pipeline the compute agent runs; its haptic intent
//! goes through the feedback agent's own step into the hands; the user feels it, reacts,
//! and moves. Physics and feedback run at [`PHYSICS_HZ`], the camera at its frame rate.
//!
//! The memory beyond the field of view is moved by odometry of the camera's floor frame
//! (where the perception's user frame lives: it turns with the cane's sweep), as
//! visual odometry on the cane camera would measure it, with the sim's VO error model.

use std::collections::VecDeque;

use feedback_agent::console::ConsoleSpeech;
use feedback_agent::device::SpeechEngine;
use feedback_agent::{Feedback, StepSettings};
use localization::{Pose2, Tracker, TrackerConfig};
use map::Building;
use perception::body_rate::BodyRate;
use perception::predictive::{CaneModel, PredictiveConfig, RouteAhead, UserModel, Way};
use perception::second_view::{SecondView, ViewState};
use perception::{cue, ComputeStep, CueConfig, FrameData, FrameIn, NoTimer, Perception, PerceptionConfig, StepOutput};
use schemas::{
    AppliedAction, DepthEncoding, DepthFrame, GroundState, HapticIntent, Hazard, ImuSample, MountGuess, OdomIncrement,
    RouteStatus, SpeechIntent,
};
use sim::compass::{CompassModel, CompassNoise};
use sim::odometry::{OdometryModel, OdometryNoise};
use sim::render::DEPTH_UNITS_PER_M;
use sim::shape::Shape;
use sim::source::noisy_gravity;
use sim::walker::wrap_pi;
use sim::{
    CameraPose, CameraProfile, CaneMount, ChestMount, ObstacleId, ObstacleKind, Renderer, SimRng, UserPose, World,
};

use super::contacts::{cane_distance_m, in_field_of_view, Contact, Part, SeenLog, Touching, RELEASE_M, TOUCH_M};
use super::floor_plan;
use super::hands::{Felt, FeltRumble, Hands};
use super::oracle::{Now, Oracle, OracleConfig, PointGrid, Seen, Sees};
use super::spoken::{self, Ear, Heard, SpokenDevice, SpokenGuide, SPEECH_WPM, UNDERSTAND_S};
use super::virtual_user::{ExperimenterAssist, GoalSound, Guide, RouteFollow, Touch, UserParams, VirtualUser};

/// Physics, feedback and reaction steps per second (pulse edges resolved to 8 ms).
pub const PHYSICS_HZ: u32 = 120;
/// The guide is asked every this many physics steps (4 Hz: instructions, not servoing).
const GUIDE_EVERY: u64 = 30;
/// How far the still cane is turned each way to tell which side a touched obstacle is on, radians.
const CANE_PROBE_RAD: f64 = 0.05;
/// Heading more than this off where the guide points counts as walking away, radians.
const AWAY_RAD: f64 = std::f64::consts::FRAC_PI_2;
/// Walking away for longer than this is one reorientation, seconds (the thesis's
/// experimenters turned such users back). Away from where the guide points: the goal's
/// sound, the route, or the experimenter leading round a divider, which is no more a
/// reorientation than following the route is.
pub const REORIENT_AFTER_S: f64 = 5.0;
/// Capture stamp of t = 0, ns (stamps of 0 mean "self-initiated" downstream).
const T0_NS: u64 = 1_000_000_000;

/// A heading further off than this while tracking is a turned copy of the place
/// ([`TrackedError::frames_turned`]), radians.
const TURNED_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// Mixed into a walk's seed for its compass's own random stream.
const COMPASS_SEED: u64 = 0x636f_6d70_6173_7300;

/// What the user heads for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GuideKind {
    /// The goal's sound: bearing only (Taylor's music source).
    Sound,
    /// The world's route (stand-in for turn-by-turn guidance; the goal's sound in
    /// worlds without a route): the user is kept on it and pointed a lookahead along
    /// it (`--route-lookahead-m`), so turns begin before the corner.
    Route,
    /// The goal's sound, and an experimenter who leads a user stuck for 20 s along the
    /// route until the goal is in sight (Taylor's reorienting; the goal's sound alone
    /// in worlds without a route).
    Assisted,
    /// Spoken route guidance ([`crate::spoken`]): the compute agent's navigator on the
    /// world's floor plan, from the place the device believes ([`WalkConfig::pose`]),
    /// speaks through the feedback step's speech queue; the user turns and walks by
    /// the words heard, and once told "you have arrived" finds the place by its sound.
    Spoken,
}

/// What the map behind the route (and the experimenter's leading) holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RouteMap {
    /// Every obstacle: the world's route, laid round them all; line of sight past them.
    Full,
    /// The floor plan alone (walls and drop-offs, no furniture or hanging obstacles):
    /// the world's floor-plan route, line of sight past walls only.
    FloorPlan,
}

/// How far along the route a route-guided user is pointed at least, metres: turns
/// begin this far before a corner, about where turn-by-turn guidance says "turn right".
pub const ROUTE_LOOKAHEAD_M: f64 = 1.5;
/// A user who turns wider is pointed this many turning radii along the route.
pub const ROUTE_LOOKAHEAD_TURN_RADII: f64 = 1.5;

/// How far along the route guidance points `user` (see [`GuideKind::Route`]):
/// [`ROUTE_LOOKAHEAD_M`], or [`ROUTE_LOOKAHEAD_TURN_RADII`] turning radii (walking
/// speed over turning rate) for a user who could not make the turn in that.
pub fn route_lookahead_m(user: &UserParams) -> f64 {
    let radius_m = user.walk_speed_m_s / user.turn_rate_deg_s.to_radians().max(1e-6);
    ROUTE_LOOKAHEAD_M.max(ROUTE_LOOKAHEAD_TURN_RADII * radius_m)
}

/// No nearer the goal for this long, an assisted user is led back on course, seconds
/// (the 20 s of [`GuideKind::Assisted`]'s help).
pub const STUCK_AFTER_S: f64 = 20.0;

/// Everything that makes one walk.
#[derive(Debug, Clone)]
pub struct WalkConfig {
    /// Perception settings (cost function, beyond-the-thesis switches).
    pub perception: PerceptionConfig,
    /// Rumble state to haptic intent.
    pub cue: CueConfig,
    /// Feedback step settings.
    pub feedback: StepSettings,
    /// The user.
    pub user: UserParams,
    /// Cane, camera mount and sweep.
    pub mount: CaneMount,
    /// Depth camera.
    pub camera: CameraProfile,
    /// A second depth camera (the same model) worn at the chest, its frames through a
    /// compute step of their own and its cue joined to the cane camera's
    /// ([`perception::second_view`]); `None`: the cane camera alone.
    pub chest: Option<ChestMount>,
    /// What the user heads for.
    pub guide: GuideKind,
    /// With [`GuideKind::Route`] (and the experimenter of [`GuideKind::Assisted`]), how
    /// far along the route the user is pointed, metres
    /// (0: the farthest waypoint in sight, corner to corner; `None`: fitted to the
    /// user, [`route_lookahead_m`]).
    pub route_lookahead_m: Option<f64>,
    /// What the route's map holds.
    pub route_map: RouteMap,
    /// The rumble reaches the hands (false: the device off, the cane alone).
    pub rumble: bool,
    /// Walk ends unfinished after this, seconds.
    pub timeout_s: f64,
    /// Goal reached within this distance of it, metres.
    pub goal_radius_m: f64,
    /// Capture to intent applied, ms (perception, transport, device write).
    pub latency_ms: f64,
    /// Send frames through the wire codec's bounded-error mode with this step (mm);
    /// `None` skips the codec (the lossless mode gives back the exact samples).
    pub bounded_mm: Option<u16>,
    /// Start pose jitter: position (metres) and heading (degrees), uniform +-.
    pub start_jitter: (f64, f64),
    /// Reaction time jitter, fraction of the reaction time, uniform +-.
    pub reaction_jitter: f64,
    /// Record a [`TraceRow`] per camera frame in [`WalkOutcome::trace`].
    pub trace: bool,
    /// Give perception the body's turn rate from a simulated body-worn gyro
    /// ([`BodyGyro`]), so the costs are also taken along the heading the user is turning
    /// to (`turn_ahead`). Off: as the agents run today, with no such sensor.
    pub body_gyro: bool,
    /// The phone worn at the chest gives its compass ([`CompassModel`]) to the particle
    /// filter, where the walk runs one. Off: no compass reaches the filter.
    pub compass: bool,
    /// Cues from the [`Oracle`] (perfect knowledge of the world and the user) instead
    /// of perception: the bound of what any device could do for this user. Perception
    /// still runs (for the trace and the feedback agent's watchdog).
    pub oracle: Option<OracleConfig>,
    /// The cue from where the user heads ([`perception::predictive`]): each frame the
    /// compute step is told the way ahead, from the route the user follows (the goal
    /// for a user heading for its sound) and the user's place on it. The place is the
    /// place and heading from [`WalkConfig::pose`]. Needs [`WalkConfig::body_gyro`]
    /// (the body's heading under the sweep).
    pub predictive: Option<PredictiveConfig>,
    /// Where the predictive cue takes the user to be.
    pub pose: PoseSource,
    /// The map the particle filter localizes on (`PoseSource::Filter`); routes are
    /// planned on the floor plan either way.
    pub localization_map: floor_plan::LocalizationMap,
    /// The simulated visual odometry's errors (scale, noise, heading drift) times this
    /// (1: typical indoor VO, `OdometryNoise::default`): what the particle filter and the
    /// body's speed are made from, made worse to see how the cue degrades as the place's
    /// error grows.
    pub odometry_noise: f64,
    /// With the spoken guide: what the perception holds goes onto the navigator's
    /// planner, and a route with something standing on it ahead is laid round it
    /// (`guidance::Navigator::perceived`). Off: the route is the floor plan's alone.
    pub ways_round: bool,
}

/// Whose walking the predictive cue's model of the user is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CueModel {
    /// The typical user's ([`UserParams::default`]), whoever walks: the compute
    /// agent's.
    Typical,
    /// The typical user's to begin with, the turning rate then learnt from the body
    /// gyro while the user acts on a rumble ([`PredictiveConfig::learn_turn_rate`]).
    Learnt,
    /// This walk's user's mean walking speed, turning rate and reaction: a device that
    /// had learnt them.
    User,
}

/// Where the predictive cue takes the user to be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseSource {
    /// The compute agent's particle filter on the world's floor plan, told where the
    /// walk starts, from the camera's odometry, the cane's and the body's gyros and the
    /// perception's scans; while it does not track, the cost functions decide.
    Filter,
    /// The simulator's truth: only to tell the filter's error from the cue's.
    Truth,
}

/// One camera frame of a walk, for finding out why a contact happened.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TraceRow {
    /// Seconds into the walk.
    pub t_s: f64,
    /// User position, map metres.
    pub x_m: f64,
    /// User position, map metres.
    pub y_m: f64,
    /// User heading, degrees counter-clockwise from +x.
    pub yaw_deg: f64,
    /// Cane sweep angle, degrees (left positive).
    pub sweep_deg: f64,
    /// Walking speed, m/s.
    pub speed_m_s: f64,
    /// Rumble state perception decided for this frame (`None` when it refused the frame).
    pub rumble: Option<schemas::Rumble>,
    /// What the hands felt at this instant.
    pub felt: Felt,
    /// Nearest obstacle point in the user frame, metres.
    pub nearest_m: f32,
    /// Its bearing, degrees (left positive).
    pub bearing_deg: f32,
    /// Time to collision, seconds.
    pub ttc_s: Option<f32>,
    /// Active cost function's forward cost.
    pub forward_cost: f32,
    /// Closest the body is to any obstacle, metres.
    pub clearance_m: f64,
    /// The cue of this frame came from the heading the body is turning to (`turn_ahead`,
    /// with [`WalkConfig::body_gyro`]).
    pub turn_ahead: bool,
    /// The particle filter's estimate after this frame (x, y in map metres, heading in
    /// degrees, status), when the walk runs one.
    pub estimate: Option<([f64; 3], localization::Status)>,
    /// Route guidance may take that estimate ([`localization::Estimate::guides`]).
    pub estimate_guides: bool,
}

/// The Asus Xtion in its 320x240 mode: with a perception stride of 1 these are the
/// rays the compute agent samples from the 640x480 image at its default stride of 2,
/// for a quarter of the rendering cost.
pub fn xtion_qvga() -> CameraProfile {
    let vga = CameraProfile::xtion();
    CameraProfile { name: "xtion-qvga".into(), width: vga.width / 2, height: vga.height / 2, ..vga }
}

impl WalkConfig {
    /// The predictive cue on the route the device knows, from the user's place (not on
    /// the user's own way, which needs neither).
    pub fn predictive_on_route(&self) -> bool {
        self.predictive.is_some_and(|p| !p.own_way)
    }

    /// How far along the route the user is pointed, metres: as set, or fitted to the
    /// user ([`route_lookahead_m`]).
    pub fn lookahead_m(&self) -> f64 {
        self.route_lookahead_m.unwrap_or_else(|| route_lookahead_m(&self.user))
    }
}

impl Default for WalkConfig {
    /// Xtion at 320x240 with stride 1 (see [`xtion_qvga`]), default perception, cue,
    /// feedback, user and cane; 300 s timeout, 0.5 m goal radius, 50 ms latency.
    fn default() -> Self {
        Self {
            perception: PerceptionConfig { stride_px: 1, ..PerceptionConfig::default() },
            cue: CueConfig::default(),
            feedback: StepSettings::default(),
            user: UserParams::default(),
            mount: CaneMount::default(),
            camera: xtion_qvga(),
            chest: None,
            guide: GuideKind::Sound,
            route_lookahead_m: None,
            route_map: RouteMap::Full,
            rumble: true,
            timeout_s: 300.0,
            goal_radius_m: 0.5,
            latency_ms: 50.0,
            bounded_mm: None,
            start_jitter: (0.15, 10.0),
            reaction_jitter: 0.25,
            trace: false,
            body_gyro: false,
            compass: false,
            oracle: None,
            predictive: None,
            pose: PoseSource::Filter,
            localization_map: floor_plan::LocalizationMap::FloorPlan,
            odometry_noise: 1.0,
            ways_round: false,
        }
    }
}

/// A gyro worn on the body (a phone at the chest, tilted 20 degrees down): the user's
/// turn rate about gravity, with the torso's sway at each step (3 degrees each way at
/// 0.9 Hz, in proportion to the walking speed), white noise of 1 degree/s per sample and
/// a constant bias of up to 0.5 degree/s drawn per walk, sampled at 100 Hz and read
/// through the compute agent's own estimator ([`BodyRate`]) as it reads a phone's.
pub struct BodyGyro {
    rng: SimRng,
    phase_rad: f64,
    bias_rad_s: f64,
    last: Option<(f64, f64)>,
    /// Index of the next 100 Hz sample.
    next: u64,
    rate: BodyRate,
}

impl BodyGyro {
    /// Sway each way, degrees.
    pub const SWAY_DEG: f64 = 3.0;
    /// Sway frequency (one stride), Hz.
    pub const SWAY_HZ: f64 = 0.9;
    /// White noise per sample, degrees per second.
    pub const NOISE_DEG_S: f64 = 1.0;
    /// Largest bias, degrees per second.
    pub const BIAS_DEG_S: f64 = 0.5;
    /// Sample rate, Hz.
    pub const RATE_HZ: f64 = 100.0;
    /// Tilt of the device below the horizontal, degrees.
    const TILT_DEG: f64 = 20.0;

    /// A gyro whose phase and bias come from `rng`.
    pub fn new(mut rng: SimRng) -> Self {
        let phase_rad = rng.uniform() * std::f64::consts::TAU;
        let bias_rad_s = (2.0 * rng.uniform() - 1.0) * Self::BIAS_DEG_S.to_radians();
        Self { rng, phase_rad, bias_rad_s, last: None, next: 0, rate: BodyRate::default() }
    }

    /// The rate the compute agent would read at `t_s` from a user facing `yaw_rad` and
    /// walking at `speed_fraction` of their pace: the samples since the last reading
    /// carry the turn since then (evenly), sway, noise and bias. `None` on the first
    /// reading.
    pub fn read(&mut self, t_s: f64, yaw_rad: f64, speed_fraction: f64) -> Option<f32> {
        let Some((t0, yaw0)) = self.last.replace((t_s, yaw_rad)).filter(|(t0, _)| t_s > *t0) else {
            self.next = (t_s * Self::RATE_HZ).floor() as u64 + 1;
            return None;
        };
        let turn = wrap_pi(yaw_rad - yaw0) / (t_s - t0);
        let w = std::f64::consts::TAU * Self::SWAY_HZ;
        let sway_rad = Self::SWAY_DEG.to_radians() * speed_fraction.clamp(0.0, 1.0);
        let tilt = Self::TILT_DEG.to_radians();
        // the device's frame: x right, y down its face, z out of its back
        let up = [0.0, -tilt.cos() as f32, -tilt.sin() as f32];
        loop {
            let t_k = self.next as f64 / Self::RATE_HZ;
            if t_k > t_s {
                break;
            }
            self.next += 1;
            let sway = sway_rad * w * (w * t_k + self.phase_rad).cos();
            let noise = self.rng.gaussian() * Self::NOISE_DEG_S.to_radians();
            let r = (turn + sway + noise + self.bias_rad_s) as f32;
            let sample =
                ImuSample { stamp_ns: ns(t_k), gyro_rad_s: up.map(|u| u * r), accel_m_s2: up.map(|u| u * 9.81) };
            // in range and in order by construction: a refusal would leave the rate
            // stale, never wrong
            let _ = self.rate.add(&sample, sample.stamp_ns);
        }
        self.rate.rate_at(ns(t_s), ns(t_s))
    }
}

/// The particle filter's errors on a walk, against the truth, over the frames it said
/// `Tracking` (the frames the device used its place); NaN when it never tracked.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TrackedError {
    /// Position, root mean square, metres.
    pub position_rmse_m: f64,
    /// Heading, root mean square, degrees (what a turn the guide calls is off by).
    pub heading_rmse_deg: f64,
    /// Frames tracked.
    pub frames: u32,
    /// Of those, the frames the filter was more than 1 m off (the device guided the
    /// user from a place a metre or more wrong).
    pub frames_over_1m: u32,
    /// Of those, the frames its heading was more than 45° off (a room's turned copy:
    /// every turn the guide called was wrong by as much).
    pub frames_turned: u32,
}

/// What happened on one walk.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WalkOutcome {
    /// Seed of the walk.
    pub seed: u64,
    /// Reached the goal before the timeout.
    pub completed: bool,
    /// Time to the goal, or the timeout, seconds.
    pub time_s: f64,
    /// Rumble signals: changes of the felt state to left, right or both.
    pub signals: u32,
    /// Times the feedback told the user detection was offline.
    pub offline_signals: u32,
    /// Every contact, in time order.
    pub contacts: Vec<Contact>,
    /// Episodes of heading away from where the guide points (the goal's sound, the
    /// route, the experimenter leading) for more than [`REORIENT_AFTER_S`].
    pub reorientations: u32,
    /// Times an experimenter led the user back on course ([`GuideKind::Assisted`]).
    pub assists: u32,
    /// Frames the perception refused (no intent for them; the third in a row and every
    /// 30th after send the blind state, as the compute agent does: `perception::rejections`).
    pub perception_errors: u32,
    /// Camera frames processed.
    pub frames: u32,
    /// Closest the body came to any obstacle, metres (0 = contact).
    pub min_clearance_m: f64,
    /// Distance walked, metres.
    pub path_m: f64,
    /// Reaction time of this walk, seconds.
    pub reaction_s: f64,
    /// Where the user ended.
    pub end_xy_m: [f64; 2],
    /// Whether the world has a way through from the start to the goal for a 0.5 m wide
    /// body ([`World::way_through`]; `None`: not searched).
    pub way_through: Option<bool>,
    /// With the predictive cue or the spoken guide on the filter's pose: the filter's
    /// errors over the frames it tracked.
    pub localization: Option<TrackedError>,
    /// With the spoken guide: utterances heard to their end, and of them the prompts to
    /// come back to the route ("Off the route: ...").
    pub heard: Option<(u32, u32)>,
    /// With the spoken guide: utterances the user never heard to their end (dropped
    /// unspoken by the feedback agent's speech queue, or cut off; not a duplicate of
    /// one said), and of them the turns to make "now".
    pub missed: Option<(u32, u32)>,
    /// With the spoken guide: metres walked while guidance could not take the place the
    /// device believed (told "position uncertain", or waiting for a first position), and
    /// the longest such stretch walked, metres.
    pub unguided_m: Option<(f64, f64)>,
    /// With the spoken guide: ways round what the camera found (`--ways-round`): laid,
    /// looked for without one found, and found but within a sidestep of the route.
    pub ways_round: Option<(u64, u64, u64)>,
    /// With the predictive cue learning the user's turning rate (`--cue-model learnt`):
    /// the rate its model had learnt by the walk's end, degrees per second (`None`:
    /// not learnt, or too little turning on a rumble to learn it).
    pub learnt_turn_rate_deg_s: Option<f64>,
    /// One row per camera frame when [`WalkConfig::trace`] asked for it.
    #[serde(skip)]
    pub trace: Vec<TraceRow>,
}

impl WalkOutcome {
    /// One utterance the user did not hear to its end (`missed`).
    fn count_missed(&mut self, text: &str) {
        if let Some((missed, turns_now)) = self.missed.as_mut() {
            *missed += 1;
            if text.ends_with(" now.") {
                *turns_now += 1;
            }
        }
    }

    /// Contacts of one part, optionally only those in (`Some(true)`) or out of view.
    pub fn count(&self, part: Part, in_fov: Option<bool>) -> usize {
        self.contacts.iter().filter(|c| c.part == part && in_fov.is_none_or(|v| c.in_fov == v)).count()
    }

    /// "goal reached", "goal not reached", or, when the world has no way through, why
    /// not.
    pub fn verdict(&self) -> &'static str {
        match (self.completed, self.way_through) {
            (true, _) => "goal reached",
            (false, Some(false)) => "goal not reached: there is no way through (0.5 m wide) from the start to the goal",
            (false, _) => "goal not reached",
        }
    }
}

/// The camera's floor frame as a pose (where the perception's user frame sits).
fn camera_floor(camera: &CameraPose) -> UserPose {
    UserPose { x_m: camera.position_m.x, y_m: camera.position_m.y, yaw_rad: camera.yaw_rad(), floor: camera.floor }
}

/// A frame as the sensor agent sends this walk's camera: its size, intrinsics, depth
/// unit, codec and mount guess; samples and gravity filled by [`pack`] each frame.
fn wire_frame(config: &WalkConfig, renderer: &Renderer, mount: MountGuess) -> DepthFrame {
    DepthFrame {
        width: config.camera.width,
        height: config.camera.height,
        depth_scale_m: 1.0 / DEPTH_UNITS_PER_M,
        intrinsics: renderer.intrinsics(),
        gravity_camera: None,
        mount: Some(mount),
        encoding: config.bounded_mm.map_or(DepthEncoding::Raw, |step| DepthEncoding::Bounded { step }),
        data: Vec::new(),
    }
}

/// Gravity error of each frame, degrees per axis (an IMU attitude filter's).
const GRAVITY_NOISE_DEG: f64 = 0.5;

/// Packs `depth` into `wire` with the gravity of `camera` as an IMU would give it.
fn pack(depth: &[u16], camera: &CameraPose, gravity_rng: &mut SimRng, wire: &mut DepthFrame) {
    if schemas::depth_codec::encode(depth, wire.width, wire.height, wire.encoding, &mut wire.data).is_err() {
        // nothing to send: the step refuses the empty frame as the agent would
        wire.data.clear();
    }
    let g = camera.gravity_camera();
    wire.gravity_camera = Some(noisy_gravity(gravity_rng, GRAVITY_NOISE_DEG.to_radians(), g));
}

/// The second depth camera, worn at the chest: rendered where the body is, packed as
/// the sensor agent packs it (with its mount guess and a gravity as noisy as the
/// cane's), and perceived by a compute step of its own, moved by the odometry of the
/// body it turns with.
struct ChestCamera {
    mount: ChestMount,
    renderer: Renderer,
    step: ComputeStep,
    wire: DepthFrame,
    depth: Vec<u16>,
    depth_rng: SimRng,
    gravity_rng: SimRng,
    odometry: OdometryModel,
    last: Option<(UserPose, u64)>,
}

impl ChestCamera {
    fn new(mount: ChestMount, config: &WalkConfig, rng: &mut SimRng) -> Self {
        let renderer = Renderer::new(config.camera.clone());
        let guess = MountGuess { height_m: mount.height_m as f32, pitch_deg: mount.pitch_deg as f32 };
        let wire = wire_frame(config, &renderer, guess);
        Self {
            mount,
            renderer,
            step: ComputeStep::new(config.perception.for_chest(), config.cue.clone()),
            wire,
            depth: Vec::new(),
            depth_rng: rng.fork(),
            gravity_rng: rng.fork(),
            odometry: OdometryModel::new(OdometryNoise::default().scaled(config.odometry_noise), rng.fork()),
            last: None,
        }
    }

    /// The chest frame at `t`: its state and obstacle points for the cane's step to
    /// join (`None` while its refusals are too few to say it is blind; no points for a
    /// refused frame).
    fn frame(
        &mut self,
        world: &World,
        pose: &UserPose,
        t: f64,
        now: u64,
        seq: u64,
        body_yaw_rate_rad_s: Option<f32>,
    ) -> Option<(ViewState, &[[f32; 2]])> {
        let camera = self.mount.camera_pose(pose, 0.0);
        self.renderer.render(world, &camera, t, &mut self.depth_rng, &mut self.depth);
        pack(&self.depth, &camera, &mut self.gravity_rng, &mut self.wire);
        let floor_pose = camera_floor(&camera);
        if let Some((from, from_ns)) = self.last {
            let inc = self.odometry.increment(&from, &floor_pose, from_ns, now);
            if let Err(e) = self.step.add_odometry(&inc) {
                tracing::warn!("chest camera: {e}");
            }
        }
        self.last = Some((floor_pose, now));
        let input = FrameIn { data: FrameData::Wire(&self.wire), seq, capture_ns: now, body_yaw_rate_rad_s, way: None };
        match self.step.process(input, &mut NoTimer) {
            StepOutput::Perceived { hazard, .. } => Some((ViewState::of(&hazard, now), self.step.obstacle_points())),
            StepOutput::Refused { blind, .. } => blind.map(|b| (ViewState::of(&b.hazard, now), &[][..])),
        }
    }
}

/// Spacing of the body positions a line-of-sight check tests, metres.
const SIGHT_STEP_M: f64 = 0.1;

/// True when a body of `radius_m` can walk straight from `pose` to `to` past every
/// static shape of the floor that reaches below head height and that `map` holds, and
/// never over a drop-off.
fn walkable(world: &World, map: RouteMap, pose: &UserPose, to: [f64; 2], radius_m: f64) -> bool {
    let (dx, dy) = (to[0] - pose.x_m, to[1] - pose.y_m);
    let n = ((dx.hypot(dy) / SIGHT_STEP_M).ceil() as usize).max(1);
    let g = world.geometry(pose.floor);
    let on_map =
        |id: &ObstacleId| map == RouteMap::Full || world.obstacle(*id).is_some_and(|o| o.kind == ObstacleKind::Wall);
    (0..=n).all(|i| {
        let f = i as f64 / n as f64;
        let (x, y) = (pose.x_m + f * dx, pose.y_m + f * dy);
        g.boxes
            .iter()
            .filter(|(_, id)| on_map(id))
            .all(|(b, _)| Shape::Box(*b).body_distance_m(x, y, radius_m, 1.8) > 0.0)
            && g.cylinders
                .iter()
                .filter(|(_, id)| on_map(id))
                .all(|(c, _)| Shape::Cylinder(*c).body_distance_m(x, y, radius_m, 1.8) > 0.0)
            && g.drop_offs.iter().all(|(d, _)| Shape::DropOff(*d).body_distance_m(x, y, radius_m, 1.8) > radius_m)
    })
}

/// The user's knowledge of the floor is handed to the predictive cue this far around
/// them (either way along each axis), metres: past what a look-ahead reaches.
const KNOWN_NEAR_M: f64 = 4.5;

/// What the user knows stands on `floor` (what their route's `map` holds, as the
/// guide's line of sight takes it: walls, or every fixed shape, and level changes), as
/// points every 10 cm around each footprint, map metres.
fn known_points(world: &World, map: RouteMap, floor: i32) -> Vec<[f64; 2]> {
    let g = world.geometry(floor);
    let on_map =
        |id: &ObstacleId| map == RouteMap::Full || world.obstacle(*id).is_some_and(|o| o.kind == ObstacleKind::Wall);
    let mut out = Vec::new();
    let mut outline = |center: [f64; 2], half: [f64; 2], yaw: f64| {
        let (s, c) = yaw.sin_cos();
        let corners = [[-half[0], -half[1]], [half[0], -half[1]], [half[0], half[1]], [-half[0], half[1]]];
        for k in 0..4 {
            let (a, b) = (corners[k], corners[(k + 1) % 4]);
            let n = (((b[0] - a[0]).hypot(b[1] - a[1])) / 0.1).ceil().max(1.0) as usize;
            for i in 0..n {
                let f = i as f64 / n as f64;
                let (x, y) = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
                out.push([center[0] + c * x - s * y, center[1] + s * x + c * y]);
            }
        }
    };
    for (b, _) in g.boxes.iter().filter(|(b, id)| on_map(id) && b.bottom_m < 1.8) {
        outline(b.center_m, b.half_size_m, b.yaw_rad);
    }
    for (d, _) in &g.drop_offs {
        outline(d.center_m, d.half_size_m, d.yaw_rad);
    }
    for (cyl, _) in g.cylinders.iter().filter(|(c, id)| on_map(id) && c.bottom_m < 1.8) {
        let n = ((std::f64::consts::TAU * cyl.radius_m / 0.1).ceil() as usize).max(6);
        for i in 0..n {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            out.push([cyl.center_m[0] + cyl.radius_m * a.cos(), cyl.center_m[1] + cyl.radius_m * a.sin()]);
        }
    }
    out
}

/// The compute agent's particle filter on `world`'s floor plan, told where the walk
/// starts (the world's start, not this walk's jittered one); `None`, said in the log,
/// when the floor plan cannot be made or the start is not on it.
fn filter_for(world: &World, building: Result<&Building, &str>, seed: u64) -> Option<Tracker> {
    let start = world.start();
    let made = building
        .map_err(str::to_string)
        .and_then(|building| Tracker::new(building, TrackerConfig::default(), seed).map_err(|e| e.to_string()))
        .and_then(|mut tracker| {
            tracker
                .start_at(start.floor, Pose2::new(start.x_m, start.y_m, start.yaw_rad))
                .map_err(|e| e.to_string())?;
            Ok(tracker)
        });
    match made {
        Ok(tracker) => Some(tracker),
        Err(e) => {
            tracing::warn!("{}: no particle filter ({e}): the cost functions decide", world.name());
            None
        }
    }
}

/// The route the device knows: the one the guide keeps the user on (start, waypoints,
/// goal), or for a user heading for the goal's sound, the goal.
fn device_route(world: &World, config: &WalkConfig) -> Vec<[f64; 2]> {
    let (start, goal) = (world.start(), world.goal());
    let route = match config.route_map {
        RouteMap::Full => world.walker().map(|w| w.waypoints.clone()),
        RouteMap::FloorPlan => world.floor_plan_route().map(<[_]>::to_vec),
    };
    match (config.guide, route) {
        (GuideKind::Route, Some(points)) => {
            let mut route = vec![[start.x_m, start.y_m]];
            route.extend(points);
            route.push([goal.x_m, goal.y_m]);
            route
        }
        _ => vec![[goal.x_m, goal.y_m]],
    }
}

/// The predictive cue's model of `config`'s user and cane: the device is taken to have
/// learnt the user's walking speed, turning rate and reaction (each walk's user reacts
/// up to 25 % off it; give a config with the typical user for a device that has learnt
/// nothing), and to know its cane.
pub fn predictive_for(config: &WalkConfig) -> PredictiveConfig {
    let (u, m) = (&config.user, &config.mount);
    let reach_m = (m.cane_length_m.powi(2) - m.handle_height_m.powi(2)).max(0.0).sqrt();
    PredictiveConfig {
        user: UserModel {
            walk_speed_m_s: u.walk_speed_m_s,
            turn_walk_speed_m_s: u.turn_walk_speed_m_s,
            turn_rate_deg_s: u.turn_rate_deg_s,
            reaction_s: u.reaction_s,
            accel_m_s2: u.accel_m_s2,
            commit_s: u.commit_s,
            shoulder_width_m: u.shoulder_width_m,
            lookahead_m: config.lookahead_m(),
            ..UserModel::default()
        },
        cane: CaneModel {
            hand_forward_m: m.hand_forward_m,
            camera_from_hand_m: m.camera_below_handle_m * reach_m / m.cane_length_m.max(1e-6),
            reach_m,
            sweep_deg: m.sweep_amplitude_deg,
            sweep_hz: m.sweep_hz,
        },
        latency_s: config.latency_ms / 1000.0,
        goal_radius_m: config.goal_radius_m,
        ..PredictiveConfig::default()
    }
}

/// Where the device's guide takes the user to be: the simulator's place (`Truth`), or
/// the filter's estimate, confident while it tracks or follows the place from a known
/// one ([`localization::Estimate::guides`]; with no filter, nowhere).
fn guided_pose(tracker: Option<&Tracker>, source: PoseSource, pose: &UserPose) -> guidance::UserPose {
    match (tracker, source) {
        (_, PoseSource::Truth) => guidance::UserPose {
            x_m: pose.x_m,
            y_m: pose.y_m,
            heading_rad: pose.yaw_rad,
            floor: pose.floor,
            confident: true,
        },
        (Some(tracker), PoseSource::Filter) => {
            let e = tracker.estimate();
            guidance::UserPose {
                x_m: e.pose.x_m,
                y_m: e.pose.y_m,
                heading_rad: e.pose.heading_rad,
                floor: e.level,
                confident: e.guides(),
            }
        }
        (None, PoseSource::Filter) => guidance::UserPose {
            x_m: f64::NAN,
            y_m: f64::NAN,
            heading_rad: f64::NAN,
            floor: pose.floor,
            confident: false,
        },
    }
}

/// A guide for `kind` in `world`.
fn guide_for<'a>(
    kind: GuideKind,
    world: &'a World,
    map: RouteMap,
    radius_m: f64,
    lookahead_m: f64,
    ear: &Ear,
) -> Box<dyn Guide + 'a> {
    let goal = world.goal();
    if kind == GuideKind::Spoken {
        return Box::new(SpokenGuide::new(ear.clone(), spoken::profile(), GoalSound { x_m: goal.x_m, y_m: goal.y_m }));
    }
    let route = match map {
        RouteMap::Full => world.walker().map(|w| w.waypoints.clone()),
        RouteMap::FloorPlan => world.floor_plan_route().map(<[_]>::to_vec),
    };
    let start = world.start();
    let route = route.map(|mut points| {
        points.push([goal.x_m, goal.y_m]);
        RouteFollow::new([start.x_m, start.y_m], points, lookahead_m, move |p: &UserPose, to| {
            walkable(world, map, p, to, radius_m)
        })
    });
    match (kind, route) {
        (GuideKind::Route, Some(route)) => Box::new(route),
        (GuideKind::Assisted, Some(route)) => {
            let to = [goal.x_m, goal.y_m];
            Box::new(ExperimenterAssist::new(
                GoalSound { x_m: goal.x_m, y_m: goal.y_m },
                route,
                move |p: &UserPose| walkable(world, map, p, to, radius_m),
                STUCK_AFTER_S,
            ))
        }
        _ => Box::new(GoalSound { x_m: goal.x_m, y_m: goal.y_m }),
    }
}

/// A frame's outputs on their way to the feedback step: due time (s), hazard, intent
/// with its capture stamp.
type InFlight = (f64, Option<Hazard>, Option<(HapticIntent, u64)>);

/// Share of the full sweep at walking speed `speed_m_s`: the two-point touch technique
/// taps the cane left and right in step with the feet, so a user standing still (turning
/// in place, waiting) holds it ahead instead of sweeping; full sweep from half the
/// walking speed up.
pub(super) fn sweep_scale(speed_m_s: f64, params: &UserParams) -> f64 {
    (2.0 * speed_m_s / params.walk_speed_m_s.max(1e-6)).clamp(0.0, 1.0)
}

fn ns(t_s: f64) -> u64 {
    T0_NS + (t_s * 1e9).round() as u64
}

/// Walks `world` once with `seed` (start jitter, sweep phase, reaction time, sensor
/// noise, odometry errors all follow from it).
pub fn walk(world: &World, config: &WalkConfig, seed: u64) -> WalkOutcome {
    let mut w = Walk::new(world, config, seed);
    while w.step() {}
    w.finish()
}

/// One frame as the walk fed it to the compute agent's step (recorded with
/// [`Walk::record_frames`]): what a sensor agent would have published, and what the
/// step made of it.
#[derive(Debug, Clone, PartialEq)]
pub struct FedFrame {
    /// Odometry increments added to the step since the previous frame.
    pub odometry: Vec<OdomIncrement>,
    /// The depth frame, packed as on the wire.
    pub frame: DepthFrame,
    /// Its sequence number (the hazard's `frame_seq`).
    pub seq: u64,
    /// Its capture stamp, ns.
    pub capture_ns: u64,
    /// The hazard the step gave (`None`: the frame was refused).
    pub hazard: Option<Hazard>,
}

/// A walk in progress: [`Walk::step`] advances it by one physics step
/// (1 / [`PHYSICS_HZ`] s): a camera frame through the compute agent's step when one is
/// due, intents due through the feedback step to the hands, the user's reaction and
/// move, and the contacts that move makes.
pub struct Walk<'w> {
    world: &'w World,
    config: &'w WalkConfig,
    /// Physics steps taken.
    steps: u64,
    /// Physics steps before the time limit.
    limit: u64,
    frame_every: u64,
    latency_s: f64,
    depth_rng: SimRng,
    gravity_rng: SimRng,
    odometry: OdometryModel,
    mount: CaneMount,
    params: UserParams,
    body_gyro: Option<BodyGyro>,
    compass: Option<CompassModel>,
    chest: Option<ChestCamera>,
    user: VirtualUser,
    renderer: Renderer,
    frame_step: ComputeStep,
    wire: DepthFrame,
    depth: Vec<u16>,
    feedback: Feedback,
    felt: FeltRumble,
    body: Touching,
    /// Body distances at the user's committed position.
    body_now: Vec<f64>,
    cane: Touching,
    seen: SeenLog,
    radius_m: f64,
    guide: Box<dyn Guide + 'w>,
    target: Option<f64>,
    guided_at_s: f64,
    oracle: Option<Oracle>,
    seen_points: PointGrid,
    /// With the predictive cue: the route the device knows, and the way ahead.
    route_ahead: Option<RouteAhead>,
    way: Vec<[f64; 2]>,
    /// With `WalkConfig::ways_round`: what the perception holds, map frame.
    held_in_map: Vec<[f64; 2]>,
    /// What the user knows of the floor (the route map's walls and level changes) as
    /// points every 10 cm, map frame, and the floor they are of; near ones in the body
    /// frame.
    known: (Option<i32>, Vec<[f64; 2]>),
    known_near: Vec<[f64; 2]>,
    /// With the predictive cue or the spoken guide on the filter's pose: the filter, the
    /// camera's heading at the last frame (the cane gyro's rate between frames), and the
    /// squared position errors while it tracked.
    tracker: Option<Tracker>,
    last_camera_yaw: Option<(f64, f64)>,
    /// squared position error (m²), squared heading error (rad²), frames, frames more
    /// than 1 m off, and frames more than 45° off, summed while tracking
    tracked_error: (f64, f64, u32, u32, u32),
    /// With the spoken guide: the device's navigator, what it says this frame, and what
    /// the user heard and has not yet acted on.
    spoken: Option<SpokenDevice>,
    /// guidance takes the place the device believes now, and metres walked since it last
    /// did (spoken guide)
    guided_now: bool,
    unguided_run_m: f64,
    said: Vec<SpeechIntent>,
    ear: Ear,
    pending: VecDeque<InFlight>,
    last_floor: Option<(UserPose, u64)>,
    shown: Felt,
    felt_since: Option<f64>,
    away_since: Option<f64>,
    away_counted: bool,
    /// Frames fed to the compute agent's step, when recording.
    fed: Option<Vec<FedFrame>>,
    odometry_fed: Vec<OdomIncrement>,
    out: WalkOutcome,
}

impl<'w> Walk<'w> {
    /// The user at the (jittered) start of `world`, nothing felt yet.
    pub fn new(world: &'w World, config: &'w WalkConfig, seed: u64) -> Self {
        let mut rng = SimRng::seed_from(seed);
        let depth_rng = rng.fork();
        let gravity_rng = rng.fork();
        let odometry = OdometryModel::new(OdometryNoise::default().scaled(config.odometry_noise), rng.fork());
        let mut jitter = |half: f64| (2.0 * rng.uniform() - 1.0) * half;
        let start = world.start();
        let start = UserPose {
            x_m: start.x_m + jitter(config.start_jitter.0),
            y_m: start.y_m + jitter(config.start_jitter.0),
            yaw_rad: start.yaw_rad + jitter(config.start_jitter.1).to_radians(),
            floor: start.floor,
        };
        let mount = CaneMount { sweep_phase_rad: jitter(std::f64::consts::PI), ..config.mount };
        let params =
            UserParams { reaction_s: config.user.reaction_s * (1.0 + jitter(config.reaction_jitter)), ..config.user };
        // drawn after everything else, so a walk without it is the walk it always was
        let body_gyro = config.body_gyro.then(|| BodyGyro::new(rng.fork()));
        // its own stream: the same walk with and without it differs only by it
        let compass =
            config.compass.then(|| CompassModel::new(CompassNoise::default(), SimRng::seed_from(seed ^ COMPASS_SEED)));
        let chest = config.chest.map(|mount| ChestCamera::new(mount, config, &mut rng));

        let renderer = Renderer::new(config.camera.clone());
        // the compute agent's own frame step, fed frames as the sensor agent packs them
        let mut frame_step = ComputeStep::new(config.perception.clone(), config.cue.clone());
        if let Some(mount) = config.chest {
            frame_step = frame_step.with_second_view(SecondView::default().ahead_of_body(mount.forward_m as f32));
        }
        if let Some(p) = config.predictive {
            frame_step = frame_step.with_predictive(p);
        }
        // the mount the simulator's sensor agent sends with every frame
        let guess =
            MountGuess { height_m: config.mount.camera_height_m() as f32, pitch_deg: config.mount.pitch_deg as f32 };
        let wire = wire_frame(config, &renderer, guess);
        // the device's plan: the world's floor plan, as `wearnav map` exports it
        let spoken = config.guide == GuideKind::Spoken;
        let filter = config.pose == PoseSource::Filter && (config.predictive_on_route() || spoken);
        let building = (filter || spoken)
            .then(|| floor_plan::export(world, floor_plan::DEFAULT_RESOLUTION_M).map_err(|e| format!("{e:#}")));
        let building = building.as_ref().map(|b| b.as_ref().map_err(String::as_str));
        let mapped = (filter && config.localization_map != floor_plan::LocalizationMap::FloorPlan).then(|| {
            config
                .localization_map
                .export(world, floor_plan::DEFAULT_RESOLUTION_M, &config.perception)
                .map_err(|e| format!("{e:#}"))
        });
        let localization_map = match &mapped {
            Some(m) => Some(m.as_ref().map_err(String::as_str)),
            None => building,
        };
        let tracker = localization_map.filter(|_| filter).and_then(|b| filter_for(world, b, seed));
        let spoken = building.filter(|_| spoken).and_then(|b| {
            let made = b
                .map_err(|e| anyhow::anyhow!("{e}"))
                .and_then(|b| SpokenDevice::new(b, &floor_plan::goal_label(world)));
            made.map_err(|e| tracing::warn!("{}: no spoken guidance ({e:#}): the user hears nothing", world.name()))
                .ok()
        });
        // a voice for the spoken guide, timed as the agent's console voice (no sound made)
        let voices: Vec<Box<dyn SpeechEngine>> = match spoken {
            Some(_) => vec![Box::new(ConsoleSpeech::new(Box::new(std::io::sink()), SPEECH_WPM))],
            None => Vec::new(),
        };
        let feedback = Feedback::new(config.feedback.clone(), vec![Box::new(Hands::default())], voices, T0_NS);
        let ear = Ear::default();
        let n = world.obstacles().len();
        let mut body = Touching::new(n);
        let radius_m = params.shoulder_width_m / 2.0;
        body.measure(world, start.floor, 0.0, |s| s.body_distance_m(start.x_m, start.y_m, radius_m, params.height_m));
        let body_now = body.distance_m.clone();
        let out = WalkOutcome {
            seed,
            completed: false,
            time_s: config.timeout_s,
            signals: 0,
            offline_signals: 0,
            contacts: Vec::new(),
            reorientations: 0,
            assists: 0,
            perception_errors: 0,
            frames: 0,
            min_clearance_m: f64::INFINITY,
            path_m: 0.0,
            reaction_s: params.reaction_s,
            end_xy_m: [start.x_m, start.y_m],
            way_through: world.way_through(),
            localization: None,
            heard: (config.guide == GuideKind::Spoken).then_some((0, 0)),
            missed: (config.guide == GuideKind::Spoken).then_some((0, 0)),
            unguided_m: (config.guide == GuideKind::Spoken).then_some((0.0, 0.0)),
            ways_round: None,
            learnt_turn_rate_deg_s: None,
            trace: Vec::new(),
        };
        Self {
            world,
            config,
            steps: 0,
            limit: (config.timeout_s * PHYSICS_HZ as f64).ceil() as u64,
            frame_every: ((PHYSICS_HZ as f64 / config.camera.rate_hz).round() as u64).max(1),
            latency_s: config.latency_ms / 1000.0,
            depth_rng,
            gravity_rng,
            odometry,
            mount,
            params,
            body_gyro,
            compass,
            chest,
            user: VirtualUser::new(params, start),
            renderer,
            frame_step,
            wire,
            depth: Vec::new(),
            feedback,
            felt: FeltRumble::default(),
            body,
            body_now,
            cane: Touching::new(n),
            seen: SeenLog::new(n),
            radius_m,
            guide: guide_for(config.guide, world, config.route_map, radius_m, config.lookahead_m(), &ear),
            target: None,
            guided_at_s: 0.0,
            oracle: config.oracle.map(Oracle::new),
            seen_points: PointGrid::default(),
            // (the spoken guide's way is the navigator's route)
            route_ahead: (config.predictive_on_route() && config.guide != GuideKind::Spoken)
                .then(|| RouteAhead::new(device_route(world, config))),
            way: Vec::new(),
            held_in_map: Vec::new(),
            known: (None, Vec::new()),
            known_near: Vec::new(),
            tracker,
            last_camera_yaw: None,
            tracked_error: (0.0, 0.0, 0, 0, 0),
            spoken,
            guided_now: false,
            unguided_run_m: 0.0,
            said: Vec::new(),
            ear,
            pending: VecDeque::new(),
            last_floor: None,
            shown: Felt::None,
            felt_since: None,
            away_since: None,
            away_counted: false,
            fed: None,
            odometry_fed: Vec::new(),
            out,
        }
    }

    /// Keep every frame fed to the compute agent's step from now on ([`Walk::fed_frames`]).
    pub fn record_frames(&mut self) {
        self.fed.get_or_insert_with(Vec::new);
    }

    /// The frames fed to the compute agent's step since [`Walk::record_frames`].
    pub fn fed_frames(&self) -> &[FedFrame] {
        self.fed.as_deref().unwrap_or_default()
    }

    /// Where the user is now.
    pub fn pose(&self) -> UserPose {
        self.user.pose()
    }

    /// Advances the walk by one physics step; `false` once it is over (the goal
    /// reached, or the time limit).
    pub fn step(&mut self) -> bool {
        let dt = 1.0 / PHYSICS_HZ as f64;
        let t = self.steps as f64 * dt;
        let now = ns(t);
        let pose = self.user.pose();
        let goal = self.world.goal();
        if (pose.x_m - goal.x_m).hypot(pose.y_m - goal.y_m) <= self.config.goal_radius_m && pose.floor == goal.floor {
            self.out.completed = true;
            self.out.time_s = t;
            return false;
        }
        if self.steps == self.limit {
            // the limit: nothing more happens in this walk (arriving right at it counts)
            return false;
        }
        if self.steps.is_multiple_of(self.frame_every) {
            self.camera_frame(t, now, &pose);
        }
        self.feel(t, now);
        self.track_reorientation(t, &pose);
        if self.steps.is_multiple_of(GUIDE_EVERY) {
            self.target = self.guide.heading_target_rad(&pose, t);
            self.user.spin(self.guide.spin_rad_s());
            self.guided_at_s = t;
        }
        self.move_user(t, dt, &pose);
        self.steps += 1;
        true
    }

    /// What happened, once the walk is over.
    pub fn finish(mut self) -> WalkOutcome {
        self.out.assists = self.guide.assists();
        self.out.ways_round = self.spoken.as_ref().filter(|_| self.config.ways_round).map(SpokenDevice::detours);
        self.out.learnt_turn_rate_deg_s = self.frame_step.learnt_turn_rate_deg_s();
        if self.tracker.is_some() {
            let (pos2, head2, n, over, turned) = self.tracked_error;
            // never tracked: no error to give (NaN, `null` in JSON)
            let rms = |sum: f64| if n == 0 { f64::NAN } else { (sum / f64::from(n)).sqrt() };
            self.out.localization = Some(TrackedError {
                position_rmse_m: rms(pos2),
                heading_rmse_deg: rms(head2).to_degrees(),
                frames: n,
                frames_over_1m: over,
                frames_turned: turned,
            });
        }
        self.out
    }

    /// A camera frame: rendered, packed as the sensor agent packs it, through the
    /// compute agent's step (with the odometry since the last frame and the body's turn
    /// rate); its hazard and intent leave for the feedback step after the latency.
    fn camera_frame(&mut self, t: f64, now: u64, pose: &UserPose) {
        let (config, world) = (self.config, self.world);
        let sweep = self.mount.sweep_rad(t) * sweep_scale(self.user.speed_m_s(), &self.params);
        let camera = self.mount.camera_pose(pose, sweep);
        self.renderer.render(world, &camera, t, &mut self.depth_rng, &mut self.depth);
        self.seen.update(self.renderer.obstacle_ids(), &self.depth, t);
        self.out.frames += 1;
        pack(&self.depth, &camera, &mut self.gravity_rng, &mut self.wire);
        let wire = &self.wire;
        let floor_pose = camera_floor(&camera);
        let speed_fraction = self.user.speed_m_s() / self.params.walk_speed_m_s.max(1e-6);
        let body_yaw_rate_rad_s = self.body_gyro.as_mut().and_then(|gyro| gyro.read(t, pose.yaw_rad, speed_fraction));
        if let Some(chest) = self.chest.as_mut() {
            // the chest camera's frame, captured with the cane's, through its own step
            if let Some((state, points)) = chest.frame(world, pose, t, now, self.out.frames as u64, body_yaw_rate_rad_s)
            {
                self.frame_step.second_view_heard(state, points);
            }
            self.seen.update(chest.renderer.obstacle_ids(), &chest.depth, t);
        }
        if let Some((from, from_ns)) = self.last_floor {
            let inc = self.odometry.increment(&from, &floor_pose, from_ns, now);
            if let Err(e) = self.frame_step.add_odometry(&inc) {
                tracing::warn!("seed {}: {e}", self.out.seed);
            }
            if let Some(tracker) = self.tracker.as_mut() {
                // refused as the step refuses it: counted by the filter
                let _ = tracker.odometry(&inc, body_yaw_rate_rad_s.map(f64::from));
            }
            if self.fed.is_some() {
                self.odometry_fed.push(inc);
            }
        }
        if let (Some(compass), Some(tracker)) = (self.compass.as_mut(), self.tracker.as_mut()) {
            // the phone reports no accuracy (as a browser's deviceorientationabsolute)
            let north = sim::compass::SIM_NORTH_DEG.to_radians();
            if let Err(e) = tracker.compass(compass.read(pose.x_m, pose.y_m, pose.yaw_rad, north), None) {
                tracing::warn!("seed {}: {e}", self.out.seed);
            }
        }
        self.last_floor = Some((floor_pose, now));
        let seq = self.out.frames as u64;
        // where the device takes the user to be: the truth, or the filter while it tracks
        let believed = match (&self.tracker, config.pose) {
            (_, PoseSource::Truth) => Some(*pose),
            (Some(tracker), PoseSource::Filter) => {
                let e = tracker.estimate();
                (e.status == localization::Status::Tracking).then(|| {
                    let err2 = (e.pose.x_m - pose.x_m).powi(2) + (e.pose.y_m - pose.y_m).powi(2);
                    let head2 = localization::wrap_angle(e.pose.heading_rad - pose.yaw_rad).powi(2);
                    let (p, h, n, over, turned) = self.tracked_error;
                    let turned = turned + u32::from(head2 > TURNED_RAD * TURNED_RAD);
                    self.tracked_error = (p + err2, h + head2, n + 1, over + u32::from(err2 > 1.0), turned);
                    UserPose { x_m: e.pose.x_m, y_m: e.pose.y_m, yaw_rad: e.pose.heading_rad, floor: e.level }
                })
            }
            (None, PoseSource::Filter) => None,
        };
        if let Some(device) = self.spoken.as_mut() {
            // the guide speaks from where the device believes the user is
            let g = guided_pose(self.tracker.as_ref(), config.pose, pose);
            self.guided_now = g.confident;
            if g.confident {
                self.unguided_run_m = 0.0;
            }
            let news = self.tracker.as_mut().and_then(Tracker::news);
            let now_ms = (t * 1000.0) as u64;
            let awaiting = self.tracker.as_ref().filter(|_| config.pose == PoseSource::Filter);
            device.set_awaiting_word(awaiting.is_some_and(|t| t.estimate().awaits_word()));
            for asked in std::mem::take(&mut self.ear.borrow_mut().asked) {
                device.command(&asked, &g, now_ms, &mut self.said);
            }
            device.step(&g, news, now_ms, &mut self.said);
            for intent in self.said.drain(..) {
                // the guide's own intents are well formed; a refusal would be the queue's
                if let Err(e) = self.feedback.on_speech(&intent, now, now) {
                    tracing::warn!("seed {}: speech refused: {}", self.out.seed, e.reason);
                }
            }
        }
        let believed = believed.filter(|_| config.predictive_on_route());
        if let Some(at) = believed {
            if self.known.0 != Some(at.floor) {
                self.known = (Some(at.floor), known_points(world, config.route_map, at.floor));
            }
            let (s, c) = at.yaw_rad.sin_cos();
            self.known_near.clear();
            self.known_near.extend(self.known.1.iter().filter_map(|p| {
                let (dx, dy) = (p[0] - at.x_m, p[1] - at.y_m);
                (dx.abs() <= KNOWN_NEAR_M && dy.abs() <= KNOWN_NEAR_M).then(|| [c * dx + s * dy, -s * dx + c * dy])
            }));
        }
        let way = match (self.route_ahead.as_mut(), self.spoken.as_ref(), believed) {
            (Some(route), _, Some(at)) => {
                route.ahead(at.x_m, at.y_m, at.yaw_rad, &mut self.way);
                Some(Way {
                    points: &self.way,
                    ends_at_goal: route.ends_at_goal(self.way.len()),
                    walls: &self.known_near,
                })
            }
            // the spoken guide's route while it guides, as the compute agent hands it on
            (None, Some(device), Some(at)) => {
                let g = guidance::UserPose {
                    x_m: at.x_m,
                    y_m: at.y_m,
                    heading_rad: at.yaw_rad,
                    floor: at.floor,
                    confident: true,
                };
                let state = device.state(&g);
                (state.status == RouteStatus::Guiding).then(|| {
                    let ends_at_goal =
                        guidance::way_ahead(&g, &state, &self.known.1, &mut self.way, &mut self.known_near);
                    Way { points: &self.way, ends_at_goal, walls: &self.known_near }
                })
            }
            _ => None,
        };
        let cane_rate = self.last_camera_yaw.and_then(|(t0, yaw0)| {
            let dt = t - t0;
            (dt > 0.0).then(|| wrap_pi(floor_pose.yaw_rad - yaw0) / dt)
        });
        self.last_camera_yaw = Some((t, floor_pose.yaw_rad));
        let input = FrameIn { data: FrameData::Wire(wire), seq, capture_ns: now, body_yaw_rate_rad_s, way };
        let processed = match self.frame_step.process(input, &mut NoTimer) {
            StepOutput::Perceived { perception, hazard, intent } => {
                if let Some(tracker) = self.tracker.as_mut() {
                    tracker.frame(&perception.scan, now, cane_rate, body_yaw_rate_rad_s.map(f64::from));
                }
                if let Some(device) = self.spoken.as_mut().filter(|_| config.ways_round) {
                    // what the perception holds, placed where the device believes the camera is
                    let held = self.frame_step.obstacle_points();
                    let at = guided_pose(self.tracker.as_ref(), config.pose, pose);
                    let camera = match (&self.tracker, config.pose) {
                        (Some(tracker), PoseSource::Filter) => tracker.points_in_map(held, &mut self.held_in_map),
                        _ => {
                            let camera = [floor_pose.x_m, floor_pose.y_m];
                            localization::tracker::place_points(
                                camera,
                                floor_pose.yaw_rad,
                                held,
                                &mut self.held_in_map,
                            );
                            camera
                        }
                    };
                    device.perceived(&at, camera, &self.held_in_map, (t * 1000.0) as u64);
                }
                Ok((hazard, intent, perception.turn_ahead))
            }
            StepOutput::Refused { blind, .. } => Err(blind),
        };
        if let Some(fed) = self.fed.as_mut() {
            fed.push(FedFrame {
                odometry: std::mem::take(&mut self.odometry_fed),
                frame: self.wire.clone(),
                seq,
                capture_ns: now,
                hazard: processed.as_ref().ok().map(|(h, _, _)| h.clone()),
            });
        }
        let known = self.oracle_cue(t, &floor_pose, processed.is_ok());
        let latency_s = self.latency_s;
        let mut turn_ahead = false;
        let hazard = match processed {
            Ok((hazard, intent, ahead)) => {
                turn_ahead = ahead;
                let intent = known.unwrap_or(intent);
                self.pending.push_back((t + latency_s, Some(hazard.clone()), Some((intent, now))));
                Some(hazard)
            }
            Err(blind) => {
                self.out.perception_errors += 1;
                if let Some(intent) = known {
                    self.pending.push_back((t + latency_s, None, Some((intent, now))));
                } else if let Some(blind) = blind {
                    self.pending.push_back((t + latency_s, Some(blind.hazard), Some((blind.intent, now))));
                }
                None
            }
        };
        if config.trace {
            let forward_cost = hazard.as_ref().map_or(f32::NAN, |h| match h.active {
                schemas::CostFunction::Ficf => h.ficf.forward,
                schemas::CostFunction::Cacf => h.cacf.forward,
            });
            let estimate = self.tracker.as_ref().map(Tracker::estimate);
            self.out.trace.push(TraceRow {
                t_s: t,
                x_m: pose.x_m,
                y_m: pose.y_m,
                yaw_deg: pose.yaw_rad.to_degrees(),
                sweep_deg: sweep.to_degrees(),
                speed_m_s: self.user.speed_m_s(),
                rumble: hazard.as_ref().map(|h| h.rumble),
                felt: self.shown,
                nearest_m: hazard.as_ref().map_or(f32::NAN, |h| h.nearest_m),
                bearing_deg: hazard.as_ref().map_or(f32::NAN, |h| h.nearest_bearing_deg),
                ttc_s: hazard.as_ref().and_then(|h| h.ttc_s),
                forward_cost,
                clearance_m: self.body_now.iter().copied().fold(f64::INFINITY, f64::min),
                turn_ahead,
                estimate: estimate
                    .as_ref()
                    .map(|e| ([e.pose.x_m, e.pose.y_m, e.pose.heading_rad.to_degrees()], e.status)),
                estimate_guides: estimate.as_ref().is_some_and(localization::Estimate::guides),
            });
        }
    }

    /// With an oracle, its cue for this frame (`perceived`: the step took the frame, so
    /// what the perception holds is new).
    fn oracle_cue(&mut self, t: f64, floor_pose: &UserPose, perceived: bool) -> Option<HapticIntent> {
        let o = self.oracle.as_mut()?;
        let config = self.config;
        if perceived {
            // what the perception holds, into the map (a refused frame keeps the last)
            let (s, c) = floor_pose.yaw_rad.sin_cos();
            // only what the user could reach within the look-ahead
            let reach_m = (self.params.walk_speed_m_s * o.config().horizon_s + self.mount.cane_length_m + 0.5) as f32;
            self.seen_points.rebuild(
                self.frame_step.obstacle_points().iter().filter(|p| p[0].hypot(p[1]) <= reach_m).map(|&[x, y]| {
                    let (x, y) = (f64::from(x), f64::from(y));
                    [floor_pose.x_m + c * x - s * y, floor_pose.y_m + s * x + c * y]
                }),
            );
        }
        let goal = self.world.goal();
        let now = Now {
            t_s: t,
            user: &self.user,
            assumed: UserParams {
                turn_rate_deg_s: o.config().turn_rate_deg_s.unwrap_or(config.user.turn_rate_deg_s),
                ..config.user
            },
            guide: self.guide.as_ref(),
            target_rad: self.target,
            guide_every_s: GUIDE_EVERY as f64 * (1.0 / PHYSICS_HZ as f64),
            guided_at_s: self.guided_at_s,
            felt: self.shown,
            latency_s: self.latency_s,
            goal: ([goal.x_m, goal.y_m], config.goal_radius_m),
            seen: match o.config().sees {
                Sees::World => Seen::World(self.world),
                Sees::Perception => Seen::Points(&self.seen_points),
            },
        };
        let rumble = o.decide(&self.mount, &now);
        let nearest_m = self.body_now.iter().copied().fold(f64::INFINITY, f64::min) as f32;
        let p = Perception { rumble, ground: GroundState::Found, nearest_m, ..Perception::empty() };
        Some(cue(&p, &config.cue))
    }

    /// Intents due reach the feedback step; what it applies reaches the hands (with the
    /// device on), and the user feels it.
    fn feel(&mut self, t: f64, now: u64) {
        while self.pending.front().is_some_and(|(at, _, _)| *at <= t + 1e-9) {
            if let Some((_, hazard, intent)) = self.pending.pop_front() {
                if let Some(h) = hazard {
                    // the frame behind it was captured when its intent was made
                    let captured = intent.as_ref().map_or(now, |(_, capture_ns)| *capture_ns);
                    self.feedback.on_hazard(&h, captured, now);
                }
                if let Some((i, capture_ns)) = intent {
                    // intents from our own cue never carry NaN; a refusal would leave the motors as they are
                    let _ = self.feedback.on_haptic(&i, capture_ns, now);
                }
            }
        }
        self.feedback.tick(now);
        for a in self.feedback.drain_applied() {
            match &a.action {
                AppliedAction::SpeechStarted { .. } => self.ear.borrow_mut().speaking = true,
                AppliedAction::SpeechFinished { .. } => self.ear.borrow_mut().speaking = false,
                AppliedAction::SpeechInterrupted { text } => {
                    self.ear.borrow_mut().speaking = false;
                    self.out.count_missed(text);
                    // the device hears back what the voice did not finish, as the
                    // compute agent would on `feedback/applied`
                    if let Some(device) = self.spoken.as_mut() {
                        device.not_heard(text);
                    }
                }
                AppliedAction::SpeechDropped { text, reason } => {
                    if reason != "duplicate" {
                        self.out.count_missed(text);
                    }
                    if let Some(device) = self.spoken.as_mut() {
                        device.not_heard(text);
                    }
                }
                _ => {}
            }
            if let (AppliedAction::SpeechFinished { text }, Some((heard, prompts))) = (&a.action, &mut self.out.heard) {
                *heard += 1;
                if text.starts_with("Off the route") {
                    *prompts += 1;
                }
                self.ear.borrow_mut().heard.push_back(Heard { at_s: t + UNDERSTAND_S, text: text.clone() });
            }
            if self.config.rumble {
                self.felt.apply(&a);
            }
        }
        let state = self.felt.felt(now);
        if state != self.shown {
            match state {
                Felt::Left | Felt::Right | Felt::Both => self.out.signals += 1,
                Felt::Offline => self.out.offline_signals += 1,
                Felt::None => {}
            }
            if state == Felt::None {
                self.felt_since = None;
            } else if self.shown == Felt::None {
                self.felt_since = Some(t);
            }
            self.shown = state;
        }
        self.user.feel(t, state, self.felt.pulse_period_ms(now));
    }

    /// Reorientations: heading far off where the guide points for too long.
    fn track_reorientation(&mut self, t: f64, pose: &UserPose) {
        if self.target.is_some_and(|to| wrap_pi(to - pose.yaw_rad).abs() > AWAY_RAD) {
            let since = *self.away_since.get_or_insert(t);
            if !self.away_counted && t - since > REORIENT_AFTER_S {
                self.out.reorientations += 1;
                self.away_counted = true;
            }
        } else {
            self.away_since = None;
            self.away_counted = false;
        }
    }

    /// The user's proposed move, stopped by what the body touches; then the cane's
    /// touches at the new pose.
    fn move_user(&mut self, t: f64, dt: f64, pose: &UserPose) {
        let world = self.world;
        let (proposed, speed) = self.user.propose(t, dt, self.target);
        let t_next = t + dt;
        let (radius_m, height_m) = (self.radius_m, self.params.height_m);
        self.body.measure(world, proposed.floor, t_next, |s| {
            s.body_distance_m(proposed.x_m, proposed.y_m, radius_m, height_m)
        });
        let entering = self.body.entering();
        // the body cannot go deeper into anything it touches
        let blocking = self.body.distance_m.iter().zip(&self.body_now).position(|(&d, &was)| d <= TOUCH_M && d < was);
        let camera = self.mount.camera_pose(&proposed, self.mount.sweep_rad(t_next) * sweep_scale(speed, &self.params));
        // which side an obstacle is on: probe a little to the left and right of the body
        let on_left = |id: ObstacleId| {
            let (s, c) = proposed.yaw_rad.sin_cos();
            let probe = |side: f64| {
                obstacle_distance_m(world, id, proposed.floor, t_next, |sh| {
                    sh.body_distance_m(proposed.x_m - s * side, proposed.y_m + c * side, radius_m, height_m)
                })
            };
            probe(0.05) <= probe(-0.05)
        };
        for id in entering {
            let bottom_m = self.body.touch_bottom_m[id.0 as usize];
            let c = self.contact(id, Part::Body, t_next, &camera, bottom_m);
            self.out.contacts.push(c);
        }
        self.out.min_clearance_m = self.out.min_clearance_m.min(self.body.nearest_m());
        if let Some(i) = blocking {
            // the body stays where it was, but the turn goes on (a cylinder turning
            // in place never goes deeper into anything)
            self.user.commit(UserPose { yaw_rad: proposed.yaw_rad, ..*pose }, 0.0);
            self.user.stopped_by(t_next, on_left(ObstacleId(i as u32)));
        } else {
            let step_m = (proposed.x_m - pose.x_m).hypot(proposed.y_m - pose.y_m);
            self.out.path_m += step_m;
            if let (Some((total, longest)), false) = (self.out.unguided_m.as_mut(), self.guided_now) {
                self.unguided_run_m += step_m;
                *total += step_m;
                *longest = longest.max(self.unguided_run_m);
            }
            self.user.commit(proposed, speed);
            self.body_now.copy_from_slice(&self.body.distance_m);
        }
        let now_pose = self.user.pose();
        let sweep = self.mount.sweep_rad(t_next) * sweep_scale(self.user.speed_m_s(), &self.params);
        let (hand, tip) = self.mount.cane_segment(&now_pose, sweep);
        // Only "touching or not" is read from the cane's distances, so a shape whose
        // bounds are clear of the release distance keeps its lower bound.
        self.cane.measure(world, now_pose.floor, t_next, |s| cane_distance_m(s, hand, tip, RELEASE_M));
        for id in self.cane.entering() {
            let on_left = cane_touch_on_left(world, &self.mount, &now_pose, sweep, id, t_next);
            self.user.touch(Touch { t_s: t_next, on_left });
            let camera = self.mount.camera_pose(&now_pose, sweep);
            let bottom_m = self.cane.touch_bottom_m[id.0 as usize];
            let c = self.contact(id, Part::Cane, t_next, &camera, bottom_m);
            self.out.contacts.push(c);
        }
        self.out.end_xy_m = [now_pose.x_m, now_pose.y_m];
    }

    /// A contact of `part` with obstacle `id` at `t_s`, the camera at `camera`; the
    /// contact's lowest point at `touch_bottom_m` above the floor.
    fn contact(&self, id: ObstacleId, part: Part, t_s: f64, camera: &CameraPose, touch_bottom_m: f64) -> Contact {
        let obstacle = self.world.obstacle(id);
        Contact {
            t_s,
            part,
            obstacle: id.0,
            label: obstacle.map_or_else(String::new, |o| o.label.clone()),
            kind: obstacle.map_or_else(String::new, |o| format!("{:?}", o.kind)),
            in_fov: in_field_of_view(self.world, id, camera, &self.config.camera, t_s)
                || self.config.chest.is_some_and(|chest| {
                    let at = chest.camera_pose(&self.user.pose(), 0.0);
                    in_field_of_view(self.world, id, &at, &self.config.camera, t_s)
                }),
            seen_ago_s: self.seen.ago_s(id, t_s),
            warned_ago_s: self.felt_since.map(|since| t_s - since),
            head_high: touch_bottom_m > self.mount.handle_height_m,
        }
    }
}

/// Whether obstacle `id`, touched by the cane, is on the user's left: where the swept
/// tip is; with the cane held still (standing, turning in place), the side the cane
/// reaches deeper into it when turned a little.
fn cane_touch_on_left(world: &World, mount: &CaneMount, pose: &UserPose, sweep: f64, id: ObstacleId, t_s: f64) -> bool {
    if sweep != 0.0 {
        return sweep > 0.0;
    }
    let distance = |turn: f64| {
        let (hand, tip) = mount.cane_segment(pose, turn);
        obstacle_distance_m(world, id, pose.floor, t_s, |sh| sh.segment_distance_m(hand, tip))
    };
    distance(CANE_PROBE_RAD) <= distance(-CANE_PROBE_RAD)
}

/// Smallest `distance` to any shape of obstacle `id` on `floor` at `t_s`, metres.
fn obstacle_distance_m(world: &World, id: ObstacleId, floor: i32, t_s: f64, distance: impl Fn(&Shape) -> f64) -> f64 {
    world.obstacles_at(floor, t_s).filter(|(i, _)| *i == id).map(|(_, sh)| distance(&sh)).fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_still_cane_tells_the_side_of_what_it_touched() {
        // a wall along the user's right, its face where the still cane's tip is
        let w = World::from_toml(
            "name = \"t\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 5.0, y_m = 0.0 }\n\
             [[walls]]\nlabel = \"right\"\nfrom = [0.5, -0.05]\nto = [0.5, -2.0]\n",
            "t",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let mount = CaneMount::default();
        // facing +x, the tip 1.08 m ahead: the wall's end at x 0.45-0.55 runs from the
        // cane's line to the right
        let pose = UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: -0.05, floor: 0 };
        let id = ObstacleId(0);
        assert!(!cane_touch_on_left(&w, &mount, &pose, 0.0, id, 0.0), "the wall is on the right");
        let mirrored = World::from_toml(
            "name = \"t\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 5.0, y_m = 0.0 }\n\
             [[walls]]\nlabel = \"left\"\nfrom = [0.5, 0.05]\nto = [0.5, 2.0]\n",
            "t",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(cane_touch_on_left(&mirrored, &mount, &UserPose { yaw_rad: 0.05, ..pose }, 0.0, id, 0.0));
        // swept, the tip's side says it
        assert!(cane_touch_on_left(&w, &mount, &pose, 0.1, id, 0.0));
        assert!(!cane_touch_on_left(&mirrored, &mount, &pose, -0.1, id, 0.0));
    }

    #[test]
    fn route_guidance_calls_turns_earlier_for_a_user_who_turns_wider() {
        let user = UserParams::default();
        assert_eq!(route_lookahead_m(&user), ROUTE_LOOKAHEAD_M);
        // 1 m/s at 30°/s: a turning radius of 1.91 m
        let wide = UserParams { turn_rate_deg_s: 30.0, ..user };
        assert!((route_lookahead_m(&wide) - 1.5 / 30f64.to_radians()).abs() < 1e-12);
        // slower walking turns tighter again
        let careful = UserParams { walk_speed_m_s: 0.5, ..wide };
        assert_eq!(route_lookahead_m(&careful), ROUTE_LOOKAHEAD_M);
    }
}
