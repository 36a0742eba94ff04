//! What the monitor page (`/monitor`, docs/phone.md) is sent: the scan with Taylor's cost
//! regions, the hazard and the haptic intent (rumble per side), the utterances, the pose
//! with its covariance, the simulator's truth, the route, the floor map and every agent's
//! health. A page asks for these with `subscribe` on the phone's own socket; a socket that
//! did not ask gets none of them, so the phone's stream stays as it was. Pure: no socket,
//! no bus, no clock (times are the messages' capture stamps).

use std::collections::{BTreeMap, VecDeque};

use map::{Cell, Floor};
use perception::config::CostConfig;
use schemas::{
    CameraPlace, GroundTruth, HapticIntent, HapticPattern, Hazard, HealthStats, LocalizationStatus, MapPoint, Pose,
    RouteState, RouteStatus, Scan, SideCosts, SpeechIntent,
};
use serde::Serialize;

use crate::protocol::{ground_name, priority_name, rumble_name};

/// Utterances a page is sent when it subscribes (the newest).
pub const UTTERANCES_KEPT: usize = 20;
/// A floor map is sent with at most this many cells; a larger one is sent coarser (a
/// desktop canvas shows about a million pixels).
pub const MAX_MAP_CELLS: usize = 1 << 20;

/// What a page can subscribe to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// `perception/scan`, the cost regions it is drawn with, and where each scan lies
    /// on the map (`localization/camera`).
    Scan,
    /// `perception/hazard`: costs, rumble state, nearest, latency by stage.
    Hazard,
    /// `feedback/haptic`: the rumble asked of each side.
    Haptic,
    /// `localization/pose` with its covariance ellipse.
    Pose,
    /// `sensor/*/truth`: where the simulated user really is.
    Truth,
    /// `route/state` with the route's points.
    Route,
    /// The floor maps the bridge was given (`--map`).
    Map,
    /// `health/*`: each agent's liveliness, status, streams and latency.
    Health,
    /// `feedback/speech`: the utterances asked for.
    Speech,
}

impl Stream {
    /// Every stream, in the order a page is sent their state.
    pub const ALL: [Stream; 9] = [
        Stream::Map,
        Stream::Route,
        Stream::Pose,
        Stream::Truth,
        Stream::Health,
        Stream::Speech,
        Stream::Hazard,
        Stream::Haptic,
        Stream::Scan,
    ];

    /// Its name in `subscribe`.
    pub fn name(self) -> &'static str {
        match self {
            Stream::Scan => "scan",
            Stream::Hazard => "hazard",
            Stream::Haptic => "haptic",
            Stream::Pose => "pose",
            Stream::Truth => "truth",
            Stream::Route => "route",
            Stream::Map => "map",
            Stream::Health => "health",
            Stream::Speech => "speech",
        }
    }

    /// The stream named `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// Every name, comma-separated, for error messages.
    pub fn names() -> String {
        Self::ALL.map(Stream::name).join(", ")
    }

    fn bit(self) -> u16 {
        1 << (self as u16)
    }
}

/// The streams one socket asked for.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StreamSet(u16);

impl StreamSet {
    /// These streams.
    pub fn of(streams: &[Stream]) -> Self {
        Self(streams.iter().fold(0, |bits, s| bits | s.bit()))
    }

    /// Whether `s` was asked for.
    pub fn contains(self, s: Stream) -> bool {
        self.0 & s.bit() != 0
    }

    /// Nothing asked for: a phone, not a monitor.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The streams asked for, in [`Stream::ALL`] order.
    pub fn streams(self) -> impl Iterator<Item = Stream> {
        Stream::ALL.into_iter().filter(move |s| self.contains(*s))
    }
}

/// One cost function's regions in the user frame (x forward, y left), metres, and its
/// thresholds (`perception::cost_function`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegionView {
    /// Width of the forward region.
    pub forward_width_m: f32,
    /// Depth of the forward region.
    pub forward_depth_m: f32,
    /// Width of the side region (its left half gives the left cost, its right half the right).
    pub side_width_m: f32,
    /// Depth of the side region.
    pub side_depth_m: f32,
    /// Forward cost at or above which the user must turn.
    pub forward_threshold: f32,
    /// Left and right costs both at or above this: blocked.
    pub side_threshold: f32,
}

impl From<&CostConfig> for RegionView {
    fn from(c: &CostConfig) -> Self {
        Self {
            forward_width_m: c.forward_width_m,
            forward_depth_m: c.forward_depth_m,
            side_width_m: c.side_width_m,
            side_depth_m: c.side_depth_m,
            forward_threshold: c.forward_threshold,
            side_threshold: c.side_threshold,
        }
    }
}

/// Time spent in one stage of the hazard's frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageView {
    /// Stage name (`arrival`, `decode`, `ground_plane`, ...).
    pub stage: String,
    /// Milliseconds.
    pub ms: f32,
}

/// One stream of an agent's health.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StreamHealthView {
    /// Key below the user's prefix (`perception/scan`).
    pub key: String,
    /// Subscribed (true) or published.
    pub inbound: bool,
    /// Messages a second over the agent's last period.
    pub rate_hz: f32,
    /// Median age at receipt (capture to now), ms; `None` when none arrived.
    pub p50_ms: Option<f32>,
    /// 99th percentile age at receipt, ms.
    pub p99_ms: Option<f32>,
    /// Rejected payloads since start.
    pub rejects: u64,
    /// Messages lost on the way since start (gaps in their publishers' numbering).
    pub missed: u64,
}

/// What the bridge sends a page that subscribed (JSON, `type` as for [`crate::protocol::ToPage`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum ToMonitor {
    /// The answer to `subscribe`, before the streams' state.
    Subscribed {
        /// The streams this socket now gets.
        streams: Vec<&'static str>,
        /// Floors whose map the bridge has (empty: started without `--map`).
        map_floors: Vec<i32>,
    },
    /// The cost regions of both functions, as the bridge's perception configuration has
    /// them (the compute agent's own, when both are given the same file).
    Regions {
        /// Fully-Integrated.
        ficf: RegionView,
        /// Cushioned Avoidance.
        cacf: RegionView,
    },
    /// A nearest-point scan, user frame.
    Scan {
        /// Sequence number of the scan on the bus.
        seq: u64,
        /// Capture stamp, ms since the epoch.
        t: f64,
        /// Bearing of the first beam's centre, degrees (negative = right).
        angle_min_deg: f32,
        /// Beam width, degrees.
        angle_increment_deg: f32,
        /// Largest range trusted, metres.
        range_max_m: f32,
        /// Range per beam, metres to the millimetre; `null`: nothing seen.
        ranges_m: Vec<Option<f32>>,
        /// Number of beams.
        beams: usize,
        /// Nearest range in the scan, metres to the millimetre.
        nearest_m: Option<f32>,
        /// Its beam's bearing, degrees, positive left.
        nearest_bearing_deg: Option<f32>,
    },
    /// Costs, rumble state and what a frame took.
    Hazard {
        /// Sequence number on the bus.
        seq: u64,
        /// Capture stamp, ms since the epoch.
        t: f64,
        /// Age at the bridge, ms.
        age_ms: f64,
        /// `none`, `left`, `right`, `both`.
        rumble: &'static str,
        /// `found`, `lost`, `degraded`.
        ground: &'static str,
        /// `ficf` or `cacf`: the function driving the rumble.
        active: &'static str,
        /// Fully-Integrated costs.
        ficf: SideCosts,
        /// Cushioned Avoidance costs.
        cacf: SideCosts,
        /// Nearest obstacle, metres.
        nearest_m: Option<f32>,
        /// Its bearing, degrees, positive left.
        nearest_bearing_deg: f32,
        /// Time to collision, seconds.
        ttc_s: Option<f32>,
        /// A drop-off ahead.
        dropoff_ahead: bool,
        /// The warning is about where the body is turning.
        turn_ahead: bool,
        /// The frame carried the camera's gravity (false: a camera without IMU).
        gravity: bool,
        /// Sum of the stages, ms (capture to hazard, as the compute agent timed it).
        latency_ms: f32,
        /// The stages.
        stages: Vec<StageView>,
    },
    /// The rumble asked of each side.
    Haptic {
        /// Capture stamp, ms since the epoch.
        t: f64,
        /// Left level, 0..1.
        left: f32,
        /// Right level, 0..1.
        right: f32,
        /// `steady` or `pulses`.
        pattern: &'static str,
        /// Pulse period, ms.
        period_ms: Option<u32>,
        /// Fraction of the period on.
        duty: Option<f32>,
        /// The intent holds this long after `t`.
        ttl_ms: u32,
    },
    /// The pose estimate and its uncertainty (the particles are not on the bus: the
    /// ellipse is the covariance the filter publishes).
    Pose {
        /// Capture stamp, ms since the epoch.
        t: f64,
        /// Map x, metres.
        x_m: f32,
        /// Map y, metres.
        y_m: f32,
        /// Heading, radians (0 = +x, counter-clockwise).
        yaw_rad: f32,
        /// Floor.
        floor: i32,
        /// `tracking`, `converging`, `lost`.
        status: &'static str,
        /// Standard deviation along the ellipse's major axis, metres.
        sigma_major_m: Option<f32>,
        /// Along its minor axis, metres.
        sigma_minor_m: Option<f32>,
        /// Direction of the major axis, radians from +x, counter-clockwise.
        major_angle_rad: Option<f32>,
        /// Standard deviation of the heading, degrees.
        sigma_yaw_deg: Option<f32>,
        /// Route guidance takes this place (`tracking`, or `converging` and followed from
        /// a known place).
        guides: bool,
    },
    /// Where a frame's scan lies on the map (`localization/camera`): the page draws
    /// the scan of the same capture stamp on the map with it.
    Camera {
        /// Capture stamp of the frame, ms since the epoch (the scan's `t`).
        t: f64,
        /// Map x of the floor below the camera, metres.
        x_m: f32,
        /// Map y, metres.
        y_m: f32,
        /// The camera's view (the scan's bearing 0), radians from +x, counter-clockwise.
        yaw_rad: f32,
        /// Floor.
        floor: i32,
    },
    /// Where the simulated user really is (simulator only).
    Truth {
        /// Capture stamp, ms since the epoch.
        t: f64,
        /// Map x, metres.
        x_m: f32,
        /// Map y, metres.
        y_m: f32,
        /// Heading, radians.
        yaw_rad: f32,
        /// Floor.
        floor: i32,
    },
    /// The route and where guidance stands.
    RoutePath {
        /// As the phone's `route`, plus `preview`.
        status: &'static str,
        /// The destination, if any.
        destination: Option<String>,
        /// The route still ahead.
        points: Vec<MapPoint>,
        /// The next waypoint.
        next: Option<MapPoint>,
        /// Metres left, while guiding.
        distance_m: Option<f32>,
        /// The instruction last given.
        instruction: String,
    },
    /// One floor's occupancy map.
    Map {
        /// Floor level.
        floor: i32,
        /// Cells along x.
        width: usize,
        /// Cells along y.
        height: usize,
        /// Metres per cell side.
        resolution_m: f64,
        /// Lower-left corner of cell (0, 0) and the grid's rotation: `[x_m, y_m, yaw_rad]`.
        origin: [f64; 3],
        /// Runs of cells, row 0 (the bottom, smallest y) first: `f` free, `o` occupied,
        /// `u` unknown, each followed by its count (`u120f30o2...`).
        cells: String,
        /// Cells of the floor's own map per cell side here (1: as it is; more: made
        /// coarser to stay under [`MAX_MAP_CELLS`]).
        coarsened: usize,
    },
    /// One agent's health.
    Health {
        /// Agent name.
        agent: String,
        /// Its liveliness token is present.
        alive: bool,
        /// It says it is doing its job.
        ok: bool,
        /// What it says of itself.
        status: String,
        /// Since it started, ms (`None`: no stats heard yet).
        uptime_ms: Option<u64>,
        /// Age of its last stats at the bridge, ms.
        age_ms: Option<f64>,
        /// Its streams.
        streams: Vec<StreamHealthView>,
        /// Rejected inputs, all kinds.
        rejects: u64,
    },
    /// An utterance asked for.
    Utterance {
        /// Capture stamp, ms since the epoch.
        t: f64,
        /// The words.
        text: String,
        /// `important`, `message`, `text`, `notification`, `progress`.
        priority: &'static str,
        /// Cuts off what is being said.
        interrupt: bool,
        /// Announced with a light tap (guidance not asked for).
        notice: bool,
    },
}

impl ToMonitor {
    /// The stream this message belongs to (`None`: the answer to `subscribe`).
    pub fn stream(&self) -> Option<Stream> {
        Some(match self {
            ToMonitor::Subscribed { .. } => return None,
            ToMonitor::Regions { .. } | ToMonitor::Scan { .. } | ToMonitor::Camera { .. } => Stream::Scan,
            ToMonitor::Hazard { .. } => Stream::Hazard,
            ToMonitor::Haptic { .. } => Stream::Haptic,
            ToMonitor::Pose { .. } => Stream::Pose,
            ToMonitor::Truth { .. } => Stream::Truth,
            ToMonitor::RoutePath { .. } => Stream::Route,
            ToMonitor::Map { .. } => Stream::Map,
            ToMonitor::Health { .. } => Stream::Health,
            ToMonitor::Utterance { .. } => Stream::Speech,
        })
    }
}

/// JSON text of a message for the page.
pub fn to_text(m: &ToMonitor) -> String {
    // strings, numbers, bools and lists of them: this cannot fail
    serde_json::to_string(m).unwrap_or_else(|e| format!(r#"{{"type":"error","message":"{e}"}}"#))
}

fn ms(capture_ns: u64) -> f64 {
    capture_ns as f64 / 1e6
}

fn mm(r: f32) -> f32 {
    (r * 1000.0).round() / 1000.0
}

fn finite(x: f32) -> Option<f32> {
    x.is_finite().then_some(x)
}

/// The regions of both cost functions.
pub fn regions(ficf: &CostConfig, cacf: &CostConfig) -> ToMonitor {
    ToMonitor::Regions { ficf: ficf.into(), cacf: cacf.into() }
}

/// A scan for the page: ranges to the millimetre, nothing seen as `null`, and its
/// nearest range and bearing.
pub fn scan(s: &Scan, seq: u64, capture_ns: u64) -> ToMonitor {
    let ranges_m: Vec<Option<f32>> = s.ranges_m.iter().map(|&r| (r.is_finite() && r >= 0.0).then(|| mm(r))).collect();
    let nearest = ranges_m.iter().enumerate().filter_map(|(i, r)| r.map(|r| (i, r))).min_by(|a, b| a.1.total_cmp(&b.1));
    ToMonitor::Scan {
        seq,
        t: ms(capture_ns),
        angle_min_deg: s.angle_min_deg,
        angle_increment_deg: s.angle_increment_deg,
        range_max_m: s.range_max_m,
        beams: ranges_m.len(),
        nearest_m: nearest.map(|(_, r)| r),
        nearest_bearing_deg: nearest.map(|(i, _)| s.angle_min_deg + i as f32 * s.angle_increment_deg),
        ranges_m,
    }
}

/// A hazard for the page.
pub fn hazard(h: &Hazard, seq: u64, capture_ns: u64, age_ms: f64) -> ToMonitor {
    let stages: Vec<StageView> =
        h.latency.iter().map(|s| StageView { stage: s.stage.clone(), ms: s.us as f32 / 1000.0 }).collect();
    ToMonitor::Hazard {
        seq,
        t: ms(capture_ns),
        age_ms: (age_ms * 10.0).round() / 10.0,
        rumble: rumble_name(h.rumble),
        ground: ground_name(h.ground),
        active: match h.active {
            schemas::CostFunction::Ficf => "ficf",
            schemas::CostFunction::Cacf => "cacf",
        },
        ficf: h.ficf,
        cacf: h.cacf,
        nearest_m: finite(h.nearest_m).map(mm),
        nearest_bearing_deg: h.nearest_bearing_deg,
        ttc_s: h.ttc_s.and_then(finite),
        dropoff_ahead: h.dropoff_ahead,
        turn_ahead: h.turn_ahead,
        gravity: h.gravity,
        latency_ms: stages.iter().map(|s| s.ms).sum(),
        stages,
    }
}

/// A haptic intent for the page.
pub fn haptic(i: &HapticIntent, capture_ns: u64) -> ToMonitor {
    let (pattern, period_ms, duty) = match i.pattern {
        HapticPattern::Steady => ("steady", None, None),
        HapticPattern::Pulses { period_ms, duty } => ("pulses", Some(period_ms), Some(duty)),
    };
    ToMonitor::Haptic { t: ms(capture_ns), left: i.left, right: i.right, pattern, period_ms, duty, ttl_ms: i.ttl_ms }
}

/// The x-y covariance of a pose as an ellipse: standard deviations along its axes and
/// the major axis's direction; `None` for a covariance that is not one (NaN).
pub fn ellipse(covariance: &[f32; 9]) -> Option<(f32, f32, f32)> {
    let (a, b, c) = (f64::from(covariance[0]), f64::from(covariance[1]), f64::from(covariance[4]));
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return None;
    }
    let mean = (a + c) / 2.0;
    let spread = (((a - c) / 2.0).powi(2) + b * b).sqrt();
    let major = (mean + spread).max(0.0).sqrt();
    let minor = (mean - spread).max(0.0).sqrt();
    let angle = 0.5 * (2.0 * b).atan2(a - c);
    Some((major as f32, minor as f32, angle as f32))
}

/// A pose for the page, with its covariance as an ellipse.
pub fn pose(p: &Pose, capture_ns: u64) -> ToMonitor {
    let e = ellipse(&p.covariance);
    ToMonitor::Pose {
        t: ms(capture_ns),
        x_m: p.x_m,
        y_m: p.y_m,
        yaw_rad: p.yaw_rad,
        floor: p.floor,
        status: match p.status {
            LocalizationStatus::Tracking => "tracking",
            LocalizationStatus::Converging => "converging",
            LocalizationStatus::Lost => "lost",
        },
        sigma_major_m: e.map(|e| e.0),
        sigma_minor_m: e.map(|e| e.1),
        major_angle_rad: e.map(|e| e.2),
        sigma_yaw_deg: finite(p.covariance[8]).filter(|v| *v >= 0.0).map(|v| v.sqrt().to_degrees()),
        guides: p.guides,
    }
}

/// Where a frame's scan lies on the map, for the page (sent with the scan stream).
pub fn camera(c: &CameraPlace, capture_ns: u64) -> ToMonitor {
    ToMonitor::Camera { t: ms(capture_ns), x_m: c.x_m, y_m: c.y_m, yaw_rad: c.yaw_rad, floor: c.floor }
}

/// The simulator's truth for the page.
pub fn truth(g: &GroundTruth, capture_ns: u64) -> ToMonitor {
    ToMonitor::Truth { t: ms(capture_ns), x_m: g.x_m, y_m: g.y_m, yaw_rad: g.yaw_rad, floor: g.floor }
}

/// The route for the page, previews included.
pub fn route_path(r: &RouteState) -> ToMonitor {
    let status = match r.status {
        RouteStatus::Idle => "idle",
        RouteStatus::WaitingForPosition => "waiting-for-position",
        RouteStatus::Guiding => "guiding",
        RouteStatus::WaitingForFloor => "waiting-for-floor",
        RouteStatus::Arrived => "arrived",
        RouteStatus::Unreachable => "unreachable",
        RouteStatus::Preview => "preview",
    };
    ToMonitor::RoutePath {
        status,
        destination: (!r.destination.is_empty()).then(|| r.destination.clone()),
        points: r.route.clone(),
        next: r.next_waypoint,
        distance_m: finite(r.distance_left_m).map(|d| (d * 10.0).round() / 10.0),
        instruction: r.instruction.clone(),
    }
}

/// An utterance for the page.
pub fn utterance(s: &SpeechIntent, capture_ns: u64) -> ToMonitor {
    ToMonitor::Utterance {
        t: ms(capture_ns),
        text: s.text.clone(),
        priority: priority_name(s.priority),
        interrupt: s.interrupt,
        notice: s.notice,
    }
}

/// An agent's health for the page; keys shown below `prefix/`.
pub fn health(h: &HealthStats, alive: bool, prefix: &str, age_ms: f64) -> ToMonitor {
    let streams = h
        .streams
        .iter()
        .map(|s| StreamHealthView {
            key: s.key.strip_prefix(prefix).and_then(|k| k.strip_prefix('/')).unwrap_or(&s.key).to_string(),
            inbound: s.inbound,
            rate_hz: (s.rate_hz * 10.0).round() / 10.0,
            p50_ms: finite(s.latency_p50_ms),
            p99_ms: finite(s.latency_p99_ms),
            rejects: s.rejects,
            missed: s.missed,
        })
        .collect();
    ToMonitor::Health {
        agent: h.agent.clone(),
        alive,
        ok: h.ok,
        status: h.status.clone(),
        uptime_ms: Some(h.uptime_ms),
        age_ms: Some((age_ms * 10.0).round() / 10.0),
        streams,
        rejects: h.rejects.iter().map(|r| r.count).sum(),
    }
}

/// A floor's map for the page: its cells as runs, made coarser (by a whole factor, a
/// coarse cell occupied if any of its cells is, else free if any is) until it has at
/// most `max_cells`.
pub fn floor_map(floor: &Floor, max_cells: usize) -> ToMonitor {
    let grid = &floor.grid;
    let (w, h) = (grid.width(), grid.height());
    let mut k = 1;
    while w.div_ceil(k) * h.div_ceil(k) > max_cells.max(1) {
        k += 1;
    }
    let (cw, ch) = (w.div_ceil(k), h.div_ceil(k));
    let coarse = |col: usize, row: usize| {
        let mut seen = Cell::Unknown;
        for r in row * k..((row + 1) * k).min(h) {
            for c in col * k..((col + 1) * k).min(w) {
                match grid.get(c, r) {
                    Some(Cell::Occupied) => return Cell::Occupied,
                    Some(Cell::Free) => seen = Cell::Free,
                    _ => {}
                }
            }
        }
        seen
    };
    let mut cells = String::new();
    let mut run: Option<(Cell, usize)> = None;
    for row in 0..ch {
        for col in 0..cw {
            let cell = if k == 1 { grid.get(col, row).unwrap_or(Cell::Unknown) } else { coarse(col, row) };
            run = match run {
                Some((c, n)) if c == cell => Some((c, n + 1)),
                Some((c, n)) => {
                    push_run(&mut cells, c, n);
                    Some((cell, 1))
                }
                None => Some((cell, 1)),
            };
        }
    }
    if let Some((c, n)) = run {
        push_run(&mut cells, c, n);
    }
    let o = grid.origin();
    ToMonitor::Map {
        floor: floor.level,
        width: cw,
        height: ch,
        resolution_m: grid.resolution_m() * k as f64,
        origin: [o.x_m, o.y_m, o.yaw_rad],
        cells,
        coarsened: k,
    }
}

fn push_run(out: &mut String, cell: Cell, n: usize) {
    out.push(match cell {
        Cell::Free => 'f',
        Cell::Occupied => 'o',
        Cell::Unknown => 'u',
    });
    out.push_str(&n.to_string());
}

/// The latest of each stream, sent to a page as it subscribes.
#[derive(Debug, Default)]
pub struct MonitorState {
    regions: Option<ToMonitor>,
    maps: Vec<ToMonitor>,
    latest: BTreeMap<&'static str, ToMonitor>,
    health: BTreeMap<String, ToMonitor>,
    utterances: VecDeque<ToMonitor>,
}

impl MonitorState {
    /// A state with the cost regions and the floor maps, which do not change.
    pub fn new(regions: ToMonitor, maps: Vec<ToMonitor>) -> Self {
        Self { regions: Some(regions), maps, ..Self::default() }
    }

    /// Floors with a map.
    pub fn map_floors(&self) -> Vec<i32> {
        self.maps
            .iter()
            .filter_map(|m| if let ToMonitor::Map { floor, .. } = m { Some(*floor) } else { None })
            .collect()
    }

    /// Keep `m` as its stream's state (utterances: the newest [`UTTERANCES_KEPT`];
    /// health: one per agent).
    pub fn keep(&mut self, m: &ToMonitor) {
        match m {
            ToMonitor::Subscribed { .. } | ToMonitor::Regions { .. } | ToMonitor::Map { .. } => {}
            ToMonitor::Health { agent, .. } => {
                self.health.insert(agent.clone(), m.clone());
            }
            ToMonitor::Utterance { .. } => {
                if self.utterances.len() == UTTERANCES_KEPT {
                    self.utterances.pop_front();
                }
                self.utterances.push_back(m.clone());
            }
            _ => {
                if let Some(s) = m.stream() {
                    self.latest.insert(s.name(), m.clone());
                }
            }
        }
    }

    /// An agent's liveliness token came or went: its health as it now stands (an
    /// agent not heard from yet is known by its token only).
    pub fn set_alive(&mut self, agent: &str, alive: bool) -> ToMonitor {
        let entry = self.health.entry(agent.to_string()).or_insert_with(|| ToMonitor::Health {
            agent: agent.to_string(),
            alive,
            ok: false,
            status: "no health stats heard yet".into(),
            uptime_ms: None,
            age_ms: None,
            streams: vec![],
            rejects: 0,
        });
        if let ToMonitor::Health { alive: a, .. } = entry {
            *a = alive;
        }
        entry.clone()
    }

    /// What a page that subscribed to `set` is sent first: the answer, then each
    /// stream's state (oldest utterance first).
    pub fn greeting(&self, set: StreamSet) -> Vec<ToMonitor> {
        let mut out = vec![ToMonitor::Subscribed {
            streams: set.streams().map(Stream::name).collect(),
            map_floors: self.map_floors(),
        }];
        for s in set.streams() {
            match s {
                Stream::Map => out.extend(self.maps.iter().cloned()),
                Stream::Health => out.extend(self.health.values().cloned()),
                Stream::Speech => out.extend(self.utterances.iter().cloned()),
                Stream::Scan => out.extend(self.regions.iter().chain(self.latest.get(s.name())).cloned()),
                _ => out.extend(self.latest.get(s.name()).cloned()),
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use map::{OccupancyGrid, Origin, SemanticLayer};

    #[test]
    fn stream_names_round_trip_and_sets_keep_their_order() {
        for s in Stream::ALL {
            assert_eq!(Stream::from_name(s.name()), Some(s));
        }
        assert_eq!(Stream::from_name("particles"), None);
        let set = StreamSet::of(&[Stream::Scan, Stream::Map, Stream::Scan]);
        assert_eq!(set.streams().collect::<Vec<_>>(), [Stream::Map, Stream::Scan]);
        assert!(StreamSet::default().is_empty() && !set.is_empty());
    }

    #[test]
    fn a_covariance_becomes_its_ellipse() {
        let diag = [0.04, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.0025];
        let (major, minor, angle) = ellipse(&diag).unwrap();
        assert!((major - 0.2).abs() < 1e-6 && (minor - 0.1).abs() < 1e-6 && angle.abs() < 1e-6);
        // the same ellipse turned 45 degrees
        let turned = [0.025, 0.015, 0.0, 0.015, 0.025, 0.0, 0.0, 0.0, 0.0];
        let (major, minor, angle) = ellipse(&turned).unwrap();
        assert!((major - 0.2).abs() < 1e-6 && (minor - 0.1).abs() < 1e-6, "{major} {minor}");
        assert!((angle - std::f32::consts::FRAC_PI_4).abs() < 1e-6, "{angle}");
        assert_eq!(ellipse(&[f32::NAN; 9]), None);
    }

    #[test]
    fn a_floor_becomes_runs_from_the_bottom_row_and_coarser_when_large() {
        use Cell::{Free as F, Occupied as O, Unknown as U};
        // rows bottom first: F F O U / U U U U
        let origin = Origin { x_m: -1.0, y_m: 2.0, yaw_rad: 0.0 };
        let grid = OccupancyGrid::new(4, 2, 0.05, origin, vec![F, F, O, U, U, U, U, U]).unwrap();
        let floor = Floor { level: 1, grid, semantic: SemanticLayer::default() };
        let m = floor_map(&floor, 100);
        assert_eq!(
            to_text(&m),
            r#"{"type":"map","floor":1,"width":4,"height":2,"resolution_m":0.05,"origin":[-1.0,2.0,0.0],"cells":"f2o1u5","coarsened":1}"#
        );
        // 2 cells at most: halves of 2x2 cells; an occupied cell wins, then a free one
        let ToMonitor::Map { width, height, cells, coarsened, resolution_m, .. } = floor_map(&floor, 2) else {
            panic!("a map")
        };
        assert_eq!((width, height, cells.as_str(), coarsened, resolution_m), (2, 1, "f1o1", 2, 0.1));
    }
}
