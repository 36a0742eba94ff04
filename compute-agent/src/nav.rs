//! Localization, route planning and guidance in the compute agent: the bus side of
//! [`localization::Tracker`] and [`guidance::Navigator`].
//!
//! In: the body's odometry and gyro (from the loop), each frame's scan with the cane's
//! and the body's turn rates, the worn phone's compass (`sensor/<device>/motion`, when
//! the map says where north is), a barometer's readings (`sensor/*/pressure`, when the
//! map gives its floors' heights: a floor reached is taken as the user's word is),
//! `cmd/*` commands, `query/destinations` and `query/route`, and `feedback/applied` (an
//! instruction the feedback agent dropped or cut off is given again).
//! Out: `localization/pose`, `route/state` (5 Hz, and at once when a command changes
//! it), and speech intents at `Message` priority on `feedback/speech`: the position
//! found or lost, the guide's instructions (never before localization tracks), and a
//! floor the user said that the barometer's height is not, to be checked.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use bus::{Health, Lane, Publisher, Query, Queryable, Received, Subscriber};
use guidance::{Barometer, GuidanceProfile, Navigator, UserPose};
use localization::{Pose2, Tracker, TrackerConfig};
use map::{Building, Cell};
use perception::body_rate::BodyRate;
use perception::predictive::Way;
use planning::UserProfile;
use schemas::{
    Applied, AppliedAction, CameraPlace, Command, ImuBatch, Keys, OdomIncrement, PhoneMotion, Pose, Pressure, Priority,
    RouteState, RouteStatus, Scan, SpeechIntent,
};

use crate::run::AGENT;

/// A floor plan's occupied cells as points, at most one per 10 cm square.
fn wall_points(grid: &map::OccupancyGrid) -> Vec<[f64; 2]> {
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    for row in 0..grid.height() {
        for col in 0..grid.width() {
            if grid.get(col, row) == Some(Cell::Occupied) {
                let (x, y) = grid.cell_center(col, row);
                if seen.insert(((x / 0.1).floor() as i64, (y / 0.1).floor() as i64)) {
                    out.push([x, y]);
                }
            }
        }
    }
    out
}

/// A barometer reading older than this says nothing of where the user stands now, ns.
const BAROMETER_FRESH_NS: u64 = 2_000_000_000;

/// What the barometer says of the user's height at `now_ns` for the guide: unread when
/// no reading was taken within [`BAROMETER_FRESH_NS`] (none, or it stopped sending),
/// else whether its height is held at the estimate's floor (`held`,
/// `Tracker::height_held`).
fn barometer_state(last_reading_ns: Option<u64>, now_ns: u64, held: bool) -> Barometer {
    match last_reading_ns {
        Some(t) if now_ns.saturating_sub(t) < BAROMETER_FRESH_NS && held => Barometer::AtFloor,
        Some(t) if now_ns.saturating_sub(t) < BAROMETER_FRESH_NS => Barometer::OffFloor,
        _ => Barometer::Unread,
    }
}

/// Period of `localization/pose` and `route/state`.
pub const STATE_PERIOD: Duration = Duration::from_millis(200);

/// Oldest command acted on, from its capture: a command replayed or stuck in a queue
/// for longer is refused as stale (as the feedback agent's speech bound).
pub const MAX_COMMAND_AGE: Duration = Duration::from_secs(5);

/// The floor map.
#[derive(Debug, Clone)]
pub enum MapSource {
    /// A building manifest (`building.toml`, as `wearnav map` writes it), or the
    /// directory holding one.
    File(PathBuf),
    /// A building already in memory (the demo's: the simulated world's floor plan),
    /// with a name for the logs.
    Loaded(String, Box<Building>),
}

impl MapSource {
    fn name(&self) -> String {
        match self {
            MapSource::File(p) => p.display().to_string(),
            MapSource::Loaded(name, _) => name.clone(),
        }
    }

    fn building(&self) -> anyhow::Result<Building> {
        match self {
            MapSource::File(p) => load_building(p),
            MapSource::Loaded(_, b) => Ok((**b).clone()),
        }
    }
}

/// What the agent navigates with.
#[derive(Debug, Clone)]
pub struct NavConfig {
    /// The floor map.
    pub map: MapSource,
    /// Where the user stands at the start (floor, pose), when known; otherwise the
    /// filter starts over every floor and guidance waits until it tracks.
    pub start: Option<(i32, Pose2)>,
    /// The particle filter as the agent runs it.
    pub tracker: TrackerConfig,
    /// Route preferences (stairs, elevator, distance to walls).
    pub route: UserProfile,
    /// Guidance wording and spacing.
    pub guidance: GuidanceProfile,
    /// Seed of the filter's random draws.
    pub seed: u64,
    /// What the perception holds that the map lacks goes onto the planner, and a route
    /// with something standing on it ahead is laid round it (`Navigator::perceived`).
    pub ways_round: bool,
}

impl NavConfig {
    /// Defaults for the building `map`.
    pub fn new(map: MapSource) -> Self {
        Self {
            map,
            start: None,
            tracker: TrackerConfig::default(),
            route: UserProfile::default(),
            guidance: GuidanceProfile::default(),
            seed: 1,
            ways_round: false,
        }
    }
}

/// Loads the building manifest at `path` (or `path/building.toml`).
pub fn load_building(path: &Path) -> anyhow::Result<Building> {
    let manifest = if path.is_dir() { path.join("building.toml") } else { path.to_path_buf() };
    Building::load(&manifest).with_context(|| format!("cannot load the floor map {}", manifest.display()))
}

/// Loads the user's guidance profile (TOML, fields of [`GuidanceProfile`]) at `path`;
/// refused with the file and the field named.
pub fn load_guidance_profile(path: &Path) -> anyhow::Result<GuidanceProfile> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    GuidanceProfile::from_toml(&text).with_context(|| format!("bad guidance profile {}", path.display()))
}

/// The navigation half of the agent.
pub struct Nav {
    tracker: Tracker,
    navigator: Navigator,
    cane_rate: BodyRate,
    /// device whose IMU is worn on the body (its samples are not the cane's)
    body_device: Option<String>,
    keys: Keys,
    pose_out: Publisher<Pose>,
    camera_out: Publisher<CameraPlace>,
    route_out: Publisher<RouteState>,
    speech_out: Publisher<SpeechIntent>,
    pub(crate) commands: Subscriber<Command>,
    pub(crate) cane_imu: Subscriber<ImuBatch>,
    /// the worn phone's compass; `None` without one or on a map without north
    pub(crate) motion: Option<Subscriber<PhoneMotion>>,
    /// barometers' readings (`sensor/*/pressure`); `None` on a map without floors'
    /// heights. The first device heard is the one read.
    pub(crate) pressure: Option<Subscriber<Pressure>>,
    barometer_device: Option<String>,
    /// when the last barometer reading was taken, ns (the bus's clock)
    pressure_at_ns: Option<u64>,
    /// no reading from the barometer read before for [`BAROMETER_FRESH_NS`] (logged)
    barometer_silent: bool,
    /// what the feedback agent did: an instruction it never finished is given again
    pub(crate) applied: Subscriber<Applied>,
    pub(crate) destinations: Queryable,
    pub(crate) routes: Queryable,
    serial: u64,
    started_ns: u64,
    /// Each floor's walls as points about 10 cm apart (what the user is taken to know),
    /// and the way ahead and the walls near the user for the predictive cue.
    walls: Vec<(i32, Vec<[f64; 2]>)>,
    way: Vec<[f64; 2]>,
    walls_near: Vec<[f64; 2]>,
    /// what the perception holds, map frame, and whether it goes onto the planner
    held: Vec<[f64; 2]>,
    ways_round: bool,
}

impl Nav {
    /// Loads the map, starts the filter and declares the streams.
    pub async fn declare(
        config: &NavConfig,
        session: &zenoh::Session,
        keys: &Keys,
        body_device: Option<String>,
        compass_device: Option<&str>,
        health: &Arc<Health>,
    ) -> anyhow::Result<Self> {
        let building = config.map.building()?;
        let mut tracker = Tracker::new(&building, config.tracker.clone(), config.seed)
            .with_context(|| format!("cannot localize on {}", config.map.name()))?;
        match config.start {
            Some((level, pose)) => tracker.start_at(level, pose).context("bad start pose")?,
            None => tracker.start_global(),
        }
        let navigator = Navigator::new(&building, config.route, config.guidance);
        let motion = match (compass_device, tracker.has_north()) {
            (Some(device), true) => {
                schemas::keys::check_chunk("device", device).context("bad compass device")?;
                tracing::info!("localization reads the compass of {}", keys.motion(device));
                Some(Subscriber::declare(session, keys.motion(device), false, health).await?)
            }
            (Some(_), false) => {
                tracing::info!("the floor map gives no north (north_deg): no compass is read");
                None
            }
            (None, _) => None,
        };
        let pressure = if tracker.has_elevations() {
            tracing::info!("floor changes are also read from a barometer ({})", keys.pressure_any());
            Some(Subscriber::declare(session, keys.pressure_any(), false, health).await?)
        } else {
            tracing::info!("the floor map gives no floor heights (elevation_m): floors only from the user's word");
            None
        };
        let floors: Vec<String> = building.floors().iter().map(|f| f.level.to_string()).collect();
        tracing::info!(
            "floor map {}: floors {}, {} destinations; {}",
            config.map.name(),
            floors.join(", "),
            navigator.destinations().destinations.len(),
            match config.start {
                Some((level, p)) => format!("starting at ({:.2}, {:.2}) on floor {level}", p.x_m, p.y_m),
                None => "start unknown: localizing over every floor".to_string(),
            }
        );
        Ok(Self {
            tracker,
            navigator,
            cane_rate: BodyRate::default(),
            body_device,
            keys: keys.clone(),
            pose_out: Publisher::declare(session, keys.pose(), AGENT, Lane::Telemetry, Some(health)).await?,
            camera_out: Publisher::declare(session, keys.camera_place(), AGENT, Lane::Telemetry, Some(health)).await?,
            route_out: Publisher::declare(session, keys.route_state(), AGENT, Lane::Events, Some(health)).await?,
            speech_out: Publisher::declare(session, keys.speech(), AGENT, Lane::RealTime, Some(health)).await?,
            commands: Subscriber::declare_fresh(session, keys.cmd_any(), false, MAX_COMMAND_AGE, health).await?,
            cane_imu: Subscriber::declare(session, keys.imu_any(), false, health).await?,
            motion,
            pressure,
            barometer_device: None,
            pressure_at_ns: None,
            barometer_silent: false,
            applied: Subscriber::declare(session, keys.applied(), false, health).await?,
            destinations: Queryable::declare(session, keys.query("destinations"), health).await?,
            routes: Queryable::declare(session, keys.query("route"), health).await?,
            serial: 0,
            started_ns: bus::now_ns(),
            walls: building.floors().iter().map(|f| (f.level, wall_points(&f.grid))).collect(),
            way: Vec::new(),
            walls_near: Vec::new(),
            held: Vec::new(),
            ways_round: config.ways_round,
        })
    }

    /// The pose as guidance reads it: confident while the filter tracks or follows the
    /// place from a known one ([`localization::Estimate::guides`]).
    fn user_pose(&self) -> UserPose {
        let e = self.tracker.estimate();
        UserPose {
            x_m: e.pose.x_m,
            y_m: e.pose.y_m,
            heading_rad: e.pose.heading_rad,
            floor: e.level,
            confident: e.guides(),
        }
    }

    fn now_ms(&self) -> u64 {
        bus::now_ns().saturating_sub(self.started_ns) / 1_000_000
    }

    /// Where the user heads, for the predictive cue: the route from the user's place on
    /// this floor and the floor's walls near them, in the body's frame at the filter's
    /// pose. `None` (the cost functions decide) while the filter does not track, tracks
    /// a place a search found that the user has not confirmed, or no route is being
    /// followed.
    pub fn way(&mut self) -> Option<Way<'_>> {
        let e = self.tracker.estimate();
        if e.status != localization::Status::Tracking || e.searched {
            return None;
        }
        let pose = self.user_pose();
        let state = self.navigator.state(&pose);
        if state.status != RouteStatus::Guiding {
            return None;
        }
        let walls = self.walls.iter().find(|(level, _)| *level == pose.floor).map_or(&[][..], |(_, w)| w);
        let ends_at_goal = guidance::way_ahead(&pose, &state, walls, &mut self.way, &mut self.walls_near);
        Some(Way { points: &self.way, ends_at_goal, walls: &self.walls_near })
    }

    /// One odometry increment of the body, with the body's gyro rate over it.
    pub fn odometry(&mut self, inc: &Received<OdomIncrement>, body_yaw_rate: Option<f32>, health: &Health) {
        match self.tracker.odometry(&inc.body, body_yaw_rate.map(f64::from)) {
            Ok(()) => self.navigator.walked(f64::from(inc.body.forward_m).hypot(f64::from(inc.body.left_m))),
            Err(e) => health.reject(&inc.key, "implausible", &e),
        }
    }

    /// IMU samples of a device other than the body's: the cane's (its turn rate carries
    /// the sweep).
    pub fn imu(&mut self, batch: &Received<ImuBatch>, health: &Health) {
        let device = self.keys.device_of(&batch.key);
        if device.is_none() || device == self.body_device.as_deref() {
            return;
        }
        for s in &batch.body.samples {
            if let Err(e) = self.cane_rate.add(s, batch.received_ns) {
                health.reject(&batch.key, e.kind(), &e);
            }
        }
    }

    /// The worn phone's compass heading, if it gave one: to the filter. A reading that
    /// is no heading or that the phone itself doubts is refused and counted.
    pub fn motion(&mut self, motion: &Received<PhoneMotion>, health: &Health) {
        let Some(heading_deg) = motion.body.heading_deg else { return };
        if let Err(e) = self.tracker.compass(heading_deg, motion.body.accuracy_deg) {
            let kind = match e {
                localization::CompassRefused::NoNorth => "no_north",
                localization::CompassRefused::NotAHeading(_) => "not_a_heading",
                localization::CompassRefused::Unsure(_) => "compass_unsure",
            };
            health.reject(&motion.key, kind, &e);
        }
    }

    /// A barometer's reading: a floor reached is taken as the user's word for it would
    /// be (the guide starts the floor's leg, or the user hears "Floor 2."); a floor the
    /// user said that the height is not, they are asked to check (once for each word).
    /// Readings of a second barometer, or that are no pressure, are refused and counted.
    pub async fn pressure(&mut self, reading: &Received<Pressure>, health: &Health) {
        let device = self.keys.device_of(&reading.key).unwrap_or_default().to_string();
        match &self.barometer_device {
            None => {
                tracing::info!("reading the barometer of {device}");
                self.barometer_device = Some(device);
            }
            Some(d) if *d != device => {
                let why = format!("the barometer of {d} is read; one of {device} too would mix two heights");
                health.reject(&reading.key, "second_barometer", &why);
                return;
            }
            Some(_) => {}
        }
        let taken = self.tracker.pressure(reading.body.stamp_ns, f64::from(reading.body.pressure_pa));
        if !matches!(taken, Err(localization::PressureError::Refused(_))) {
            self.pressure_at_ns = Some(bus::now_ns());
        }
        let level = match taken {
            Ok(Some(localization::FloorNews::Reached(level))) => level,
            Ok(Some(localization::FloorNews::Disagrees { said, felt })) => {
                tracing::warn!("the user said floor {said}; the barometer's height is floor {felt}'s");
                let text = format!(
                    "You said floor {said}, but the height I measure is floor {felt}'s. Please check which floor you are on, and tell me."
                );
                let speech = self.speech(&text, "floor/check");
                return self.say(bus::now_ns(), speech).await;
            }
            Ok(None) => return,
            Err(e @ localization::PressureError::Refused(_)) => {
                return health.reject(&reading.key, "not_a_pressure", &e)
            }
            Err(e) => return tracing::warn!("the barometer says the user changed floors, but {e}"),
        };
        tracing::info!("localization: floor {level} reached (the barometer)");
        let (pose, now_ms) = (self.user_pose(), self.now_ms());
        let response = self.navigator.command(&Command::Floor { floor: level }, &pose, now_ms);
        for speech in response.speech {
            tracing::info!("answer: {}", speech.text);
            self.say(bus::now_ns(), speech).await;
        }
        self.publish_state().await;
    }

    /// Says in the log when the barometer read before falls silent, and when it is
    /// heard again.
    fn log_barometer_silence(&mut self, barometer: Barometer) {
        let (Some(device), silent) = (self.barometer_device.as_deref(), barometer == Barometer::Unread) else {
            return;
        };
        if silent && !self.barometer_silent {
            tracing::warn!(
                "no reading from the barometer of {device} for {} s: floors reached are noticed only when the user says them",
                BAROMETER_FRESH_NS / 1_000_000_000
            );
        } else if !silent && self.barometer_silent {
            tracing::info!("the barometer of {device} is heard again");
        }
        self.barometer_silent = silent;
    }

    /// One frame's scan and the obstacle points the perception holds (the camera's
    /// floor frame, x forward, y left): the filter corrects, what stands on the route
    /// ahead and the floor plan lacks gets a way round (`Navigator::perceived`), the
    /// guide speaks if it has something to say.
    pub async fn frame(&mut self, scan: &Scan, held: &[[f32; 2]], capture_ns: u64, body_yaw_rate: Option<f32>) {
        let cane = self.cane_rate.rate_at(capture_ns, bus::now_ns()).map(f64::from);
        self.tracker.frame(scan, capture_ns, cane, body_yaw_rate.map(f64::from));
        // where this frame's scan lies on the map, at the frame's capture (for viewers)
        let (camera, yaw) = self.tracker.camera_in_map();
        let estimate = self.tracker.estimate();
        let place = CameraPlace {
            x_m: camera[0] as f32,
            y_m: camera[1] as f32,
            yaw_rad: localization::wrap_angle(yaw) as f32,
            floor: estimate.level,
            status: localization::tracker::wire_status(estimate.status),
        };
        if [place.x_m, place.y_m, place.yaw_rad].iter().all(|v| v.is_finite()) {
            if let Err(e) = self.camera_out.put(capture_ns, &place).await {
                tracing::warn!("{e:#}");
            }
        }
        let news = self.tracker.news();
        if let Some(news) = news {
            tracing::info!("localization: {news}");
            self.serial += 1;
            let speech = guidance::instruction::localization_news(news, self.serial);
            self.say(capture_ns, speech).await;
        }
        let pose = self.user_pose();
        let now_ms = self.now_ms();
        // a barometer that stopped sending says nothing of where the user stands
        let barometer = barometer_state(self.pressure_at_ns, bus::now_ns(), self.tracker.height_held());
        self.log_barometer_silence(barometer);
        self.navigator.set_barometer(barometer);
        self.navigator.set_awaiting_word(self.tracker.estimate().awaits_word());
        if self.ways_round {
            let camera = self.tracker.points_in_map(held, &mut self.held);
            let before = self.navigator.detours().0;
            self.navigator.perceived(&pose, camera, &self.held, now_ms);
            if self.navigator.detours().0 > before {
                let (cells, _) = self.navigator.perceived_obstacles();
                tracing::info!("guidance: something stands on the route ahead: a way round ({cells} cells seen that the map lacks)");
            }
        }
        if let Some(speech) = self.navigator.step_after_news(&pose, news, now_ms) {
            tracing::info!("guidance: {}", speech.text);
            self.say(capture_ns, speech).await;
        }
        if let Some(problem) = self.navigator.take_problem() {
            tracing::warn!("{problem}");
        }
    }

    /// What the feedback agent did: an instruction of the guide it dropped (stale) or
    /// cut off (a warning) is given again with the words of then (`Guide::not_heard`).
    pub fn applied(&mut self, applied: &Applied) {
        if let AppliedAction::SpeechDropped { text, .. } | AppliedAction::SpeechInterrupted { text } = &applied.action {
            if self.navigator.not_heard(text) {
                tracing::info!("guidance: not heard ({}), to be said again: {text}", applied.device);
            }
        }
    }

    /// A user command.
    pub async fn command(&mut self, cmd: &Received<Command>) {
        tracing::info!("command {:?} from {}", cmd.body, cmd.header.sender);
        let pose = self.user_pose();
        let now_ms = self.now_ms();
        self.navigator.set_awaiting_word(self.tracker.estimate().awaits_word());
        let response = self.navigator.command(&cmd.body, &pose, now_ms);
        let stamp = bus::now_ns();
        if let Some(level) = response.floor_confirmed {
            if let Err(e) = self.tracker.floor_confirmed(level) {
                tracing::warn!("floor {level} confirmed, but {e}");
                let speech = self.speech(&format!("I cannot move you to floor {level}: {e}."), "floor");
                self.say(stamp, speech).await;
            }
        }
        if let Some(number) = &response.door {
            let text = match self.tracker.door(number) {
                Ok(()) => {
                    tracing::info!("localization: door {number:?} taken");
                    format!("Door {number}.")
                }
                Err(e) => {
                    tracing::warn!("localization: {e}");
                    format!("Door {number} is not on my map.")
                }
            };
            let speech = self.speech(&text, "door");
            self.say(stamp, speech).await;
        }
        if let Some((name, at)) = &response.place {
            let text = match self.tracker.place(at.floor, [at.x, at.y]) {
                Ok(()) => {
                    tracing::info!("localization: near {name:?} taken (floor {}, {:.1}, {:.1})", at.floor, at.x, at.y);
                    format!("Near {name}.")
                }
                Err(e) => {
                    tracing::warn!("localization: near {name:?} refused: {e}");
                    format!("{name} is not on my map.")
                }
            };
            let speech = self.speech(&text, "place");
            self.say(stamp, speech).await;
        }
        for speech in response.speech {
            tracing::info!("answer: {}", speech.text);
            self.say(stamp, speech).await;
        }
        if let Some(problem) = self.navigator.take_problem() {
            tracing::warn!("{problem}");
        }
        self.publish_state().await;
    }

    /// Answers `query/destinations`.
    pub async fn answer_destinations(&self, query: Query) {
        if let Err(e) = query.reply(AGENT, &self.navigator.destinations()).await {
            tracing::warn!("{e:#}");
        }
    }

    /// Answers `query/route?to=LABEL`: the route from the user's place, not followed.
    pub async fn answer_route(&mut self, query: Query) {
        let pose = self.user_pose();
        let result = match query.parameter("to") {
            None => Err("say where to: query/route?to=<destination>".to_string()),
            Some(to) => self.navigator.preview(&pose, &to),
        };
        let sent = match result {
            Ok(state) => query.reply(AGENT, &state).await,
            Err(text) => query.reply_err(&text).await,
        };
        if let Err(e) = sent {
            tracing::warn!("{e:#}");
        }
    }

    /// Publishes pose and route state.
    pub async fn publish_state(&mut self) {
        let stamp = bus::now_ns();
        let pose = self.tracker.pose();
        let route = self.navigator.state(&self.user_pose());
        for result in [self.pose_out.put(stamp, &pose).await, self.route_out.put(stamp, &route).await] {
            if let Err(e) = result {
                tracing::warn!("{e:#}");
            }
        }
    }

    /// A one-line summary for the health status.
    pub fn status(&self) -> String {
        let e = self.tracker.estimate();
        let route = self.navigator.state(&self.user_pose());
        format!(
            "localization {:?} ({:.1}, {:.1}) floor {}, route {:?}{}",
            localization::tracker::wire_status(e.status),
            e.pose.x_m,
            e.pose.y_m,
            e.level,
            route.status,
            if route.destination.is_empty() { String::new() } else { format!(" to {}", route.destination) }
        )
    }

    fn speech(&mut self, text: &str, key: &str) -> SpeechIntent {
        self.serial += 1;
        SpeechIntent {
            text: text.to_string(),
            priority: Priority::Message,
            interrupt: false,
            ttl_ms: 5000,
            dedup_key: format!("{key}/{}", self.serial),
            notice: false,
        }
    }

    async fn say(&mut self, capture_ns: u64, speech: SpeechIntent) {
        if let Err(e) = self.speech_out.put(capture_ns, &speech).await {
            tracing::warn!("{e:#}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_barometer_that_stopped_sending_two_seconds_ago_is_unread_for_the_guide() {
        let t = 50_000_000_000;
        assert_eq!(barometer_state(None, t, true), Barometer::Unread);
        assert_eq!(barometer_state(Some(t - 1_999_000_000), t, true), Barometer::AtFloor);
        assert_eq!(barometer_state(Some(t - 1_999_000_000), t, false), Barometer::OffFloor);
        assert_eq!(barometer_state(Some(t - 2_000_000_000), t, true), Barometer::Unread);
        assert_eq!(barometer_state(Some(t - 2_000_000_000), t, false), Barometer::Unread);
        // `now` read before the reading arrived: fresh, not unread
        assert_eq!(barometer_state(Some(t + 5), t, false), Barometer::OffFloor);
    }
}
