//! What a well-formed message must also be before anything acts on it: fresh (captured
//! within a bound of its arrival, not in the future) and new (a sequence number its
//! publisher has not used before). Pure logic, time as an argument; the `bus` crate's
//! subscribers apply it where a message arrives, before it takes its place in the inbox,
//! so a replayed or stale message never displaces a good one.
//!
//! Capture stamps come from the sender's clock. Across hosts that clock may be off from
//! ours, so ages are read against [`Clocks`]: per sender, the smallest `arrival - stamp`
//! of its recent health messages (its clock offset plus the shortest trip). A sender
//! whose clock is off by more than a bound is named in the agent's health status.

use std::collections::{HashMap, VecDeque};
use std::time::Duration;

use crate::Header;
use thiserror::Error;

/// How old (and how far in the future) an input may be when it arrives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Freshness {
    /// Oldest capture accepted, measured from arrival.
    pub max_age: Duration,
    /// Furthest a capture stamp may lie ahead of arrival (clock jitter, the offset
    /// estimate's error).
    pub max_ahead: Duration,
}

impl Freshness {
    /// Captures up to `max_age` old, and up to 50 ms (or `max_age`, if less) ahead.
    pub fn within(max_age: Duration) -> Self {
        Self { max_age, max_ahead: max_age.min(Duration::from_millis(50)) }
    }
}

/// Why a well-formed message was refused.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum InputError {
    /// Captured longer ago than the bound.
    #[error("captured {age_ms} ms before it arrived (bound {bound_ms} ms): stale")]
    Stale {
        /// Age at arrival, clock offset taken out.
        age_ms: i64,
        /// The bound.
        bound_ms: u64,
    },
    /// Stamped ahead of arrival by more than the bound.
    #[error("stamped {ahead_ms} ms in the future (bound {bound_ms} ms)")]
    Future {
        /// How far ahead.
        ahead_ms: i64,
        /// The bound.
        bound_ms: u64,
    },
    /// A sequence number this publisher already used.
    #[error("sequence {seq} from {sender} (session {session:016x}) already seen (last {last}): replayed")]
    Replayed {
        /// Sender named in the envelope.
        sender: String,
        /// Its session.
        session: u64,
        /// Sequence received.
        seq: u64,
        /// Highest sequence seen before.
        last: u64,
    },
}

impl InputError {
    /// Short stable name for counters and health stats.
    pub fn kind(&self) -> &'static str {
        match self {
            InputError::Stale { .. } => "stale",
            InputError::Future { .. } => "future",
            InputError::Replayed { .. } => "replayed",
        }
    }
}

/// Publishers remembered per guard; the least recently heard is forgotten first. A
/// forgotten publisher's old messages are then refused by freshness (where set).
const MAX_PUBLISHERS: usize = 64;

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct PublisherId {
    key: String,
    sender: String,
    session: u64,
}

#[derive(Debug, Clone, Copy)]
struct Heard {
    last_seq: u64,
    last_ns: u64,
    /// Messages above `last_seq` refused since it (stale or future): not lost.
    refused_since: u64,
}

/// Freshness and sequence checks for one subscription.
#[derive(Debug, Default)]
pub struct Guard {
    freshness: Option<Freshness>,
    publishers: HashMap<PublisherId, Heard>,
}

impl Guard {
    /// Checks sequence numbers, and freshness when `freshness` is given.
    pub fn new(freshness: Option<Freshness>) -> Self {
        Self { freshness, publishers: HashMap::new() }
    }

    /// The freshness bound, if any.
    pub fn freshness(&self) -> Option<Freshness> {
        self.freshness
    }

    /// Accept or refuse a message that arrived on `key` at `received_ns` (our clock),
    /// from a sender whose clock reads `offset_ns` behind ours ([`Clocks::offset_ns`]).
    /// Freshness comes first, so a stale message does not move the sequence state (it is
    /// only noted as refused, so that it is not also counted as lost).
    ///
    /// Accepted, it gives how many messages this publisher numbered between the last
    /// one heard here and this one that never arrived (neither accepted nor refused):
    /// lost on the way, as a lane that drops rather than queue drops them. Nothing is
    /// known of what a publisher sent before its first message heard here.
    pub fn check(&mut self, key: &str, header: &Header, received_ns: u64, offset_ns: i64) -> Result<u64, InputError> {
        let id = PublisherId { key: key.to_string(), sender: header.sender.clone(), session: header.session };
        if let Err(e) = self.fresh(header, received_ns, offset_ns) {
            if let Some(heard) = self.publishers.get_mut(&id).filter(|h| header.seq > h.last_seq) {
                heard.refused_since += 1;
            }
            return Err(e);
        }
        if let Some(heard) = self.publishers.get_mut(&id) {
            if header.seq <= heard.last_seq {
                return Err(InputError::Replayed {
                    sender: id.sender,
                    session: id.session,
                    seq: header.seq,
                    last: heard.last_seq,
                });
            }
            let missed = (header.seq - heard.last_seq - 1).saturating_sub(heard.refused_since);
            *heard = Heard { last_seq: header.seq, last_ns: received_ns, refused_since: 0 };
            return Ok(missed);
        }
        if self.publishers.len() >= MAX_PUBLISHERS {
            if let Some(oldest) = self.publishers.iter().min_by_key(|(_, h)| h.last_ns).map(|(id, _)| id.clone()) {
                self.publishers.remove(&oldest);
            }
        }
        self.publishers.insert(id, Heard { last_seq: header.seq, last_ns: received_ns, refused_since: 0 });
        Ok(0)
    }

    /// The freshness check alone.
    fn fresh(&self, header: &Header, received_ns: u64, offset_ns: i64) -> Result<(), InputError> {
        if let Some(f) = self.freshness {
            let age_ns = received_ns as i128 - header.capture_ns as i128 - offset_ns as i128;
            if age_ns > f.max_age.as_nanos() as i128 {
                return Err(InputError::Stale {
                    age_ms: (age_ns / 1_000_000) as i64,
                    bound_ms: f.max_age.as_millis() as u64,
                });
            }
            if -age_ns > f.max_ahead.as_nanos() as i128 {
                return Err(InputError::Future {
                    ahead_ms: (-age_ns / 1_000_000) as i64,
                    bound_ms: f.max_ahead.as_millis() as u64,
                });
            }
        }
        Ok(())
    }
}

/// Health messages per sender that the clock offset is the minimum of (20 s at the
/// default 1 Hz): long enough to contain a quick trip, short enough to follow a clock
/// that was stepped.
const OFFSET_WINDOW: usize = 20;

/// Largest clock offset a receiver reads a sender's stamps through. A LAN's clocks (NTP,
/// a phone's network time) agree to milliseconds; one off by more is misconfigured, or
/// the "offset" comes from old health messages replayed with old data, which would then
/// look fresh. Beyond this the sender's stamps are read as they are (its data is
/// refused as stale or future, and the watchdog warns), and the sender is named.
pub const MAX_TRUSTED_OFFSET: Duration = Duration::from_secs(10);

/// Clock offsets of the other agents, from the stamps of their health messages.
#[derive(Debug, Default)]
pub struct Clocks {
    seen: HashMap<String, VecDeque<i64>>,
}

impl Clocks {
    /// A health message from `sender`, stamped `stamp_ns` by its clock, arrived at
    /// `received_ns` by ours.
    pub fn observe(&mut self, sender: &str, stamp_ns: u64, received_ns: u64) {
        let gap = (received_ns as i128 - stamp_ns as i128).clamp(i64::MIN as i128, i64::MAX as i128) as i64;
        if !self.seen.contains_key(sender) && self.seen.len() >= MAX_PUBLISHERS {
            return;
        }
        let window = self.seen.entry(sender.to_string()).or_default();
        if window.len() == OFFSET_WINDOW {
            window.pop_front();
        }
        window.push_back(gap);
    }

    /// How far `sender`'s clock reads behind ours (negative: ahead), trip included,
    /// as its stamps are to be read: 0 for a sender not heard from, and 0 for one off by
    /// more than [`MAX_TRUSTED_OFFSET`] (see there).
    pub fn offset_ns(&self, sender: &str) -> i64 {
        let raw = self.measured_offset_ns(sender);
        if raw.unsigned_abs() as u128 > MAX_TRUSTED_OFFSET.as_nanos() {
            0
        } else {
            raw
        }
    }

    /// The offset measured from `sender`'s health messages, trusted or not.
    pub fn measured_offset_ns(&self, sender: &str) -> i64 {
        self.seen.get(sender).and_then(|w| w.iter().min().copied()).unwrap_or(0)
    }

    /// Senders whose clock is off by more than `bound`, with the offset in ms, by name.
    pub fn off_by_more_than(&self, bound: Duration) -> Vec<(String, i64)> {
        let mut off: Vec<(String, i64)> = self
            .seen
            .keys()
            .map(|s| (s.clone(), self.measured_offset_ns(s)))
            .filter(|(_, o)| o.unsigned_abs() as u128 > bound.as_nanos())
            .map(|(s, o)| (s, o / 1_000_000))
            .collect();
        off.sort();
        off
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;
    const T0: u64 = 1_800_000_000_000_000_000;

    fn header(sender: &str, session: u64, seq: u64, capture_ns: u64) -> Header {
        Header { schema: 1, version: 2, sender: sender.into(), session, seq, capture_ns }
    }

    #[test]
    fn old_and_future_captures_are_refused_with_their_age() {
        let mut g = Guard::new(Some(Freshness::within(Duration::from_millis(150))));
        assert_eq!(g.check("k", &header("s", 1, 0, T0), T0 + 149 * MS, 0), Ok(0));
        assert_eq!(
            g.check("k", &header("s", 1, 1, T0), T0 + 5_700 * MS, 0),
            Err(InputError::Stale { age_ms: 5_700, bound_ms: 150 })
        );
        assert_eq!(
            g.check("k", &header("s", 1, 2, T0 + 60 * MS), T0, 0),
            Err(InputError::Future { ahead_ms: 60, bound_ms: 50 })
        );
        // the refused ones left no trace: seq 1 is still new
        assert_eq!(g.check("k", &header("s", 1, 1, T0 + 200 * MS), T0 + 210 * MS, 0), Ok(0));
    }

    #[test]
    fn health_replayed_from_an_hour_ago_does_not_make_that_hours_data_fresh() {
        let mut clocks = Clocks::default();
        let hour = 3_600_000 * MS;
        for i in 0..5u64 {
            // recorded health, stamped an hour before it arrives
            let ours = T0 + i * 1_000 * MS;
            clocks.observe("sensor-agent", ours - hour, ours);
        }
        assert_eq!(clocks.measured_offset_ns("sensor-agent"), hour as i64);
        assert_eq!(clocks.offset_ns("sensor-agent"), 0, "an offset past the trusted bound is not applied");
        assert_eq!(clocks.off_by_more_than(Duration::from_millis(150)), [("sensor-agent".to_string(), 3_600_000)]);
        // the recorded frame, as old as the health: stale
        let mut g = Guard::new(Some(Freshness::within(Duration::from_millis(150))));
        let frame = header("sensor-agent", 9, 0, T0 + 5_000 * MS - hour);
        let got = g.check("k", &frame, T0 + 5_000 * MS, clocks.offset_ns("sensor-agent"));
        assert_eq!(got, Err(InputError::Stale { age_ms: 3_600_000, bound_ms: 150 }));
    }

    #[test]
    fn a_sender_clock_two_seconds_behind_is_read_through_its_offset() {
        let mut clocks = Clocks::default();
        // health stamped by a clock 2 s behind ours, trips of 1-9 ms
        for (i, trip) in [9, 3, 1, 4, 7].iter().enumerate() {
            let ours = T0 + i as u64 * 1_000 * MS;
            clocks.observe("sensor-agent", ours - 2_000 * MS - trip * MS, ours);
        }
        assert_eq!(clocks.offset_ns("sensor-agent"), (2_001 * MS) as i64);
        assert_eq!(clocks.offset_ns("never-heard"), 0);
        assert_eq!(clocks.off_by_more_than(Duration::from_millis(150)), [("sensor-agent".to_string(), 2_001)]);
        let mut g = Guard::new(Some(Freshness::within(Duration::from_millis(150))));
        let offset = clocks.offset_ns("sensor-agent");
        // a frame 20 ms old by the sender's clock
        assert_eq!(g.check("k", &header("sensor-agent", 1, 0, T0 - 2_020 * MS), T0, offset), Ok(0));
        // without the offset it would look 2 s stale
        assert_eq!(g.check("k", &header("sensor-agent", 1, 1, T0 - 2_020 * MS), T0, 0).unwrap_err().kind(), "stale");
        // a replayed health message (an old stamp) cannot shrink the offset's minimum
        clocks.observe("sensor-agent", T0 - 9_000 * MS, T0 + 10 * MS);
        assert_eq!(clocks.offset_ns("sensor-agent"), (2_001 * MS) as i64);
    }

    #[test]
    fn repeated_and_regressing_sequences_are_replays_a_new_session_is_a_restart() {
        let mut g = Guard::new(None);
        for (seq, lost) in [(0, 0), (1, 0), (5, 3)] {
            assert_eq!(g.check("k", &header("cam", 7, seq, T0), T0, 0), Ok(lost), "seq {seq}");
        }
        for seq in [5, 4, 0] {
            let err = g.check("k", &header("cam", 7, seq, T0), T0, 0).unwrap_err();
            assert_eq!(err, InputError::Replayed { sender: "cam".into(), session: 7, seq, last: 5 });
        }
        // the sender restarted: numbering from 0 under a new session is not a replay
        assert_eq!(g.check("k", &header("cam", 8, 0, T0), T0, 0), Ok(0));
        // the same numbers from another sender or on another key are their own
        assert_eq!(g.check("k", &header("other", 7, 1, T0), T0, 0), Ok(0));
        assert_eq!(g.check("k2", &header("cam", 7, 1, T0), T0, 0), Ok(0));
        // the old session's messages are still checked against what it sent
        assert_eq!(g.check("k", &header("cam", 7, 5, T0), T0, 0).unwrap_err().kind(), "replayed");
    }

    #[test]
    fn numbers_a_publisher_skipped_are_counted_as_lost_and_refused_ones_are_not() {
        let mut g = Guard::new(Some(Freshness::within(Duration::from_millis(150))));
        // heard from 10 on: what it sent before is not known here, not lost
        assert_eq!(g.check("k", &header("cam", 7, 10, T0), T0, 0), Ok(0));
        assert_eq!(g.check("k", &header("cam", 7, 11, T0), T0, 0), Ok(0));
        // 12 and 13 never arrived
        assert_eq!(g.check("k", &header("cam", 7, 14, T0), T0, 0), Ok(2));
        // 15 arrived stale, 16 never arrived: one lost, one refused (counted as such)
        assert_eq!(g.check("k", &header("cam", 7, 15, T0), T0 + 900 * MS, 0).unwrap_err().kind(), "stale");
        assert_eq!(g.check("k", &header("cam", 7, 17, T0 + 900 * MS), T0 + 900 * MS, 0), Ok(1));
        // a replay of an old number changes nothing
        assert_eq!(
            g.check("k", &header("cam", 7, 12, T0 + 900 * MS), T0 + 900 * MS, 0).unwrap_err().kind(),
            "replayed"
        );
        assert_eq!(g.check("k", &header("cam", 7, 18, T0 + 900 * MS), T0 + 900 * MS, 0), Ok(0));
        // a restart numbers from 0 under a new session: nothing lost
        assert_eq!(g.check("k", &header("cam", 8, 0, T0 + 900 * MS), T0 + 900 * MS, 0), Ok(0));
    }

    #[test]
    fn a_flood_of_forged_sessions_is_bounded_and_forgets_the_least_recent() {
        let mut g = Guard::new(None);
        assert_eq!(g.check("k", &header("cam", 1, 10, T0), T0, 0), Ok(0));
        for s in 0..1_000u64 {
            assert_eq!(g.check("k", &header("forger", 1_000 + s, 0, T0), T0 + 1 + s, 0), Ok(0));
        }
        assert_eq!(g.publishers.len(), MAX_PUBLISHERS);
        assert!(!g.publishers.keys().any(|id| id.sender == "cam"), "the least recently heard is forgotten");
    }
}
