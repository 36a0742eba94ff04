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

/// A user's guidance preferences. As a file (`compute-agent --guidance-profile`): TOML
/// with any of these fields, the rest keeping their defaults ([`GuidanceProfile::from_toml`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
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
    /// asked to stop and turn on the spot, and the position still not found this long
    /// after, ms: the user is asked to stop turning, and to tell a door number or ask
    /// someone nearby (in the spoken guide's 120 generated walks no turning on the spot
    /// that found the place lasted more than 10 s, and users in 11 walks, on streets and
    /// in a lobby, turned until the walk ended; default 25000, two full turns at a slow
    /// pace: our choice; docs/guidance.md, "When turning does not find the place")
    pub search_for_ms: u64,
    /// "Passing door 214, on your left." as the user comes level with a numbered door
    /// beside the route (Zhang et al.: door numbers are the landmarks a user can check
    /// with a hand on the sign; a sign that says otherwise is told to the device with
    /// the door command). Never said where it could hold back a turn, a gateway or the
    /// goal, and never holds back anything itself (default true)
    pub passing_doors: bool,
    /// a door counts as beside the route when it is this far from it at most, metres
    /// (default 2.5: our choice, the widest generated corridor's doors seen from its
    /// far side)
    pub passing_door_m: f64,
    /// at most one door said per this many metres walked (default 10: our choice; the
    /// doors of a corridor are 3-6 m apart)
    pub passing_door_every_m: f64,
    /// "Entering the stair hall." as the user enters a named area of the map on the
    /// way (ISANA's areas; a place the user can tell from its sound and size), once a
    /// trip per area, under the rules of a door in passing (default true)
    pub passing_areas: bool,
}

/// A guidance profile that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProfileError {
    /// Not TOML, a field the profile does not have (a misspelt one would be ignored
    /// otherwise), or a value of the wrong type.
    #[error("{0}")]
    Syntax(String),
    /// A value outside what guidance works with.
    #[error("{field} = {value}: {rule}")]
    OutOfRange {
        /// the field's name
        field: &'static str,
        /// the value given
        value: String,
        /// what it must be
        rule: String,
    },
}

impl GuidanceProfile {
    /// How far the user walks during the spacing between spontaneous instructions, at
    /// the assumed walking speed, metres (3 m by default).
    pub fn spacing_walk_m(&self) -> f64 {
        self.walking_speed_mps * self.min_spacing_ms as f64 / 1000.0
    }

    /// A profile from TOML: the fields given, the defaults for the rest; an unknown
    /// field or a value out of range is refused with the field's name.
    ///
    /// ```
    /// use guidance::{DirectionStyle, GuidanceProfile};
    /// let p = GuidanceProfile::from_toml("directions = \"clock\"\npassing_doors = false\n").unwrap();
    /// assert_eq!(p.directions, DirectionStyle::Clock);
    /// assert!(GuidanceProfile::from_toml("direction = \"clock\"\n").is_err());
    /// ```
    pub fn from_toml(text: &str) -> Result<Self, ProfileError> {
        let p: Self = toml::from_str(text).map_err(|e| ProfileError::Syntax(e.to_string().trim().to_string()))?;
        p.validate()?;
        Ok(p)
    }

    /// Checks every value against what guidance works with: lengths and times finite
    /// and positive, the hysteresis and the announcement ordered (a user never back on
    /// the route, a turn announced after its "now"), the turn categories ascending.
    pub fn validate(&self) -> Result<(), ProfileError> {
        let within = |field: &'static str, v: f64, lo: f64, hi: f64| {
            if v.is_finite() && lo < v && v <= hi {
                Ok(())
            } else {
                Err(ProfileError::OutOfRange {
                    field,
                    value: v.to_string(),
                    rule: format!("must be above {lo} and at most {hi}"),
                })
            }
        };
        let ms = |field: &'static str, v: u64, lo: u64, hi: u64| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(ProfileError::OutOfRange {
                    field,
                    value: v.to_string(),
                    rule: format!("must be from {lo} to {hi}"),
                })
            }
        };
        within("stride_m", self.stride_m, 0.1, 2.0)?;
        ms("min_spacing_ms", self.min_spacing_ms, 0, 30_000)?;
        within("turn_now_m", self.turn_now_m, 0.0, 10.0)?;
        within("announce_turn_m", self.announce_turn_m, self.turn_now_m, 50.0)?;
        within("walking_speed_mps", self.walking_speed_mps, 0.0, 3.0)?;
        within("arrival_radius_m", self.arrival_radius_m, 0.0, 5.0)?;
        within("on_route_m", self.on_route_m, 0.0, 20.0)?;
        within("off_route_m", self.off_route_m, self.on_route_m, 20.0)?;
        within("rejoin_radius_m", self.rejoin_radius_m, 0.0, 50.0)?;
        ms("deviation_repeat_ms", self.deviation_repeat_ms, 1000, 600_000)?;
        within("near_door_m", self.near_door_m, 0.0, 20.0)?;
        // "straight on" may be nothing (every bend a turn), the categories above it not
        if !(self.straight_max_deg.is_finite() && (0.0..180.0).contains(&self.straight_max_deg)) {
            return Err(ProfileError::OutOfRange {
                field: "straight_max_deg",
                value: self.straight_max_deg.to_string(),
                rule: "must be from 0 to below 180".into(),
            });
        }
        within("slight_max_deg", self.slight_max_deg, self.straight_max_deg, 180.0)?;
        within("normal_max_deg", self.normal_max_deg, self.slight_max_deg, 180.0)?;
        within("sharp_max_deg", self.sharp_max_deg, self.normal_max_deg, 180.0)?;
        within("still_max_deg_s", self.still_max_deg_s, 0.0, 360.0)?;
        ms("stop_when_uncertain_ms", self.stop_when_uncertain_ms, 1000, 3_600_000)?;
        ms("search_for_ms", self.search_for_ms, 1000, 3_600_000)?;
        within("passing_door_m", self.passing_door_m, crate::guide::PASSING_MIN_M, 10.0)?;
        within("passing_door_every_m", self.passing_door_every_m, 0.0, 1000.0)?;
        Ok(())
    }
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
            search_for_ms: 25_000,
            passing_doors: true,
            passing_door_m: 2.5,
            passing_door_every_m: 10.0,
            passing_areas: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(text: &str) -> String {
        match GuidanceProfile::from_toml(text) {
            Ok(p) => panic!("{text:?} was taken: {p:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn a_file_sets_what_it_names_and_leaves_the_defaults_for_the_rest() {
        let p = GuidanceProfile::from_toml(
            "directions = \"clock\"\nunits = \"steps\"\nstride_m = 0.65\npassing_doors = false\n",
        )
        .unwrap();
        let expect = GuidanceProfile {
            directions: DirectionStyle::Clock,
            units: DistanceUnits::Steps,
            stride_m: 0.65,
            passing_doors: false,
            ..GuidanceProfile::default()
        };
        assert_eq!(p, expect);
        assert_eq!(GuidanceProfile::from_toml("").unwrap(), GuidanceProfile::default());
        assert!(GuidanceProfile::default().validate().is_ok());
    }

    #[test]
    fn a_misspelt_field_a_wrong_type_or_a_value_out_of_range_is_refused_with_its_name() {
        let e = refused("directons = \"clock\"\n");
        assert!(e.contains("directons"), "{e}");
        let e = refused("directions = \"compass\"\n");
        assert!(e.contains("compass"), "{e}");
        let e = refused("min_spacing_ms = \"3 s\"\n");
        assert!(e.contains("min_spacing_ms"), "{e}");
        assert_eq!(refused("stride_m = 0.0\n"), "stride_m = 0: must be above 0.1 and at most 2");
        assert_eq!(refused("arrival_radius_m = nan\n"), "arrival_radius_m = NaN: must be above 0 and at most 5");
        // a turn announced after its "now"; a user never back on the route
        assert_eq!(refused("announce_turn_m = 1.0\n"), "announce_turn_m = 1: must be above 1.5 and at most 50");
        assert_eq!(refused("on_route_m = 2.0\n"), "off_route_m = 1.5: must be above 2 and at most 20");
        // the turn categories ascend
        assert_eq!(refused("slight_max_deg = 130\n"), "normal_max_deg = 120: must be above 130 and at most 180");
        assert_eq!(refused("straight_max_deg = -5\n"), "straight_max_deg = -5: must be from 0 to below 180");
        assert_eq!(refused("deviation_repeat_ms = 0\n"), "deviation_repeat_ms = 0: must be from 1000 to 600000");
        assert_eq!(refused("passing_door_m = 0.3\n"), "passing_door_m = 0.3: must be above 0.4 and at most 10");
    }
}
