//! Envelope, encode and decode: bincode 2 with its legacy (bincode-1) layout.
//!
//! A payload is `Header` then the body, both in bincode's legacy layout: fixed-width
//! little-endian integers, `u64` length prefixes for strings and vectors, `u32` enum
//! variant indices, a `u8` tag for options. That is plain `struct` in Python and a layout
//! any maintained bincode-1 compatible crate reproduces byte for byte. A CRC-32 of
//! everything before it (IEEE, as zlib's `crc32`) ends the payload: a payload damaged on
//! the way (a flipped bit, a cut) is refused as `corrupt` before any of it is read. The
//! checksum catches damage, not forgery: anyone can compute it (the secure deployment
//! profile keeps strangers off the bus).
//!
//! Decoding never trusts a length prefix: the whole payload is bounded by the schema's
//! `MAX_BYTES` before anything is read, and bincode's allocation limit stops a forged
//! length from reserving memory.

use bincode::config::{Fixint, Limit, LittleEndian};
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use thiserror::Error;

use crate::messages::*;

/// Hard ceiling for any payload: a 640x480 raw depth frame is 614,400 bytes; a
/// 1280x720 raw one 1.8 MB. Nothing on the bus should come close to this.
pub const MAX_PAYLOAD_BYTES: usize = 8 * 1024 * 1024;

type Config<const N: usize> = bincode::config::Configuration<LittleEndian, Fixint, Limit<N>>;

fn config<const N: usize>() -> Config<N> {
    bincode::config::legacy().with_limit::<N>()
}

/// The most a decode of a `len`-byte payload may let a length prefix reserve: the
/// smallest tier at least 8 times the payload (a string's or container's claim is at
/// most a few times the bytes that encode it), so a forged length in a 50-byte intent
/// reserves 1 KiB, not the global limit. Payloads over 512 KiB keep the global limit.
pub fn claim_limit(len: usize) -> usize {
    CLAIM_TIERS.into_iter().find(|&t| t >= 8 * len).unwrap_or(MAX_PAYLOAD_BYTES)
}

const CLAIM_TIERS: [usize; 4] = [1 << 10, 16 << 10, 256 << 10, 4 << 20];

/// bincode decode of `T` from `bytes` under [`claim_limit`] of `payload_len`.
fn decode_limited<T: DeserializeOwned>(bytes: &[u8], payload_len: usize) -> Result<(T, usize), WireError> {
    let limit = claim_limit(payload_len);
    let decoded = match limit {
        l if l == CLAIM_TIERS[0] => bincode::serde::decode_from_slice(bytes, config::<{ 1 << 10 }>()),
        l if l == CLAIM_TIERS[1] => bincode::serde::decode_from_slice(bytes, config::<{ 16 << 10 }>()),
        l if l == CLAIM_TIERS[2] => bincode::serde::decode_from_slice(bytes, config::<{ 256 << 10 }>()),
        l if l == CLAIM_TIERS[3] => bincode::serde::decode_from_slice(bytes, config::<{ 4 << 20 }>()),
        _ => bincode::serde::decode_from_slice(bytes, config::<MAX_PAYLOAD_BYTES>()),
    };
    decoded.map_err(|e| map_decode_error(e, payload_len, limit))
}

/// Numeric schema ids: stable forever, never reused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[repr(u16)]
pub enum SchemaId {
    /// [`DepthFrame`]
    DepthFrame = 1,
    /// [`ImuBatch`]
    ImuBatch = 2,
    /// [`OdomIncrement`]
    OdomIncrement = 3,
    /// [`GroundTruth`]
    GroundTruth = 4,
    /// [`Scan`]
    Scan = 5,
    /// [`Hazard`]
    Hazard = 6,
    /// [`Pose`]
    Pose = 7,
    /// [`RouteState`]
    RouteState = 8,
    /// [`HapticIntent`]
    HapticIntent = 9,
    /// [`SpeechIntent`]
    SpeechIntent = 10,
    /// [`Applied`]
    Applied = 11,
    /// [`Command`]
    Command = 12,
    /// [`HealthStats`]
    HealthStats = 13,
    /// [`Destinations`]
    Destinations = 14,
    /// [`PhoneHaptic`]
    PhoneHaptic = 15,
    /// [`PhoneSpeech`]
    PhoneSpeech = 16,
    /// [`PhoneAck`]
    PhoneAck = 17,
    /// [`PhoneMotion`]
    PhoneMotion = 18,
    /// [`Pressure`]
    Pressure = 19,
    /// [`CameraPlace`]
    CameraPlace = 20,
}

impl SchemaId {
    /// Every schema, in id order.
    pub const ALL: [SchemaId; 20] = [
        SchemaId::DepthFrame,
        SchemaId::ImuBatch,
        SchemaId::OdomIncrement,
        SchemaId::GroundTruth,
        SchemaId::Scan,
        SchemaId::Hazard,
        SchemaId::Pose,
        SchemaId::RouteState,
        SchemaId::HapticIntent,
        SchemaId::SpeechIntent,
        SchemaId::Applied,
        SchemaId::Command,
        SchemaId::HealthStats,
        SchemaId::Destinations,
        SchemaId::PhoneHaptic,
        SchemaId::PhoneSpeech,
        SchemaId::PhoneAck,
        SchemaId::PhoneMotion,
        SchemaId::Pressure,
        SchemaId::CameraPlace,
    ];

    /// The schema with this numeric id.
    pub fn from_u16(id: u16) -> Option<Self> {
        Self::ALL.iter().copied().find(|s| *s as u16 == id)
    }

    /// Snake-case name, as used in the Zenoh encoding and by the Python decoder.
    pub fn name(self) -> &'static str {
        match self {
            SchemaId::DepthFrame => "depth_frame",
            SchemaId::ImuBatch => "imu_batch",
            SchemaId::OdomIncrement => "odom_increment",
            SchemaId::GroundTruth => "ground_truth",
            SchemaId::Scan => "scan",
            SchemaId::Hazard => "hazard",
            SchemaId::Pose => "pose",
            SchemaId::RouteState => "route_state",
            SchemaId::HapticIntent => "haptic_intent",
            SchemaId::SpeechIntent => "speech_intent",
            SchemaId::Applied => "applied",
            SchemaId::Command => "command",
            SchemaId::HealthStats => "health_stats",
            SchemaId::Destinations => "destinations",
            SchemaId::PhoneHaptic => "phone_haptic",
            SchemaId::PhoneSpeech => "phone_speech",
            SchemaId::PhoneAck => "phone_ack",
            SchemaId::PhoneMotion => "phone_motion",
            SchemaId::Pressure => "pressure",
            SchemaId::CameraPlace => "camera_place",
        }
    }

    /// The version of this schema's layout this build speaks (and writes); receivers
    /// reject any other. Bumped when a schema's layout changes: `hazard` v2 added
    /// `turn_ahead` and `body_turn_deg_s`, v4 `predictive` and v5 `gravity`; every schema went up one
    /// when the envelope gained the sender's `session` and the checksum trailer; `pose`
    /// v3 added `status` and v4 `guides`,
    /// `route_state` v3 `floor`, `status` and `route`, `command` v3 `Cancel` and `Floor`,
    /// v4 `Door` and v5 `Place`, `speech_intent` v3 `notice`.
    pub const fn version(self) -> u16 {
        match self {
            SchemaId::Hazard => 5,
            SchemaId::Command => 5,
            SchemaId::Pose => 4,
            SchemaId::RouteState | SchemaId::SpeechIntent | SchemaId::HealthStats => 3,
            _ => 2,
        }
    }

    /// Schema string carried in the Zenoh `Encoding` (`wearnav/<name>/v<version>`), so
    /// a generic monitor can dispatch without guessing.
    pub fn encoding_schema(self) -> String {
        format!("wearnav/{}/v{}", self.name(), self.version())
    }
}

/// A message body with its schema identity and size bound.
pub trait Message: Serialize + DeserializeOwned {
    /// Schema id written in the header.
    const SCHEMA: SchemaId;
    /// Version written in the header; receivers reject any other.
    const VERSION: u16 = Self::SCHEMA.version();
    /// Largest acceptable encoded payload (header included).
    const MAX_BYTES: usize = 64 * 1024;

    /// Semantic checks beyond the layout (NaN levels, empty texts...). A message that
    /// fails is rejected and counted like a malformed one, never acted on.
    fn validate(&self) -> Result<(), String> {
        Ok(())
    }
}

/// The envelope every payload starts with.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// [`SchemaId`] as a number.
    pub schema: u16,
    /// Schema version.
    pub version: u16,
    /// Sending agent (and host) name.
    pub sender: String,
    /// Random id of the publisher that sent it, new each time one is declared: a sender
    /// that restarts numbers from 0 again under a new session, which receivers tell
    /// from a replay of old messages.
    pub session: u64,
    /// Per-publisher sequence number, from 0, +1 per message.
    pub seq: u64,
    /// Capture time of the data this message derives from, ns since the Unix epoch.
    pub capture_ns: u64,
}

/// Why a payload was rejected. Every variant has a short `kind` for counters.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum WireError {
    /// A schema id this build does not know.
    #[error("unknown schema id {0}")]
    UnknownSchema(u16),
    /// A known schema at a version this build does not speak.
    #[error("{schema} version {got} not supported (this build speaks v{expected})")]
    UnknownVersion {
        /// Schema name.
        schema: &'static str,
        /// Version in the payload.
        got: u16,
        /// Version this build speaks.
        expected: u16,
    },
    /// A valid header of another schema than the subscriber expects.
    #[error("expected a {expected} payload, got {got}")]
    WrongSchema {
        /// Expected schema name.
        expected: &'static str,
        /// Schema id found.
        got: u16,
    },
    /// Larger than the schema allows.
    #[error("payload of {len} bytes is, or claims to hold, more than the {max}-byte limit")]
    TooLarge {
        /// Payload length.
        len: usize,
        /// Limit.
        max: usize,
    },
    /// Ended before the message did.
    #[error("payload truncated")]
    Truncated,
    /// Bytes that do not form the message (bad tags, bad UTF-8, trailing bytes).
    #[error("malformed payload: {0}")]
    Malformed(String),
    /// Well-formed but semantically unusable (NaN levels, empty text...).
    #[error("invalid message: {0}")]
    Invalid(String),
    /// The checksum does not match: damaged (bit flips, cut short) on the way.
    #[error("checksum mismatch: payload damaged or cut short (crc {found:08x}, computed {computed:08x})")]
    Corrupt {
        /// Checksum in the trailer.
        found: u32,
        /// Checksum of the bytes received.
        computed: u32,
    },
}

impl WireError {
    /// Short stable name for counters and health stats.
    pub fn kind(&self) -> &'static str {
        match self {
            WireError::UnknownSchema(_) => "unknown_schema",
            WireError::UnknownVersion { .. } => "unknown_version",
            WireError::WrongSchema { .. } => "wrong_schema",
            WireError::TooLarge { .. } => "too_large",
            WireError::Truncated => "truncated",
            WireError::Malformed(_) => "malformed",
            WireError::Invalid(_) => "invalid",
            WireError::Corrupt { .. } => "corrupt",
        }
    }
}

fn map_decode_error(err: bincode::error::DecodeError, len: usize, limit: usize) -> WireError {
    use bincode::error::DecodeError as D;
    match err {
        D::UnexpectedEnd { .. } => WireError::Truncated,
        // a length prefix claims more than the payload could hold
        D::LimitExceeded => WireError::TooLarge { len, max: limit },
        other => WireError::Malformed(other.to_string()),
    }
}

/// Bytes of the checksum trailer.
pub const CHECKSUM_BYTES: usize = 4;

/// Who sends a message: the name in its envelope and the publisher's session.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Origin<'a> {
    /// Sending agent (and host) name.
    pub sender: &'a str,
    /// The publisher's random session id ([`Header::session`]).
    pub session: u64,
}

/// Encode `body` from `origin` with sequence number `seq` and capture stamp
/// `capture_ns` (schema and version are filled in), checksum last.
pub fn encode<M: Message>(origin: &Origin, seq: u64, capture_ns: u64, body: &M) -> Vec<u8> {
    let mut out = Vec::with_capacity(64);
    encode_into(origin, seq, capture_ns, body, &mut out);
    out
}

/// Like [`encode`], appending to `out` (reuse one buffer on hot paths).
pub fn encode_into<M: Message>(origin: &Origin, seq: u64, capture_ns: u64, body: &M, out: &mut Vec<u8>) {
    let start = out.len();
    let header = Header {
        schema: M::SCHEMA as u16,
        version: M::VERSION,
        sender: origin.sender.to_string(),
        session: origin.session,
        seq,
        capture_ns,
    };
    // Writing into a Vec cannot fail, and every message type serialises (no maps with
    // non-string keys, no unsized sequences); the limit only guards decoding.
    let cfg = bincode::config::legacy();
    bincode::serde::encode_into_std_write(&header, out, cfg).expect("header serialises into a Vec");
    bincode::serde::encode_into_std_write(body, out, cfg).expect("body serialises into a Vec");
    let crc = crc32fast::hash(&out[start..]);
    out.extend_from_slice(&crc.to_le_bytes());
}

/// Rewrite the checksum trailer of `payload` to match the bytes before it: for tests
/// and the fuzzer, which damage a payload's inside on purpose and want the decoder, not
/// the checksum, to meet the damage. Does nothing to a payload shorter than a trailer.
pub fn reseal(payload: &mut [u8]) {
    if let Some(split) = payload.len().checked_sub(CHECKSUM_BYTES) {
        let crc = crc32fast::hash(&payload[..split]);
        payload[split..].copy_from_slice(&crc.to_le_bytes());
    }
}

/// The payload without its trailer, once the trailer matches.
fn verified(bytes: &[u8]) -> Result<&[u8], WireError> {
    let split = bytes.len().checked_sub(CHECKSUM_BYTES).ok_or(WireError::Truncated)?;
    let (body, trailer) = bytes.split_at(split);
    let found = u32::from_le_bytes(trailer.try_into().expect("4-byte trailer"));
    let computed = crc32fast::hash(body);
    if found != computed {
        return Err(WireError::Corrupt { found, computed });
    }
    Ok(body)
}

/// Schema and version from the first four bytes, checked before the checksum so a
/// payload of another build's layout is named as such rather than as damaged.
fn check_schema_version(bytes: &[u8]) -> Result<SchemaId, WireError> {
    let [s0, s1, v0, v1, ..] = *bytes else {
        return Err(WireError::Truncated);
    };
    let (id, version) = (u16::from_le_bytes([s0, s1]), u16::from_le_bytes([v0, v1]));
    let schema = SchemaId::from_u16(id).ok_or(WireError::UnknownSchema(id))?;
    if version != schema.version() {
        return Err(WireError::UnknownVersion { schema: schema.name(), got: version, expected: schema.version() });
    }
    Ok(schema)
}

/// Read only the envelope of a whole payload (checksum verified), e.g. to dispatch on
/// the schema: the header and the bytes it used.
pub fn decode_header(bytes: &[u8]) -> Result<(Header, usize), WireError> {
    if bytes.len() > MAX_PAYLOAD_BYTES {
        return Err(WireError::TooLarge { len: bytes.len(), max: MAX_PAYLOAD_BYTES });
    }
    check_schema_version(bytes)?;
    let bytes = verified(bytes)?;
    decode_limited(bytes, bytes.len())
}

/// Decode and validate a payload of schema `M`.
pub fn decode<M: Message>(bytes: &[u8]) -> Result<(Header, M), WireError> {
    if bytes.len() > M::MAX_BYTES {
        return Err(WireError::TooLarge { len: bytes.len(), max: M::MAX_BYTES });
    }
    let schema = check_schema_version(bytes)?;
    if schema != M::SCHEMA {
        return Err(WireError::WrongSchema { expected: M::SCHEMA.name(), got: schema as u16 });
    }
    let (header, used) = decode_header(bytes)?;
    let rest = &bytes[used..bytes.len() - CHECKSUM_BYTES];
    let (body, body_used): (M, usize) = decode_limited(rest, bytes.len())?;
    if body_used != rest.len() {
        return Err(WireError::Malformed(format!(
            "{} trailing bytes after the {} body",
            rest.len() - body_used,
            M::SCHEMA.name()
        )));
    }
    body.validate().map_err(WireError::Invalid)?;
    Ok((header, body))
}

fn finite(name: &str, values: &[f32]) -> Result<(), String> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => Err(format!("{name} is {v}")),
        None => Ok(()),
    }
}

fn unit_level(name: &str, v: f32) -> Result<(), String> {
    if v.is_nan() {
        Err(format!("{name} level is NaN"))
    } else {
        Ok(())
    }
}

/// Longest utterance accepted: about a minute of speech.
pub const MAX_SPEECH_CHARS: usize = 1000;

impl Message for DepthFrame {
    const SCHEMA: SchemaId = SchemaId::DepthFrame;
    const MAX_BYTES: usize = MAX_PAYLOAD_BYTES;
    fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 {
            return Err(format!("empty image {}x{}", self.width, self.height));
        }
        if (self.width as u64) * (self.height as u64) > 4096 * 4096 {
            return Err(format!("image {}x{} too large", self.width, self.height));
        }
        if !self.intrinsics.is_valid() {
            return Err(format!("bad intrinsics {:?}", self.intrinsics));
        }
        if !(self.depth_scale_m.is_finite() && self.depth_scale_m > 0.0) {
            return Err(format!("bad depth scale {}", self.depth_scale_m));
        }
        if let Some(g) = self.gravity_camera {
            finite("gravity", &g)?;
        }
        if let Some(m) = self.mount {
            m.check()?;
        }
        if let DepthEncoding::Bounded { step: 0 } = self.encoding {
            return Err("bounded encoding with step 0".into());
        }
        Ok(())
    }
}

impl Message for ImuBatch {
    const SCHEMA: SchemaId = SchemaId::ImuBatch;
    fn validate(&self) -> Result<(), String> {
        for s in &self.samples {
            finite("gyro", &s.gyro_rad_s)?;
            finite("accel", &s.accel_m_s2)?;
        }
        Ok(())
    }
}

impl Message for OdomIncrement {
    const SCHEMA: SchemaId = SchemaId::OdomIncrement;
    fn validate(&self) -> Result<(), String> {
        finite("odometry", &[self.forward_m, self.left_m, self.yaw_rad])
    }
}

impl Message for GroundTruth {
    const SCHEMA: SchemaId = SchemaId::GroundTruth;
}

impl Message for Scan {
    const SCHEMA: SchemaId = SchemaId::Scan;
    fn validate(&self) -> Result<(), String> {
        if self.ranges_m.iter().any(|r| r.is_nan()) {
            return Err("NaN range in scan".into());
        }
        finite("scan angles", &[self.angle_min_deg, self.angle_increment_deg])
    }
}

impl Message for Hazard {
    const SCHEMA: SchemaId = SchemaId::Hazard;
    fn validate(&self) -> Result<(), String> {
        let c = [self.ficf, self.cacf];
        finite("cost", &c.iter().flat_map(|s| [s.left, s.forward, s.right]).collect::<Vec<_>>())?;
        if let Some(r) = self.body_turn_deg_s {
            finite("body turn rate", &[r])?;
        }
        Ok(())
    }
}

impl Message for Pose {
    const SCHEMA: SchemaId = SchemaId::Pose;
    fn validate(&self) -> Result<(), String> {
        finite("pose", &[self.x_m, self.y_m, self.yaw_rad])
    }
}

impl Message for CameraPlace {
    const SCHEMA: SchemaId = SchemaId::CameraPlace;
    const MAX_BYTES: usize = 1024;
    fn validate(&self) -> Result<(), String> {
        finite("camera place", &[self.x_m, self.y_m, self.yaw_rad])
    }
}

impl Message for RouteState {
    const SCHEMA: SchemaId = SchemaId::RouteState;
    fn validate(&self) -> Result<(), String> {
        finite("distance left", &[self.distance_left_m])?;
        let points = self.route.iter().chain(self.next_waypoint.iter());
        finite("route", &points.flat_map(|p| [p.x_m, p.y_m]).collect::<Vec<_>>())
    }
}

impl Message for HapticIntent {
    const SCHEMA: SchemaId = SchemaId::HapticIntent;
    const MAX_BYTES: usize = 256;
    fn validate(&self) -> Result<(), String> {
        unit_level("left", self.left)?;
        unit_level("right", self.right)?;
        if let HapticPattern::Pulses { period_ms, duty } = self.pattern {
            if period_ms == 0 || duty.is_nan() {
                return Err(format!("bad pulse pattern period {period_ms} ms duty {duty}"));
            }
        }
        Ok(())
    }
}

impl Message for SpeechIntent {
    const SCHEMA: SchemaId = SchemaId::SpeechIntent;
    const MAX_BYTES: usize = 16 * 1024;
    fn validate(&self) -> Result<(), String> {
        if self.text.trim().is_empty() {
            return Err("empty utterance".into());
        }
        if self.text.chars().count() > MAX_SPEECH_CHARS {
            return Err(format!("utterance longer than {MAX_SPEECH_CHARS} characters"));
        }
        Ok(())
    }
}

impl Message for Applied {
    const SCHEMA: SchemaId = SchemaId::Applied;
}

/// Longest door number a `Door` command carries (signs say "214", "B1.07", "Lab 3").
pub const MAX_DOOR_NUMBER_CHARS: usize = 16;

/// Longest place label a `Place` command carries ("room 204", "north entrance").
pub const MAX_PLACE_LABEL_CHARS: usize = 64;

impl Message for Command {
    const SCHEMA: SchemaId = SchemaId::Command;
    fn validate(&self) -> Result<(), String> {
        match self {
            Command::Door { number } => short_words(number, "door number", MAX_DOOR_NUMBER_CHARS),
            Command::Place { label } => short_words(label, "place label", MAX_PLACE_LABEL_CHARS),
            _ => Ok(()),
        }
    }
}

/// `text` (trimmed) is not empty, at most `max` characters and without control
/// characters; the error names it `what`.
fn short_words(text: &str, what: &str, max: usize) -> Result<(), String> {
    let t = text.trim();
    if t.is_empty() {
        Err(format!("{what} is empty"))
    } else if t.chars().count() > max {
        Err(format!("{what} is longer than {max} characters"))
    } else if t.chars().any(char::is_control) {
        Err(format!("{what} has control characters"))
    } else {
        Ok(())
    }
}

impl Message for Destinations {
    const SCHEMA: SchemaId = SchemaId::Destinations;
    const MAX_BYTES: usize = 256 * 1024;
    fn validate(&self) -> Result<(), String> {
        finite("destinations", &self.destinations.iter().flat_map(|d| [d.at.x_m, d.at.y_m]).collect::<Vec<_>>())
    }
}

/// Longest vibration pattern sent to a phone (on/off steps).
pub const MAX_PHONE_PATTERN_STEPS: usize = 64;

impl Message for PhoneHaptic {
    const SCHEMA: SchemaId = SchemaId::PhoneHaptic;
    const MAX_BYTES: usize = 1024;
    fn validate(&self) -> Result<(), String> {
        if self.pattern_ms.is_empty() || self.pattern_ms.len() > MAX_PHONE_PATTERN_STEPS {
            return Err(format!(
                "vibration pattern of {} steps (1 to {MAX_PHONE_PATTERN_STEPS})",
                self.pattern_ms.len()
            ));
        }
        if self.pattern_ms.iter().any(|&ms| ms > 10_000) {
            return Err("a vibration step longer than 10 s".into());
        }
        finite("left level", &[self.left, self.right])?;
        if !(0.0..=1.0).contains(&self.left) || !(0.0..=1.0).contains(&self.right) {
            return Err(format!("levels {} {} outside 0..1", self.left, self.right));
        }
        Ok(())
    }
}

impl Message for PhoneSpeech {
    const SCHEMA: SchemaId = SchemaId::PhoneSpeech;
    const MAX_BYTES: usize = 16 * 1024;
    fn validate(&self) -> Result<(), String> {
        match self {
            PhoneSpeech::Say { text, .. } if text.trim().is_empty() => Err("empty utterance".into()),
            PhoneSpeech::Say { text, .. } if text.chars().count() > MAX_SPEECH_CHARS => {
                Err(format!("utterance longer than {MAX_SPEECH_CHARS} characters"))
            }
            _ => Ok(()),
        }
    }
}

impl Message for PhoneAck {
    const SCHEMA: SchemaId = SchemaId::PhoneAck;
    const MAX_BYTES: usize = 1024;
}

impl Message for PhoneMotion {
    const SCHEMA: SchemaId = SchemaId::PhoneMotion;
    const MAX_BYTES: usize = 1024;
    fn validate(&self) -> Result<(), String> {
        if self.heading_deg.is_some_and(|h| !(0.0..=360.0).contains(&h)) {
            return Err("heading outside 0..360 degrees".into());
        }
        if self.accuracy_deg.is_some_and(|a| !(a >= 0.0 && a.is_finite())) {
            return Err("heading accuracy not a finite positive angle".into());
        }
        Ok(())
    }
}

/// Pressures a barometer can read on the ground where people live and travel (the
/// Dead Sea shore to a high pass, storms included), pascals: anything else is a fault.
pub const PRESSURE_RANGE_PA: std::ops::RangeInclusive<f32> = 30_000.0..=110_000.0;

impl Message for Pressure {
    const SCHEMA: SchemaId = SchemaId::Pressure;
    const MAX_BYTES: usize = 1024;
    fn validate(&self) -> Result<(), String> {
        if !PRESSURE_RANGE_PA.contains(&self.pressure_pa) {
            return Err(format!(
                "pressure {} Pa outside {}..{} Pa",
                self.pressure_pa,
                PRESSURE_RANGE_PA.start(),
                PRESSURE_RANGE_PA.end()
            ));
        }
        Ok(())
    }
}

impl Message for HealthStats {
    const SCHEMA: SchemaId = SchemaId::HealthStats;
    const MAX_BYTES: usize = 256 * 1024;
}

#[cfg(test)]
mod tests {
    use super::*;

    const X: Origin = Origin { sender: "x", session: 0x5e55 };

    fn intent() -> HapticIntent {
        HapticIntent {
            left: 0.5,
            right: 1.0,
            pattern: HapticPattern::Pulses { period_ms: 200, duty: 0.5 },
            ttl_ms: 300,
        }
    }

    #[test]
    fn round_trip_keeps_header_and_body() {
        let origin = Origin { sender: "compute-agent", session: 42 };
        let bytes = encode(&origin, 7, 123_456_789, &intent());
        let (h, body) = decode::<HapticIntent>(&bytes).unwrap();
        assert_eq!(h.schema, SchemaId::HapticIntent as u16);
        assert_eq!(
            (h.version, h.sender.as_str(), h.session, h.seq, h.capture_ns),
            (2, "compute-agent", 42, 7, 123_456_789)
        );
        assert_eq!(body, intent());
    }

    #[test]
    fn a_door_command_needs_a_short_printable_number() {
        let long = "1".repeat(MAX_DOOR_NUMBER_CHARS + 1);
        for (number, ok) in
            [("214", true), ("B1.07", true), ("", false), ("   ", false), (&long[..], false), ("2\u{7}1", false)]
        {
            let bytes = encode(&X, 0, 0, &Command::Door { number: number.into() });
            match decode::<Command>(&bytes) {
                Ok((_, body)) => assert!(ok && body == Command::Door { number: number.into() }, "{number:?} accepted"),
                Err(e) => assert!(!ok && e.kind() == "invalid", "{number:?}: {e}"),
            }
        }
    }

    #[test]
    fn a_place_command_needs_a_short_printable_label() {
        let long = "a".repeat(MAX_PLACE_LABEL_CHARS + 1);
        let longest = "a".repeat(MAX_PLACE_LABEL_CHARS);
        for (label, ok) in [
            ("room 204", true),
            (&longest[..], true),
            ("", false),
            (" ", false),
            (&long[..], false),
            ("lob\u{7}by", false),
        ] {
            let bytes = encode(&X, 0, 0, &Command::Place { label: label.into() });
            match decode::<Command>(&bytes) {
                Ok((_, body)) => assert!(ok && body == Command::Place { label: label.into() }, "{label:?} accepted"),
                Err(e) => {
                    assert!(!ok && e.kind() == "invalid" && e.to_string().contains("place label"), "{label:?}: {e}")
                }
            }
        }
    }

    #[test]
    fn header_layout_is_bincode_legacy() {
        let bytes = encode(&Origin { sender: "ab", session: 9 }, 1, 2, &Command::Repeat);
        // schema u16, version u16, sender (u64 len + bytes), session u64, seq u64,
        // capture u64, variant u32, then the CRC-32 of all that.
        assert_eq!(&bytes[0..2], &12u16.to_le_bytes());
        assert_eq!(&bytes[2..4], &5u16.to_le_bytes());
        assert_eq!(&bytes[4..12], &2u64.to_le_bytes());
        assert_eq!(&bytes[12..14], b"ab");
        assert_eq!(&bytes[14..22], &9u64.to_le_bytes());
        assert_eq!(&bytes[22..30], &1u64.to_le_bytes());
        assert_eq!(&bytes[30..38], &2u64.to_le_bytes());
        assert_eq!(&bytes[38..42], &3u32.to_le_bytes());
        assert_eq!(&bytes[42..46], &crc32fast::hash(&bytes[..42]).to_le_bytes());
        assert_eq!(bytes.len(), 46);
    }

    #[test]
    fn every_truncation_is_rejected_as_corrupt_or_truncated() {
        let bytes = encode(&X, 0, 0, &intent());
        for cut in 0..bytes.len() {
            let err = decode::<HapticIntent>(&bytes[..cut]).unwrap_err();
            let want = if cut < 4 { "truncated" } else { "corrupt" };
            assert_eq!(err.kind(), want, "cut at {cut}: {err}");
            // cut short by a sender that sealed what it had: the decoder meets the end
            let mut sealed = bytes[..cut].to_vec();
            if cut >= 4 + CHECKSUM_BYTES {
                sealed.extend_from_slice(&[0; CHECKSUM_BYTES]);
                reseal(&mut sealed);
                sealed.truncate(cut);
                reseal(&mut sealed);
                let err = decode::<HapticIntent>(&sealed).unwrap_err();
                assert!(matches!(err, WireError::Truncated), "sealed cut at {cut}: {err}");
            }
        }
    }

    #[test]
    fn every_single_bit_flip_is_refused() {
        let bytes = encode(&X, 3, 99, &intent());
        for bit in 0..bytes.len() * 8 {
            let mut b = bytes.clone();
            b[bit / 8] ^= 1 << (bit % 8);
            let err = decode::<HapticIntent>(&b).unwrap_err();
            // a flip in schema or version is named as such (another schema may have
            // another version); anywhere else it is damage
            let want = match bit / 8 {
                0 | 1 => ["unknown_schema", "wrong_schema", "unknown_version"].as_slice(),
                2 | 3 => &["unknown_version"],
                _ => &["corrupt"],
            };
            assert!(want.contains(&err.kind()), "bit {bit}: {err}");
        }
    }

    #[test]
    fn unknown_version_and_wrong_schema_are_named() {
        let mut bytes = encode(&X, 0, 0, &intent());
        bytes[2] = 9;
        reseal(&mut bytes);
        assert_eq!(decode::<HapticIntent>(&bytes).unwrap_err().kind(), "unknown_version");
        let other = encode(&X, 0, 0, &Command::WhereAmI);
        assert_eq!(
            decode::<HapticIntent>(&other).unwrap_err(),
            WireError::WrongSchema { expected: "haptic_intent", got: 12 }
        );
        let mut unknown = other.clone();
        unknown[0] = 200;
        reseal(&mut unknown);
        assert_eq!(decode::<Command>(&unknown).unwrap_err(), WireError::UnknownSchema(200));
    }

    #[test]
    fn oversized_and_forged_lengths_are_refused_without_allocating() {
        let big = vec![0u8; HapticIntent::MAX_BYTES + 1];
        assert_eq!(decode::<HapticIntent>(&big).unwrap_err().kind(), "too_large");
        // A speech intent whose text claims 2^40 bytes.
        let mut bytes = encode(
            &X,
            0,
            0,
            &SpeechIntent {
                text: "hi".into(),
                priority: Priority::Text,
                interrupt: false,
                ttl_ms: 1,
                dedup_key: String::new(),
                notice: false,
            },
        );
        let text_len_at = 4 + 8 + 1 + 8 + 8 + 8;
        bytes[text_len_at..text_len_at + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
        reseal(&mut bytes);
        let err = decode::<SpeechIntent>(&bytes).unwrap_err();
        assert!(matches!(err, WireError::TooLarge { .. } | WireError::Truncated), "{err:?}");
    }

    #[test]
    fn garbage_and_trailing_bytes_are_malformed_not_panics() {
        let mut bytes = encode(&X, 0, 0, &Command::Mute { muted: true });
        bytes.insert(bytes.len() - CHECKSUM_BYTES, 0);
        reseal(&mut bytes);
        assert_eq!(decode::<Command>(&bytes).unwrap_err().kind(), "malformed");
        let mut bad_variant = encode(&X, 0, 0, &Command::Repeat);
        let n = bad_variant.len() - CHECKSUM_BYTES;
        bad_variant[n - 4..n].copy_from_slice(&77u32.to_le_bytes());
        reseal(&mut bad_variant);
        assert_eq!(decode::<Command>(&bad_variant).unwrap_err().kind(), "malformed");
        // Pseudo-random garbage never panics.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for len in 0..300 {
            let junk: Vec<u8> = (0..len)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    x as u8
                })
                .collect();
            let _ = decode::<Hazard>(&junk);
            let _ = decode::<DepthFrame>(&junk);
        }
    }

    #[test]
    fn nan_levels_and_empty_texts_are_invalid() {
        let mut nan = intent();
        nan.left = f32::NAN;
        let bytes = encode(&X, 0, 0, &nan);
        assert_eq!(decode::<HapticIntent>(&bytes).unwrap_err().kind(), "invalid");
        let empty = SpeechIntent {
            text: "  ".into(),
            priority: Priority::Important,
            interrupt: true,
            ttl_ms: 1,
            dedup_key: String::new(),
            notice: false,
        };
        assert_eq!(decode::<SpeechIntent>(&encode(&X, 0, 0, &empty)).unwrap_err().kind(), "invalid");
    }

    #[test]
    fn a_depth_frame_whose_mount_guess_no_cane_could_give_is_invalid() {
        let frame = |height_m: f32, pitch_deg: f32| DepthFrame {
            width: 2,
            height: 1,
            depth_scale_m: 0.001,
            intrinsics: Intrinsics { fx: 525.0, fy: 525.0, cx: 0.5, cy: 0.0 },
            gravity_camera: None,
            mount: Some(MountGuess { height_m, pitch_deg }),
            encoding: DepthEncoding::Raw,
            data: vec![0; 4],
        };
        assert!(decode::<DepthFrame>(&encode(&X, 0, 0, &frame(0.9, 30.0))).is_ok());
        for (h, p) in [(f32::NAN, 30.0), (0.0, 30.0), (-0.9, 30.0), (3.5, 30.0), (0.9, f32::INFINITY), (0.9, 120.0)] {
            let err = decode::<DepthFrame>(&encode(&X, 0, 0, &frame(h, p))).unwrap_err();
            assert_eq!(err.kind(), "invalid", "height {h}, pitch {p}: {err}");
            assert!(err.to_string().contains("mount"), "{err}");
        }
    }

    #[test]
    fn schema_ids_round_trip_and_name_the_encoding() {
        for s in SchemaId::ALL {
            assert_eq!(SchemaId::from_u16(s as u16), Some(s));
        }
        assert_eq!(SchemaId::Hazard.encoding_schema(), "wearnav/hazard/v5");
        assert_eq!(SchemaId::ImuBatch.encoding_schema(), "wearnav/imu_batch/v2");
    }
}
