//! `wearnav record`, `replay` and `inspect`: a bus session in an MCAP file
//! (<https://mcap.dev>), so a walk can be looked at, shared and run again.
//!
//! Conventions (docs/recording.md): one MCAP channel per key expression (and per schema
//! seen on it), topic = the key; every message is the payload exactly as it crossed the
//! bus (the `schemas` envelope, bincode body and CRC), message encoding
//! [`MESSAGE_ENCODING`]; the schema is named as the Zenoh encoding names it
//! (`wearnav/<name>/v<version>`) from the payload's own header, or [`UNKNOWN_SCHEMA`]
//! when the header does not decode (recorded all the same: nothing is lost); the Zenoh
//! encoding the sample carried is kept in the channel's metadata under
//! [`ZENOH_ENCODING`], and replay sends it again. `log_time` is the arrival time at the
//! recorder, `publish_time` the header's capture time (the arrival time when the header
//! does not decode), `sequence` the header's sequence number (its low 32 bits).
//! Hazards, haptic and speech intents also get a decoded JSON twin on `<key>/json`
//! for tools that read JSON but not the wire, and the scan, the pose, the route, the
//! hazard and the camera's place a Foxglove twin on `<key>/foxglove` (`foxglove.LaserScan`,
//! `foxglove.PoseInFrame`, `foxglove.PosesInFrame`, `foxglove.FrameTransform`, JSON) that
//! Foxglove draws; replay leaves the twins out.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::hash::BuildHasher;
use std::io::{BufWriter, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context};
use bus::{BusOptions, Shutdown};
use schemas::guard::Guard;
use zenoh::key_expr::KeyExpr;

/// MCAP message encoding of every recorded payload: the wearnav wire format.
pub const MESSAGE_ENCODING: &str = "wearnav-bincode";
/// Schema name of payloads whose header did not decode (unknown schema or version,
/// damaged).
pub const UNKNOWN_SCHEMA: &str = "unknown";
/// Channel metadata key holding the Zenoh encoding the samples carried.
pub const ZENOH_ENCODING: &str = "zenoh_encoding";
/// Suffix of the topic of a key's JSON twin (`wearnav/<user>/perception/hazard/json`).
pub const JSON_SUFFIX: &str = "/json";
/// Suffix of the topic of a key's Foxglove twin (`wearnav/<user>/perception/scan/foxglove`).
pub const FOXGLOVE_SUFFIX: &str = "/foxglove";

/// Bytes of messages buffered in a chunk before it is compressed and written: an
/// interrupted recording loses at most this much (about half a second of the demo).
const CHUNK_BYTES: u64 = 1 << 20;

/// Record a user's bus traffic into an MCAP file.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    #[command(flatten)]
    pub bus: BusOptions,
    /// The MCAP file to write (replaced if it exists).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// How long to record (`30s`, `5m`); without it, until Ctrl-C.
    #[arg(long, value_parser = humantime::parse_duration)]
    pub duration: Option<Duration>,
    /// Which keys, as a Zenoh key expression under the user's prefix `wearnav/<user>/`
    /// (`sensor/**`, `perception/*`).
    #[arg(long, value_name = "GLOB", default_value = "**")]
    pub keys: String,
    /// Start a new file once the current one holds this many megabytes of payload: the
    /// files are then numbered (`walk.mcap` becomes `walk-000.mcap`, `walk-001.mcap`, ...).
    #[arg(long, value_name = "MB")]
    pub split_size_mb: Option<f64>,
    /// Start a new file after this long (`10m`), numbered as with --split-size-mb.
    #[arg(long, value_name = "DURATION", value_parser = humantime::parse_duration)]
    pub split_every: Option<Duration>,
    /// Also record every N-th depth frame (by its sequence number) as a
    /// `foxglove.PointCloud` on `<key>/foxglove`: 15 is two clouds a second of a 30 Hz
    /// camera; 0 records none. Each cloud is about 0.3 MB (see --cloud-stride).
    #[arg(long, value_name = "N", default_value_t = 15)]
    pub cloud_every: u64,
    /// Take every PX-th pixel across and down into a point cloud: 4 makes 19,200 points
    /// of a 640 x 480 frame; 1 all of them (16 times the bytes).
    #[arg(long, value_name = "PX", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub cloud_stride: u32,
    /// The floor map the compute agent navigates with (a building manifest or its
    /// directory, as for `compute-agent --map`): each floor is written as a
    /// `foxglove.Grid` on `wearnav/<user>/map/floor<level>/foxglove` at the start of
    /// every file, so Foxglove draws the pose and route on it. The map is not on the
    /// bus; without this option the recording has none.
    #[arg(long, value_name = "PATH")]
    pub map: Option<PathBuf>,
}

/// Republish a recorded session on the bus with its original timing.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The MCAP file `wearnav record` wrote.
    pub file: PathBuf,
    /// Speed: 2.0 replays twice as fast, 0.5 at half speed.
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// Start again from the beginning at the end, until Ctrl-C. Receivers that check
    /// sequence numbers (every agent) refuse the rounds after the first as replayed,
    /// unless --restamp.
    #[arg(long = "loop")]
    pub repeat: bool,
    /// Which keys, as a Zenoh key expression under the recorded user's prefix
    /// `wearnav/<user>/` (`sensor/**`).
    #[arg(long, value_name = "GLOB", default_value = "**")]
    pub keys: String,
    /// Move every stamp (capture stamps, and the stamps inside IMU, odometry and
    /// feedback messages) to the replay's clock, all by the same amount at --rate 1, and
    /// give each publisher a new session every round, so running agents take the
    /// recorded walk as live input instead of refusing it as stale and replayed, and a
    /// fresh compute agent given a recording's sensors perceives exactly what the
    /// original did (docs/recording.md). For development: it defeats the agents' guard
    /// against exactly this.
    #[arg(long)]
    pub restamp: bool,
    /// Zenoh JSON5 configuration file (default: $ZENOH_CONFIG, else peer mode with
    /// multicast scouting).
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
    /// Endpoint to connect to, e.g. `tcp/192.168.1.20:7447` (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Endpoint to listen on, e.g. `tcp/0.0.0.0:7447` (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Turn multicast scouting off.
    #[arg(long)]
    pub no_multicast: bool,
}

/// Summarise a recorded session per key.
#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    /// The MCAP file.
    pub file: PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// One sample as it arrived.
struct Arrival {
    arrival_ns: u64,
    key: String,
    encoding: String,
    payload: Vec<u8>,
}

/// What the recorder writes beside the wire messages, besides the JSON and Foxglove
/// twins every file gets.
struct Extras {
    /// A point cloud of each depth frame whose sequence number is a multiple of this
    /// (0: none).
    cloud_every: u64,
    /// Pixel step of a point cloud, across and down.
    cloud_stride: usize,
    /// (topic, floor plan) of each floor of the map, written first in every file as a
    /// `foxglove.Grid`.
    grids: Vec<(String, map::OccupancyGrid)>,
    /// The decoder's output, kept between frames.
    depth: Vec<u16>,
}

/// One MCAP file being written and the channels it has opened.
struct Recording {
    path: PathBuf,
    opened: Instant,
    writer: mcap::Writer<BufWriter<File>>,
    /// (key, schema, Zenoh encoding) -> channel id
    channels: HashMap<(String, String, String), u16>,
    payload_bytes: u64,
}

impl Recording {
    fn create(path: &Path, extras: &Extras) -> anyhow::Result<Self> {
        let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        let writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Lz4))
            .chunk_size(Some(CHUNK_BYTES))
            .profile("wearnav")
            .create(BufWriter::new(file))
            .with_context(|| format!("cannot start the MCAP file {}", path.display()))?;
        let mut recording = Self {
            path: path.to_path_buf(),
            opened: Instant::now(),
            writer,
            channels: HashMap::new(),
            payload_bytes: 0,
        };
        let now = bus::now_ns();
        let header = mcap::records::MessageHeader { channel_id: 0, sequence: 0, log_time: now, publish_time: now };
        for (topic, grid) in &extras.grids {
            recording.write_twin(topic, "foxglove.Grid", header, &grid_json(grid, now))?;
        }
        Ok(recording)
    }

    /// Write a Foxglove twin (JSON with Foxglove's schema `name`) on `topic`.
    fn write_twin(
        &mut self,
        topic: &str,
        name: &str,
        header: mcap::records::MessageHeader,
        json: &[u8],
    ) -> anyhow::Result<()> {
        let id = (topic.to_string(), name.to_string(), "json".to_string());
        let channel_id = match self.channels.get(&id) {
            Some(&c) => c,
            None => {
                let schema_id = self.writer.add_schema(name, "jsonschema", foxglove_schema(name).as_bytes())?;
                let c = self.writer.add_channel(schema_id, &id.0, "json", &BTreeMap::new())?;
                self.channels.insert(id, c);
                c
            }
        };
        self.writer.write_to_known_channel(&mcap::records::MessageHeader { channel_id, ..header }, json)?;
        Ok(())
    }

    /// Write the summary and footer: the file is complete.
    fn finish(mut self) -> anyhow::Result<PathBuf> {
        self.writer.finish().with_context(|| format!("cannot finish {}", self.path.display()))?;
        Ok(self.path)
    }

    fn write(
        &mut self,
        arrival: &Arrival,
        header: Option<&schemas::Header>,
        extras: &mut Extras,
    ) -> anyhow::Result<()> {
        let schema = header
            .and_then(|h| schemas::SchemaId::from_u16(h.schema))
            .map_or_else(|| UNKNOWN_SCHEMA.to_string(), |s| s.encoding_schema());
        let id = (arrival.key.clone(), schema, arrival.encoding.clone());
        let channel_id = match self.channels.get(&id) {
            Some(&c) => c,
            None => {
                // The layout is the `schemas` crate's (docs/wire.md), not an MCAP
                // schema language: the schema record names it and carries no data.
                let schema_id = self.writer.add_schema(&id.1, "", &[])?;
                let metadata = BTreeMap::from([(ZENOH_ENCODING.to_string(), id.2.clone())]);
                let c = self.writer.add_channel(schema_id, &id.0, MESSAGE_ENCODING, &metadata)?;
                self.channels.insert(id, c);
                c
            }
        };
        let message = mcap::records::MessageHeader {
            channel_id,
            sequence: header.map_or(0, |h| h.seq as u32),
            log_time: arrival.arrival_ns,
            publish_time: header.map_or(arrival.arrival_ns, |h| h.capture_ns),
        };
        self.writer.write_to_known_channel(&message, &arrival.payload)?;
        self.payload_bytes += arrival.payload.len() as u64;
        let schema = header.and_then(|h| schemas::SchemaId::from_u16(h.schema));
        if let Some(json) = schema.and_then(|s| as_json(s, &arrival.payload)) {
            let topic = format!("{}{JSON_SUFFIX}", arrival.key);
            let id = (topic, "json".to_string(), String::new());
            let channel_id = match self.channels.get(&id) {
                Some(&c) => c,
                None => {
                    let c = self.writer.add_channel(0, &id.0, "json", &BTreeMap::new())?;
                    self.channels.insert(id, c);
                    c
                }
            };
            self.writer.write_to_known_channel(&mcap::records::MessageHeader { channel_id, ..message }, &json)?;
        }
        let topic = || format!("{}{FOXGLOVE_SUFFIX}", arrival.key);
        if let Some((name, json)) = schema.and_then(|s| as_foxglove(s, &arrival.payload)) {
            self.write_twin(&topic(), name, message, &json)?;
        }
        let cloud_due = extras.cloud_every > 0 && header.is_some_and(|h| h.seq % extras.cloud_every == 0);
        if cloud_due && schema == Some(schemas::SchemaId::DepthFrame) {
            if let Some(json) = point_cloud(&arrival.payload, extras.cloud_stride, &mut extras.depth) {
                self.write_twin(&topic(), "foxglove.PointCloud", message, &json)?;
            }
        }
        Ok(())
    }
}

/// A capture stamp as Foxglove's time.
fn foxglove_time(capture_ns: u64) -> serde_json::Value {
    serde_json::json!({ "sec": capture_ns / 1_000_000_000, "nsec": capture_ns % 1_000_000_000 })
}

/// A pose in the floor's plane (z = 0), turned `yaw` about z.
fn foxglove_pose(x: f64, y: f64, yaw: f64) -> serde_json::Value {
    serde_json::json!({
        "position": { "x": x, "y": y, "z": 0.0 },
        "orientation": { "x": 0.0, "y": 0.0, "z": (yaw / 2.0).sin(), "w": (yaw / 2.0).cos() },
    })
}

/// The scan, the pose and the route also as Foxglove's well-known types, JSON-encoded,
/// so Foxglove draws them: `foxglove.LaserScan` in the user frame (`wearnav_user`: x
/// forward, y left; a bin that saw nothing has range 0, which Foxglove draws at the
/// origin), `foxglove.PoseInFrame` and `foxglove.PosesInFrame` (the route ahead, each
/// point facing the next) in the map frame (`map`, the floor's plane; z = 0); each
/// hazard's floor plane as the `foxglove.FrameTransform` from the user frame to the
/// camera's (`wearnav_camera`, the point clouds' frame); and each frame's camera place
/// (`localization/camera`) as the `foxglove.FrameTransform` from the map to the user
/// frame, so the scan and the point cloud are drawn on the map.
fn as_foxglove(schema: schemas::SchemaId, payload: &[u8]) -> Option<(&'static str, Vec<u8>)> {
    let (stamp, pose) = (foxglove_time, foxglove_pose);
    let value = match schema {
        schemas::SchemaId::Scan => {
            let (header, scan) = schemas::decode::<schemas::Scan>(payload).ok()?;
            let start = f64::from(scan.angle_min_deg).to_radians();
            let step = f64::from(scan.angle_increment_deg).to_radians();
            let last = scan.ranges_m.len().saturating_sub(1) as f64;
            let ranges: Vec<f64> =
                scan.ranges_m.iter().map(|&r| if r.is_finite() && r >= 0.0 { f64::from(r) } else { 0.0 }).collect();
            (
                "foxglove.LaserScan",
                serde_json::json!({
                    "timestamp": stamp(header.capture_ns),
                    "frame_id": "wearnav_user",
                    "pose": pose(0.0, 0.0, 0.0),
                    "start_angle": start,
                    "end_angle": start + step * last,
                    "ranges": ranges,
                    "intensities": [],
                }),
            )
        }
        schemas::SchemaId::Pose => {
            let (header, p) = schemas::decode::<schemas::Pose>(payload).ok()?;
            if !(p.x_m.is_finite() && p.y_m.is_finite() && p.yaw_rad.is_finite()) {
                return None;
            }
            (
                "foxglove.PoseInFrame",
                serde_json::json!({
                    "timestamp": stamp(header.capture_ns),
                    "frame_id": "map",
                    "pose": pose(f64::from(p.x_m), f64::from(p.y_m), f64::from(p.yaw_rad)),
                }),
            )
        }
        schemas::SchemaId::RouteState => {
            // the route ahead, each point facing the next (the last one the way it came)
            let (header, r) = schemas::decode::<schemas::RouteState>(payload).ok()?;
            let points: Vec<(f64, f64)> = r
                .route
                .iter()
                .filter(|p| p.x_m.is_finite() && p.y_m.is_finite())
                .map(|p| (f64::from(p.x_m), f64::from(p.y_m)))
                .collect();
            let mut yaw = 0.0;
            let poses: Vec<_> = (0..points.len())
                .map(|i| {
                    if let Some(next) = points.get(i + 1) {
                        yaw = (next.1 - points[i].1).atan2(next.0 - points[i].0);
                    }
                    pose(points[i].0, points[i].1, yaw)
                })
                .collect();
            (
                "foxglove.PosesInFrame",
                serde_json::json!({
                    "timestamp": stamp(header.capture_ns),
                    "frame_id": "map",
                    "poses": poses,
                }),
            )
        }
        schemas::SchemaId::Hazard => {
            // the frame the scan is in, from the floor the frame's perception used
            let (header, h) = schemas::decode::<schemas::Hazard>(payload).ok()?;
            let (translation, rotation) = camera_in_user_frame(h.plane_camera)?;
            (
                "foxglove.FrameTransform",
                serde_json::json!({
                    "timestamp": stamp(header.capture_ns),
                    "parent_frame_id": "wearnav_user",
                    "child_frame_id": "wearnav_camera",
                    "translation": { "x": translation[0], "y": translation[1], "z": translation[2] },
                    "rotation": { "x": rotation[0], "y": rotation[1], "z": rotation[2], "w": rotation[3] },
                }),
            )
        }
        schemas::SchemaId::CameraPlace => {
            // the scan's frame on the map: the floor below the camera, turned to its view
            let (header, c) = schemas::decode::<schemas::CameraPlace>(payload).ok()?;
            let yaw = f64::from(c.yaw_rad);
            (
                "foxglove.FrameTransform",
                serde_json::json!({
                    "timestamp": stamp(header.capture_ns),
                    "parent_frame_id": "map",
                    "child_frame_id": "wearnav_user",
                    "translation": { "x": f64::from(c.x_m), "y": f64::from(c.y_m), "z": 0.0 },
                    "rotation": { "x": 0.0, "y": 0.0, "z": (yaw / 2.0).sin(), "w": (yaw / 2.0).cos() },
                }),
            )
        }
        _ => return None,
    };
    Some((value.0, serde_json::to_vec(&value.1).ok()?))
}

/// Where the camera is in the user frame the scan is in (x forward, y left, z up, on the
/// floor below the camera: [`perception::nearest_scan::UserFrame`]), from the floor
/// plane `[a, b, c, d]` in the camera's optical frame: its place (`[0, 0, d]`) and its
/// orientation as a quaternion `[x, y, z, w]`. None for a plane that is none (not a unit
/// normal, the camera not above it, or looking straight along it).
fn camera_in_user_frame(plane_camera: [f32; 4]) -> Option<([f64; 3], [f64; 4])> {
    let [a, b, c, d] = plane_camera;
    let unit = (a * a + b * b + c * c).sqrt();
    if !(d.is_finite() && d > 0.0 && (unit - 1.0).abs() < 1e-3) {
        return None;
    }
    let plane = perception::ground_plane::Plane { normal: [a, b, c], offset_m: d };
    let frame = perception::nearest_scan::UserFrame::from_plane(&plane)?;
    // rows: the user's axes in camera coordinates, so columns: the camera's in the user's
    let [f, l, n] = [frame.forward, frame.left, plane.normal].map(|row| row.map(f64::from));
    let m = nalgebra::Matrix3::new(f[0], f[1], f[2], l[0], l[1], l[2], n[0], n[1], n[2]);
    // the nearest rotation (the f32 axes are orthonormal to about 1e-7)
    let q = nalgebra::UnitQuaternion::from_matrix(&m);
    Some(([0.0, 0.0, f64::from(d)], [q.i, q.j, q.k, q.w]))
}

/// A depth frame as a `foxglove.PointCloud` in the camera's optical frame
/// (`wearnav_camera`: x right, y down, z forward, metres): every `stride`-th pixel across
/// and down that holds a depth, as float32 x, y, z. None when the frame does not decode.
fn point_cloud(payload: &[u8], stride: usize, depth: &mut Vec<u16>) -> Option<Vec<u8>> {
    use base64::Engine as _;
    let (header, frame) = schemas::decode::<schemas::DepthFrame>(payload).ok()?;
    let k = frame.intrinsics;
    if !(k.is_valid() && frame.depth_scale_m.is_finite() && frame.depth_scale_m > 0.0) {
        return None;
    }
    schemas::depth_codec::decode(&frame.data, frame.width, frame.height, frame.encoding, depth).ok()?;
    let (width, height) = (frame.width as usize, frame.height as usize);
    let mut data = Vec::with_capacity((width / stride + 1) * (height / stride + 1) * 12);
    for v in (0..height).step_by(stride) {
        for u in (0..width).step_by(stride) {
            let raw = depth[v * width + u];
            if raw == 0 {
                continue;
            }
            let z = f32::from(raw) * frame.depth_scale_m;
            let x = (u as f32 - k.cx) * z / k.fx;
            let y = (v as f32 - k.cy) * z / k.fy;
            for c in [x, y, z] {
                data.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    let field = |name: &str, offset: u32| serde_json::json!({ "name": name, "offset": offset, "type": FLOAT32 });
    let value = serde_json::json!({
        "timestamp": foxglove_time(header.capture_ns),
        "frame_id": "wearnav_camera",
        "pose": foxglove_pose(0.0, 0.0, 0.0),
        "point_stride": 12,
        "fields": [field("x", 0), field("y", 4), field("z", 8)],
        "data": base64::engine::general_purpose::STANDARD.encode(&data),
    });
    serde_json::to_vec(&value).ok()
}

/// Foxglove's `NumericType` of an int8 and a float32 field.
const INT8: u32 = 2;
const FLOAT32: u32 = 7;

/// A floor's occupancy grid as a `foxglove.Grid` in the map frame, one int8 a cell as
/// ROS maps have them (0 free, 100 occupied, -1 unknown), row 0 at the bottom, placed at
/// the map's origin.
fn grid_json(grid: &map::OccupancyGrid, stamp_ns: u64) -> Vec<u8> {
    use base64::Engine as _;
    let data: Vec<u8> = grid
        .cells()
        .iter()
        .map(|c| match c {
            map::Cell::Free => 0u8,
            map::Cell::Occupied => 100,
            map::Cell::Unknown => (-1i8) as u8,
        })
        .collect();
    let origin = grid.origin();
    let value = serde_json::json!({
        "timestamp": foxglove_time(stamp_ns),
        "frame_id": "map",
        "pose": foxglove_pose(origin.x_m, origin.y_m, origin.yaw_rad),
        "column_count": grid.width(),
        "cell_size": { "x": grid.resolution_m(), "y": grid.resolution_m() },
        "row_stride": grid.width(),
        "cell_stride": 1,
        "fields": [{ "name": "occupancy", "offset": 0, "type": INT8 }],
        "data": base64::engine::general_purpose::STANDARD.encode(&data),
    });
    serde_json::to_vec(&value).expect("a grid serialises")
}

/// The JSON schema recorded with a Foxglove twin: the fields we write, by their
/// Foxglove names (Foxglove knows the type by the schema's name).
fn foxglove_schema(name: &str) -> String {
    let time = r#"{"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}}"#;
    let xyz = r#"{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}}"#;
    let quat = r#"{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}}"#;
    let pose = format!(r#"{{"type":"object","properties":{{"position":{xyz},"orientation":{quat}}}}}"#);
    let numbers = r#"{"type":"array","items":{"type":"number"}}"#;
    let integer = r#"{"type":"integer","minimum":0}"#;
    let bytes = r#"{"type":"string","contentEncoding":"base64"}"#;
    let packed = format!(
        r#"{{"type":"array","items":{{"type":"object","properties":{{"name":{{"type":"string"}},"offset":{integer},"type":{integer}}}}}}}"#
    );
    let fields = match name {
        "foxglove.PointCloud" => {
            format!(r#""pose":{pose},"point_stride":{integer},"fields":{packed},"data":{bytes}"#)
        }
        "foxglove.Grid" => format!(
            r#""pose":{pose},"column_count":{integer},"cell_size":{{"type":"object","properties":{{"x":{{"type":"number"}},"y":{{"type":"number"}}}}}},"row_stride":{integer},"cell_stride":{integer},"fields":{packed},"data":{bytes}"#
        ),
        "foxglove.LaserScan" => format!(
            r#""pose":{pose},"start_angle":{{"type":"number"}},"end_angle":{{"type":"number"}},"ranges":{numbers},"intensities":{numbers}"#
        ),
        "foxglove.PosesInFrame" => format!(r#""poses":{{"type":"array","items":{pose}}}"#),
        _ => format!(r#""pose":{pose}"#),
    };
    if name == "foxglove.FrameTransform" {
        return format!(
            r#"{{"title":"{name}","type":"object","properties":{{"timestamp":{time},"parent_frame_id":{{"type":"string"}},"child_frame_id":{{"type":"string"}},"translation":{xyz},"rotation":{quat}}}}}"#
        );
    }
    format!(
        r#"{{"title":"{name}","type":"object","properties":{{"timestamp":{time},"frame_id":{{"type":"string"}},{fields}}}}}"#
    )
}

/// Hazards, haptic and speech intents also as JSON (`{"header": .., "body": ..}`, as
/// serde writes them; non-finite numbers as `null`), for tools that read JSON but not
/// our wire (Foxglove's plots and raw messages); None for other schemas and for
/// payloads that do not decode.
fn as_json(schema: schemas::SchemaId, payload: &[u8]) -> Option<Vec<u8>> {
    // serialised straight from the types, so an f32 is written as the shortest text
    // that reads back to it, as serde_json and the Python decoder write it
    #[derive(serde::Serialize)]
    struct Twin<M> {
        header: schemas::Header,
        body: M,
    }
    fn json<M: schemas::Message>(payload: &[u8]) -> Option<Vec<u8>> {
        let (header, body) = schemas::decode::<M>(payload).ok()?;
        serde_json::to_vec(&Twin { header, body }).ok()
    }
    match schema {
        schemas::SchemaId::Hazard => json::<schemas::Hazard>(payload),
        schemas::SchemaId::HapticIntent => json::<schemas::HapticIntent>(payload),
        schemas::SchemaId::SpeechIntent => json::<schemas::SpeechIntent>(payload),
        _ => None,
    }
}

/// When to start a new file, and what to call each.
struct Rotation {
    out: PathBuf,
    max_bytes: Option<u64>,
    max_age: Option<Duration>,
}

impl Rotation {
    /// `--out` as given, or numbered (`walk-000.mcap`, `walk-001.mcap`, ...) when
    /// files rotate.
    fn path(&self, index: usize) -> PathBuf {
        if self.max_bytes.is_none() && self.max_age.is_none() {
            return self.out.clone();
        }
        let stem = self.out.file_stem().map_or_else(|| "recording".into(), |s| s.to_string_lossy());
        let ext = self.out.extension().map_or_else(|| "mcap".into(), |e| e.to_string_lossy());
        self.out.with_file_name(format!("{stem}-{index:03}.{ext}"))
    }

    fn due(&self, current: &Recording) -> bool {
        self.max_bytes.is_some_and(|b| current.payload_bytes >= b)
            || self.max_age.is_some_and(|a| current.opened.elapsed() >= a)
    }
}

/// The file being written, the files finished before it, and the totals.
struct Recorder {
    rotation: Rotation,
    extras: Extras,
    current: Recording,
    finished: Vec<PathBuf>,
    messages: u64,
    payload_bytes: u64,
    /// Sequence numbers per publisher (no freshness: a recorder keeps what comes).
    sequence: Guard,
    /// Per key, messages its publishers numbered that never reached the recorder.
    lost: BTreeMap<String, u64>,
}

impl Recorder {
    fn start(rotation: Rotation, extras: Extras) -> anyhow::Result<Self> {
        let current = Recording::create(&rotation.path(0), &extras)?;
        Ok(Self {
            rotation,
            extras,
            current,
            finished: Vec::new(),
            messages: 0,
            payload_bytes: 0,
            sequence: Guard::new(None),
            lost: BTreeMap::new(),
        })
    }

    fn write(&mut self, arrival: &Arrival) -> anyhow::Result<()> {
        if self.rotation.due(&self.current) {
            let next = Recording::create(&self.rotation.path(self.finished.len() + 1), &self.extras)?;
            let done = std::mem::replace(&mut self.current, next);
            self.finished.push(done.finish()?);
        }
        let header = schemas::decode_header(&arrival.payload).ok().map(|(h, _)| h);
        self.current.write(arrival, header.as_ref(), &mut self.extras)?;
        self.messages += 1;
        self.payload_bytes += arrival.payload.len() as u64;
        // a number seen before (a replay on the bus) is recorded all the same
        if let Some(Ok(lost)) = header.map(|h| self.sequence.check(&arrival.key, &h, arrival.arrival_ns, 0)) {
            if lost > 0 {
                *self.lost.entry(arrival.key.clone()).or_default() += lost;
            }
        }
        Ok(())
    }

    /// Messages lost on the way to the recorder, all keys.
    fn lost_total(&self) -> u64 {
        self.lost.values().sum()
    }

    /// Finish the current file; every file written, in order.
    fn finish(mut self) -> anyhow::Result<Vec<PathBuf>> {
        self.finished.push(self.current.finish()?);
        Ok(self.finished)
    }
}

/// Writes what the subscription delivers until `stop`, with a progress line a second.
fn write_loop(mut recording: Recorder, rx: mpsc::Receiver<Arrival>, stop: Arc<AtomicBool>) -> anyhow::Result<Recorder> {
    let started = Instant::now();
    let mut next_report = started + Duration::from_secs(1);
    let mut in_period = 0u64;
    let mut period_start = started;
    loop {
        match rx.recv_timeout(Duration::from_millis(100)) {
            Ok(arrival) => {
                recording
                    .write(&arrival)
                    .context("writing the recording failed (`wearnav inspect` reads what was written before)")?;
                in_period += 1;
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
        let now = Instant::now();
        if now >= next_report {
            let rate = in_period as f64 / (now - period_start).as_secs_f64();
            eprintln!(
                "[{:6.1}s] {} messages, {:.1} MB, {:.0} msgs/s, {} lost on the way",
                (now - started).as_secs_f64(),
                recording.messages,
                recording.payload_bytes as f64 / 1e6,
                rate,
                recording.lost_total()
            );
            (in_period, period_start, next_report) = (0, now, next_report + Duration::from_secs(1));
        }
        if stop.load(Ordering::Relaxed) {
            // what already arrived is kept
            while let Ok(arrival) = rx.try_recv() {
                recording
                    .write(&arrival)
                    .context("writing the recording failed (`wearnav inspect` reads what was written before)")?;
            }
            break;
        }
    }
    Ok(recording)
}

/// `wearnav record`: Ok once the file is complete (summary and footer written).
pub async fn record(args: RecordArgs) -> anyhow::Result<()> {
    let keys = args.bus.keys()?;
    let key_expr = format!("{}/{}", keys.prefix(), args.keys);
    KeyExpr::try_from(key_expr.clone()).map_err(|e| anyhow!("bad --keys {:?}: {e}", args.keys))?;
    let max_bytes = match args.split_size_mb {
        Some(mb) if mb.is_finite() && mb > 0.0 => Some((mb * 1e6) as u64),
        Some(mb) => bail!("--split-size-mb must be a positive number, not {mb}"),
        None => None,
    };
    if args.split_every.is_some_and(|d| d.is_zero()) {
        bail!("--split-every must be longer than zero");
    }
    let grids = match &args.map {
        Some(path) => {
            let building = compute_agent::nav::load_building(path)?;
            building
                .floors()
                .iter()
                .map(|f| (format!("{}/map/floor{}{FOXGLOVE_SUFFIX}", keys.prefix(), f.level), f.grid.clone()))
                .collect()
        }
        None => Vec::new(),
    };
    let extras =
        Extras { cloud_every: args.cloud_every, cloud_stride: args.cloud_stride as usize, grids, depth: Vec::new() };
    let recording = Recorder::start(Rotation { out: args.out.clone(), max_bytes, max_age: args.split_every }, extras)?;
    let session = bus::open_session(&args.bus).await?;
    let (tx, rx) = mpsc::channel();
    let subscriber = session
        .declare_subscriber(key_expr.clone())
        .callback(move |sample| {
            let _ = tx.send(Arrival {
                arrival_ns: bus::now_ns(),
                key: sample.key_expr().as_str().to_string(),
                encoding: sample.encoding().to_string(),
                payload: sample.payload().to_bytes().into_owned(),
            });
        })
        .await
        .map_err(|e| anyhow!("cannot subscribe {key_expr}: {e}"))?;
    eprintln!("recording {key_expr} into {}", recording.current.path.display());
    let stop = Arc::new(AtomicBool::new(false));
    let mut writer = tokio::task::spawn_blocking({
        let stop = stop.clone();
        move || write_loop(recording, rx, stop)
    });
    let shutdown = Shutdown::new();
    shutdown.trigger_on_signals();
    let deadline = async {
        match args.duration {
            Some(d) => tokio::time::sleep(d).await,
            None => std::future::pending().await,
        }
    };
    let early = tokio::select! {
        _ = shutdown.triggered() => None,
        _ = deadline => None,
        done = &mut writer => Some(done),
    };
    stop.store(true, Ordering::Relaxed);
    let _ = subscriber.undeclare().await;
    let done = match early {
        Some(done) => done,
        None => writer.await,
    };
    let mut recording = done.context("the recording's writer stopped")??;
    let (messages, payload_bytes) = (recording.messages, recording.payload_bytes);
    let lost_total = recording.lost_total();
    let lost = std::mem::take(&mut recording.lost);
    let files = recording.finish()?;
    let _ = session.close().await;
    let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    eprintln!(
        "recorded {messages} messages, {:.1} MB of payload, into {}",
        payload_bytes as f64 / 1e6,
        names.join(", ")
    );
    if !lost.is_empty() {
        let per_key: Vec<String> = lost.iter().map(|(k, n)| format!("{n} on {k}")).collect();
        eprintln!(
            "not recorded: {lost_total} messages lost on the way to the recorder (gaps in their publishers' numbering): {}",
            per_key.join(", ")
        );
    }
    Ok(())
}

/// A recorded message, as replay and inspect use it.
struct Recorded {
    topic: String,
    /// The schema's name; the message encoding for a channel without one (`json`).
    schema: String,
    message_encoding: String,
    zenoh_encoding: String,
    sequence: u32,
    log_time: u64,
    data: Vec<u8>,
}

/// Records larger than this are taken for damage (a corrupted length), not allocated:
/// 16 times our chunks, and over 4000 times the largest message the wire allows.
const RECORD_LIMIT_BYTES: usize = 16 * CHUNK_BYTES as usize;

/// Stream every message of `path`, in file order, into `each` (which may stop the
/// reading by returning false). A file that is not MCAP at all is an error; of a damaged
/// or truncated one, what precedes the damage is read, and the damage is returned.
/// Only a chunk at a time is held in memory.
fn read(path: &Path, mut each: impl FnMut(Recorded) -> bool) -> anyhow::Result<Option<String>> {
    let mut file = File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut magic = [0u8; 8];
    let is_mcap = file.read_exact(&mut magic).is_ok() && magic == *mcap::MAGIC;
    if !is_mcap {
        bail!("{} is not an MCAP file (it does not start with the MCAP magic)", path.display());
    }
    let len = file.seek(SeekFrom::End(0))?;
    file.seek(SeekFrom::Start(len.saturating_sub(8)))?;
    let ends_well = file.read_exact(&mut magic).is_ok() && magic == *mcap::MAGIC && len >= 16;
    file.seek(SeekFrom::Start(0))?;
    let options = mcap::sans_io::LinearReaderOptions::default()
        .with_skip_end_magic(!ends_well)
        .with_validate_chunk_crcs(true)
        .with_record_length_limit(RECORD_LIMIT_BYTES);
    let mut count = 0u64;
    for message in mcap::io::MessageReader::new_with_options(std::io::BufReader::new(file), options) {
        let m = match message {
            Ok(m) => m,
            Err(e) => return Ok(Some(format!("damaged after message {count}: {e}"))),
        };
        count += 1;
        let recorded = Recorded {
            topic: m.channel.topic.clone(),
            schema: m.channel.schema.as_ref().map_or_else(|| m.channel.message_encoding.clone(), |s| s.name.clone()),
            message_encoding: m.channel.message_encoding.clone(),
            zenoh_encoding: m.channel.metadata.get(ZENOH_ENCODING).cloned().unwrap_or_default(),
            sequence: m.sequence,
            log_time: m.log_time,
            data: m.data.into_owned(),
        };
        if !each(recorded) {
            return Ok(None);
        }
    }
    Ok((!ends_well).then(|| format!("truncated after message {count}: no footer (the recording did not finish)")))
}

/// Figures of one channel.
#[derive(Debug, serde::Serialize)]
struct ChannelSummary {
    key: String,
    schema: String,
    count: u64,
    bytes: u64,
    duration_s: f64,
    rate_hz: f64,
    largest_gap_ms: f64,
    /// Messages whose sequence number was not above the one before on the channel.
    sequence_breaks: u64,
    /// Messages missing from the recording: gaps in the numbering of each publisher
    /// on the key, read from the wire header (0 for channels not of the wire).
    missed: u64,
    #[serde(skip)]
    first_ns: u64,
    #[serde(skip)]
    last_ns: u64,
    #[serde(skip)]
    last_sequence: Option<u32>,
}

/// The whole file's summary.
#[derive(Debug, serde::Serialize)]
struct FileSummary {
    file: String,
    messages: u64,
    bytes: u64,
    duration_s: f64,
    channels: Vec<ChannelSummary>,
    /// Why the file could not be read to its end, if it could not.
    damage: Option<String>,
}

/// Read `path` and summarise it per channel.
fn summarise(path: &Path) -> anyhow::Result<FileSummary> {
    let mut channels: Vec<ChannelSummary> = Vec::new();
    let (mut messages, mut first, mut last) = (0u64, u64::MAX, 0u64);
    let mut numbering = Guard::new(None);
    let damage = read(path, |m| {
        messages += 1;
        (first, last) = (first.min(m.log_time), last.max(m.log_time));
        let index = match channels.iter().position(|c| c.key == m.topic && c.schema == m.schema) {
            Some(i) => i,
            None => {
                channels.push(ChannelSummary {
                    key: m.topic.clone(),
                    schema: m.schema.clone(),
                    count: 0,
                    bytes: 0,
                    duration_s: 0.0,
                    rate_hz: 0.0,
                    largest_gap_ms: 0.0,
                    sequence_breaks: 0,
                    missed: 0,
                    first_ns: m.log_time,
                    last_ns: m.log_time,
                    last_sequence: None,
                });
                channels.len() - 1
            }
        };
        let c = &mut channels[index];
        let gap_ms = m.log_time.saturating_sub(c.last_ns) as f64 / 1e6;
        c.largest_gap_ms = c.largest_gap_ms.max(gap_ms);
        if c.last_sequence.is_some_and(|s| m.sequence <= s) {
            c.sequence_breaks += 1;
        }
        c.last_sequence = Some(m.sequence);
        if m.message_encoding == MESSAGE_ENCODING {
            if let Ok((header, _)) = schemas::decode_header(&m.data) {
                c.missed += numbering.check(&m.topic, &header, m.log_time, 0).unwrap_or(0);
            }
        }
        c.last_ns = c.last_ns.max(m.log_time);
        c.count += 1;
        c.bytes += m.data.len() as u64;
        true
    })?;
    for c in &mut channels {
        c.duration_s = (c.last_ns - c.first_ns) as f64 / 1e9;
        c.rate_hz = if c.count > 1 && c.duration_s > 0.0 { (c.count - 1) as f64 / c.duration_s } else { 0.0 };
    }
    channels.sort_by(|a, b| a.key.cmp(&b.key).then(a.schema.cmp(&b.schema)));
    Ok(FileSummary {
        file: path.display().to_string(),
        messages,
        bytes: channels.iter().map(|c| c.bytes).sum(),
        duration_s: last.saturating_sub(first) as f64 / 1e9,
        channels,
        damage,
    })
}

/// The summary as a table (written, not printed: a closed pipe, `| head`, is an error,
/// not a panic).
fn write_table(out: &mut impl std::io::Write, summary: &FileSummary) -> std::io::Result<()> {
    writeln!(
        out,
        "{}: {} messages, {:.1} MB of payload, {:.1} s",
        summary.file,
        summary.messages,
        summary.bytes as f64 / 1e6,
        summary.duration_s
    )?;
    let width = summary.channels.iter().map(|c| c.key.len()).max().unwrap_or(3).max(3);
    writeln!(
        out,
        "{:<width$}  {:<26} {:>7} {:>8} {:>8} {:>9} {:>11} {:>6} {:>6}",
        "key", "schema", "count", "rate/s", "dur s", "max gap", "bytes", "seq!", "lost"
    )?;
    for c in &summary.channels {
        writeln!(
            out,
            "{:<width$}  {:<26} {:>7} {:>8.1} {:>8.1} {:>6.0} ms {:>11} {:>6} {:>6}",
            c.key, c.schema, c.count, c.rate_hz, c.duration_s, c.largest_gap_ms, c.bytes, c.sequence_breaks, c.missed
        )?;
    }
    Ok(())
}

/// `wearnav inspect`: the summary of what is readable; an error (after the summary)
/// when the file is damaged.
pub fn inspect(args: &InspectArgs) -> anyhow::Result<()> {
    let summary = summarise(&args.file)?;
    let mut out = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut out, &summary)?;
        std::io::Write::write_all(&mut out, b"\n")?;
    } else {
        write_table(&mut out, &summary)?;
    }
    match &summary.damage {
        Some(damage) => bail!("{}: {damage}; the figures above are of what precedes it", args.file.display()),
        None => Ok(()),
    }
}

/// Whether `topic` (`wearnav/<user>/<rest>`) is selected by `glob` (a key expression
/// under the user's prefix).
fn selected(glob: &KeyExpr<'_>, topic: &str) -> bool {
    let rest = topic.splitn(3, '/').nth(2).unwrap_or("");
    KeyExpr::try_from(rest).is_ok_and(|k| glob.intersects(&k))
}

/// `wearnav replay`: republish the recorded payloads, byte for byte, on their keys and
/// with their encodings, at the recorded pace scaled by `--rate`.
pub async fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate must be a positive number, not {}", args.rate);
    }
    let glob = KeyExpr::try_from(args.keys.clone()).map_err(|e| anyhow!("bad --keys {:?}: {e}", args.keys))?;
    // refuse a file that is not MCAP before touching the bus
    read(&args.file, |_| false)?;
    let mut bus = BusOptions::for_user("replay");
    (bus.zenoh_config, bus.connect, bus.listen, bus.no_multicast) =
        (args.zenoh_config.clone(), args.connect.clone(), args.listen.clone(), args.no_multicast);
    let session = bus::open_session(&bus).await?;
    let shutdown = Shutdown::new();
    shutdown.trigger_on_signals();
    let mut player =
        Player { session: &session, publishers: HashMap::new(), restamp: args.restamp, rate: args.rate, waited: false };
    let (mut rounds, mut sent) = (0u64, 0u64);
    loop {
        // the file is read as it is played, a chunk at a time
        let (tx, mut rx) = tokio::sync::mpsc::channel::<Recorded>(1024);
        let (path, glob) = (args.file.clone(), glob.clone().into_owned());
        let reader = tokio::task::spawn_blocking(move || {
            // only the wire's channels: their JSON twins are the recorder's own
            read(&path, |m| {
                m.message_encoding != MESSAGE_ENCODING || !selected(&glob, &m.topic) || tx.blocking_send(m).is_ok()
            })
        });
        let played = player.round(&mut rx, &shutdown).await;
        drop(rx);
        let damage = reader.await.context("the file's reader stopped")??;
        sent += played?;
        if let Some(damage) = damage.filter(|_| rounds == 0) {
            eprintln!("{}: {damage}; replayed what precedes it", args.file.display());
        }
        if sent == 0 {
            bail!("{}: no message matches --keys {:?}", args.file.display(), args.keys);
        }
        rounds += 1;
        if !args.repeat || shutdown.is_triggered() {
            break;
        }
    }
    eprintln!("replayed {sent} messages ({rounds} round(s)) from {}", args.file.display());
    // let the last messages leave before the session goes
    tokio::time::sleep(Duration::from_millis(200)).await;
    let _ = session.close().await;
    Ok(())
}

/// Publishes recorded messages on the bus at their recorded pace.
struct Player<'s> {
    session: &'s zenoh::Session,
    /// (key, Zenoh encoding) -> publisher, declared as keys first appear
    publishers: HashMap<(String, String), zenoh::pubsub::Publisher<'s>>,
    restamp: bool,
    rate: f64,
    /// Whether the wait for a first subscriber is done (once, not every round).
    waited: bool,
}

impl Player<'_> {
    /// Play what `rx` delivers, timed from its first message, until it ends or
    /// shutdown; how many messages were sent.
    async fn round(
        &mut self,
        rx: &mut tokio::sync::mpsc::Receiver<Recorded>,
        shutdown: &Shutdown,
    ) -> anyhow::Result<u64> {
        let mut clock: Option<(tokio::time::Instant, u64)> = None;
        let mut restamp = Restamp::new(self.rate);
        let mut sent = 0;
        while let Some(m) = tokio::select! { m = rx.recv() => m, _ = shutdown.triggered() => None } {
            let id = (m.topic.clone(), m.zenoh_encoding.clone());
            if !self.publishers.contains_key(&id) {
                // Block rather than drop: a replay is only worth its completeness.
                let publisher = self
                    .session
                    .declare_publisher(m.topic.clone())
                    .encoding(zenoh::bytes::Encoding::from(m.zenoh_encoding.clone()))
                    .congestion_control(zenoh::qos::CongestionControl::Block)
                    .express(true)
                    .await
                    .map_err(|e| anyhow!("cannot declare a publisher on {}: {e}", m.topic))?;
                self.publishers.insert(id.clone(), publisher);
            }
            let publisher = &self.publishers[&id];
            let (start, first_ns) = match clock {
                Some(c) => c,
                None => {
                    if !self.waited {
                        wait_for_subscribers(publisher, shutdown).await;
                        self.waited = true;
                    }
                    *clock.insert((tokio::time::Instant::now(), m.log_time))
                }
            };
            let offset_ns = (m.log_time.saturating_sub(first_ns) as f64 / self.rate) as u64;
            tokio::select! {
                _ = tokio::time::sleep_until(start + Duration::from_nanos(offset_ns)) => {}
                _ = shutdown.triggered() => break,
            }
            let payload = match self.restamp {
                true => restamp.payload(&m)?,
                false => m.data,
            };
            publisher.put(payload).await.map_err(|e| anyhow!("publish on {} failed: {e}", m.topic))?;
            sent += 1;
        }
        Ok(sent)
    }
}

/// What `--restamp` does to one round's messages: every stamp moved to the replay's
/// clock by one mapping, and every recorded publisher session replaced by a new one.
struct Restamp {
    rate: f64,
    /// (log time of the round's first message, the replay's clock when it was played)
    clock: Option<(u64, u64)>,
    /// recorded session -> its new one
    sessions: HashMap<u64, u64>,
}

impl Restamp {
    fn new(rate: f64) -> Self {
        Self { rate, clock: None, sessions: HashMap::new() }
    }

    /// A recorded stamp on the replay's clock: `now_at_first + (t - first_log) / rate`,
    /// so at `--rate 1` every stamp moves by the same amount and the intervals between
    /// them, the ages messages arrive with and the order of stamps stay as recorded. A
    /// 0 (no stamp: an effect with no cause) stays 0.
    fn map(&self, t: u64) -> u64 {
        let Some((first_log, now_at_first)) = self.clock else { return t };
        if t == 0 {
            return 0;
        }
        let offset = (t as i128 - first_log as i128) as f64 / self.rate;
        (now_at_first as i128 + offset.round() as i128).max(0) as u64
    }

    /// The recorded payload with its capture stamp, the stamps in its body (IMU
    /// samples, odometry, applied feedback, phone acknowledgements) and its session
    /// moved to the replay (checksum resealed). A payload whose header does not decode
    /// goes out as recorded.
    fn payload(&mut self, m: &Recorded) -> anyhow::Result<Vec<u8>> {
        let Ok((header, used)) = schemas::decode_header(&m.data) else {
            return Ok(m.data.clone());
        };
        let (first_log, now) = *self.clock.get_or_insert((m.log_time, bus::now_ns()));
        let session = *self.sessions.entry(header.session).or_insert_with(|| {
            std::collections::hash_map::RandomState::new().hash_one((header.session, now, first_log))
        });
        let capture_ns = self.map(header.capture_ns);
        let origin = schemas::Origin { sender: &header.sender, session };
        // bodies with stamps of their own: decoded, moved, encoded again
        fn again<M: schemas::Message>(
            data: &[u8],
            origin: &schemas::Origin,
            seq: u64,
            capture_ns: u64,
            mut shift: impl FnMut(&mut M),
        ) -> Option<Vec<u8>> {
            let (_, mut body) = schemas::decode::<M>(data).ok()?;
            shift(&mut body);
            Some(schemas::encode(origin, seq, capture_ns, &body))
        }
        let (seq, map) = (header.seq, |t| self.map(t));
        let rewritten = match schemas::SchemaId::from_u16(header.schema) {
            Some(schemas::SchemaId::ImuBatch) => {
                again(&m.data, &origin, seq, capture_ns, |b: &mut schemas::ImuBatch| {
                    b.samples.iter_mut().for_each(|s| s.stamp_ns = map(s.stamp_ns))
                })
            }
            Some(schemas::SchemaId::OdomIncrement) => {
                again(&m.data, &origin, seq, capture_ns, |o: &mut schemas::OdomIncrement| {
                    (o.from_ns, o.to_ns) = (map(o.from_ns), map(o.to_ns))
                })
            }
            Some(schemas::SchemaId::Applied) => again(&m.data, &origin, seq, capture_ns, |a: &mut schemas::Applied| {
                (a.applied_ns, a.cause_capture_ns) = (map(a.applied_ns), map(a.cause_capture_ns))
            }),
            Some(schemas::SchemaId::PhoneAck) => {
                again(&m.data, &origin, seq, capture_ns, |a: &mut schemas::PhoneAck| a.at_ns = map(a.at_ns))
            }
            _ => None,
        };
        if let Some(out) = rewritten {
            return Ok(out);
        }
        // The envelope ends with session, seq and capture_ns, fixed-width little-endian
        // u64 (bincode's legacy layout, docs/wire.md); the check below proves it for
        // each one.
        let mut out = m.data.clone();
        out[used - 24..used - 16].copy_from_slice(&session.to_le_bytes());
        out[used - 8..used].copy_from_slice(&capture_ns.to_le_bytes());
        schemas::wire::reseal(&mut out);
        match schemas::decode_header(&out) {
            Ok((check, _)) if check == schemas::Header { session, capture_ns, ..header } => Ok(out),
            _ => {
                bail!("cannot restamp a {} message on {}: its envelope is not laid out as expected", m.schema, m.topic)
            }
        }
    }
}

async fn wait_for_subscribers(publisher: &zenoh::pubsub::Publisher<'_>, shutdown: &Shutdown) {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(2);
    while tokio::time::Instant::now() < deadline && !shutdown.is_triggered() {
        if publisher.matching_status().await.is_ok_and(|s| s.matching()) {
            return;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use schemas::{MapPoint, Origin, RouteState, RouteStatus};

    #[test]
    fn a_route_becomes_poses_in_the_map_each_facing_the_next_point() {
        let point = |x_m, y_m| MapPoint { x_m, y_m, floor: 0 };
        let route = RouteState {
            destination: "room 204".into(),
            next_waypoint: Some(point(4.0, 0.0)),
            distance_left_m: 7.0,
            instruction: String::new(),
            floor: 0,
            status: RouteStatus::Guiding,
            route: vec![point(1.0, 0.0), point(4.0, 0.0), point(4.0, 4.0)],
        };
        let payload = schemas::encode(&Origin { sender: "test", session: 1 }, 3, 2_500_000_001, &route);
        let (name, json) = as_foxglove(schemas::SchemaId::RouteState, &payload).expect("a route twin");
        assert_eq!(name, "foxglove.PosesInFrame");
        let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
        assert_eq!((v["timestamp"]["sec"].as_u64(), v["timestamp"]["nsec"].as_u64()), (Some(2), Some(500_000_001)));
        let poses = v["poses"].as_array().unwrap();
        let xy: Vec<_> = poses.iter().map(|p| (p["position"]["x"].as_f64(), p["position"]["y"].as_f64())).collect();
        assert_eq!(xy, [(Some(1.0), Some(0.0)), (Some(4.0), Some(0.0)), (Some(4.0), Some(4.0))]);
        let yaw = |p: &serde_json::Value| {
            2.0 * p["orientation"]["z"].as_f64().unwrap().atan2(p["orientation"]["w"].as_f64().unwrap())
        };
        // east, then north; the last point keeps the way it came
        let yaws: Vec<f64> = poses.iter().map(yaw).collect();
        assert!(yaws[0].abs() < 1e-9 && (yaws[1] - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{yaws:?}");
        assert!((yaws[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{yaws:?}");
        let schema: serde_json::Value = serde_json::from_str(&foxglove_schema(name)).unwrap();
        assert_eq!(schema["title"], "foxglove.PosesInFrame");
        assert!(schema["properties"]["poses"]["items"]["properties"]["orientation"].is_object());
    }

    #[test]
    fn a_hazards_floor_plane_places_the_camera_in_the_user_frame_above_the_floor_looking_down_the_way() {
        // a camera 1.0 m up, pitched 30 degrees down: the floor's upward normal in its
        // optical frame (x right, y down, z forward)
        let (s, c) = 30f32.to_radians().sin_cos();
        let hazard = schemas::Hazard {
            plane_camera: [0.0, -c, -s, 1.0],
            ..schemas::Hazard::nothing_ahead(7, schemas::GroundState::Found)
        };
        let payload = schemas::encode(&schemas::Origin { sender: "test", session: 1 }, 3, 2_500_000_001, &hazard);
        let (name, json) = as_foxglove(schemas::SchemaId::Hazard, &payload).expect("a transform twin");
        assert_eq!(name, "foxglove.FrameTransform");
        let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
        assert_eq!(
            (v["parent_frame_id"].as_str(), v["child_frame_id"].as_str()),
            (Some("wearnav_user"), Some("wearnav_camera"))
        );
        assert_eq!((v["timestamp"]["sec"].as_u64(), v["timestamp"]["nsec"].as_u64()), (Some(2), Some(500_000_001)));
        let t = &v["translation"];
        assert!(t["x"].as_f64() == Some(0.0) && t["y"].as_f64() == Some(0.0), "{t}");
        assert!((t["z"].as_f64().unwrap() - 1.0).abs() < 1e-6, "{t}");
        let r = &v["rotation"];
        let q = ["x", "y", "z", "w"].map(|k| r[k].as_f64().unwrap());
        // a camera vector in the user frame: v' = v + 2w (q x v) + 2 q x (q x v)
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        };
        let rotate = |v: [f64; 3]| {
            let u = [q[0], q[1], q[2]];
            let t = cross(u, v).map(|x| 2.0 * x);
            let ut = cross(u, t);
            [0, 1, 2].map(|i| v[i] + q[3] * t[i] + ut[i])
        };
        let near = |a: [f64; 3], b: [f64; 3]| (0..3).all(|i| (a[i] - b[i]).abs() < 1e-6);
        let (s, c) = (f64::from(s), f64::from(c));
        // the optical axis forward and down by 30 degrees, image right to the user's right,
        // image down forward-and-down
        assert!(near(rotate([0.0, 0.0, 1.0]), [c, 0.0, -s]), "{:?}", rotate([0.0, 0.0, 1.0]));
        assert!(near(rotate([1.0, 0.0, 0.0]), [0.0, -1.0, 0.0]), "{:?}", rotate([1.0, 0.0, 0.0]));
        assert!(near(rotate([0.0, 1.0, 0.0]), [-s, 0.0, -c]), "{:?}", rotate([0.0, 1.0, 0.0]));
        // a plane that is none (before the first frame: zeros) places nothing
        let none = schemas::Hazard { plane_camera: [0.0; 4], ..hazard };
        let payload = schemas::encode(&schemas::Origin { sender: "test", session: 1 }, 4, 1, &none);
        assert_eq!(as_foxglove(schemas::SchemaId::Hazard, &payload), None);
        let schema: serde_json::Value = serde_json::from_str(&foxglove_schema(name)).unwrap();
        assert!(schema["properties"]["rotation"]["properties"]["w"].is_object(), "{schema}");
    }

    #[test]
    fn a_depth_frame_becomes_points_in_the_camera_frame_every_stride_pixels_and_none_where_invalid() {
        use base64::Engine as _;
        // 8 x 4 pixels: 2.0 m everywhere but one invalid sample at (4, 2)
        let (width, height) = (8u32, 4u32);
        let mut samples = [2000u16; 32];
        samples[2 * 8 + 4] = 0;
        let data: Vec<u8> = samples.iter().flat_map(|d| d.to_le_bytes()).collect();
        let frame = schemas::DepthFrame {
            width,
            height,
            depth_scale_m: 0.001,
            intrinsics: schemas::Intrinsics { fx: 100.0, fy: 50.0, cx: 4.0, cy: 2.0 },
            gravity_camera: None,
            mount: None,
            encoding: schemas::DepthEncoding::Raw,
            data,
        };
        let payload = schemas::encode(&Origin { sender: "test", session: 1 }, 30, 7_000_000_000, &frame);
        let json = point_cloud(&payload, 2, &mut Vec::new()).expect("a cloud");
        let v: serde_json::Value = serde_json::from_slice(&json).unwrap();
        assert_eq!((v["timestamp"]["sec"].as_u64(), v["frame_id"].as_str()), (Some(7), Some("wearnav_camera")));
        assert_eq!(v["point_stride"], 12);
        let bytes = base64::engine::general_purpose::STANDARD.decode(v["data"].as_str().unwrap()).unwrap();
        let floats: Vec<f32> = bytes.chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
        let points: Vec<&[f32]> = floats.chunks(3).collect();
        // pixels (0|2|4|6, 0|2): 8, less the invalid one
        assert_eq!(points.len(), 7, "{points:?}");
        // (u, v) = (0, 0): x = (0 - 4) * 2 / 100, y = (0 - 2) * 2 / 50
        assert_eq!(points[0], [-0.08, -0.08, 2.0]);
        // (6, 2): x = 2 * 2 / 100, y = 0
        assert_eq!(points[6], [0.04, 0.0, 2.0]);
        assert!(points.iter().all(|p| p[2] == 2.0));
        assert!(point_cloud(&payload[..payload.len() - 3], 2, &mut Vec::new()).is_none(), "a damaged frame");
    }

    #[test]
    fn a_floor_plan_becomes_a_grid_of_ros_occupancy_values_at_its_origin() {
        use base64::Engine as _;
        use map::Cell::{Free, Occupied, Unknown};
        let origin = map::Origin { x_m: -1.5, y_m: 2.0, yaw_rad: 0.0 };
        let grid =
            map::OccupancyGrid::new(3, 2, 0.05, origin, vec![Free, Occupied, Unknown, Occupied, Free, Free]).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&grid_json(&grid, 1_500_000_000)).unwrap();
        assert_eq!(
            (v["column_count"].as_u64(), v["row_stride"].as_u64(), v["cell_stride"].as_u64()),
            (Some(3), Some(3), Some(1))
        );
        assert_eq!((v["cell_size"]["x"].as_f64(), v["pose"]["position"]["x"].as_f64()), (Some(0.05), Some(-1.5)));
        assert_eq!(v["fields"][0]["type"], INT8);
        let cells = base64::engine::general_purpose::STANDARD.decode(v["data"].as_str().unwrap()).unwrap();
        let cells: Vec<i8> = cells.into_iter().map(|b| b as i8).collect();
        assert_eq!(cells, [0, 100, -1, 100, 0, 0]);
    }
}
