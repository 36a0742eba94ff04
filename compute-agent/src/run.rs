//! The compute agent's loop: the only place where perception meets the bus and the
//! clock. Newest depth frame in; scan, hazard and haptic intent out, each stamped with
//! the frame's capture time so every downstream latency is measured from capture.

use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use bus::{BusOptions, Health, Lane, Publisher, Received, Shutdown, Subscriber};
use schemas::{DepthFrame, HapticIntent, Hazard, ImuBatch, OdomIncrement, Scan, StageLatency};

use perception::body_rate::{BodyRate, MAX_AGE_NS};
use perception::predictive::{PredictiveConfig, Way};
use perception::rejections::REJECTIONS_BEFORE_BLIND;
use perception::second_view::{SecondView, ViewState};
use perception::{Blind, ComputeStep, CueConfig, FrameData, FrameIn, InstantTimer, PerceptionConfig, StepOutput};

use crate::nav::{Nav, NavConfig, STATE_PERIOD};

/// Agent name: liveliness token `health/compute-agent` and sender of its messages.
pub const AGENT: &str = "compute-agent";

/// Everything the compute agent needs to run.
#[derive(Debug, Clone)]
pub struct ComputeConfig {
    /// Bus and user.
    pub bus: BusOptions,
    /// Obstacle perception parameters.
    pub perception: PerceptionConfig,
    /// Mapping from rumble state to haptic intents.
    pub cue: CueConfig,
    /// Period of health stats.
    pub health_period: Duration,
    /// Device whose IMU is worn on the body (`sensor/<device>/imu`): its turn rate lets
    /// the costs look the way the user turns (`perception::turn_ahead`). `None`: the
    /// costs look along the camera's heading only, as in the thesis.
    pub body_imu_device: Option<String>,
    /// Device whose compass the localization reads (`sensor/<device>/motion`), with a
    /// floor map that says where north is. `None`: no compass.
    pub compass_device: Option<String>,
    /// Oldest depth frame acted on, from capture to arrival and again when the loop
    /// takes it up: an older one (a stalled link, a replay) is refused as `stale`, so a
    /// rumble never reports a world that was, and it counts as no input (the feedback
    /// agent's watchdog then warns that detection is offline).
    pub max_input_age: Duration,
    /// Oldest odometry step taken, from capture to arrival. A late step is still how
    /// the user moved, placed by its stamps before the frame it leads up to: refusing
    /// it would leave the obstacle memory and the localization where the user was. An
    /// older one (a replay, a link down for longer) is refused as `stale`.
    pub max_odometry_age: Duration,
    /// Localization, route planning and guidance on a floor map; `None`: obstacle
    /// perception only.
    pub nav: Option<NavConfig>,
    /// The cue from where the user heads ([`perception::predictive`]) while a route is
    /// followed and the position tracked (needs `nav`); the cost functions otherwise.
    /// `None`: the cost functions always.
    pub predictive: Option<PredictiveConfig>,
    /// A second depth camera worn at the chest (`sensor/<device>/depth` and its
    /// `/odom`): perceived with a step of its own, its cue joined to every other
    /// camera's frame while fresh ([`perception::second_view`]), so what hangs at head
    /// height is warned of. `None`: every depth frame is one camera's.
    pub chest_device: Option<String>,
    /// The cane camera's device: only its frames and odometry go through the cane's
    /// step. `None`: the first camera heard (the chest camera aside). Another camera's
    /// are refused and counted as `other_camera`.
    pub cane_device: Option<String>,
}

/// Default [`ComputeConfig::max_input_age`]: a frame is 33 ms at 30 Hz and capture ->
/// intent 5-6 ms at p99 in the demo, so this allows a few frames of delay, not more.
pub const DEFAULT_MAX_INPUT_AGE: Duration = Duration::from_millis(150);

/// Default [`ComputeConfig::max_odometry_age`]: a stall of the cane's link or of this
/// machine is ridden out (on a loaded machine, with the depth frames' 150 ms bound, a
/// stall once had 12 steps refused as stale, 0.4 s of walking lost, and the
/// localization went from tracking to converging); a replayed recording is not taken.
pub const DEFAULT_MAX_ODOMETRY_AGE: Duration = Duration::from_secs(2);

/// Default body-worn IMU device: the simulator's (`sensor-agent --source sim:...`
/// publishes one); a phone or belt IMU publishing under this name is used the same way.
pub const DEFAULT_BODY_IMU_DEVICE: &str = "body";

impl ComputeConfig {
    /// Defaults for `bus`.
    pub fn new(bus: BusOptions) -> Self {
        Self {
            bus,
            perception: PerceptionConfig::default(),
            cue: CueConfig::default(),
            health_period: Duration::from_secs(1),
            body_imu_device: Some(DEFAULT_BODY_IMU_DEVICE.to_string()),
            compass_device: Some(DEFAULT_BODY_IMU_DEVICE.to_string()),
            max_input_age: DEFAULT_MAX_INPUT_AGE,
            max_odometry_age: DEFAULT_MAX_ODOMETRY_AGE,
            nav: None,
            predictive: None,
            chest_device: None,
            cane_device: None,
        }
    }
}

struct Outputs {
    scan: Publisher<Scan>,
    hazard: Publisher<Hazard>,
    haptic: Publisher<HapticIntent>,
    /// Whether the last perceived frame carried gravity (to log when that changes).
    gravity: Option<bool>,
}

/// The body-worn IMU as the loop sees it.
struct Body {
    imu: Option<Subscriber<ImuBatch>>,
    /// Depth frames from this key come from the body device: its IMU is the cane's.
    same_as_depth: String,
    rate: BodyRate,
    /// Whether the last frame had a body rate (to log when that changes).
    heard: bool,
}

impl Body {
    async fn recv(&self) -> Option<Received<ImuBatch>> {
        match &self.imu {
            Some(s) => s.recv().await,
            None => std::future::pending().await,
        }
    }

    fn add(&mut self, batch: &Received<ImuBatch>, health: &Health) {
        for s in &batch.body.samples {
            if let Err(e) = self.rate.add(s, batch.received_ns) {
                health.reject(&batch.key, e.kind(), &e);
            }
        }
    }

    /// The body's turn rate for a frame from `depth_key` captured at `capture_ns`.
    fn rate_for(&mut self, depth_key: &str, capture_ns: u64) -> Option<f32> {
        let imu = self.imu.as_ref()?;
        if depth_key == self.same_as_depth {
            // the cane's own IMU carries the sweep: looking along it reads every wall
            // beside a corridor as ahead (`perception::turn_ahead`)
            tracing::error!(
                "{} is the depth camera's device, not one worn on the body: its IMU is not used as the body's (--body-imu-device)",
                imu.key()
            );
            self.imu = None;
            return None;
        }
        let rate = self.rate.rate_at(capture_ns, bus::now_ns());
        match (self.heard, rate.is_some()) {
            (false, true) => {
                tracing::info!("body-worn IMU on {}: the costs also look the way the user turns", imu.key())
            }
            (true, false) => tracing::warn!(
                "body-worn IMU on {} silent for {} ms: the costs look along the camera's heading only",
                imu.key(),
                MAX_AGE_NS / 1_000_000
            ),
            _ => {}
        }
        self.heard = rate.is_some();
        rate
    }
}

/// Which camera the cane's step perceives: the one named, else the first whose frame or
/// odometry arrives. Another camera's frames and odometry are refused and counted
/// (`other_camera`), and the log names it once: two cameras through one step would mix
/// two heights in one ground tracker and two motions in one memory (a second camera
/// must be told to the agent as the chest camera, `--chest-device`).
struct CaneCamera {
    keys: schemas::Keys,
    device: Option<String>,
    refused: std::collections::BTreeSet<String>,
}

impl CaneCamera {
    /// Whether `key` is the cane camera's, as far as known (an IMU does not name it: the
    /// body-worn one comes first as often as not).
    fn is_cane(&self, key: &str) -> bool {
        self.device.is_some() && self.keys.device_of(key) == self.device.as_deref()
    }

    /// Whether a message on `key` (a `sensor/<device>/...` key) is the cane camera's;
    /// the first one heard names it when none was given.
    fn accepts(&mut self, key: &str, health: &Health) -> bool {
        let Some(device) = self.keys.device_of(key) else { return false };
        match &self.device {
            Some(cane) if cane == device => true,
            Some(cane) => {
                if self.refused.insert(device.to_string()) {
                    tracing::warn!(
                        "{key}: camera {device:?} is not the cane camera {cane:?}: its frames and odometry are refused (give it as --chest-device if it is worn at the chest)"
                    );
                }
                health.reject(key, "other_camera", &format_args!("{device:?} is not the cane camera {cane:?}"));
                false
            }
            None => {
                tracing::info!(
                    "the cane camera is {device:?} (the first heard): other cameras' frames and odometry are refused"
                );
                self.device = Some(device.to_string());
                true
            }
        }
    }
}

/// The chest camera as the loop sees it: its keys and its own step.
struct Chest {
    depth_key: String,
    odom_key: String,
    step: ComputeStep,
    /// Whether cane frames are joined to a fresh chest state, as last logged, and a
    /// change not yet held for [`CHEST_CHANGE_FRAMES`] frames (a blink is not logged).
    joined: Option<ChestState>,
    changing: (Option<ChestState>, u32),
}

/// Whether cane frames are joined to the chest camera's state, and if not why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ChestState {
    /// fresh and seeing: the cue is both cameras'
    Joined,
    /// no state within the age a join allows
    Silent,
    /// fresh, but the camera cannot see its floor (its ground degraded)
    Blind,
}

/// Cane frames a change of the chest camera's state must hold before it is logged.
const CHEST_CHANGE_FRAMES: u32 = 5;

impl Chest {
    /// Runs a chest frame through its own step; its state goes to the cane's `step`.
    fn frame(
        &mut self,
        frame: &Received<DepthFrame>,
        body_yaw_rate_rad_s: Option<f32>,
        step: &mut ComputeStep,
        health: &Health,
    ) {
        let capture_ns = frame.header.capture_ns;
        let input = FrameIn {
            data: FrameData::Wire(&frame.body),
            seq: frame.header.seq,
            capture_ns,
            body_yaw_rate_rad_s,
            way: None,
        };
        match self.step.process(input, &mut perception::NoTimer) {
            StepOutput::Perceived { hazard, .. } => {
                step.second_view_heard(ViewState::of(&hazard, capture_ns), self.step.obstacle_points())
            }
            StepOutput::Refused { error, blind, .. } => {
                health.reject(&frame.key, error.kind(), &error);
                if let Some(blind) = blind {
                    step.second_view_heard(ViewState::of(&blind.hazard, capture_ns), &[]);
                }
            }
        }
    }

    /// Before a cane frame captured at `capture_ns`: whether it will be joined to the
    /// chest's state, said in the log when that changes and for the health status.
    fn report(&mut self, step: &ComputeStep, capture_ns: u64) -> Option<&'static str> {
        let joined = step.second_view().map(|(v, _)| match v.fresh(capture_ns) {
            Some(_) => ChestState::Joined,
            None if v.blind(capture_ns) => ChestState::Blind,
            None => ChestState::Silent,
        });
        self.changing = match self.changing {
            (c, n) if c == joined => (c, n + 1),
            _ => (joined, 1),
        };
        let held = self.changing.1 >= CHEST_CHANGE_FRAMES || self.joined.is_none();
        if joined != self.joined && held {
            self.joined = joined;
            match joined {
                Some(ChestState::Silent) => tracing::warn!(
                    "chest camera on {} silent: head-high obstacles are not warned of, the cane camera's cue alone",
                    self.depth_key
                ),
                Some(ChestState::Blind) => tracing::warn!(
                    "chest camera on {} cannot see its floor (ground degraded): head-high obstacles are not warned of, the cane camera's cue alone",
                    self.depth_key
                ),
                Some(ChestState::Joined) => {
                    tracing::info!("chest camera on {} joined: head-high obstacles are warned of", self.depth_key)
                }
                None => {}
            }
        }
        match joined {
            Some(ChestState::Joined) => Some("chest camera joined"),
            Some(ChestState::Silent) => Some("chest camera silent"),
            Some(ChestState::Blind) => Some("chest camera cannot see its floor"),
            None => None,
        }
    }
}

/// Run the compute agent until `shutdown`.
pub async fn run(config: ComputeConfig, shutdown: Shutdown) -> anyhow::Result<()> {
    let keys = config.bus.keys()?;
    let session = bus::open_session(&config.bus).await?;
    let health = Health::new(AGENT);
    let mut health_task = health.spawn(session.clone(), keys.clone(), config.health_period, shutdown.clone());

    let max_age = config.max_input_age;
    let frames = Subscriber::<DepthFrame>::declare_fresh(&session, keys.depth_any(), true, max_age, &health).await?;
    let odom_age = config.max_odometry_age;
    let odom = Subscriber::<OdomIncrement>::declare_fresh(&session, keys.odom_any(), false, odom_age, &health).await?;
    let mut body = Body {
        imu: match &config.body_imu_device {
            Some(device) => {
                schemas::keys::check_chunk("device", device).context("bad body IMU device")?;
                Some(Subscriber::<ImuBatch>::declare(&session, keys.imu(device), false, &health).await?)
            }
            None => None,
        },
        same_as_depth: config.body_imu_device.as_deref().map(|d| keys.depth(d)).unwrap_or_default(),
        rate: BodyRate::default(),
        heard: false,
    };
    let mut out = Outputs {
        scan: Publisher::declare(&session, keys.scan(), AGENT, Lane::Perception, Some(&health)).await?,
        hazard: Publisher::declare(&session, keys.hazard(), AGENT, Lane::Perception, Some(&health)).await?,
        haptic: Publisher::declare(&session, keys.haptic(), AGENT, Lane::RealTime, Some(&health)).await?,
        gravity: None,
    };
    let mut nav = match &config.nav {
        Some(c) => Some(
            Nav::declare(c, &session, &keys, config.body_imu_device.clone(), config.compass_device.as_deref(), &health)
                .await?,
        ),
        None => None,
    };
    let mut state_tick = tokio::time::interval(STATE_PERIOD);
    state_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut step = ComputeStep::new(config.perception.clone(), config.cue.clone());
    // the learnt turning rate last told in the log
    let mut turn_rate_told = None;
    if let Some(p) = config.predictive.filter(|_| nav.is_some()) {
        step = step.with_predictive(p);
    }
    let mut chest = match &config.chest_device {
        Some(device) => {
            schemas::keys::check_chunk("device", device).context("bad chest device")?;
            step = step.with_second_view(SecondView::default());
            Some(Chest {
                depth_key: keys.depth(device),
                odom_key: keys.odom(device),
                step: ComputeStep::new(config.perception.for_chest(), config.cue.clone()),
                joined: None,
                changing: (None, 0),
            })
        }
        None => None,
    };
    let mut cane = CaneCamera { keys: keys.clone(), device: config.cane_device.clone(), refused: Default::default() };
    if let Some(device) = &cane.device {
        schemas::keys::check_chunk("device", device).context("bad cane device")?;
        if config.chest_device.as_ref() == Some(device) {
            anyhow::bail!("{device:?} is given as both the cane camera and the chest camera");
        }
    }
    health.set_status(true, "waiting for depth frames");
    tracing::info!(user = %config.bus.user, "compute agent running: {} -> {}", keys.depth_any(), keys.hazard());

    loop {
        tokio::select! {
            // odometry first: a frame waiting with its own step behind it takes the step
            biased;
            _ = shutdown.triggered() => break,
            e = health_task.failed() => return Err(e),
            Some(inc) = odom.recv() => add_step(&mut step, &mut cane, chest.as_mut(), nav.as_mut(), &mut body, &inc, &health),
            Some(batch) = body.recv() => body.add(&batch, &health),
            Some(batch) = bus::maybe(nav.as_ref().map(|n| n.cane_imu.recv())) => {
                if let Some(n) = nav.as_mut().filter(|_| cane.is_cane(&batch.key)) {
                    n.imu(&batch, &health);
                }
            }
            Some(motion) = bus::maybe(nav.as_ref().and_then(|n| n.motion.as_ref()).map(|m| m.recv())) => {
                if let Some(n) = nav.as_mut() {
                    n.motion(&motion, &health);
                }
            }
            Some(reading) = bus::maybe(nav.as_ref().and_then(|n| n.pressure.as_ref()).map(|p| p.recv())) => {
                if let Some(n) = nav.as_mut() {
                    n.pressure(&reading, &health).await;
                }
            }
            Some(applied) = bus::maybe(nav.as_ref().map(|n| n.applied.recv())) => {
                if let Some(n) = nav.as_mut() {
                    n.applied(&applied.body);
                }
            }
            Some(cmd) = bus::maybe(nav.as_ref().map(|n| n.commands.recv())) => {
                if let Some(n) = nav.as_mut() {
                    n.command(&cmd).await;
                }
            }
            Some(query) = bus::maybe(nav.as_ref().map(|n| n.destinations.recv())) => {
                if let Some(n) = nav.as_ref() {
                    n.answer_destinations(query).await;
                }
            }
            Some(query) = bus::maybe(nav.as_ref().map(|n| n.routes.recv())) => {
                if let Some(n) = nav.as_mut() {
                    n.answer_route(query).await;
                }
            }
            _ = state_tick.tick(), if nav.is_some() => {
                if let Some(n) = nav.as_mut() {
                    n.publish_state().await;
                }
            }
            Some(frame) = frames.recv() => {
                while let Some(inc) = odom.try_recv() {
                    add_step(&mut step, &mut cane, chest.as_mut(), nav.as_mut(), &mut body, &inc, &health);
                }
                while let Some(batch) = body.imu.as_ref().and_then(|s| s.try_recv()) {
                    body.add(&batch, &health);
                }
                if let Some(n) = nav.as_mut() {
                    while let Some(batch) = n.cane_imu.try_recv() {
                        if cane.is_cane(&batch.key) {
                            n.imu(&batch, &health);
                        }
                    }
                }
                if let Err(e) = still_fresh(&frame, max_age, &health) {
                    health.reject(&frame.key, e.kind(), &e);
                    continue;
                }
                let body_yaw_rate_rad_s = body.rate_for(&frame.key, frame.header.capture_ns);
                if let Some(c) = chest.as_mut().filter(|c| frame.key == c.depth_key) {
                    c.frame(&frame, body_yaw_rate_rad_s, &mut step, &health);
                    continue;
                }
                if !cane.accepts(&frame.key, &health) {
                    continue;
                }
                let nav_status = nav.as_ref().map(|n| n.status());
                let way = if config.predictive.is_some() { nav.as_mut().and_then(|n| n.way()) } else { None };
                let chest_status = chest.as_mut().and_then(|c| c.report(&step, frame.header.capture_ns));
                let status = [chest_status.map(str::to_string), nav_status].into_iter().flatten().collect::<Vec<_>>();
                let status = (!status.is_empty()).then(|| status.join("; "));
                let scan = process(&frame, body_yaw_rate_rad_s, way, &mut step, &health, &mut out, status).await;
                if let Some(news) = turn_rate_news(&mut turn_rate_told, step.learnt_turn_rate_deg_s()) {
                    tracing::info!("{news}");
                }
                if let (Some(n), Some(scan)) = (nav.as_mut(), scan) {
                    n.frame(&scan, step.obstacle_points(), frame.header.capture_ns, body_yaw_rate_rad_s).await;
                }
            }
        }
    }
    tracing::info!("compute agent stopping");
    health_task.join().await?;
    session.close().await.map_err(|e| anyhow::anyhow!("{e}")).context("closing the Zenoh session")?;
    Ok(())
}

/// The log's line when the predictive cue's model has learnt the user's turning rate
/// (`now`, degrees per second) for the first time, or moved 5°/s or more from the rate
/// last told (`told`, updated).
fn turn_rate_news(told: &mut Option<f64>, now: Option<f64>) -> Option<String> {
    let now = now?;
    let news = match *told {
        None => format!(
            "the predictive cue's model of the user now turns at {now:.0}°/s, learnt from their turns on the rumble"
        ),
        Some(last) if (now - last).abs() >= 5.0 => {
            format!("the predictive cue's model of the user now turns at {now:.0}°/s (was {last:.0}°/s)")
        }
        Some(_) => return None,
    };
    *told = Some(now);
    Some(news)
}

/// A frame that was fresh on arrival may have waited for the loop: checked again.
fn still_fresh(frame: &Received<DepthFrame>, max_age: Duration, health: &Health) -> Result<(), bus::InputError> {
    let offset_ns = health.clock_offset_ns(&frame.header.sender) as i128;
    let age_ns = bus::now_ns() as i128 - frame.header.capture_ns as i128 - offset_ns;
    if age_ns > max_age.as_nanos() as i128 {
        return Err(bus::InputError::Stale {
            age_ms: (age_ns / 1_000_000) as i64,
            bound_ms: max_age.as_millis() as u64,
        });
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn add_step(
    step: &mut ComputeStep,
    cane: &mut CaneCamera,
    chest: Option<&mut Chest>,
    nav: Option<&mut Nav>,
    body: &mut Body,
    inc: &Received<OdomIncrement>,
    health: &Health,
) {
    if let Some(chest) = chest.filter(|c| inc.key == c.odom_key) {
        // the chest camera's own visual odometry moves its own memory only
        if let Err(e) = chest.step.add_odometry(&inc.body) {
            health.reject(&inc.key, e.kind(), &e);
        }
        return;
    }
    if !cane.accepts(&inc.key, health) {
        return;
    }
    if let Err(e) = step.add_odometry(&inc.body) {
        health.reject(&inc.key, e.kind(), &e);
        return;
    }
    if let Some(nav) = nav {
        let rate = body.imu.is_some().then(|| body.rate.rate_at(inc.body.to_ns, bus::now_ns())).flatten();
        nav.odometry(inc, rate, health);
    }
}

/// Runs one frame through the step and publishes what it gave: intent, hazard (with
/// the latencies from capture) and scan; a refused frame is counted, and when the
/// refusals in a row mean the system is blind, that is published instead of silence.
/// Returns the scan of a perceived frame.
#[allow(clippy::too_many_arguments)]
async fn process(
    frame: &Received<DepthFrame>,
    body_yaw_rate_rad_s: Option<f32>,
    way: Option<Way<'_>>,
    step: &mut ComputeStep,
    health: &Arc<Health>,
    out: &mut Outputs,
    nav_status: Option<String>,
) -> Option<Scan> {
    let capture_ns = frame.header.capture_ns;
    let mut clock = InstantTimer::default();
    // The hops before this agent, so a monitor can attribute capture -> intent:
    // `arrival` = capture -> decoded off the bus here (sensor packing + transport),
    // `queue` = waiting for this loop (another frame or odometry being handled).
    let started_ns = bus::now_ns();
    clock.stages.push(("arrival", Duration::from_nanos(frame.received_ns.saturating_sub(capture_ns))));
    clock.stages.push(("queue", Duration::from_nanos(started_ns.saturating_sub(frame.received_ns))));
    let input =
        FrameIn { data: FrameData::Wire(&frame.body), seq: frame.header.seq, capture_ns, body_yaw_rate_rad_s, way };
    let ways_refused = step.ways_refused();
    let (perception, mut hazard, intent) = match step.process(input, &mut clock) {
        StepOutput::Perceived { perception, hazard, intent } => {
            if step.ways_refused() > ways_refused {
                // the navigation side made a way with a NaN: the cost functions decided
                health.reject(&frame.key, "way_not_finite", &"the way ahead had a non-finite point");
            }
            (perception, hazard, intent)
        }
        StepOutput::Refused { error, blind, answer } => {
            health.reject(&frame.key, error.kind(), &error);
            if let Some(blind) = blind {
                publish_blind(capture_ns, blind, health, out).await;
            } else if let Some(hazard) = answer {
                // still blind: the frame answered, for the sensor agent's link pacing
                if let Err(e) = out.hazard.put(capture_ns, &hazard).await {
                    tracing::warn!("{e:#}");
                }
            }
            return None;
        }
    };
    hazard.latency = clock
        .stages
        .iter()
        .map(|(stage, d)| StageLatency { stage: stage.to_string(), us: d.as_micros() as u32 })
        .collect();
    let seeing = matches!(hazard.ground, schemas::GroundState::Found);
    let body = match body_yaw_rate_rad_s {
        Some(r) => format!("body turning {:+.0} deg/s", r.to_degrees()),
        None => "no body turn rate".to_string(),
    };
    let nav = nav_status.map(|s| format!("; {s}")).unwrap_or_default();
    let gravity = if hazard.gravity { "" } else { ", no gravity (lower ground along the path only)" };
    if out.gravity != Some(hazard.gravity) {
        match hazard.gravity {
            true => tracing::info!("depth frames on {} carry gravity", frame.key),
            false => tracing::warn!(
                "depth frames on {} carry no gravity (a camera without IMU): the floor is searched around the camera's down axis, lower ground only along the path ahead",
                frame.key
            ),
        }
        out.gravity = Some(hazard.gravity);
    }
    health.set_status(seeing, format!("{:?} ground{gravity}, rumble {:?}, {body}{nav}", hazard.ground, hazard.rumble));
    // The intent first: it is what the user feels, the rest is for monitors.
    for result in [
        out.haptic.put(capture_ns, &intent).await,
        out.hazard.put(capture_ns, &hazard).await,
        out.scan.put(capture_ns, &perception.scan).await,
    ] {
        if let Err(e) = result {
            tracing::warn!("{e:#}");
        }
    }
    Some(perception.scan)
}

/// Frames keep coming but none can be used: say so with a degraded hazard (rumble
/// `Both`: stop) and the distinct "unavailable" cue, rather than fall silent.
async fn publish_blind(capture_ns: u64, blind: Blind, health: &Arc<Health>, out: &mut Outputs) {
    health.set_status(false, "depth frames unusable: obstacle detection degraded");
    tracing::warn!("{REJECTIONS_BEFORE_BLIND}+ unusable depth frames in a row: reporting degraded");
    for result in [out.haptic.put(capture_ns, &blind.intent).await, out.hazard.put(capture_ns, &blind.hazard).await] {
        if let Err(e) = result {
            tracing::warn!("{e:#}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::turn_rate_news;

    #[test]
    fn the_log_tells_the_learnt_turning_rate_once_and_again_when_it_moves_five_degrees_a_second() {
        let mut told = None;
        assert_eq!(turn_rate_news(&mut told, None), None, "nothing learnt yet");
        let first = turn_rate_news(&mut told, Some(31.2));
        assert_eq!(
            first.as_deref(),
            Some("the predictive cue's model of the user now turns at 31°/s, learnt from their turns on the rumble")
        );
        assert_eq!(turn_rate_news(&mut told, Some(34.0)), None);
        assert_eq!(turn_rate_news(&mut told, Some(27.0)), None, "4.2°/s from the rate told");
        let moved = turn_rate_news(&mut told, Some(25.9));
        assert_eq!(moved.as_deref(), Some("the predictive cue's model of the user now turns at 26°/s (was 31°/s)"));
        assert_eq!(told, Some(25.9));
    }
}
