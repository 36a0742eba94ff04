//! The simulated world: scene files, a ray-cast depth camera with the Xtion's error
//! model, a cane-mounted camera carried by a scripted walker, IMU and odometry from the
//! true motion, and `SimSource` (`sim:<world>`) that streams it all as frames.
//!
//! The pieces are usable on their own, which is what the closed-loop virtual user
//! (issue 6) does: load a [`World`] ([`World::start`], [`World::goal`]), place the
//! camera with [`CaneMount::camera_pose`] (or any [`CameraPose`]), call
//! [`Renderer::render`] (then [`Renderer::saw_obstacle`]: was it in view), and count
//! contacts with [`World::nearest_to_body`] and, for the cane from
//! [`CaneMount::cane_segment`], [`World::nearest_to_segment`]. Nothing reads a clock:
//! time is the `t_s` argument, so a course runs as fast as the CPU allows.
//! Camera model from Taylor (2017, sec. 2.1) and Khoshelham & Elberink (2012); see
//! each module.

pub mod barometer;
pub mod body;
pub mod camera;
pub mod cane;
pub mod chest;
pub mod compass;
pub mod frame;
pub mod generate;
pub mod guided;
pub mod imu;
pub mod odometry;
pub mod pose;
pub mod random;
pub mod render;
pub mod scene;
pub mod shape;
pub mod signs;
pub mod source;
pub mod walker;
pub mod world;

pub use camera::CameraProfile;
pub use cane::CaneMount;
pub use chest::ChestMount;
pub use frame::{FrameSource, SourceError, SourceFrame};
pub use guided::{Directions, DirectionsHandle, GuidedWalker};
pub use pose::CameraPose;
pub use random::SimRng;
pub use render::Renderer;
pub use scene::SceneError;
pub use signs::{DoorSignReader, SignReaderConfig, SignReading};
pub use source::{SimConfig, SimSource};
pub use walker::{Ride, ScriptedWalker, Trajectory};
pub use world::{Nearest, ObstacleId, ObstacleKind, UserPose, World};
