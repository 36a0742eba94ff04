//! The words: turn categories, clock directions and spoken distances. Pure functions of
//! numbers and the profile, so every boundary is tested exactly (`docs/guidance.md`
//! lists them).

use map::GatewayKind;

use crate::profile::{DirectionStyle, DistanceUnits, GuidanceProfile};

/// Which side a turn goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// counter-clockwise seen from above
    Left,
    /// clockwise seen from above
    Right,
}

/// A change of heading sorted into the words a walker hears.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Turn {
    /// below `straight_max_deg`: nothing to announce
    Straight,
    /// "turn slightly left / right"
    Slight(Side),
    /// "turn left / right"
    Normal(Side),
    /// "turn sharply left / right"
    Sharp(Side),
    /// "turn around" (from `sharp_max_deg` to 180 degrees: left or right would mislead)
    Around,
}

impl Turn {
    /// Sorts a turn of `right_deg` degrees (positive clockwise, to the right; negative to
    /// the left; any value, wrapped to (-180, 180]). Each category includes its lower
    /// bound: exactly `straight_max_deg` is already slight, exactly `slight_max_deg` is
    /// already a plain turn, and so on.
    pub fn of(right_deg: f64, p: &GuidanceProfile) -> Self {
        let a = wrap_deg(right_deg);
        let side = if a < 0.0 { Side::Left } else { Side::Right };
        let m = a.abs();
        if m < p.straight_max_deg {
            Turn::Straight
        } else if m < p.slight_max_deg {
            Turn::Slight(side)
        } else if m < p.normal_max_deg {
            Turn::Normal(side)
        } else if m < p.sharp_max_deg {
            Turn::Sharp(side)
        } else {
            Turn::Around
        }
    }
}

/// Wraps degrees to (-180, 180].
pub fn wrap_deg(deg: f64) -> f64 {
    let w = deg.rem_euclid(360.0);
    if w > 180.0 {
        w - 360.0
    } else {
        w
    }
}

/// The clock hour of a direction `right_deg` degrees clockwise from straight ahead:
/// 12 ahead, 3 right, 6 behind, 9 left. Each hour covers 30 degrees centred on it; a
/// direction exactly between two hours (15, 45, ... degrees) goes to the later hour
/// clockwise (15 -> 1 o'clock, -15 -> 12 o'clock).
pub fn clock_hour(right_deg: f64) -> u32 {
    let h = (wrap_deg(right_deg) / 30.0 + 0.5).floor() as i64;
    match h.rem_euclid(12) {
        0 => 12,
        h => h as u32,
    }
}

/// The imperative for a turn: "turn right", "turn slightly left", "turn to 2 o'clock",
/// "go straight on", "turn around".
pub fn turn_phrase(turn: Turn, right_deg: f64, p: &GuidanceProfile) -> String {
    let side = |s: Side| if s == Side::Left { "left" } else { "right" };
    match (turn, p.directions) {
        (Turn::Straight, _) => "go straight on".into(),
        (Turn::Around, _) => "turn around".into(),
        (_, DirectionStyle::Clock) => format!("turn to {} o'clock", clock_hour(right_deg)),
        (Turn::Slight(s), DirectionStyle::Words) => format!("turn slightly {}", side(s)),
        (Turn::Normal(s), DirectionStyle::Words) => format!("turn {}", side(s)),
        (Turn::Sharp(s), DirectionStyle::Words) => format!("turn sharply {}", side(s)),
    }
}

/// Where something is from the user: "ahead", "slightly to your left", "to your right",
/// "sharply to your left", "behind you", or "at 2 o'clock".
pub fn bearing_phrase(right_deg: f64, p: &GuidanceProfile) -> String {
    let turn = Turn::of(right_deg, p);
    let side = |s: Side| if s == Side::Left { "left" } else { "right" };
    match (turn, p.directions) {
        (Turn::Straight, _) => "ahead".into(),
        (Turn::Around, _) => "behind you".into(),
        (_, DirectionStyle::Clock) => format!("at {} o'clock", clock_hour(right_deg)),
        (Turn::Slight(s), DirectionStyle::Words) => format!("slightly to your {}", side(s)),
        (Turn::Normal(s), DirectionStyle::Words) => format!("to your {}", side(s)),
        (Turn::Sharp(s), DirectionStyle::Words) => format!("behind you to the {}", side(s)),
    }
}

/// A distance as spoken: "4 metres", "1 metre", "6 steps". Rounded to what a walker
/// can use: whole units below 20, then to 5 below 100, then to 10; never below 1.
pub fn distance_phrase(distance_m: f64, p: &GuidanceProfile) -> String {
    let (amount, one, many) = match p.units {
        DistanceUnits::Metres => (distance_m, "metre", "metres"),
        DistanceUnits::Steps => (distance_m / p.stride_m.max(0.1), "step", "steps"),
    };
    let n = spoken_count(amount);
    format!("{n} {}", if n == 1 { one } else { many })
}

/// Rounds a count for speech (see [`distance_phrase`]); halves round up.
pub fn spoken_count(amount: f64) -> u64 {
    let a = if amount.is_finite() { amount.max(0.0) } else { 0.0 };
    let to = |q: f64| ((a / q + 0.5).floor() * q) as u64;
    let n = if a < 19.5 {
        to(1.0)
    } else if a < 97.5 {
        to(5.0)
    } else {
        to(10.0)
    };
    n.max(1)
}

/// "elevator", "stairs", "ramp", and the pronoun that goes with it.
pub fn gateway_words(kind: GatewayKind) -> (&'static str, &'static str) {
    match kind {
        GatewayKind::Elevator => ("elevator", "it"),
        GatewayKind::Stairs => ("stairs", "them"),
        GatewayKind::Ramp => ("ramp", "it"),
    }
}

/// First letter upper case (sentences are built from lower-case phrases).
pub fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> GuidanceProfile {
        GuidanceProfile::default()
    }

    #[test]
    fn turn_categories_include_their_lower_bound() {
        let p = p();
        let cases = [
            (0.0, Turn::Straight),
            (19.999, Turn::Straight),
            (20.0, Turn::Slight(Side::Right)),
            (-20.0, Turn::Slight(Side::Left)),
            (59.999, Turn::Slight(Side::Right)),
            (60.0, Turn::Normal(Side::Right)),
            (-90.0, Turn::Normal(Side::Left)),
            (119.999, Turn::Normal(Side::Right)),
            (120.0, Turn::Sharp(Side::Right)),
            (-169.999, Turn::Sharp(Side::Left)),
            (170.0, Turn::Around),
            (-170.0, Turn::Around),
            (180.0, Turn::Around),
            (360.0 + 90.0, Turn::Normal(Side::Right)),
            (270.0, Turn::Normal(Side::Left)),
        ];
        for (deg, want) in cases {
            assert_eq!(Turn::of(deg, &p), want, "{deg} degrees");
        }
    }

    #[test]
    fn clock_hours_split_at_half_hours() {
        let cases = [
            (0.0, 12),
            (14.999, 12),
            (15.0, 1),
            (-15.0, 12),
            (-15.001, 11),
            (60.0, 2),
            (90.0, 3),
            (180.0, 6),
            (-90.0, 9),
            (-60.0, 10),
            (165.0, 6),
            (-165.0, 7),
        ];
        for (deg, want) in cases {
            assert_eq!(clock_hour(deg), want, "{deg} degrees");
        }
    }

    #[test]
    fn phrases_in_words_and_on_the_clock() {
        let words = p();
        let clock = GuidanceProfile { directions: DirectionStyle::Clock, ..p() };
        assert_eq!(turn_phrase(Turn::of(90.0, &words), 90.0, &words), "turn right");
        assert_eq!(turn_phrase(Turn::of(-30.0, &words), -30.0, &words), "turn slightly left");
        assert_eq!(turn_phrase(Turn::of(135.0, &words), 135.0, &words), "turn sharply right");
        assert_eq!(turn_phrase(Turn::of(175.0, &words), 175.0, &words), "turn around");
        assert_eq!(turn_phrase(Turn::of(60.0, &clock), 60.0, &clock), "turn to 2 o'clock");
        assert_eq!(turn_phrase(Turn::of(-90.0, &clock), -90.0, &clock), "turn to 9 o'clock");
        assert_eq!(bearing_phrase(-90.0, &words), "to your left");
        assert_eq!(bearing_phrase(180.0, &words), "behind you");
        assert_eq!(bearing_phrase(45.0, &clock), "at 2 o'clock");
    }

    #[test]
    fn distances_round_to_what_a_walker_can_use() {
        let m = p();
        let steps = GuidanceProfile { units: DistanceUnits::Steps, stride_m: 0.7, ..p() };
        let cases = [
            (0.2, "1 metre"),
            (1.49, "1 metre"),
            (1.5, "2 metres"),
            (4.2, "4 metres"),
            (19.49, "19 metres"),
            (19.5, "20 metres"),
            (22.4, "20 metres"),
            (22.5, "25 metres"),
            (97.4, "95 metres"),
            (97.5, "100 metres"),
            (123.0, "120 metres"),
        ];
        for (d, want) in cases {
            assert_eq!(distance_phrase(d, &m), want, "{d} m");
        }
        assert_eq!(distance_phrase(4.2, &steps), "6 steps");
        assert_eq!(distance_phrase(0.5, &steps), "1 step");
        assert_eq!(distance_phrase(21.0, &steps), "30 steps");
    }
}
