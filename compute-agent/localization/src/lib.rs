//! Localization on the floor map: where the user stands, which way they face, on which
//! floor. Pure: no bus, no runtime, no clock (time comes in as `dt_s`).
//!
//! | what | module | source |
//! | --- | --- | --- |
//! | particle filter: motion, corrections, resampling, adaptive count, recovery, status | [`particle_filter`] | AMCL; Thrun et al. *Probabilistic Robotics* ch. 8; Fox 2003 (KLD) |
//! | odometry + IMU motion model | [`motion`] | AMCL `odom_alpha1..4`; Zhang et al. (IMU limits heading drift) |
//! | likelihood field of a range scan | [`likelihood_field`] | AMCL `likelihood_field` |
//! | door numbers, corners, wall angles | [`landmarks`] | Zhang et al., CCNY |
//! | height from a barometer (floor changes) | [`barometer`] | the barometric formula |
//! | straight walls in a scan (the wall angle) | [`walls`] | split and merge; total least squares |
//! | a floor ready for the filter | [`floor_model`] | |
//! | the filter fed by the agent's streams: body odometry, swept-cane scan, floor confirmed | [`tracker`] | |
//! | CARMEN log reader (real laser + odometry data) | [`carmen`] | CARMEN `FLASER`, `ODOM` |
//! | occupancy grid from scans at known poses | [`mapping`] | ray casting, log-odds (Moravec & Elfes) |
//!
//! ```no_run
//! use localization::{FilterConfig, FloorModel, Observations, OdometryIncrement, ParticleFilter, Pose2};
//! # fn demo(grid: &map::OccupancyGrid, semantic: &map::SemanticLayer, scan: &localization::Scan)
//! #     -> Result<(), localization::LocalizationError> {
//! let floor = FloorModel::new(0, grid, semantic, &Default::default())?;
//! let mut pf = ParticleFilter::new(vec![floor], FilterConfig::default(), 42)?;
//! pf.init_pose(0, Pose2::new(1.0, 2.0, 0.0), 0.3, 0.1)?;
//! let step = OdometryIncrement { forward_m: 0.05, left_m: 0.0, yaw_rad: 0.0, dt_s: 0.033 };
//! let _ = pf.predict(&step, Some(0.0)); // refused input is counted, never applied
//! pf.correct(&Observations { scan: Some(scan), ..Default::default() });
//! let estimate = pf.estimate(); // pose, covariance, status
//! # let _ = estimate; Ok(()) }
//! ```

pub mod barometer;
mod bin_sums;
pub mod carmen;
pub mod corners;
pub mod floor_model;
pub mod landmarks;
pub mod likelihood_field;
pub mod log_run;
pub mod mapping;
pub mod motion;
pub mod particle_filter;
pub mod pose;
pub mod rng;
pub mod scan;
pub mod tracker;
pub mod walls;

pub use barometer::{Barometer, BarometerConfig, BarometerRefused};
pub use corners::{corners_of_grid, corners_of_walls, CornerConfig, CornerField, GridCornerConfig};
pub use floor_model::{dominant_wall_directions, FloorModel};
pub use landmarks::{CompassHeading, Landmark, LandmarkConfig, WallAngle};
pub use likelihood_field::{FreeSpaceConfig, GridPose, GridPoses, LikelihoodField, LikelihoodFieldConfig};
pub use motion::{MotionNoise, OdometryIncrement};
pub use particle_filter::{
    Correction, Counters, Estimate, FilterConfig, Observations, Particle, ParticleFilter, RecoveryAnchor, Rejected,
    Status, CONFIRM_DOOR_M, CONFIRM_PER_WALKED, CONFIRM_WITHIN_M, WALL_CROSSING_LOG_P,
};
pub use pose::{wrap_angle, Pose2};
pub use rng::Rng;
pub use scan::{Beam, Scan};
pub use tracker::{CaneOnBody, CompassRefused, FloorNews, PressureError, Tracker, TrackerConfig, SEARCHED_NEWS};
pub use walls::{longest_wall, wall_segments, WallFitConfig, WallSegment};

/// Why a filter could not be built or started.
#[derive(Debug, thiserror::Error)]
pub enum LocalizationError {
    /// no floor given
    #[error("no floor map given: the filter needs at least one")]
    NoFloors,
    /// two floors with one level
    #[error("floor level {level} given twice")]
    DuplicateFloor {
        /// the level
        level: i32,
    },
    /// more floors than particles can index
    #[error("more than 65535 floors")]
    TooManyFloors,
    /// a floor with nowhere to stand
    #[error(
        "floor {level} has no free cell: check the map's thresholds (free_thresh) and that it is not inverted (negate)"
    )]
    NoFreeSpace {
        /// the level
        level: i32,
    },
    /// a level the filter does not know
    #[error("floor {level} is not one of the filter's floors")]
    UnknownFloor {
        /// the level
        level: i32,
    },
    /// a gateway without a stop on the floor asked for
    #[error("gateway '{gateway}' has no stop on floor {level}")]
    GatewayNotOnFloor {
        /// the gateway's name
        gateway: String,
        /// the level
        level: i32,
    },
    /// a start pose off the floor's free space
    #[error("the start ({x:.2}, {y:.2}) on floor {level} is {why}: give a place the user can stand on")]
    StartNotFree {
        /// the level
        level: i32,
        /// map x, metres
        x: f64,
        /// map y, metres
        y: f64,
        /// "outside the floor map", "not within 0.5 m of free space"
        why: &'static str,
    },
    /// a configuration that cannot work
    #[error("bad localization configuration: {0}")]
    BadConfig(String),
    /// a recorded log that cannot be replayed ([`log_run`])
    #[error("cannot replay the log: {0}")]
    BadLog(String),
}
