//! The compute agent's loop: the only place where perception meets the bus and the
//! clock. Newest depth frame in; scan, hazard and haptic intent out, each stamped with
//! the frame's capture time so every downstream latency is measured from capture.

use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use bus::{BusOptions, Health, Lane, Publisher, Received, Shutdown, Subscriber};
use schemas::{DepthFrame, HapticIntent, Hazard, ImuBatch, OdomIncrement, Scan, StageLatency};

use crate::body_rate::{BodyRate, MAX_AGE_NS};
use crate::perception::rejections::{self, REJECTIONS_BEFORE_BLIND};
use crate::perception::{
    cue, cue_unavailable, CueConfig, DepthInput, FrameContext, InstantTimer, Motion, PerceptionConfig, Pipeline,
    Rejections, StageTimer,
};

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
}

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
        }
    }
}

/// Largest step one odometry increment may report, metres and radians: far beyond
/// anything a walking user does between two frames (30 Hz), far below what would wreck
/// the memory's map (a finite but absurd step moves every remembered cell for good).
const MAX_STEP_M: f32 = 2.0;
const MAX_STEP_RAD: f32 = std::f32::consts::PI;
/// Increments held for frames not yet arrived; beyond this the oldest two are merged.
const MAX_PENDING_STEPS: usize = 64;
/// A step ending this far after a frame's capture is on another clock: it is taken in
/// the order it arrived, as if it had no stamp.
const OTHER_CLOCK_NS: u64 = 1_000_000_000;

/// An odometry increment that cannot be a walking user's motion.
#[derive(Debug, thiserror::Error)]
#[error("odometry step of {forward_m} m forward, {left_m} m left, {yaw_rad} rad over {from_ns}..{to_ns} ns is not a walking user's")]
struct ImplausibleStep {
    from_ns: u64,
    to_ns: u64,
    forward_m: f32,
    left_m: f32,
    yaw_rad: f32,
}

/// Planar motion reported by odometry, held until the frame it leads up to: each frame
/// takes the steps that end at or before its capture stamp, so a frame never gets a
/// later frame's motion nor loses its own to the order the two arrive in.
#[derive(Debug, Default)]
struct MotionSince {
    /// (end stamp, motion), in arrival order.
    pending: Vec<(u64, Motion)>,
}

impl MotionSince {
    fn add(&mut self, inc: &OdomIncrement) -> Result<(), ImplausibleStep> {
        let m = Motion { forward_m: inc.forward_m, left_m: inc.left_m, yaw_rad: inc.yaw_rad };
        if !(m.is_finite() && m.forward_m.hypot(m.left_m) <= MAX_STEP_M && m.yaw_rad.abs() <= MAX_STEP_RAD) {
            let &OdomIncrement { from_ns, to_ns, forward_m, left_m, yaw_rad } = inc;
            return Err(ImplausibleStep { from_ns, to_ns, forward_m, left_m, yaw_rad });
        }
        if self.pending.len() >= MAX_PENDING_STEPS {
            // no frame for a while: keep the motion, in fewer pieces
            let (_, first) = self.pending.remove(0);
            self.pending[0].1 = first.then(self.pending[0].1);
        }
        self.pending.push((inc.to_ns, m));
        Ok(())
    }

    /// The motion of every step ending at or before `capture_ns`, composed in order.
    fn take_until(&mut self, capture_ns: u64) -> Option<Motion> {
        let mut total: Option<Motion> = None;
        self.pending.retain(|&(to_ns, m)| {
            let due = to_ns <= capture_ns || to_ns - capture_ns > OTHER_CLOCK_NS;
            if due {
                total = Some(m.after(total));
            }
            !due
        });
        total
    }
}

struct Outputs {
    scan: Publisher<Scan>,
    hazard: Publisher<Hazard>,
    haptic: Publisher<HapticIntent>,
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

/// Run the compute agent until `shutdown`.
pub async fn run(config: ComputeConfig, shutdown: Shutdown) -> anyhow::Result<()> {
    let keys = config.bus.keys()?;
    let session = bus::open_session(&config.bus).await?;
    let health = Health::new(AGENT);
    tokio::spawn(health.clone().serve(session.clone(), keys.clone(), config.health_period, shutdown.clone()));

    let frames = Subscriber::<DepthFrame>::declare(&session, keys.depth_any(), true, &health).await?;
    let odom = Subscriber::<OdomIncrement>::declare(&session, keys.odom_any(), false, &health).await?;
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
    };
    let mut pipeline = Pipeline::new(config.perception.clone());
    let mut motion = MotionSince::default();
    let mut depth = Vec::new();
    let mut rejections = Rejections::default();
    health.set_status(true, "waiting for depth frames");
    tracing::info!(user = %config.bus.user, "compute agent running: {} -> {}", keys.depth_any(), keys.hazard());

    loop {
        tokio::select! {
            // odometry first: a frame waiting with its own step behind it takes the step
            biased;
            _ = shutdown.triggered() => break,
            Some(inc) = odom.recv() => add_step(&mut motion, &inc, &health),
            Some(batch) = body.recv() => body.add(&batch, &health),
            Some(frame) = frames.recv() => {
                while let Some(inc) = odom.try_recv() {
                    add_step(&mut motion, &inc, &health);
                }
                while let Some(batch) = body.imu.as_ref().and_then(|s| s.try_recv()) {
                    body.add(&batch, &health);
                }
                let body_yaw_rate_rad_s = body.rate_for(&frame.key, frame.header.capture_ns);
                let frame_in = FrameIn { frame: &frame, body_yaw_rate_rad_s };
                let ok = process(frame_in, &mut pipeline, &mut depth, &mut motion, &config, &health, &mut out).await;
                if rejections.record(ok) {
                    publish_blind(&frame, &config, &health, &mut out).await;
                }
            }
        }
    }
    tracing::info!("compute agent stopping");
    session.close().await.map_err(|e| anyhow::anyhow!("{e}")).context("closing the Zenoh session")?;
    Ok(())
}

fn add_step(motion: &mut MotionSince, inc: &Received<OdomIncrement>, health: &Health) {
    if let Err(e) = motion.add(&inc.body) {
        health.reject(&inc.key, "odom_implausible", &e);
    }
}

/// Process one frame; `false` when it was rejected (and counted).
/// A depth frame and the body's turn rate at its capture.
struct FrameIn<'a> {
    frame: &'a Received<DepthFrame>,
    body_yaw_rate_rad_s: Option<f32>,
}

async fn process(
    FrameIn { frame, body_yaw_rate_rad_s }: FrameIn<'_>,
    pipeline: &mut Pipeline,
    depth: &mut Vec<u16>,
    motion: &mut MotionSince,
    config: &ComputeConfig,
    health: &Arc<Health>,
    out: &mut Outputs,
) -> bool {
    let f = &frame.body;
    let mut clock = InstantTimer::default();
    // The hops before this agent, so a monitor can attribute capture -> intent:
    // `arrival` = capture -> decoded off the bus here (sensor packing + transport),
    // `queue` = waiting for this loop (another frame or odometry being handled).
    let started_ns = bus::now_ns();
    clock.stages.push(("arrival", Duration::from_nanos(frame.received_ns.saturating_sub(frame.header.capture_ns))));
    clock.stages.push(("queue", Duration::from_nanos(started_ns.saturating_sub(frame.received_ns))));
    clock.start("decode");
    let decoded = schemas::depth_codec::decode(&f.data, f.width, f.height, f.encoding, depth);
    clock.stop();
    if let Err(e) = decoded {
        health.reject(&frame.key, "depth_decode", &e);
        return false;
    }
    let input = DepthInput::Depth {
        samples: depth,
        width: f.width,
        height: f.height,
        depth_scale_m: f.depth_scale_m,
        intrinsics: f.intrinsics,
    };
    let capture_ns = frame.header.capture_ns;
    let ctx = FrameContext {
        stamp_ns: capture_ns,
        gravity_camera: f.gravity_camera,
        motion: motion.take_until(capture_ns),
        body_yaw_rate_rad_s,
    };
    let perception = match pipeline.process(input, &ctx, &mut clock) {
        Ok(p) => p.clone(),
        Err(e) => {
            health.reject(&frame.key, e.kind(), &e);
            return false;
        }
    };
    let intent = cue(&perception, &config.cue);
    let latency = clock
        .stages
        .iter()
        .map(|(stage, d)| StageLatency { stage: stage.to_string(), us: d.as_micros() as u32 })
        .collect();
    let hazard = perception.hazard(frame.header.seq, config.perception.cost_function, latency);
    let seeing = matches!(hazard.ground, schemas::GroundState::Found);
    let body = match body_yaw_rate_rad_s {
        Some(r) => format!("body turning {:+.0} deg/s", r.to_degrees()),
        None => "no body turn rate".to_string(),
    };
    health.set_status(seeing, format!("{:?} ground, rumble {:?}, {body}", hazard.ground, hazard.rumble));
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
    true
}

/// Frames keep coming but none can be used: say so with a degraded hazard (rumble
/// `Both`: stop) and the distinct "unavailable" cue, rather than fall silent.
async fn publish_blind(frame: &Received<DepthFrame>, config: &ComputeConfig, health: &Arc<Health>, out: &mut Outputs) {
    let hazard = rejections::blind().hazard(frame.header.seq, config.perception.cost_function, Vec::new());
    health.set_status(false, "depth frames unusable: obstacle detection degraded");
    tracing::warn!("{REJECTIONS_BEFORE_BLIND}+ unusable depth frames in a row: reporting degraded");
    let capture_ns = frame.header.capture_ns;
    for result in
        [out.haptic.put(capture_ns, &cue_unavailable(&config.cue)).await, out.hazard.put(capture_ns, &hazard).await]
    {
        if let Err(e) = result {
            tracing::warn!("{e:#}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odometry_increments_compose_in_the_first_frame() {
        let mut m = MotionSince::default();
        let quarter = std::f32::consts::FRAC_PI_2;
        m.add(&OdomIncrement { from_ns: 0, to_ns: 1, forward_m: 1.0, left_m: 0.0, yaw_rad: quarter }).unwrap();
        m.add(&OdomIncrement { from_ns: 1, to_ns: 2, forward_m: 1.0, left_m: 0.0, yaw_rad: 0.0 }).unwrap();
        let total = m.take_until(2).unwrap();
        assert!((total.forward_m - 1.0).abs() < 1e-5, "{total:?}");
        assert!((total.left_m - 1.0).abs() < 1e-5, "{total:?}");
        assert!((total.yaw_rad - quarter).abs() < 1e-6);
        assert!(m.take_until(2).is_none(), "taking resets the accumulator");
    }

    #[test]
    fn a_frame_takes_only_the_steps_that_end_by_its_capture() {
        let mut m = MotionSince::default();
        let step =
            |to_ns, forward_m| OdomIncrement { from_ns: to_ns - 33, to_ns, forward_m, left_m: 0.0, yaw_rad: 0.0 };
        // the step ending at frame 2 arrived before frame 1 was processed
        m.add(&step(33, 0.03)).unwrap();
        m.add(&step(66, 0.04)).unwrap();
        assert_eq!(m.take_until(33).map(|t| t.forward_m), Some(0.03));
        assert_eq!(m.take_until(66).map(|t| t.forward_m), Some(0.04));
        assert_eq!(m.take_until(99), None);
        // odometry on a clock seconds ahead of the camera's: taken as it comes
        m.add(&step(5_000_000_099, 0.05)).unwrap();
        assert_eq!(m.take_until(99).map(|t| t.forward_m), Some(0.05));
    }

    #[test]
    fn absurd_odometry_is_refused_and_leaves_the_motion_alone() {
        let mut m = MotionSince::default();
        let inc = |forward_m, yaw_rad| OdomIncrement { from_ns: 0, to_ns: 33, forward_m, left_m: 0.0, yaw_rad };
        m.add(&inc(0.03, 0.1)).unwrap();
        let e = m.add(&inc(1e17, 0.0)).unwrap_err();
        assert!(e.to_string().contains("not a walking user's"), "{e}");
        assert!(m.add(&inc(0.0, 7.0)).is_err());
        assert!(m.add(&inc(f32::NAN, 0.0)).is_err());
        let total = m.take_until(33).unwrap();
        assert_eq!((total.forward_m, total.yaw_rad), (0.03, 0.1));
    }

    #[test]
    fn steps_held_without_frames_are_merged_not_lost() {
        let mut m = MotionSince::default();
        for k in 1..=200u64 {
            m.add(&OdomIncrement { from_ns: k - 1, to_ns: k, forward_m: 0.01, left_m: 0.0, yaw_rad: 0.0 }).unwrap();
        }
        assert!(m.pending.len() <= MAX_PENDING_STEPS);
        let total = m.take_until(200).unwrap();
        assert!((total.forward_m - 2.0).abs() < 1e-4, "{total:?}");
    }
}
