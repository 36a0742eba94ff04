//! The compute agent's loop: the only place where perception meets the bus and the
//! clock. Newest depth frame in; scan, hazard and haptic intent out, each stamped with
//! the frame's capture time so every downstream latency is measured from capture.

use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use bus::{BusOptions, Health, Lane, Publisher, Received, Shutdown, Subscriber};
use schemas::{DepthFrame, HapticIntent, Hazard, OdomIncrement, Scan, StageLatency};

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
}

impl ComputeConfig {
    /// Defaults for `bus`.
    pub fn new(bus: BusOptions) -> Self {
        Self {
            bus,
            perception: PerceptionConfig::default(),
            cue: CueConfig::default(),
            health_period: Duration::from_secs(1),
        }
    }
}

/// Planar motion reported by odometry since the last processed frame.
#[derive(Debug, Default)]
struct MotionSince {
    motion: Option<Motion>,
}

impl MotionSince {
    fn add(&mut self, inc: &OdomIncrement) {
        let m = self.motion.get_or_insert(Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 0.0 });
        // Compose in the frame of the first increment: rotate the new translation by
        // the heading accumulated so far.
        let (s, c) = m.yaw_rad.sin_cos();
        m.forward_m += c * inc.forward_m - s * inc.left_m;
        m.left_m += s * inc.forward_m + c * inc.left_m;
        m.yaw_rad += inc.yaw_rad;
    }

    fn take(&mut self) -> Option<Motion> {
        self.motion.take()
    }
}

struct Outputs {
    scan: Publisher<Scan>,
    hazard: Publisher<Hazard>,
    haptic: Publisher<HapticIntent>,
}

/// Run the compute agent until `shutdown`.
pub async fn run(config: ComputeConfig, shutdown: Shutdown) -> anyhow::Result<()> {
    let keys = config.bus.keys()?;
    let session = bus::open_session(&config.bus).await?;
    let health = Health::new(AGENT);
    tokio::spawn(health.clone().serve(session.clone(), keys.clone(), config.health_period, shutdown.clone()));

    let frames = Subscriber::<DepthFrame>::declare(&session, keys.depth_any(), true, &health).await?;
    let odom = Subscriber::<OdomIncrement>::declare(&session, keys.odom_any(), false, &health).await?;
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
            _ = shutdown.triggered() => break,
            Some(inc) = odom.recv() => motion.add(&inc.body),
            Some(frame) = frames.recv() => {
                let ok = process(&frame, &mut pipeline, &mut depth, &mut motion, &config, &health, &mut out).await;
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

/// Process one frame; `false` when it was rejected (and counted).
async fn process(
    frame: &Received<DepthFrame>,
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
    let ctx =
        FrameContext { stamp_ns: frame.header.capture_ns, gravity_camera: f.gravity_camera, motion: motion.take() };
    let perception = match pipeline.process(input, &ctx, &mut clock) {
        Ok(p) => p.clone(),
        Err(e) => {
            health.reject(&frame.key, e.kind(), &e);
            return false;
        }
    };
    let capture_ns = frame.header.capture_ns;
    let intent = cue(&perception, &config.cue);
    let latency = clock
        .stages
        .iter()
        .map(|(stage, d)| StageLatency { stage: stage.to_string(), us: d.as_micros() as u32 })
        .collect();
    let hazard = perception.hazard(frame.header.seq, config.perception.cost_function, latency);
    let seeing = matches!(hazard.ground, schemas::GroundState::Found);
    health.set_status(seeing, format!("{:?} ground, rumble {:?}", hazard.ground, hazard.rumble));
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
        m.add(&OdomIncrement { from_ns: 0, to_ns: 1, forward_m: 1.0, left_m: 0.0, yaw_rad: quarter });
        m.add(&OdomIncrement { from_ns: 1, to_ns: 2, forward_m: 1.0, left_m: 0.0, yaw_rad: 0.0 });
        let total = m.take().unwrap();
        assert!((total.forward_m - 1.0).abs() < 1e-5, "{total:?}");
        assert!((total.left_m - 1.0).abs() < 1e-5, "{total:?}");
        assert!((total.yaw_rad - quarter).abs() < 1e-6);
        assert!(m.take().is_none(), "taking resets the accumulator");
    }
}
