"""Every message body of ``schemas/src/messages.rs``, as one layout table.

Field order here *is* the wire format and must match the Rust structs exactly: a
change in messages.rs is one line here, and the golden vectors
(``UPDATE_VECTORS=1 cargo test -p schemas --test golden``, then pytest) catch any drift.
"""

from dataclasses import dataclass

from .layout import (
    BOOL,
    BYTES,
    F32,
    I32,
    MAX_PAYLOAD_BYTES,
    STRING,
    U16,
    U32,
    U64,
    Array,
    Enum,
    Optional,
    Seq,
    Struct,
)

INTRINSICS = Struct("Intrinsics", fx=F32, fy=F32, cx=F32, cy=F32)

DEPTH_ENCODING = Enum("DepthEncoding", {"Raw": None, "Lossless": None, "Bounded": {"step": U16}})

MOUNT_GUESS = Struct("MountGuess", height_m=F32, pitch_deg=F32)

DEPTH_FRAME = Struct(
    "DepthFrame",
    width=U32,
    height=U32,
    depth_scale_m=F32,
    intrinsics=INTRINSICS,
    gravity_camera=Optional(Array(F32, 3)),
    mount=Optional(MOUNT_GUESS),
    encoding=DEPTH_ENCODING,
    data=BYTES,
)

IMU_SAMPLE = Struct("ImuSample", stamp_ns=U64, gyro_rad_s=Array(F32, 3), accel_m_s2=Array(F32, 3))

IMU_BATCH = Struct("ImuBatch", samples=Seq(IMU_SAMPLE))

ODOM_INCREMENT = Struct(
    "OdomIncrement", from_ns=U64, to_ns=U64, forward_m=F32, left_m=F32, yaw_rad=F32
)

GROUND_TRUTH = Struct(
    "GroundTruth",
    x_m=F32,
    y_m=F32,
    yaw_rad=F32,
    floor=I32,
    camera_height_m=F32,
    camera_pitch_deg=F32,
    sweep_deg=F32,
)

SCAN = Struct(
    "Scan", angle_min_deg=F32, angle_increment_deg=F32, ranges_m=Seq(F32), range_max_m=F32
)

SIDE_COSTS = Struct("SideCosts", left=F32, forward=F32, right=F32)

COST_FUNCTION = Enum("CostFunction", {"Ficf": None, "Cacf": None})

RUMBLE = Enum("Rumble", {"None": None, "Left": None, "Right": None, "Both": None})

GROUND_STATE = Enum("GroundState", {"Found": None, "Lost": None, "Degraded": None})

STAGE_LATENCY = Struct("StageLatency", stage=STRING, us=U32)

HAZARD = Struct(
    "Hazard",
    frame_seq=U64,
    ficf=SIDE_COSTS,
    cacf=SIDE_COSTS,
    active=COST_FUNCTION,
    rumble=RUMBLE,
    ground=GROUND_STATE,
    plane_camera=Array(F32, 4),
    nearest_m=F32,
    nearest_bearing_deg=F32,
    ttc_s=Optional(F32),
    dropoff_ahead=BOOL,
    turn_ahead=BOOL,
    body_turn_deg_s=Optional(F32),
    predictive=BOOL,
    gravity=BOOL,
    latency=Seq(STAGE_LATENCY),
)

LOCALIZATION_STATUS = Enum(
    "LocalizationStatus", {"Tracking": None, "Converging": None, "Lost": None}
)

POSE = Struct(
    "Pose",
    x_m=F32,
    y_m=F32,
    yaw_rad=F32,
    floor=I32,
    covariance=Array(F32, 9),
    status=LOCALIZATION_STATUS,
    guides=BOOL,
)

CAMERA_PLACE = Struct(
    "CameraPlace", x_m=F32, y_m=F32, yaw_rad=F32, floor=I32, status=LOCALIZATION_STATUS
)

MAP_POINT = Struct("MapPoint", x_m=F32, y_m=F32, floor=I32)

ROUTE_STATUS = Enum(
    "RouteStatus",
    {
        "Idle": None,
        "WaitingForPosition": None,
        "Guiding": None,
        "WaitingForFloor": None,
        "Arrived": None,
        "Unreachable": None,
        "Preview": None,
    },
)

ROUTE_STATE = Struct(
    "RouteState",
    destination=STRING,
    next_waypoint=Optional(MAP_POINT),
    distance_left_m=F32,
    instruction=STRING,
    floor=I32,
    status=ROUTE_STATUS,
    route=Seq(MAP_POINT),
)

DESTINATION = Struct("Destination", label=STRING, at=MAP_POINT)

DESTINATIONS = Struct("Destinations", destinations=Seq(DESTINATION))

HAPTIC_PATTERN = Enum(
    "HapticPattern", {"Steady": None, "Pulses": {"period_ms": U32, "duty": F32}}
)

HAPTIC_INTENT = Struct("HapticIntent", left=F32, right=F32, pattern=HAPTIC_PATTERN, ttl_ms=U32)

PRIORITY = Enum(
    "Priority",
    {"Important": None, "Message": None, "Text": None, "Notification": None, "Progress": None},
)

SPEECH_INTENT = Struct(
    "SpeechIntent",
    text=STRING,
    priority=PRIORITY,
    interrupt=BOOL,
    ttl_ms=U32,
    dedup_key=STRING,
    notice=BOOL,
)

APPLIED_ACTION = Enum(
    "AppliedAction",
    {
        "Rumble": {"left": F32, "right": F32, "pattern": HAPTIC_PATTERN},
        "SpeechStarted": {"text": STRING, "priority": PRIORITY},
        "SpeechFinished": {"text": STRING},
        "SpeechInterrupted": {"text": STRING},
        "SpeechDropped": {"text": STRING, "reason": STRING},
        "OfflineWarning": {"offline": BOOL, "reason": STRING},
        "DeviceStatus": {"text": STRING},
    },
)

APPLIED = Struct(
    "Applied", device=STRING, action=APPLIED_ACTION, applied_ns=U64, cause_capture_ns=U64
)

COMMAND = Enum(
    "Command",
    {
        "Destination": {"label": STRING},
        "WhereAmI": None,
        "Mute": {"muted": BOOL},
        "Repeat": None,
        "Cancel": None,
        "Floor": {"floor": I32},
        "Door": {"number": STRING},
        "Place": {"label": STRING},
    },
)

PHONE_HAPTIC = Struct("PhoneHaptic", id=U64, pattern_ms=Seq(U32), left=F32, right=F32)

PHONE_SPEECH = Enum(
    "PhoneSpeech",
    {
        "Say": {"id": U64, "text": STRING, "priority": PRIORITY, "interrupt": BOOL},
        "Cut": {"id": U64},
    },
)

PHONE_EVENT = Enum(
    "PhoneEvent",
    {
        "Vibrated": None,
        "Started": None,
        "Ended": None,
        "Interrupted": None,
        "Failed": {"reason": STRING},
    },
)

PHONE_ACK = Struct("PhoneAck", id=U64, event=PHONE_EVENT, at_ns=U64)

PHONE_MOTION = Struct(
    "PhoneMotion", heading_deg=Optional(F32), accuracy_deg=Optional(F32), steps=U64
)

PRESSURE = Struct("Pressure", stamp_ns=U64, pressure_pa=F32)

STREAM_STATS = Struct(
    "StreamStats",
    key=STRING,
    inbound=BOOL,
    count=U64,
    rate_hz=F32,
    bytes_per_s=F32,
    rejects=U64,
    missed=U64,
    latency_p50_ms=F32,
    latency_p99_ms=F32,
)

REJECT_COUNT = Struct("RejectCount", kind=STRING, count=U64)

HEALTH_STATS = Struct(
    "HealthStats",
    agent=STRING,
    uptime_ms=U64,
    ok=BOOL,
    status=STRING,
    streams=Seq(STREAM_STATS),
    rejects=Seq(REJECT_COUNT),
)

#: The envelope every payload starts with (wire.rs ``Header``).
HEADER = Struct(
    "Header", schema=U16, version=U16, sender=STRING, session=U64, seq=U64, capture_ns=U64
)


@dataclass(frozen=True)
class Schema:
    """One schema of wire.rs ``SchemaId``: its stable id, snake-case name, body layout,
    the largest payload (header included) a receiver accepts (``Message::MAX_BYTES``)
    and the version of its layout (``SchemaId::version``; receivers reject any other)."""

    id: int
    name: str
    body: object
    max_bytes: int = 64 * 1024
    version: int = 2


#: Every schema, in id order (ids are stable forever, never reused).
SCHEMAS = (
    Schema(1, "depth_frame", DEPTH_FRAME, MAX_PAYLOAD_BYTES),
    Schema(2, "imu_batch", IMU_BATCH),
    Schema(3, "odom_increment", ODOM_INCREMENT),
    Schema(4, "ground_truth", GROUND_TRUTH),
    Schema(5, "scan", SCAN),
    # v2 added turn_ahead and body_turn_deg_s, v4 predictive, v5 gravity
    Schema(6, "hazard", HAZARD, version=5),
    # v3 added status
    Schema(7, "pose", POSE, version=4),
    # v3 added floor, status and route
    Schema(8, "route_state", ROUTE_STATE, version=3),
    Schema(9, "haptic_intent", HAPTIC_INTENT, 256),
    # v3 added notice
    Schema(10, "speech_intent", SPEECH_INTENT, 16 * 1024, version=3),
    Schema(11, "applied", APPLIED),
    # v3 added Cancel and Floor, v4 Door, v5 Place
    Schema(12, "command", COMMAND, version=5),
    # v3 added missed (per stream)
    Schema(13, "health_stats", HEALTH_STATS, 256 * 1024, version=3),
    Schema(14, "destinations", DESTINATIONS, 256 * 1024),
    Schema(15, "phone_haptic", PHONE_HAPTIC, 1024),
    Schema(16, "phone_speech", PHONE_SPEECH, 16 * 1024),
    Schema(17, "phone_ack", PHONE_ACK, 1024),
    Schema(18, "phone_motion", PHONE_MOTION, 1024),
    Schema(19, "pressure", PRESSURE, 1024),
    Schema(20, "camera_place", CAMERA_PLACE, 1024),
)
