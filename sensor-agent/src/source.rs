//! Where depth frames come from: the narrow trait every source implements (simulated
//! world, recorded files, a real camera), so the agent loop never knows which it runs.

use schemas::Intrinsics;

pub use sim::frame::{FrameSource, SourceError, SourceFrame};

/// Options shared by every source kind; each uses the ones that apply to it.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceOptions {
    /// Simulated camera profile (`xtion`, `d435`).
    pub camera: String,
    /// Seed of the simulator's random draws.
    pub seed: u64,
    /// Replay speed multiplier (1.0 = real time).
    pub rate: f64,
    /// Start a recording again at its end.
    pub loop_playback: bool,
    /// Metres per depth unit of a plain PNG folder.
    pub depth_scale_m: Option<f32>,
    /// Intrinsics of a plain PNG folder.
    pub intrinsics: Option<Intrinsics>,
    /// Simulate a second camera worn at the chest too (`sim:` only).
    pub chest: bool,
}

impl Default for SourceOptions {
    fn default() -> Self {
        Self {
            camera: "xtion".into(),
            seed: 1,
            rate: 1.0,
            loop_playback: false,
            depth_scale_m: None,
            intrinsics: None,
            chest: false,
        }
    }
}

/// Why a source spec could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The spec has no known `kind:` prefix.
    #[error("unknown source {0:?}: use sim:<world-or-scene-file>, pcd:<file-or-dir>, tum:<dir>, png:<dir> or openni2:[device-uri]")]
    UnknownKind(String),
    /// The simulated camera profile is not known.
    #[error("unknown camera profile {0:?}: use xtion or d435")]
    UnknownCamera(String),
    /// The world or scene file could not be loaded.
    #[error(transparent)]
    Scene(#[from] crate::sim::scene::SceneError),
    /// The recording could not be opened.
    #[error(transparent)]
    Replay(#[from] crate::replay::ReplayError),
    /// The camera could not be opened.
    #[error("camera: {0}")]
    Camera(String),
    /// A chest camera was asked of a source that has none.
    #[error("{0} has no chest camera: only sim: simulates one; a real chest camera runs a sensor agent of its own (--device chest --mount 1.3,10)")]
    NoChest(String),
}

/// Open the source a spec names (`sim:approach`, `pcd:/data/frames/`, ...).
pub fn open(spec: &str, opts: &SourceOptions) -> Result<Box<dyn FrameSource>, OpenError> {
    match spec.split_once(':') {
        Some(("sim", world)) => {
            let camera = crate::sim::camera::CameraProfile::by_name(&opts.camera)
                .ok_or_else(|| OpenError::UnknownCamera(opts.camera.clone()))?;
            let config = crate::sim::SimConfig {
                world: world.to_string(),
                camera,
                seed: opts.seed,
                chest: opts.chest.then(crate::sim::ChestMount::default),
                ..Default::default()
            };
            Ok(Box::new(crate::sim::SimSource::new(config)?))
        }
        _ if opts.chest => Err(OpenError::NoChest(spec.to_string())),
        Some(("pcd" | "tum" | "png", _)) => {
            let replay = crate::replay::ReplayOptions {
                rate: opts.rate,
                loop_playback: opts.loop_playback,
                depth_scale_m: opts.depth_scale_m,
                intrinsics: opts.intrinsics,
                ..Default::default()
            };
            Ok(crate::replay::open_source(spec, &replay)?)
        }
        Some(("openni2", uri)) => open_camera(uri),
        _ => Err(OpenError::UnknownKind(spec.to_string())),
    }
}

#[cfg(feature = "openni2")]
fn open_camera(uri: &str) -> Result<Box<dyn FrameSource>, OpenError> {
    use crate::camera::openni2::{OpenNi2Camera, OpenNi2Options};
    let options = OpenNi2Options { uri: (!uri.is_empty()).then(|| uri.to_string()), ..Default::default() };
    let camera = OpenNi2Camera::open(&options).map_err(|e| {
        let hint = if e.call == "oniDeviceOpen" {
            "; is the camera plugged in (an Xtion or Kinect shows in `lsusb`)? Without one, use a recording \
             (pcd:, tum:, png:) or a simulated world (sim:)"
        } else {
            ""
        };
        OpenError::Camera(format!("{e}{hint}"))
    })?;
    Ok(Box::new(camera))
}

#[cfg(not(feature = "openni2"))]
fn open_camera(_uri: &str) -> Result<Box<dyn FrameSource>, OpenError> {
    Err(OpenError::Camera(
        "this build has no camera driver: rebuild with `cargo build --release -p sensor-agent --features openni2` \
         (needs Debian's libopenni2-dev)"
            .into(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_of_spec_opens_or_says_what_to_use() {
        let opts = SourceOptions::default();
        assert_eq!(open("sim:approach", &opts).unwrap().describe(), "sim:approach");
        let err = open("webcam:0", &opts).err().unwrap().to_string();
        assert!(err.contains("sim:") && err.contains("pcd:"), "{err}");
        let err = open("sim:no-such-world", &opts).err().unwrap().to_string();
        assert!(err.contains("no-such-world"), "{err}");
        // generated worlds go through the same loader
        assert_eq!(open("sim:gen:corridor:7", &opts).unwrap().describe(), "sim:gen:corridor:7");
        let err = open("sim:gen:lobby:x", &opts).err().unwrap().to_string();
        assert!(err.starts_with("gen:lobby:x: seed must be a whole number"), "{err}");
        let bad_camera = SourceOptions { camera: "kinect9".into(), ..SourceOptions::default() };
        assert!(open("sim:approach", &bad_camera).err().unwrap().to_string().contains("kinect9"));
    }

    #[test]
    fn recorded_pcd_frames_come_out_of_the_replay_spec() {
        let file = crate::test_data::real_capture("five_people.pcd");
        let mut source = open(&format!("pcd:{}", file.display()), &SourceOptions::default()).unwrap();
        let frame = source.next_frame(1_000).unwrap().expect("one frame");
        assert_eq!((frame.width, frame.height), (640, 480));
        let valid = frame.depth.iter().filter(|&&d| d > 0).count();
        assert!((230_000..=240_000).contains(&valid), "{valid} valid pixels");
    }

    #[cfg(feature = "openni2")]
    #[test]
    fn openni2_spec_without_a_camera_says_to_plug_one_in_or_use_a_recording() {
        let err = open("openni2:", &SourceOptions::default()).err().unwrap().to_string();
        assert!(
            err.starts_with(
                "camera: OpenNI2 oniDeviceOpen failed (status 1): DeviceOpen using default: no devices found; "
            ),
            "{err}"
        );
        assert!(err.contains("plugged in") && err.contains("pcd:") && err.contains("sim:"), "{err}");
    }

    #[cfg(not(feature = "openni2"))]
    #[test]
    fn camera_spec_without_the_feature_says_how_to_get_it() {
        let err = open("openni2:", &SourceOptions::default()).err().unwrap().to_string();
        assert!(err.contains("--features openni2"), "{err}");
    }
}

/// The failed reads of a device read at each frame beside the camera (an IMU, a
/// barometer): counted, the first and then every 100th logged (a loose cable must not
/// flood the log).
#[derive(Debug, Default)]
pub(crate) struct FailedReads(u64);

impl FailedReads {
    /// One more failed read of `device`, whose frame goes without `lost`.
    pub(crate) fn count(&mut self, device: &str, lost: &str, error: &dyn std::fmt::Display) {
        self.0 += 1;
        if self.0 % 100 == 1 {
            tracing::warn!(device, failed = self.0, "{device} read failed, frame sent without {lost}: {error}");
        }
    }

    /// Reads that failed so far.
    pub(crate) fn get(&self) -> u64 {
        self.0
    }
}
