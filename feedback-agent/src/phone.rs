//! The phone as a feedback device: vibration and speech on the user's phone, through
//! the phone bridge (`phone/haptic`, `phone/speech` out; `phone/ack` back).
//!
//! Nothing is reported on `feedback/applied` until the phone page says it did it:
//! a rumble when the page called `navigator.vibrate`, an utterance when it started,
//! ended or was cut, each with the page's time on the bridge's clock. A phone that
//! stops answering is a lost device, and the user is told on the other devices.
//!
//! The device side ([`PhoneHaptic`], [`PhoneSpeech`]) is synchronous like every
//! backend; it shares a [`PhoneLink`] with the bus side ([`run_link`]), which publishes
//! the requests and files the acknowledgements.

use std::collections::{HashSet, VecDeque};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use schemas::{AppliedAction, HapticPattern, PhoneAck, PhoneEvent, Priority};
use tokio::sync::Notify;

use crate::device::{DeviceOutput, HapticDevice, SpeakingHandle, SpeechEngine, SpeechError, SpeechEvent};
use crate::haptic_cue::Levels;

const MS: u64 = 1_000_000;

/// Device name on `feedback/applied`.
pub const DEVICE: &str = "phone";

/// How long one vibration request runs on the phone by itself, ms: a phone that loses
/// the link stops within this time (safety rule 2: no rumble outlives its intent).
pub const WINDOW_MS: u32 = 1200;
/// A running vibration is renewed this often, ms (before its window ends).
pub const RENEW_MS: u64 = 800;
/// An idle phone is asked to confirm it is there this often, ms.
pub const KEEPALIVE_MS: u64 = 1000;
/// A request unanswered for this long means the phone is lost, ms.
pub const LOST_AFTER_MS: u64 = 2500;
/// An utterance the phone has not started within this time is given up, ms.
pub const START_TIMEOUT_MS: u64 = 3000;
/// Right-side rhythm: on, off (ms). The left side is one unbroken vibration.
pub const RIGHT_RHYTHM_MS: [u32; 2] = [60, 40];
/// Both sides: long breaks (ms), unlike either side alone.
pub const BOTH_RHYTHM_MS: [u32; 2] = [200, 60];
/// Acknowledgements kept for utterances not yet looked at.
const MAX_WAITING_ACKS: usize = 256;
/// How often acknowledgements are looked for, ms.
pub const POLL_MS: u64 = 20;
/// Shortest vibration a phone motor renders as a distinct pulse, ms.
pub const MIN_PULSE_MS: u32 = 40;

/// A request for the phone, as the bus side publishes it.
#[derive(Debug, Clone, PartialEq)]
pub enum Outgoing {
    /// `phone/haptic`.
    Haptic(schemas::PhoneHaptic),
    /// `phone/speech`.
    Speech(schemas::PhoneSpeech),
}

#[derive(Debug, Default)]
struct LinkState {
    next_id: u64,
    outbox: VecDeque<Outgoing>,
    haptic_acks: VecDeque<PhoneAck>,
    speech_acks: VecDeque<PhoneAck>,
    /// Utterances the phone has finished (ended, cut or failed).
    done: HashSet<u64>,
}

/// What the phone devices and the bus side share.
#[derive(Debug, Clone, Default)]
pub struct PhoneLink {
    state: Arc<Mutex<LinkState>>,
    wake: Arc<Notify>,
}

impl PhoneLink {
    /// A link with nothing sent yet.
    pub fn new() -> Self {
        Self::default()
    }

    fn lock(&self) -> MutexGuard<'_, LinkState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn next_id(&self) -> u64 {
        let mut s = self.lock();
        s.next_id += 1;
        s.next_id
    }

    fn send(&self, request: Outgoing) {
        self.lock().outbox.push_back(request);
        self.wake.notify_one();
    }

    /// Requests waiting for the bus, oldest first.
    pub fn take_outgoing(&self) -> Vec<Outgoing> {
        self.lock().outbox.drain(..).collect()
    }

    /// Wait until a request is waiting.
    pub async fn outgoing(&self) {
        self.wake.notified().await
    }

    /// File an acknowledgement from the page.
    pub fn acknowledge(&self, ack: PhoneAck) {
        let mut s = self.lock();
        match ack.event {
            PhoneEvent::Vibrated => s.haptic_acks.push_back(ack),
            _ => {
                if !matches!(ack.event, PhoneEvent::Started) {
                    s.done.insert(ack.id);
                }
                s.speech_acks.push_back(ack);
                // answers for utterances nobody waits for (a page confused, or hostile)
                // must not pile up
                while s.speech_acks.len() > MAX_WAITING_ACKS {
                    if let Some(old) = s.speech_acks.pop_front() {
                        s.done.remove(&old.id);
                    }
                }
            }
        }
    }

    fn take_haptic_acks(&self) -> Vec<PhoneAck> {
        self.lock().haptic_acks.drain(..).collect()
    }

    fn take_speech_acks(&self, id: u64) -> Vec<PhoneAck> {
        let mut s = self.lock();
        let (mine, rest): (VecDeque<_>, VecDeque<_>) = s.speech_acks.drain(..).partition(|a| a.id == id);
        s.speech_acks = rest;
        mine.into()
    }

    fn is_done(&self, id: u64) -> bool {
        self.lock().done.contains(&id)
    }

    fn forget(&self, id: u64) {
        let mut s = self.lock();
        s.done.remove(&id);
        s.speech_acks.retain(|a| a.id != id);
    }
}

/// The `navigator.vibrate` pattern for `levels` played as `pattern`, lasting about
/// `window_ms`. The phone has one motor, so the side is the rhythm: left one unbroken
/// vibration, right a fast broken one ([`RIGHT_RHYTHM_MS`]), both a slow broken one
/// ([`BOTH_RHYTHM_MS`]); pulses keep their period and duty (the on-time at least
/// [`MIN_PULSE_MS`]), each pulse carrying the side's rhythm. Off is `[0]`.
pub fn vibrate_pattern(levels: Levels, pattern: HapticPattern, window_ms: u32) -> Vec<u32> {
    let (left, right) = (levels.left > 0.0, levels.right > 0.0);
    if !left && !right {
        return vec![0];
    }
    let rhythm = match (left, right) {
        (true, false) => None,
        (false, true) => Some(RIGHT_RHYTHM_MS),
        _ => Some(BOTH_RHYTHM_MS),
    };
    // one burst of `on` ms in the side's rhythm, as on/off steps (ending on an on step)
    let burst = |on: u32| -> Vec<u32> {
        let Some([r_on, r_off]) = rhythm else { return vec![on] };
        let mut steps = Vec::new();
        let mut left_ms = on;
        while left_ms > 0 {
            let step = r_on.min(left_ms);
            steps.push(step);
            left_ms -= step;
            if left_ms == 0 {
                break;
            }
            let gap = r_off.min(left_ms);
            steps.push(gap);
            left_ms -= gap;
        }
        if steps.len() % 2 == 0 {
            // ended on a gap: drop it (a pattern's last step is a vibration)
            steps.pop();
        }
        steps
    };
    let mut out = Vec::new();
    match pattern {
        HapticPattern::Steady => out = burst(window_ms),
        HapticPattern::Pulses { period_ms, duty } => {
            let period = period_ms.max(2 * MIN_PULSE_MS);
            let on = ((period as f32 * duty.clamp(0.0, 1.0)).round() as u32).clamp(MIN_PULSE_MS, period - MIN_PULSE_MS);
            let pulse = burst(on);
            let off = period - pulse.iter().sum::<u32>();
            let mut elapsed = 0;
            while elapsed < window_ms && out.len() < schemas::wire::MAX_PHONE_PATTERN_STEPS {
                if !out.is_empty() {
                    out.push(off);
                }
                out.extend(&pulse);
                elapsed += period;
            }
        }
    }
    // the wire carries at most MAX_PHONE_PATTERN_STEPS steps: keep whole on/off pairs
    let max = schemas::wire::MAX_PHONE_PATTERN_STEPS - 1;
    out.truncate(max);
    if out.len() % 2 == 0 {
        out.pop();
    }
    out
}

/// What the phone is vibrating, as far as this side knows.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Playing {
    levels: Levels,
    pattern: HapticPattern,
}

#[derive(Debug, Clone, Copy)]
struct Sent {
    id: u64,
    playing: Playing,
    cause_ns: u64,
    sent_ns: u64,
    /// A renewal or keep-alive: its acknowledgement proves the phone is there but is
    /// not a new action on `feedback/applied`.
    renewal: bool,
}

/// The phone's vibration motor, as a haptic backend.
pub struct PhoneHaptic {
    link: PhoneLink,
    playing: Option<Playing>,
    last_sent_ns: u64,
    unanswered: VecDeque<Sent>,
    lost: bool,
    /// Whether the phone ever answered (the first loss says "not connected").
    answered: bool,
    started_ns: Option<u64>,
    last_poll_ns: Option<u64>,
}

impl PhoneHaptic {
    /// A phone vibration backend on `link`.
    pub fn new(link: PhoneLink) -> Self {
        Self {
            link,
            playing: None,
            last_sent_ns: 0,
            unanswered: VecDeque::new(),
            lost: false,
            answered: false,
            started_ns: None,
            last_poll_ns: None,
        }
    }

    fn send(&mut self, playing: Playing, cause_ns: u64, now_ns: u64, renewal: bool) {
        let id = self.link.next_id();
        let pattern_ms = vibrate_pattern(playing.levels, playing.pattern, WINDOW_MS);
        self.link.send(Outgoing::Haptic(schemas::PhoneHaptic {
            id,
            pattern_ms,
            left: playing.levels.left.clamp(0.0, 1.0),
            right: playing.levels.right.clamp(0.0, 1.0),
        }));
        self.unanswered.push_back(Sent { id, playing, cause_ns, sent_ns: now_ns, renewal });
        // a phone that never answers must not grow this without bound
        while self.unanswered.len() > 64 {
            self.unanswered.pop_front();
        }
        self.playing = Some(playing);
        self.last_sent_ns = now_ns;
    }
}

impl HapticDevice for PhoneHaptic {
    fn name(&self) -> &str {
        DEVICE
    }

    fn set_levels(
        &mut self,
        levels: Levels,
        pattern: HapticPattern,
        cause_ns: u64,
        now_ns: u64,
        _refresh: bool,
        _out: &mut DeviceOutput,
    ) {
        self.started_ns.get_or_insert(now_ns);
        // The page plays pulses by itself: the off half of a pulse is not "stop".
        let pulses = matches!(pattern, HapticPattern::Pulses { .. });
        if pulses && levels.is_off() && self.playing.is_some_and(|p| p.pattern == pattern && !p.levels.is_off()) {
            return;
        }
        let want = Playing { levels, pattern };
        if self.playing != Some(want) {
            self.send(want, cause_ns, now_ns, false);
        }
    }

    fn poll(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.started_ns.get_or_insert(now_ns);
        self.last_poll_ns = Some(now_ns);
        for ack in self.link.take_haptic_acks() {
            let Some(k) = self.unanswered.iter().position(|s| s.id == ack.id) else { continue };
            // everything sent before it is answered too (or lost for good)
            let sent = self.unanswered.drain(..=k).next_back().expect("position found");
            self.answered = true;
            if self.lost {
                self.lost = false;
                out.status(DEVICE, "Phone connected.".into(), now_ns);
            }
            if !sent.renewal {
                let p = sent.playing;
                let action = AppliedAction::Rumble { left: p.levels.left, right: p.levels.right, pattern: p.pattern };
                out.applied(DEVICE, action, ack.at_ns, sent.cause_ns);
            }
        }
        let oldest = self.unanswered.front().map(|s| s.sent_ns).or(self.started_ns.filter(|_| !self.answered));
        if !self.lost && oldest.is_some_and(|t| now_ns.saturating_sub(t) >= LOST_AFTER_MS * MS) {
            self.lost = true;
            let text = if self.answered {
                "Phone not answering: no vibration on the phone."
            } else {
                "Phone not connected: no vibration on the phone."
            };
            out.status(DEVICE, text.into(), now_ns);
        }
        // renew a running vibration before its window ends; ask an idle phone to answer
        if let Some(p) = self.playing {
            let every = if p.levels.is_off() { KEEPALIVE_MS } else { RENEW_MS };
            if now_ns.saturating_sub(self.last_sent_ns) >= every * MS {
                self.send(p, 0, now_ns, true);
            }
        } else {
            self.send(Playing { levels: Levels::OFF, pattern: HapticPattern::Steady }, 0, now_ns, true);
        }
    }

    fn next_poll_ns(&self) -> Option<u64> {
        // acknowledgements are filed by the bus side: look often enough that
        // `feedback/applied` follows the page closely
        Some(self.last_poll_ns.map_or(0, |t| t + POLL_MS * MS))
    }

    fn off(&mut self, now_ns: u64, _out: &mut DeviceOutput) {
        self.send(Playing { levels: Levels::OFF, pattern: HapticPattern::Steady }, 0, now_ns, false);
    }
}

/// The phone's voice (`speechSynthesis` in the page), as a speech engine.
pub struct PhoneSpeech {
    link: PhoneLink,
}

impl PhoneSpeech {
    /// A phone speech engine on `link`.
    pub fn new(link: PhoneLink) -> Self {
        Self { link }
    }
}

impl SpeechEngine for PhoneSpeech {
    fn name(&self) -> &str {
        DEVICE
    }

    fn confirms(&self) -> bool {
        true
    }

    fn start(&mut self, text: &str, priority: Priority, now_ns: u64) -> Result<Box<dyn SpeakingHandle>, SpeechError> {
        let id = self.link.next_id();
        // The agent's queue has already decided what this cuts: the page drops
        // whatever it still says (a cut it has not yet heard of) before speaking.
        self.link.send(Outgoing::Speech(schemas::PhoneSpeech::Say {
            id,
            text: text.to_string(),
            priority,
            interrupt: true,
        }));
        // at most about 6 words a second, plus the time to start
        let longest = START_TIMEOUT_MS + 200 * text.chars().count() as u64;
        Ok(Box::new(PhoneSpeaking {
            link: self.link.clone(),
            id,
            sent_ns: now_ns,
            started: false,
            ended: false,
            give_up_ns: now_ns + longest * MS,
        }))
    }
}

/// One utterance on the phone.
struct PhoneSpeaking {
    link: PhoneLink,
    id: u64,
    sent_ns: u64,
    started: bool,
    ended: bool,
    give_up_ns: u64,
}

impl SpeakingHandle for PhoneSpeaking {
    fn is_finished(&mut self, now_ns: u64) -> bool {
        if self.ended || self.link.is_done(self.id) {
            return true;
        }
        let no_start = !self.started && now_ns.saturating_sub(self.sent_ns) >= START_TIMEOUT_MS * MS;
        no_start || now_ns >= self.give_up_ns
    }

    fn cut(&mut self) {
        self.link.send(Outgoing::Speech(schemas::PhoneSpeech::Cut { id: self.id }));
    }

    fn take_events(&mut self, now_ns: u64) -> Vec<SpeechEvent> {
        let mut events = Vec::new();
        for ack in self.link.take_speech_acks(self.id) {
            let at = ack.at_ns;
            match ack.event {
                PhoneEvent::Started => {
                    self.started = true;
                    events.push(SpeechEvent::Started(at));
                }
                PhoneEvent::Ended => events.push(SpeechEvent::Ended(at)),
                PhoneEvent::Interrupted => events.push(SpeechEvent::Interrupted(at)),
                PhoneEvent::Failed { reason } => events.push(SpeechEvent::Failed { at_ns: at, reason }),
                PhoneEvent::Vibrated => {}
            }
        }
        if events.iter().any(|e| !matches!(e, SpeechEvent::Started(_))) {
            self.ended = true;
            self.link.forget(self.id);
        } else if !self.ended && self.is_finished(now_ns) {
            self.ended = true;
            self.link.forget(self.id);
            let reason = if self.started { "the phone never said it finished" } else { "the phone did not start it" };
            events.push(SpeechEvent::Failed { at_ns: now_ns, reason: reason.into() });
        }
        events
    }
}

/// Carry the link over the bus until `shutdown`: publish what the devices ask for,
/// file the page's acknowledgements. Bad acknowledgements are refused and counted by
/// the subscriber, like every other input.
pub async fn run_link(
    link: PhoneLink,
    session: &zenoh::Session,
    keys: &schemas::Keys,
    sender: &str,
    health: &Arc<bus::Health>,
    shutdown: bus::Shutdown,
) -> anyhow::Result<()> {
    use bus::{Lane, Publisher, Subscriber};
    let mut haptic =
        Publisher::<schemas::PhoneHaptic>::declare(session, keys.phone_haptic(), sender, Lane::RealTime, Some(health))
            .await?;
    let mut speech =
        Publisher::<schemas::PhoneSpeech>::declare(session, keys.phone_speech(), sender, Lane::Events, Some(health))
            .await?;
    let acks = Subscriber::<PhoneAck>::declare_fresh(
        session,
        keys.phone_ack(),
        false,
        Duration::from_millis(LOST_AFTER_MS),
        health,
    )
    .await?;
    loop {
        for request in link.take_outgoing() {
            let sent = match &request {
                Outgoing::Haptic(h) => haptic.put(bus::now_ns(), h).await,
                Outgoing::Speech(s) => speech.put(bus::now_ns(), s).await,
            };
            if let Err(e) = sent {
                tracing::warn!("cannot send to the phone: {e:#}");
            }
        }
        tokio::select! {
            _ = shutdown.triggered() => break,
            _ = link.outgoing() => {}
            Some(m) = acks.recv() => link.acknowledge(m.body),
        }
    }
    // the devices' last words (motors off) still go out
    for request in link.take_outgoing() {
        let _ = match &request {
            Outgoing::Haptic(h) => haptic.put(bus::now_ns(), h).await,
            Outgoing::Speech(s) => speech.put(bus::now_ns(), s).await,
        };
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const T0: u64 = 1_700_000_000_000_000_000;
    const LEFT: Levels = Levels { left: 0.8, right: 0.0 };
    const RIGHT: Levels = Levels { left: 0.0, right: 0.8 };
    const BOTH: Levels = Levels { left: 0.8, right: 0.8 };

    fn sent(link: &PhoneLink) -> Vec<Outgoing> {
        link.take_outgoing()
    }

    fn haptics(out: Vec<Outgoing>) -> Vec<schemas::PhoneHaptic> {
        out.into_iter()
            .filter_map(|o| match o {
                Outgoing::Haptic(h) => Some(h),
                Outgoing::Speech(_) => None,
            })
            .collect()
    }

    fn ack(id: u64, event: PhoneEvent, at_ns: u64) -> PhoneAck {
        PhoneAck { id, event, at_ns }
    }

    #[test]
    fn sides_are_rhythms_and_off_is_zero() {
        assert_eq!(vibrate_pattern(Levels::OFF, HapticPattern::Steady, 1200), [0]);
        assert_eq!(vibrate_pattern(LEFT, HapticPattern::Steady, 1200), [1200]);
        let right = vibrate_pattern(RIGHT, HapticPattern::Steady, 300);
        assert_eq!(right, [60, 40, 60, 40, 60]);
        let both = vibrate_pattern(BOTH, HapticPattern::Steady, 600);
        assert_eq!(both, [200, 60, 200, 60, 80]);
        // every pattern ends on a vibration and sums to about the window
        for p in [&right, &both] {
            assert_eq!(p.len() % 2, 1);
        }
    }

    #[test]
    fn pulses_keep_their_period_and_duty() {
        let pulses = HapticPattern::Pulses { period_ms: 400, duty: 0.5 };
        assert_eq!(vibrate_pattern(LEFT, pulses, 1200), [200, 200, 200, 200, 200]);
        // a right pulse is a broken burst; the pause makes up the period
        let p = vibrate_pattern(RIGHT, pulses, 800);
        assert_eq!(p, [60, 40, 60, 240, 60, 40, 60]);
        // very short on-times are lengthened to what a motor can render
        let fast = vibrate_pattern(LEFT, HapticPattern::Pulses { period_ms: 100, duty: 0.1 }, 300);
        assert_eq!(fast, [40, 60, 40, 60, 40]);
        // the wire limit holds for any window
        let long = vibrate_pattern(RIGHT, HapticPattern::Pulses { period_ms: 80, duty: 0.9 }, 10_000);
        assert!(long.len() < schemas::wire::MAX_PHONE_PATTERN_STEPS && long.len() % 2 == 1, "{long:?}");
    }

    #[test]
    fn a_rumble_is_applied_only_when_the_page_says_it_vibrated_at_its_time() {
        let link = PhoneLink::new();
        let mut phone = PhoneHaptic::new(link.clone());
        let mut out = DeviceOutput::default();
        phone.set_levels(LEFT, HapticPattern::Steady, T0 - 5 * MS, T0, true, &mut out);
        let h = haptics(sent(&link));
        assert_eq!(h.len(), 1);
        assert_eq!(h[0].pattern_ms, [WINDOW_MS]);
        // the same levels again (a refresh) send nothing
        phone.set_levels(LEFT, HapticPattern::Steady, T0, T0 + 30 * MS, true, &mut out);
        assert!(sent(&link).is_empty());
        phone.poll(T0 + 40 * MS, &mut out);
        assert!(out.applied.is_empty(), "nothing is applied before the page answers");
        link.acknowledge(ack(h[0].id, PhoneEvent::Vibrated, T0 + 45 * MS));
        phone.poll(T0 + 60 * MS, &mut out);
        assert_eq!(out.applied.len(), 1);
        let a = &out.applied[0];
        assert_eq!((a.device.as_str(), a.applied_ns, a.cause_capture_ns), (DEVICE, T0 + 45 * MS, T0 - 5 * MS));
        assert!(matches!(a.action, AppliedAction::Rumble { left, right, .. } if left == 0.8 && right == 0.0));
    }

    #[test]
    fn pulse_gaps_are_not_stops_but_the_end_of_a_cue_is() {
        let link = PhoneLink::new();
        let mut phone = PhoneHaptic::new(link.clone());
        let mut out = DeviceOutput::default();
        let pulses = HapticPattern::Pulses { period_ms: 400, duty: 0.5 };
        phone.set_levels(RIGHT, pulses, 1, T0, true, &mut out);
        phone.set_levels(Levels::OFF, pulses, 0, T0 + 200 * MS, false, &mut out);
        phone.set_levels(RIGHT, pulses, 0, T0 + 400 * MS, false, &mut out);
        assert_eq!(haptics(sent(&link)).len(), 1, "the page plays the pulses itself");
        phone.set_levels(Levels::OFF, HapticPattern::Steady, 0, T0 + 500 * MS, false, &mut out);
        let stop = haptics(sent(&link));
        assert_eq!(stop.len(), 1);
        assert_eq!(stop[0].pattern_ms, [0]);
    }

    #[test]
    fn a_running_vibration_is_renewed_and_an_idle_phone_is_asked_to_answer() {
        let link = PhoneLink::new();
        let mut phone = PhoneHaptic::new(link.clone());
        let mut out = DeviceOutput::default();
        phone.set_levels(LEFT, HapticPattern::Steady, 1, T0, true, &mut out);
        let first = haptics(sent(&link));
        link.acknowledge(ack(first[0].id, PhoneEvent::Vibrated, T0 + 10 * MS));
        phone.poll(T0 + (RENEW_MS - 10) * MS, &mut out);
        assert!(sent(&link).is_empty());
        phone.poll(T0 + RENEW_MS * MS, &mut out);
        let renewal = haptics(sent(&link));
        assert_eq!(renewal.len(), 1);
        assert_eq!(renewal[0].pattern_ms, [WINDOW_MS], "renewed before the window of {WINDOW_MS} ms ends");
        link.acknowledge(ack(renewal[0].id, PhoneEvent::Vibrated, T0 + (RENEW_MS + 20) * MS));
        phone.poll(T0 + (RENEW_MS + 30) * MS, &mut out);
        assert_eq!(out.applied.len(), 1, "a renewal is not a new action: {:?}", out.applied);
        // off: keep-alives every second
        phone.set_levels(Levels::OFF, HapticPattern::Steady, 0, T0 + 1000 * MS, false, &mut out);
        sent(&link);
        phone.poll(T0 + (1000 + KEEPALIVE_MS) * MS, &mut out);
        assert_eq!(haptics(sent(&link))[0].pattern_ms, [0]);
    }

    #[test]
    fn a_phone_that_stops_answering_is_lost_and_said_on_the_other_devices() {
        let link = PhoneLink::new();
        let mut phone = PhoneHaptic::new(link.clone());
        let mut out = DeviceOutput::default();
        phone.poll(T0, &mut out);
        let first = haptics(sent(&link));
        link.acknowledge(ack(first[0].id, PhoneEvent::Vibrated, T0 + 20 * MS));
        phone.poll(T0 + 30 * MS, &mut out);
        assert!(out.say.is_empty());
        // nothing answered from now on
        let mut t = T0 + 30 * MS;
        while t < T0 + (KEEPALIVE_MS + LOST_AFTER_MS + 100) * MS {
            t += 50 * MS;
            phone.poll(t, &mut out);
        }
        assert_eq!(out.said(), ["Phone not answering: no vibration on the phone."]);
        assert!(out.applied.iter().any(|a| a.action == AppliedAction::DeviceStatus { text: out.say[0].text.clone() }));
        // it comes back
        let last = haptics(sent(&link)).pop().expect("keep-alives went on");
        link.acknowledge(ack(last.id, PhoneEvent::Vibrated, t));
        phone.poll(t + 10 * MS, &mut out);
        assert_eq!(out.said().last().copied(), Some("Phone connected."));
    }

    #[test]
    fn a_phone_that_never_answered_is_not_connected() {
        let link = PhoneLink::new();
        let mut phone = PhoneHaptic::new(link.clone());
        let mut out = DeviceOutput::default();
        for k in 0..=60 {
            phone.poll(T0 + k * 50 * MS, &mut out);
        }
        assert_eq!(out.said(), ["Phone not connected: no vibration on the phone."]);
    }

    #[test]
    fn speech_is_reported_by_the_pages_events_and_a_silent_page_is_given_up() {
        let link = PhoneLink::new();
        let mut engine = PhoneSpeech::new(link.clone());
        assert!(engine.confirms());
        let mut h = engine.start("Turn left.", Priority::Message, T0).unwrap();
        let Outgoing::Speech(schemas::PhoneSpeech::Say { id, text, interrupt, .. }) = sent(&link).remove(0) else {
            panic!("no say request")
        };
        assert_eq!((text.as_str(), interrupt), ("Turn left.", true));
        assert!(h.take_events(T0 + MS).is_empty() && !h.is_finished(T0 + MS));
        link.acknowledge(ack(id, PhoneEvent::Started, T0 + 40 * MS));
        assert_eq!(h.take_events(T0 + 50 * MS), [SpeechEvent::Started(T0 + 40 * MS)]);
        link.acknowledge(ack(id, PhoneEvent::Ended, T0 + 900 * MS));
        assert!(h.is_finished(T0 + 910 * MS));
        assert_eq!(h.take_events(T0 + 910 * MS), [SpeechEvent::Ended(T0 + 900 * MS)]);

        // cut: the page says when it stopped
        let mut h = engine.start("In ten metres, turn right.", Priority::Message, T0 + 2000 * MS).unwrap();
        let Outgoing::Speech(schemas::PhoneSpeech::Say { id, .. }) = sent(&link).remove(0) else { panic!() };
        h.cut();
        assert_eq!(sent(&link), [Outgoing::Speech(schemas::PhoneSpeech::Cut { id })]);
        link.acknowledge(ack(id, PhoneEvent::Interrupted, T0 + 2100 * MS));
        assert_eq!(h.take_events(T0 + 2110 * MS), [SpeechEvent::Interrupted(T0 + 2100 * MS)]);

        // a page that never starts it: given up after START_TIMEOUT_MS
        let mut h = engine.start("Arrived.", Priority::Message, T0 + 3000 * MS).unwrap();
        let late = T0 + (3000 + START_TIMEOUT_MS) * MS;
        assert!(h.is_finished(late));
        assert_eq!(
            h.take_events(late),
            [SpeechEvent::Failed { at_ns: late, reason: "the phone did not start it".into() }]
        );
    }
}
