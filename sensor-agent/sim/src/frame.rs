//! The contract between a source of depth frames and the agent loop: the frame a
//! source delivers, why it could not, and the narrow trait every source implements
//! (the simulator here, recorded files and real cameras in the sensor agent). It lives
//! with the simulator so that what walks simulated frames (the study) needs no bus.

use schemas::{GroundTruth, ImuSample, Intrinsics, MountGuess, OdomIncrement, PhoneMotion, Pressure};

/// One captured depth frame with whatever motion data came with it, uncompressed.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceFrame {
    /// Capture time, ns since the Unix epoch (sources that replay files re-stamp them).
    pub stamp_ns: u64,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Metres per depth unit.
    pub depth_scale_m: f32,
    /// Pinhole intrinsics.
    pub intrinsics: Intrinsics,
    /// Row-major depth samples, 0 = invalid.
    pub depth: Vec<u16>,
    /// Gravity direction in the camera frame (unit, towards the floor), when known.
    pub gravity_camera: Option<[f32; 3]>,
    /// Mounting guess.
    pub mount: Option<MountGuess>,
    /// IMU samples since the previous frame.
    pub imu: Vec<ImuSample>,
    /// Samples of an IMU worn on the body since the previous frame (the simulator's
    /// stand-in for a phone; real body-worn devices publish their own).
    pub body_imu: Vec<ImuSample>,
    /// The body-worn phone's compass and steps, when a reading is due (the simulator's;
    /// a real phone's come through the phone bridge).
    pub motion: Option<PhoneMotion>,
    /// The barometer's reading at this frame (the simulator's cane board; a real one's
    /// is read by the sensor agent, `--barometer`).
    pub pressure: Option<Pressure>,
    /// Odometry since the previous frame.
    pub odom: Option<OdomIncrement>,
    /// Ground truth (simulated sources only).
    pub truth: Option<GroundTruth>,
    /// The frame of a second camera worn at the chest, captured at the same moment
    /// (the simulator's, with `SourceOptions::chest`; a real chest camera runs a sensor
    /// agent of its own): its depth, gravity, mount guess and odometry; no IMU, no truth.
    pub chest: Option<Box<SourceFrame>>,
}

impl SourceFrame {
    /// A frame of depth alone: no gravity, mount guess, IMU, odometry, truth or chest
    /// camera (a camera without IMU, a recording of depth images).
    pub fn depth_only(
        stamp_ns: u64,
        (width, height): (u32, u32),
        depth_scale_m: f32,
        intrinsics: Intrinsics,
        depth: Vec<u16>,
    ) -> Self {
        Self {
            stamp_ns,
            width,
            height,
            depth_scale_m,
            intrinsics,
            depth,
            gravity_camera: None,
            mount: None,
            imu: Vec::new(),
            body_imu: Vec::new(),
            motion: None,
            pressure: None,
            odom: None,
            truth: None,
            chest: None,
        }
    }
}

/// Why a source could not deliver a frame. `Skipped` is not fatal: the stream goes on.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// One input (file, frame) was unusable; the source has moved past it.
    #[error("skipped {what}: {reason}")]
    Skipped {
        /// What was skipped (a file name, a frame number).
        what: String,
        /// Why.
        reason: String,
    },
    /// The source cannot go on (device gone, folder removed).
    #[error("source failed: {0}")]
    Fatal(String),
}

/// A stream of depth frames. `next_frame` is called at the source's own pace: it
/// returns the capture stamp it wants the frame published at, and the agent loop
/// sleeps until then (simulated and replayed sources), or returns as soon as a frame
/// is ready (cameras).
pub trait FrameSource: Send {
    /// Short description for logs and health (`sim:taylor-course`, `pcd:/data/x.pcd`).
    fn describe(&self) -> String;
    /// The next frame, `Ok(None)` at the end of a finite recording.
    fn next_frame(&mut self, now_ns: u64) -> Result<Option<SourceFrame>, SourceError>;
    /// Nominal frame period, ns, for pacing (0 = as fast as frames come).
    fn period_ns(&self) -> u64;
}
