//! `cmd/mute` through the agent loop on real Zenoh sessions over loopback (its own
//! test binary, so it never shares a process with the timing-sensitive `bus_loop`).

mod common;

use std::time::Duration;

use bus::{Lane, Publisher, Shutdown, Subscriber};
use common::{wait_applied, HazardStream, Loopback};
use feedback_agent::console::ConsoleSpeech;
use feedback_agent::{Devices, FeedbackConfig};
use schemas::{Applied, AppliedAction, Command, Priority, SpeechIntent};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mute_command_over_the_bus_silences_guidance_but_not_warnings() {
    let Loopback { agent_bus, keys, session, health: test_health, .. } = Loopback::open("fbmute").await;
    let applied = Subscriber::<Applied>::declare(&session, keys.applied(), false, &test_health).await.unwrap();
    let _token = session.liveliness().declare_token(keys.health("compute-agent")).await.unwrap();
    let _hazards = HazardStream::start(session.clone(), keys.clone());
    let devices = Devices {
        haptics: vec![],
        engines: vec![Box::new(ConsoleSpeech::new(Box::new(std::io::sink()), 175))],
        notes: vec![],
        phone: None,
    };
    let shutdown = Shutdown::new();
    let agent = tokio::spawn(feedback_agent::run_with(FeedbackConfig::with_bus(agent_bus), devices, shutdown.clone()));
    tokio::time::sleep(Duration::from_millis(800)).await;

    let mut speech =
        Publisher::<SpeechIntent>::declare(&session, keys.speech(), "test-compute", Lane::Events, None).await.unwrap();
    let mut cmd =
        Publisher::<Command>::declare(&session, keys.cmd("mute"), "test-phone", Lane::Events, None).await.unwrap();
    let say = |text: &str, priority| SpeechIntent {
        text: text.into(),
        priority,
        interrupt: false,
        ttl_ms: 5000,
        dedup_key: String::new(),
        notice: false,
    };
    let started = |text: &'static str| move |a: &Applied| matches!(&a.action, AppliedAction::SpeechStarted { text: t, .. } if t == text);
    let within = Duration::from_secs(2);

    speech.put(bus::now_ns(), &say("in twenty metres turn left at the lift", Priority::Message)).await.unwrap();
    wait_applied(&applied, within, started("in twenty metres turn left at the lift")).await;

    cmd.put(bus::now_ns(), &Command::Mute { muted: true }).await.unwrap();
    let status = wait_applied(
        &applied,
        within,
        |a| matches!(&a.action, AppliedAction::DeviceStatus { text } if text == "speech muted"),
    )
    .await;
    assert_eq!(status.device, "speech-queue");
    wait_applied(&applied, within, |a| matches!(&a.action, AppliedAction::SpeechInterrupted { .. })).await;
    wait_applied(&applied, within, started("speech muted")).await;

    speech.put(bus::now_ns(), &say("cafeteria on your right", Priority::Text)).await.unwrap();
    let dropped = wait_applied(&applied, within, |a| matches!(&a.action, AppliedAction::SpeechDropped { .. })).await;
    assert_eq!(
        dropped.action,
        AppliedAction::SpeechDropped { text: "cafeteria on your right".into(), reason: "muted".into() }
    );

    // Warnings still sound while muted (safety rule 3 outranks the user's mute).
    speech.put(bus::now_ns(), &say("stop, wall ahead", Priority::Important)).await.unwrap();
    wait_applied(&applied, within, started("stop, wall ahead")).await;

    cmd.put(bus::now_ns(), &Command::Mute { muted: false }).await.unwrap();
    wait_applied(
        &applied,
        within,
        |a| matches!(&a.action, AppliedAction::DeviceStatus { text } if text == "speech on"),
    )
    .await;
    speech.put(bus::now_ns(), &say("lift on your left", Priority::Text)).await.unwrap();
    wait_applied(&applied, Duration::from_secs(6), started("lift on your left")).await;

    shutdown.trigger();
    agent.await.expect("agent task").expect("agent ran cleanly");
}
