//! Envelope, encode and decode: bincode 2 with its legacy (bincode-1) layout.
//!
//! A payload is `Header` then the body, both in bincode's legacy layout: fixed-width
//! little-endian integers, `u64` length prefixes for strings and vectors, `u32` enum
//! variant indices, a `u8` tag for options. That is plain `struct` in Python and a layout
//! any maintained bincode-1 compatible crate reproduces byte for byte.
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

type WireConfig = bincode::config::Configuration<LittleEndian, Fixint, Limit<MAX_PAYLOAD_BYTES>>;

fn config() -> WireConfig {
    bincode::config::legacy().with_limit::<MAX_PAYLOAD_BYTES>()
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
}

impl SchemaId {
    /// Every schema, in id order.
    pub const ALL: [SchemaId; 13] = [
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
        }
    }

    /// The version of this schema's layout this build speaks (and writes); receivers
    /// reject any other. Bumped when a schema's layout changes: `hazard` v2 added
    /// `turn_ahead` and `body_turn_deg_s`.
    pub const fn version(self) -> u16 {
        match self {
            SchemaId::Hazard => 2,
            _ => 1,
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
    #[error("payload of {len} bytes exceeds the {max}-byte limit")]
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
        }
    }
}

fn map_decode_error(err: bincode::error::DecodeError, len: usize) -> WireError {
    use bincode::error::DecodeError as D;
    match err {
        D::UnexpectedEnd { .. } => WireError::Truncated,
        D::LimitExceeded => WireError::TooLarge {
            len,
            max: MAX_PAYLOAD_BYTES,
        },
        other => WireError::Malformed(other.to_string()),
    }
}

/// Encode `body` behind `header`'s sender/seq/stamp (schema and version are filled in).
pub fn encode<M: Message>(sender: &str, seq: u64, capture_ns: u64, body: &M) -> Vec<u8> {
    let mut out = Vec::with_capacity(64);
    encode_into(sender, seq, capture_ns, body, &mut out);
    out
}

/// Like [`encode`], appending to `out` (reuse one buffer on hot paths).
pub fn encode_into<M: Message>(
    sender: &str,
    seq: u64,
    capture_ns: u64,
    body: &M,
    out: &mut Vec<u8>,
) {
    let header = Header {
        schema: M::SCHEMA as u16,
        version: M::VERSION,
        sender: sender.to_string(),
        seq,
        capture_ns,
    };
    // Writing into a Vec cannot fail, and every message type serialises (no maps with
    // non-string keys, no unsized sequences); the limit only guards decoding.
    let cfg = bincode::config::legacy();
    bincode::serde::encode_into_std_write(&header, out, cfg).expect("header serialises into a Vec");
    bincode::serde::encode_into_std_write(body, out, cfg).expect("body serialises into a Vec");
}

/// Read only the envelope, e.g. to dispatch on the schema.
pub fn decode_header(bytes: &[u8]) -> Result<(Header, usize), WireError> {
    if bytes.len() > MAX_PAYLOAD_BYTES {
        return Err(WireError::TooLarge {
            len: bytes.len(),
            max: MAX_PAYLOAD_BYTES,
        });
    }
    let (header, used): (Header, usize) = bincode::serde::decode_from_slice(bytes, config())
        .map_err(|e| map_decode_error(e, bytes.len()))?;
    let schema =
        SchemaId::from_u16(header.schema).ok_or(WireError::UnknownSchema(header.schema))?;
    if header.version != schema.version() {
        return Err(WireError::UnknownVersion {
            schema: schema.name(),
            got: header.version,
            expected: schema.version(),
        });
    }
    Ok((header, used))
}

/// Decode and validate a payload of schema `M`.
pub fn decode<M: Message>(bytes: &[u8]) -> Result<(Header, M), WireError> {
    if bytes.len() > M::MAX_BYTES {
        return Err(WireError::TooLarge {
            len: bytes.len(),
            max: M::MAX_BYTES,
        });
    }
    let (header, used) = decode_header(bytes)?;
    if header.schema != M::SCHEMA as u16 {
        return Err(WireError::WrongSchema {
            expected: M::SCHEMA.name(),
            got: header.schema,
        });
    }
    if header.version != M::VERSION {
        return Err(WireError::UnknownVersion {
            schema: M::SCHEMA.name(),
            got: header.version,
            expected: M::VERSION,
        });
    }
    let rest = &bytes[used..];
    let (body, body_used): (M, usize) = bincode::serde::decode_from_slice(rest, config())
        .map_err(|e| map_decode_error(e, bytes.len()))?;
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
        finite(
            "scan angles",
            &[self.angle_min_deg, self.angle_increment_deg],
        )
    }
}

impl Message for Hazard {
    const SCHEMA: SchemaId = SchemaId::Hazard;
    fn validate(&self) -> Result<(), String> {
        let c = [self.ficf, self.cacf];
        finite(
            "cost",
            &c.iter()
                .flat_map(|s| [s.left, s.forward, s.right])
                .collect::<Vec<_>>(),
        )?;
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

impl Message for RouteState {
    const SCHEMA: SchemaId = SchemaId::RouteState;
}

impl Message for HapticIntent {
    const SCHEMA: SchemaId = SchemaId::HapticIntent;
    const MAX_BYTES: usize = 256;
    fn validate(&self) -> Result<(), String> {
        unit_level("left", self.left)?;
        unit_level("right", self.right)?;
        if let HapticPattern::Pulses { period_ms, duty } = self.pattern {
            if period_ms == 0 || duty.is_nan() {
                return Err(format!(
                    "bad pulse pattern period {period_ms} ms duty {duty}"
                ));
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
            return Err(format!(
                "utterance longer than {MAX_SPEECH_CHARS} characters"
            ));
        }
        Ok(())
    }
}

impl Message for Applied {
    const SCHEMA: SchemaId = SchemaId::Applied;
}

impl Message for Command {
    const SCHEMA: SchemaId = SchemaId::Command;
}

impl Message for HealthStats {
    const SCHEMA: SchemaId = SchemaId::HealthStats;
    const MAX_BYTES: usize = 256 * 1024;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn intent() -> HapticIntent {
        HapticIntent {
            left: 0.5,
            right: 1.0,
            pattern: HapticPattern::Pulses {
                period_ms: 200,
                duty: 0.5,
            },
            ttl_ms: 300,
        }
    }

    #[test]
    fn round_trip_keeps_header_and_body() {
        let bytes = encode("compute-agent", 7, 123_456_789, &intent());
        let (h, body) = decode::<HapticIntent>(&bytes).unwrap();
        assert_eq!(h.schema, SchemaId::HapticIntent as u16);
        assert_eq!(
            (h.version, h.sender.as_str(), h.seq, h.capture_ns),
            (1, "compute-agent", 7, 123_456_789)
        );
        assert_eq!(body, intent());
    }

    #[test]
    fn header_layout_is_bincode_legacy() {
        let bytes = encode("ab", 1, 2, &Command::Repeat);
        // schema u16, version u16, sender (u64 len + bytes), seq u64, capture u64, variant u32.
        assert_eq!(&bytes[0..2], &12u16.to_le_bytes());
        assert_eq!(&bytes[2..4], &1u16.to_le_bytes());
        assert_eq!(&bytes[4..12], &2u64.to_le_bytes());
        assert_eq!(&bytes[12..14], b"ab");
        assert_eq!(&bytes[14..22], &1u64.to_le_bytes());
        assert_eq!(&bytes[22..30], &2u64.to_le_bytes());
        assert_eq!(&bytes[30..34], &3u32.to_le_bytes());
        assert_eq!(bytes.len(), 34);
    }

    #[test]
    fn every_truncation_is_rejected_as_truncated() {
        let bytes = encode("x", 0, 0, &intent());
        for cut in 0..bytes.len() {
            let err = decode::<HapticIntent>(&bytes[..cut]).unwrap_err();
            assert_eq!(err, WireError::Truncated, "cut at {cut}");
        }
    }

    #[test]
    fn unknown_version_and_wrong_schema_are_named() {
        let mut bytes = encode("x", 0, 0, &intent());
        bytes[2] = 9;
        assert_eq!(
            decode::<HapticIntent>(&bytes).unwrap_err().kind(),
            "unknown_version"
        );
        let other = encode("x", 0, 0, &Command::WhereAmI);
        assert_eq!(
            decode::<HapticIntent>(&other).unwrap_err(),
            WireError::WrongSchema {
                expected: "haptic_intent",
                got: 12
            }
        );
        let mut unknown = other.clone();
        unknown[0] = 200;
        assert_eq!(
            decode::<Command>(&unknown).unwrap_err(),
            WireError::UnknownSchema(200)
        );
    }

    #[test]
    fn oversized_and_forged_lengths_are_refused_without_allocating() {
        let big = vec![0u8; HapticIntent::MAX_BYTES + 1];
        assert_eq!(
            decode::<HapticIntent>(&big).unwrap_err().kind(),
            "too_large"
        );
        // A speech intent whose text claims 2^40 bytes.
        let mut bytes = encode(
            "x",
            0,
            0,
            &SpeechIntent {
                text: "hi".into(),
                priority: Priority::Text,
                interrupt: false,
                ttl_ms: 1,
                dedup_key: String::new(),
            },
        );
        let text_len_at = 4 + 8 + 1 + 8 + 8;
        bytes[text_len_at..text_len_at + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
        let err = decode::<SpeechIntent>(&bytes).unwrap_err();
        assert!(
            matches!(err, WireError::TooLarge { .. } | WireError::Truncated),
            "{err:?}"
        );
    }

    #[test]
    fn garbage_and_trailing_bytes_are_malformed_not_panics() {
        let mut bytes = encode("x", 0, 0, &Command::Mute { muted: true });
        bytes.push(0);
        assert_eq!(decode::<Command>(&bytes).unwrap_err().kind(), "malformed");
        let mut bad_variant = encode("x", 0, 0, &Command::Repeat);
        let n = bad_variant.len();
        bad_variant[n - 4..].copy_from_slice(&77u32.to_le_bytes());
        assert_eq!(
            decode::<Command>(&bad_variant).unwrap_err().kind(),
            "malformed"
        );
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
        let bytes = encode("x", 0, 0, &nan);
        assert_eq!(
            decode::<HapticIntent>(&bytes).unwrap_err().kind(),
            "invalid"
        );
        let empty = SpeechIntent {
            text: "  ".into(),
            priority: Priority::Important,
            interrupt: true,
            ttl_ms: 1,
            dedup_key: String::new(),
        };
        assert_eq!(
            decode::<SpeechIntent>(&encode("x", 0, 0, &empty))
                .unwrap_err()
                .kind(),
            "invalid"
        );
    }

    #[test]
    fn schema_ids_round_trip_and_name_the_encoding() {
        for s in SchemaId::ALL {
            assert_eq!(SchemaId::from_u16(s as u16), Some(s));
        }
        assert_eq!(SchemaId::Hazard.encoding_schema(), "wearnav/hazard/v2");
        assert_eq!(SchemaId::ImuBatch.encoding_schema(), "wearnav/imu_batch/v1");
    }
}
