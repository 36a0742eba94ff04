//! wearnav compute agent: the shell around the pure cores (`perception`, and as they
//! arrive localization, planning, guidance): one agent loop ([`run`]) that takes frames,
//! odometry and the body's IMU off the bus, runs them through
//! [`perception::ComputeStep`] and publishes what it gives.

pub mod nav;
pub mod run;
