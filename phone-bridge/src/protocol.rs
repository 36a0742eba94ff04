//! The WebSocket messages between the phone page and the bridge (docs/phone.md), and
//! their mapping to and from the wire schemas. Pure: no socket, no bus, no clock.

use schemas::{
    Command, Destinations, GroundState, Hazard, LocalizationStatus, PhoneEvent, PhoneHaptic, PhoneSpeech, Pose,
    Priority, RouteState, RouteStatus, Rumble,
};
use serde::Serialize;
use serde_json::Value;

use crate::monitor::{Stream, StreamSet};

/// Largest WebSocket message the bridge reads, bytes.
pub const MAX_MESSAGE_BYTES: usize = 16 * 1024;
/// Longest destination label a command may carry, characters.
pub const MAX_LABEL_CHARS: usize = 200;

/// A destination as the page lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DestinationView {
    /// What the user picks or says.
    pub label: String,
    /// Floor it is on.
    pub floor: i32,
}

/// What the bridge sends the page.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum ToPage {
    /// First message on a socket.
    Hello {
        /// The user this bridge serves.
        user: String,
    },
    /// Every place guidance can take the user to.
    Destinations {
        /// Sorted as the planner gave them.
        destinations: Vec<DestinationView>,
    },
    /// Where guidance stands.
    Route {
        /// `idle`, `waiting-for-position`, `guiding`, `waiting-for-floor`, `arrived`,
        /// `unreachable`.
        status: &'static str,
        /// The destination, if any.
        destination: Option<String>,
        /// Metres left, while guiding.
        distance_m: Option<f32>,
        /// The instruction last given.
        instruction: String,
        /// The floor of the next waypoint (the user's when idle).
        floor: i32,
    },
    /// How far the position is known.
    Position {
        /// `tracking`, `found` (tracking a place a search found that the user has not
        /// confirmed: route guidance does not take it), `followed` (converging, and route
        /// guidance takes the place: it is followed from a known one), `converging`,
        /// `lost`.
        status: &'static str,
        /// Floor.
        floor: i32,
    },
    /// The obstacle cue in force.
    Obstacle {
        /// `none`, `left`, `right`, `both`.
        rumble: &'static str,
        /// `found`, `lost`, `degraded`.
        ground: &'static str,
    },
    /// Agents whose liveliness token is present.
    Agents {
        /// Names.
        alive: Vec<String>,
    },
    /// Vibrate this `navigator.vibrate` pattern and acknowledge it.
    Vibrate {
        /// Request id.
        id: u64,
        /// On, off, on... ms; `[0]` stops.
        pattern: Vec<u32>,
    },
    /// Say this and acknowledge start and end.
    Say {
        /// Request id.
        id: u64,
        /// The words.
        text: String,
        /// `important`, `message`, `text`, `notification`, `progress`.
        priority: &'static str,
        /// Cut off what the page says first.
        interrupt: bool,
    },
    /// Stop saying the utterance `id`.
    Cut {
        /// Request id of the `say`.
        id: u64,
    },
    /// The bridge's clock, ms since the epoch; the page answers at once. Also the
    /// heartbeat (every second).
    Clock {
        /// Bridge wall clock, ms.
        t: f64,
    },
    /// Something the page sent was refused, or a command failed.
    Error {
        /// What to show and say.
        message: String,
    },
}

/// What the page sends the bridge.
#[derive(Debug, Clone, PartialEq)]
pub enum FromPage {
    /// A user command for the compute (or feedback) agent.
    Command(Command),
    /// What the page did with a request, at page time `t_ms`.
    Ack {
        /// Request id.
        id: u64,
        /// What happened.
        event: PhoneEvent,
        /// Page wall clock, ms since the epoch.
        t_ms: f64,
    },
    /// Answer to a `clock`.
    Clock {
        /// The bridge's `t`, echoed.
        t_ms: f64,
        /// The page's wall clock when it answered, ms.
        page_t_ms: f64,
    },
    /// Compass heading.
    Heading {
        /// Degrees clockwise from magnetic north.
        deg: f32,
        /// Accuracy, degrees.
        accuracy_deg: Option<f32>,
    },
    /// Steps since the page loaded.
    Steps {
        /// Count.
        count: u64,
    },
    /// Send the destination list again.
    Destinations,
    /// Send this socket the monitor's streams too (none: only the phone's).
    Subscribe(StreamSet),
}

/// Why a page message was refused: a short `kind` for the health counters and a
/// sentence for the page.
#[derive(Debug, Clone, PartialEq)]
pub struct Refusal {
    /// Counter name (`bad_json`, `unknown_type`, `bad_field`, `unknown_verb`).
    pub kind: &'static str,
    /// What the page shows.
    pub message: String,
}

fn refuse(kind: &'static str, message: impl Into<String>) -> Refusal {
    Refusal { kind, message: message.into() }
}

fn field<'v>(v: &'v Value, name: &str, what: &str) -> Result<&'v Value, Refusal> {
    v.get(name).ok_or_else(|| refuse("bad_field", format!("{what} needs \"{name}\"")))
}

fn number(v: &Value, name: &str, what: &str) -> Result<f64, Refusal> {
    field(v, name, what)?
        .as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| refuse("bad_field", format!("{what}: \"{name}\" must be a number")))
}

fn count(v: &Value, name: &str, what: &str) -> Result<u64, Refusal> {
    field(v, name, what)?
        .as_u64()
        .ok_or_else(|| refuse("bad_field", format!("{what}: \"{name}\" must be a whole number, 0 or more")))
}

/// Read one text frame from the page.
pub fn parse(text: &str) -> Result<FromPage, Refusal> {
    let v: Value = serde_json::from_str(text).map_err(|e| refuse("bad_json", format!("not JSON: {e}")))?;
    let kind = v.get("type").and_then(Value::as_str).ok_or_else(|| {
        refuse(
            "bad_field",
            "every message needs a \"type\" (command, ack, clock, heading, steps, destinations, subscribe)",
        )
    })?;
    match kind {
        "command" => parse_command(&v).map(FromPage::Command),
        "ack" => {
            let id = count(&v, "id", "ack")?;
            let t_ms = number(&v, "t", "ack")?;
            let event = match field(&v, "event", "ack")?.as_str() {
                Some("vibrated") => PhoneEvent::Vibrated,
                Some("started") => PhoneEvent::Started,
                Some("ended") => PhoneEvent::Ended,
                Some("interrupted") => PhoneEvent::Interrupted,
                Some("failed") => {
                    let reason = v.get("reason").and_then(Value::as_str).unwrap_or("no reason given");
                    PhoneEvent::Failed { reason: reason.chars().take(200).collect() }
                }
                _ => {
                    return Err(refuse(
                        "bad_field",
                        "ack: \"event\" must be vibrated, started, ended, interrupted or failed",
                    ))
                }
            };
            Ok(FromPage::Ack { id, event, t_ms })
        }
        "clock" => Ok(FromPage::Clock { t_ms: number(&v, "t", "clock")?, page_t_ms: number(&v, "page_t", "clock")? }),
        "heading" => {
            let deg = number(&v, "deg", "heading")?;
            if !(0.0..=360.0).contains(&deg) {
                return Err(refuse("bad_field", format!("heading: {deg} is not within 0..360 degrees")));
            }
            let accuracy_deg = match v.get("accuracy_deg") {
                None | Some(Value::Null) => None,
                Some(a) => Some(
                    a.as_f64()
                        .filter(|a| a.is_finite() && *a >= 0.0)
                        .ok_or_else(|| refuse("bad_field", "heading: \"accuracy_deg\" must be a positive number"))?
                        as f32,
                ),
            };
            Ok(FromPage::Heading { deg: deg as f32, accuracy_deg })
        }
        "steps" => Ok(FromPage::Steps { count: count(&v, "count", "steps")? }),
        "destinations" => Ok(FromPage::Destinations),
        "subscribe" => parse_subscribe(&v).map(FromPage::Subscribe),
        other => Err(refuse(
            "unknown_type",
            format!("unknown message type {other:?} (command, ack, clock, heading, steps, destinations, subscribe)"),
        )),
    }
}

/// A command's text field, trimmed: refused with `missing` when absent or blank, and
/// as "`what` is at most N characters" when longer than `max_chars`, and when it has
/// control characters (the bus refuses them in a door number or a place's name).
fn text_field(v: &Value, name: &str, missing: &str, what: &str, max_chars: usize) -> Result<String, Refusal> {
    let text = v
        .get(name)
        .and_then(Value::as_str)
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .ok_or_else(|| refuse("bad_field", missing))?;
    if text.chars().count() > max_chars {
        return Err(refuse("bad_field", format!("{what} is at most {max_chars} characters")));
    }
    if text.chars().any(char::is_control) {
        return Err(refuse("bad_field", format!("{what} has control characters")));
    }
    Ok(text.to_string())
}

fn parse_command(v: &Value) -> Result<Command, Refusal> {
    let verb = v.get("verb").and_then(Value::as_str).ok_or_else(|| refuse("bad_field", "command needs a \"verb\""))?;
    match verb {
        "destination" => {
            let missing = "destination needs a \"label\": the place to go to";
            let label = text_field(v, "label", missing, "a destination name", MAX_LABEL_CHARS)?;
            Ok(Command::Destination { label })
        }
        "door" => {
            let missing = "door needs a \"number\": the number on the door's sign";
            let number = text_field(v, "number", missing, "a door number", schemas::wire::MAX_DOOR_NUMBER_CHARS)?;
            Ok(Command::Door { number })
        }
        "place" => {
            let missing = "place needs a \"label\": the name of the place you are at";
            let label = text_field(v, "label", missing, "a place name", schemas::wire::MAX_PLACE_LABEL_CHARS)?;
            Ok(Command::Place { label })
        }
        "where-am-i" => Ok(Command::WhereAmI),
        "repeat" => Ok(Command::Repeat),
        "cancel" => Ok(Command::Cancel),
        "mute" => {
            let muted = v
                .get("muted")
                .and_then(Value::as_bool)
                .ok_or_else(|| refuse("bad_field", "mute needs \"muted\": true or false"))?;
            Ok(Command::Mute { muted })
        }
        other => Err(refuse(
            "unknown_verb",
            format!("unknown command {other:?} (destination, where-am-i, door, place, repeat, cancel, mute)"),
        )),
    }
}

fn parse_subscribe(v: &Value) -> Result<StreamSet, Refusal> {
    let names = field(v, "streams", "subscribe")?.as_array().ok_or_else(|| {
        refuse("bad_field", format!("subscribe: \"streams\" must be a list of names ({})", Stream::names()))
    })?;
    let mut streams = Vec::with_capacity(names.len());
    for name in names {
        let stream = name.as_str().and_then(Stream::from_name).ok_or_else(|| {
            refuse("bad_field", format!("subscribe: unknown stream {name} (the streams are {})", Stream::names()))
        })?;
        streams.push(stream);
    }
    Ok(StreamSet::of(&streams))
}

/// The page's name of a priority.
pub fn priority_name(p: Priority) -> &'static str {
    match p {
        Priority::Important => "important",
        Priority::Message => "message",
        Priority::Text => "text",
        Priority::Notification => "notification",
        Priority::Progress => "progress",
    }
}

/// A vibration request for the page.
pub fn vibrate(h: &PhoneHaptic) -> ToPage {
    ToPage::Vibrate { id: h.id, pattern: h.pattern_ms.clone() }
}

/// A speech request for the page.
pub fn speech(s: &PhoneSpeech) -> ToPage {
    match s {
        PhoneSpeech::Say { id, text, priority, interrupt } => {
            ToPage::Say { id: *id, text: text.clone(), priority: priority_name(*priority), interrupt: *interrupt }
        }
        PhoneSpeech::Cut { id } => ToPage::Cut { id: *id },
    }
}

/// The route state as the page shows it; `None` for a preview (not being followed).
pub fn route(r: &RouteState) -> Option<ToPage> {
    let status = match r.status {
        RouteStatus::Idle => "idle",
        RouteStatus::WaitingForPosition => "waiting-for-position",
        RouteStatus::Guiding => "guiding",
        RouteStatus::WaitingForFloor => "waiting-for-floor",
        RouteStatus::Arrived => "arrived",
        RouteStatus::Unreachable => "unreachable",
        RouteStatus::Preview => return None,
    };
    let guiding = matches!(r.status, RouteStatus::Guiding | RouteStatus::WaitingForFloor);
    Some(ToPage::Route {
        status,
        destination: (!r.destination.is_empty()).then(|| r.destination.clone()),
        distance_m: (guiding && r.distance_left_m.is_finite()).then_some((r.distance_left_m * 10.0).round() / 10.0),
        instruction: r.instruction.clone(),
        floor: r.floor,
    })
}

/// How far the position is known.
pub fn position(p: &Pose) -> ToPage {
    let status = match p.status {
        LocalizationStatus::Tracking if p.guides => "tracking",
        LocalizationStatus::Tracking => "found",
        LocalizationStatus::Converging if p.guides => "followed",
        LocalizationStatus::Converging => "converging",
        LocalizationStatus::Lost => "lost",
    };
    ToPage::Position { status, floor: p.floor }
}

/// The page's name of a rumble state.
pub fn rumble_name(r: Rumble) -> &'static str {
    match r {
        Rumble::None => "none",
        Rumble::Left => "left",
        Rumble::Right => "right",
        Rumble::Both => "both",
    }
}

/// The page's name of a ground state.
pub fn ground_name(g: GroundState) -> &'static str {
    match g {
        GroundState::Found => "found",
        GroundState::Lost => "lost",
        GroundState::Degraded => "degraded",
    }
}

/// The obstacle cue of a hazard.
pub fn obstacle(h: &Hazard) -> ToPage {
    ToPage::Obstacle { rumble: rumble_name(h.rumble), ground: ground_name(h.ground) }
}

/// The destination list.
pub fn destinations(d: &Destinations) -> ToPage {
    ToPage::Destinations {
        destinations: d
            .destinations
            .iter()
            .map(|d| DestinationView { label: d.label.clone(), floor: d.at.floor })
            .collect(),
    }
}

/// JSON text of a message for the page.
pub fn to_text(m: &ToPage) -> String {
    // every field is a string, number, bool or list of them: this cannot fail
    serde_json::to_string(m).unwrap_or_else(|e| format!(r#"{{"type":"error","message":"{e}"}}"#))
}

#[cfg(test)]
mod tests {
    use super::*;
    use schemas::MapPoint;

    #[test]
    fn commands_map_to_the_schema_and_bad_ones_say_why() {
        let ok = |t: &str| parse(t).unwrap();
        assert_eq!(
            ok(r#"{"type":"command","verb":"destination","label":" room 204 "}"#),
            FromPage::Command(Command::Destination { label: "room 204".into() })
        );
        assert_eq!(ok(r#"{"type":"command","verb":"where-am-i"}"#), FromPage::Command(Command::WhereAmI));
        assert_eq!(ok(r#"{"type":"command","verb":"repeat"}"#), FromPage::Command(Command::Repeat));
        assert_eq!(ok(r#"{"type":"command","verb":"cancel"}"#), FromPage::Command(Command::Cancel));
        assert_eq!(
            ok(r#"{"type":"command","verb":"mute","muted":true}"#),
            FromPage::Command(Command::Mute { muted: true })
        );
        let bad = |t: &str| parse(t).unwrap_err();
        assert_eq!(bad("{nope").kind, "bad_json");
        assert_eq!(bad(r#"[1,2]"#).kind, "bad_field");
        let unknown = bad(r#"{"type":"teleport"}"#);
        assert_eq!(unknown.kind, "unknown_type");
        assert!(unknown.message.contains("\"teleport\""), "{}", unknown.message);
        assert_eq!(bad(r#"{"type":"command","verb":"fly"}"#).kind, "unknown_verb");
        let no_label = bad(r#"{"type":"command","verb":"destination","label":"  "}"#);
        assert_eq!(
            (no_label.kind, no_label.message.as_str()),
            ("bad_field", "destination needs a \"label\": the place to go to")
        );
        let long = format!(r#"{{"type":"command","verb":"destination","label":"{}"}}"#, "a".repeat(201));
        assert_eq!(bad(&long).kind, "bad_field");
        assert_eq!(bad(r#"{"type":"command","verb":"mute","muted":"yes"}"#).kind, "bad_field");
        assert_eq!(
            ok(r#"{"type":"command","verb":"door","number":" 214 "}"#),
            FromPage::Command(Command::Door { number: "214".into() })
        );
        assert_eq!(bad(r#"{"type":"command","verb":"door","number":""}"#).kind, "bad_field");
        assert_eq!(bad(r#"{"type":"command","verb":"door","number":"12345678901234567"}"#).kind, "bad_field");
    }

    #[test]
    fn a_place_is_read_trimmed_and_refused_when_blank_missing_or_long() {
        let ok = |t: &str| parse(t).unwrap();
        let bad = |t: &str| parse(t).unwrap_err();
        assert_eq!(
            ok(r#"{"type":"command","verb":"place","label":"  room 204 "}"#),
            FromPage::Command(Command::Place { label: "room 204".into() })
        );
        let missing = "place needs a \"label\": the name of the place you are at";
        for frame in [
            r#"{"type":"command","verb":"place","label":"   "}"#,
            r#"{"type":"command","verb":"place","label":""}"#,
            r#"{"type":"command","verb":"place"}"#,
            r#"{"type":"command","verb":"place","label":204}"#,
        ] {
            let refused = bad(frame);
            assert_eq!((refused.kind, refused.message.as_str()), ("bad_field", missing), "{frame}");
        }
        let max = schemas::wire::MAX_PLACE_LABEL_CHARS;
        assert_eq!(max, 64);
        let longest = format!(r#"{{"type":"command","verb":"place","label":" {} "}}"#, "é".repeat(max));
        assert_eq!(ok(&longest), FromPage::Command(Command::Place { label: "é".repeat(max) }));
        let long = bad(&format!(r#"{{"type":"command","verb":"place","label":"{}"}}"#, "a".repeat(max + 1)));
        assert_eq!((long.kind, long.message.as_str()), ("bad_field", "a place name is at most 64 characters"));
        let control = bad(r#"{"type":"command","verb":"place","label":"room\u0007204"}"#);
        assert_eq!((control.kind, control.message.as_str()), ("bad_field", "a place name has control characters"));
        let unknown = bad(r#"{"type":"command","verb":"teleport"}"#);
        assert!(unknown.message.contains("door, place,"), "{}", unknown.message);
    }

    #[test]
    fn acks_clock_and_sensors_are_read_with_their_bounds() {
        assert_eq!(
            parse(r#"{"type":"ack","id":7,"event":"vibrated","t":1700000000123.5}"#).unwrap(),
            FromPage::Ack { id: 7, event: PhoneEvent::Vibrated, t_ms: 1_700_000_000_123.5 }
        );
        assert_eq!(
            parse(r#"{"type":"ack","id":8,"event":"failed","t":1,"reason":"synthesis-failed"}"#).unwrap(),
            FromPage::Ack { id: 8, event: PhoneEvent::Failed { reason: "synthesis-failed".into() }, t_ms: 1.0 }
        );
        assert_eq!(parse(r#"{"type":"ack","id":-1,"event":"ended","t":1}"#).unwrap_err().kind, "bad_field");
        assert_eq!(parse(r#"{"type":"ack","id":1,"event":"exploded","t":1}"#).unwrap_err().kind, "bad_field");
        assert_eq!(
            parse(r#"{"type":"clock","t":10,"page_t":25.5}"#).unwrap(),
            FromPage::Clock { t_ms: 10.0, page_t_ms: 25.5 }
        );
        assert_eq!(
            parse(r#"{"type":"heading","deg":271.5,"accuracy_deg":null}"#).unwrap(),
            FromPage::Heading { deg: 271.5, accuracy_deg: None }
        );
        assert_eq!(parse(r#"{"type":"heading","deg":400}"#).unwrap_err().kind, "bad_field");
        assert_eq!(parse(r#"{"type":"steps","count":12}"#).unwrap(), FromPage::Steps { count: 12 });
        assert_eq!(parse(r#"{"type":"destinations"}"#).unwrap(), FromPage::Destinations);
    }

    #[test]
    fn subscribe_names_the_monitor_streams_and_refuses_others() {
        assert_eq!(
            parse(r#"{"type":"subscribe","streams":["scan","health","scan"]}"#).unwrap(),
            FromPage::Subscribe(StreamSet::of(&[Stream::Scan, Stream::Health]))
        );
        assert_eq!(parse(r#"{"type":"subscribe","streams":[]}"#).unwrap(), FromPage::Subscribe(StreamSet::default()));
        let unknown = parse(r#"{"type":"subscribe","streams":["scan","particles"]}"#).unwrap_err();
        assert_eq!(unknown.kind, "bad_field");
        assert_eq!(
            unknown.message,
            "subscribe: unknown stream \"particles\" (the streams are map, route, pose, truth, health, speech, hazard, haptic, scan)"
        );
        assert_eq!(parse(r#"{"type":"subscribe","streams":"scan"}"#).unwrap_err().kind, "bad_field");
        assert_eq!(parse(r#"{"type":"subscribe","streams":[7]}"#).unwrap_err().kind, "bad_field");
        assert_eq!(parse(r#"{"type":"subscribe"}"#).unwrap_err().kind, "bad_field");
    }

    #[test]
    fn bus_messages_become_the_json_the_page_reads() {
        let text = to_text(&vibrate(&PhoneHaptic { id: 3, pattern_ms: vec![60, 40, 60], left: 0.0, right: 1.0 }));
        assert_eq!(text, r#"{"type":"vibrate","id":3,"pattern":[60,40,60]}"#);
        let say = PhoneSpeech::Say { id: 4, text: "Turn left.".into(), priority: Priority::Message, interrupt: true };
        assert_eq!(
            to_text(&speech(&say)),
            r#"{"type":"say","id":4,"text":"Turn left.","priority":"message","interrupt":true}"#
        );
        assert_eq!(to_text(&speech(&PhoneSpeech::Cut { id: 4 })), r#"{"type":"cut","id":4}"#);
        let mut r = RouteState {
            destination: "room 204".into(),
            next_waypoint: Some(MapPoint { x_m: 1.0, y_m: 2.0, floor: 1 }),
            distance_left_m: 12.345,
            instruction: "Turn left.".into(),
            floor: 1,
            status: RouteStatus::Guiding,
            route: vec![],
        };
        assert_eq!(
            to_text(&route(&r).unwrap()),
            r#"{"type":"route","status":"guiding","destination":"room 204","distance_m":12.3,"instruction":"Turn left.","floor":1}"#
        );
        r.status = RouteStatus::Preview;
        assert_eq!(route(&r), None, "a preview is not the user's route");
        r.status = RouteStatus::Idle;
        r.destination.clear();
        assert!(to_text(&route(&r).unwrap()).contains(r#""status":"idle","destination":null,"distance_m":null"#));
        // the position: as the filter has it, and "followed" while it converges but route
        // guidance takes its place
        let mut p = Pose {
            x_m: 1.0,
            y_m: 2.0,
            yaw_rad: 0.0,
            floor: 2,
            covariance: [0.0; 9],
            status: LocalizationStatus::Converging,
            guides: true,
        };
        assert_eq!(to_text(&position(&p)), r#"{"type":"position","status":"followed","floor":2}"#);
        p.guides = false;
        assert_eq!(to_text(&position(&p)), r#"{"type":"position","status":"converging","floor":2}"#);
        (p.status, p.guides) = (LocalizationStatus::Tracking, true);
        assert_eq!(to_text(&position(&p)), r#"{"type":"position","status":"tracking","floor":2}"#);
        // tracked, but a search's place the user has not confirmed: guidance waits
        p.guides = false;
        assert_eq!(to_text(&position(&p)), r#"{"type":"position","status":"found","floor":2}"#);
    }
}
