//! The agent loop: the only place that touches the bus, the clock and the devices'
//! lifetimes. One `select!` over the subscriptions, the liveliness of the compute agent,
//! the next timer of the feedback step, and shutdown (dora-style event loop).

use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, Context};
use bus::{now_ns, Health, Lane, Publisher, Shutdown, Subscriber};
use schemas::{Applied, AppliedAction, Command, HapticIntent, Hazard, SpeechIntent};
use tokio::sync::mpsc;
use zenoh::sample::SampleKind;

use crate::config::{FeedbackConfig, HapticBackend, SpeechBackend};
use crate::console::{ConsoleHaptic, ConsoleSpeech};
use crate::device::{HapticDevice, SpeechEngine};
use crate::espeak::{find_player, EspeakEngine};
use crate::evdev::{EvdevBackend, EvdevOpener};
use crate::feedback::Feedback;
use crate::phone::{run_link, PhoneHaptic, PhoneLink, PhoneSpeech};
use crate::speechd::SpeechdEngine;
use crate::watchdog::DetectionState;
use crate::wiimote::link::HidapiBus;
use crate::wiimote::WiimoteBackend;

/// The agent's name: its liveliness token, health key and `sender`.
pub const AGENT: &str = "feedback-agent";

/// The devices the agent drives, and what was noted while opening them.
pub struct Devices {
    /// Haptic backends.
    pub haptics: Vec<Box<dyn HapticDevice>>,
    /// Speech engines.
    pub engines: Vec<Box<dyn SpeechEngine>>,
    /// Start-up notes (`device`, text), published as device status.
    pub notes: Vec<(String, String)>,
    /// The link to the phone, when a phone backend is configured (carried over the
    /// bus once the session is open).
    pub phone: Option<PhoneLink>,
}

impl Devices {
    /// Open the backends the configuration names. Fails when a named backend cannot
    /// work at all (espeak-ng missing, or refused: [`FeedbackConfig::check`]), rather
    /// than running silently without it.
    pub fn from_config(config: &FeedbackConfig) -> anyhow::Result<Self> {
        let mut devices = Devices { haptics: Vec::new(), engines: Vec::new(), notes: Vec::new(), phone: None };
        for backend in &config.haptic {
            match backend {
                HapticBackend::Console => devices.haptics.push(Box::new(ConsoleHaptic::stdout())),
                HapticBackend::Wiimote => {
                    devices.haptics.push(Box::new(WiimoteBackend::new(Box::new(HidapiBus::new()), config.wiimote())))
                }
                HapticBackend::Evdev => {
                    let evdev = config.evdev();
                    if evdev.left.is_none() && evdev.right.is_none() {
                        return Err(anyhow!("--haptic evdev needs --evdev-left and/or --evdev-right (an /dev/input/eventN node with FF_RUMBLE)"));
                    }
                    devices.haptics.push(Box::new(EvdevBackend::new(Box::new(EvdevOpener), evdev)));
                }
                HapticBackend::Phone => {
                    let link = devices.phone.get_or_insert_with(PhoneLink::new).clone();
                    devices.haptics.push(Box::new(PhoneHaptic::new(link)));
                }
            }
        }
        for backend in &config.speech {
            match backend {
                SpeechBackend::Console => devices.engines.push(Box::new(ConsoleSpeech::stdout(config.rate_wpm))),
                SpeechBackend::Espeak => {
                    let engine = EspeakEngine::new(config.espeak(), find_player()).context("--speech espeak")?;
                    devices.notes.push(("espeak".into(), engine.describe()));
                    devices.engines.push(Box::new(engine));
                }
                SpeechBackend::Speechd => {
                    let speechd = config.speechd().map_err(|e| anyhow!("--speech speechd: {e}"))?;
                    let engine = SpeechdEngine::new(speechd).context("--speech speechd")?;
                    devices.notes.push(("speechd".into(), engine.describe()));
                    devices.engines.push(Box::new(engine));
                }
                SpeechBackend::Phone => {
                    let link = devices.phone.get_or_insert_with(PhoneLink::new).clone();
                    devices.engines.push(Box::new(PhoneSpeech::new(link)));
                }
            }
        }
        Ok(devices)
    }
}

/// Run the feedback agent with the devices its configuration names until `shutdown`.
/// A refused configuration ([`FeedbackConfig::check`]) fails before any session opens.
pub async fn run(config: FeedbackConfig, shutdown: Shutdown) -> anyhow::Result<()> {
    config.check()?;
    let devices = Devices::from_config(&config)?;
    run_with(config, devices, shutdown).await
}

/// `applied` records waiting for the bus; beyond it new ones are counted and dropped.
const APPLIED_BACKLOG: usize = 4096;

/// Hands what was applied to the publishing task. The device loop never waits for the
/// network: a congested link to a monitor must not hold a rumble past its time to live.
fn publish(tx: &mpsc::Sender<Applied>, applied: impl IntoIterator<Item = Applied>, health: &Health, key: &str) {
    for a in applied {
        if let AppliedAction::DeviceStatus { text } = &a.action {
            tracing::info!(device = %a.device, "{text}");
        }
        if let Err(mpsc::error::TrySendError::Full(a)) = tx.try_send(a) {
            let why = format!("{APPLIED_BACKLOG} records already wait for the bus; {:?} not published", a.action);
            health.reject(key, "applied_backlog", &why);
        }
    }
}

/// Publishes `applied` records until the loop drops its sender.
async fn publish_applied(mut publisher: Publisher<Applied>, mut rx: mpsc::Receiver<Applied>) {
    while let Some(a) = rx.recv().await {
        // The envelope's capture stamp is the cause's, so a monitor reads the age of an
        // applied record as the end-to-end latency of the intent behind it.
        let stamp = if a.cause_capture_ns != 0 { a.cause_capture_ns } else { a.applied_ns };
        if let Err(e) = publisher.put(stamp, &a).await {
            tracing::warn!("cannot publish applied action: {e:#}");
        }
    }
}

fn status_of(state: DetectionState) -> (bool, String) {
    match state {
        DetectionState::Starting => (true, "waiting for the first hazard".into()),
        DetectionState::Online => (true, "obstacle detection online".into()),
        DetectionState::Offline(reason) => (false, format!("obstacle detection offline: {}", reason.describe())),
    }
}

/// Run with the given devices (tests and benchmarks pass fakes) until `shutdown`.
pub async fn run_with(config: FeedbackConfig, devices: Devices, shutdown: Shutdown) -> anyhow::Result<()> {
    let keys = config.bus.keys()?;
    let session = bus::open_session(&config.bus).await?;
    let health: Arc<Health> = Health::new(AGENT);
    let period = Duration::from_millis(config.health_period_ms.max(100));
    let mut health_task = health.spawn(session.clone(), keys.clone(), period, shutdown.clone());

    let haptic_key = keys.haptic();
    let speech_key = keys.speech();
    // Only the newest haptic intent matters; speech intents queue, none may be lost.
    // Stale or replayed ones are refused where they arrive: they never reach a device.
    let intent_age = Duration::from_millis(config.max_intent_age_ms);
    let speech_age = Duration::from_millis(config.max_speech_age_ms);
    let haptic_sub =
        Subscriber::<HapticIntent>::declare_fresh(&session, haptic_key.clone(), true, intent_age, &health).await?;
    let speech_sub =
        Subscriber::<SpeechIntent>::declare_fresh(&session, speech_key.clone(), false, speech_age, &health).await?;
    let hazard_sub = Subscriber::<Hazard>::declare_fresh(&session, keys.hazard(), true, intent_age, &health).await?;
    // Only `mute` is ours among the user commands; each one counts, none may be lost.
    let mute_key = keys.cmd("mute");
    let mute_sub = Subscriber::<Command>::declare_fresh(&session, mute_key.clone(), false, speech_age, &health).await?;
    let alive_key = keys.health(&config.compute_agent);
    let liveliness = session
        .liveliness()
        .declare_subscriber(alive_key.clone())
        .history(true)
        .await
        .map_err(|e| anyhow!("cannot watch the liveliness of {alive_key}: {e}"))?;
    let applied_key = keys.applied();
    let applied_pub =
        Publisher::<Applied>::declare(&session, applied_key.clone(), AGENT, Lane::Events, Some(&health)).await?;
    let (applied_tx, applied_rx) = mpsc::channel(APPLIED_BACKLOG);
    let applied_task = tokio::spawn(publish_applied(applied_pub, applied_rx));

    // The link outlives the loop: it carries the devices' last words (motors off).
    let link_stop = Shutdown::new();
    let phone_task = devices.phone.clone().map(|link| {
        let (session, keys, health, stop) = (session.clone(), keys.clone(), health.clone(), link_stop.clone());
        tokio::spawn(async move { run_link(link, &session, &keys, AGENT, &health, stop).await })
    });

    let started = now_ns();
    let mut feedback = Feedback::new(config.step_settings(), devices.haptics, devices.engines, started);
    let notes = devices.notes.into_iter().map(|(device, text)| Applied {
        device,
        action: AppliedAction::DeviceStatus { text },
        applied_ns: started,
        cause_capture_ns: 0,
    });
    publish(&applied_tx, notes, &health, &applied_key);
    tracing::info!(user = %config.bus.user, "feedback agent running (haptic {:?}, speech {:?})", config.haptic, config.speech);

    let mut shown = status_of(feedback.detection());
    health.set_status(shown.0, shown.1.clone());
    // Set when the loop ends on an error; the devices are still switched off first.
    let mut failure = None;
    loop {
        let now = now_ns();
        let wake = feedback.next_wake_ns(now);
        if wake <= now {
            // Timers are due: handle them before waiting, so a steady stream of
            // intents can never starve pulse edges, TTLs or the watchdog.
            feedback.tick(now);
        } else {
            let sleep = Duration::from_nanos(wake - now).min(Duration::from_millis(250));
            tokio::select! {
                biased;
                _ = shutdown.triggered() => break,
                e = health_task.failed() => {
                    failure = Some(e);
                    break;
                }
                Some(m) = haptic_sub.recv() => {
                    match feedback.on_haptic(&m.body, m.header.capture_ns, now_ns()) {
                        Ok(None) => {}
                        Ok(Some(note)) => health.reject(&haptic_key, "clamped", &note),
                        Err(r) => health.reject(&haptic_key, r.kind, &r.reason),
                    }
                }
                Some(m) = hazard_sub.recv() => feedback.on_hazard(&m.body, m.captured_ns, now_ns()),
                sample = liveliness.recv_async() => match sample {
                    Ok(s) => feedback.on_compute_liveliness(s.kind() == SampleKind::Put, now_ns()),
                    Err(e) => {
                        tracing::error!("liveliness subscription closed: {e}");
                        break;
                    }
                },
                Some(m) = mute_sub.recv() => {
                    if !feedback.on_command(&m.body, now_ns()) {
                        health.reject(&mute_key, "wrong_command", &format!("{} sent on the mute key", m.body.verb()));
                    }
                }
                Some(m) = speech_sub.recv() => {
                    if let Err(r) = feedback.on_speech(&m.body, m.header.capture_ns, now_ns()) {
                        health.reject(&speech_key, r.kind, &r.reason);
                    }
                }
                _ = tokio::time::sleep(sleep) => feedback.tick(now_ns()),
            }
        }
        publish(&applied_tx, feedback.drain_applied(), &health, &applied_key);
        let status = status_of(feedback.detection());
        if status != shown {
            health.set_status(status.0, status.1.clone());
            shown = status;
        }
    }
    feedback.shutdown(now_ns());
    publish(&applied_tx, feedback.drain_applied(), &health, &applied_key);
    drop(applied_tx);
    if let Err(e) = applied_task.await {
        tracing::warn!("applied publishing task ended abnormally: {e}");
    }
    drop(feedback);
    link_stop.trigger();
    if let Some(task) = phone_task {
        match task.await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => tracing::warn!("phone link: {e:#}"),
            Err(e) => tracing::warn!("phone link task ended abnormally: {e}"),
        }
    }
    if let Some(e) = failure {
        return Err(e);
    }
    health_task.join().await?;
    session.close().await.map_err(|e| anyhow!("closing the session: {e}"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_backlog_of_applied_records_is_counted_not_waited_for() {
        let health = Health::new(AGENT);
        let (tx, mut rx) = mpsc::channel(2);
        let record = |k: u64| Applied {
            device: "console".into(),
            action: AppliedAction::DeviceStatus { text: format!("note {k}") },
            applied_ns: k,
            cause_capture_ns: 0,
        };
        // nobody is draining the channel (the bus is congested): the call returns at once
        publish(&tx, (0..5).map(record), &health, "wearnav/u/feedback/applied");
        assert_eq!(health.rejects_of("applied_backlog"), 3);
        let kept: Vec<u64> = std::iter::from_fn(|| rx.try_recv().ok()).map(|a| a.applied_ns).collect();
        assert_eq!(kept, [0, 1], "the oldest records go out first");
    }
}
