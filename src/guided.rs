//! `wearnav demo --destination LABEL`: a guided walk on the simulated world. The compute
//! agent localizes on the world's floor plan (exported as `wearnav map` would, never
//! the simulator's truth) and guides; the simulated user walks by the route it gives,
//! as seen from where the device believes the user is, takes elevators when told to,
//! and says which floor they reached (with `--floor-unsaid` it does not: the barometer
//! finds it, and the user says it only when the device asks them to). The demo reads the bus for the walker (route
//! state, pose), sends the user's commands, prints what is said, and ends on arrival.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use bus::{Health, Lane, Publisher, Subscriber};
use compute_agent::nav::{MapSource, NavConfig};
use localization::Pose2;
use map::Building;
use schemas::{Applied, AppliedAction, Command, GroundTruth, Keys, Pose, RouteState, RouteStatus, SpeechIntent};
use sensor_agent::sim::source::Guidance;
use sensor_agent::sim::{Directions, DirectionsHandle, SimConfig, SimSource, World};
use sensor_agent::source::FrameSource;

/// Sender name of the user's commands in the demo.
const USER: &str = "demo-user";

/// Navigation on a simulated world: its floor plan (exported as `wearnav map` would)
/// for the compute agent, which starts where the world's walk starts (the user says
/// where they stand, as at a building's entrance).
pub fn sim_navigation(source: &str) -> anyhow::Result<Option<(World, NavConfig)>> {
    let Some(world_name) = source.strip_prefix("sim:") else {
        return Ok(None);
    };
    let world = World::load(world_name).with_context(|| format!("cannot load world {world_name:?}"))?;
    let building = study::floor_plan::export(&world, study::floor_plan::DEFAULT_RESOLUTION_M)
        .with_context(|| format!("cannot make a floor plan of {}", world.name()))?;
    let start = world.start();
    let mut nav = NavConfig::new(MapSource::Loaded(format!("floor plan of {}", world.name()), Box::new(building)));
    nav.start = Some((start.floor, Pose2::new(start.x_m, start.y_m, start.yaw_rad)));
    // the simulated user rides elevators but does not climb stairs
    nav.route.prefer_elevator = true;
    Ok(Some((world, nav)))
}

/// How the simulated user and their devices behave on a guided walk.
#[derive(Debug, Clone, Copy)]
pub struct WalkOptions {
    /// a second depth camera worn at the chest
    pub chest: bool,
    /// the user says the floor a lift took them to (else only when the device asks)
    pub says_floor: bool,
    /// a fault: the cane board's barometer stops sending when the first ride starts
    pub barometer_stops_in_ride: bool,
}

/// A guided walk set up before the agents start.
pub struct GuidedWalk {
    /// where to
    pub label: String,
    /// the place's position (floor, x, y) on the floor plan
    pub place: (i32, f64, f64),
    /// the simulated camera, walked by guidance (taken by the sensor agent)
    pub source: Option<Box<dyn FrameSource>>,
    directions: DirectionsHandle,
    says_floor: bool,
}

impl GuidedWalk {
    /// The simulated camera of `world` walked by guidance to `label` on `building`.
    pub fn prepare(world: &World, nav: &NavConfig, label: &str, options: WalkOptions) -> anyhow::Result<Self> {
        let MapSource::Loaded(_, building) = &nav.map else {
            bail!("a guided walk needs the simulated world's own floor plan");
        };
        let place = find_label(building, label)?;
        let directions: DirectionsHandle = Arc::new(Mutex::new(Directions::default()));
        let config = SimConfig {
            world: world.name().to_string(),
            guided_by: Some(Guidance(directions.clone())),
            chest: options.chest.then(sensor_agent::sim::ChestMount::default),
            barometer_stops_in_ride: options.barometer_stops_in_ride,
            ..SimConfig::default()
        };
        let sim = SimSource::new(config).with_context(|| format!("cannot simulate {:?}", world.name()))?;
        Ok(Self {
            label: place.0,
            place: place.1,
            source: Some(Box::new(sim)),
            directions,
            says_floor: options.says_floor,
        })
    }
}

/// The label called `asked` on any floor (case-insensitive), or the names there are.
fn find_label(building: &Building, asked: &str) -> anyhow::Result<(String, (i32, f64, f64))> {
    let labels: Vec<&map::Label> = building.floors().iter().flat_map(|f| f.semantic.labels.iter()).collect();
    match labels.iter().find(|l| l.name.eq_ignore_ascii_case(asked.trim())) {
        Some(l) => Ok((l.name.clone(), (l.floor, l.x, l.y))),
        None => {
            let names: Vec<&str> = labels.iter().map(|l| l.name.as_str()).collect();
            bail!("no place called {asked:?} on this world's floor plan; places: {}", names.join(", "))
        }
    }
}

/// The demo's side of a guided walk, once the agents run.
pub struct GuidedWatch {
    label: String,
    place: (i32, f64, f64),
    directions: DirectionsHandle,
    pub(crate) route: Subscriber<RouteState>,
    pub(crate) pose: Subscriber<Pose>,
    pub(crate) speech: Subscriber<SpeechIntent>,
    pub(crate) truth: Subscriber<GroundTruth>,
    destination_out: Publisher<Command>,
    floor_out: Publisher<Command>,
    started: Instant,
    asked_at: Option<Instant>,
    accepted: bool,
    last_status: Option<RouteStatus>,
    last_truth: Option<GroundTruth>,
    arrived_at: Option<Instant>,
    /// the arrival's words were spoken to their end (or cut, or dropped) by a device
    arrival_ended: bool,
    utterances: usize,
    floors_said: Vec<i32>,
    says_floor: bool,
    /// floors reached by lift and not said
    floors_unsaid: Vec<i32>,
    /// the floor reached by lift that the user has not said yet
    unsaid: Option<i32>,
    /// the device asked the user to say the floor they are on
    floor_asked: bool,
    /// floors said because the device asked
    floors_said_when_asked: Vec<i32>,
}

impl GuidedWatch {
    /// Subscribes what the walker needs and declares the user's command keys.
    pub async fn declare(
        walk: &GuidedWalk,
        session: &zenoh::Session,
        keys: &Keys,
        health: &Arc<Health>,
    ) -> anyhow::Result<Self> {
        Ok(Self {
            label: walk.label.clone(),
            place: walk.place,
            directions: walk.directions.clone(),
            route: Subscriber::declare(session, keys.route_state(), true, health).await?,
            pose: Subscriber::declare(session, keys.pose(), true, health).await?,
            speech: Subscriber::declare(session, keys.speech(), false, health).await?,
            truth: Subscriber::declare(session, keys.truth_any(), true, health).await?,
            destination_out: Publisher::declare(session, keys.cmd("destination"), USER, Lane::Events, Some(health))
                .await?,
            floor_out: Publisher::declare(session, keys.cmd("floor"), USER, Lane::Events, Some(health)).await?,
            started: Instant::now(),
            asked_at: None,
            accepted: false,
            last_status: None,
            last_truth: None,
            arrived_at: None,
            arrival_ended: false,
            utterances: 0,
            floors_said: Vec::new(),
            says_floor: walk.says_floor,
            floors_unsaid: Vec::new(),
            unsaid: None,
            floor_asked: false,
            floors_said_when_asked: Vec::new(),
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Directions> {
        match self.directions.lock() {
            Ok(d) => d,
            Err(poisoned) => poisoned.into_inner(),
        }
    }

    fn stamp(&self) -> String {
        format!("[{:6.1}s]", self.started.elapsed().as_secs_f32())
    }

    /// What a feedback device did: whether the arrival's words are over.
    pub fn on_applied(&mut self, a: &Applied) {
        let ended = match &a.action {
            AppliedAction::SpeechFinished { text }
            | AppliedAction::SpeechInterrupted { text }
            | AppliedAction::SpeechDropped { text, .. } => text,
            _ => return,
        };
        // the guide's words for it ("You have arrived at room 204.")
        if self.arrived_at.is_some() && ended.starts_with("You have arrived") {
            self.arrival_ended = true;
        }
    }

    /// Arrived, and the arrival's words are over (or `limit` has passed since arrival,
    /// for a device that never says what became of them).
    pub fn done(&self, limit: Duration) -> bool {
        self.arrived_at.is_some_and(|t| self.arrival_ended || t.elapsed() >= limit)
    }

    /// A route state: the walker's directions, and news for the terminal.
    pub fn on_route(&mut self, state: RouteState) {
        if state.destination.eq_ignore_ascii_case(&self.label) {
            self.accepted = true;
        }
        if self.last_status != Some(state.status) {
            eprintln!("{} route: {:?} {}", self.stamp(), state.status, describe(&state));
            self.last_status = Some(state.status);
        }
        if state.status == RouteStatus::Arrived && self.arrived_at.is_none() {
            self.arrived_at = Some(Instant::now());
        }
        let first_floor = state.route.first().map(|p| p.floor);
        let mut d = self.lock();
        d.status = Some(state.status);
        d.next = state.next_waypoint;
        d.next_floor = state.route.iter().map(|p| p.floor).find(|f| Some(*f) != first_floor);
    }

    /// The device's pose estimate.
    pub fn on_pose(&mut self, pose: Pose) {
        self.lock().estimate = Some(pose);
    }

    /// What the user hears; a user who does not say the floor on their own says it
    /// when asked to ("... tell me when you are on floor 1.").
    pub fn on_speech(&mut self, speech: &SpeechIntent) {
        self.utterances += 1;
        eprintln!("{} says ({:?}): {}", self.stamp(), speech.priority, speech.text);
        self.floor_asked |= speech.text.contains("tell me when you are on floor");
    }

    /// The simulator's truth (for the report only; the agents never see it).
    pub fn on_truth(&mut self, truth: GroundTruth) {
        self.last_truth = Some(truth);
    }

    /// Every quarter second: ask for the destination until the agent has it, and say
    /// the floor the walker reached.
    pub async fn tick(&mut self) {
        let due = self.asked_at.is_none_or(|t| t.elapsed() >= Duration::from_secs(2));
        if !self.accepted && due {
            eprintln!("{} user: take me to {}", self.stamp(), self.label);
            if let Err(e) =
                self.destination_out.put(bus::now_ns(), &Command::Destination { label: self.label.clone() }).await
            {
                eprintln!("{} {e:#}", self.stamp());
            }
            self.asked_at = Some(Instant::now());
        }
        let reached = self.lock().said_floor.take();
        if let Some(floor) = reached.filter(|_| !self.says_floor) {
            eprintln!("{} user: (out of the lift on floor {floor}, says nothing)", self.stamp());
            self.floors_unsaid.push(floor);
            self.unsaid = Some(floor);
        } else if let Some(floor) = reached {
            eprintln!("{} user: I am on floor {floor}", self.stamp());
            self.floors_said.push(floor);
            self.say_floor(floor).await;
        }
        if self.floor_asked {
            if let Some(floor) = self.unsaid.take() {
                self.floor_asked = false;
                eprintln!("{} user: (asked) I am on floor {floor}", self.stamp());
                self.floors_said_when_asked.push(floor);
                self.say_floor(floor).await;
            }
        }
    }

    async fn say_floor(&mut self, floor: i32) {
        if let Err(e) = self.floor_out.put(bus::now_ns(), &Command::Floor { floor }).await {
            eprintln!("{} {e:#}", self.stamp());
        }
    }

    /// The walk's result, printed; an error when the user did not arrive within 1 m.
    pub fn finish(&self) -> anyhow::Result<()> {
        let (floor, x, y) = self.place;
        let Some(t) = self.last_truth else {
            bail!("guided walk to {}: no ground truth seen, the simulated walk never ran", self.label);
        };
        let off_m = (f64::from(t.x_m) - x).hypot(f64::from(t.y_m) - y);
        let rides = match (self.floors_said.is_empty(), self.floors_unsaid.is_empty()) {
            (true, true) => "no elevator ride".to_string(),
            (false, _) => format!("floors said after elevator rides: {:?}", self.floors_said),
            (true, false) if self.floors_said_when_asked.is_empty() => {
                format!("floors reached by elevator, not said: {:?}", self.floors_unsaid)
            }
            (true, false) => format!(
                "floors reached by elevator, not said: {:?}, said when the device asked: {:?}",
                self.floors_unsaid, self.floors_said_when_asked
            ),
        };
        let place = format!("{} (floor {floor}, {x:.2}, {y:.2})", self.label);
        match self.arrived_at {
            Some(at) => eprintln!(
                "guided walk summary: arrived at {place} after {:.1} s; the user stands {off_m:.2} m from it on floor {}; {} utterances; {rides}",
                (at - self.started).as_secs_f32(),
                t.floor,
                self.utterances
            ),
            None => eprintln!(
                "guided walk summary: NOT arrived at {place} after {:.1} s (route {:?}); the user stands {off_m:.2} m from it on floor {}; {} utterances; {rides}",
                self.started.elapsed().as_secs_f32(),
                self.last_status,
                t.floor,
                self.utterances
            ),
        }
        if self.arrived_at.is_none() {
            bail!("the guided walk did not arrive at {}", self.label);
        }
        if t.floor != floor || off_m > 1.0 {
            bail!("guidance said arrived, but the user is {off_m:.2} m from {} on floor {}", self.label, t.floor);
        }
        Ok(())
    }
}

/// "4 points, 21.3 m left, next (19.00, 5.00) on floor 0".
fn describe(s: &RouteState) -> String {
    match s.next_waypoint {
        Some(n) => format!(
            "to {}: {} points, {:.1} m left, next ({:.2}, {:.2}) on floor {}",
            s.destination,
            s.route.len(),
            s.distance_left_m,
            n.x_m,
            n.y_m,
            n.floor
        ),
        None if s.destination.is_empty() => String::new(),
        None => format!("to {}", s.destination),
    }
}
