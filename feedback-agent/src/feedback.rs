//! The feedback step: intents, hazards and liveliness in; device actions out.
//!
//! This joins the pure parts (`haptic_cue`, `speech_queue`, `watchdog`) to the devices
//! behind their traits, with `now` always given by the caller: the same step runs under
//! the bus loop (`run`), in tests with fake devices, and in the latency benchmark.
//! Safety rules 1-3 of ARCHITECTURE.md are enforced here: the offline warning goes
//! through every backend, every cue expires, and warnings pre-empt guidance speech.

use schemas::{Applied, AppliedAction, Command, HapticIntent, HapticPattern, Hazard, Priority, SpeechIntent};

use crate::device::{DeviceOutput, HapticDevice, SpeakingHandle, SpeechEngine, SpeechEvent};
use crate::haptic_cue::{CueLimits, HapticCue, Levels};
use crate::speech_queue::{QueueConfig, SpeechAction, SpeechQueue, Utterance};
use crate::watchdog::{DetectionState, DetectionWatchdog, GravityWatch, Transition, GRAVITY_MISSING};

const MS: u64 = 1_000_000;

/// Settings of the feedback step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepSettings {
    /// Limits applied to haptic intents.
    pub limits: CueLimits,
    /// Speech queue settings.
    pub queue: QueueConfig,
    /// Hazards older than this (or liveliness lost) mean detection is offline, ms.
    pub offline_after_ms: u64,
    /// Half period of the left/right offline alert, ms.
    pub alert_half_ms: u32,
    /// Left-right cycles per alert.
    pub alert_cycles: u32,
    /// While offline, the alert rumble repeats this often, ms (0 = once).
    pub alert_repeat_ms: u64,
    /// How often a speaking utterance is checked for its end, ms.
    pub speech_poll_ms: u64,
}

impl Default for StepSettings {
    /// 500 ms deadline (ARCHITECTURE.md rule 1); alert 150 ms per side x 3 cycles
    /// (~1 s, long enough to feel the alternation); repeated every 5 s while offline so
    /// a user who missed it is reminded; speech end checked every 20 ms.
    fn default() -> Self {
        Self {
            limits: CueLimits::default(),
            queue: QueueConfig::default(),
            offline_after_ms: 500,
            alert_half_ms: 150,
            alert_cycles: 3,
            alert_repeat_ms: 5000,
            speech_poll_ms: 20,
        }
    }
}

/// An input refused, with a short kind for the reject counters.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reject {
    /// Counter kind (`nan_level`, `empty_text`, ...).
    pub kind: &'static str,
    /// Human-readable reason.
    pub reason: String,
}

/// An utterance cut on an engine that confirms, waiting for it to say so.
struct CutUtterance {
    engine: usize,
    handle: Box<dyn SpeakingHandle>,
    text: String,
    priority: Priority,
    capture_ns: u64,
}

/// TTL of the agent's own utterances, ms.
const OWN_UTTERANCE_TTL_MS: u32 = 10_000;

/// The feedback step with its devices.
pub struct Feedback {
    settings: StepSettings,
    haptics: Vec<Box<dyn HapticDevice>>,
    engines: Vec<Box<dyn SpeechEngine>>,
    handles: Vec<(usize, Box<dyn SpeakingHandle>)>,
    /// Utterances cut on a confirming engine, until it says they stopped.
    cut: Vec<CutUtterance>,
    queue: SpeechQueue,
    watchdog: DetectionWatchdog,
    gravity: GravityWatch,
    obstacle: Option<HapticCue>,
    alert: Option<HapticCue>,
    /// The notice tap of an utterance that asked for one.
    notice: Option<HapticCue>,
    next_alert_ns: Option<u64>,
    out: DeviceOutput,
    actions: Vec<SpeechAction>,
    applied: Vec<Applied>,
    /// Last error of each engine, so a failing engine is logged once, not per utterance.
    engine_errors: Vec<Option<String>>,
}

impl Feedback {
    /// A step started at `now_ns` driving `haptics` and `engines`.
    pub fn new(
        settings: StepSettings,
        haptics: Vec<Box<dyn HapticDevice>>,
        engines: Vec<Box<dyn SpeechEngine>>,
        now_ns: u64,
    ) -> Self {
        Self {
            queue: SpeechQueue::new(settings.queue),
            watchdog: DetectionWatchdog::new(now_ns, settings.offline_after_ms),
            gravity: GravityWatch::default(),
            settings,
            haptics,
            handles: Vec::new(),
            cut: Vec::new(),
            engine_errors: vec![None; engines.len()],
            engines,
            obstacle: None,
            alert: None,
            notice: None,
            next_alert_ns: None,
            out: DeviceOutput::default(),
            actions: Vec::new(),
            applied: Vec::new(),
        }
    }

    /// Whether obstacle detection is believed to be running.
    pub fn detection(&self) -> DetectionState {
        self.watchdog.state()
    }

    /// Actions performed since the last drain, in order.
    pub fn drain_applied(&mut self) -> std::vec::Drain<'_, Applied> {
        self.applied.drain(..)
    }

    /// A haptic intent captured at `capture_ns` arrived at `now_ns`. Returns what was
    /// clamped, if anything; refuses NaN.
    pub fn on_haptic(&mut self, intent: &HapticIntent, capture_ns: u64, now_ns: u64) -> Result<Option<String>, Reject> {
        let accepted =
            HapticCue::from_intent(intent, capture_ns, now_ns, &self.settings.limits, self.obstacle.as_ref())
                .map_err(|e| Reject { kind: e.kind(), reason: e.to_string() })?;
        self.obstacle = Some(accepted.cue);
        self.drive_haptics(now_ns, true);
        Ok(accepted.clamped)
    }

    /// A speech intent captured at `capture_ns` arrived at `now_ns`.
    pub fn on_speech(&mut self, intent: &SpeechIntent, capture_ns: u64, now_ns: u64) -> Result<(), Reject> {
        let mut actions = std::mem::take(&mut self.actions);
        let offered = self.queue.offer(intent, capture_ns, now_ns, &mut actions);
        self.actions = actions;
        offered.map_err(|e| Reject { kind: e.kind(), reason: e.to_string() })?;
        self.perform_speech(now_ns);
        Ok(())
    }

    /// A user command arrived at `now_ns`. The feedback agent acts on `Mute` only
    /// (the others are the compute agent's); returns whether it acted.
    ///
    /// Muted, speech below `Important` is dropped, and the change is said once
    /// ("speech muted", "speech on") and published as a `DeviceStatus` of the
    /// `speech-queue`. Warnings, offline warnings and device news still sound.
    pub fn on_command(&mut self, command: &Command, now_ns: u64) -> bool {
        let Command::Mute { muted } = *command else { return false };
        let mut actions = std::mem::take(&mut self.actions);
        let changed = self.queue.set_muted(muted, now_ns, &mut actions);
        if changed {
            let text = if muted { "speech muted" } else { "speech on" };
            tracing::info!("{text}");
            self.out.applied("speech-queue", AppliedAction::DeviceStatus { text: text.into() }, now_ns, 0);
            // Cuts first, then the confirmation (the agent's own, so it passes the mute).
            self.actions = actions;
            self.perform_speech(now_ns);
            let mut actions = std::mem::take(&mut self.actions);
            self.queue.offer_own(text, Priority::Message, OWN_UTTERANCE_TTL_MS, now_ns, &mut actions);
            self.actions = actions;
            self.perform_speech(now_ns);
        } else {
            self.actions = actions;
        }
        true
    }

    /// True while the user has muted speech below `Important`.
    pub fn is_muted(&self) -> bool {
        self.queue.is_muted()
    }

    /// A hazard arrived at `now_ns`, from a depth frame captured at `captured_ns` on
    /// this agent's clock (the watchdog's deadline counts from there).
    pub fn on_hazard(&mut self, hazard: &Hazard, captured_ns: u64, now_ns: u64) {
        self.watchdog.on_hazard(captured_ns, now_ns, hazard.ground);
        self.check_detection(now_ns);
        if let Some(text) = self.gravity.on_hazard(captured_ns, hazard.ground, hazard.gravity) {
            if text == GRAVITY_MISSING {
                tracing::warn!("depth frames without gravity (no IMU): lower ground is looked for along the path only");
            } else {
                tracing::info!("depth frames carry gravity again");
            }
            let mut actions = std::mem::take(&mut self.actions);
            self.queue.offer_own(text, Priority::Important, OWN_UTTERANCE_TTL_MS, now_ns, &mut actions);
            self.actions = actions;
            self.perform_speech(now_ns);
        }
    }

    /// The compute agent's liveliness token appeared or disappeared.
    pub fn on_compute_liveliness(&mut self, alive: bool, now_ns: u64) {
        self.watchdog.on_compute_liveliness(alive);
        self.check_detection(now_ns);
    }

    /// Advance timers to `now_ns`: watchdog, pulse edges, TTLs, speech ends, devices.
    pub fn tick(&mut self, now_ns: u64) {
        self.check_detection(now_ns);
        if self.next_alert_ns.is_some_and(|at| now_ns >= at) {
            self.alert =
                Some(HapticCue::offline_alert(now_ns, self.settings.alert_half_ms, self.settings.alert_cycles));
            self.next_alert_ns = Some(now_ns + self.settings.alert_repeat_ms * MS);
        }
        self.confirmed_speech(now_ns);
        if self.queue.speaking().is_some() && self.handles.iter_mut().all(|(_, h)| h.is_finished(now_ns)) {
            for (engine, _) in self.handles.drain(..) {
                if self.engines[engine].confirms() {
                    continue; // its own events said it (confirmed_speech)
                }
                if let Some(u) = self.queue.speaking() {
                    let action = AppliedAction::SpeechFinished { text: u.text.clone() };
                    self.out.applied(self.engines[engine].name(), action, now_ns, u.capture_ns);
                }
            }
            let mut actions = std::mem::take(&mut self.actions);
            self.queue.finished(now_ns, &mut actions);
            self.actions = actions;
        }
        let mut actions = std::mem::take(&mut self.actions);
        self.queue.expire(now_ns, &mut actions);
        self.actions = actions;
        self.perform_speech(now_ns);
        for d in &mut self.haptics {
            if d.next_poll_ns().is_some_and(|t| now_ns >= t) {
                d.poll(now_ns, &mut self.out);
            }
        }
        self.drive_haptics(now_ns, false);
    }

    /// The next instant `tick` has work to do.
    pub fn next_wake_ns(&self, now_ns: u64) -> u64 {
        let mut next = u64::MAX;
        let mut consider = |t: Option<u64>| {
            if let Some(t) = t {
                next = next.min(t);
            }
        };
        consider(self.watchdog.next_check_ns());
        consider(self.obstacle.and_then(|c| c.next_change_ns(now_ns)));
        consider(self.alert.and_then(|c| c.next_change_ns(now_ns)));
        consider(self.notice.and_then(|c| c.next_change_ns(now_ns)));
        consider(self.next_alert_ns);
        consider(self.queue.next_expiry_ns());
        let speaking = self.queue.speaking().is_some() || !self.cut.is_empty();
        consider(speaking.then_some(now_ns + self.settings.speech_poll_ms * MS));
        for d in &self.haptics {
            consider(d.next_poll_ns());
        }
        next.max(now_ns)
    }

    /// Stop everything: speech cut, motors off.
    pub fn shutdown(&mut self, now_ns: u64) {
        let mut actions = std::mem::take(&mut self.actions);
        self.queue.clear(&mut actions);
        self.actions = actions;
        self.perform_speech(now_ns);
        self.obstacle = None;
        self.alert = None;
        self.notice = None;
        self.next_alert_ns = None;
        for d in &mut self.haptics {
            d.off(now_ns, &mut self.out);
        }
        self.applied.append(&mut self.out.applied);
    }

    fn check_detection(&mut self, now_ns: u64) {
        let Some(transition) = self.watchdog.step(now_ns) else { return };
        let (offline, reason, text) = match transition {
            Transition::Offline(reason) => {
                tracing::warn!("obstacle detection offline: {}", reason.describe());
                self.alert =
                    Some(HapticCue::offline_alert(now_ns, self.settings.alert_half_ms, self.settings.alert_cycles));
                self.next_alert_ns =
                    (self.settings.alert_repeat_ms > 0).then(|| now_ns + self.settings.alert_repeat_ms * MS);
                (true, reason.describe(), reason.utterance())
            }
            Transition::Back => {
                tracing::info!("obstacle detection back");
                self.alert = None;
                self.next_alert_ns = None;
                (false, "hazards fresh again", "obstacle detection back")
            }
        };
        let names: Vec<String> = if self.haptics.is_empty() {
            vec!["feedback-agent".to_string()]
        } else {
            self.haptics.iter().map(|d| d.name().to_string()).collect()
        };
        for name in names {
            let action = AppliedAction::OfflineWarning { offline, reason: reason.to_string() };
            self.out.applied(&name, action, now_ns, 0);
        }
        let mut actions = std::mem::take(&mut self.actions);
        self.queue.offer_status(text, OWN_UTTERANCE_TTL_MS, now_ns, &mut actions);
        self.actions = actions;
        self.perform_speech(now_ns);
        self.drive_haptics(now_ns, false);
    }

    /// Drive every haptic device to the state of now. `refresh` is true when an intent
    /// has just arrived: devices re-send their state, and what they do is caused by that
    /// intent (its capture stamp goes into `applied`). Otherwise the agent's own timing
    /// acts (pulse edges, TTL expiry, alerts) and `applied` says so with a cause of 0, so
    /// capture -> applied measures the agent, not where in a pulse train an intent fell.
    fn drive_haptics(&mut self, now_ns: u64, refresh: bool) {
        let alert = self.alert.filter(|a| a.is_live(now_ns));
        self.alert = alert;
        // a notice taps only on idle motors: an obstacle cue (even between its pulses)
        // or an alert cancels it
        let busy = alert.is_some() || self.obstacle.is_some_and(|o| o.is_live(now_ns) && !o.is_at_rest());
        self.notice = self.notice.filter(|n| n.is_live(now_ns) && !busy);
        let (levels, pattern, cause) = match (alert, self.obstacle, self.notice) {
            (Some(a), _, _) => (a.levels_at(now_ns), a.pattern(), 0),
            (None, _, Some(n)) => (n.levels_at(now_ns), n.pattern(), 0),
            (None, Some(o), None) => (o.levels_at(now_ns), o.pattern(), if refresh { o.cause_capture_ns } else { 0 }),
            (None, None, None) => (Levels::OFF, HapticPattern::Steady, 0),
        };
        if self.obstacle.is_some_and(|o| !o.is_live(now_ns)) {
            self.obstacle = None;
        }
        for d in &mut self.haptics {
            d.set_levels(levels, pattern, cause, now_ns, refresh, &mut self.out);
        }
        self.absorb_device_output(now_ns);
    }

    /// Move device records to `applied`, and speak device news.
    fn absorb_device_output(&mut self, now_ns: u64) {
        self.applied.append(&mut self.out.applied);
        if self.out.say.is_empty() {
            return;
        }
        let mut actions = std::mem::take(&mut self.actions);
        for news in self.out.say.drain(..) {
            self.queue.offer_news(&news.device, &news.text, OWN_UTTERANCE_TTL_MS, now_ns, &mut actions);
        }
        self.actions = actions;
        self.perform_speech(now_ns);
    }

    fn perform_speech(&mut self, now_ns: u64) {
        let mut actions = std::mem::take(&mut self.actions);
        let mut k = 0;
        while k < actions.len() {
            match &actions[k] {
                SpeechAction::Cut(u) => {
                    for (engine, mut h) in self.handles.drain(..) {
                        h.cut();
                        if self.engines[engine].confirms() {
                            let (text, priority, capture_ns) = (u.text.clone(), u.priority, u.capture_ns);
                            self.cut.push(CutUtterance { engine, handle: h, text, priority, capture_ns });
                            continue;
                        }
                        let action = AppliedAction::SpeechInterrupted { text: u.text.clone() };
                        self.out.applied(self.engines[engine].name(), action, now_ns, u.capture_ns);
                    }
                }
                SpeechAction::Start(u) => {
                    self.start_utterance(u, now_ns);
                    if self.handles.is_empty() {
                        // Nothing could speak it: move on rather than wait forever.
                        self.queue.finished(now_ns, &mut actions);
                    }
                }
                SpeechAction::Drop { utterance, reason } => {
                    let action =
                        AppliedAction::SpeechDropped { text: utterance.text.clone(), reason: reason.to_string() };
                    self.out.applied("speech-queue", action, now_ns, utterance.capture_ns);
                }
            }
            k += 1;
        }
        actions.clear();
        self.actions = actions;
        self.applied.append(&mut self.out.applied);
    }

    /// Report what confirming engines say happened to the utterance being spoken and to
    /// the ones cut, at the device's own times.
    fn confirmed_speech(&mut self, now_ns: u64) {
        let speaking = self.queue.speaking().map(|u| (u.text.clone(), u.priority, u.capture_ns));
        for (engine, h) in &mut self.handles {
            let name = self.engines[*engine].name();
            let Some((text, priority, cause)) = &speaking else { continue };
            for event in h.take_events(now_ns) {
                let (action, at) = match event {
                    SpeechEvent::Started(at) => {
                        (AppliedAction::SpeechStarted { text: text.clone(), priority: *priority }, at)
                    }
                    SpeechEvent::Ended(at) => (AppliedAction::SpeechFinished { text: text.clone() }, at),
                    SpeechEvent::Interrupted(at) => (AppliedAction::SpeechInterrupted { text: text.clone() }, at),
                    SpeechEvent::Failed { at_ns, reason } => {
                        let text = format!("{name} could not say {text:?}: {reason}");
                        (AppliedAction::DeviceStatus { text }, at_ns)
                    }
                };
                self.out.applied(name, action, at, *cause);
            }
        }
        let mut k = 0;
        while k < self.cut.len() {
            let c = &mut self.cut[k];
            let name = self.engines[c.engine].name();
            let mut over = false;
            for event in c.handle.take_events(now_ns) {
                let (action, at) = match event {
                    // it began before the cut reached the device
                    SpeechEvent::Started(at) => {
                        (AppliedAction::SpeechStarted { text: c.text.clone(), priority: c.priority }, at)
                    }
                    // it had ended before the cut reached the device
                    SpeechEvent::Ended(at) => (AppliedAction::SpeechFinished { text: c.text.clone() }, at),
                    SpeechEvent::Interrupted(at) => (AppliedAction::SpeechInterrupted { text: c.text.clone() }, at),
                    SpeechEvent::Failed { at_ns, reason } => {
                        let text = format!("{name} could not say {:?}: {reason}", c.text);
                        (AppliedAction::DeviceStatus { text }, at_ns)
                    }
                };
                over |= !matches!(action, AppliedAction::SpeechStarted { .. });
                self.out.applied(name, action, at, c.capture_ns);
            }
            if over {
                self.cut.swap_remove(k);
            } else {
                k += 1;
            }
        }
        self.applied.append(&mut self.out.applied);
    }

    fn start_utterance(&mut self, u: &Utterance, now_ns: u64) {
        if u.notice && !self.haptics.is_empty() {
            self.notice = Some(HapticCue::notice(now_ns));
            self.drive_haptics(now_ns, false);
        }
        let mut voices = 0;
        for (k, engine) in self.engines.iter_mut().enumerate() {
            if u.about.as_deref() == Some(engine.name()) {
                continue; // news of this device: its own voice does not say it
            }
            voices += 1;
            match engine.start(&u.text, u.priority, now_ns) {
                Ok(handle) => {
                    if self.engine_errors[k].take().is_some() {
                        tracing::info!("{} speaks again", engine.name());
                    }
                    self.handles.push((k, handle));
                    if engine.confirms() {
                        continue; // reported when the device says it started
                    }
                    let action = AppliedAction::SpeechStarted { text: u.text.clone(), priority: u.priority };
                    self.out.applied(engine.name(), action, now_ns, u.capture_ns);
                }
                Err(e) => {
                    let text = e.to_string();
                    if self.engine_errors[k].as_ref() != Some(&text) {
                        tracing::warn!("{} cannot speak: {text}", engine.name());
                    }
                    self.out.applied(engine.name(), AppliedAction::DeviceStatus { text: text.clone() }, now_ns, 0);
                    self.engine_errors[k] = Some(text);
                }
            }
        }
        if let (0, Some(device)) = (voices, &u.about) {
            let reason = format!("news of the {device}: no other voice to say it");
            let action = AppliedAction::SpeechDropped { text: u.text.clone(), reason };
            self.out.applied("speech-queue", action, now_ns, u.capture_ns);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::console::ConsoleSpeech;
    use crate::haptic_cue::NOTICE_LEVEL;
    use crate::wiimote::fake::FakeHid;
    use crate::wiimote::{WiimoteBackend, WiimoteConfig};
    use schemas::GroundState;

    const T0: u64 = 1_700_000_000_000_000_000;
    const LEFT: &str = "/dev/hidraw0";
    const RIGHT: &str = "/dev/hidraw1";

    fn setup() -> (FakeHid, Feedback) {
        let hid = FakeHid::new();
        hid.attach(LEFT, "l");
        hid.attach(RIGHT, "r");
        let wii = WiimoteBackend::new(Box::new(hid.clone()), WiimoteConfig::default());
        let speech = ConsoleSpeech::new(Box::new(std::io::sink()), 175);
        let mut f = Feedback::new(StepSettings::default(), vec![Box::new(wii)], vec![Box::new(speech)], T0);
        f.tick(T0);
        f.drain_applied();
        hid.clear_written();
        (hid, f)
    }

    fn hazard(ground: GroundState) -> Hazard {
        Hazard::nothing_ahead(0, ground)
    }

    fn steady(left: f32, right: f32, ttl_ms: u32) -> HapticIntent {
        HapticIntent { left, right, pattern: HapticPattern::Steady, ttl_ms }
    }

    fn spoken(f: &mut Feedback) -> Vec<String> {
        f.drain_applied()
            .filter_map(|a| match a.action {
                AppliedAction::SpeechStarted { text, .. } => Some(format!("start {text}")),
                AppliedAction::SpeechInterrupted { text } => Some(format!("cut {text}")),
                _ => None,
            })
            .collect()
    }

    /// Keep detection online with a fresh hazard at `now`.
    fn fresh(f: &mut Feedback, now: u64) {
        f.on_hazard(&hazard(GroundState::Found), now, now);
    }

    /// A phone that never answers is news for the user, said by every voice but the
    /// phone's own; with the phone the only voice, it is dropped, and said why.
    #[test]
    fn news_of_the_phone_is_not_said_by_the_phone() {
        use crate::phone::{Outgoing, PhoneHaptic, PhoneLink, PhoneSpeech as Phone, LOST_AFTER_MS};
        const NEWS: &str = "Phone not connected: no vibration on the phone.";
        let said_on_phone = |link: &PhoneLink| {
            link.take_outgoing()
                .into_iter()
                .filter_map(|o| match o {
                    Outgoing::Speech(schemas::PhoneSpeech::Say { text, .. }) => Some(text),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        for with_console in [true, false] {
            let link = PhoneLink::new();
            let mut voices: Vec<Box<dyn SpeechEngine>> = vec![Box::new(Phone::new(link.clone()))];
            if with_console {
                voices.push(Box::new(ConsoleSpeech::new(Box::new(std::io::sink()), 175)));
            }
            let haptics: Vec<Box<dyn HapticDevice>> = vec![Box::new(PhoneHaptic::new(link.clone()))];
            let mut f = Feedback::new(StepSettings::default(), haptics, voices, T0);
            let mut phone_said = Vec::new();
            let mut t = T0;
            while t <= T0 + (LOST_AFTER_MS + 200) * MS {
                fresh(&mut f, t);
                f.tick(t);
                phone_said.extend(said_on_phone(&link));
                t += 50 * MS;
            }
            let applied: Vec<Applied> = f.drain_applied().collect();
            let started_on = |device: &str| {
                applied.iter().any(|a| {
                    a.device == device && matches!(&a.action, AppliedAction::SpeechStarted { text, .. } if text == NEWS)
                })
            };
            assert!(
                applied.iter().any(|a| a.action == AppliedAction::DeviceStatus { text: NEWS.into() }),
                "the phone was never found missing: {applied:?}"
            );
            assert!(!phone_said.iter().any(|t| t == NEWS), "the phone was asked to say its own news: {phone_said:?}");
            assert_eq!(started_on("console"), with_console, "{applied:?}");
            let dropped = applied.iter().any(|a| {
                matches!(&a.action, AppliedAction::SpeechDropped { text, reason }
                    if text == NEWS && reason == "news of the phone: no other voice to say it")
            });
            assert_eq!(dropped, !with_console, "{applied:?}");
        }
    }

    #[test]
    fn a_confirming_engine_reports_speech_at_the_devices_times_and_a_cut_when_it_stopped() {
        use crate::phone::{Outgoing, PhoneLink, PhoneSpeech as Phone};
        use schemas::{PhoneAck, PhoneEvent, PhoneSpeech};
        let link = PhoneLink::new();
        let mut f = Feedback::new(StepSettings::default(), vec![], vec![Box::new(Phone::new(link.clone()))], T0);
        fresh(&mut f, T0);
        f.tick(T0);
        f.drain_applied();
        let say = |text: &str, priority| SpeechIntent {
            text: text.into(),
            priority,
            interrupt: false,
            ttl_ms: 2000,
            dedup_key: String::new(),
            notice: false,
        };
        let said = |link: &PhoneLink| -> Vec<u64> {
            link.take_outgoing()
                .into_iter()
                .filter_map(|o| match o {
                    Outgoing::Speech(PhoneSpeech::Say { id, .. }) => Some(id),
                    _ => None,
                })
                .collect()
        };
        f.on_speech(&say("Turn left.", Priority::Message), T0, T0 + MS).unwrap();
        let turn = said(&link)[0];
        assert!(spoken(&mut f).is_empty(), "nothing reported before the phone says it started");
        link.acknowledge(PhoneAck { id: turn, event: PhoneEvent::Started, at_ns: T0 + 60 * MS });
        f.tick(T0 + 70 * MS);
        let started: Vec<(String, u64, u64)> =
            f.drain_applied().map(|a| (format!("{:?}", a.action), a.applied_ns, a.cause_capture_ns)).collect();
        assert_eq!(started, [(r#"SpeechStarted { text: "Turn left.", priority: Message }"#.into(), T0 + 60 * MS, T0)]);

        // a warning cuts it: the interruption is reported when the phone says it stopped
        f.on_speech(&say("Stop.", Priority::Important), T0 + 100 * MS, T0 + 100 * MS).unwrap();
        let out = link.take_outgoing();
        assert!(matches!(out[0], Outgoing::Speech(PhoneSpeech::Cut { id }) if id == turn), "{out:?}");
        assert!(spoken(&mut f).is_empty());
        link.acknowledge(PhoneAck { id: turn, event: PhoneEvent::Interrupted, at_ns: T0 + 130 * MS });
        f.tick(T0 + 140 * MS);
        let cut: Vec<(String, u64)> = f.drain_applied().map(|a| (format!("{:?}", a.action), a.applied_ns)).collect();
        assert_eq!(cut, [(r#"SpeechInterrupted { text: "Turn left." }"#.into(), T0 + 130 * MS)]);
    }

    #[test]
    fn stale_intent_stops_rumble_within_ttl() {
        let (hid, mut f) = setup();
        fresh(&mut f, T0);
        f.on_haptic(&steady(1.0, 0.0, 200), T0, T0 + MS).unwrap();
        assert_eq!(hid.written_to(LEFT), vec![vec![0x10, 0x01]]);
        assert!(f.next_wake_ns(T0 + MS) <= T0 + 200 * MS, "woken up by the TTL at the latest");
        fresh(&mut f, T0 + 199 * MS);
        f.tick(T0 + 199 * MS);
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x10, 0x01]);
        f.tick(T0 + 200 * MS);
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x10, 0x00]);
        let rumble: Vec<(f32, u64)> = f
            .drain_applied()
            .filter_map(|a| match a.action {
                AppliedAction::Rumble { left, .. } if a.device == "wiimote-left" => Some((left, a.cause_capture_ns)),
                _ => None,
            })
            .collect();
        // on at the intent's arrival, caused by it; off by the agent's own TTL timing
        assert_eq!(rumble, [(1.0, T0), (0.0, 0)]);
    }

    #[test]
    fn pulses_are_timed_by_the_agent_on_the_remote() {
        let (hid, mut f) = setup();
        fresh(&mut f, T0);
        let pulses = HapticIntent {
            left: 0.0,
            right: 1.0,
            pattern: HapticPattern::Pulses { period_ms: 200, duty: 0.5 },
            ttl_ms: 1000,
        };
        f.on_haptic(&pulses, T0, T0).unwrap();
        assert_eq!(f.next_wake_ns(T0), T0 + 50 * MS, "wiimote input poll, then the off edge at 100 ms");
        let mut at = Vec::new();
        for ms in [50, 100, 150, 200, 300] {
            fresh(&mut f, T0 + ms * MS);
            f.tick(T0 + ms * MS);
            at.push(hid.written_to(RIGHT).last().cloned().unwrap());
        }
        assert_eq!(at, [vec![0x10, 0x01], vec![0x10, 0x00], vec![0x10, 0x00], vec![0x10, 0x01], vec![0x10, 0x00]]);
    }

    #[test]
    fn silence_at_start_is_announced_with_the_alternating_alert() {
        let (hid, mut f) = setup();
        assert_eq!(f.next_wake_ns(T0 + MS), T0 + 50 * MS, "the wiimote input poll comes first");
        f.tick(T0 + 500 * MS);
        let applied: Vec<Applied> = f.drain_applied().collect();
        assert!(applied.iter().any(|a| a.action
            == AppliedAction::OfflineWarning { offline: true, reason: "no hazard received since start".into() }));
        assert!(applied.iter().any(|a| a.action
            == AppliedAction::SpeechStarted {
                text: "obstacle detection not yet running".into(),
                priority: Priority::Important
            }));
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x10, 0x01]);
        assert_eq!(hid.written_to(RIGHT), Vec::<Vec<u8>>::new(), "right stays off in the first half");
        f.tick(T0 + 650 * MS);
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x10, 0x00]);
        assert_eq!(hid.written_to(RIGHT).last().unwrap(), &vec![0x10, 0x01]);
        // After the alert the motors rest, and the reminder comes back 5 s later.
        f.tick(T0 + 1400 * MS);
        assert_eq!(hid.written_to(RIGHT).last().unwrap(), &vec![0x10, 0x00]);
        f.tick(T0 + 5500 * MS);
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x10, 0x01]);
    }

    #[test]
    fn frames_without_gravity_are_spoken_as_a_missing_tilt_sensor_once() {
        let (_hid, mut f) = setup();
        let with = hazard(GroundState::Found);
        let without = Hazard { gravity: false, ..hazard(GroundState::Found) };
        let mut said = Vec::new();
        for k in 0..90 {
            let now = T0 + k * 33 * MS;
            f.on_hazard(if k < 30 { &with } else { &without }, now, now);
            f.tick(now);
            said.extend(spoken(&mut f));
        }
        assert_eq!(said, ["start No tilt sensor: steps down may be missed"]);
        assert_eq!(f.detection(), DetectionState::Online, "no frame was refused: detection stays on");
    }

    #[test]
    fn hazards_resuming_are_announced_as_back_and_stop_the_alert() {
        let (hid, mut f) = setup();
        fresh(&mut f, T0 + 10 * MS);
        f.tick(T0 + 600 * MS);
        assert_eq!(spoken(&mut f), ["start obstacle detection offline"]);
        fresh(&mut f, T0 + 700 * MS);
        let applied: Vec<Applied> = f.drain_applied().collect();
        assert!(applied.iter().any(|a| matches!(&a.action, AppliedAction::OfflineWarning { offline: false, .. })));
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x10, 0x00], "alert cut short");
        // "back" waits for "offline" to finish (both important), then is said once.
        let mut said = Vec::new();
        for k in 1..=30 {
            fresh(&mut f, T0 + (700 + k * 100) * MS);
            f.tick(T0 + (700 + k * 100) * MS);
            said.extend(spoken(&mut f));
        }
        assert_eq!(said, ["start obstacle detection back"]);
    }

    #[test]
    fn flickering_ground_does_not_push_a_warning_out_of_the_queue() {
        let (_, mut f) = setup();
        fresh(&mut f, T0);
        f.tick(T0);
        // the ground comes and goes at 30 Hz for 5 s: found, lost five times, degraded
        use GroundState::{Degraded, Found, Lost};
        let cycle = [Found, Lost, Lost, Lost, Lost, Lost, Degraded];
        let mut said = Vec::new();
        let mut now = T0;
        for &ground in cycle.iter().cycle().take(150) {
            now += 33 * MS;
            f.on_hazard(&hazard(ground), now, now);
            f.tick(now);
            said.extend(spoken(&mut f));
        }
        let warning = SpeechIntent {
            text: "stop, wall ahead".into(),
            priority: Priority::Important,
            interrupt: false,
            ttl_ms: 3000,
            dedup_key: String::new(),
            notice: false,
        };
        f.on_speech(&warning, now, now).unwrap();
        let warned_at = now;
        said.extend(spoken(&mut f));
        let before = said.len();
        while now < warned_at + 3000 * MS {
            now += 33 * MS;
            fresh(&mut f, now);
            f.tick(now);
            said.extend(spoken(&mut f));
        }
        let at = said.iter().position(|s| s == "start stop, wall ahead");
        assert!(at.is_some(), "the warning was never spoken: {said:?}");
        // only the newest status, waiting when the warning came, was started before it
        assert!(at.unwrap() - before <= 1, "{said:?}");
    }

    #[test]
    fn compute_liveliness_loss_warns_at_once() {
        let (_, mut f) = setup();
        f.on_compute_liveliness(true, T0);
        fresh(&mut f, T0 + 10 * MS);
        f.on_compute_liveliness(false, T0 + 20 * MS);
        assert_eq!(spoken(&mut f), ["start obstacle detection offline"]);
    }

    #[test]
    fn guidance_asking_for_notice_taps_twice_lightly_on_idle_motors_only() {
        let left_levels = |f: &mut Feedback| -> Vec<f32> {
            f.drain_applied()
                .filter_map(|a| match a.action {
                    AppliedAction::Rumble { left, .. } if a.device == "wiimote-left" => Some(left),
                    _ => None,
                })
                .collect()
        };
        let say = |notice| SpeechIntent {
            text: "in six metres turn left".into(),
            priority: Priority::Message,
            interrupt: false,
            ttl_ms: 3000,
            dedup_key: String::new(),
            notice,
        };
        // path clear: tap on, off, on, off within 170 ms, then nothing
        let (_, mut f) = setup();
        fresh(&mut f, T0);
        f.on_haptic(&steady(0.0, 0.0, 500), T0, T0).unwrap();
        f.drain_applied();
        f.on_speech(&say(true), T0, T0 + MS).unwrap();
        for k in 2..=300u64 {
            f.tick(T0 + k * MS);
        }
        // the Wiimote's motor is on or off: the tap is told apart by being brief
        let taps = left_levels(&mut f);
        assert_eq!(taps, [1.0, 0.0, 1.0, 0.0], "{taps:?}");
        const { assert!(NOTICE_LEVEL < 0.5, "light where a motor can be") };
        // an utterance that does not ask for it: no tap
        let (_, mut f) = setup();
        fresh(&mut f, T0);
        f.drain_applied();
        f.on_speech(&say(false), T0, T0 + MS).unwrap();
        for k in 2..=300u64 {
            f.tick(T0 + k * MS);
        }
        assert!(left_levels(&mut f).is_empty());
        // an obstacle cue on: the obstacle is felt, never the tap
        let (_, mut f) = setup();
        fresh(&mut f, T0);
        f.on_haptic(&steady(0.8, 0.0, 500), T0, T0).unwrap();
        f.drain_applied();
        f.on_speech(&say(true), T0, T0 + MS).unwrap();
        for k in 2..=300u64 {
            f.tick(T0 + k * MS);
        }
        // the steady obstacle cue holds the motor on until its TTL: nothing changes
        assert!(left_levels(&mut f).is_empty(), "the notice was felt over an obstacle");
    }

    #[test]
    fn warning_preempts_guidance_speech() {
        let (_, mut f) = setup();
        fresh(&mut f, T0);
        let say = |text: &str, priority| SpeechIntent {
            text: text.into(),
            priority,
            interrupt: false,
            ttl_ms: 3000,
            dedup_key: String::new(),
            notice: false,
        };
        f.on_speech(&say("in ten metres turn left at the lift", Priority::Message), T0, T0).unwrap();
        f.on_speech(&say("stop", Priority::Important), T0 + 5 * MS, T0 + 5 * MS).unwrap();
        assert_eq!(
            spoken(&mut f),
            ["start in ten metres turn left at the lift", "cut in ten metres turn left at the lift", "start stop"]
        );
    }

    #[test]
    fn mute_silences_guidance_once_but_warnings_still_sound() {
        let (_, mut f) = setup();
        fresh(&mut f, T0);
        let say = |text: &str, priority| SpeechIntent {
            text: text.into(),
            priority,
            interrupt: false,
            ttl_ms: 3000,
            dedup_key: String::new(),
            notice: false,
        };
        f.on_speech(&say("in ten metres turn left", Priority::Message), T0, T0).unwrap();
        f.drain_applied();
        assert!(f.on_command(&Command::Mute { muted: true }, T0 + MS));
        let applied: Vec<Applied> = f.drain_applied().collect();
        assert!(applied
            .iter()
            .any(|a| a.device == "speech-queue"
                && a.action == AppliedAction::DeviceStatus { text: "speech muted".into() }));
        let said: Vec<String> = applied
            .into_iter()
            .filter_map(|a| match a.action {
                AppliedAction::SpeechStarted { text, .. } => Some(format!("start {text}")),
                AppliedAction::SpeechInterrupted { text } => Some(format!("cut {text}")),
                _ => None,
            })
            .collect();
        assert_eq!(said, ["cut in ten metres turn left", "start speech muted"]);
        assert!(f.on_command(&Command::Mute { muted: true }, T0 + 2 * MS));
        assert!(spoken(&mut f).is_empty(), "said once, not on every repeat of the command");
        f.on_speech(&say("lift on your right", Priority::Text), T0 + 3 * MS, T0 + 3 * MS).unwrap();
        let dropped: Vec<Applied> = f.drain_applied().collect();
        assert!(dropped
            .iter()
            .any(|a| a.action
                == AppliedAction::SpeechDropped { text: "lift on your right".into(), reason: "muted".into() }));
        f.on_speech(&say("stop, wall ahead", Priority::Important), T0 + 4 * MS, T0 + 4 * MS).unwrap();
        assert_eq!(spoken(&mut f), ["cut speech muted", "start stop, wall ahead"]);
        // Detection going offline is still announced while muted.
        f.tick(T0 + 600 * MS);
        assert!(f.drain_applied().any(|a| matches!(a.action, AppliedAction::OfflineWarning { offline: true, .. })));
        assert!(f.on_command(&Command::Mute { muted: false }, T0 + 700 * MS));
        assert!(!f.is_muted());
        assert!(!f.on_command(&Command::Repeat, T0 + 700 * MS), "other commands are the compute agent's");
    }

    #[test]
    fn nan_intent_is_rejected_and_leaves_the_motors_alone() {
        let (hid, mut f) = setup();
        fresh(&mut f, T0);
        let r = f.on_haptic(&steady(f32::NAN, 1.0, 200), T0, T0).unwrap_err();
        assert_eq!(r.kind, "nan_level");
        assert!(hid.written().is_empty());
        let clamped = f.on_haptic(&steady(3.0, 0.0, 200), T0, T0).unwrap();
        assert!(clamped.is_some());
        assert_eq!(hid.written_to(LEFT), vec![vec![0x10, 0x01]]);
    }

    #[test]
    fn remote_disconnect_is_spoken() {
        let (hid, mut f) = setup();
        fresh(&mut f, T0);
        hid.detach(RIGHT);
        f.on_haptic(&steady(0.0, 1.0, 200), T0, T0 + MS).unwrap();
        assert_eq!(spoken(&mut f), ["start right controller disconnected"]);
    }

    #[test]
    fn shutdown_turns_rumble_off() {
        let (hid, mut f) = setup();
        fresh(&mut f, T0);
        f.on_haptic(&steady(1.0, 1.0, 1000), T0, T0).unwrap();
        f.shutdown(T0 + MS);
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x10, 0x00]);
        assert_eq!(hid.written_to(RIGHT).last().unwrap(), &vec![0x10, 0x00]);
    }
}
