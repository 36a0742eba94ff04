//! `sensor-agent`: publishes depth frames (simulated, replayed or from a camera) with
//! IMU, odometry and ground truth.

use std::time::Duration;

use anyhow::Context;
use clap::{Parser, ValueEnum};
use schemas::{Intrinsics, MountGuess};
use sensor_agent::run::WireCodec;
use sensor_agent::source::SourceOptions;

/// How depth frames are packed on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Codec {
    /// Exact samples.
    Lossless,
    /// Quantised to --step-mm, each sample within half a step of the truth.
    Bounded,
    /// Uncompressed (614 kB per 640x480 frame: only for a wired link).
    Raw,
}

/// Publish the cane camera's depth frames on the bus, compressed, with IMU,
/// odometry and (simulated sources only) ground truth.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(flatten)]
    bus: bus::BusOptions,
    /// Frame source: `sim:<world>` (approach, taylor-course, open-course, corridor,
    /// building, step-down, sign-ahead, or a scene TOML file), `pcd:<file-or-dir>`,
    /// `tum:<dir>` (TUM RGB-D layout),
    /// `png:<dir>` (16-bit depth PNGs; give --depth-scale and --intrinsics) or
    /// `openni2:[device-uri]` (a real camera; builds with the `openni2` feature only).
    #[arg(long, default_value = "sim:approach")]
    source: String,
    /// Device name in the keys: `wearnav/<user>/sensor/<device>/depth`.
    #[arg(long, default_value = "cane")]
    device: String,
    /// Device name of the simulated phone worn on the body (at the chest; `sim:` sources
    /// only): its IMU on `wearnav/<user>/sensor/<body-device>/imu`, what the compute
    /// agent reads the body's turn rate from (its --body-imu-device), and its compass on
    /// `.../<body-device>/motion` (the compute agent's --compass-device).
    #[arg(long, default_value = "body")]
    body_device: String,
    /// Simulate a second depth camera (the same model) worn at the chest, 1.3 m up and
    /// 10 degrees down, and publish its frames and odometry under this device name
    /// (`sim:` sources only; a real chest camera runs a sensor agent of its own, with
    /// `--device chest --mount 1.3,10`). The compute agent joins its cue to the cane
    /// camera's with its own --chest-device: what overhangs at head height is warned of.
    #[arg(long, value_name = "DEVICE")]
    chest_device: Option<String>,
    /// Depth packing on the wire.
    #[arg(long, value_enum, default_value_t = Codec::Lossless)]
    codec: Codec,
    /// Quantisation step of --codec bounded, millimetres (max error is half of it).
    #[arg(long, default_value_t = 5)]
    step_mm: u16,
    /// Send every frame, full size, at --codec, however slow the link. By default a
    /// frame goes only while fewer than six sent ones wait for the compute agent's
    /// hazard, and on a link too slow for that the frames are halved (every second
    /// pixel of every second row: what the perception samples anyway), quantised in
    /// bounded steps of 10 then 25 mm, and thinned to every 2nd, 3rd or 6th, until
    /// they arrive fresh; finer again, a step at a time, once the link has had room for
    /// 10 s. A slow Wi-Fi gives fewer, coarser frames instead of none
    /// (docs/deployment.md).
    #[arg(long)]
    no_pacing: bool,
    /// Name of the compute agent whose hazards answer the frames (its liveliness
    /// token `health/<name>`; without it every frame goes).
    #[arg(long, default_value = "compute-agent")]
    compute_agent: String,
    /// Simulated camera profile: xtion (Asus Xtion Pro Live, the thesis's) or d435.
    #[arg(long, default_value = "xtion")]
    camera: String,
    /// Seed of the simulator's noise and dropouts.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Replay speed (1 = real time, 2 = twice as fast).
    #[arg(long, default_value_t = 1.0)]
    rate: f64,
    /// Replay the recording again from the start when it ends.
    #[arg(long = "loop")]
    loop_playback: bool,
    /// Metres per depth unit of a png: folder (0.001 for millimetres).
    #[arg(long)]
    depth_scale: Option<f32>,
    /// Intrinsics of a png: folder, `fx,fy,cx,cy` in pixels.
    #[arg(long, value_parser = parse_intrinsics)]
    intrinsics: Option<Intrinsics>,
    /// Where the camera sits on the cane, `HEIGHT,PITCH`: metres above the floor and
    /// degrees below horizontal, sent with every frame of a source that does not know
    /// it (all but `sim:`, whose mount is its own). The compute agent then looks for
    /// the floor within 0.25 m of HEIGHT, so a seat or box top filling the view is never
    /// taken for it; without it, anywhere 0.5-2 m below the camera.
    #[arg(long, value_parser = parse_mount, value_name = "HEIGHT,PITCH")]
    mount: Option<MountGuess>,
    /// An IMU on the cane beside a camera that has none (`openni2:` sources; the Xtion
    /// has no IMU): `mpu6050:/dev/i2c-N[@0x68]`, an InvenSense MPU-6050 on the kernel's
    /// i2c-dev bus. Each frame then carries its sample and gravity (while the cane is
    /// still enough to tell), so the compute agent looks for steps down everywhere.
    /// Untested with hardware: check the axes against a level floor first.
    #[arg(long, value_name = "SPEC")]
    imu: Option<String>,
    /// How the IMU board sits against the camera: the board axis (signed) along the
    /// camera's x (right), y (down) and z (forward), e.g. `-y,-z,x`.
    #[arg(long, value_name = "X,Y,Z", default_value = "x,y,z", requires = "imu", allow_hyphen_values = true)]
    imu_axes: String,
    /// A barometer on the cane board (`openni2:` sources; the simulator has its own):
    /// `bmp388:/dev/i2c-N[@0x77]`, a Bosch BMP388 or BMP390 on the kernel's i2c-dev bus.
    /// Each frame then carries its pressure (`sensor/<device>/pressure`), from which the
    /// compute agent tells when the user reached another floor (on a floor map that
    /// gives each floor's height). Untested with hardware (docs/hardware.md).
    #[arg(long, value_name = "SPEC")]
    barometer: Option<String>,
    /// Health reports the source stalled after this long without a frame.
    #[arg(long, default_value_t = 500, value_name = "MS")]
    stall_after_ms: u64,
}

/// Comma-separated numbers.
fn parse_floats(s: &str) -> Result<Vec<f32>, String> {
    s.split(',').map(|p| p.trim().parse::<f32>().map_err(|e| format!("{p:?}: {e}"))).collect()
}

fn parse_mount(s: &str) -> Result<MountGuess, String> {
    let v = parse_floats(s)?;
    let [height_m, pitch_deg] = v[..] else {
        return Err(format!("expected HEIGHT,PITCH (metres, degrees), got {} numbers", v.len()));
    };
    let mount = MountGuess { height_m, pitch_deg };
    mount.check()?;
    Ok(mount)
}

fn parse_intrinsics(s: &str) -> Result<Intrinsics, String> {
    let v = parse_floats(s)?;
    let [fx, fy, cx, cy] = v[..] else {
        return Err(format!("expected fx,fy,cx,cy, got {} numbers", v.len()));
    };
    let k = Intrinsics { fx, fy, cx, cy };
    if !k.is_valid() {
        return Err(format!("intrinsics {s} are not finite positive focal lengths"));
    }
    Ok(k)
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    bus::logging::init();
    let cli = Cli::parse();
    let options = SourceOptions {
        camera: cli.camera.clone(),
        seed: cli.seed,
        rate: cli.rate,
        loop_playback: cli.loop_playback,
        depth_scale_m: cli.depth_scale,
        intrinsics: cli.intrinsics,
        chest: cli.chest_device.is_some(),
    };
    let mut source = sensor_agent::source::open(&cli.source, &options)
        .with_context(|| format!("cannot open frame source {:?}", cli.source))?;
    if let Some(spec) = &cli.imu {
        if !cli.source.starts_with("openni2:") {
            anyhow::bail!("--imu is for a real camera (openni2:); {:?} brings its own IMU or none", cli.source);
        }
        let axes = sensor_agent::imu::AxisMap::parse(&cli.imu_axes)?;
        let imu = sensor_agent::imu::open(spec).with_context(|| format!("cannot open the IMU {spec:?}"))?;
        tracing::info!(imu = %imu.describe(), axes = %cli.imu_axes, "frames carry the IMU's sample and gravity");
        source = Box::new(sensor_agent::imu::WithImu::new(source, imu, axes));
    }
    if let Some(spec) = &cli.barometer {
        if !cli.source.starts_with("openni2:") {
            anyhow::bail!(
                "--barometer is for a real camera's cane board (openni2:); {:?} brings its own barometer or none",
                cli.source
            );
        }
        let barometer =
            sensor_agent::barometer::open(spec).with_context(|| format!("cannot open the barometer {spec:?}"))?;
        tracing::info!(barometer = %barometer.describe(), "frames carry the barometer's pressure");
        source = Box::new(sensor_agent::barometer::WithBarometer::new(source, barometer));
    }
    let mut config = sensor_agent::run::SensorConfig::new(cli.bus);
    config.device = cli.device;
    config.body_device = cli.body_device;
    config.stall_after = Duration::from_millis(cli.stall_after_ms);
    config.pacing = !cli.no_pacing;
    config.compute_agent = cli.compute_agent;
    config.mount = cli.mount;
    config.chest_device = cli.chest_device;
    config.codec = match cli.codec {
        Codec::Lossless => WireCodec::Lossless,
        Codec::Raw => WireCodec::Raw,
        Codec::Bounded if cli.step_mm == 0 => anyhow::bail!("--step-mm must be at least 1"),
        Codec::Bounded => WireCodec::BoundedMm(cli.step_mm),
    };
    let shutdown = bus::Shutdown::new();
    shutdown.trigger_on_signals();
    sensor_agent::run::run(config, source, shutdown).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mount_is_a_height_and_a_pitch_a_cane_could_give() {
        assert_eq!(parse_mount("0.9,30"), Ok(MountGuess { height_m: 0.9, pitch_deg: 30.0 }));
        assert_eq!(parse_mount(" 1.1 , -5 "), Ok(MountGuess { height_m: 1.1, pitch_deg: -5.0 }));
        for (bad, says) in [
            ("0.9", "expected HEIGHT,PITCH"),
            ("0,30", "not above 0"),
            ("3.5,30", "at most 3"),
            ("nan,30", "not above 0"),
            ("0.9,95", "not within -90 to 90"),
            ("0.9,x", "\"x\""),
        ] {
            let err = parse_mount(bad).unwrap_err();
            assert!(err.contains(says), "{bad}: {err}");
        }
    }
}
