//! The sensor agent's loop: a source thread paces and compresses frames; the async
//! side publishes depth, IMU, odometry, pressure and ground truth, and says in its health when
//! the source stalls.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::{anyhow, Context};
use bus::{BusOptions, Health, Lane, Publisher, Shutdown, Subscriber};
use schemas::{
    DepthEncoding, DepthFrame, GroundTruth, Hazard, ImuBatch, MountGuess, OdomIncrement, PhoneMotion, Pressure,
};
use tokio::sync::mpsc;
use zenoh::sample::SampleKind;

use crate::pacing::{Level, LevelChange, Pacer, PacingConfig};
use crate::source::{FrameSource, SourceError, SourceFrame};

/// Agent name: liveliness token `health/sensor-agent` and sender of its messages.
pub const AGENT: &str = "sensor-agent";

/// Everything the sensor agent needs to run.
#[derive(Debug, Clone)]
pub struct SensorConfig {
    /// Bus and user.
    pub bus: BusOptions,
    /// Device name in the keys (`sensor/<device>/...`).
    pub device: String,
    /// Device name of the phone worn on the body, when the source has one (the
    /// simulator's): its IMU `sensor/<body_device>/imu`, its compass and steps
    /// `sensor/<body_device>/motion`.
    pub body_device: String,
    /// How depth is packed on the wire (the finest level when pacing).
    pub codec: WireCodec,
    /// Send a frame only when the link has room, and coarsen the codec when it has
    /// too little ([`crate::pacing`]); off: every frame, always `codec`.
    pub pacing: bool,
    /// The compute agent whose hazards answer the frames (its liveliness token
    /// `health/<name>` says whether anything will).
    pub compute_agent: String,
    /// Health says "stalled" when no frame came for this long (safety rule 1).
    pub stall_after: Duration,
    /// Period of health stats.
    pub health_period: Duration,
    /// Where the camera sits on the cane, sent with every frame whose source does not
    /// know it (every source but the simulator): the compute agent looks for the floor
    /// near this height, so a seat or a box top filling the view is not taken for it.
    pub mount: Option<MountGuess>,
    /// Device name of the chest camera, when the source has one (the simulator's with
    /// `SourceOptions::chest`): its frames and odometry on `sensor/<chest_device>/depth`
    /// and `/odom`, paced with the cane camera's.
    pub chest_device: Option<String>,
}

impl SensorConfig {
    /// Defaults for `bus`: device `cane` (and `body` worn), lossless frames, 500 ms stall deadline.
    pub fn new(bus: BusOptions) -> Self {
        Self {
            bus,
            device: "cane".to_string(),
            body_device: "body".to_string(),
            codec: WireCodec::Lossless,
            pacing: true,
            compute_agent: "compute-agent".to_string(),
            stall_after: Duration::from_millis(500),
            health_period: Duration::from_secs(1),
            mount: None,
            chest_device: None,
        }
    }
}

/// How depth is packed on the wire, independent of each source's depth unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireCodec {
    /// Uncompressed.
    Raw,
    /// Exact samples.
    Lossless,
    /// Quantised to a step in millimetres (max error half a step).
    BoundedMm(u16),
}

impl WireCodec {
    /// The encoding for frames whose unit is `depth_scale_m` metres: a millimetre step
    /// becomes a whole number of units, rounded down so the promised bound holds
    /// (at least one unit).
    pub fn encoding_for(self, depth_scale_m: f32) -> DepthEncoding {
        match self {
            WireCodec::Raw => DepthEncoding::Raw,
            WireCodec::Lossless => DepthEncoding::Lossless,
            WireCodec::BoundedMm(mm) => {
                // The tolerance absorbs f32 scales like 0.001 that are a hair above
                // their decimal value (5 mm / 0.001 must be 5 units, not 4.9999).
                let units = (f64::from(mm) * 1e-3 / f64::from(depth_scale_m) + 1e-6).floor();
                DepthEncoding::Bounded { step: units.clamp(1.0, f64::from(u16::MAX)) as u16 }
            }
        }
    }
}

/// What the source thread hands to the publisher.
enum Produced {
    // boxed: a frame is ~300 bytes of metadata, the other variants a string
    // `depth` is None when the pacer held the frame back (its motion still goes)
    // `chest` is the chest camera's frame, packed alike, when the source has one
    Frame { frame: Box<SourceFrame>, depth: Option<DepthFrame>, chest: Option<DepthFrame> },
    Skipped(String),
    End,
    Failed(String),
}

/// Pack `frame` at `level`: halved to every second pixel of every second row (the
/// intrinsics with it) when the level says so, then compressed with its codec.
fn pack(
    frame: &SourceFrame,
    mount: Option<MountGuess>,
    level: Level,
    halved: &mut Vec<u16>,
    buf: &mut Vec<u8>,
) -> Result<DepthFrame, String> {
    let encoding = level.codec.encoding_for(frame.depth_scale_m);
    let (mut width, mut height, mut k) = (frame.width, frame.height, frame.intrinsics);
    let samples = if level.half {
        if frame.width == 0 || frame.depth.len() != frame.width as usize * frame.height as usize {
            return Err(format!("{} samples for {}x{}", frame.depth.len(), frame.width, frame.height));
        }
        (width, height) = (frame.width.div_ceil(2), frame.height.div_ceil(2));
        let w = frame.width as usize;
        halved.clear();
        halved.extend(frame.depth.chunks(w).step_by(2).flat_map(|row| row.iter().step_by(2)));
        k = schemas::Intrinsics { fx: k.fx / 2.0, fy: k.fy / 2.0, cx: k.cx / 2.0, cy: k.cy / 2.0 };
        &halved[..]
    } else {
        &frame.depth[..]
    };
    schemas::depth_codec::encode(samples, width, height, encoding, buf).map_err(|e| e.to_string())?;
    Ok(DepthFrame {
        width,
        height,
        depth_scale_m: frame.depth_scale_m,
        intrinsics: k,
        gravity_camera: frame.gravity_camera,
        mount: frame.mount.or(mount),
        encoding,
        data: std::mem::take(buf),
    })
}

/// Pull frames from `source` at its pace (sleeping until each frame's stamp), pack
/// them, hand them over. Runs on its own thread: rendering and compression are CPU
/// work that must not stall the async publishers.
fn produce(
    mut source: Box<dyn FrameSource>,
    mount: Option<MountGuess>,
    pacer: Arc<Mutex<Pacer>>,
    tx: mpsc::Sender<Produced>,
    shutdown: Shutdown,
) {
    let (mut buf, mut halved) = (Vec::new(), Vec::new());
    let period_ns = source.period_ns();
    // Paced sources (simulator, replay) are asked for the frame of the next capture
    // moment a little ahead of it, so a frame of time t is in hand at t, like a camera
    // with no readout delay: the capture -> applied latency then measures the agents,
    // not how long the simulator takes to render. Compression happens after the stamp,
    // as it would on a real device.
    let lead_ns = period_ns * 3 / 4;
    let mut next_due_ns = bus::now_ns() + lead_ns;
    while !shutdown.is_triggered() {
        if period_ns > 0 {
            sleep_until_ns(next_due_ns.saturating_sub(lead_ns));
        }
        let item = match source.next_frame(next_due_ns.max(bus::now_ns())) {
            Ok(Some(frame)) => {
                sleep_until_ns(frame.stamp_ns);
                let level = pacer.lock().unwrap_or_else(|e| e.into_inner()).admit(frame.stamp_ns, bus::now_ns());
                let packed = level.map(|level| {
                    let depth = pack(&frame, mount, level, &mut halved, &mut buf)?;
                    let chest = frame.chest.as_deref().map(|c| pack(c, None, level, &mut halved, &mut buf));
                    Ok::<_, String>((depth, chest.transpose()?))
                });
                match packed.transpose() {
                    Ok(Some((depth, chest))) => Produced::Frame { frame: Box::new(frame), depth: Some(depth), chest },
                    Ok(None) => Produced::Frame { frame: Box::new(frame), depth: None, chest: None },
                    Err(e) => Produced::Skipped(format!("frame could not be packed: {e}")),
                }
            }
            Ok(None) => Produced::End,
            Err(SourceError::Skipped { what, reason }) => Produced::Skipped(format!("{what}: {reason}")),
            Err(SourceError::Fatal(reason)) => Produced::Failed(reason),
        };
        // Never burst to catch up after a slow frame: late frames are just late.
        next_due_ns = (next_due_ns + period_ns).max(bus::now_ns());
        let last = matches!(item, Produced::End | Produced::Failed(_));
        if tx.blocking_send(item).is_err() || last {
            return;
        }
    }
}

/// Sleep until the wall clock reaches `stamp_ns` (at most 5 s, so a bad stamp in a
/// recording cannot freeze the stream).
fn sleep_until_ns(stamp_ns: u64) {
    let wait_ns = stamp_ns.saturating_sub(bus::now_ns());
    if wait_ns > 0 {
        std::thread::sleep(Duration::from_nanos(wait_ns.min(5_000_000_000)));
    }
}

struct Outputs {
    depth: Publisher<DepthFrame>,
    imu: Publisher<ImuBatch>,
    body_imu: Publisher<ImuBatch>,
    /// the body-worn phone's compass and steps (`sensor/<body_device>/motion`)
    motion: Publisher<PhoneMotion>,
    /// the cane board's barometer (`sensor/<device>/pressure`)
    pressure: Publisher<Pressure>,
    odom: Publisher<OdomIncrement>,
    truth: Publisher<GroundTruth>,
    /// The chest camera's depth and odometry.
    chest: Option<(Publisher<DepthFrame>, Publisher<OdomIncrement>)>,
}

/// Run the sensor agent on `source` until `shutdown` or the end of a finite recording.
pub async fn run(config: SensorConfig, source: Box<dyn FrameSource>, shutdown: Shutdown) -> anyhow::Result<()> {
    let keys = config.bus.keys()?;
    schemas::keys::check_chunk("device", &config.device).context("bad --device")?;
    schemas::keys::check_chunk("device", &config.body_device).context("bad --body-device")?;
    if config.body_device == config.device {
        anyhow::bail!(
            "--body-device {0:?} is the camera's --device: the body-worn IMU needs a device name of its own",
            config.device
        );
    }
    if let Some(chest) = &config.chest_device {
        schemas::keys::check_chunk("device", chest).context("bad --chest-device")?;
        anyhow::ensure!(
            chest != &config.device && chest != &config.body_device,
            "--chest-device {chest:?} is the camera's or the body IMU's device: the chest camera needs a name of its own"
        );
    }
    let session = bus::open_session(&config.bus).await?;
    let health = Health::new(AGENT);
    let mut health_task = health.spawn(session.clone(), keys.clone(), config.health_period, shutdown.clone());
    let dev = &config.device;
    let mut out = Outputs {
        depth: Publisher::declare(&session, keys.depth(dev), AGENT, Lane::Bulk, Some(&health)).await?,
        imu: Publisher::declare(&session, keys.imu(dev), AGENT, Lane::Telemetry, Some(&health)).await?,
        body_imu: Publisher::declare(&session, keys.imu(&config.body_device), AGENT, Lane::Telemetry, Some(&health))
            .await?,
        motion: Publisher::declare(&session, keys.motion(&config.body_device), AGENT, Lane::Events, Some(&health))
            .await?,
        pressure: Publisher::declare(&session, keys.pressure(dev), AGENT, Lane::Telemetry, Some(&health)).await?,
        odom: Publisher::declare(&session, keys.odom(dev), AGENT, Lane::Events, Some(&health)).await?,
        truth: Publisher::declare(&session, keys.truth(dev), AGENT, Lane::Telemetry, Some(&health)).await?,
        chest: match &config.chest_device {
            Some(chest) => Some((
                Publisher::declare(&session, keys.depth(chest), AGENT, Lane::Bulk, Some(&health)).await?,
                Publisher::declare(&session, keys.odom(chest), AGENT, Lane::Events, Some(&health)).await?,
            )),
            None => None,
        },
    };
    let described = source.describe();
    tracing::info!(user = %config.bus.user, "sensor agent publishing {described} on {}", keys.depth(dev));
    health.set_status(true, format!("streaming {described}"));

    // Without pacing nothing ever says a compute agent is there: every frame goes, at
    // the configured codec.
    let pacer = Arc::new(Mutex::new(Pacer::new(PacingConfig::for_codec(config.codec))));
    // The compute agent's answers: its hazards (each with the capture stamp of the
    // frame it perceived) and its liveliness (nothing answers without it).
    let answers = match config.pacing {
        true => Some(Subscriber::<Hazard>::declare(&session, keys.hazard(), true, &health).await?),
        false => None,
    };
    let compute_key = keys.health(&config.compute_agent);
    let compute_alive = match config.pacing {
        true => Some(
            session
                .liveliness()
                .declare_subscriber(compute_key.clone())
                .history(true)
                .await
                .map_err(|e| anyhow!("cannot watch the liveliness of {compute_key}: {e}"))?,
        ),
        false => None,
    };

    let (tx, mut rx) = mpsc::channel(2);
    let producer = {
        let shutdown = shutdown.clone();
        let pacer = pacer.clone();
        let mount = config.mount;
        std::thread::Builder::new()
            .name("frame-source".into())
            .spawn(move || produce(source, mount, pacer, tx, shutdown))
            .context("cannot start the frame source thread")?
    };

    let mut stalled = false;
    // the stall deadline runs from the last item of the source, whatever else arrives
    let mut stall_at = tokio::time::Instant::now() + config.stall_after;
    loop {
        let item = tokio::select! {
            _ = shutdown.triggered() => break,
            e = health_task.failed() => return Err(e),
            Some(hazard) = bus::maybe(answers.as_ref().map(|a| a.recv())) => {
                pacer.lock().unwrap_or_else(|e| e.into_inner()).answered(hazard.header.capture_ns, bus::now_ns());
                continue;
            }
            sample = bus::maybe(compute_alive.as_ref().map(|l| l.recv_async())) => {
                match sample {
                    Ok(s) => pacer.lock().unwrap_or_else(|e| e.into_inner()).set_consumer(s.kind() == SampleKind::Put),
                    Err(e) => anyhow::bail!("liveliness subscription of {compute_key} closed: {e}"),
                }
                continue;
            }
            item = tokio::time::timeout_at(stall_at, rx.recv()) => item,
        };
        stall_at = tokio::time::Instant::now() + config.stall_after;
        match item {
            Err(_elapsed) => {
                if !stalled {
                    stalled = true;
                    tracing::warn!("no frame from {described} for {} ms", config.stall_after.as_millis());
                    health.set_status(
                        false,
                        format!("source stalled: no frame for {} ms", config.stall_after.as_millis()),
                    );
                }
            }
            Ok(None) | Ok(Some(Produced::End)) => {
                tracing::info!("{described} ended");
                health.set_status(false, "source ended");
                break;
            }
            Ok(Some(Produced::Failed(reason))) => {
                health.set_status(false, format!("source failed: {reason}"));
                anyhow::bail!("{described} failed: {reason}");
            }
            Ok(Some(Produced::Skipped(reason))) => health.reject(&described, "skipped_input", &reason),
            Ok(Some(Produced::Frame { frame, depth, chest })) => {
                if stalled {
                    stalled = false;
                    tracing::info!("{described} delivering again");
                    health.set_status(true, format!("streaming {described}"));
                }
                publish(&mut out, *frame, depth, chest).await;
                let mut pacer = pacer.lock().unwrap_or_else(|e| e.into_inner());
                if let Some(change) = pacer.tick(bus::now_ns()) {
                    report_level(&change, &pacer, &health, &described);
                }
            }
        }
    }
    drop(rx);
    if producer.join().is_err() {
        tracing::error!("frame source thread panicked");
    }
    health_task.join().await?;
    session.close().await.map_err(|e| anyhow::anyhow!("{e}")).context("closing the Zenoh session")?;
    Ok(())
}

/// A codec change: logged, and said in the health status (what a monitor shows).
fn report_level(change: &LevelChange, pacer: &Pacer, health: &Health, described: &str) {
    let why = format!(
        "of {} frames due in the last second {} held back, {} unanswered; since start {} held back, {} left out",
        change.due,
        change.held,
        change.lost,
        pacer.held_total(),
        pacer.skipped_total()
    );
    let level = |l: &Level| {
        let size = if l.half { "halved" } else { "full size" };
        format!("{:?} {size} at one frame in {}", l.codec, l.every)
    };
    tracing::warn!("link pacing: depth frames now {}, were {} ({why})", level(&change.to), level(&change.from));
    let status = match pacer.level() {
        0 => format!("streaming {described}"),
        _ => format!("streaming {described}; slow link: depth sent {} ({why})", level(&change.to)),
    };
    health.set_status(true, status);
}

async fn publish(out: &mut Outputs, frame: SourceFrame, depth: Option<DepthFrame>, chest: Option<DepthFrame>) {
    let stamp = frame.stamp_ns;
    let mut results = Vec::with_capacity(8);
    if let (Some((chest_depth, chest_odom)), Some(source)) = (out.chest.as_mut(), frame.chest.as_deref()) {
        if let Some(odom) = source.odom {
            results.push(chest_odom.put(stamp, &odom).await);
        }
        if let Some(depth) = &chest {
            results.push(chest_depth.put(stamp, depth).await);
        }
    }
    // the motion leading up to the frame first, so it is there when the frame is processed
    if let Some(odom) = frame.odom {
        results.push(out.odom.put(stamp, &odom).await);
    }
    if !frame.imu.is_empty() {
        results.push(out.imu.put(stamp, &ImuBatch { samples: frame.imu }).await);
    }
    if !frame.body_imu.is_empty() {
        results.push(out.body_imu.put(stamp, &ImuBatch { samples: frame.body_imu }).await);
    }
    if let Some(motion) = &frame.motion {
        results.push(out.motion.put(stamp, motion).await);
    }
    if let Some(pressure) = &frame.pressure {
        results.push(out.pressure.put(stamp, pressure).await);
    }
    if let Some(depth) = depth {
        results.push(out.depth.put(stamp, &depth).await);
    }
    if let Some(truth) = frame.truth {
        results.push(out.truth.put(stamp, &truth).await);
    }
    for r in results {
        if let Err(e) = r {
            tracing::warn!("{e:#}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_halved_frame_keeps_every_second_pixel_of_every_second_row_and_halves_the_intrinsics() {
        let k = schemas::Intrinsics { fx: 500.0, fy: 480.0, cx: 320.0, cy: 240.0 };
        let frame = SourceFrame::depth_only(1, (5, 3), 0.001, k, (1..=15).collect());
        let (mut halved, mut buf) = (Vec::new(), Vec::new());
        let level = Level { codec: WireCodec::Lossless, half: true, every: 1 };
        let packed = pack(&frame, None, level, &mut halved, &mut buf).unwrap();
        assert_eq!((packed.width, packed.height), (3, 2));
        assert_eq!(packed.mount, None);
        // the configured mount goes with a frame whose source has none, not over its own
        let configured = MountGuess { height_m: 0.9, pitch_deg: 30.0 };
        assert_eq!(pack(&frame, Some(configured), level, &mut halved, &mut buf).unwrap().mount, Some(configured));
        let own = SourceFrame { mount: Some(MountGuess { height_m: 0.885, pitch_deg: 30.0 }), ..frame.clone() };
        assert_eq!(pack(&own, Some(configured), level, &mut halved, &mut buf).unwrap().mount, own.mount);
        assert_eq!(halved, [1, 3, 5, 11, 13, 15]);
        assert_eq!(packed.intrinsics, schemas::Intrinsics { fx: 250.0, fy: 240.0, cx: 160.0, cy: 120.0 });
        let mut decoded = Vec::new();
        schemas::depth_codec::decode(&packed.data, 3, 2, packed.encoding, &mut decoded).unwrap();
        assert_eq!(decoded, [1, 3, 5, 11, 13, 15]);
        // full size: the frame as it is
        let packed = pack(&frame, None, Level { half: false, ..level }, &mut halved, &mut buf).unwrap();
        assert_eq!((packed.width, packed.height, packed.intrinsics), (5, 3, k));
        // a frame whose samples do not fill it is refused, not sliced
        let short = SourceFrame { depth: vec![1; 14], ..frame };
        assert!(pack(&short, None, level, &mut halved, &mut buf).unwrap_err().contains("14 samples for 5x3"));
    }

    #[test]
    fn millimetre_step_becomes_whole_depth_units_without_loosening_the_bound() {
        assert_eq!(WireCodec::BoundedMm(5).encoding_for(0.001), DepthEncoding::Bounded { step: 5 });
        // TUM frames: 0.2 mm per unit -> 25 units of 0.2 mm = 5 mm.
        assert_eq!(WireCodec::BoundedMm(5).encoding_for(0.0002), DepthEncoding::Bounded { step: 25 });
        // A 1 cm unit cannot carry a 5 mm step: one unit, the finest there is.
        assert_eq!(WireCodec::BoundedMm(5).encoding_for(0.01), DepthEncoding::Bounded { step: 1 });
        assert_eq!(WireCodec::Lossless.encoding_for(0.001), DepthEncoding::Lossless);
    }
}
