//! Phone backends: the phone is one more device. What the agent decided (levels in
//! force, the utterance the queue started) goes to the phone bridge's keys
//! (`phone/haptic`, `phone/speech`), which forwards it over its WebSocket.
//!
//! Devices are driven synchronously by the feedback step, so they only queue messages
//! on a channel; [`forward`] publishes them from the agent loop's runtime.
//!
//! The phone has one vibration motor: the bridge maps any non-zero side to it. Every
//! haptic message carries a short TTL ([`PHONE_HAPTIC_TTL_MS`]) and is re-sent with
//! each intent, so a phone that loses the link stops vibrating by itself (rule 2).
//! A new utterance is sent with `interrupt` set: the phone cuts what it says for it,
//! which is what the agent's queue just did on every other engine.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use bus::{Health, Lane, Publisher};
use schemas::{AppliedAction, HapticIntent, HapticPattern, Keys, Priority, SpeechIntent};
use tokio::sync::mpsc;

use crate::console::spoken_duration_ns;
use crate::device::{DeviceOutput, HapticDevice, SpeakingHandle, SpeechEngine, SpeechError};
use crate::haptic_cue::Levels;

/// TTL of each haptic message to the phone, ms: ~8 frames at 30 Hz.
pub const PHONE_HAPTIC_TTL_MS: u32 = 250;

/// TTL of each utterance sent to the phone, ms.
pub const PHONE_SPEECH_TTL_MS: u32 = 5000;

/// A message for the phone bridge.
#[derive(Debug, Clone, PartialEq)]
pub enum PhoneMessage {
    /// Vibrate (capture stamp of the cause, 0 if none).
    Haptic(u64, HapticIntent),
    /// Say (capture stamp of the cause, 0 if none).
    Speech(u64, SpeechIntent),
}

/// The sending end shared by the phone devices.
#[derive(Debug, Clone)]
pub struct PhoneLink {
    tx: mpsc::UnboundedSender<PhoneMessage>,
}

/// A phone link and the receiving end for [`forward`].
pub fn phone_channel() -> (PhoneLink, mpsc::UnboundedReceiver<PhoneMessage>) {
    let (tx, rx) = mpsc::unbounded_channel();
    (PhoneLink { tx }, rx)
}

impl PhoneLink {
    fn send(&self, m: PhoneMessage) -> bool {
        self.tx.send(m).is_ok()
    }
}

/// Vibration on the phone.
pub struct PhoneHaptic {
    link: PhoneLink,
    shown: Option<Levels>,
}

impl PhoneHaptic {
    /// Send through `link`.
    pub fn new(link: PhoneLink) -> Self {
        Self { link, shown: None }
    }
}

impl HapticDevice for PhoneHaptic {
    fn name(&self) -> &str {
        "phone"
    }

    fn set_levels(
        &mut self,
        levels: Levels,
        pattern: HapticPattern,
        cause_ns: u64,
        now_ns: u64,
        refresh: bool,
        out: &mut DeviceOutput,
    ) {
        let changed = self.shown != Some(levels);
        // Off needs no refresh: the phone's own TTL ends any vibration.
        if !(changed || (refresh && !levels.is_off())) {
            return;
        }
        let intent = HapticIntent {
            left: levels.left,
            right: levels.right,
            pattern: HapticPattern::Steady,
            ttl_ms: PHONE_HAPTIC_TTL_MS,
        };
        if self.link.send(PhoneMessage::Haptic(cause_ns, intent)) && changed {
            self.shown = Some(levels);
            out.applied(
                "phone",
                AppliedAction::Rumble { left: levels.left, right: levels.right, pattern },
                now_ns,
                cause_ns,
            );
        }
    }

    fn off(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.set_levels(Levels::OFF, HapticPattern::Steady, 0, now_ns, false, out);
    }
}

/// Speech on the phone, timed like a voice at `rate_wpm` (the phone does not report
/// when it finished).
pub struct PhoneSpeech {
    link: PhoneLink,
    rate_wpm: u32,
    /// The agent's queue cut the last utterance off: the next one cuts it on the phone.
    cut_pending: Arc<AtomicBool>,
}

impl PhoneSpeech {
    /// Send through `link`.
    pub fn new(link: PhoneLink, rate_wpm: u32) -> Self {
        Self { link, rate_wpm, cut_pending: Arc::default() }
    }
}

struct PhoneUtterance {
    ends_ns: u64,
    cut: Arc<AtomicBool>,
    was_cut: bool,
}

impl SpeakingHandle for PhoneUtterance {
    fn is_finished(&mut self, now_ns: u64) -> bool {
        self.was_cut || now_ns >= self.ends_ns
    }

    fn cut(&mut self) {
        // The phone cuts when the next utterance arrives with `interrupt` set.
        self.was_cut = true;
        self.cut.store(true, Ordering::Relaxed);
    }
}

impl SpeechEngine for PhoneSpeech {
    fn name(&self) -> &str {
        "phone"
    }

    fn start(&mut self, text: &str, priority: Priority, now_ns: u64) -> Result<Box<dyn SpeakingHandle>, SpeechError> {
        // The agent's queue has already ordered and cut. The phone interrupts only what
        // the queue cut: the end of an utterance is an estimate, and a warning the phone
        // is still saying must not be cut off by the guidance queued after it.
        let interrupt = self.cut_pending.swap(false, Ordering::Relaxed);
        let intent = SpeechIntent {
            text: text.to_string(),
            priority,
            interrupt,
            ttl_ms: PHONE_SPEECH_TTL_MS,
            dedup_key: String::new(),
        };
        if !self.link.send(PhoneMessage::Speech(now_ns, intent)) {
            return Err(SpeechError::Unavailable("phone link closed".into()));
        }
        let ends_ns = now_ns + spoken_duration_ns(text, self.rate_wpm);
        Ok(Box::new(PhoneUtterance { ends_ns, cut: self.cut_pending.clone(), was_cut: false }))
    }
}

/// Publish phone messages on `phone/haptic` and `phone/speech` until every phone
/// device is gone (so the last "off" sent at shutdown still goes out).
pub async fn forward(
    session: zenoh::Session,
    keys: Keys,
    sender: &str,
    mut rx: mpsc::UnboundedReceiver<PhoneMessage>,
    health: Arc<Health>,
) -> anyhow::Result<()> {
    let mut haptic =
        Publisher::<HapticIntent>::declare(&session, keys.phone_haptic(), sender, Lane::RealTime, Some(&health))
            .await?;
    let mut speech =
        Publisher::<SpeechIntent>::declare(&session, keys.phone_speech(), sender, Lane::RealTime, Some(&health))
            .await?;
    loop {
        let sent = match rx.recv().await {
            None => return Ok(()),
            Some(PhoneMessage::Haptic(cause, intent)) => haptic.put(stamp(cause), &intent).await,
            Some(PhoneMessage::Speech(cause, intent)) => speech.put(stamp(cause), &intent).await,
        };
        if let Err(e) = sent {
            tracing::warn!("phone publish failed: {e:#}");
        }
    }
}

fn stamp(cause_ns: u64) -> u64 {
    if cause_ns != 0 {
        cause_ns
    } else {
        bus::now_ns()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phone_vibrates_on_change_and_refreshes_only_while_on() {
        let (link, mut rx) = phone_channel();
        let mut p = PhoneHaptic::new(link);
        let mut out = DeviceOutput::default();
        let on = Levels { left: 1.0, right: 0.0 };
        p.set_levels(on, HapticPattern::Steady, 7, 10, true, &mut out);
        p.set_levels(on, HapticPattern::Steady, 8, 11, true, &mut out);
        p.set_levels(Levels::OFF, HapticPattern::Steady, 8, 12, false, &mut out);
        p.set_levels(Levels::OFF, HapticPattern::Steady, 9, 13, true, &mut out);
        let mut got = Vec::new();
        while let Ok(m) = rx.try_recv() {
            got.push(m);
        }
        let expect = |cause, left| {
            PhoneMessage::Haptic(cause, HapticIntent { left, right: 0.0, pattern: HapticPattern::Steady, ttl_ms: 250 })
        };
        assert_eq!(got, [expect(7, 1.0), expect(8, 1.0), expect(8, 0.0)]);
        assert_eq!(out.applied.len(), 2, "applied records changes only");
    }

    #[test]
    fn phone_speech_interrupts_only_what_the_queue_cut_and_is_timed_like_a_voice() {
        let (link, mut rx) = phone_channel();
        let mut s = PhoneSpeech::new(link, 120);
        let mut said = || match rx.try_recv().unwrap() {
            PhoneMessage::Speech(_, i) => (i.text, i.priority, i.interrupt),
            other => panic!("{other:?}"),
        };
        let mut h = s.start("in ten metres turn left", Priority::Message, 0).unwrap();
        assert_eq!(said(), ("in ten metres turn left".into(), Priority::Message, false));
        h.cut();
        let mut h = s.start("stop now", Priority::Important, 1).unwrap();
        assert!(!h.is_finished(1_000_000_000) && h.is_finished(1_000_000_001));
        assert_eq!(said(), ("stop now".into(), Priority::Important, true), "cuts the guidance on the phone");
        // played to its estimated end: what follows waits for the phone, never cuts it
        s.start("turn left", Priority::Message, 1_000_000_001).unwrap();
        assert_eq!(said(), ("turn left".into(), Priority::Message, false));
        drop(rx);
        assert!(s.start("x", Priority::Text, 0).is_err(), "a closed link is reported");
    }
}
