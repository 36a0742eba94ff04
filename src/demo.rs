//! `wearnav demo`: every agent in one process, each with its own Zenoh session, on the
//! simulated world, with a live status line measured from the message stamps.

use std::collections::BTreeMap;
use std::net::{Ipv4Addr, SocketAddr, TcpListener};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use bus::{BusOptions, Health, Shutdown, Subscriber};
use schemas::{Applied, AppliedAction, HapticIntent, Hazard, HealthStats};

/// Run the whole system on the simulated world in this one process.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// How long to run (`20s`, `2m`); without it, until Ctrl-C.
    #[arg(long, value_parser = humantime::parse_duration)]
    pub duration: Option<Duration>,
    /// User name: the key prefix `wearnav/<user>`.
    #[arg(long, default_value = "demo")]
    pub user: String,
    /// Frame source: `sim:<world>` (approach, taylor-course, open-course, corridor,
    /// building, step-down, sign-ahead, corridor-narrow, lobby-bench, hanging-lamp, or a
    /// generated world such as gen:corridor:7), `pcd:<file-or-dir>`, `tum:<dir>`, `png:<dir>`.
    #[arg(long, default_value = "sim:approach")]
    pub source: String,
    /// The simulated world to run on: the same as `--source sim:<WORLD>`.
    #[arg(long, value_name = "WORLD", conflicts_with = "source")]
    pub world: Option<String>,
    /// Extra endpoint the demo listens on, so a Python monitor or another machine can
    /// join (`tcp/0.0.0.0:7447`). The demo always listens on a free loopback port too
    /// and prints it.
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Also find and join peers by multicast scouting (off: the demo stays to itself).
    #[arg(long)]
    pub multicast: bool,
    /// Address of the phone page, plain HTTP on loopback (port 0 picks a free one).
    #[arg(long, default_value = "127.0.0.1:0")]
    pub http: SocketAddr,
    /// Serve the phone page over HTTPS here instead (`0.0.0.0:8443` to open it on a
    /// phone on the LAN; the pairing code is printed).
    #[arg(long, value_name = "ADDR")]
    pub https: Option<SocketAddr>,
    /// Speech backends of the feedback agent, comma-separated (`console`, `espeak`).
    #[arg(long, value_delimiter = ',', default_value = "console")]
    pub speech: Vec<feedback_agent::SpeechBackend>,
    /// Haptic backends of the feedback agent, comma-separated (`console`, `wiimote`).
    #[arg(long, value_delimiter = ',', default_value = "console")]
    pub haptic: Vec<feedback_agent::HapticBackend>,
    /// Walk the simulated world to this place by the device's guidance (a label of its
    /// floor plan, `wearnav map --world W` lists them; needs a simulated world, `--world`): the
    /// compute agent localizes on the floor plan and guides, the simulated user walks by
    /// the route as the device sees it and takes elevators when told (the device is told
    /// to prefer them: the simulated user does not climb stairs). Ends on arrival; fails
    /// when the user did not arrive within 1 m of the place.
    #[arg(long, value_name = "LABEL")]
    pub destination: Option<String>,
    /// On a simulated world: the rumble from where the user heads (the route followed
    /// and the position on the floor plan) instead of the cost functions, while the
    /// device guides and tracks the position (docs/predictive-cue.md).
    #[arg(long)]
    pub predictive: bool,
    /// On a simulated world: a second depth camera worn at the chest (1.3 m up, 10°
    /// down, published as device `chest`), whose cue the compute agent joins to the
    /// cane camera's (with --predictive, whose obstacles join the cue's look-ahead
    /// too), so what overhangs at head height is warned of.
    #[arg(long)]
    pub chest: bool,
    /// On a guided walk (`--destination`): the simulated user does not say which floor
    /// a lift took them to; the compute agent finds it with the cane board's barometer
    /// (the simulator's: the floor plan gives each floor's height).
    #[arg(long, requires = "destination")]
    pub floor_unsaid: bool,
    /// On a guided walk (`--destination`), a fault: the simulated cane board's
    /// barometer stops sending when the first elevator ride starts. The device, which
    /// had said it would notice the floor, asks the user to say it (with
    /// `--floor-unsaid` the user says it only then).
    #[arg(long, requires = "destination")]
    pub barometer_fails_in_lift: bool,
    /// On a simulated world: how guidance speaks, as TOML (fields of
    /// `guidance::GuidanceProfile`, the compute agent's `--guidance-profile`):
    /// `directions = "clock"`, `units = "steps"`, `passing_doors = false`, ...
    /// (docs/guidance.md, "Thresholds"). Refused with the field named before any agent
    /// starts.
    #[arg(long, value_name = "FILE")]
    pub guidance_profile: Option<std::path::PathBuf>,
}

/// Device name of the demo's simulated chest camera (`--chest`).
const CHEST_DEVICE: &str = "chest";

fn free_loopback_port() -> anyhow::Result<u16> {
    let probe = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).context("no free loopback port")?;
    Ok(probe.local_addr()?.port())
}

/// Latency and rate figures gathered from the bus.
#[derive(Debug, Default)]
struct Tally {
    hazards: u64,
    hazards_in_period: u64,
    last: Option<Hazard>,
    e2e_ms: Vec<f32>,
    e2e_period_ms: Vec<f32>,
    intent_ms: Vec<f32>,
    /// Per-hop durations reported in the hazards (`arrival`, `queue`, `decode`, ...).
    stages_ms: Vec<(String, Vec<f32>)>,
    sensor_fps: Option<f32>,
    applied: u64,
    offline_warnings: u64,
    /// Per agent, from its latest health: rejected inputs and messages lost on the way
    /// to it (gaps in their publishers' numbering).
    losses: BTreeMap<String, (u64, u64)>,
}

impl Tally {
    fn on_applied(&mut self, a: &Applied) {
        self.applied += 1;
        match &a.action {
            AppliedAction::Rumble { .. } if a.cause_capture_ns > 0 => {
                let ms = bus::clock::age_ms(a.cause_capture_ns, a.applied_ns) as f32;
                self.e2e_ms.push(ms);
                self.e2e_period_ms.push(ms);
            }
            AppliedAction::OfflineWarning { offline: true, .. } => self.offline_warnings += 1,
            _ => {}
        }
    }

    fn on_hazard(&mut self, h: Hazard) {
        self.hazards += 1;
        self.hazards_in_period += 1;
        for s in &h.latency {
            let ms = s.us as f32 / 1e3;
            match self.stages_ms.iter_mut().find(|(name, _)| *name == s.stage) {
                Some((_, v)) => v.push(ms),
                None => self.stages_ms.push((s.stage.clone(), vec![ms])),
            }
        }
        self.last = Some(h);
    }

    /// `stage p50/p99` for every hop the hazards reported, in pipeline order.
    fn stage_breakdown(&mut self) -> String {
        let parts: Vec<String> = self
            .stages_ms
            .iter_mut()
            .map(|(name, v)| {
                let (p50, p99) = bus::health::percentiles(v);
                format!("{name} {}/{}", fmt_ms(p50), fmt_ms(p99))
            })
            .collect();
        parts.join(", ")
    }

    fn on_health(&mut self, h: &HealthStats) {
        let rejects = h.rejects.iter().map(|r| r.count).sum();
        let missed = h.streams.iter().map(|s| s.missed).sum();
        self.losses.insert(h.agent.clone(), (rejects, missed));
        if h.agent == sensor_agent::run::AGENT {
            if let Some(depth) = h.streams.iter().find(|s| s.key.ends_with("/depth") && !s.inbound) {
                self.sensor_fps = Some(depth.rate_hz);
            }
        }
    }

    /// Rejected inputs and messages lost on the way, all agents.
    fn losses(&self) -> (u64, u64) {
        self.losses.values().fold((0, 0), |(r, m), (ar, am)| (r + ar, m + am))
    }

    fn status_line(&mut self, elapsed: Duration, period: Duration) -> String {
        let perceived = self.hazards_in_period as f32 / period.as_secs_f32();
        self.hazards_in_period = 0;
        let (p50, p99) = bus::health::percentiles(&mut self.e2e_period_ms);
        self.e2e_period_ms.clear();
        let state = match &self.last {
            Some(h) => format!(
                "rumble {:<5} nearest {} ground {:?}",
                format!("{:?}", h.rumble).to_lowercase(),
                if h.nearest_m.is_finite() { format!("{:.2} m", h.nearest_m) } else { "-".into() },
                h.ground
            ),
            None => "no hazard yet".into(),
        };
        let (rejects, lost) = self.losses();
        format!(
            "[{:6.1}s] sensor {} fps | perceived {:.1}/s | {} | capture->applied p50 {} p99 {} ms | rejects {} | lost {}",
            elapsed.as_secs_f32(),
            self.sensor_fps.map_or("-".into(), |f| format!("{f:.1}")),
            perceived,
            state,
            fmt_ms(p50),
            fmt_ms(p99),
            rejects,
            lost,
        )
    }
}

/// Waits up to 5 s for an agent's task to end; what went wrong goes to `failures`.
async fn stopped(name: &str, task: tokio::task::JoinHandle<anyhow::Result<()>>, failures: &mut Vec<String>) {
    match tokio::time::timeout(Duration::from_secs(5), task).await {
        Ok(Ok(Ok(()))) => {}
        Ok(Ok(Err(e))) => failures.push(format!("{name}: {e:#}")),
        Ok(Err(e)) => failures.push(format!("{name} panicked: {e}")),
        Err(_) => failures.push(format!("{name} did not stop within 5 s")),
    }
}

fn fmt_ms(v: f32) -> String {
    if v.is_nan() {
        "-".into()
    } else {
        format!("{v:.2}")
    }
}

/// Run the demo; `Ok` when it ran cleanly (frames perceived, every agent stopped well).
pub async fn run(mut args: DemoArgs) -> anyhow::Result<()> {
    if let Some(world) = args.world.take() {
        args.source = format!("sim:{world}");
    }
    schemas::Keys::new(&args.user).with_context(|| format!("bad --user {:?}", args.user))?;
    // A refused configuration (a backend named twice) stops the demo here, before any
    // agent starts.
    let feedback_config = feedback_agent::FeedbackConfig {
        speech: args.speech.clone(),
        haptic: args.haptic.clone(),
        ..feedback_agent::FeedbackConfig::default()
    };
    feedback_config.check()?;
    let hub = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
    let mut hub_bus = BusOptions::for_user(&args.user);
    hub_bus.listen = std::iter::once(hub.clone()).chain(args.listen.iter().cloned()).collect();
    hub_bus.no_multicast = !args.multicast;
    let mut peer_bus = BusOptions::for_user(&args.user);
    peer_bus.connect = vec![hub.clone()];
    peer_bus.no_multicast = !args.multicast;

    // on a simulated world the compute agent localizes and guides on its floor plan
    let mut navigation = crate::guided::sim_navigation(&args.source)?;
    if let Some(path) = &args.guidance_profile {
        let Some((_, nav)) = navigation.as_mut() else {
            bail!("--guidance-profile needs a simulated world (--world W or --source sim:W), not {:?}", args.source)
        };
        nav.guidance = compute_agent::nav::load_guidance_profile(path)?;
    }
    let (source, guided) = match (&args.destination, &navigation) {
        (Some(label), Some((world, nav))) => {
            let mut walk = crate::guided::GuidedWalk::prepare(
                world,
                nav,
                label,
                crate::guided::WalkOptions {
                    chest: args.chest,
                    says_floor: !args.floor_unsaid,
                    barometer_stops_in_ride: args.barometer_fails_in_lift,
                },
            )?;
            let source = walk.source.take().context("the guided walk's source was taken twice")?;
            (source, Some(walk))
        }
        (Some(_), None) => {
            bail!("--destination needs a simulated world (--world W or --source sim:W), not {:?}", args.source)
        }
        (None, _) => (
            sensor_agent::source::open(
                &args.source,
                &sensor_agent::source::SourceOptions { chest: args.chest, ..Default::default() },
            )
            .with_context(|| format!("cannot open frame source {:?}", args.source))?,
            None,
        ),
    };
    let shutdown = Shutdown::new();
    shutdown.trigger_on_signals();

    // The hub (compute) must be listening before the others connect.
    let mut compute_config = compute_agent::run::ComputeConfig::new(hub_bus);
    compute_config.nav = navigation.as_ref().map(|(_, nav)| nav.clone());
    compute_config.chest_device = args.chest.then(|| CHEST_DEVICE.to_string());
    if args.predictive {
        anyhow::ensure!(
            compute_config.nav.is_some(),
            "--predictive needs a simulated world (--world W or --source sim:W)"
        );
        compute_config.predictive = Some(perception::predictive::PredictiveConfig::default());
    }
    let compute = tokio::spawn(compute_agent::run::run(compute_config, shutdown.clone()));
    tokio::time::sleep(Duration::from_millis(300)).await;
    let feedback_config = feedback_agent::FeedbackConfig { bus: peer_bus.clone(), ..feedback_config };
    // At the demo's end the feedback agent stops first: stopping after the compute agent,
    // it would say that obstacle detection went offline (a signal stops all at once).
    let feedback_shutdown = Shutdown::new();
    tokio::spawn({
        let (all, feedback) = (shutdown.clone(), feedback_shutdown.clone());
        async move {
            all.triggered().await;
            feedback.trigger();
        }
    });
    let feedback = tokio::spawn(feedback_agent::run(feedback_config, feedback_shutdown.clone()));
    let (bound_tx, bound_rx) = tokio::sync::oneshot::channel();
    let mut phone_config = phone_bridge::PhoneConfig::new(peer_bus.clone());
    phone_config.serve = match args.https {
        Some(addr) => phone_bridge::Serve::Https(addr),
        None => phone_bridge::Serve::Http(args.http),
    };
    // the demo prints the page's address itself; the pairing code goes to its log
    phone_config.announce = false;
    // the monitor page draws the pose and route on the floor plan the compute agent uses
    phone_config.map = navigation.as_ref().and_then(|(_, nav)| match &nav.map {
        compute_agent::nav::MapSource::Loaded(_, building) => Some(std::sync::Arc::new((**building).clone())),
        compute_agent::nav::MapSource::File(path) => {
            compute_agent::nav::load_building(path).ok().map(std::sync::Arc::new)
        }
    });
    let phone = tokio::spawn(phone_bridge::run(phone_config, shutdown.clone(), Some(bound_tx)));
    let sensor_config = sensor_agent::run::SensorConfig {
        chest_device: args.chest.then(|| CHEST_DEVICE.to_string()),
        ..sensor_agent::run::SensorConfig::new(peer_bus.clone())
    };
    let sensor = tokio::spawn(sensor_agent::run::run(sensor_config, source, shutdown.clone()));

    // The demo's own eyes: a fifth session that watches what the user would feel.
    let session = bus::open_session(&peer_bus).await?;
    let keys = peer_bus.keys()?;
    let watch = Health::new("demo-monitor");
    let hazards = Subscriber::<Hazard>::declare(&session, keys.hazard(), false, &watch).await?;
    let applied = Subscriber::<Applied>::declare(&session, keys.applied(), false, &watch).await?;
    let health = Subscriber::<HealthStats>::declare(&session, keys.health_any(), false, &watch).await?;
    // Intents arrive here exactly as at the feedback agent (one hop from compute), so
    // their age is capture -> intent at the device's agent for every frame, free of
    // the pulse timing that shifts when a pulsed rumble's edges are applied.
    let intents = Subscriber::<HapticIntent>::declare(&session, keys.haptic(), false, &watch).await?;
    let mut guide = match &guided {
        Some(walk) => Some(crate::guided::GuidedWatch::declare(walk, &session, &keys, &watch).await?),
        None => None,
    };
    let mut guide_tick = tokio::time::interval(Duration::from_millis(250));
    if let Ok(addr) = bound_rx.await {
        let scheme = if args.https.is_some() { "https" } else { "http" };
        eprintln!("phone page: {scheme}://{addr}/");
    }
    eprintln!(
        "wearnav demo for user {:?} on {}; watch it with:\n  python3 schemas/python/monitor.py --user {} --connect {hub}",
        args.user, args.source, args.user
    );
    if navigation.is_some() && guided.is_none() {
        eprintln!(
            "guidance on the world's floor plan; ask for a place with:\n  python3 schemas/python/send.py --user {} --connect {hub} cmd destination <place>",
            args.user
        );
    }

    let started = Instant::now();
    let period = Duration::from_secs(1);
    let mut tick = tokio::time::interval_at(tokio::time::Instant::now() + period, period);
    let mut tally = Tally::default();
    let deadline = async {
        match args.duration {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending().await,
        }
    };
    tokio::pin!(deadline);
    loop {
        tokio::select! {
            _ = shutdown.triggered() => break,
            _ = &mut deadline => break,
            Some(h) = hazards.recv() => tally.on_hazard(h.body),
            Some(a) = applied.recv() => {
                tally.on_applied(&a.body);
                if let Some(g) = guide.as_mut() { g.on_applied(&a.body) }
            }
            Some(i) = intents.recv() => tally.intent_ms.push(i.age_ms() as f32),
            Some(h) = health.recv() => tally.on_health(&h.body),
            _ = tick.tick() => eprintln!("{}", tally.status_line(started.elapsed(), period)),
            Some(r) = bus::maybe(guide.as_ref().map(|g| g.route.recv())) => {
                if let Some(g) = guide.as_mut() { g.on_route(r.body) }
            }
            Some(p) = bus::maybe(guide.as_ref().map(|g| g.pose.recv())) => {
                if let Some(g) = guide.as_mut() { g.on_pose(p.body) }
            }
            Some(s) = bus::maybe(guide.as_ref().map(|g| g.speech.recv())) => {
                if let Some(g) = guide.as_mut() { g.on_speech(&s.body) }
            }
            Some(t) = bus::maybe(guide.as_ref().map(|g| g.truth.recv())) => {
                if let Some(g) = guide.as_mut() { g.on_truth(t.body) }
            }
            _ = guide_tick.tick(), if guide.is_some() => {
                if let Some(g) = guide.as_mut() {
                    g.tick().await;
                    // once "you have arrived" has been heard to its end
                    if g.done(Duration::from_secs(8)) {
                        break;
                    }
                }
            }
        }
    }
    let mut failures = Vec::new();
    feedback_shutdown.trigger_exit();
    stopped("feedback-agent", feedback, &mut failures).await;
    shutdown.trigger_exit();
    for (name, task) in [("sensor-agent", sensor), ("compute-agent", compute), ("phone-bridge", phone)] {
        stopped(name, task, &mut failures).await;
    }
    let _ = session.close().await;
    let (p50, p99) = bus::health::percentiles(&mut tally.e2e_ms);
    let (i50, i99) = bus::health::percentiles(&mut tally.intent_ms);
    eprintln!(
        "demo summary: capture->haptic intent p50 {} ms p99 {} ms over {} frames",
        fmt_ms(i50),
        fmt_ms(i99),
        tally.intent_ms.len()
    );
    eprintln!(
        "demo summary: hops p50/p99 ms (capture->arrival at compute, then compute's stages): {}",
        tally.stage_breakdown()
    );
    eprintln!(
        "demo summary: {:.1} s, {} hazards ({:.1}/s), {} applied actions, capture->applied p50 {} ms p99 {} ms over {} rumble changes made on an intent's arrival (pulse edges are the agent's own timing), {} offline warnings, {} rejects, {} messages lost on the way",
        started.elapsed().as_secs_f32(),
        tally.hazards,
        tally.hazards as f32 / started.elapsed().as_secs_f32(),
        tally.applied,
        fmt_ms(p50),
        fmt_ms(p99),
        tally.e2e_ms.len(),
        tally.offline_warnings,
        tally.losses().0,
        tally.losses().1
    );
    if !failures.is_empty() {
        bail!("agents failed: {}", failures.join("; "));
    }
    if let Some(g) = &guide {
        g.finish()?;
    }
    if tally.hazards == 0 {
        bail!("no hazard was perceived: obstacle detection never ran");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Parser)]
    struct Demo {
        #[command(flatten)]
        args: DemoArgs,
    }

    #[tokio::test]
    async fn a_backend_named_twice_is_refused_before_any_agent_starts() {
        // a source that cannot open: reaching it would fail with another message
        let Demo { args } = Demo::parse_from(["demo", "--haptic", "phone,phone", "--source", "sim:no-such-world"]);
        let error = format!("{:#}", run(args).await.unwrap_err());
        assert!(error.starts_with("--haptic names phone twice"), "{error}");
    }

    #[tokio::test]
    async fn a_bad_guidance_profile_is_refused_before_any_agent_starts() {
        let dir = tempfile::Builder::new().prefix("wearnav-demo-").tempdir().unwrap();
        let path = dir.path().join("profile.toml");
        std::fs::write(&path, "directions = \"compass\"\n").unwrap();
        let file = path.to_str().unwrap();
        let Demo { args } = Demo::parse_from(["demo", "--world", "corridor", "--guidance-profile", file]);
        let error = format!("{:#}", run(args).await.unwrap_err());
        assert!(error.starts_with("bad guidance profile") && error.contains("compass"), "{error}");
        let Demo { args } = Demo::parse_from(["demo", "--source", "pcd:nowhere", "--guidance-profile", file]);
        let error = format!("{:#}", run(args).await.unwrap_err());
        assert!(error.starts_with("--guidance-profile needs a simulated world"), "{error}");
    }

    #[tokio::test]
    async fn world_names_the_simulated_source() {
        let Demo { args } = Demo::parse_from(["demo", "--world", "no-such-world", "--destination", "music"]);
        let error = format!("{:#}", run(args).await.unwrap_err());
        assert!(error.contains("no-such-world"), "the world is loaded as sim:no-such-world: {error}");
        assert!(Demo::try_parse_from(["demo", "--world", "taylor-course", "--source", "sim:corridor"]).is_err());
    }
}
