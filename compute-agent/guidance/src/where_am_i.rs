//! "Where am I" from the semantic layer (ISANA's tree of areas; Zhang et al.'s door
//! numbers as the landmarks a person can check with a hand on the sign): the innermost
//! area and its parents, then the nearest numbered door within reach.
//! "In the corridor, east wing, near door 214."

use map::SemanticLayer;

/// The answer for a user at (x, y) on `floor`; `near_door_m` bounds "near door N".
pub fn where_am_i(layer: &SemanticLayer, floor: i32, x: f64, y: f64, near_door_m: f64) -> String {
    let areas: Vec<&str> = layer.areas_at(floor, x, y).iter().map(|a| a.name.as_str()).collect();
    let door = layer
        .doors
        .iter()
        .filter(|d| d.floor == floor)
        .map(|d| ((d.x - x).hypot(d.y - y), d))
        .filter(|(dist, _)| *dist <= near_door_m)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, d)| d.number.as_str());
    let place = match areas.split_first() {
        Some((inner, parents)) => {
            let mut s = format!("In {}", with_article(inner));
            for p in parents {
                s.push_str(", ");
                s.push_str(p);
            }
            Some(s)
        }
        None => None,
    };
    match (place, door) {
        (Some(place), Some(door)) => format!("{place}, near door {door}."),
        (Some(place), None) => format!("{place}."),
        (None, Some(door)) => format!("Near door {door}."),
        (None, None) => format!("On floor {floor}; I have no name for this place."),
    }
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
}
