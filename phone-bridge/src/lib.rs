//! wearnav phone bridge: a small web server for the user's phone. At this stage it
//! serves the start page and a health endpoint that shows which agents are alive and
//! what the obstacle perception last said; the phone app (destination picking, speech,
//! vibration, WebSocket <-> Zenoh) builds on it.

pub mod run;

pub use run::{run, PhoneConfig, AGENT};
