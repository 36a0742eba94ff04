//! Every message body of the key space, one struct per schema.
//!
//! Frames are named in field names: `camera` (optical: x right, y down, z forward),
//! `user` (x forward, y left, z up, origin on the floor under the user) and `map`.
//! Units are in names (`_m`, `_ns`, `_deg`, `_rad`, `_ms`). Angles in the user frame
//! are positive to the left (counter-clockwise seen from above).
//!
//! Layout on the wire is bincode's legacy layout (see `wire`), so field order here *is*
//! the wire format: reorder nothing without bumping the schema version, and mirror any
//! change in `schemas/python/wearnav_schemas/messages.py` (the golden vectors catch drift).

use serde::{Deserialize, Serialize};

/// Pinhole intrinsics of an organized depth image, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length along x.
    pub fx: f32,
    /// Focal length along y.
    pub fy: f32,
    /// Principal point x.
    pub cx: f32,
    /// Principal point y.
    pub cy: f32,
}

impl Intrinsics {
    /// True when every parameter is finite and the focal lengths are positive.
    pub fn is_valid(&self) -> bool {
        [self.fx, self.fy, self.cx, self.cy].iter().all(|v| v.is_finite()) && self.fx > 0.0 && self.fy > 0.0
    }
}

/// How the depth samples of a [`DepthFrame`] are packed (see `depth_codec`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum DepthEncoding {
    /// Little-endian u16 samples, uncompressed.
    Raw,
    /// Lossless compression; decodes to the exact samples.
    Lossless,
    /// Samples quantised to `step` depth units, so each is within `step / 2` of the truth.
    Bounded {
        /// Quantisation step in depth units (not metres).
        step: u16,
    },
}

/// Where the camera is believed to sit on the cane: a guess the perception may refine.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MountGuess {
    /// Camera height above the floor, metres.
    pub height_m: f32,
    /// Downward pitch of the optical axis below horizontal, degrees.
    pub pitch_deg: f32,
}

/// Highest camera a mount guess may give, metres.
pub const MAX_MOUNT_HEIGHT_M: f32 = 3.0;

impl MountGuess {
    /// Whether a cane could give this: a height above 0 and at most
    /// [`MAX_MOUNT_HEIGHT_M`], a pitch within -90 to 90 degrees (the perception looks
    /// for the floor around the height: a camera below the floor or out of reach of any
    /// cane would hide the floor or invent one).
    pub fn check(&self) -> Result<(), String> {
        let (h, p) = (self.height_m, self.pitch_deg);
        if !(h.is_finite() && h > 0.0 && h <= MAX_MOUNT_HEIGHT_M) {
            return Err(format!("mount height {h} m is not above 0 and at most {MAX_MOUNT_HEIGHT_M} m"));
        }
        if !(p.is_finite() && p.abs() <= 90.0) {
            return Err(format!("mount pitch {p} deg is not within -90 to 90"));
        }
        Ok(())
    }
}

/// One organized depth image from a cane camera, compressed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DepthFrame {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Metres per depth unit (0.001 for millimetres, 0.0002 for TUM's 5000 per metre).
    pub depth_scale_m: f32,
    /// Pinhole intrinsics.
    pub intrinsics: Intrinsics,
    /// Gravity direction in the camera frame (unit, pointing down towards the floor),
    /// from the IMU at capture time, when the device has one.
    pub gravity_camera: Option<[f32; 3]>,
    /// Mounting guess (extrinsics prior).
    pub mount: Option<MountGuess>,
    /// Packing of `data`.
    pub encoding: DepthEncoding,
    /// Packed samples, row-major; 0 means invalid.
    pub data: Vec<u8>,
}

/// One IMU reading in the device frame (camera optical frame for a cane camera).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ImuSample {
    /// Sample time, nanoseconds on the sender's clock (same clock as capture stamps).
    pub stamp_ns: u64,
    /// Angular rate, rad/s.
    pub gyro_rad_s: [f32; 3],
    /// Specific force, m/s^2 (at rest: 9.81 pointing away from the floor).
    pub accel_m_s2: [f32; 3],
}

/// A batch of IMU samples (100-200 Hz sensors are sent in batches).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuBatch {
    /// Samples in time order.
    pub samples: Vec<ImuSample>,
}

/// Planar motion of the user between two stamps, in the user frame at `from_ns`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OdomIncrement {
    /// Start of the interval, ns.
    pub from_ns: u64,
    /// End of the interval, ns.
    pub to_ns: u64,
    /// Forward translation, metres.
    pub forward_m: f32,
    /// Leftward translation, metres.
    pub left_m: f32,
    /// Heading change, radians, positive to the left.
    pub yaw_rad: f32,
}

/// Ground-truth pose from the simulator (tests and monitors only; never for guidance).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GroundTruth {
    /// User position on the map, metres.
    pub x_m: f32,
    /// User position on the map, metres.
    pub y_m: f32,
    /// User heading on the map, radians (0 = +x, positive counter-clockwise).
    pub yaw_rad: f32,
    /// Floor index.
    pub floor: i32,
    /// Camera height above the floor, metres.
    pub camera_height_m: f32,
    /// Camera pitch below horizontal, degrees.
    pub camera_pitch_deg: f32,
    /// Cane sweep angle relative to the heading, degrees, positive left.
    pub sweep_deg: f32,
}

/// Nearest-point scan: the closest obstacle range in each angular bin, user frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scan {
    /// Bearing of the first bin's centre, degrees (negative = right).
    pub angle_min_deg: f32,
    /// Bin width, degrees.
    pub angle_increment_deg: f32,
    /// Horizontal range to the nearest obstacle point per bin, metres; `f32::INFINITY`
    /// when the bin saw nothing within `range_max_m`.
    pub ranges_m: Vec<f32>,
    /// Largest range the sensor is trusted to.
    pub range_max_m: f32,
}

/// Left / forward / right cost triple of one cost function.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SideCosts {
    /// Cost of obstacles on the left.
    pub left: f32,
    /// Cost of obstacles straight ahead.
    pub forward: f32,
    /// Cost of obstacles on the right.
    pub right: f32,
}

/// Taylor's two cost functions (thesis eq. 2.11-2.15).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CostFunction {
    /// Fully-Integrated Cost Function.
    Ficf,
    /// Cushioned Avoidance Cost Function.
    Cacf,
}

/// The 4-state rumble of Taylor's Table 2.1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Rumble {
    /// Path clear: go straight.
    None,
    /// Obstacle on the right: rumble left, turn left.
    Left,
    /// Obstacle on the left: rumble right, turn right.
    Right,
    /// Blocked: stop and turn in place.
    Both,
}

/// Whether the perception is actually seeing the floor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GroundState {
    /// Ground plane found in this frame.
    Found,
    /// Ground not found in this frame; the previous plane is used.
    Lost,
    /// Ground lost for several frames: the output must not be trusted as "clear".
    Degraded,
}

/// Time spent in one perception stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageLatency {
    /// Stage name (`decode`, `ground_plane`, `nearest_scan`, ...).
    pub stage: String,
    /// Duration, microseconds.
    pub us: u32,
}

/// Obstacle hazard of one depth frame: what the rumble should say and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hazard {
    /// Sequence number of the depth frame this came from.
    pub frame_seq: u64,
    /// Fully-Integrated costs.
    pub ficf: SideCosts,
    /// Cushioned Avoidance costs.
    pub cacf: SideCosts,
    /// The cost function driving `rumble`.
    pub active: CostFunction,
    /// Rumble state after hysteresis.
    pub rumble: Rumble,
    /// Ground state.
    pub ground: GroundState,
    /// Ground plane in the camera frame, `[a, b, c, d]` with unit normal pointing up.
    pub plane_camera: [f32; 4],
    /// Nearest obstacle range in the scan, metres (`INFINITY` if none).
    pub nearest_m: f32,
    /// Bearing of the nearest obstacle, degrees, positive left.
    pub nearest_bearing_deg: f32,
    /// Time to collision with the nearest approaching obstacle, seconds.
    pub ttc_s: Option<f32>,
    /// A drop-off or step down ahead.
    pub dropoff_ahead: bool,
    /// The rumble warns of what lies the way the body is turning: along the camera's
    /// heading the path was clear (the costs above are those along the heading).
    pub turn_ahead: bool,
    /// The body's turn rate perception was given, degrees/s positive left (from a
    /// body-worn IMU); `None`: none heard lately, the costs look along the camera only.
    pub body_turn_deg_s: Option<f32>,
    /// The rumble comes from where the user heads (the route followed and the position
    /// tracked: the predictive cue); false: from the cost function `active` (no route,
    /// the position not tracked, or the cue off).
    pub predictive: bool,
    /// The frame carried the camera's gravity (its IMU): the floor was searched level
    /// with it, lower ground looked for across the whole view, and the floor predicted
    /// from it while a near wall hides the floor. false: a camera without one: the floor
    /// is searched around the camera's down axis or the last floor found, lower ground
    /// only along the path ahead, and a near wall that hides the floor means "detection
    /// degraded" (the feedback agent tells the user).
    pub gravity: bool,
    /// Per-stage latency of this frame.
    pub latency: Vec<StageLatency>,
}

impl Hazard {
    /// A frame where nothing is in the way: no costs, no rumble, the floor in `ground`
    /// state, 1.2 m below a level camera. What a test or a tool sends to keep a feedback
    /// agent's watchdog fed.
    pub fn nothing_ahead(frame_seq: u64, ground: GroundState) -> Self {
        Hazard {
            frame_seq,
            ficf: SideCosts::default(),
            cacf: SideCosts::default(),
            active: CostFunction::Ficf,
            rumble: Rumble::None,
            ground,
            plane_camera: [0.0, -1.0, 0.0, 1.2],
            nearest_m: f32::INFINITY,
            nearest_bearing_deg: 0.0,
            ttc_s: None,
            dropoff_ahead: false,
            turn_ahead: false,
            predictive: false,
            body_turn_deg_s: None,
            gravity: true,
            latency: vec![],
        }
    }
}

/// Pose on the floor map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Map x, metres.
    pub x_m: f32,
    /// Map y, metres.
    pub y_m: f32,
    /// Heading, radians (0 = +x, counter-clockwise).
    pub yaw_rad: f32,
    /// Floor index.
    pub floor: i32,
    /// Row-major 3x3 covariance of (x, y, yaw).
    pub covariance: [f32; 9],
    /// How far the estimate can be trusted.
    pub status: LocalizationStatus,
    /// Route guidance takes this place: while `Tracking`, or while `Converging` when the
    /// estimate is followed from a known place (a told start, a gateway's stop, a
    /// `Tracking` estimate) and every correction since met `Tracking`'s conditions but
    /// the streak of them. Never while `Lost`.
    pub guides: bool,
}

/// Where the scan's frame is on the map at one frame's capture (`localization/camera`):
/// the camera's floor frame (the scan's: on the floor below the camera, x along its
/// view, y to the left), placed by the localization estimate of then, the cane's reach
/// from the hand and its sweep. A recording's viewer draws the scan and the point cloud
/// on the map with it; nothing steers by it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraPlace {
    /// Map x of the point on the floor below the camera, metres.
    pub x_m: f32,
    /// Map y of that point, metres.
    pub y_m: f32,
    /// The camera's view on the map, radians (0 = +x, counter-clockwise): the scan's
    /// bearing 0.
    pub yaw_rad: f32,
    /// Floor index.
    pub floor: i32,
    /// The localization status of the estimate it was placed from.
    pub status: LocalizationStatus,
}

/// How far a [`Pose`] can be trusted; route guidance acts on it where [`Pose::guides`]
/// says so.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LocalizationStatus {
    /// The estimate is one tight cluster: position known to a few decimetres.
    Tracking,
    /// Several hypotheses or a wide one: walking on narrows it down.
    Converging,
    /// The map no longer explains what the sensors see: recovery is running.
    Lost,
}

/// A point on the map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MapPoint {
    /// Map x, metres.
    pub x_m: f32,
    /// Map y, metres.
    pub y_m: f32,
    /// Floor index.
    pub floor: i32,
}

/// Progress along the current route.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RouteState {
    /// Destination label, empty when no route is active.
    pub destination: String,
    /// Next waypoint, if a route is active.
    pub next_waypoint: Option<MapPoint>,
    /// Remaining distance, metres.
    pub distance_left_m: f32,
    /// The instruction last given ("turn left in 3 metres").
    pub instruction: String,
    /// Floor the next waypoint is on (the user's floor when no route is active).
    pub floor: i32,
    /// Where guidance stands.
    pub status: RouteStatus,
    /// The route still ahead, from the user's place to the destination, smoothed (the
    /// points where the walk turns, and every gateway stop).
    pub route: Vec<MapPoint>,
}

/// Where route guidance stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum RouteStatus {
    /// No destination.
    Idle,
    /// A destination is set, but the position is not known well enough to guide.
    WaitingForPosition,
    /// Guiding along the route.
    Guiding,
    /// At a gateway (elevator, stairs): waiting for the user to confirm the floor.
    WaitingForFloor,
    /// The destination is reached.
    Arrived,
    /// No way to the destination from here.
    Unreachable,
    /// A route planned on request (`query/route`), not being followed.
    Preview,
}

/// Shape of a haptic cue.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum HapticPattern {
    /// Continuous rumble.
    Steady,
    /// On/off pulses; the rate carries distance (faster = nearer).
    Pulses {
        /// Full period of one pulse, milliseconds.
        period_ms: u32,
        /// Fraction of the period the motor is on, 0..1.
        duty: f32,
    },
}

/// Device-neutral haptic intent: the feedback agent maps it to whatever devices exist.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HapticIntent {
    /// Left actuator level, 0..1.
    pub left: f32,
    /// Right actuator level, 0..1.
    pub right: f32,
    /// Pattern.
    pub pattern: HapticPattern,
    /// Time to live from the capture stamp; a device stops when it expires.
    pub ttl_ms: u32,
}

/// Speech priority, with speech-dispatcher's SSIP semantics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Priority {
    /// Imminent obstacle: spoken at once, never interrupted.
    Important,
    /// Turns: not interrupted by its own kind.
    Message,
    /// Landmarks: only the newest is kept.
    Text,
    /// Dropped by anything higher.
    Notification,
    /// Dropped by anything higher.
    Progress,
}

/// Something to say to the user.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpeechIntent {
    /// The words.
    pub text: String,
    /// Priority.
    pub priority: Priority,
    /// Cut off what is being spoken (subject to the priority rules).
    pub interrupt: bool,
    /// Drop the utterance if it cannot start within this time of its capture stamp.
    pub ttl_ms: u32,
    /// Utterances with the same non-empty key are not repeated within the dedup window.
    pub dedup_key: String,
    /// Announce it with a short, light double tap where a device can (route guidance
    /// the user did not ask for); never while an obstacle cue or an alert is on.
    pub notice: bool,
}

/// What a feedback device actually did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum AppliedAction {
    /// Rumble levels now in force on a device.
    Rumble {
        /// Left level, 0..1.
        left: f32,
        /// Right level, 0..1.
        right: f32,
        /// Pattern being played.
        pattern: HapticPattern,
    },
    /// An utterance began playing.
    SpeechStarted {
        /// The words.
        text: String,
        /// Priority.
        priority: Priority,
    },
    /// An utterance played to its end.
    SpeechFinished {
        /// The words.
        text: String,
    },
    /// An utterance was cut off.
    SpeechInterrupted {
        /// The words cut off.
        text: String,
    },
    /// An utterance was never spoken (stale, duplicate, dropped by a higher priority).
    SpeechDropped {
        /// The words.
        text: String,
        /// Why.
        reason: String,
    },
    /// Obstacle detection went offline (`offline == true`) or came back.
    OfflineWarning {
        /// True when going offline.
        offline: bool,
        /// What went stale.
        reason: String,
    },
    /// Device came, went, or reported its state (battery, errors).
    DeviceStatus {
        /// Human-readable status.
        text: String,
    },
}

/// One action a feedback device performed, with the stamps that time it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Applied {
    /// Device that did it (`console`, `wiimote-left`, `espeak`, `phone`).
    pub device: String,
    /// What it did.
    pub action: AppliedAction,
    /// When the device was driven, ns (wall clock, same epoch as capture stamps).
    pub applied_ns: u64,
    /// Capture stamp of the intent whose arrival caused it; 0 when the agent's own
    /// timing did (pulse edges, TTL expiry, offline alerts, device news).
    pub cause_capture_ns: u64,
}

/// A user command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Start guidance to a named destination.
    Destination {
        /// Destination label.
        label: String,
    },
    /// Say where I am.
    WhereAmI,
    /// Mute or unmute speech (warnings still sound).
    Mute {
        /// True to mute.
        muted: bool,
    },
    /// Repeat the last instruction.
    Repeat,
    /// Stop guidance (the destination is forgotten).
    Cancel,
    /// The user says which floor they are on (after an elevator or stairs).
    Floor {
        /// Floor index.
        floor: i32,
    },
    /// The user is at a door and says its number (read on its tactile or printed
    /// sign): a landmark for localization (Zhang et al.'s "verify door number").
    Door {
        /// The number as on the sign ("214", "B1.07"), at most
        /// [`crate::wire::MAX_DOOR_NUMBER_CHARS`] characters.
        number: String,
    },
    /// The user says where they are by a place's name on the map ("room 204", "the
    /// lobby"), as someone nearby told them or as they know it: a landmark for
    /// localization, looser than a door's (the user is somewhere near that place).
    Place {
        /// The place's label, as for [`Command::Destination`], at most
        /// [`crate::wire::MAX_PLACE_LABEL_CHARS`] characters.
        label: String,
    },
}

impl Command {
    /// The `cmd/<verb>` chunk this command is published under.
    pub fn verb(&self) -> &'static str {
        match self {
            Command::Destination { .. } => "destination",
            Command::WhereAmI => "where-am-i",
            Command::Mute { .. } => "mute",
            Command::Repeat => "repeat",
            Command::Cancel => "cancel",
            Command::Floor { .. } => "floor",
            Command::Door { .. } => "door",
            Command::Place { .. } => "place",
        }
    }
}

/// A place guidance can take the user to (`query/destinations`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Destination {
    /// Label the user says or picks ("room 204").
    pub label: String,
    /// Where it is.
    pub at: MapPoint,
}

/// Every destination of the loaded map, sorted by floor then label.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Destinations {
    /// The destinations.
    pub destinations: Vec<Destination>,
}

/// What the phone page is asked to vibrate (`phone/haptic`, from the feedback agent's
/// phone backend through the phone bridge). The phone has one motor: the side is
/// carried by the rhythm (docs/phone.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhoneHaptic {
    /// Request number; the page acknowledges it by this id.
    pub id: u64,
    /// `navigator.vibrate` pattern: on, off, on... milliseconds; `[0]` stops.
    pub pattern_ms: Vec<u32>,
    /// Left level it stands for, 0..1 (for monitors).
    pub left: f32,
    /// Right level it stands for, 0..1.
    pub right: f32,
}

/// What the phone page is asked to say, or to stop saying (`phone/speech`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum PhoneSpeech {
    /// Speak `text` (`speechSynthesis`).
    Say {
        /// Request number; the page acknowledges it by this id.
        id: u64,
        /// The words.
        text: String,
        /// Priority (for the page's display; the feedback agent already ordered it).
        priority: Priority,
        /// Cut off whatever the page is saying first.
        interrupt: bool,
    },
    /// Stop the utterance `id` at once.
    Cut {
        /// The `Say` request to stop.
        id: u64,
    },
}

/// What the phone page did with a request.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum PhoneEvent {
    /// `navigator.vibrate` was called (or a beep played where the browser cannot vibrate).
    Vibrated,
    /// The utterance began.
    Started,
    /// The utterance played to its end.
    Ended,
    /// The utterance was cut off.
    Interrupted,
    /// The page could not do it.
    Failed {
        /// Why, as the browser said.
        reason: String,
    },
}

/// The phone page's acknowledgement of one request (`phone/ack`, from the bridge).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhoneAck {
    /// The request's id.
    pub id: u64,
    /// What happened.
    pub event: PhoneEvent,
    /// When, ns since the epoch on the bridge's clock (the page's own time with the
    /// page's clock offset, measured by the bridge, taken out).
    pub at_ns: u64,
}

/// The phone's own sensors (`sensor/phone/motion`): compass heading and steps.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PhoneMotion {
    /// Compass heading, degrees clockwise from magnetic north, 0..360; `None` until
    /// the phone gave one.
    pub heading_deg: Option<f32>,
    /// The heading's accuracy as the phone reports it, degrees.
    pub accuracy_deg: Option<f32>,
    /// Steps counted by the page since it loaded.
    pub steps: u64,
}

/// One barometer reading (`sensor/<device>/pressure`): the air's pressure where the
/// device is worn. What it measures is height: about 12 Pa a metre near sea level, so a
/// storey is some 35 Pa; the weather moves it too, slowly (up to about 100 Pa an hour).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pressure {
    /// Sample time, nanoseconds on the sender's clock (the clock of its other stamps).
    pub stamp_ns: u64,
    /// Static air pressure, pascals.
    pub pressure_pa: f32,
}

/// Counters of one stream an agent publishes or subscribes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StreamStats {
    /// Key expression.
    pub key: String,
    /// True for a subscription, false for a publication.
    pub inbound: bool,
    /// Messages since start.
    pub count: u64,
    /// Messages per second over the last period.
    pub rate_hz: f32,
    /// Payload bytes per second over the last period.
    pub bytes_per_s: f32,
    /// Rejected payloads since start.
    pub rejects: u64,
    /// Messages since start that a publisher numbered and that never arrived (gaps in
    /// its sequence numbers: dropped on the way, as a lane that drops rather than
    /// queue does on a congested link). Always 0 for a publication.
    pub missed: u64,
    /// Median age at receipt (capture -> now), milliseconds, over the last period.
    pub latency_p50_ms: f32,
    /// 99th percentile age at receipt, milliseconds, over the last period.
    pub latency_p99_ms: f32,
}

/// Count of rejected inputs of one kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RejectCount {
    /// Kind (`truncated`, `unknown_version`, `nan_points`, ...).
    pub kind: String,
    /// How many since start.
    pub count: u64,
}

/// Periodic health of one agent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HealthStats {
    /// Agent name.
    pub agent: String,
    /// Time since the agent started, milliseconds.
    pub uptime_ms: u64,
    /// False when the agent knows it is not doing its job (source stalled, ground lost).
    pub ok: bool,
    /// Why not ok, or a short state summary.
    pub status: String,
    /// Per-stream counters.
    pub streams: Vec<StreamStats>,
    /// Rejected inputs by kind.
    pub rejects: Vec<RejectCount>,
}
