//! "Where am I" from the semantic layer (ISANA's tree of areas; Zhang et al.'s door
//! numbers as the landmarks a person can check with a hand on the sign): the innermost
//! area and its parents, then the nearest numbered door within reach.
//! "In the corridor, east wing, near door 214."

use map::SemanticLayer;

use crate::profile::GuidanceProfile;
use crate::utterance::{capitalised, distance_phrase};

/// The answer for a user at (x, y) on `floor`; `near_door_m` bounds "near door N".
pub fn where_am_i(layer: &SemanticLayer, floor: i32, x: f64, y: f64, near_door_m: f64) -> String {
    match place_phrase(layer, floor, x, y, near_door_m) {
        Some(place) => format!("{}.", capitalised(&place)),
        None => format!("On floor {floor}; I have no name for this place."),
    }
}

/// The place at (x, y) on `floor` as the middle of a sentence: "in the corridor, east
/// wing, near door 214", "near door 214"; none where the layer names nothing there.
fn place_phrase(layer: &SemanticLayer, floor: i32, x: f64, y: f64, near_door_m: f64) -> Option<String> {
    let areas: Vec<&str> = layer.areas_at(floor, x, y).iter().map(|a| a.name.as_str()).collect();
    let door = layer
        .doors
        .iter()
        .filter(|d| d.floor == floor)
        .map(|d| ((d.x - x).hypot(d.y - y), d))
        .filter(|(dist, _)| *dist <= near_door_m)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, d)| d.number.as_str());
    let place = areas.split_first().map(|(inner, parents)| {
        let mut s = format!("in {}", with_article(inner));
        for p in parents {
            s.push_str(", ");
            s.push_str(p);
        }
        s
    });
    match (place, door) {
        (Some(place), Some(door)) => Some(format!("{place}, near door {door}")),
        (Some(place), None) => Some(place),
        (None, Some(door)) => Some(format!("near door {door}")),
        (None, None) => None,
    }
}

/// Where the user was last placed (guidance took the place) and how far they have
/// walked since, by the odometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LastKnown {
    /// floor level
    pub floor: i32,
    /// map x, metres
    pub x_m: f64,
    /// map y, metres
    pub y_m: f64,
    /// walked since, metres
    pub walked_m: f64,
}

/// The answer to "where am I" while the place is not known: that it is not, and where
/// the user was last placed when the layer names that place ("Last known: near door
/// 214, 12 metres walked since."): somewhere to ask about or to walk back to.
pub fn not_known(last: Option<&LastKnown>, layer: &SemanticLayer, profile: &GuidanceProfile, floor: i32) -> String {
    let unknown = "Position uncertain: I do not know where you are.";
    let Some(last) = last else { return unknown.to_string() };
    let Some(place) = place_phrase(layer, last.floor, last.x_m, last.y_m, profile.near_door_m) else {
        return unknown.to_string();
    };
    let on_floor = if last.floor == floor { String::new() } else { format!(" on floor {}", last.floor) };
    let walked = distance_phrase(last.walked_m, profile);
    format!("{unknown} Last known: {place}{on_floor}, {walked} walked since.")
}

/// "the corridor", but "room 214" and "Main Hall" as they are: a name with a number or
/// a capital is a proper name.
pub(crate) fn with_article(name: &str) -> String {
    let proper = name.chars().any(|c| c.is_ascii_digit() || c.is_uppercase());
    if proper {
        name.to_string()
    } else {
        format!("the {name}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// An east wing (x 10..30) holding a corridor (y 0..2) and room 214 above it, with
    /// door 214 in the corridor wall; a west wing with no areas inside.
    const LAYER: &str = r#"
[[door]]
number = "214"
x = 12.5
y = 2.0
floor = 2
normal = [0.0, -1.0]

[[door]]
number = "216"
x = 17.5
y = 2.0
floor = 2
normal = [0.0, -1.0]

[[area]]
name = "east wing"
floor = 2
polygon = [[10.0, 0.0], [30.0, 0.0], [30.0, 20.0], [10.0, 20.0]]

[[area]]
name = "corridor"
floor = 2
parent = "east wing"
polygon = [[10.0, 0.0], [30.0, 0.0], [30.0, 2.0], [10.0, 2.0]]

[[area]]
name = "room 214"
floor = 2
parent = "east wing"
polygon = [[11.0, 2.0], [14.0, 2.0], [14.0, 5.0], [11.0, 5.0]]
"#;

    fn layer() -> SemanticLayer {
        SemanticLayer::parse(LAYER, Path::new("east.toml")).unwrap()
    }

    #[test]
    fn names_the_innermost_area_its_parents_and_the_nearest_door() {
        let l = layer();
        assert_eq!(where_am_i(&l, 2, 13.0, 1.0, 3.0), "In the corridor, east wing, near door 214.");
        assert_eq!(where_am_i(&l, 2, 17.0, 1.0, 3.0), "In the corridor, east wing, near door 216.");
        assert_eq!(where_am_i(&l, 2, 12.0, 4.0, 3.0), "In room 214, east wing, near door 214.");
        assert_eq!(where_am_i(&l, 2, 25.0, 1.0, 3.0), "In the corridor, east wing.");
        assert_eq!(where_am_i(&l, 2, 25.0, 15.0, 3.0), "In the east wing.");
        assert_eq!(where_am_i(&l, 2, 9.0, 1.0, 3.0), "On floor 2; I have no name for this place.");
        assert_eq!(where_am_i(&l, 2, 9.9, 2.0, 3.0), "Near door 214.");
        // the same place on another floor is unknown
        assert_eq!(where_am_i(&l, 1, 13.0, 1.0, 3.0), "On floor 1; I have no name for this place.");
    }

    #[test]
    fn not_known_says_where_the_user_was_last_placed_if_it_has_a_name_and_the_floor_if_another() {
        let l = layer();
        let profile = GuidanceProfile { near_door_m: 3.0, ..GuidanceProfile::default() };
        let unknown = "Position uncertain: I do not know where you are.";
        assert_eq!(not_known(None, &l, &profile, 2), unknown);
        let last = LastKnown { floor: 2, x_m: 9.9, y_m: 2.0, walked_m: 23.4 };
        assert_eq!(
            not_known(Some(&last), &l, &profile, 2),
            format!("{unknown} Last known: near door 214, 25 metres walked since.")
        );
        assert_eq!(
            not_known(Some(&last), &l, &profile, 3),
            format!("{unknown} Last known: near door 214 on floor 2, 25 metres walked since.")
        );
        let steps = GuidanceProfile { units: crate::profile::DistanceUnits::Steps, ..profile };
        let inside = LastKnown { floor: 2, x_m: 12.0, y_m: 4.0, walked_m: 0.2 };
        assert!(not_known(Some(&inside), &l, &steps, 2)
            .ends_with(" Last known: in room 214, east wing, near door 214, 1 step walked since."));
        let nameless = LastKnown { floor: 2, x_m: 9.0, y_m: 1.0, walked_m: 5.0 };
        assert_eq!(not_known(Some(&nameless), &l, &profile, 2), unknown);
    }
}
