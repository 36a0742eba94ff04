//! A guided walk without the bus: the simulated camera walked by a user who follows
//! guidance ([`sim::GuidedWalker`]), and the compute agent's navigation
//! (perception's scan, [`localization::Tracker`], [`guidance::Navigator`]) fed exactly
//! what the agent is fed, frame by frame, as fast as the machine runs. What the demo's
//! guided walk does across processes, made deterministic for tests and for finding out
//! why a walk fails.

use std::sync::{Arc, Mutex};

use guidance::{GuidanceProfile, Navigator, UserPose};
use localization::{Pose2, Tracker, TrackerConfig};
use perception::body_rate::BodyRate;
use perception::{ComputeStep, CueConfig, FrameData, FrameIn, NoTimer, PerceptionConfig, StepOutput};
use planning::UserProfile;
use schemas::{Command, DepthEncoding, DepthFrame, RouteStatus};
use sim::source::Guidance;
use sim::FrameSource;
use sim::{Directions, DirectionsHandle, SimConfig, SimSource, World};

use crate::floor_plan;

/// One frame of a guided walk.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GuidedFrame {
    /// seconds from the start
    pub t_s: f64,
    /// the simulator's truth: x, y, heading (degrees), floor
    pub truth: [f64; 4],
    /// the filter's estimate: x, y, heading (degrees), floor
    pub estimate: [f64; 4],
    /// guidance took the filter's place ([`localization::Estimate::guides`]: tracking,
    /// or followed from the told start)
    pub guided: bool,
    /// the sweep the scan was read with, degrees
    pub sweep_deg: f64,
    /// the simulator's sweep, degrees
    pub true_sweep_deg: f64,
    /// where guidance stands
    #[serde(skip)]
    pub status: RouteStatus,
}

/// What a guided walk gave.
#[derive(Debug, Clone, serde::Serialize)]
pub struct GuidedReport {
    /// every frame
    pub frames: Vec<GuidedFrame>,
    /// what was said, with its time
    pub said: Vec<(f64, String)>,
    /// guidance said "arrived", at this time
    pub arrived_s: Option<f64>,
    /// the user's distance from the place at the end, metres, and the floor
    pub off_m: f64,
    /// the floor the user ended on
    pub floor: i32,
}

/// Walks `world` from its start to the place called `label`, at most `timeout_s`.
pub fn guided_walk(world_name: &str, label: &str, seed: u64, timeout_s: f64) -> anyhow::Result<GuidedReport> {
    let world = World::load(world_name)?;
    let building = floor_plan::export(&world, floor_plan::DEFAULT_RESOLUTION_M)?;
    let directions: DirectionsHandle = Arc::new(Mutex::new(Directions::default()));
    let mut sim = SimSource::new(SimConfig {
        world: world_name.to_string(),
        seed,
        guided_by: Some(Guidance(directions.clone())),
        ..SimConfig::default()
    })?;
    let start = world.start();
    let mut tracker = Tracker::new(&building, TrackerConfig::default(), seed)?;
    tracker.start_at(start.floor, Pose2::new(start.x_m, start.y_m, start.yaw_rad))?;
    let route = UserProfile { prefer_elevator: true, ..UserProfile::default() };
    let mut nav = Navigator::new(&building, route, GuidanceProfile::default());
    let place = nav.find(label).map_err(anyhow::Error::msg)?.clone();
    let mut step = ComputeStep::new(PerceptionConfig::default(), CueConfig::default());
    let (mut body, mut cane) = (BodyRate::default(), BodyRate::default());
    let period = sim.period_ns();
    let t0 = 1_000_000_000_000u64;
    let mut report = GuidedReport { frames: Vec::new(), said: Vec::new(), arrived_s: None, off_m: f64::NAN, floor: 0 };
    let mut asked = false;
    for k in 0.. {
        let now = t0 + k * period;
        let t_s = (k * period) as f64 * 1e-9;
        if t_s > timeout_s || report.arrived_s.is_some_and(|a| t_s > a + 2.0) {
            break;
        }
        let Some(f) = sim.next_frame(now)? else { break };
        for s in &f.body_imu {
            let _ = body.add(s, now);
        }
        for s in &f.imu {
            let _ = cane.add(s, now);
        }
        let body_rate = body.rate_at(f.stamp_ns, now);
        if let Some(o) = &f.odom {
            let _ = step.add_odometry(o);
            let _ = tracker.odometry(o, body.rate_at(o.to_ns, now).map(f64::from));
        }
        let mut data = Vec::new();
        schemas::depth_codec::encode(&f.depth, f.width, f.height, DepthEncoding::Raw, &mut data)?;
        let frame = DepthFrame {
            width: f.width,
            height: f.height,
            depth_scale_m: f.depth_scale_m,
            intrinsics: f.intrinsics,
            gravity_camera: f.gravity_camera,
            mount: f.mount,
            encoding: DepthEncoding::Raw,
            data,
        };
        let input = FrameIn {
            data: FrameData::Wire(&frame),
            seq: k,
            capture_ns: f.stamp_ns,
            body_yaw_rate_rad_s: body_rate,
            way: None,
        };
        if let StepOutput::Perceived { perception, .. } = step.process(input, &mut NoTimer) {
            tracker.frame(
                &perception.scan,
                f.stamp_ns,
                cane.rate_at(f.stamp_ns, now).map(f64::from),
                body_rate.map(f64::from),
            );
        }
        let e = tracker.estimate();
        let pose = UserPose {
            x_m: e.pose.x_m,
            y_m: e.pose.y_m,
            heading_rad: e.pose.heading_rad,
            floor: e.level,
            confident: e.guides(),
        };
        let now_ms = k * period / 1_000_000;
        let mut said = Vec::new();
        let news = tracker.news();
        said.extend(news.map(str::to_string));
        nav.set_awaiting_word(e.awaits_word());
        if !asked {
            said.extend(
                nav.command(&Command::Destination { label: place.name.clone() }, &pose, now_ms)
                    .speech
                    .into_iter()
                    .map(|s| s.text),
            );
            asked = true;
        }
        said.extend(nav.step_after_news(&pose, news, now_ms).map(|s| s.text));
        let floor_said = {
            let mut d = directions.lock().unwrap_or_else(|p| p.into_inner());
            d.said_floor.take()
        };
        if let Some(floor) = floor_said {
            let r = nav.command(&Command::Floor { floor }, &pose, now_ms);
            if let Some(level) = r.floor_confirmed {
                if let Err(e) = tracker.floor_confirmed(level) {
                    said.push(format!("(floor {level} refused: {e})"));
                }
            }
            said.extend(r.speech.into_iter().map(|s| s.text));
        }
        let state = nav.state(&pose);
        if state.status == RouteStatus::Arrived && report.arrived_s.is_none() {
            report.arrived_s = Some(t_s);
        }
        {
            let first_floor = state.route.first().map(|p| p.floor);
            let mut d = directions.lock().unwrap_or_else(|p| p.into_inner());
            d.status = Some(state.status);
            d.next = state.next_waypoint;
            d.next_floor = state.route.iter().map(|p| p.floor).find(|fl| Some(*fl) != first_floor);
            d.estimate = Some(tracker.pose());
        }
        report.said.extend(said.into_iter().map(|s| (t_s, s)));
        let Some(truth) = f.truth else { continue };
        report.frames.push(GuidedFrame {
            t_s,
            truth: [
                f64::from(truth.x_m),
                f64::from(truth.y_m),
                f64::from(truth.yaw_rad).to_degrees(),
                f64::from(truth.floor),
            ],
            estimate: [e.pose.x_m, e.pose.y_m, e.pose.heading_rad.to_degrees(), f64::from(e.level)],
            guided: pose.confident,
            sweep_deg: tracker.sweep_rad().to_degrees(),
            true_sweep_deg: f64::from(truth.sweep_deg),
            status: state.status,
        });
        report.off_m = (f64::from(truth.x_m) - place.x).hypot(f64::from(truth.y_m) - place.y);
        report.floor = truth.floor;
    }
    Ok(report)
}
