//! The monitor streams on the phone's socket, against a real bridge on a real bus: a
//! page that subscribes gets the state first (the answer, the floor map, the cost
//! regions, the agents, the utterances said before) and then what the bus carries, as
//! the page reads it; a phone socket beside it gets none of it; unsubscribing stops it;
//! a bad subscription is refused; `/monitor` serves the page.

mod common;

use std::sync::Arc;
use std::time::Duration;

use bus::{BusOptions, Lane, Publisher, Shutdown};
use common::{connect, drain, get, next_of, pair};
use futures_util::SinkExt;
use map::{Building, Cell, Floor, OccupancyGrid, Origin, SemanticLayer};
use schemas::{
    CameraPlace, CostFunction, GroundState, GroundTruth, HapticIntent, HapticPattern, Hazard, HealthStats,
    LocalizationStatus, MapPoint, Pose, Priority, RouteState, RouteStatus, Rumble, Scan, SideCosts, SpeechIntent,
    StageLatency, StreamStats,
};
use serde_json::{json, Value};
use tokio_tungstenite::tungstenite::Message;

const CODE: &str = "135790";
const USER: &str = "monitor-test";
const WAIT: Duration = Duration::from_secs(5);

/// One floor, 4 x 2 cells of 0.1 m, rows bottom first: free free occupied unknown /
/// unknown x 4.
fn building() -> Building {
    use Cell::{Free as F, Occupied as O, Unknown as U};
    let origin = Origin { x_m: -0.5, y_m: 1.0, yaw_rad: 0.0 };
    let grid = OccupancyGrid::new(4, 2, 0.1, origin, vec![F, F, O, U, U, U, U, U]).unwrap();
    Building::new(vec![Floor { level: 0, grid, semantic: SemanticLayer::default() }], "test".as_ref()).unwrap()
}

fn say(text: &str) -> SpeechIntent {
    SpeechIntent {
        text: text.into(),
        priority: Priority::Message,
        interrupt: true,
        ttl_ms: 5000,
        dedup_key: String::new(),
        notice: false,
    }
}

async fn send(socket: &mut common::Socket, v: Value) {
    socket.send(Message::Text(v.to_string().into())).await.unwrap();
}

/// The messages of the greeting a subscription gets: everything up to the clock tick
/// or bus news that follows, by type.
async fn greeting(socket: &mut common::Socket) -> Vec<Value> {
    let first = next_of(socket, "subscribed", WAIT).await;
    let mut out = vec![first];
    // the greeting is sent at once, in one go
    out.extend(drain(socket, Duration::from_millis(300)).await);
    out
}

/// `m` without its capture stamp `t`, which must be `t_ns` (to the microsecond: JSON
/// numbers are read back to within a unit in the last place).
fn stamped(mut m: Value, t_ns: u64) -> Value {
    let t = m.as_object_mut().and_then(|o| o.remove("t")).and_then(|t| t.as_f64());
    assert!(t.is_some_and(|t| (t - t_ns as f64 / 1e6).abs() < 1e-3), "t {t:?} is not {t_ns} ns: {m}");
    m
}

fn of<'v>(messages: &'v [Value], type_: &str) -> Vec<&'v Value> {
    messages.iter().filter(|m| m["type"] == type_).collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_monitor_gets_the_state_then_the_bus_and_a_phone_beside_it_none_of_it() {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut hub = BusOptions::for_user(USER);
    hub.listen = vec![endpoint.clone()];
    hub.no_multicast = true;
    let session = bus::open_session(&hub).await.unwrap();
    let keys = hub.keys().unwrap();

    let mut bus = BusOptions::for_user(USER);
    bus.connect = vec![endpoint];
    bus.no_multicast = true;
    let mut config = phone_bridge::PhoneConfig::new(bus);
    config.serve = phone_bridge::Serve::Http("127.0.0.1:0".parse().unwrap());
    let dir = tempfile::Builder::new().prefix("wearnav-bridge-monitor-").tempdir().unwrap();
    config.state_dir = dir.path().to_path_buf();
    config.announce = false;
    config.pairing_code = Some(CODE.into());
    config.map = Some(Arc::new(building()));
    config.perception = perception::PerceptionConfig::from_toml("[ficf]\nforward_width_m = 0.9\n").unwrap();
    let shutdown = Shutdown::new();
    let (tx, rx) = tokio::sync::oneshot::channel();
    let bridge = tokio::spawn(phone_bridge::run(config, shutdown.clone(), Some(tx)));
    let addr = tokio::time::timeout(Duration::from_secs(10), rx).await.unwrap().unwrap();

    // an agent whose token the bridge sees before any stats of it: then the bridge's
    // subscriptions are known to the hub too (declared before its liveliness watch)
    let agent_token = session.liveliness().declare_token(keys.health("test-agent")).await.unwrap();
    let until = tokio::time::Instant::now() + WAIT;
    while !common::health(addr).await["agents_alive"].to_string().contains("test-agent") {
        assert!(tokio::time::Instant::now() < until, "the bridge never saw the test agent's token");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }

    let (status, body) = get(addr, "/monitor").await;
    assert_eq!(status, 200);
    assert!(body.contains("<title>wearnav monitor</title>"), "{body}");

    let (status, answer) = pair(addr, CODE).await;
    assert_eq!(status, 200, "{answer}");
    let token = answer["token"].as_str().unwrap().to_string();
    let mut phone = connect(addr, &token).await.unwrap();
    let mut monitor = connect(addr, &token).await.unwrap();
    next_of(&mut phone, "hello", WAIT).await;
    next_of(&mut monitor, "hello", WAIT).await;

    // a bad subscription is refused and changes nothing
    send(&mut monitor, json!({"type": "subscribe", "streams": ["scan", "particles"]})).await;
    let refused = next_of(&mut monitor, "error", WAIT).await;
    assert!(refused["message"].as_str().unwrap().starts_with("subscribe: unknown stream \"particles\""), "{refused}");

    // speech only: an utterance said now is passed on, and kept
    send(&mut monitor, json!({"type": "subscribe", "streams": ["speech"]})).await;
    let first = greeting(&mut monitor).await;
    assert_eq!(first[0], json!({"type": "subscribed", "streams": ["speech"], "map_floors": [0]}));
    let mut speech =
        Publisher::<SpeechIntent>::declare(&session, keys.speech(), "test", Lane::Events, None).await.unwrap();
    let said_ns = bus::now_ns();
    speech.put(said_ns, &say("Turn left in 3 metres.")).await.unwrap();
    let heard = stamped(next_of(&mut monitor, "utterance", WAIT).await, said_ns);
    assert_eq!(
        heard,
        json!({"type": "utterance", "text": "Turn left in 3 metres.",
               "priority": "message", "interrupt": true, "notice": false})
    );

    // everything: the state first, in the order of the answer
    let all = ["map", "route", "pose", "truth", "health", "speech", "hazard", "haptic", "scan"];
    send(&mut monitor, json!({"type": "subscribe", "streams": ["scan", "hazard", "haptic", "pose", "truth", "route", "map", "health", "speech"]})).await;
    let state = greeting(&mut monitor).await;
    assert_eq!(state[0], json!({"type": "subscribed", "streams": all, "map_floors": [0]}));
    assert_eq!(
        of(&state, "map"),
        [&json!({"type": "map", "floor": 0, "width": 4, "height": 2, "resolution_m": 0.1,
                  "origin": [-0.5, 1.0, 0.0], "cells": "f2o1u5", "coarsened": 1})]
    );
    let regions = of(&state, "regions");
    assert_eq!(regions.len(), 1, "{state:?}");
    assert_eq!(
        regions[0]["ficf"],
        json!({"forward_width_m": 0.9, "forward_depth_m": 3.5, "side_width_m": 0.75, "side_depth_m": 3.5,
               "forward_threshold": 3.0, "side_threshold": 6.0}),
        "the configuration given, the thesis's defaults for the rest"
    );
    assert_eq!(regions[0]["cacf"]["side_width_m"], json!(1.5));
    let agent = of(&state, "health").into_iter().find(|h| h["agent"] == "test-agent").cloned();
    assert_eq!(
        agent,
        Some(json!({"type": "health", "agent": "test-agent", "alive": true, "ok": false,
                    "status": "no health stats heard yet", "uptime_ms": null, "age_ms": null,
                    "streams": [], "rejects": 0})),
        "an agent known by its token only"
    );
    let utterances: Vec<_> = of(&state, "utterance").iter().map(|u| u["text"].clone()).collect();
    assert_eq!(utterances, [json!("Turn left in 3 metres.")], "the utterance said before is kept");

    // then the bus, as the page reads it
    let t_ns = bus::now_ns();
    let mut scans = Publisher::<Scan>::declare(&session, keys.scan(), "test", Lane::Perception, None).await.unwrap();
    let scan = Scan {
        angle_min_deg: -1.5,
        angle_increment_deg: 1.0,
        ranges_m: vec![1.5, f32::INFINITY, 0.80042, 2.0],
        range_max_m: 4.0,
    };
    let seq = scans.put(t_ns, &scan).await.unwrap();
    let got = stamped(next_of(&mut monitor, "scan", WAIT).await, t_ns);
    assert_eq!(
        got,
        json!({"type": "scan", "seq": seq, "angle_min_deg": -1.5,
               "angle_increment_deg": 1.0, "range_max_m": 4.0, "ranges_m": [1.5, null, 0.8, 2.0],
               "beams": 4, "nearest_m": 0.8, "nearest_bearing_deg": 0.5})
    );

    let mut intents =
        Publisher::<HapticIntent>::declare(&session, keys.haptic(), "test", Lane::RealTime, None).await.unwrap();
    let pulses = HapticPattern::Pulses { period_ms: 180, duty: 0.5 };
    intents.put(t_ns, &HapticIntent { left: 0.0, right: 1.0, pattern: pulses, ttl_ms: 300 }).await.unwrap();
    assert_eq!(
        stamped(next_of(&mut monitor, "haptic", WAIT).await, t_ns),
        json!({"type": "haptic", "left": 0.0, "right": 1.0, "pattern": "pulses",
               "period_ms": 180, "duty": 0.5, "ttl_ms": 300})
    );

    let mut hazards =
        Publisher::<Hazard>::declare(&session, keys.hazard(), "test", Lane::Perception, None).await.unwrap();
    let mut hazard = Hazard::nothing_ahead(7, GroundState::Found);
    hazard.rumble = Rumble::Left;
    hazard.ficf = SideCosts { left: 1.0, forward: 4.5, right: 2.25 };
    hazard.nearest_m = 0.61234;
    hazard.nearest_bearing_deg = -12.0;
    hazard.latency = vec![
        StageLatency { stage: "decode".into(), us: 2500 },
        StageLatency { stage: "cost_function".into(), us: 500 },
    ];
    hazards.put(bus::now_ns(), &hazard).await.unwrap();
    let h = next_of(&mut monitor, "hazard", WAIT).await;
    assert_eq!(
        (&h["rumble"], &h["ground"], &h["active"], &h["ficf"], &h["nearest_m"], &h["nearest_bearing_deg"]),
        (
            &json!("left"),
            &json!("found"),
            &json!("ficf"),
            &json!({"left": 1.0, "forward": 4.5, "right": 2.25}),
            &json!(0.612),
            &json!(-12.0)
        ),
        "{h}"
    );
    assert_eq!(h["latency_ms"], json!(3.0), "{h}");
    assert_eq!(h["stages"], json!([{"stage": "decode", "ms": 2.5}, {"stage": "cost_function", "ms": 0.5}]));
    assert!(h["age_ms"].as_f64().unwrap() < 1000.0, "{h}");

    let mut poses = Publisher::<Pose>::declare(&session, keys.pose(), "test", Lane::Telemetry, None).await.unwrap();
    let pose = Pose {
        x_m: 3.0,
        y_m: 4.0,
        yaw_rad: 1.5,
        floor: 0,
        // 0.2 m by 0.1 m, the long axis 45 degrees from +x; heading 2 degrees
        covariance: [0.025, 0.015, 0.0, 0.015, 0.025, 0.0, 0.0, 0.0, 2f32.to_radians().powi(2)],
        // followed from a known place: guidance takes it before the filter tracks
        status: LocalizationStatus::Converging,
        guides: true,
    };
    poses.put(t_ns, &pose).await.unwrap();
    let p = next_of(&mut monitor, "pose", WAIT).await;
    let close = |v: &Value, want: f64| (v.as_f64().unwrap() - want).abs() < 1e-4;
    assert!(close(&p["sigma_major_m"], 0.2) && close(&p["sigma_minor_m"], 0.1), "{p}");
    assert!(close(&p["major_angle_rad"], std::f64::consts::FRAC_PI_4) && close(&p["sigma_yaw_deg"], 2.0), "{p}");
    assert_eq!((&p["x_m"], &p["status"], &p["guides"]), (&json!(3.0), &json!("converging"), &json!(true)));

    let mut truths =
        Publisher::<GroundTruth>::declare(&session, keys.truth("sim"), "test", Lane::Telemetry, None).await.unwrap();
    let truth = GroundTruth {
        x_m: 3.1,
        y_m: 4.0,
        yaw_rad: 1.5,
        floor: 0,
        camera_height_m: 1.0,
        camera_pitch_deg: 20.0,
        sweep_deg: 0.0,
    };
    truths.put(t_ns, &truth).await.unwrap();
    let tr = next_of(&mut monitor, "truth", WAIT).await;
    assert_eq!((&tr["x_m"], &tr["floor"]), (&json!(3.1), &json!(0)), "{tr}");

    // where the scan's frame lies on the map: with the scan stream, at the frame's stamp
    let mut cameras =
        Publisher::<CameraPlace>::declare(&session, keys.camera_place(), "test", Lane::Telemetry, None).await.unwrap();
    let place = CameraPlace { x_m: 3.5, y_m: 4.25, yaw_rad: 0.5, floor: 0, status: LocalizationStatus::Tracking };
    cameras.put(t_ns, &place).await.unwrap();
    let cam = next_of(&mut monitor, "camera", WAIT).await;
    assert_eq!(
        (&cam["x_m"], &cam["y_m"], &cam["yaw_rad"], &cam["floor"]),
        (&json!(3.5), &json!(4.25), &json!(0.5), &json!(0)),
        "{cam}"
    );
    // the frame's stamp in ms, to the microsecond (a float read back from JSON may be a
    // unit in the last place off)
    assert!((cam["t"].as_f64().unwrap() - t_ns as f64 / 1e6).abs() < 1e-3, "{cam} at {t_ns} ns");

    let mut routes =
        Publisher::<RouteState>::declare(&session, keys.route_state(), "test", Lane::Events, None).await.unwrap();
    let point = |x_m, y_m| MapPoint { x_m, y_m, floor: 0 };
    let route = RouteState {
        destination: "room 204".into(),
        next_waypoint: Some(point(5.0, 4.0)),
        distance_left_m: 7.04,
        instruction: "Go straight on.".into(),
        floor: 0,
        status: RouteStatus::Guiding,
        route: vec![point(5.0, 4.0), point(5.0, 9.0)],
    };
    routes.put(t_ns, &route).await.unwrap();
    assert_eq!(
        next_of(&mut monitor, "route-path", WAIT).await,
        json!({"type": "route-path", "status": "guiding", "destination": "room 204",
               "points": [{"x_m": 5.0, "y_m": 4.0, "floor": 0}, {"x_m": 5.0, "y_m": 9.0, "floor": 0}],
               "next": {"x_m": 5.0, "y_m": 4.0, "floor": 0}, "distance_m": 7.0, "instruction": "Go straight on."})
    );

    let mut stats =
        Publisher::<HealthStats>::declare(&session, keys.health("test-agent"), "test-agent", Lane::Telemetry, None)
            .await
            .unwrap();
    let scan_stats = StreamStats {
        key: keys.scan(),
        inbound: true,
        count: 300,
        rate_hz: 29.96,
        bytes_per_s: 9000.0,
        rejects: 2,
        missed: 7,
        latency_p50_ms: 2.5,
        latency_p99_ms: f32::NAN,
    };
    let report = HealthStats {
        agent: "test-agent".into(),
        uptime_ms: 12_000,
        ok: true,
        status: "fine".into(),
        streams: vec![scan_stats],
        rejects: vec![schemas::RejectCount { kind: "truncated".into(), count: 2 }],
    };
    stats.put(bus::now_ns(), &report).await.unwrap();
    let hs = loop {
        let hs = next_of(&mut monitor, "health", WAIT).await;
        if hs["agent"] == "test-agent" {
            break hs;
        }
    };
    assert_eq!(
        (&hs["alive"], &hs["ok"], &hs["status"], &hs["uptime_ms"], &hs["rejects"]),
        (&json!(true), &json!(true), &json!("fine"), &json!(12_000), &json!(2))
    );
    assert_eq!(
        hs["streams"],
        json!([{"key": "perception/scan", "inbound": true, "rate_hz": 30.0, "p50_ms": 2.5, "p99_ms": null,
                "rejects": 2, "missed": 7}])
    );

    // the agent goes: said at once
    drop(agent_token);
    let gone = loop {
        let hs = next_of(&mut monitor, "health", WAIT).await;
        if hs["agent"] == "test-agent" {
            break hs;
        }
    };
    assert_eq!((&gone["alive"], &gone["status"]), (&json!(false), &json!("fine")), "{gone}");

    let view = common::health(addr).await;
    assert_eq!((view["phones_connected"].as_u64(), view["monitors_connected"].as_u64()), (Some(1), Some(1)), "{view}");

    // the phone had the hazard's cue and the pose's status, and none of the monitor's
    let on_phone = drain(&mut phone, Duration::from_millis(300)).await;
    let types: std::collections::BTreeSet<&str> = on_phone.iter().filter_map(|m| m["type"].as_str()).collect();
    assert!(types.contains("obstacle") && types.contains("position") && types.contains("route"), "{types:?}");
    let monitor_types =
        ["subscribed", "regions", "map", "scan", "camera", "hazard", "haptic", "pose", "truth", "route-path"];
    for t in monitor_types.iter().chain(&["health", "utterance"]) {
        assert!(!types.contains(t), "the phone socket got a {t}: {types:?}");
    }

    // unsubscribed: nothing more, and it counts as a phone again
    send(&mut monitor, json!({"type": "subscribe", "streams": []})).await;
    assert_eq!(next_of(&mut monitor, "subscribed", WAIT).await["streams"], json!([]));
    scans.put(bus::now_ns(), &scan).await.unwrap();
    speech.put(bus::now_ns(), &say("Stop.")).await.unwrap();
    let after = drain(&mut monitor, Duration::from_millis(500)).await;
    assert!(after.iter().all(|m| !monitor_types.contains(&m["type"].as_str().unwrap_or(""))), "{after:?}");
    let view = common::health(addr).await;
    assert_eq!((view["phones_connected"].as_u64(), view["monitors_connected"].as_u64()), (Some(2), Some(0)), "{view}");

    shutdown.trigger();
    tokio::time::timeout(Duration::from_secs(5), bridge).await.unwrap().unwrap().unwrap();
}

#[test]
fn the_hazard_names_the_cost_function_that_drives_it() {
    let mut h = Hazard::nothing_ahead(1, GroundState::Degraded);
    h.active = CostFunction::Cacf;
    let m = phone_bridge::monitor::to_text(&phone_bridge::monitor::hazard(&h, 9, 2_000_000, 1.26));
    let v: Value = serde_json::from_str(&m).unwrap();
    assert_eq!(
        (&v["active"], &v["ground"], &v["nearest_m"], &v["seq"], &v["t"], &v["age_ms"], &v["latency_ms"]),
        (&json!("cacf"), &json!("degraded"), &Value::Null, &json!(9), &json!(2.0), &json!(1.3), &json!(0.0))
    );
}
