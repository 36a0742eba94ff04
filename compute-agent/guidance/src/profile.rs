//! How a user wants to be guided: units, direction words, pacing and the thresholds
//! that sort turns into words. Defaults and where they come from are in
//! `docs/guidance.md`; every one not taken from a paper is our choice, marked so.

use serde::{Deserialize, Serialize};

/// How distances are spoken.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DistanceUnits {
    /// "in 4 metres"
    Metres,
    /// "in 6 steps", from the profile's stride length
    Steps,
}

/// How directions are spoken.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DirectionStyle {
    /// "turn slightly left", "turn right", "turn sharply right", "turn around"
    Words,
    /// "turn to 2 o'clock" (12 is straight ahead, clockwise as on a watch face)
    Clock,
}

/// A user's guidance preferences.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GuidanceProfile {
    /// metres or steps (default metres)
    pub units: DistanceUnits,
    /// one step, metres, for [`DistanceUnits::Steps`] (default 0.7: our choice, an adult
    /// walking step; measure the user's own)
    pub stride_m: f64,
    /// left/right words or clock directions (default words)
    pub directions: DirectionStyle,
    /// no two spontaneous instructions closer than this, ms; arrival is exempt, and so
    /// are answers the user asked for (default 3000: our choice)
    pub min_spacing_ms: u64,
    /// a turn or a gateway is announced when it is this far ahead along the route,
    /// metres (default 6: our choice, about 5 s of walking)
    pub announce_turn_m: f64,
    /// "turn right now" when the turn is this close, metres (default 1.5: our choice,
    /// two steps, so the user turns at the corner and not past it)
    pub turn_now_m: f64,
    /// assumed walking speed, m/s: an announcement that would leave less than
    /// `min_spacing_ms` of walking before "now" is skipped, "now" alone is said
    /// (default 1.0: our choice, a cautious pace with a cane)
    pub walking_speed_mps: f64,
    /// "you have arrived" within this distance of the goal, metres (default 0.5: a
    /// guided walk must end within 1 m of the place, issue 31; said at 1 m, the
    /// simulated user, stopping as told, stood 0.85-0.97 m from it over six seeds,
    /// a localization error away from missing)
    pub arrival_radius_m: f64,
    /// off the route when farther than this from the route's segment, metres
    /// (default 1.5: our choice, wider than a corridor's half-width plus drift)
    pub off_route_m: f64,
    /// back on the route when nearer than this again, metres (hysteresis; default 1.0)
    pub on_route_m: f64,
    /// how far [`planning::Route::rejoin`] looks for the route, metres; beyond it, a
    /// replan is requested (default 4.0: our choice)
    pub rejoin_radius_m: f64,
    /// a deviation prompt or replan request is said again after this long if the user
    /// is still off the route, ms (default 8000: our choice)
    pub deviation_repeat_ms: u64,
    /// "near door 214" when a numbered door is this close, metres (default 3.0)
    pub near_door_m: f64,
    /// the device has a vibrator: ask for a short vibration before each spontaneous
    /// instruction (default true)
    pub vibrate_before: bool,
    /// a bend smaller than this (degrees, either side) is "straight on": no turn is
    /// announced (default 20: our choice)
    pub straight_max_deg: f64,
    /// from `straight_max_deg` up to this, "slightly" (default 60: our choice)
    pub slight_max_deg: f64,
    /// from `slight_max_deg` up to this, a plain turn (default 120: our choice)
    pub normal_max_deg: f64,
    /// from `normal_max_deg` up to this, "sharply"; from here to 180, "turn around"
    /// (default 170: our choice)
    pub sharp_max_deg: f64,
    /// a direction relative to where the user faces (the route's start, back on the
    /// route, off the route) waits while the heading turns faster than this, degrees a
    /// second over the last second: said as the user turns, it is wrong by the time it
    /// is heard (default 15: our choice; a user turning on the spot for the device to
    /// find them turns about 30, a walker's sway stays under 10)
    pub still_max_deg_s: f64,
    /// guidance without a place for this long, ms, and the user is asked to stop and
    /// turn slowly on the spot until the position is found (told "position lost: walk
    /// on slowly while I look for it", a user who is never told more walks on away from
    /// the route: 258-290 m in eight of the spoken guide's 120 generated walks; default
    /// 60000: at 30000 walkers were stopped a few metres before walking on found their
    /// place again; docs/guidance.md, "Walking on untold")
    pub stop_when_uncertain_ms: u64,
}

impl Default for GuidanceProfile {
    fn default() -> Self {
        Self {
            units: DistanceUnits::Metres,
            stride_m: 0.7,
            directions: DirectionStyle::Words,
            min_spacing_ms: 3000,
            announce_turn_m: 6.0,
            turn_now_m: 1.5,
            walking_speed_mps: 1.0,
            arrival_radius_m: 0.5,
            off_route_m: 1.5,
            on_route_m: 1.0,
            rejoin_radius_m: 4.0,
            deviation_repeat_ms: 8000,
            near_door_m: 3.0,
            vibrate_before: true,
            straight_max_deg: 20.0,
            slight_max_deg: 60.0,
            normal_max_deg: 120.0,
            sharp_max_deg: 170.0,
            still_max_deg_s: 15.0,
            stop_when_uncertain_ms: 60_000,
        }
    }
}
