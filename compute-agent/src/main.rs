//! `compute-agent`: obstacle perception on the depth frames of the bus.

use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;
use perception::PerceptionConfig;
use schemas::CostFunction;

/// Find obstacles in the cane camera's depth frames and publish scan, hazard and
/// haptic intents (Taylor 2017 pipeline, with memory, drop-offs, time to collision);
/// with a floor map, also localize the user on it, plan routes and guide by speech.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(flatten)]
    bus: bus::BusOptions,
    /// Perception parameters as TOML (fields of `PerceptionConfig`; missing ones keep
    /// their documented defaults). A field the pipeline does not have, or a value out
    /// of its range, is refused with the field's name before the agent starts.
    #[arg(long, value_name = "FILE")]
    perception_config: Option<PathBuf>,
    /// Cost function driving the rumble: `ficf` (Fully-Integrated) or `cacf`
    /// (Cushioned Avoidance).
    #[arg(long, value_parser = parse_cost)]
    cost: Option<CostFunction>,
    /// Device of the IMU worn on the body (a phone on a lanyard, a belt clip), read on
    /// `sensor/<device>/imu`: its turn rate about gravity lets the costs look the way
    /// the user is turning, not only along the camera. The simulator publishes one as
    /// `body`. Never the cane's own device: its IMU carries the sweep (refused).
    #[arg(long, value_name = "DEVICE", default_value = compute_agent::run::DEFAULT_BODY_IMU_DEVICE)]
    body_imu_device: String,
    /// Do not read a body-worn IMU: the costs look along the camera's heading only, as
    /// in the thesis.
    #[arg(long)]
    no_body_imu: bool,
    /// Device of the phone whose compass the localization reads, on
    /// `sensor/<device>/motion` (with --map, when the map says where north is): the
    /// simulator's phone is `body`, the phone bridge's `phone` (a phone worn at the
    /// chest, not carried in a pocket: the compass gives its heading). Read loosely: it
    /// tells a room from its turned copy.
    #[arg(long, value_name = "DEVICE", default_value = compute_agent::run::DEFAULT_BODY_IMU_DEVICE)]
    compass_device: String,
    /// Do not read a compass.
    #[arg(long)]
    no_compass: bool,
    /// Device of a second depth camera worn at the chest (`sensor/<device>/depth` and
    /// `/odom`: `sensor-agent --chest-device` simulates one, a real one runs a sensor
    /// agent of its own): its frames are perceived on their own, warning only of what
    /// overhangs from 1 m up (a lamp, a sign, a cabinet standing out from a wall), and
    /// its cue is joined to every other camera's while it is fresh (300 ms; with
    /// --predictive, its obstacles join the cue's look-ahead too, as what only the body
    /// can touch); when it falls silent or cannot see, the log and the health status say
    /// so and the cane camera's cue goes on alone.
    #[arg(long, value_name = "DEVICE")]
    chest_device: Option<String>,
    /// Device of the cane camera (`sensor/<device>/depth` and `/odom`): only its frames
    /// and odometry are perceived as the cane's. Default: the first camera heard (the
    /// chest camera aside), named in the log. Another camera's frames and odometry are
    /// refused and counted as `other_camera` (one ground and one memory per camera).
    #[arg(long, value_name = "DEVICE")]
    cane_device: Option<String>,
    /// Oldest depth frame acted on, in milliseconds from its capture (the sender's
    /// clock offset, estimated from its health messages, taken out). An older one (a
    /// stalled link, a replay) is refused and counted as `stale`; when every frame is,
    /// the feedback agent warns that detection is offline.
    #[arg(long, value_name = "MS", default_value_t = compute_agent::run::DEFAULT_MAX_INPUT_AGE.as_millis() as u64,
          value_parser = clap::value_parser!(u64).range(1..=10_000))]
    max_input_age_ms: u64,
    /// Oldest odometry step taken, in milliseconds from its capture. A late step is
    /// still the user's motion and is applied in order (the obstacle memory and the
    /// localization would be left where the user was without it); an older one (a
    /// replay, a link down for longer) is refused and counted as `stale`.
    #[arg(long, value_name = "MS", default_value_t = compute_agent::run::DEFAULT_MAX_ODOMETRY_AGE.as_millis() as u64,
          value_parser = clap::value_parser!(u64).range(1..=10_000))]
    max_odometry_age_ms: u64,
    /// Floor map to localize on and plan routes with: a building manifest
    /// (`building.toml`, as `wearnav map` writes it) or its directory. With it the agent
    /// publishes `localization/pose` and `route/state`, answers `query/destinations` and
    /// `query/route?to=LABEL`, and guides on `cmd/destination`, `where-am-i`, `repeat`,
    /// `cancel` and `floor`. Without it: obstacle perception only.
    #[arg(long, value_name = "PATH")]
    map: Option<PathBuf>,
    /// Where the user stands at the start: `X,Y,HEADING_DEG[,FLOOR]` in the map's frame
    /// (heading counter-clockwise from +x). Without it the filter searches every floor,
    /// and guidance waits until the user confirms the place it finds with the number of
    /// a door they are at or the name of a place they are near (places look alike).
    #[arg(long, value_name = "X,Y,DEG[,FLOOR]", value_parser = parse_start, requires = "map")]
    start: Option<(i32, localization::Pose2)>,
    /// How guidance speaks, as TOML (fields of `guidance::GuidanceProfile`; missing ones
    /// keep their defaults): `directions = "clock"` for clock-face directions,
    /// `units = "steps"` with `stride_m` for steps, `passing_doors = false` to leave out
    /// "Passing door 214, on your left.", the spacing and distances (docs/guidance.md,
    /// "Thresholds"). A field guidance does not have, or a value out of its range, is
    /// refused with the field's name before the agent starts.
    #[arg(long, value_name = "FILE", requires = "map")]
    guidance_profile: Option<PathBuf>,
    /// Seed of the localization filter's random draws.
    #[arg(long, value_name = "N", default_value_t = 1, requires = "map")]
    localization_seed: u64,
    /// Rumble from where the user heads while a route is followed and the position is
    /// tracked: each frame a model of the typical user is walked ahead along the route
    /// under each state, against what the perception holds (docs/predictive-cue.md);
    /// the cost functions otherwise. Needs the body's gyro (--body-imu-device) for the
    /// body's heading under the cane's sweep. Off by default: on generated worlds it is
    /// not yet better than the cost functions.
    #[arg(long, requires = "map", conflicts_with = "no_body_imu")]
    predictive: bool,
    /// With --predictive: the model's turning rate is learnt from how fast the user
    /// turns (the body's gyro) while acting on a side or both rumble, never above the
    /// typical 60°/s; the log says what it learnt. Off by default: the figures in
    /// docs/predictive-cue.md were measured without it ("A user other than the typical
    /// one").
    #[arg(long, requires = "predictive")]
    learn_turn_rate: bool,
    /// What the camera finds that the floor map lacks (a desk, a bench, a person) goes
    /// onto the planner, and a route something stands on ahead is laid round it:
    /// "Something stands in the way. A way round: ..." (docs/guidance.md, "Ways round
    /// what the camera finds"). Off by default: on the generated worlds it was not tuned
    /// on, the spoken guide's users completed fewer walks with it.
    #[arg(long, requires = "map")]
    ways_round: bool,
}

/// `X,Y,HEADING_DEG[,FLOOR]`.
fn parse_start(s: &str) -> Result<(i32, localization::Pose2), String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if !(3..=4).contains(&parts.len()) {
        return Err(format!("{s:?}: give X,Y,HEADING_DEG or X,Y,HEADING_DEG,FLOOR"));
    }
    let num = |i: usize, what: &str| {
        parts[i]
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{s:?}: {what} {:?} is not a number", parts[i]))
    };
    let floor = match parts.get(3) {
        Some(f) => f.parse::<i32>().map_err(|_| format!("{s:?}: floor {f:?} is not a whole number"))?,
        None => 0,
    };
    Ok((floor, localization::Pose2::new(num(0, "x")?, num(1, "y")?, num(2, "heading")?.to_radians())))
}

fn parse_cost(s: &str) -> Result<CostFunction, String> {
    match s {
        "ficf" => Ok(CostFunction::Ficf),
        "cacf" => Ok(CostFunction::Cacf),
        other => Err(format!("unknown cost function {other:?}: use ficf or cacf")),
    }
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    bus::logging::init();
    let cli = Cli::parse();
    let mut config = compute_agent::run::ComputeConfig::new(cli.bus);
    if let Some(path) = &cli.perception_config {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
        config.perception =
            PerceptionConfig::from_toml(&text).with_context(|| format!("bad perception config {}", path.display()))?;
    }
    if let Some(cost) = cli.cost {
        config.perception.cost_function = cost;
    }
    config.body_imu_device = (!cli.no_body_imu).then_some(cli.body_imu_device);
    config.compass_device = (!cli.no_compass).then_some(cli.compass_device);
    config.max_input_age = std::time::Duration::from_millis(cli.max_input_age_ms);
    config.max_odometry_age = std::time::Duration::from_millis(cli.max_odometry_age_ms);
    config.chest_device = cli.chest_device;
    config.cane_device = cli.cane_device;
    if let Some(map) = cli.map {
        let mut nav = compute_agent::nav::NavConfig::new(compute_agent::nav::MapSource::File(map));
        nav.start = cli.start;
        nav.seed = cli.localization_seed;
        nav.ways_round = cli.ways_round;
        if let Some(path) = &cli.guidance_profile {
            nav.guidance = compute_agent::nav::load_guidance_profile(path)?;
        }
        config.nav = Some(nav);
    }
    config.predictive = cli.predictive.then(|| perception::predictive::PredictiveConfig {
        learn_turn_rate: cli.learn_turn_rate,
        ..Default::default()
    });
    let shutdown = bus::Shutdown::new();
    shutdown.trigger_on_signals();
    compute_agent::run::run(config, shutdown).await
}
