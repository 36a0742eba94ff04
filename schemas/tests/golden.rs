//! Golden vectors: the bytes Rust writes for representative values of every message,
//! committed in `schemas/vectors/`, which `schemas/python/tests/test_vectors.py` decodes
//! and re-encodes, so the Rust and Python sides of the wire contract cannot drift apart.
//!
//! - `<name>.bin` is `schemas::encode` of the value, `<name>.json` its header and body as
//!   serde_json writes them (non-finite floats become `null`; depth frames also carry
//!   the decoded `depth_samples`).
//! - `reject/<case>.bin` are damaged payloads and `reject/<case>.json` the error kind
//!   Rust's `decode` gives for them; Python must give the same kind.
//! - `keys.json` and `schemas.json` hold the key builders' output and the schema table.
//!
//! A change in `messages.rs` fails this test with the command to regenerate:
//! `UPDATE_VECTORS=1 cargo test -p schemas --test golden`, then review
//! `git diff schemas/vectors` and run pytest.

use std::fmt::Debug;
use std::fs;
use std::path::{Path, PathBuf};

use schemas::depth_codec;
use schemas::wire::MAX_PAYLOAD_BYTES;
use schemas::*;
use serde::Serialize;

const SENDER: &str = "golden";
/// The golden publisher's session id.
const SESSION: u64 = 0x0123_4567_89ab_cdef;
const ORIGIN: Origin = Origin { sender: SENDER, session: SESSION };
/// 2025-11-22T02:00:00Z, so ages printed from these vectors look like real stamps.
const CAPTURE_NS: u64 = 1_763_776_800_000_000_000;
const REGENERATE: &str = "regenerate with `UPDATE_VECTORS=1 cargo test -p schemas --test golden`, \
     review `git diff schemas/vectors`, then run `python3 -m pytest schemas/python`";

fn vectors_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("vectors")
}

fn updating() -> bool {
    std::env::var_os("UPDATE_VECTORS").is_some_and(|v| v == "1")
}

/// What the committed bytes of a vector must do when Rust decodes them.
type Check = Box<dyn Fn(&[u8]) -> Result<(), String>>;

/// One file to compare with (or write to) `schemas/vectors`, and the check that its
/// committed bytes decode back in Rust.
struct Golden {
    path: String,
    bytes: Vec<u8>,
    check: Check,
}

impl Golden {
    /// A file with nothing to decode (the JSON side of a vector, the key table).
    fn plain(path: String, bytes: Vec<u8>) -> Self {
        Self { path, bytes, check: Box::new(|_| Ok(())) }
    }
}

#[derive(Serialize)]
struct VectorJson<'a, M> {
    schema: &'static str,
    schema_id: u16,
    encoding_schema: String,
    max_bytes: usize,
    header: &'a Header,
    body: &'a M,
    #[serde(skip_serializing_if = "Option::is_none")]
    depth_samples: Option<Vec<u16>>,
}

fn json_text<T: Serialize>(value: &T) -> Vec<u8> {
    let mut text = serde_json::to_string_pretty(value).expect("vectors serialise to JSON");
    text.push('\n');
    text.into_bytes()
}

/// `<name>.bin` and `<name>.json` for `body`, sent as the `seq`-th message.
fn vector<M>(name: &str, seq: u64, body: M) -> [Golden; 2]
where
    M: Message + PartialEq + Debug + 'static,
{
    vector_with_samples(name, seq, body, None)
}

fn vector_with_samples<M>(name: &str, seq: u64, body: M, depth_samples: Option<Vec<u16>>) -> [Golden; 2]
where
    M: Message + PartialEq + Debug + 'static,
{
    assert!(name.starts_with(M::SCHEMA.name()), "vector {name} must start with its schema name");
    let capture_ns = CAPTURE_NS + seq * 33_000_000;
    let bytes = encode(&ORIGIN, seq, capture_ns, &body);
    let header = Header {
        schema: M::SCHEMA as u16,
        version: M::VERSION,
        sender: SENDER.to_string(),
        session: SESSION,
        seq,
        capture_ns,
    };
    let json = json_text(&VectorJson {
        schema: M::SCHEMA.name(),
        schema_id: M::SCHEMA as u16,
        encoding_schema: M::SCHEMA.encoding_schema(),
        max_bytes: M::MAX_BYTES,
        header: &header,
        body: &body,
        depth_samples,
    });
    let check = move |committed: &[u8]| match decode::<M>(committed) {
        Ok((h, b)) if h == header && b == body => Ok(()),
        Ok((h, b)) => Err(format!("decodes to {h:?} {b:?}")),
        Err(e) => Err(format!("does not decode: {e}")),
    };
    [Golden { path: format!("{name}.bin"), bytes, check: Box::new(check) }, Golden::plain(format!("{name}.json"), json)]
}

fn depth_vector(name: &str, seq: u64, mut frame: DepthFrame, samples: &[u16]) -> [Golden; 2] {
    depth_codec::encode(samples, frame.width, frame.height, frame.encoding, &mut frame.data).expect("test image packs");
    let mut decoded = Vec::new();
    depth_codec::decode(&frame.data, frame.width, frame.height, frame.encoding, &mut decoded)
        .expect("test image unpacks");
    vector_with_samples(name, seq, frame, Some(decoded))
}

/// A 4x3 depth image in millimetres with invalid (0) pixels and a near obstacle.
const DEPTH_MM: [u16; 12] = [0, 1500, 1502, 1499, 800, 812, 0, 2750, 65535, 1, 2, 3000];

fn depth_frames() -> Vec<[Golden; 2]> {
    let frame = |encoding, gravity_camera, mount| DepthFrame {
        width: 4,
        height: 3,
        depth_scale_m: 0.001,
        intrinsics: Intrinsics { fx: 3.5, fy: 3.5, cx: 1.5, cy: 1.0 },
        gravity_camera,
        mount,
        encoding,
        data: Vec::new(),
    };
    let mount = MountGuess { height_m: 0.8, pitch_deg: 30.0 };
    vec![
        depth_vector("depth_frame_raw", 1, frame(DepthEncoding::Raw, Some([0.0, 0.866, 0.5]), Some(mount)), &DEPTH_MM),
        depth_vector("depth_frame_lossless", 2, frame(DepthEncoding::Lossless, None, None), &DEPTH_MM),
        depth_vector(
            "depth_frame_bounded",
            3,
            frame(DepthEncoding::Bounded { step: 4 }, Some([0.01, 0.99, -0.125]), None),
            &DEPTH_MM,
        ),
    ]
}

fn sensor_vectors() -> Vec<[Golden; 2]> {
    vec![
        vector(
            "imu_batch",
            4,
            ImuBatch {
                samples: vec![
                    ImuSample { stamp_ns: CAPTURE_NS, gyro_rad_s: [0.01, -0.02, 0.5], accel_m_s2: [0.1, -9.81, 0.25] },
                    ImuSample {
                        stamp_ns: CAPTURE_NS + 5_000_000,
                        gyro_rad_s: [0.0, 0.0, -0.5],
                        accel_m_s2: [0.0, -9.75, 0.5],
                    },
                ],
            },
        ),
        vector("imu_batch_empty", 5, ImuBatch { samples: Vec::new() }),
        vector(
            "odom_increment",
            6,
            OdomIncrement {
                from_ns: CAPTURE_NS,
                to_ns: CAPTURE_NS + 33_333_333,
                forward_m: 0.042,
                left_m: -0.003,
                yaw_rad: 0.0175,
            },
        ),
        vector(
            "ground_truth",
            7,
            GroundTruth {
                x_m: 2.5,
                y_m: -1.25,
                yaw_rad: 1.5707964,
                floor: -1,
                camera_height_m: 0.82,
                camera_pitch_deg: 35.0,
                sweep_deg: -12.5,
            },
        ),
    ]
}

fn perception_vectors() -> Vec<[Golden; 2]> {
    let costs = |left, forward, right| SideCosts { left, forward, right };
    let latency =
        vec![StageLatency { stage: "decode".into(), us: 850 }, StageLatency { stage: "ground_plane".into(), us: 4200 }];
    let hazard = |rumble, ground, active| Hazard {
        frame_seq: 41,
        ficf: costs(0.0, 0.0, 0.0),
        cacf: costs(0.0, 0.0, 0.0),
        active,
        rumble,
        ground,
        plane_camera: [0.0047, -0.9968, -0.0798, 1.2714],
        nearest_m: f32::INFINITY,
        nearest_bearing_deg: 0.0,
        ttc_s: None,
        dropoff_ahead: false,
        turn_ahead: false,
        body_turn_deg_s: None,
        predictive: false,
        gravity: true,
        latency: Vec::new(),
    };
    vec![
        vector(
            "scan",
            8,
            Scan {
                angle_min_deg: -2.0,
                angle_increment_deg: 1.0,
                ranges_m: vec![f32::INFINITY, 1.75, 0.75, 2.5, f32::INFINITY],
                range_max_m: 4.0,
            },
        ),
        vector(
            "scan_empty",
            9,
            Scan { angle_min_deg: -22.5, angle_increment_deg: 1.0, ranges_m: Vec::new(), range_max_m: 4.0 },
        ),
        vector("hazard_clear", 10, hazard(Rumble::None, GroundState::Found, CostFunction::Ficf)),
        vector(
            "hazard_left",
            11,
            Hazard {
                ficf: costs(0.25, 1.5, 3.0),
                cacf: costs(0.5, 2.0, 4.5),
                nearest_m: 0.75,
                nearest_bearing_deg: -10.0,
                ttc_s: Some(1.5),
                body_turn_deg_s: Some(-3.5),
                latency: latency.clone(),
                ..hazard(Rumble::Left, GroundState::Lost, CostFunction::Cacf)
            },
        ),
        vector(
            "hazard_right",
            12,
            Hazard {
                ficf: costs(2.0, 1.0, 0.0),
                nearest_m: 1.25,
                nearest_bearing_deg: 15.0,
                turn_ahead: true,
                body_turn_deg_s: Some(45.0),
                predictive: true,
                gravity: false,
                ..hazard(Rumble::Right, GroundState::Degraded, CostFunction::Ficf)
            },
        ),
        vector(
            "hazard_both",
            13,
            Hazard {
                ficf: costs(3.0, 3.0, 3.0),
                nearest_m: 0.5,
                dropoff_ahead: true,
                ttc_s: Some(0.25),
                latency,
                ..hazard(Rumble::Both, GroundState::Found, CostFunction::Ficf)
            },
        ),
    ]
}

/// A route state with `status`, to exercise every status.
fn route_with_status(name: &str, seq: u64, status: RouteStatus) -> [Golden; 2] {
    vector(
        name,
        seq,
        RouteState {
            destination: "room 204".into(),
            next_waypoint: None,
            distance_left_m: 12.0,
            instruction: String::new(),
            floor: 1,
            status,
            route: vec![],
        },
    )
}

fn localization_vectors() -> Vec<[Golden; 2]> {
    vec![
        vector(
            "pose",
            14,
            Pose {
                x_m: 12.5,
                y_m: 3.25,
                yaw_rad: -0.5,
                floor: 2,
                covariance: [0.04, 0.001, 0.0, 0.001, 0.04, 0.0, 0.0, 0.0, 0.01],
                status: LocalizationStatus::Tracking,
                guides: true,
            },
        ),
        vector(
            "route_state_active",
            15,
            RouteState {
                destination: "room 2.14".into(),
                next_waypoint: Some(MapPoint { x_m: 14.0, y_m: 3.0, floor: 2 }),
                distance_left_m: 23.5,
                instruction: "turn left in 3 metres".into(),
                floor: 2,
                status: RouteStatus::Guiding,
                route: vec![MapPoint { x_m: 14.0, y_m: 3.0, floor: 2 }, MapPoint { x_m: 14.0, y_m: 12.5, floor: 2 }],
            },
        ),
        vector(
            "route_state_idle",
            16,
            RouteState {
                destination: String::new(),
                next_waypoint: None,
                distance_left_m: 0.0,
                instruction: String::new(),
                floor: 0,
                status: RouteStatus::Idle,
                route: vec![],
            },
        ),
        vector(
            "camera_place",
            63,
            CameraPlace { x_m: 13.25, y_m: 3.5, yaw_rad: 0.75, floor: 2, status: LocalizationStatus::Tracking },
        ),
        vector(
            "pose_lost",
            18,
            Pose {
                x_m: 0.0,
                y_m: 0.0,
                yaw_rad: 0.0,
                floor: 0,
                covariance: [25.0, 0.0, 0.0, 0.0, 25.0, 0.0, 0.0, 0.0, 3.0],
                status: LocalizationStatus::Lost,
                guides: false,
            },
        ),
        vector(
            "pose_converging",
            19,
            Pose {
                x_m: 3.0,
                y_m: 4.0,
                yaw_rad: 1.5,
                floor: 1,
                covariance: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.5],
                status: LocalizationStatus::Converging,
                guides: true,
            },
        ),
        route_with_status("route_state_waiting_for_position", 40, RouteStatus::WaitingForPosition),
        route_with_status("route_state_waiting_for_floor", 41, RouteStatus::WaitingForFloor),
        route_with_status("route_state_arrived", 42, RouteStatus::Arrived),
        route_with_status("route_state_unreachable", 43, RouteStatus::Unreachable),
        route_with_status("route_state_preview", 44, RouteStatus::Preview),
        vector(
            "destinations",
            17,
            Destinations {
                destinations: vec![
                    Destination { label: "entrance".into(), at: MapPoint { x_m: 1.5, y_m: 5.0, floor: 0 } },
                    Destination { label: "room 204".into(), at: MapPoint { x_m: 15.0, y_m: 3.5, floor: 1 } },
                ],
            },
        ),
    ]
}

fn feedback_vectors() -> Vec<[Golden; 2]> {
    let pulses = HapticPattern::Pulses { period_ms: 120, duty: 0.5 };
    let speech = |text: &str, priority, interrupt| SpeechIntent {
        text: text.into(),
        priority,
        interrupt,
        ttl_ms: 2000,
        dedup_key: String::new(),
        notice: false,
    };
    let applied = |device: &str, action| Applied {
        device: device.into(),
        action,
        applied_ns: CAPTURE_NS + 4_500_000,
        cause_capture_ns: CAPTURE_NS,
    };
    vec![
        vector(
            "haptic_intent_steady",
            17,
            HapticIntent { left: 1.0, right: 0.0, pattern: HapticPattern::Steady, ttl_ms: 300 },
        ),
        vector("haptic_intent_pulses", 18, HapticIntent { left: 0.75, right: 0.75, pattern: pulses, ttl_ms: 250 }),
        vector(
            "speech_intent_important",
            19,
            SpeechIntent {
                dedup_key: "obstacle-ahead".into(),
                ..speech("Achtung: Tür links, 1,5 m — stufe ↓ 出口", Priority::Important, true)
            },
        ),
        vector(
            "speech_intent_message",
            20,
            SpeechIntent { notice: true, ..speech("turn left in 3 metres", Priority::Message, false) },
        ),
        vector("speech_intent_text", 21, speech("door 2.14 on your right", Priority::Text, false)),
        vector("speech_intent_notification", 22, speech("battery 20 %", Priority::Notification, false)),
        vector("speech_intent_progress", 23, speech("23 metres left", Priority::Progress, false)),
        vector(
            "applied_rumble",
            24,
            applied("wiimote-left", AppliedAction::Rumble { left: 1.0, right: 0.0, pattern: pulses }),
        ),
        vector(
            "applied_speech_started",
            25,
            applied("espeak", AppliedAction::SpeechStarted { text: "stop".into(), priority: Priority::Important }),
        ),
        vector(
            "applied_speech_finished",
            26,
            applied("espeak", AppliedAction::SpeechFinished { text: "Café straight ahead".into() }),
        ),
        vector(
            "applied_speech_interrupted",
            27,
            applied("espeak", AppliedAction::SpeechInterrupted { text: "turn left in 3 metres".into() }),
        ),
        vector(
            "applied_speech_dropped",
            28,
            applied("console", AppliedAction::SpeechDropped { text: "23 metres left".into(), reason: "stale".into() }),
        ),
        vector(
            "applied_offline_warning",
            29,
            Applied {
                cause_capture_ns: 0,
                ..applied(
                    "console",
                    AppliedAction::OfflineWarning { offline: true, reason: "perception/hazard stale".into() },
                )
            },
        ),
        vector("applied_device_status", 30, applied("phone", AppliedAction::DeviceStatus { text: "connected".into() })),
    ]
}

fn phone_vectors() -> Vec<[Golden; 2]> {
    let say = PhoneSpeech::Say { id: 8, text: "Turn left.".into(), priority: Priority::Message, interrupt: true };
    let ack = |id, event| PhoneAck { id, event, at_ns: CAPTURE_NS + 45_000_000 };
    vec![
        vector("phone_haptic", 50, PhoneHaptic { id: 7, pattern_ms: vec![60, 40, 60, 40], left: 0.0, right: 0.8 }),
        vector("phone_haptic_stop", 51, PhoneHaptic { id: 9, pattern_ms: vec![0], left: 0.0, right: 0.0 }),
        vector("phone_speech_say", 52, say),
        vector("phone_speech_cut", 53, PhoneSpeech::Cut { id: 8 }),
        vector("phone_ack_vibrated", 54, ack(7, PhoneEvent::Vibrated)),
        vector("phone_ack_started", 55, ack(8, PhoneEvent::Started)),
        vector("phone_ack_ended", 56, ack(8, PhoneEvent::Ended)),
        vector("phone_ack_interrupted", 57, ack(8, PhoneEvent::Interrupted)),
        vector("phone_ack_failed", 58, ack(8, PhoneEvent::Failed { reason: "synthesis-failed".into() })),
        vector("phone_motion", 59, PhoneMotion { heading_deg: Some(271.5), accuracy_deg: Some(15.0), steps: 42 }),
        vector("phone_motion_unknown", 60, PhoneMotion { heading_deg: None, accuracy_deg: None, steps: 0 }),
        vector("pressure", 62, Pressure { stamp_ns: 1_700_000_000_123_000_000, pressure_pa: 101_325.5 }),
    ]
}

fn command_and_health_vectors() -> Vec<[Golden; 2]> {
    vec![
        vector("command_destination", 31, Command::Destination { label: "café".into() }),
        vector("command_where_am_i", 32, Command::WhereAmI),
        vector("command_mute", 33, Command::Mute { muted: true }),
        vector("command_repeat", 34, Command::Repeat),
        vector("command_cancel", 37, Command::Cancel),
        vector("command_floor", 38, Command::Floor { floor: -1 }),
        vector("command_door", 39, Command::Door { number: "B1.07".into() }),
        vector("command_place", 61, Command::Place { label: "room 204".into() }),
        vector(
            "health_stats",
            35,
            HealthStats {
                agent: "compute-agent".into(),
                uptime_ms: 12_345,
                ok: false,
                status: "ground lost".into(),
                streams: vec![
                    StreamStats {
                        key: "wearnav/alice/sensor/cane/depth".into(),
                        inbound: true,
                        count: 300,
                        rate_hz: 30.0,
                        bytes_per_s: 1_843_200.0,
                        rejects: 2,
                        missed: 5,
                        latency_p50_ms: 3.5,
                        latency_p99_ms: 8.25,
                    },
                    StreamStats {
                        key: "wearnav/alice/perception/hazard".into(),
                        inbound: false,
                        count: 298,
                        rate_hz: 29.5,
                        bytes_per_s: 4096.0,
                        rejects: 0,
                        missed: 0,
                        latency_p50_ms: 0.0,
                        latency_p99_ms: 0.0,
                    },
                ],
                rejects: vec![RejectCount { kind: "truncated".into(), count: 2 }],
            },
        ),
    ]
}

fn message_vectors() -> Vec<Golden> {
    [
        depth_frames(),
        sensor_vectors(),
        perception_vectors(),
        localization_vectors(),
        feedback_vectors(),
        phone_vectors(),
        command_and_health_vectors(),
    ]
    .into_iter()
    .flatten()
    .flatten()
    .collect()
}

#[derive(Serialize)]
struct RejectJson {
    expect_schema: &'static str,
    kind: &'static str,
}

/// `reject/<case>.bin|json`: `bytes` must fail `decode::<M>` with `kind`.
fn reject<M: Message + Debug>(case: &str, bytes: Vec<u8>, kind: &'static str) -> [Golden; 2] {
    let check = move |committed: &[u8]| match decode::<M>(committed) {
        Err(e) if e.kind() == kind => Ok(()),
        Err(e) => Err(format!("rejected as {} ({e}), expected {kind}", e.kind())),
        Ok(got) => Err(format!("decoded to {got:?}, expected a {kind} error")),
    };
    let json = json_text(&RejectJson { expect_schema: M::SCHEMA.name(), kind });
    [
        Golden { path: format!("reject/{case}.bin"), bytes, check: Box::new(check) },
        Golden::plain(format!("reject/{case}.json"), json),
    ]
}

/// Byte offset of the body: `schema u16, version u16, sender (u64 len + bytes),
/// session u64, seq u64, capture_ns u64`.
const BODY_AT: usize = 2 + 2 + 8 + SENDER.len() + 8 + 8 + 8;

fn reject_vectors() -> Vec<Golden> {
    let speech = SpeechIntent {
        text: "stop".into(),
        priority: Priority::Important,
        interrupt: true,
        ttl_ms: 1000,
        dedup_key: String::new(),
        notice: false,
    };
    let speech_bytes = encode(&ORIGIN, 1, CAPTURE_NS, &speech);
    let text_at = BODY_AT + 8;
    let command_bytes = encode(&ORIGIN, 1, CAPTURE_NS, &Command::Repeat);
    let route_bytes = encode(
        &ORIGIN,
        1,
        CAPTURE_NS,
        &RouteState {
            destination: String::new(),
            next_waypoint: None,
            distance_left_m: 0.0,
            instruction: String::new(),
            floor: 0,
            status: RouteStatus::Idle,
            route: vec![],
        },
    );
    let scan_bytes = encode(
        &ORIGIN,
        1,
        CAPTURE_NS,
        &Scan { angle_min_deg: 0.0, angle_increment_deg: 1.0, ranges_m: vec![1.0, 2.0], range_max_m: 4.0 },
    );
    // Damage inside a payload whose checksum was then made to match (a faulty sender,
    // or a forger): the decoder itself must meet it.
    let patched = |bytes: &[u8], at: usize, new: &[u8]| {
        let mut b = bytes.to_vec();
        b[at..at + new.len()].copy_from_slice(new);
        wire::reseal(&mut b);
        b
    };
    // Cut to `len` bytes, then sealed again.
    let cut_sealed = |bytes: &[u8], len: usize| {
        let mut b = bytes[..len].to_vec();
        b.extend_from_slice(&[0; wire::CHECKSUM_BYTES]);
        wire::reseal(&mut b);
        b
    };
    let flipped = |bytes: &[u8], bit: usize| {
        let mut b = bytes.to_vec();
        b[bit / 8] ^= 1 << (bit % 8);
        b
    };
    let mut too_long = encode(
        &ORIGIN,
        1,
        CAPTURE_NS,
        &HapticIntent { left: 0.5, right: 0.5, pattern: HapticPattern::Steady, ttl_ms: 100 },
    );
    too_long.resize(300, 0);
    wire::reseal(&mut too_long);
    let mut trailing = command_bytes.clone();
    trailing.insert(trailing.len() - wire::CHECKSUM_BYTES, 0);
    wire::reseal(&mut trailing);
    let hazard_bytes = encode(&ORIGIN, 1, CAPTURE_NS, &Hazard::nothing_ahead(1, GroundState::Found));

    [
        // damaged on the way: the checksum refuses it before anything is read
        reject::<SpeechIntent>("cut_short", speech_bytes[..speech_bytes.len() - 1].to_vec(), "corrupt"),
        reject::<SpeechIntent>("bit_flip_in_text", flipped(&speech_bytes, (BODY_AT + 8) * 8 + 3), "corrupt"),
        reject::<SpeechIntent>("bit_flip_in_checksum", flipped(&speech_bytes, speech_bytes.len() * 8 - 1), "corrupt"),
        reject::<Hazard>("bit_flip_in_stamp", flipped(&hazard_bytes, (BODY_AT - 8) * 8), "corrupt"),
        // cut short by the sender, sealed as it was
        reject::<SpeechIntent>("truncated_body", cut_sealed(&speech_bytes, speech_bytes.len() - 5), "truncated"),
        reject::<SpeechIntent>("truncated_header", cut_sealed(&speech_bytes, 5), "truncated"),
        reject::<SpeechIntent>("too_short", speech_bytes[..3].to_vec(), "truncated"),
        reject::<SpeechIntent>("empty", Vec::new(), "truncated"),
        reject::<SpeechIntent>("wrong_version", patched(&speech_bytes, 2, &1u16.to_le_bytes()), "unknown_version"),
        // a hazard from a build before v2 (no turn_ahead, body_turn_deg_s), from one
        // before v3 (no session, no checksum), from one before v4 (no predictive) and
        // from one before v5 (no gravity)
        reject::<Hazard>("hazard_v1", patched(&hazard_bytes, 2, &1u16.to_le_bytes()), "unknown_version"),
        reject::<Hazard>("hazard_v2", patched(&hazard_bytes, 2, &2u16.to_le_bytes()), "unknown_version"),
        reject::<Hazard>("hazard_v3", patched(&hazard_bytes, 2, &3u16.to_le_bytes()), "unknown_version"),
        reject::<Hazard>("hazard_v4", patched(&hazard_bytes, 2, &4u16.to_le_bytes()), "unknown_version"),
        reject::<SpeechIntent>("unknown_schema", patched(&speech_bytes, 0, &99u16.to_le_bytes()), "unknown_schema"),
        reject::<Hazard>("wrong_schema", scan_bytes.clone(), "wrong_schema"),
        reject::<Hazard>("garbage_ff", vec![0xff; 40], "unknown_schema"),
        reject::<Hazard>("garbage_text", b"this is not a wearnav payload at all".to_vec(), "unknown_schema"),
        reject::<Hazard>("garbage_after_valid_start", [&hazard_bytes[..4], &[0xff; 40][..]].concat(), "corrupt"),
        reject::<Command>("trailing_byte", trailing, "malformed"),
        reject::<Command>("bad_variant_index", patched(&command_bytes, BODY_AT, &9u32.to_le_bytes()), "malformed"),
        reject::<RouteState>("bad_option_tag", patched(&route_bytes, BODY_AT + 8, &[2]), "malformed"),
        reject::<SpeechIntent>("bad_bool", patched(&speech_bytes, text_at + 4 + 4, &[2]), "malformed"),
        reject::<SpeechIntent>("bad_utf8", patched(&speech_bytes, text_at, &[0xff, 0xfe]), "malformed"),
        reject::<SpeechIntent>(
            "forged_string_length",
            patched(&speech_bytes, BODY_AT, &(1u64 << 40).to_le_bytes()),
            "too_large",
        ),
        reject::<Scan>(
            "forged_vec_length",
            patched(&scan_bytes, BODY_AT + 8, &(1u64 << 40).to_le_bytes()),
            "truncated",
        ),
        reject::<HapticIntent>("over_schema_limit", too_long, "too_large"),
    ]
    .into_iter()
    .flatten()
    .collect()
}

#[derive(Serialize)]
struct KeyCase {
    method: &'static str,
    args: Vec<&'static str>,
    key: Option<String>,
}

fn key_vectors() -> Golden {
    let k = Keys::new("alice").expect("valid user");
    let case =
        |method, args: &[&'static str], key: &str| KeyCase { method, args: args.to_vec(), key: Some(key.to_string()) };
    let cases = vec![
        case("prefix", &[], k.prefix()),
        case("all", &[], &k.all()),
        case("depth", &["cane"], &k.depth("cane")),
        case("depth_any", &[], &k.depth_any()),
        case("imu", &["cane"], &k.imu("cane")),
        case("imu_any", &[], &k.imu_any()),
        case("odom", &["cane"], &k.odom("cane")),
        case("odom_any", &[], &k.odom_any()),
        case("truth", &["sim"], &k.truth("sim")),
        case("truth_any", &[], &k.truth_any()),
        case("scan", &[], &k.scan()),
        case("hazard", &[], &k.hazard()),
        case("pose", &[], &k.pose()),
        case("camera_place", &[], &k.camera_place()),
        case("route_state", &[], &k.route_state()),
        case("haptic", &[], &k.haptic()),
        case("speech", &[], &k.speech()),
        case("applied", &[], &k.applied()),
        case("phone_haptic", &[], &k.phone_haptic()),
        case("phone_speech", &[], &k.phone_speech()),
        case("phone_ack", &[], &k.phone_ack()),
        case("motion", &["phone"], &k.motion("phone")),
        case("pressure", &["cane"], &k.pressure("cane")),
        case("pressure_any", &[], &k.pressure_any()),
        case("cmd", &["where-am-i"], &k.cmd("where-am-i")),
        case("cmd_any", &[], &k.cmd_any()),
        case("health", &["compute-agent"], &k.health("compute-agent")),
        case("health_any", &[], &k.health_any()),
        case("query", &["route"], &k.query("route")),
        KeyCase {
            method: "device_of",
            args: vec!["wearnav/alice/sensor/cane/depth"],
            key: k.device_of("wearnav/alice/sensor/cane/depth").map(str::to_string),
        },
        KeyCase {
            method: "device_of",
            args: vec!["wearnav/bob/sensor/cane/depth"],
            key: k.device_of("wearnav/bob/sensor/cane/depth").map(str::to_string),
        },
        KeyCase {
            method: "agent_of",
            args: vec!["wearnav/alice/health/feedback-agent"],
            key: k.agent_of("wearnav/alice/health/feedback-agent").map(str::to_string),
        },
    ];
    #[derive(Serialize)]
    struct KeysJson {
        user: &'static str,
        cases: Vec<KeyCase>,
        command_verbs: Vec<(&'static str, &'static str)>,
    }
    let command_verbs = vec![
        ("Destination", Command::Destination { label: String::new() }.verb()),
        ("WhereAmI", Command::WhereAmI.verb()),
        ("Mute", Command::Mute { muted: false }.verb()),
        ("Repeat", Command::Repeat.verb()),
        ("Cancel", Command::Cancel.verb()),
        ("Floor", Command::Floor { floor: 0 }.verb()),
        ("Door", Command::Door { number: "1".into() }.verb()),
        ("Place", Command::Place { label: "lobby".into() }.verb()),
    ];
    let table = KeysJson { user: "alice", cases, command_verbs };
    Golden::plain("keys.json".into(), json_text(&table))
}

fn schema_table() -> Golden {
    #[derive(Serialize)]
    struct SchemaJson {
        id: u16,
        name: &'static str,
        version: u16,
        encoding_schema: String,
    }
    #[derive(Serialize)]
    struct TableJson {
        max_payload_bytes: usize,
        schemas: Vec<SchemaJson>,
    }
    let schemas = SchemaId::ALL
        .iter()
        .map(|s| SchemaJson {
            id: *s as u16,
            name: s.name(),
            version: s.version(),
            encoding_schema: s.encoding_schema(),
        })
        .collect();
    let table = TableJson { max_payload_bytes: MAX_PAYLOAD_BYTES, schemas };
    Golden::plain("schemas.json".into(), json_text(&table))
}

fn all_goldens() -> Vec<Golden> {
    let mut all = message_vectors();
    all.extend(reject_vectors());
    all.push(key_vectors());
    all.push(schema_table());
    all
}

/// Every committed file under `dir` (relative paths), to spot stale vectors.
fn committed_files(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    for sub in ["", "reject"] {
        let Ok(entries) = fs::read_dir(dir.join(sub)) else {
            continue;
        };
        for entry in entries.flatten() {
            if entry.path().is_file() {
                let name = entry.file_name().to_string_lossy().into_owned();
                found.push(if sub.is_empty() { name } else { format!("{sub}/{name}") });
            }
        }
    }
    found.sort();
    found
}

#[test]
fn vectors_match_committed_files_and_decode_back() {
    let dir = vectors_dir();
    let goldens = all_goldens();
    let mut problems = Vec::new();
    if updating() {
        fs::create_dir_all(dir.join("reject")).expect("create schemas/vectors/reject");
        for stale in committed_files(&dir) {
            if !goldens.iter().any(|g| g.path == stale) {
                fs::remove_file(dir.join(&stale)).expect("remove a stale vector");
            }
        }
        for g in &goldens {
            fs::write(dir.join(&g.path), &g.bytes).expect("write a vector");
        }
    }
    for g in &goldens {
        match fs::read(dir.join(&g.path)) {
            Err(e) => problems.push(format!("{}: cannot read ({e})", g.path)),
            Ok(committed) => {
                if committed != g.bytes {
                    problems.push(format!("{}: committed file differs from what Rust writes now", g.path));
                }
                if let Err(e) = (g.check)(&committed) {
                    problems.push(format!("{}: {e}", g.path));
                }
            }
        }
    }
    for file in committed_files(&dir) {
        if !goldens.iter().any(|g| g.path == file) {
            problems.push(format!("{file}: stale, no vector writes it any more"));
        }
    }
    assert!(problems.is_empty(), "golden vectors out of date:\n  {}\n{REGENERATE}", problems.join("\n  "));
}

#[test]
fn every_schema_has_a_vector() {
    let goldens = all_goldens();
    for schema in SchemaId::ALL {
        let name = schema.name();
        assert!(
            goldens
                .iter()
                .any(|g| !g.path.starts_with("reject/") && g.path.starts_with(name) && g.path.ends_with(".bin")),
            "no golden vector for {name}"
        );
    }
}

#[test]
fn infinity_survives_the_wire_and_becomes_null_in_json() {
    let goldens = all_goldens();
    let scan = goldens.iter().find(|g| g.path == "scan.bin").expect("scan vector");
    let (_, decoded) = decode::<Scan>(&scan.bytes).expect("scan decodes");
    assert_eq!(decoded.ranges_m[0], f32::INFINITY);
    let json = goldens.iter().find(|g| g.path == "scan.json").expect("scan json");
    let text = String::from_utf8(json.bytes.clone()).expect("utf-8 json");
    assert!(text.contains("null"), "serde_json writes INFINITY as null: {text}");
}
