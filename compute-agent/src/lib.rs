//! wearnav compute agent: obstacle perception (Taylor 2017 and beyond), later
//! localization and route planning, as pure libraries plus one agent loop (`run`).

pub mod body_rate;
pub mod perception;
pub mod run;
