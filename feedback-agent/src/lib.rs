//! wearnav feedback agent: device-neutral intents in, device actions out.
//!
//! The compute agent publishes haptic and speech intents and never knows which devices
//! exist; this agent maps them to whatever backends the configuration names (two Wii
//! remotes or any evdev rumble, espeak-ng or speech-dispatcher, the console), publishes
//! every action on `feedback/applied`, and enforces safety rules 1-3 of ARCHITECTURE.md:
//! it warns when obstacle detection goes offline, stops every rumble when its intent
//! expires, and never lets guidance speech talk over a warning. The phone is a backend
//! through the phone bridge ([`phone`]): its actions are reported when the page confirms
//! them.
//!
//! Pure parts (no bus, no clock): [`haptic_cue`], [`speech_queue`], [`watchdog`],
//! [`wiimote::protocol`], [`speechd::ssip`], [`evdev::ff`]. [`feedback`] joins them to devices; [`run()`] is the bus loop.

pub mod config;
pub mod console;
pub mod device;
pub mod espeak;
pub mod evdev;
pub mod feedback;
pub mod haptic_cue;
pub mod phone;
pub mod run;
pub mod speech_queue;
pub mod speechd;
pub mod watchdog;
pub mod wiimote;

pub use config::{ConfigError, FeedbackConfig, HapticBackend, SpeechBackend};
pub use feedback::{Feedback, StepSettings};
pub use run::{run, run_with, Devices, AGENT};
