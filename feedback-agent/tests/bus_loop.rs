//! The agent loop on real Zenoh sessions over loopback: a test session listens, the
//! agent connects to it; hazards, intents and garbage go in, `feedback/applied`,
//! health stats and the fake remotes' bytes come out.

mod common;

use std::time::{Duration, Instant};

use bus::{BusOptions, Lane, Publisher, Shutdown, Subscriber};
use common::{wait_applied, HazardStream, Loopback};
use feedback_agent::console::ConsoleSpeech;
use feedback_agent::wiimote::fake::FakeHid;
use feedback_agent::wiimote::{WiimoteBackend, WiimoteConfig};
use feedback_agent::{Devices, FeedbackConfig};
use schemas::{Applied, AppliedAction, HapticIntent, HapticPattern, HealthStats, Priority, SpeechIntent};

const LEFT: &str = "/dev/hidraw0";
const RIGHT: &str = "/dev/hidraw1";

fn offline_warning(a: &Applied, offline: bool) -> bool {
    matches!(&a.action, AppliedAction::OfflineWarning { offline: o, .. } if *o == offline)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn agent_follows_hazards_and_intents_over_loopback_and_survives_garbage() {
    let Loopback { user, test_bus, agent_bus, keys, session, health: test_health } = Loopback::open("fbtest").await;
    let applied = Subscriber::<Applied>::declare(&session, keys.applied(), false, &test_health).await.unwrap();
    let stats =
        Subscriber::<HealthStats>::declare(&session, keys.health("feedback-agent"), false, &test_health).await.unwrap();
    let token = session.liveliness().declare_token(keys.health("compute-agent")).await.unwrap();
    let hazards = HazardStream::start(session.clone(), keys.clone());

    let hid = FakeHid::new();
    hid.attach(LEFT, "00:19:1d:00:00:01");
    hid.attach(RIGHT, "00:19:1d:00:00:02");
    let devices = Devices {
        haptics: vec![Box::new(WiimoteBackend::new(Box::new(hid.clone()), WiimoteConfig::default()))],
        engines: vec![Box::new(ConsoleSpeech::new(Box::new(std::io::sink()), 175))],
        notes: vec![],
        phone: None,
    };
    let config = FeedbackConfig { health_period_ms: 200, ..FeedbackConfig::with_bus(agent_bus) };
    let shutdown = Shutdown::new();
    let agent = tokio::spawn(feedback_agent::run_with(config, devices, shutdown.clone()));
    // Let the sessions meet and the agent see fresh hazards.
    tokio::time::sleep(Duration::from_millis(800)).await;

    // A haptic intent turns the left remote on, stamped with its cause.
    let mut haptic = Publisher::<HapticIntent>::declare(&session, keys.haptic(), "test-compute", Lane::RealTime, None)
        .await
        .unwrap();
    let capture = bus::now_ns();
    let left = HapticIntent { left: 1.0, right: 0.0, pattern: HapticPattern::Steady, ttl_ms: 300 };
    haptic.put(capture, &left).await.unwrap();
    let a = wait_applied(&applied, Duration::from_secs(2), |a| {
        a.device == "wiimote-left" && matches!(a.action, AppliedAction::Rumble { left, .. } if left == 1.0)
    })
    .await;
    assert_eq!(a.cause_capture_ns, capture);
    assert!(hid.written_to(LEFT).contains(&vec![0x10, 0x01]));
    // ... and its TTL switches it off without any further message.
    let off = wait_applied(&applied, Duration::from_secs(1), |a| {
        a.device == "wiimote-left" && matches!(a.action, AppliedAction::Rumble { left, .. } if left == 0.0)
    })
    .await;
    let rumble_ms = (off.applied_ns - a.applied_ns) as f64 / 1e6;
    assert!((250.0..450.0).contains(&rumble_ms), "rumbled {rumble_ms} ms for a 300 ms TTL");

    // Hazards stop: offline within 500 ms + a margin.
    hazards.set(false);
    tokio::time::sleep(Duration::from_millis(40)).await;
    let stopped = hazards.last();
    wait_applied(&applied, Duration::from_secs(2), |a| offline_warning(a, true)).await;
    let after_ms = stopped.elapsed().as_secs_f64() * 1e3;
    eprintln!("offline warning {after_ms:.0} ms after the last hazard");
    assert!((450.0..800.0).contains(&after_ms), "offline warning after {after_ms:.0} ms");
    // Hazards resume: back.
    hazards.set(true);
    wait_applied(&applied, Duration::from_secs(1), |a| offline_warning(a, false)).await;

    // The compute agent's liveliness token goes: offline at once, even with hazards flowing.
    let dropped = Instant::now();
    drop(token);
    let w = wait_applied(&applied, Duration::from_secs(1), |a| offline_warning(a, true)).await;
    assert!(matches!(&w.action, AppliedAction::OfflineWarning { reason, .. } if reason.contains("liveliness")));
    assert!(dropped.elapsed() < Duration::from_millis(300), "liveliness loss took {:?}", dropped.elapsed());
    let _token = session.liveliness().declare_token(keys.health("compute-agent")).await.unwrap();
    wait_applied(&applied, Duration::from_secs(1), |a| offline_warning(a, false)).await;

    // Garbage on every subscribed key: counted, never acted on.
    let evil = schemas::Origin { sender: "evil", session: 1 };
    let nan = schemas::encode(
        &evil,
        0,
        bus::now_ns(),
        &HapticIntent { left: f32::NAN, right: 1.0, pattern: HapticPattern::Steady, ttl_ms: 300 },
    );
    let huge = SpeechIntent {
        text: "a".repeat(10 * 1024 * 1024),
        priority: Priority::Message,
        interrupt: false,
        ttl_ms: 1000,
        dedup_key: String::new(),
        notice: false,
    };
    let huge = schemas::encode(&evil, 0, bus::now_ns(), &huge);
    let mut bad_priority = schemas::encode(
        &evil,
        0,
        bus::now_ns(),
        &SpeechIntent {
            text: "hi".into(),
            priority: Priority::Important,
            interrupt: false,
            ttl_ms: 1000,
            dedup_key: String::new(),
            notice: false,
        },
    );
    let (_, header_len) = schemas::decode_header(&bad_priority).unwrap();
    // Priority variant index 9 does not exist.
    bad_priority[header_len + 8 + 2] = 9;
    // sealed again: a faulty sender's well-checksummed payload reaches the decoder
    schemas::wire::reseal(&mut bad_priority);
    // Spaced out: haptic and hazard subscribers keep only the newest sample, so
    // back-to-back garbage would be overwritten before the agent reads it (400 ms: a
    // loaded 2-core machine can hold the agent's loop off for more than 50, and at the
    // start of CI's test run, with every suite starting at once, once for over 150).
    let garbage = [
        (keys.haptic(), vec![1u8, 2, 3]),
        (keys.haptic(), nan),
        (keys.speech(), huge),
        (keys.speech(), bad_priority),
        (keys.hazard(), vec![0xffu8; 40]),
    ];
    // Block, not the default drop: a 10 MB put on a loaded machine finds the
    // transmit queue full and is dropped by the sender, never reaching the agent.
    for (key, bytes) in garbage {
        session.put(key, bytes).congestion_control(zenoh::qos::CongestionControl::Block).await.unwrap();
        tokio::time::sleep(Duration::from_millis(400)).await;
    }
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut seen = Vec::new();
    let rejects = loop {
        let m = tokio::time::timeout(deadline.saturating_duration_since(Instant::now()), stats.recv())
            .await
            .unwrap_or_else(|_| panic!("5 rejects in the health stats within 5 s; the last stats counted {seen:?}"))
            .expect("health stream");
        seen = m.body.rejects.iter().map(|r| (r.kind.clone(), r.count)).collect();
        let total: u64 = m.body.rejects.iter().map(|r| r.count).sum();
        if total >= 5 {
            break m.body.rejects;
        }
    };
    let kinds: Vec<&str> = rejects.iter().map(|r| r.kind.as_str()).collect();
    eprintln!("rejects counted: {rejects:?}");
    for kind in ["truncated", "invalid", "too_large", "malformed"] {
        assert!(kinds.contains(&kind), "{kind} not counted in {kinds:?}");
    }

    // Still alive: a right-hand intent is applied.
    let capture = bus::now_ns();
    haptic
        .put(capture, &HapticIntent { left: 0.0, right: 1.0, pattern: HapticPattern::Steady, ttl_ms: 300 })
        .await
        .unwrap();
    let a = wait_applied(&applied, Duration::from_secs(1), |a| {
        a.device == "wiimote-right" && a.cause_capture_ns == capture
    })
    .await;
    assert!(matches!(a.action, AppliedAction::Rumble { right, .. } if right == 1.0));

    // A publisher whose numbers 2 and 3 never arrive: two lost on the way, counted in
    // the haptic stream's health (nothing to refuse: 4 is newer than 1).
    let lossy = schemas::Origin { sender: "lossy", session: 2 };
    let still = HapticIntent { left: 0.0, right: 0.0, pattern: HapticPattern::Steady, ttl_ms: 300 };
    for seq in [0, 1, 4] {
        let bytes = schemas::encode(&lossy, seq, bus::now_ns(), &still);
        session.put(keys.haptic(), bytes).congestion_control(zenoh::qos::CongestionControl::Block).await.unwrap();
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let deadline = Instant::now() + Duration::from_secs(5);
    let missed = loop {
        let m = tokio::time::timeout(deadline.saturating_duration_since(Instant::now()), stats.recv())
            .await
            .expect("the lost intents in the health stats within 5 s")
            .expect("health stream");
        let stream = m.body.streams.iter().find(|s| s.inbound && s.key == keys.haptic()).expect("the haptic stream");
        // two intents before these three: all have come when it counts five
        if stream.count >= 5 || stream.missed > 0 {
            break stream.missed;
        }
    };
    assert_eq!(missed, 2, "numbers 2 and 3 lost on the way");

    // Shutdown leaves both motors off.
    shutdown.trigger();
    agent.await.expect("agent task").expect("agent ran cleanly");
    assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x10, 0x00]);
    assert_eq!(hid.written_to(RIGHT).last().unwrap(), &vec![0x10, 0x00]);

    // Restarted alone with other devices (one remote only) while the "compute" side
    // keeps publishing: it picks up where the first left off.
    let hid2 = FakeHid::new();
    hid2.attach("/dev/hidraw7", "00:19:1d:00:00:07");
    let devices = Devices {
        haptics: vec![Box::new(WiimoteBackend::new(Box::new(hid2.clone()), WiimoteConfig::default()))],
        engines: vec![Box::new(ConsoleSpeech::new(Box::new(std::io::sink()), 175))],
        notes: vec![],
        phone: None,
    };
    let agent_bus = BusOptions { connect: test_bus.listen.clone(), no_multicast: true, ..BusOptions::for_user(&user) };
    let shutdown = Shutdown::new();
    let agent = tokio::spawn(feedback_agent::run_with(FeedbackConfig::with_bus(agent_bus), devices, shutdown.clone()));
    let deadline = Instant::now() + Duration::from_secs(5);
    while !hid2.written_to("/dev/hidraw7").contains(&vec![0x10, 0x01]) {
        assert!(Instant::now() < deadline, "restarted agent never rumbled");
        haptic.put(bus::now_ns(), &left).await.unwrap();
        tokio::time::sleep(Duration::from_millis(33)).await;
    }
    shutdown.trigger();
    agent.await.expect("agent task").expect("agent ran cleanly");
    assert_eq!(hid2.written_to("/dev/hidraw7").last().unwrap(), &vec![0x10, 0x00]);
}
