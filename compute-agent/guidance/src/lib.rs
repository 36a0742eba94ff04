//! Spoken route guidance for a blind walker: pure, no bus, no runtime, no clock (time is
//! an argument). From a planned route (one floor or the legs of a building route), the
//! user's pose and a [`GuidanceProfile`], a [`Guide`] gives at most one [`Instruction`]
//! per step; each becomes a [`schemas::SpeechIntent`] at `Message` priority, so obstacle
//! warnings (`Important`) always pre-empt it.
//!
//! | what | module | source |
//! | --- | --- | --- |
//! | turn categories, clock directions, spoken distances | [`utterance`] | our thresholds; clock face as in O&M practice and Wayfindr |
//! | the step: turns, gateways, arrival, deviation, spacing, uncertainty | [`guide`] | ISANA (deviation recovery, gateways, speech priorities) |
//! | "where am I" | [`where_am_i`] | ISANA (area tree); Zhang et al. (door numbers) |
//! | what goes to the feedback agent | [`instruction`] | ARCHITECTURE.md safety rule 3 |
//! | commands, planning, replanning, route state | [`navigator`] | ISANA (floor confirmed by the user) |
//! | what the camera finds that the plan lacks, on the planner: ways round it | [`perceived`] | ISANA (obstacle-driven node removal) |
//! | the way ahead for the predictive cue | [`way`] | ours (`docs/predictive-cue.md`) |
//!
//! Wording rules, thresholds and where each comes from: `docs/guidance.md`.

pub mod guide;
pub mod instruction;
pub mod navigator;
pub mod perceived;
pub mod profile;
pub mod utterance;
pub mod way;
pub mod where_am_i;

pub use guide::{Ahead, Barometer, Guide, UserPose};
pub use instruction::{Instruction, InstructionKind};
pub use navigator::{Navigator, Response};
pub use profile::{DirectionStyle, DistanceUnits, GuidanceProfile, ProfileError};
pub use utterance::{Side, Turn};
pub use way::way_ahead;
