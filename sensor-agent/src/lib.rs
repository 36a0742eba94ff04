//! wearnav sensor agent: depth frames from a simulated world, recorded files or a real
//! camera, compressed and published with IMU, odometry and (simulated) ground truth.

pub mod barometer;
#[cfg(feature = "openni2")]
pub mod camera;
pub mod formats;
pub mod imu;
pub mod pacing;
pub mod replay;
pub mod run;
pub mod source;

/// The simulated world (its own crate, `sensor-agent/sim`: no bus, built fully optimised
/// for the study's walks while this agent's bus code is not).
pub use sim;
#[cfg(test)]
mod test_data;
