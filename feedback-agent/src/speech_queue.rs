//! The speech queue: which utterance speaks, which waits, which is dropped.
//!
//! Priorities follow speech-dispatcher's SSIP model (SSIP manual, "Message priorities";
//! ISANA uses the same idea to keep obstacle warnings ahead of guidance):
//! - `Important` (imminent obstacle, detection offline): starts at once, cutting off
//!   anything else that is speaking; never cut off; several queue in order.
//! - `Message` (turns): waits for `Important`; never cut off by another `Message`.
//! - `Text` (landmarks): cut off by `Important` and `Message`; only the newest is kept:
//!   a new one replaces a waiting one, and cuts a speaking one off when its `interrupt`
//!   flag is set.
//! - `Notification`, `Progress`: spoken only when nothing else speaks or waits, and
//!   cut off by anything higher.
//!
//! `interrupt` cuts off the speaking utterance only where these rules allow it.
//! Utterances past their TTL are dropped; a non-empty dedup key is not spoken twice
//! within the dedup window. Pure state: every call carries `now_ns`.

use schemas::{Priority, SpeechIntent};
use thiserror::Error;

/// Longest utterance accepted, characters (the wire limit, `schemas::wire`).
pub const MAX_UTTERANCE_CHARS: usize = schemas::wire::MAX_SPEECH_CHARS;

/// Queue settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QueueConfig {
    /// Same dedup key is not spoken again within this window, ms.
    pub dedup_window_ms: u64,
    /// Most utterances waiting; beyond it the lowest-priority, oldest one is dropped.
    pub max_pending: usize,
}

impl Default for QueueConfig {
    /// 3 s dedup window (a landmark repeated by 30 Hz guidance is said once), 16 waiting.
    fn default() -> Self {
        Self { dedup_window_ms: 3000, max_pending: 16 }
    }
}

/// Why an intent was refused outright (counted as a reject, never spoken).
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum SpeechReject {
    /// Nothing to say.
    #[error("empty utterance")]
    Empty,
    /// Longer than [`MAX_UTTERANCE_CHARS`].
    #[error("utterance of {0} characters exceeds {MAX_UTTERANCE_CHARS}")]
    TooLong(usize),
    /// A TTL of zero can never be spoken.
    #[error("ttl of 0 ms")]
    ZeroTtl,
}

impl SpeechReject {
    /// Short stable name for reject counters.
    pub fn kind(&self) -> &'static str {
        match self {
            SpeechReject::Empty => "empty_text",
            SpeechReject::TooLong(_) => "text_too_long",
            SpeechReject::ZeroTtl => "zero_ttl",
        }
    }
}

/// One utterance in the queue.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Utterance {
    /// Queue-local id, increasing.
    pub id: u64,
    /// The words.
    pub text: String,
    /// Priority.
    pub priority: Priority,
    /// Capture stamp of the intent (0 for the agent's own).
    pub capture_ns: u64,
    /// Dropped if it has not started by then.
    pub expires_ns: u64,
    /// Dedup key ("" = never deduplicated).
    pub dedup_key: String,
    /// The agent's own detection status ("offline", "back"): only the newest waits.
    pub status: bool,
    /// Announce it with a notice tap where a device can (the intent's `notice`).
    pub notice: bool,
    /// News of this device (its backend name): not said by the device's own voice.
    pub about: Option<String>,
}

/// What the driver must do, in order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SpeechAction {
    /// Cut the speaking utterance off at once.
    Cut(Utterance),
    /// Start speaking.
    Start(Utterance),
    /// Never spoken.
    Drop {
        /// The utterance.
        utterance: Utterance,
        /// Why (`stale`, `duplicate`, `replaced by newer text`, ...).
        reason: &'static str,
    },
}

fn rank(p: Priority) -> u8 {
    match p {
        Priority::Important => 4,
        Priority::Message => 3,
        Priority::Text => 2,
        Priority::Notification | Priority::Progress => 1,
    }
}

/// SSIP-style priority queue with TTL and dedup.
#[derive(Debug, Clone)]
pub struct SpeechQueue {
    config: QueueConfig,
    speaking: Option<Utterance>,
    pending: Vec<Utterance>,
    recent: Vec<(String, u64)>,
    next_id: u64,
    muted: bool,
}

impl SpeechQueue {
    /// An empty queue.
    pub fn new(config: QueueConfig) -> Self {
        Self { config, speaking: None, pending: Vec::new(), recent: Vec::new(), next_id: 0, muted: false }
    }

    /// The utterance speaking now.
    pub fn speaking(&self) -> Option<&Utterance> {
        self.speaking.as_ref()
    }

    /// Utterances waiting, in the order they will be spoken.
    pub fn pending(&self) -> &[Utterance] {
        &self.pending
    }

    /// Offer an intent captured at `capture_ns`, arriving at `now_ns`; the actions to
    /// perform are appended to `out`.
    pub fn offer(
        &mut self,
        intent: &SpeechIntent,
        capture_ns: u64,
        now_ns: u64,
        out: &mut Vec<SpeechAction>,
    ) -> Result<(), SpeechReject> {
        let text = intent.text.trim();
        if text.is_empty() {
            return Err(SpeechReject::Empty);
        }
        let chars = text.chars().count();
        if chars > MAX_UTTERANCE_CHARS {
            return Err(SpeechReject::TooLong(chars));
        }
        if intent.ttl_ms == 0 {
            return Err(SpeechReject::ZeroTtl);
        }
        let utterance = Utterance {
            id: self.next_id,
            text: text.to_string(),
            priority: intent.priority,
            capture_ns,
            expires_ns: capture_ns.saturating_add(intent.ttl_ms as u64 * 1_000_000),
            dedup_key: intent.dedup_key.clone(),
            status: false,
            notice: intent.notice,
            about: None,
        };
        self.next_id += 1;
        if self.muted && utterance.priority != Priority::Important {
            out.push(SpeechAction::Drop { utterance, reason: "muted" });
            return Ok(());
        }
        self.enqueue(utterance, intent.interrupt, now_ns, out);
        Ok(())
    }

    /// Offer the agent's own utterance (the mute's confirmation, the tilt sensor's
    /// news; device news goes by [`Self::offer_news`]): never deduplicated, reported
    /// with cause stamp 0, dropped if not started within `ttl_ms`.
    pub fn offer_own(&mut self, text: &str, priority: Priority, ttl_ms: u32, now_ns: u64, out: &mut Vec<SpeechAction>) {
        let utterance = self.own(text, priority, ttl_ms, now_ns, false);
        self.enqueue(utterance, false, now_ns, out);
    }

    /// Offer a device's news as a `Message` of the agent's own ([`Self::offer_own`]),
    /// marked as about `device` (not said by that device's voice).
    pub fn offer_news(&mut self, device: &str, text: &str, ttl_ms: u32, now_ns: u64, out: &mut Vec<SpeechAction>) {
        let mut utterance = self.own(text, Priority::Message, ttl_ms, now_ns, false);
        utterance.about = Some(device.to_string());
        self.enqueue(utterance, false, now_ns, out);
    }

    /// Offer the detection status ("obstacle detection offline", "... back") as an
    /// `Important` utterance of the agent's own. A status still waiting is out of date
    /// and is dropped (reason `replaced by newer status`): when detection flickers, the
    /// user hears where it stands now, and the warnings queued behind are not pushed
    /// back or out of the queue by a backlog of old news. One speaking plays to its end.
    pub fn offer_status(&mut self, text: &str, ttl_ms: u32, now_ns: u64, out: &mut Vec<SpeechAction>) {
        self.drop_waiting(out, |u| u.status.then_some("replaced by newer status"));
        let utterance = self.own(text, Priority::Important, ttl_ms, now_ns, true);
        self.enqueue(utterance, false, now_ns, out);
    }

    fn own(&mut self, text: &str, priority: Priority, ttl_ms: u32, now_ns: u64, status: bool) -> Utterance {
        self.next_id += 1;
        Utterance {
            id: self.next_id - 1,
            text: text.to_string(),
            priority,
            capture_ns: 0,
            expires_ns: now_ns.saturating_add(ttl_ms as u64 * 1_000_000),
            dedup_key: String::new(),
            status,
            notice: false,
            about: None,
        }
    }

    fn enqueue(&mut self, utterance: Utterance, interrupt: bool, now_ns: u64, out: &mut Vec<SpeechAction>) {
        if now_ns >= utterance.expires_ns {
            out.push(SpeechAction::Drop { utterance, reason: "stale" });
            return;
        }
        if self.is_duplicate(&utterance.dedup_key, now_ns) {
            out.push(SpeechAction::Drop { utterance, reason: "duplicate" });
            return;
        }
        let new_rank = rank(utterance.priority);
        if let Some(cur) = &self.speaking {
            let cur_rank = rank(cur.priority);
            if new_rank == 1 {
                // Notifications only fill silence (or replace another notification).
                if !(interrupt && cur_rank == 1) {
                    out.push(SpeechAction::Drop { utterance, reason: "busy" });
                    return;
                }
            }
            let cut = match cur.priority {
                Priority::Important => false,
                Priority::Message => new_rank > cur_rank,
                Priority::Text => new_rank > cur_rank || interrupt,
                Priority::Notification | Priority::Progress => new_rank > cur_rank || interrupt,
            };
            if cut {
                if let Some(cur) = self.speaking.take() {
                    out.push(SpeechAction::Cut(cur));
                }
            }
        } else if new_rank == 1 && !self.pending.is_empty() {
            out.push(SpeechAction::Drop { utterance, reason: "busy" });
            return;
        }
        // Anything higher drops waiting notifications; newer text replaces waiting text.
        let new_is_text = utterance.priority == Priority::Text;
        self.drop_waiting(out, |p| {
            (rank(p.priority) == 1 && new_rank > 1)
                .then_some("dropped by a higher priority")
                .or((p.priority == Priority::Text && new_is_text).then_some("replaced by newer text"))
        });
        let at = self.pending.iter().position(|p| rank(p.priority) < new_rank).unwrap_or(self.pending.len());
        self.pending.insert(at, utterance);
        if self.pending.len() > self.config.max_pending {
            // the oldest of the lowest priority waiting: a new warning behind a queue of
            // warnings is the one that is current, never the one dropped
            let lowest = self.pending.iter().map(|p| rank(p.priority)).min().unwrap_or(new_rank);
            if let Some(k) = self.pending.iter().position(|p| rank(p.priority) == lowest) {
                out.push(SpeechAction::Drop { utterance: self.pending.remove(k), reason: "queue full" });
            }
        }
        self.start_next(now_ns, out);
    }

    fn is_duplicate(&self, key: &str, now_ns: u64) -> bool {
        if key.is_empty() {
            return false;
        }
        let window_ns = self.config.dedup_window_ms.saturating_mul(1_000_000);
        self.speaking.as_ref().is_some_and(|u| u.dedup_key == key)
            || self.pending.iter().any(|u| u.dedup_key == key)
            || self.recent.iter().any(|(k, t)| k == key && now_ns.saturating_sub(*t) < window_ns)
    }

    fn start_next(&mut self, now_ns: u64, out: &mut Vec<SpeechAction>) {
        while self.speaking.is_none() && !self.pending.is_empty() {
            let next = self.pending.remove(0);
            if now_ns >= next.expires_ns {
                out.push(SpeechAction::Drop { utterance: next, reason: "stale" });
                continue;
            }
            if !next.dedup_key.is_empty() {
                let window_ns = self.config.dedup_window_ms.saturating_mul(1_000_000);
                self.recent.retain(|(k, t)| k != &next.dedup_key && now_ns.saturating_sub(*t) < window_ns);
                self.recent.push((next.dedup_key.clone(), now_ns));
            }
            self.speaking = Some(next.clone());
            out.push(SpeechAction::Start(next));
        }
    }

    /// The speaking utterance played to its end at `now_ns`; start the next.
    pub fn finished(&mut self, now_ns: u64, out: &mut Vec<SpeechAction>) -> Option<Utterance> {
        let done = self.speaking.take();
        self.start_next(now_ns, out);
        done
    }

    /// Drop waiting utterances whose TTL has passed.
    pub fn expire(&mut self, now_ns: u64, out: &mut Vec<SpeechAction>) {
        self.drop_waiting(out, |u| (now_ns >= u.expires_ns).then_some("stale"));
    }

    /// Drops, in order, every waiting utterance `why` gives a reason for.
    fn drop_waiting(&mut self, out: &mut Vec<SpeechAction>, mut why: impl FnMut(&Utterance) -> Option<&'static str>) {
        let mut k = 0;
        while k < self.pending.len() {
            match why(&self.pending[k]) {
                Some(reason) => out.push(SpeechAction::Drop { utterance: self.pending.remove(k), reason }),
                None => k += 1,
            }
        }
    }

    /// Earliest TTL among waiting utterances.
    pub fn next_expiry_ns(&self) -> Option<u64> {
        self.pending.iter().map(|u| u.expires_ns).min()
    }

    /// True while the user has muted speech.
    pub fn is_muted(&self) -> bool {
        self.muted
    }

    /// Mute or unmute. Muted, intents below `Important` are dropped (reason `muted`)
    /// and muting cuts and drops what speaks or waits below it: warnings still sound
    /// (ARCHITECTURE.md rule 1), and so do the agent's own utterances. Returns whether
    /// the state changed.
    pub fn set_muted(&mut self, muted: bool, now_ns: u64, out: &mut Vec<SpeechAction>) -> bool {
        if self.muted == muted {
            return false;
        }
        self.muted = muted;
        if muted {
            self.silence_below_important(now_ns, out);
        }
        true
    }

    fn silence_below_important(&mut self, now_ns: u64, out: &mut Vec<SpeechAction>) {
        if self.speaking.as_ref().is_some_and(|u| u.priority != Priority::Important) {
            if let Some(cur) = self.speaking.take() {
                out.push(SpeechAction::Cut(cur));
            }
        }
        self.drop_waiting(out, |u| (u.priority != Priority::Important).then_some("muted"));
        self.start_next(now_ns, out);
    }

    /// Cut off what speaks and drop what waits (shutdown).
    pub fn clear(&mut self, out: &mut Vec<SpeechAction>) {
        if let Some(cur) = self.speaking.take() {
            out.push(SpeechAction::Cut(cur));
        }
        for utterance in self.pending.drain(..) {
            out.push(SpeechAction::Drop { utterance, reason: "shutdown" });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;
    const T0: u64 = 1_700_000_000_000_000_000;

    fn say(text: &str, priority: Priority) -> SpeechIntent {
        SpeechIntent {
            text: text.into(),
            priority,
            interrupt: false,
            ttl_ms: 5000,
            dedup_key: String::new(),
            notice: false,
        }
    }

    fn offer(q: &mut SpeechQueue, i: &SpeechIntent, now: u64) -> Vec<SpeechAction> {
        let mut out = Vec::new();
        q.offer(i, now, now, &mut out).unwrap();
        out
    }

    fn texts(actions: &[SpeechAction]) -> Vec<String> {
        actions
            .iter()
            .map(|a| match a {
                SpeechAction::Cut(u) => format!("cut {}", u.text),
                SpeechAction::Start(u) => format!("start {}", u.text),
                SpeechAction::Drop { utterance, reason } => format!("drop {} ({reason})", utterance.text),
            })
            .collect()
    }

    #[test]
    fn warning_cuts_off_guidance_at_once() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        assert_eq!(
            texts(&offer(&mut q, &say("turn left in 5 metres", Priority::Message), T0)),
            ["start turn left in 5 metres"]
        );
        let a = offer(&mut q, &say("stop, obstacle ahead", Priority::Important), T0 + 100 * MS);
        assert_eq!(texts(&a), ["cut turn left in 5 metres", "start stop, obstacle ahead"]);
    }

    #[test]
    fn guidance_waits_until_the_warning_has_finished() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        offer(&mut q, &say("stop", Priority::Important), T0);
        let mut turn = say("turn right", Priority::Message);
        turn.interrupt = true;
        assert!(offer(&mut q, &turn, T0 + MS).is_empty(), "even with interrupt set, a warning is never cut");
        let mut out = Vec::new();
        q.finished(T0 + 500 * MS, &mut out);
        assert_eq!(texts(&out), ["start turn right"]);
    }

    #[test]
    fn warnings_queue_behind_each_other_in_order() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        offer(&mut q, &say("first", Priority::Important), T0);
        offer(&mut q, &say("second", Priority::Important), T0);
        offer(&mut q, &say("guidance", Priority::Message), T0);
        offer(&mut q, &say("third", Priority::Important), T0);
        let order: Vec<&str> = q.pending().iter().map(|u| u.text.as_str()).collect();
        assert_eq!(order, ["second", "third", "guidance"]);
    }

    #[test]
    fn message_is_not_cut_by_its_own_kind() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        offer(&mut q, &say("turn left", Priority::Message), T0);
        let mut next = say("turn right", Priority::Message);
        next.interrupt = true;
        assert!(offer(&mut q, &next, T0 + MS).is_empty());
        assert_eq!(q.speaking().unwrap().text, "turn left");
    }

    #[test]
    fn turn_instruction_cuts_a_landmark_but_not_the_reverse() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        offer(&mut q, &say("cafeteria on your right", Priority::Text), T0);
        let a = offer(&mut q, &say("turn left now", Priority::Message), T0 + MS);
        assert_eq!(texts(&a), ["cut cafeteria on your right", "start turn left now"]);
        let mut landmark = say("lift ahead", Priority::Text);
        landmark.interrupt = true;
        assert!(offer(&mut q, &landmark, T0 + 2 * MS).is_empty(), "waits behind the turn");
    }

    #[test]
    fn only_the_newest_landmark_text_is_kept() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        offer(&mut q, &say("turn left", Priority::Message), T0);
        offer(&mut q, &say("door 101", Priority::Text), T0);
        let a = offer(&mut q, &say("door 102", Priority::Text), T0 + MS);
        assert_eq!(texts(&a), ["drop door 101 (replaced by newer text)"]);
        let mut landmark = say("door 103", Priority::Text);
        landmark.interrupt = true;
        let mut out = Vec::new();
        q.finished(T0 + 2 * MS, &mut out);
        assert_eq!(texts(&out), ["start door 102"]);
        let a = offer(&mut q, &landmark, T0 + 3 * MS);
        assert_eq!(texts(&a), ["cut door 102", "start door 103"]);
    }

    #[test]
    fn notifications_only_fill_silence_and_yield_to_anything_higher() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        offer(&mut q, &say("turn left", Priority::Message), T0);
        assert_eq!(texts(&offer(&mut q, &say("battery 80", Priority::Notification), T0)), ["drop battery 80 (busy)"]);
        let mut out = Vec::new();
        q.finished(T0 + MS, &mut out);
        offer(&mut q, &say("battery 79", Priority::Progress), T0 + MS);
        let a = offer(&mut q, &say("door 4", Priority::Text), T0 + 2 * MS);
        assert_eq!(texts(&a), ["cut battery 79", "start door 4"]);
    }

    #[test]
    fn stale_utterances_are_dropped_on_arrival_and_while_waiting() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        let mut out = Vec::new();
        q.offer(&say("old", Priority::Message), T0, T0 + 6000 * MS, &mut out).unwrap();
        assert_eq!(texts(&out), ["drop old (stale)"]);
        offer(&mut q, &say("long warning", Priority::Important), T0);
        let mut turn = say("turn", Priority::Message);
        turn.ttl_ms = 1000;
        offer(&mut q, &turn, T0);
        assert_eq!(q.next_expiry_ns(), Some(T0 + 1000 * MS));
        out.clear();
        q.expire(T0 + 1000 * MS, &mut out);
        assert_eq!(texts(&out), ["drop turn (stale)"]);
        assert!(q.pending().is_empty());
    }

    #[test]
    fn same_dedup_key_is_not_repeated_within_the_window() {
        let mut q = SpeechQueue::new(QueueConfig { dedup_window_ms: 3000, max_pending: 16 });
        let mut lift = say("lift on your left", Priority::Text);
        lift.dedup_key = "lift-3".into();
        offer(&mut q, &lift, T0);
        let mut out = Vec::new();
        q.finished(T0 + 1000 * MS, &mut out);
        assert_eq!(texts(&offer(&mut q, &lift, T0 + 2999 * MS)), ["drop lift on your left (duplicate)"]);
        assert_eq!(texts(&offer(&mut q, &lift, T0 + 3000 * MS)), ["start lift on your left"]);
    }

    #[test]
    fn bad_texts_and_zero_ttl_are_rejected_with_a_kind() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        let mut out = Vec::new();
        assert_eq!(q.offer(&say("   ", Priority::Message), T0, T0, &mut out).unwrap_err().kind(), "empty_text");
        let huge = "a".repeat(10 * 1024 * 1024);
        assert_eq!(q.offer(&say(&huge, Priority::Message), T0, T0, &mut out).unwrap_err().kind(), "text_too_long");
        let mut zero = say("x", Priority::Message);
        zero.ttl_ms = 0;
        assert_eq!(q.offer(&zero, T0, T0, &mut out).unwrap_err(), SpeechReject::ZeroTtl);
        assert!(out.is_empty() && q.speaking().is_none());
    }

    #[test]
    fn muting_cuts_guidance_and_drops_all_but_warnings() {
        let mut q = SpeechQueue::new(QueueConfig::default());
        offer(&mut q, &say("turn left", Priority::Message), T0);
        offer(&mut q, &say("door 4", Priority::Text), T0);
        let mut out = Vec::new();
        assert!(q.set_muted(true, T0 + MS, &mut out));
        assert_eq!(texts(&out), ["cut turn left", "drop door 4 (muted)"]);
        assert!(!q.set_muted(true, T0 + MS, &mut out), "muting twice changes nothing");
        assert_eq!(
            texts(&offer(&mut q, &say("turn right", Priority::Message), T0 + 2 * MS)),
            ["drop turn right (muted)"]
        );
        assert_eq!(texts(&offer(&mut q, &say("stop", Priority::Important), T0 + 2 * MS)), ["start stop"]);
        out.clear();
        q.offer_own("left controller disconnected", Priority::Message, 5000, T0 + 2 * MS, &mut out);
        assert!(out.is_empty() && q.pending().len() == 1, "the agent's own news still waits its turn");
        assert!(q.set_muted(false, T0 + 3 * MS, &mut out));
        assert_eq!(
            texts(&offer(&mut q, &say("door 5", Priority::Text), T0 + 3 * MS)),
            Vec::<String>::new(),
            "queued again"
        );
    }

    #[test]
    fn a_full_queue_drops_the_lowest_priority_first() {
        let mut q = SpeechQueue::new(QueueConfig { dedup_window_ms: 0, max_pending: 2 });
        offer(&mut q, &say("speaking", Priority::Important), T0);
        offer(&mut q, &say("m1", Priority::Message), T0);
        offer(&mut q, &say("m2", Priority::Message), T0);
        let a = offer(&mut q, &say("warning", Priority::Important), T0);
        assert_eq!(texts(&a), ["drop m1 (queue full)"], "the oldest of the lowest priority");
        assert_eq!(q.pending().iter().map(|u| u.text.as_str()).collect::<Vec<_>>(), ["warning", "m2"]);
        let b = offer(&mut q, &say("m3", Priority::Message), T0);
        assert_eq!(texts(&b), ["drop m2 (queue full)"]);
    }

    #[test]
    fn only_the_newest_detection_status_waits() {
        let mut q = SpeechQueue::new(QueueConfig { dedup_window_ms: 0, max_pending: 4 });
        let mut out = Vec::new();
        q.offer_status("obstacle detection offline", 10_000, T0, &mut out);
        assert_eq!(texts(&out), ["start obstacle detection offline"]);
        // detection flickers while the first status speaks: ten changes, one warning
        for k in 0..10u64 {
            out.clear();
            let text = if k % 2 == 0 { "obstacle detection back" } else { "obstacle detection offline" };
            q.offer_status(text, 10_000, T0 + (k + 1) * 100 * MS, &mut out);
            if k > 0 {
                assert_eq!(out.len(), 1, "{out:?}");
                assert!(matches!(&out[0], SpeechAction::Drop { reason: "replaced by newer status", .. }));
            }
        }
        let warning = offer(&mut q, &say("stop, wall ahead", Priority::Important), T0 + 1100 * MS);
        assert!(warning.is_empty(), "queued, not dropped: {warning:?}");
        let waiting: Vec<_> = q.pending().iter().map(|u| u.text.as_str()).collect();
        assert_eq!(waiting, ["obstacle detection offline", "stop, wall ahead"], "the last status, then the warning");
        out.clear();
        q.finished(T0 + 1200 * MS, &mut out);
        assert_eq!(texts(&out), ["start obstacle detection offline"]);
    }

    #[test]
    fn a_queue_full_of_warnings_keeps_the_newest_warning() {
        let mut q = SpeechQueue::new(QueueConfig { dedup_window_ms: 0, max_pending: 2 });
        offer(&mut q, &say("speaking", Priority::Important), T0);
        offer(&mut q, &say("wall ahead", Priority::Important), T0);
        offer(&mut q, &say("pole left", Priority::Important), T0);
        let a = offer(&mut q, &say("stop, stairs down", Priority::Important), T0 + MS);
        assert_eq!(texts(&a), ["drop wall ahead (queue full)"]);
        assert_eq!(q.pending().iter().map(|u| u.text.as_str()).collect::<Vec<_>>(), ["pole left", "stop, stairs down"]);
        let m = offer(&mut q, &say("turn left", Priority::Message), T0 + MS);
        assert_eq!(texts(&m), ["drop turn left (queue full)"], "a message never evicts a warning");
    }
}
