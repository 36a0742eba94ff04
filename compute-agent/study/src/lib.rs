//! `wearnav course`: the virtual user study (issue 6). Taylor (2017, ch. 3) put 22
//! blindfolded volunteers through a 10 x 10 m obstacle course and counted contacts;
//! here a simulated user walks the simulated course in a closed loop with the same
//! perception, cue and feedback code the agents run, faster than real time and
//! deterministic per seed, and the same table comes out.
//!
//! | concept | module |
//! | --- | --- |
//! | what the hands feel (feedback step -> rumble state) | [`hands`] |
//! | the walking, reacting person; what they head for ([`virtual_user::Guide`]) | [`virtual_user`] |
//! | walking by spoken guidance (`--guide spoken`) | [`spoken`] |
//! | cane and body contacts, field-of-view test | [`contacts`] |
//! | one closed-loop walk | [`walk`] |
//! | N walks and the table | [`study`] |
//! | two configurations on the same seeds, walk by walk | [`compare`] |
//! | groups of worlds (generated kinds), a table per group and overall | [`world_groups`] |

pub mod compare;
pub mod contacts;
pub mod floor_plan;
pub mod guided_walk;
pub mod hands;
pub mod localize_walk;
pub mod oracle;
pub mod spoken;
pub mod study;
pub mod virtual_user;
pub mod walk;
pub mod world_groups;

use anyhow::Context;
use perception::predictive::{Guards, PredictiveConfig};
use schemas::CostFunction;
use sim::{CameraProfile, World};

use contacts::Part;
use study::{study_with_progress, table, LeadTimes};
use walk::{GuideKind, RouteMap, WalkConfig};

/// Cost function on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Cost {
    /// Fully-Integrated Cost Function.
    Ficf,
    /// Cushioned Avoidance Cost Function.
    Cacf,
}

/// Depth camera of the walks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Camera {
    /// Asus Xtion at 320x240 (its QVGA mode), perception stride 1.
    XtionQvga,
    /// Asus Xtion at 640x480, perception stride 2 (the agent's default).
    Xtion,
    /// Intel RealSense D435 at 848x480, perception stride 2.
    D435,
}

impl Camera {
    /// The camera profile and the perception stride that goes with it.
    pub fn profile_and_stride(self) -> (CameraProfile, u32) {
        match self {
            Camera::XtionQvga => (walk::xtion_qvga(), 1),
            Camera::Xtion => (CameraProfile::xtion(), 2),
            Camera::D435 => (CameraProfile::d435(), 2),
        }
    }
}

/// Walk a simulated course with a virtual user following the rumble; print Taylor's
/// table (completion time, rumble signals, cane and body contacts, reorientations).
#[derive(Debug, Clone, clap::Args)]
pub struct CourseArgs {
    /// Built-in world (`taylor-course`, `open-course`, `corridor`, `step-down`,
    /// `sign-ahead`, `approach`, `corridor-narrow`, `lobby-bench`, `hanging-lamp`), a
    /// generated one (`gen:<kind>:<seed>`, kinds corridor, office, lobby, street) or a
    /// scene file with its start and goal on one floor (the virtual user takes no stairs
    /// or lifts: `building` is refused).
    #[arg(long, default_value = "taylor-course")]
    pub world: String,
    /// Walk groups of worlds instead of one, comma-separated: `gen:<kind>` (corridor,
    /// office, lobby, street) stands for `--count` generated worlds of that kind, seeds
    /// `--seed`, `--seed + 1`, ...; any other name (a built-in world, `gen:corridor:7`, a
    /// scene file) for itself. Each world is walked `--runs` times; a table per group
    /// and overall (`wearnav course --worlds gen:corridor,gen:lobby --count 10 --runs 2`).
    #[arg(long, value_delimiter = ',', value_name = "WORLDS", conflicts_with = "world")]
    pub worlds: Vec<String>,
    /// With `--worlds`: how many generated worlds each `gen:<kind>` stands for.
    #[arg(long, default_value_t = 5)]
    pub count: u32,
    /// Cost function driving the rumble.
    #[arg(long, value_enum, default_value_t = Cost::Ficf)]
    pub cost: Cost,
    /// Number of walks (seeds `seed`, `seed + 1`, ...).
    #[arg(long, default_value_t = 20)]
    pub runs: u32,
    /// Seed of the first walk.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Print JSON (every walk with its contacts, the rows and the averages).
    #[arg(long)]
    pub json: bool,
    /// Switch off the memory of obstacles beyond the field of view.
    #[arg(long)]
    pub no_memory: bool,
    /// Switch off the debounce of the rumble state (a stop released only after 133 ms
    /// of a calmer state).
    #[arg(long)]
    pub no_hysteresis: bool,
    /// Debounce side cues too (held 133 ms against clear and the other side).
    #[arg(long)]
    pub hold_sides: bool,
    /// Switch off drop-off detection.
    #[arg(long)]
    pub no_dropoff: bool,
    /// Keep drop-off detection on the path ahead only: the edges of lower ground
    /// elsewhere in view are neither steered round nor remembered.
    #[arg(long)]
    pub no_edges: bool,
    /// Switch off the time-to-collision warning.
    #[arg(long)]
    pub no_ttc: bool,
    /// Give perception the body's turn rate from a simulated body-worn gyro (the user's
    /// own turn, with the sway of each step, noise and bias): the costs are also taken
    /// along the heading the user is turning to, 0.3 s on (`turn_ahead`). Off by
    /// default: no body-worn gyro reaches the agents yet (the cane's own IMU carries the
    /// sweep).
    #[arg(long)]
    pub body_gyro: bool,
    /// The phone worn at the chest gives its compass to the particle filter
    /// (`sim::compass`: the body's heading, the phone up to 10° askew, the building's
    /// magnetic disturbance, 12° RMS with anomalies of up to 90° near steel). Read
    /// loosely (within 45° it says nothing): it tells a room from its turned copy.
    /// Used where the filter runs (--guide spoken, --predictive with --pose filter).
    #[arg(long)]
    pub compass: bool,
    /// Take the costs along the way the user walks, not along the swept camera: the
    /// camera's angle to the body from the camera's and the body-worn gyro's turns
    /// (`walking_frame`). Needs --body-gyro.
    #[arg(long, requires = "body_gyro")]
    pub walking_frame: bool,
    /// Switch the device off: the hands feel no rumble, and the user walks by the
    /// guide and the cane's touches alone (the baseline the device is measured against).
    #[arg(long)]
    pub no_rumble: bool,
    /// Cues from an oracle instead of perception: every camera frame it walks a copy
    /// of the user ahead (2.5 s, the true geometry, the user's reaction) under each
    /// rumble state and sends one under which nothing is touched, clear whenever clear
    /// is safe. `goal`: it knows what the user heads for, as no device does (what it
    /// cannot spare this user, no perception can); `ahead`: it takes the user to walk
    /// straight on while nothing rumbles (perfect sensing, no mind reading).
    #[arg(long, value_enum)]
    pub oracle: Option<oracle::Knows>,
    /// With `--oracle`: what its look-ahead is checked against: `world`, the true
    /// geometry; `perception`, the obstacle points the perception holds each frame (in
    /// view, remembered, edges of lower ground), so only the perception's sensing limits it.
    #[arg(long, value_enum, default_value_t = oracle::Sees::World)]
    pub oracle_sees: oracle::Sees,
    /// With `--oracle`: what it keeps from being touched: `all`, the cane and the body;
    /// `body`, the body alone (the cane may touch, and the user is taken to turn away
    /// from what it finds, as a cane user does).
    #[arg(long, value_enum, default_value_t = oracle::Guards::All)]
    pub oracle_guards: oracle::Guards,
    /// With `--oracle`: the turning rate it takes the user to have, degrees per second
    /// [default: the user's own, `--turn-rate-deg-s`] (a device knows only the typical user).
    #[arg(long)]
    pub oracle_turn_rate_deg_s: Option<f64>,
    /// The cue from where the user heads (issue 32's predictive cue): each frame the
    /// device walks a model of the user (--cue-model) ahead along the route it knows (the goal
    /// for a user heading for its sound), under each rumble state, against what the
    /// perception holds, and sends one under which nothing is touched; clear whenever
    /// clear is safe. The user's place on the route: --pose. Needs --body-gyro (the body's heading under the cane's sweep).
    #[arg(long, requires = "body_gyro", conflicts_with = "oracle")]
    pub predictive: bool,
    /// The predictive cue guarding the body alone, with no map and no route: each frame
    /// it walks a model of the user (--cue-model) ahead the way they last walked free (from the body
    /// gyro), lets the cane touch what stands in the way (the user turns away from it,
    /// as a cane user does) and warns only when the body would touch something all the
    /// same. Needs --body-gyro.
    #[arg(long, requires = "body_gyro", conflicts_with_all = ["oracle", "predictive"])]
    pub body_guard: bool,
    /// With --predictive or --body-guard: whose walking the cue's model of the user
    /// is. `typical`: the typical user's (1 m/s, 60°/s, 0.5 s), whoever walks, as in
    /// the compute agent, which learns nothing of its user. `user`: this user's mean
    /// (--walk-speed-m-s, --turn-rate-deg-s, --reaction-s), as a device that had learnt
    /// them would know it (each walk still draws its reaction 25 % either side).
    /// `learnt`: the typical user's to begin with, the turning rate then learnt from
    /// the body gyro while the user turns on a rumble (never above 60°/s).
    #[arg(long, value_enum, default_value_t = walk::CueModel::Typical)]
    pub cue_model: walk::CueModel,
    /// With --predictive or --guide spoken: where the device takes the user to be: `filter`, the compute
    /// agent's particle filter on the world's floor plan (the cost functions decide
    /// while it does not track); `truth`, the simulator's, only to tell the filter's
    /// error from the cue's.
    #[arg(long, value_enum, default_value_t = walk::PoseSource::Filter)]
    pub pose: walk::PoseSource,
    /// With --guide spoken: what the perception holds goes onto the navigator's planner
    /// (what the floor plan does not have: furniture, bins, people), and a route with
    /// something standing on it ahead is laid round it ("Something stands in the way. A
    /// way round: ..."), at most once in 4 s: the compute agent's --ways-round (off
    /// there too; docs/guidance.md, "Ways round what the camera finds").
    #[arg(long)]
    pub ways_round: bool,
    /// With --pose filter: the map the particle filter localizes on: `floor-plan` (the
    /// walls `wearnav map` exports) or `mapped` (also the furniture and hanging obstacles
    /// a mapping run would record; no people, no chairs). Routes are planned on the floor
    /// plan either way.
    #[arg(long, value_enum, default_value_t = floor_plan::LocalizationMap::FloorPlan)]
    pub localization_map: floor_plan::LocalizationMap,
    /// With --pose filter: the simulated visual odometry's errors (1 % scale, 2 % noise
    /// per metre, heading noise and drift) times K, so the filter's place is worse: how
    /// the cue degrades as the localization error grows (2: the "noise doubled").
    #[arg(long, value_name = "K", default_value_t = 1.0)]
    pub odometry_noise: f64,
    /// What the user heads for. `assisted` (the default) is Taylor's protocol: the
    /// goal's sound, with an experimenter who leads a user lost for 20 s until the goal
    /// is in sight. `sound`: the goal's sound alone, nobody to help. `route`: kept on
    /// the world's route (stand-in for turn-by-turn guidance). `spoken`: the compute
    /// agent's turn-by-turn guidance, planned on the world's floor plan from the place
    /// --pose gives, said through the feedback agent's speech queue; the user turns and
    /// walks by the words heard (docs/study.md).
    #[arg(long, value_enum, default_value_t = GuideKind::Assisted)]
    pub guide: GuideKind,
    /// With `--guide route` (and the experimenter leading in `assisted`): how far along
    /// the route the user is pointed, metres; turns begin this far before a corner
    /// [default: 1.5 m, or 1.5 turning radii (walking speed / turning rate) for a user
    /// who turns wider: 2.9 m at 1 m/s and 30°/s]. 0: the farthest waypoint in sight,
    /// corner to corner (the user reaches each corner facing what lies past it).
    #[arg(long)]
    pub route_lookahead_m: Option<f64>,
    /// What the map behind `--guide route` (and the experimenter of `assisted`) holds:
    /// `full`, every obstacle (the world's route, laid round them all); `floor-plan`,
    /// the walls alone (the world's floor-plan route down the middle of each lane,
    /// past furniture and under hanging obstacles the rumble must find).
    #[arg(long, value_enum, default_value_t = RouteMap::Full)]
    pub route_map: RouteMap,
    /// Give up a walk after this many seconds of simulated time.
    #[arg(long, default_value_t = 300.0)]
    pub timeout_s: f64,
    /// User's mean reaction time, seconds (each walk draws +-25 % around it).
    #[arg(long, default_value_t = 0.5)]
    pub reaction_s: f64,
    /// User's largest turning rate, degrees per second.
    #[arg(long, default_value_t = 60.0)]
    pub turn_rate_deg_s: f64,
    /// User's walking speed, m/s.
    #[arg(long, default_value_t = 1.0)]
    pub walk_speed_m_s: f64,
    /// Tell the user that the pulses quicken as the obstacle nears: a side rumble
    /// pulsing at this period or faster (ms) makes them stop and turn in place instead of
    /// turning while walking slowly. 0: the thesis's instruction, the rate ignored. The
    /// cue pulses every 150 ms at 0.5 m and every 700 ms at 3.5 m (350 ms: about 1.6 m)
    #[arg(long, default_value_t = 0.0)]
    pub fast_pulse_ms: f64,
    /// Camera pitch below the horizontal, degrees.
    #[arg(long, default_value_t = 30.0)]
    pub pitch_deg: f64,
    /// A second depth camera (the same model) worn at the chest, 1.3 m up, 12 cm ahead
    /// of the body, looking ahead --chest-pitch-deg down: the compute agent perceives
    /// its frames with a step of their own that warns only of what overhangs from 1 m
    /// up (a lamp, a sign, a cabinet standing out from a wall; never in the cane
    /// camera's view) and joins that cue to the cane camera's: a side either warns of
    /// is warned. With --predictive or --body-guard its obstacles join the cue's
    /// look-ahead too, as what only the body can touch.
    #[arg(long)]
    pub chest: bool,
    /// With --chest: the chest camera's pitch below the horizontal, degrees.
    #[arg(long, requires = "chest", default_value_t = 10.0)]
    pub chest_pitch_deg: f64,
    /// Cane sweep amplitude each side of the walking direction, degrees (0: the cane
    /// held still, pointing ahead).
    #[arg(long, default_value_t = 17.0)]
    pub sweep_deg: f64,
    /// Cane length from the handle (held 1 m above the floor, 25 cm ahead of the body)
    /// to the tip, metres: 1.3 reaches the sternum, as long-cane practice teaches (the
    /// tip 1.08 m ahead of the body); Taylor's prototype was 1.1 (0.71 m ahead).
    #[arg(long, default_value_t = 1.3)]
    pub cane_length_m: f64,
    /// Depth camera: `xtion-qvga` renders 320x240 and perceives every pixel, the same
    /// rays the agent samples from the Xtion's 640x480 at its stride of 2, at a quarter of
    /// the rendering cost; `xtion` renders 640x480 exactly as deployed; `d435`.
    #[arg(long, value_enum, default_value_t = Camera::XtionQvga)]
    pub camera: Camera,
    /// Send frames through the wire codec's bounded-error mode with this step, mm (0:
    /// lossless, as without the flag).
    #[arg(long)]
    pub bounded_mm: Option<u16>,
    /// List every contact after the table.
    #[arg(long)]
    pub contacts: bool,
    /// Write one CSV row per camera frame of every walk to this file (pose, sweep,
    /// rumble decided, rumble felt, nearest obstacle, time to collision, clearance, and
    /// the particle filter's estimate, status and whether route guidance takes it when
    /// the walk runs one); with `--versus`, of the walks without its flags.
    #[arg(long, value_name = "FILE")]
    pub trace: Option<std::path::PathBuf>,
    /// Walk the same seeds again with these flags added (for example
    /// `--versus=--no-memory`, or `--versus "--cost cacf --no-ttc"`) and print, per
    /// column, both means and the difference walk by walk (versus minus this) with its
    /// 95 % confidence interval: whether the change moves the walks beyond the spread of
    /// the seeds. The world, seeds and number of walks stay the same.
    #[arg(long, value_name = "FLAGS", allow_hyphen_values = true)]
    pub versus: Option<String>,
}

/// The flags of `wearnav course`, for applying `--versus` on top of parsed arguments.
#[derive(clap::Parser)]
#[command(name = "course")]
struct Flags {
    #[command(flatten)]
    args: CourseArgs,
}

impl CourseArgs {
    /// These arguments with `flags` (as typed after `--versus`) applied on top: only
    /// the flags typed there change, every other argument stays as it is here. What
    /// the flags need or exclude is checked against the arguments as they end up
    /// (`--versus=--predictive` on top of `--body-gyro` is taken; on top of `--oracle`
    /// it is refused).
    pub fn with_flags(&self, flags: &str) -> anyhow::Result<CourseArgs> {
        use clap::{CommandFactory, FromArgMatches};
        let err = |e: clap::Error| {
            let text = e.render().to_string();
            let what = text.split("\n\nUsage:").next().unwrap_or_default();
            let first = what.split_whitespace().collect::<Vec<_>>().join(" ");
            anyhow::anyhow!("--versus \"{flags}\": {first}")
        };
        // clap checks what a flag needs among the flags it parses: the switches given
        // here that others need go in first (switches cannot be switched off there)
        let words: Vec<&str> = flags.split_whitespace().collect();
        let needed = [(self.body_gyro, "--body-gyro"), (self.chest, "--chest")];
        let given_here = needed.into_iter().filter(|(on, flag)| *on && !words.contains(flag)).map(|(_, flag)| flag);
        let argv = std::iter::once("course").chain(given_here).chain(words.iter().copied());
        let matches = Flags::command().try_get_matches_from(argv).map_err(err)?;
        let given = CourseArgs::from_arg_matches(&matches).map_err(err)?;
        let typed = |id: &str| matches.value_source(id) == Some(clap::parser::ValueSource::CommandLine);
        let mut v = self.clone();
        // clap's own update would also reset every argument not typed to its default
        macro_rules! take {
            ($($field:ident),* $(,)?) => {{
                $(if typed(stringify!($field)) {
                    v.$field = given.$field.clone();
                })*
                [$(stringify!($field)),*]
            }};
        }
        let taken = take!(
            world,
            worlds,
            count,
            cost,
            runs,
            seed,
            json,
            no_memory,
            no_hysteresis,
            hold_sides,
            no_dropoff,
            no_edges,
            no_ttc,
            body_gyro,
            compass,
            walking_frame,
            no_rumble,
            oracle,
            oracle_sees,
            oracle_guards,
            oracle_turn_rate_deg_s,
            predictive,
            body_guard,
            cue_model,
            pose,
            ways_round,
            localization_map,
            odometry_noise,
            guide,
            route_lookahead_m,
            route_map,
            timeout_s,
            reaction_s,
            turn_rate_deg_s,
            walk_speed_m_s,
            fast_pulse_ms,
            pitch_deg,
            chest,
            chest_pitch_deg,
            sweep_deg,
            cane_length_m,
            camera,
            bounded_mm,
            contacts,
            trace,
            versus,
        );
        let command = Flags::command();
        let mut ids = command.get_arguments().map(|a| a.get_id().as_str());
        if let Some(id) = ids.find(|id| typed(id) && !taken.contains(id)) {
            anyhow::bail!("--versus \"{flags}\": `{id}` cannot be changed there");
        }
        anyhow::ensure!(
            (v.world.as_str(), &v.worlds, v.count, v.seed, v.runs)
                == (self.world.as_str(), &self.worlds, self.count, self.seed, self.runs),
            "--versus \"{flags}\": the world, --worlds, --count, --seed and --runs must stay the same (walks are compared seed by seed)"
        );
        anyhow::ensure!(
            !typed("versus") && !typed("trace") && !typed("json"),
            "--versus \"{flags}\": --versus, --trace and --json cannot be given inside --versus"
        );
        let cues = [(v.oracle.is_some(), "--oracle"), (v.predictive, "--predictive"), (v.body_guard, "--body-guard")];
        let on: Vec<&str> = cues.iter().filter(|(on, _)| *on).map(|(_, name)| *name).collect();
        anyhow::ensure!(
            on.len() <= 1,
            "--versus \"{flags}\": with the arguments already given it would walk {}, which exclude each other",
            on.join(" and ")
        );
        Ok(v)
    }

    /// The walk configuration these arguments describe.
    pub fn walk_config(&self) -> anyhow::Result<WalkConfig> {
        let mut c = WalkConfig::default();
        c.perception.cost_function = match self.cost {
            Cost::Ficf => CostFunction::Ficf,
            Cost::Cacf => CostFunction::Cacf,
        };
        c.perception.memory.enabled = !self.no_memory;
        c.perception.hysteresis.enabled = !self.no_hysteresis;
        c.perception.hysteresis.hold_sides = self.hold_sides;
        c.perception.dropoff.enabled = !self.no_dropoff;
        c.perception.dropoff.edges = !self.no_edges;
        c.perception.ttc.enabled = !self.no_ttc;
        c.body_gyro = self.body_gyro;
        c.compass = self.compass;
        c.perception.walking_frame.enabled = self.walking_frame;
        c.rumble = !self.no_rumble;
        anyhow::ensure!(
            self.oracle_turn_rate_deg_s.is_none_or(|r| r > 0.0 && r <= 720.0),
            "--oracle-turn-rate-deg-s must be in (0, 720]"
        );
        anyhow::ensure!(
            self.oracle.is_some()
                || (self.oracle_sees == oracle::Sees::World
                    && self.oracle_guards == oracle::Guards::All
                    && self.oracle_turn_rate_deg_s.is_none()),
            "--oracle-sees, --oracle-guards and --oracle-turn-rate-deg-s go with --oracle"
        );
        c.oracle = self.oracle.map(|k| oracle::OracleConfig {
            turn_rate_deg_s: self.oracle_turn_rate_deg_s,
            guards: self.oracle_guards,
            ..oracle::OracleConfig::new(k, self.oracle_sees)
        });
        c.guide = self.guide;
        anyhow::ensure!(
            self.route_lookahead_m.is_none_or(|m| (0.0..=20.0).contains(&m)),
            "--route-lookahead-m must be between 0 (corner to corner) and 20 m"
        );
        c.route_lookahead_m = self.route_lookahead_m;
        c.route_map = self.route_map;
        anyhow::ensure!(
            self.timeout_s.is_finite() && self.timeout_s > 0.0,
            "--timeout-s must be a positive number of seconds"
        );
        anyhow::ensure!((0.0..=10.0).contains(&self.reaction_s), "--reaction-s must be between 0 and 10 s");
        anyhow::ensure!(
            self.turn_rate_deg_s > 0.0 && self.turn_rate_deg_s <= 720.0,
            "--turn-rate-deg-s must be in (0, 720]"
        );
        anyhow::ensure!(self.walk_speed_m_s > 0.0 && self.walk_speed_m_s <= 3.0, "--walk-speed-m-s must be in (0, 3]");
        anyhow::ensure!((0.0..=80.0).contains(&self.pitch_deg), "--pitch-deg must be between 0 and 80");
        c.timeout_s = self.timeout_s;
        c.user.reaction_s = self.reaction_s;
        c.user.turn_rate_deg_s = self.turn_rate_deg_s;
        c.user.walk_speed_m_s = self.walk_speed_m_s;
        anyhow::ensure!(
            (0.0..=10_000.0).contains(&self.fast_pulse_ms),
            "--fast-pulse-ms must be between 0 (ignore the rate) and 10000 ms"
        );
        c.user.fast_pulse_ms = self.fast_pulse_ms;
        c.user.turn_walk_speed_m_s = c.user.turn_walk_speed_m_s.min(self.walk_speed_m_s);
        c.mount.pitch_deg = self.pitch_deg;
        anyhow::ensure!((0.0..=60.0).contains(&self.chest_pitch_deg), "--chest-pitch-deg must be between 0 and 60");
        c.chest = self.chest.then(|| sim::ChestMount { pitch_deg: self.chest_pitch_deg, ..sim::ChestMount::default() });
        anyhow::ensure!((0.0..=60.0).contains(&self.sweep_deg), "--sweep-deg must be between 0 and 60");
        c.mount.sweep_amplitude_deg = self.sweep_deg;
        anyhow::ensure!(
            (1.05..=1.6).contains(&self.cane_length_m),
            "--cane-length-m must be between 1.05 and 1.6 m (the handle is held 1 m above the floor)"
        );
        c.mount.cane_length_m = self.cane_length_m;
        (c.camera, c.perception.stride_px) = self.camera.profile_and_stride();
        c.bounded_mm = self.bounded_mm.filter(|&s| s > 0);
        c.trace = self.trace.is_some();
        // the device's model of the user and cane, once both are set
        anyhow::ensure!(
            self.predictive || self.guide == GuideKind::Spoken || self.pose == walk::PoseSource::Filter,
            "--pose goes with --predictive or --guide spoken"
        );
        anyhow::ensure!(
            self.cue_model == walk::CueModel::Typical || self.predictive || self.body_guard,
            "--cue-model goes with --predictive or --body-guard"
        );
        let modelled = match self.cue_model {
            walk::CueModel::User => c.clone(),
            walk::CueModel::Typical | walk::CueModel::Learnt => {
                WalkConfig { user: virtual_user::UserParams::default(), ..c.clone() }
            }
        };
        let learn_turn_rate = self.cue_model == walk::CueModel::Learnt;
        let cue = PredictiveConfig { learn_turn_rate, ..walk::predictive_for(&modelled) };
        c.predictive = if self.body_guard {
            Some(PredictiveConfig { guards: Guards::Body, own_way: true, ..cue })
        } else {
            self.predictive.then_some(cue)
        };
        c.pose = self.pose;
        // the particle filter runs for the predictive cue or the spoken guide, on --pose filter
        let filter = self.pose == walk::PoseSource::Filter && (self.predictive || self.guide == GuideKind::Spoken);
        anyhow::ensure!(
            self.localization_map == floor_plan::LocalizationMap::FloorPlan || filter,
            "--localization-map goes with --pose filter (and --predictive or --guide spoken)"
        );
        c.localization_map = self.localization_map;
        anyhow::ensure!(
            self.odometry_noise.is_finite() && (0.0..=10.0).contains(&self.odometry_noise),
            "--odometry-noise must be between 0 (perfect odometry) and 10"
        );
        anyhow::ensure!(
            self.odometry_noise == 1.0 || filter,
            "--odometry-noise goes with --pose filter (and --predictive or --guide spoken)"
        );
        c.odometry_noise = self.odometry_noise;
        anyhow::ensure!(!self.ways_round || self.guide == GuideKind::Spoken, "--ways-round goes with --guide spoken");
        c.ways_round = self.ways_round;
        Ok(c)
    }
}

/// The `--versus` flags, the arguments with them applied, and their walk configuration.
type Versus<'a> = (&'a str, CourseArgs, WalkConfig);

/// The arguments and configuration `--versus` describes, when given.
fn versus_of(args: &CourseArgs) -> anyhow::Result<Option<Versus<'_>>> {
    let Some(flags) = &args.versus else { return Ok(None) };
    let v = args.with_flags(flags)?;
    let mut c = v.walk_config().with_context(|| format!("--versus \"{flags}\""))?;
    // only the walks without the --versus flags are traced
    c.trace = false;
    Ok(Some((flags.as_str(), v, c)))
}

/// Refuses a world no walk of these configurations could serve: its goal on another
/// floor, or no floor-plan route for `--route-map floor-plan`.
fn check_world(world: &World, configs: &[&WalkConfig]) -> anyhow::Result<()> {
    let (start, goal) = (world.start(), world.goal());
    anyhow::ensure!(
        start.floor == goal.floor,
        "world `{}` has its goal on floor {} and its start on floor {}: the virtual user walks one floor \
         (it takes no stairs or lifts), so no walk could reach the goal",
        world.name(),
        goal.floor,
        start.floor
    );
    if world.way_through() == Some(false) {
        tracing::warn!(
            "world `{}`: no way through from the start to the goal for a 0.5 m wide body; its walks cannot \
             reach the goal and will say so",
            world.name()
        );
    }
    for c in configs {
        if c.guide == GuideKind::Spoken {
            // the device plans on the floor plan `wearnav map` exports, to the goal's label
            let building = floor_plan::export(world, floor_plan::DEFAULT_RESOLUTION_M)
                .with_context(|| format!("--guide spoken: no floor plan of world `{}`", world.name()))?;
            spoken::SpokenDevice::new(&building, &floor_plan::goal_label(world))
                .with_context(|| format!("--guide spoken: no guidance to the goal of world `{}`", world.name()))?;
        }
        if c.route_map == RouteMap::FloorPlan && matches!(c.guide, GuideKind::Route | GuideKind::Assisted) {
            anyhow::ensure!(
                world.floor_plan_route().is_some(),
                "world `{}` has no floor-plan route (`[floor_plan_route]` in its scene); --route-map floor-plan needs one",
                world.name()
            );
        }
    }
    Ok(())
}

/// Runs the study the arguments describe and prints the table (or JSON).
pub fn run(args: &CourseArgs) -> anyhow::Result<()> {
    if !args.worlds.is_empty() {
        return world_groups::run(args);
    }
    let world = World::load(&args.world).with_context(|| format!("loading world `{}`", args.world))?;
    let config = args.walk_config()?;
    let versus = versus_of(args)?;
    check_world(&world, &std::iter::once(&config).chain(versus.as_ref().map(|v| &v.2)).collect::<Vec<_>>())?;
    let started = std::time::Instant::now();
    let ended = std::sync::atomic::AtomicU32::new(0);
    let total = args.runs.saturating_mul(if versus.is_some() { 2 } else { 1 });
    let progress = |w: &walk::WalkOutcome| {
        let n = ended.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        tracing::info!(
            "{n} of {total} walks done; {} ({:.0} s elapsed)",
            walk_done(w),
            started.elapsed().as_secs_f64()
        );
    };
    let result = study_with_progress(&world, &config, args.runs, args.seed, progress);
    let other = versus.as_ref().map(|(_, _, c)| study_with_progress(&world, c, args.runs, args.seed, progress));
    let elapsed_s = started.elapsed().as_secs_f64();
    let diffs = other.as_ref().and_then(|o| compare::compare(&result.rows, &o.rows));
    if let Some(path) = &args.trace {
        write_trace(path, &result.walks).with_context(|| format!("writing the trace {}", path.display()))?;
    }
    if args.json {
        let mut doc = summary_json(args, &config, &world, &result);
        if let (Some((flags, v, c)), Some(o)) = (&versus, &other) {
            let mut vs = summary_json(v, c, &world, o);
            vs["flags"] = serde_json::json!(flags);
            vs["difference"] = serde_json::json!(diffs
                .iter()
                .flatten()
                .map(|(name, d)| (name.to_string(), serde_json::json!(d)))
                .collect::<serde_json::Map<_, _>>());
            doc["versus"] = vs;
        }
        doc["wall_time_s"] = serde_json::json!(elapsed_s);
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    print!("{}", summary_text(args, &config, &world, &result));
    if let (Some((flags, v, c)), Some(o)) = (&versus, &other) {
        println!();
        println!("versus `{flags}`, the same seeds:");
        print!("{}", summary_text(v, c, &world, o));
        println!();
        println!("difference walk by walk (versus minus this), {} walks:", args.runs);
        match &diffs {
            Some(d) => print!("{}", compare::lines(d)),
            None => println!("too few walks to compare (at least 2)"),
        }
    }
    println!("{} walks in {:.1} s wall time", total, elapsed_s);
    Ok(())
}

/// A study as JSON: the configuration, every walk, the rows and the averages.
fn summary_json(args: &CourseArgs, config: &WalkConfig, world: &World, result: &study::Study) -> serde_json::Value {
    let mut doc = config_json(args, config);
    doc["world"] = serde_json::json!(world.name());
    doc["walks"] = serde_json::json!(result.walks);
    doc["rows"] = serde_json::json!(result.rows);
    doc["average"] = serde_json::json!(result.average);
    doc["lead_times"] = serde_json::json!({
        "cane": LeadTimes::of(&result.walks, Part::Cane),
        "body": LeadTimes::of(&result.walks, Part::Body),
    });
    doc
}

/// The configuration of a study as JSON.
fn config_json(args: &CourseArgs, config: &WalkConfig) -> serde_json::Value {
    serde_json::json!({
        "cost": format!("{:?}", args.cost).to_lowercase(),
        "memory": !args.no_memory,
        "hysteresis": !args.no_hysteresis,
        "hold_sides": !args.no_hysteresis && args.hold_sides,
        "dropoff": !args.no_dropoff,
        "edges": !args.no_dropoff && !args.no_edges,
        "ttc": !args.no_ttc,
        "body_gyro": args.body_gyro,
        "compass": args.compass,
        "walking_frame": args.walking_frame,
        "rumble": !args.no_rumble,
        "oracle": config.oracle,
        "predictive": config.predictive,
        "pose": config.predictive.map(|_| config.pose),
        "localization_map": config.localization_map,
        "odometry_noise": config.odometry_noise,
        "guide": args.guide,
        "route_lookahead_m": config.lookahead_m(),
        "route_map": args.route_map,
        "camera": config.camera.name,
        "bounded_mm": config.bounded_mm,
        "cane": {
            "length_m": config.mount.cane_length_m,
            "pitch_deg": config.mount.pitch_deg,
            "sweep_deg": config.mount.sweep_amplitude_deg,
        },
        "chest": config.chest.map(|c| serde_json::json!({
            "height_m": c.height_m,
            "forward_m": c.forward_m,
            "pitch_deg": c.pitch_deg,
        })),
        "user": config.user,
        "timeout_s": config.timeout_s,
        "first_seed": args.seed,
    })
}

/// A study as text: the configuration line, the table, the contacts by warning, the
/// walks that did not reach the goal, and every contact with `--contacts`.
fn summary_text(args: &CourseArgs, config: &WalkConfig, world: &World, result: &study::Study) -> String {
    use std::fmt::Write;
    let mut s = config_lines(args, config, world.name());
    s.push_str(&table(result));
    s.push_str(&LeadTimes::of(&result.walks, Part::Cane).line("cane"));
    s.push('\n');
    s.push_str(&LeadTimes::of(&result.walks, Part::Body).line("body"));
    s.push('\n');
    if let Some(l) = study::localization_line(result.walks.iter()) {
        s.push_str(&l);
    }
    let learning = config.predictive.is_some_and(|p| p.learn_turn_rate);
    if let Some(l) = study::learnt_turn_line(result.walks.iter(), learning) {
        s.push_str(&l);
    }
    for w in result.walks.iter().filter(|w| !w.completed) {
        let why =
            if w.way_through == Some(false) { ": there is no way through (0.5 m wide) from the start" } else { "" };
        let _ = writeln!(
            s,
            "seed {}: goal not reached within {:.0} s (ended at {:.2}, {:.2}, {:.1} m from the goal){why}",
            w.seed,
            w.time_s,
            w.end_xy_m[0],
            w.end_xy_m[1],
            (w.end_xy_m[0] - world.goal().x_m).hypot(w.end_xy_m[1] - world.goal().y_m)
        );
    }
    if args.contacts {
        for w in &result.walks {
            for c in &w.contacts {
                let _ = writeln!(
                    s,
                    "seed {} t {:6.1} s {:?} {:<18} {:<8} in_fov {:<5} head_high {:<5} seen {:<11} felt {}",
                    w.seed,
                    c.t_s,
                    c.part,
                    c.label,
                    c.kind,
                    c.in_fov,
                    c.head_high,
                    c.seen_ago_s.map_or("never".to_string(), |s| format!("{s:.1} s ago")),
                    c.warned_ago_s.map_or("nothing".to_string(), |s| format!("{s:.1} s before"))
                );
            }
        }
    }
    s
}

/// The configuration of a study as text, two lines; `worlds` names what is walked.
fn config_lines(args: &CourseArgs, config: &WalkConfig, worlds: &str) -> String {
    let lookahead_m = config.lookahead_m();
    let guide = match args.guide {
        GuideKind::Route if lookahead_m > 0.0 => format!("Route ({:?} map), {lookahead_m:.1} m ahead", args.route_map),
        GuideKind::Route => format!("Route ({:?} map), corner to corner", args.route_map),
        GuideKind::Assisted => format!("Assisted (led on the {:?} map)", args.route_map),
        g => format!("{g:?}"),
    };
    format!(
        "world {} | camera {} | rumble {}{} | cost {:?} | memory {} | hysteresis {}{} | dropoff {} | edges {} | ttc {} | body gyro {}{}{} | guide {} | {} runs from seed {}\n\
         user {:.2} m/s, turning {:.0}°/s, reacting in {:.2} s{} | cane {:.2} m, camera {:.0}° down, sweep ±{:.0}°{} | codec {} | limit {:.0} s\n",
        worlds,
        config.camera.name,
        on_off(!args.no_rumble),
        config.oracle.map_or_else(String::new, |o| {
            let turn = o.turn_rate_deg_s.map_or_else(String::new, |r| format!(", taking the user to turn at {r:.0}°/s"));
            format!(" (from the oracle: knows {:?}, sees {:?}, guards {:?}{turn})", o.knows, o.sees, o.guards)
                .to_lowercase()
        }) + &match (config.predictive, config.pose) {
            (None, _) => String::new(),
            (Some(p), _) if p.own_way => " (body guard: the predictive cue on the body alone, the user's own way)".into(),
            (Some(_), walk::PoseSource::Filter) if config.odometry_noise != 1.0 => format!(
                " (predictive: from the route and the particle filter's place, odometry errors x{})",
                config.odometry_noise
            ),
            (Some(_), walk::PoseSource::Filter) => " (predictive: from the route and the particle filter's place)".into(),
            (Some(_), walk::PoseSource::Truth) => " (predictive: from the route and the true place)".into(),
        } + &config.predictive.map_or_else(String::new, |p| {
            format!(
                " (its model: {:.2} m/s, turning {:.0}°/s, reacting in {:.2} s)",
                p.user.walk_speed_m_s, p.user.turn_rate_deg_s, p.user.reaction_s
            )
        }),
        args.cost,
        on_off(!args.no_memory),
        on_off(!args.no_hysteresis),
        if !args.no_hysteresis && args.hold_sides { " (holding sides)" } else { "" },
        on_off(!args.no_dropoff),
        on_off(!args.no_dropoff && !args.no_edges),
        on_off(!args.no_ttc),
        on_off(args.body_gyro),
        if args.walking_frame { " (costs along the way walked)" } else { "" },
        if args.compass { " | compass on" } else { "" },
        guide,
        args.runs,
        args.seed,
        config.user.walk_speed_m_s,
        config.user.turn_rate_deg_s,
        config.user.reaction_s,
        if config.user.fast_pulse_ms > 0.0 {
            format!(", stops on pulses every {:.0} ms or faster", config.user.fast_pulse_ms)
        } else {
            String::new()
        },
        config.mount.cane_length_m,
        config.mount.pitch_deg,
        config.mount.sweep_amplitude_deg,
        config.chest.map_or_else(String::new, |c| format!(" | chest camera {:.2} m up, {:.0}° down", c.height_m, c.pitch_deg)),
        config.bounded_mm.map_or_else(|| "lossless".to_string(), |mm| format!("bounded {mm} mm")),
        config.timeout_s,
    )
}

fn write_trace(path: &std::path::Path, walks: &[walk::WalkOutcome]) -> anyhow::Result<()> {
    use std::io::Write;
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "seed,t_s,x_m,y_m,yaw_deg,sweep_deg,speed_m_s,rumble,felt,nearest_m,bearing_deg,ttc_s,forward_cost,clearance_m,turn_ahead,\
         estimate_x_m,estimate_y_m,estimate_heading_deg,estimate_status,estimate_guides"
    )?;
    for w in walks {
        for r in &w.trace {
            writeln!(
                f,
                "{},{:.3},{:.3},{:.3},{:.1},{:.1},{:.2},{},{:?},{:.3},{:.1},{},{:.3},{:.3},{},{},{}",
                w.seed,
                r.t_s,
                r.x_m,
                r.y_m,
                r.yaw_deg,
                r.sweep_deg,
                r.speed_m_s,
                r.rumble.map_or("refused".to_string(), |x| format!("{x:?}")),
                r.felt,
                r.nearest_m,
                r.bearing_deg,
                r.ttc_s.map_or(String::new(), |t| format!("{t:.2}")),
                r.forward_cost,
                r.clearance_m,
                u8::from(r.turn_ahead),
                r.estimate.map_or(",,,".to_string(), |([x, y, h], s)| format!("{x:.3},{y:.3},{h:.1},{s:?}")),
                u8::from(r.estimate_guides)
            )?;
        }
    }
    f.flush()?;
    Ok(())
}

fn on_off(on: bool) -> &'static str {
    if on {
        "on"
    } else {
        "off"
    }
}

/// A finished walk in the progress log: seed, outcome, time and contacts.
pub(crate) fn walk_done(w: &walk::WalkOutcome) -> String {
    let localization = match w.localization {
        None => String::new(),
        Some(e) if e.frames == 0 => "; the filter never tracked".to_string(),
        Some(e) => format!(
            "; the filter tracked {} of {} frames, RMSE {:.2} m, heading {:.1}°{}",
            e.frames,
            w.frames,
            e.position_rmse_m,
            e.heading_rmse_deg,
            match (e.frames_over_1m, e.frames_turned) {
                (0, 0) => String::new(),
                (n, 0) => format!(", {n} of them more than 1 m off"),
                (n, t) => format!(", {n} of them more than 1 m off, {t} turned more than 45°"),
            }
        ),
    };
    let heard = match w.heard {
        None => String::new(),
        Some((heard, prompts)) => {
            format!("; heard {heard} utterances, {prompts} off-route prompts in {:.0} m", w.path_m)
        }
    };
    let heard = match w.unguided_m {
        Some((total, longest)) if total >= 0.5 => {
            format!("{heard}, {total:.0} m of them with no place for guidance (at most {longest:.0} m at a stretch)")
        }
        _ => heard,
    };
    let heard = match w.missed {
        Some((missed, turns_now)) if missed > 0 => {
            format!("{heard}; {missed} not heard to their end ({turns_now} turns \"now\")")
        }
        _ => heard,
    };
    let round = match w.ways_round {
        None => String::new(),
        Some((laid, none, sidesteps)) => {
            format!("; {laid} ways round said ({none} looked for and none found, {sidesteps} only a sidestep)")
        }
    };
    format!(
        "seed {}: {} in {:.1} s, {} cane and {} body contacts{localization}{heard}{round}",
        w.seed,
        w.verdict(),
        w.time_s,
        w.count(Part::Cane, None),
        w.count(Part::Body, None)
    )
}
