//! Typed publishers and subscribers: encode/decode with the `schemas` wire contract,
//! QoS per lane, counted and logged rejects.
//!
//! A subscriber checks each message where it arrives, in Zenoh's callback: the wire
//! checks (checksum, size, layout, values), then the [`Guard`] (sequence, and freshness
//! where the subscription has a bound). Only a message that passes takes a place in
//! the inbox, so a flood of garbage, replays or stale frames never displaces a good one.

use std::collections::VecDeque;
use std::hash::BuildHasher;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::anyhow;
use schemas::{Header, Message, Origin};
use zenoh::bytes::Encoding;
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::Sample;
use zenoh::Session;

use crate::{clock, Health, StreamCounter};
use schemas::guard::{Freshness, Guard};

/// Quality of service of a stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lane {
    /// Depth frames: large, yield to everything else (low priority), dropped rather
    /// than queued when a link is congested (a frame that waits is stale anyway, and
    /// with Block one monitor on a slow link stalled the router's forwarding to the
    /// compute agent too: no hazard in 6 s, and after a 2 s link cut detection came back
    /// 3.1-3.6 s late against 0.06-0.09 s with Drop; docs/deployment.md); sent at once
    /// rather than batched (measured: batching added ~5 ms to capture -> intent in the
    /// demo). Subscribers keep only the newest.
    Bulk,
    /// Haptic and speech intents: tiny and urgent (real-time priority, express, no
    /// batching); a late intent is worse than a dropped one, which its successor
    /// replaces within a frame.
    RealTime,
    /// Hazards and scans: high priority, express, latest wins.
    Perception,
    /// What devices did, user commands: must arrive (block), ordinary priority.
    Events,
    /// Health, pose, truth, IMU, odometry: ordinary, droppable under congestion.
    Telemetry,
}

impl Lane {
    fn qos(self) -> (Priority, CongestionControl, bool) {
        match self {
            Lane::Bulk => (Priority::DataLow, CongestionControl::Drop, true),
            Lane::RealTime => (Priority::RealTime, CongestionControl::Drop, true),
            Lane::Perception => (Priority::InteractiveHigh, CongestionControl::Drop, true),
            Lane::Events => (Priority::Data, CongestionControl::Block, false),
            Lane::Telemetry => (Priority::Data, CongestionControl::Drop, false),
        }
    }
}

/// The Zenoh encoding naming schema `M`, so generic monitors can dispatch.
pub fn encoding_of<M: Message>() -> Encoding {
    Encoding::APPLICATION_OCTET_STREAM.with_schema(M::SCHEMA.encoding_schema())
}

/// A random publisher session id, different for every publisher of every run.
fn new_session_id() -> u64 {
    static DECLARED: AtomicU64 = AtomicU64::new(0);
    // RandomState is keyed from the OS's randomness once per process
    std::collections::hash_map::RandomState::new().hash_one((
        clock::now_ns(),
        std::process::id(),
        DECLARED.fetch_add(1, Ordering::Relaxed),
    ))
}

/// Publishes messages of one schema on one key, numbering them.
pub struct Publisher<M: Message> {
    inner: zenoh::pubsub::Publisher<'static>,
    sender: String,
    session: u64,
    seq: u64,
    counter: Option<Arc<StreamCounter>>,
    _m: PhantomData<fn(M)>,
}

impl<M: Message> Publisher<M> {
    /// Declare a publisher on `key`; `health` (when given) counts what is sent.
    pub async fn declare(
        session: &Session,
        key: String,
        sender: &str,
        lane: Lane,
        health: Option<&Health>,
    ) -> anyhow::Result<Self> {
        let (priority, congestion, express) = lane.qos();
        let counter = health.map(|h| h.stream(&key, false));
        let inner = session
            .declare_publisher(key.clone())
            .encoding(encoding_of::<M>())
            .priority(priority)
            .congestion_control(congestion)
            .express(express)
            .await
            .map_err(|e| anyhow!("cannot declare publisher on {key}: {e}"))?;
        Ok(Self { inner, sender: sender.to_string(), session: new_session_id(), seq: 0, counter, _m: PhantomData })
    }

    /// Publish `body` with capture stamp `capture_ns`; returns its sequence number.
    pub async fn put(&mut self, capture_ns: u64, body: &M) -> anyhow::Result<u64> {
        let seq = self.seq;
        let origin = Origin { sender: &self.sender, session: self.session };
        let bytes = schemas::encode(&origin, seq, capture_ns, body);
        let len = bytes.len();
        self.inner.put(bytes).await.map_err(|e| anyhow!("publish on {} failed: {e}", self.inner.key_expr()))?;
        self.seq += 1;
        if let Some(c) = &self.counter {
            c.record(len, None);
        }
        Ok(seq)
    }

    /// The key published on.
    pub fn key(&self) -> &str {
        self.inner.key_expr().as_str()
    }
}

/// A decoded message with its envelope.
#[derive(Debug, Clone, PartialEq)]
pub struct Received<M> {
    /// Key it arrived on.
    pub key: String,
    /// Envelope (sender, seq, capture stamp).
    pub header: Header,
    /// Body.
    pub body: M,
    /// When it was decoded, ns since the epoch.
    pub received_ns: u64,
    /// The capture stamp on this host's clock: the sender's clock offset (as
    /// [`Health`] estimates it) taken out, and never later than `received_ns`.
    pub captured_ns: u64,
}

impl<M> Received<M> {
    /// Age at receipt, milliseconds.
    pub fn age_ms(&self) -> f64 {
        clock::age_ms(self.header.capture_ns, self.received_ns)
    }
}

/// Messages that passed every check, waiting for the agent's loop.
struct Inbox<M> {
    queue: Mutex<VecDeque<Received<M>>>,
    /// Keep only the newest of each key (depth frames, intents) instead of queueing.
    newest: bool,
    ready: tokio::sync::Notify,
}

/// Messages a queueing subscriber holds; beyond it new ones are refused and counted.
const QUEUE_CAPACITY: usize = 256;

impl<M> Inbox<M> {
    fn push(&self, message: Received<M>) -> Result<(), Received<M>> {
        let mut queue = self.queue.lock().unwrap_or_else(|e| e.into_inner());
        if self.newest {
            // per key: under a wildcard, one device's frames never push out another's
            queue.retain(|m| m.key != message.key);
        } else if queue.len() >= QUEUE_CAPACITY {
            return Err(message);
        }
        queue.push_back(message);
        drop(queue);
        self.ready.notify_one();
        Ok(())
    }

    fn pop(&self) -> Option<Received<M>> {
        self.queue.lock().unwrap_or_else(|e| e.into_inner()).pop_front()
    }
}

/// Receives messages of one schema. Rejects (wrong schema or version, damaged,
/// truncated, oversized, malformed, invalid; replayed; stale or from the future where
/// a freshness bound is set) are counted and logged in `health`, never returned.
pub struct Subscriber<M: Message> {
    _zenoh: zenoh::pubsub::Subscriber<()>,
    inbox: Arc<Inbox<M>>,
    key: String,
}

impl<M: Message + Send + 'static> Subscriber<M> {
    /// Subscribe to `key`. With `keep_newest` only the latest unread message of each
    /// key is kept (consumers of depth frames must never work through a backlog of old
    /// frames, and under a wildcard one camera's must not push out another's);
    /// otherwise messages queue (up to 256). Sequence numbers are checked; no age.
    pub async fn declare(
        session: &Session,
        key: String,
        keep_newest: bool,
        health: &Arc<Health>,
    ) -> anyhow::Result<Self> {
        Self::declare_with(session, key, keep_newest, None, health).await
    }

    /// Like [`Subscriber::declare`], refusing messages captured more than `max_age`
    /// before they arrive (or stamped in the future), after taking out the sender's
    /// clock offset as [`Health`] estimates it.
    pub async fn declare_fresh(
        session: &Session,
        key: String,
        keep_newest: bool,
        max_age: Duration,
        health: &Arc<Health>,
    ) -> anyhow::Result<Self> {
        Self::declare_with(session, key, keep_newest, Some(Freshness::within(max_age)), health).await
    }

    async fn declare_with(
        session: &Session,
        key: String,
        keep_newest: bool,
        freshness: Option<Freshness>,
        health: &Arc<Health>,
    ) -> anyhow::Result<Self> {
        if let Some(f) = freshness {
            health.bound_clock_offsets(f.max_age);
        }
        let inbox =
            Arc::new(Inbox { queue: Mutex::new(VecDeque::new()), newest: keep_newest, ready: Default::default() });
        let check = Check {
            key: key.clone(),
            health: health.clone(),
            counter: health.stream(&key, true),
            guard: Mutex::new(Guard::new(freshness)),
            inbox: inbox.clone(),
        };
        let zenoh = session
            .declare_subscriber(key.clone())
            .callback(move |sample| check.accept(&sample))
            .await
            .map_err(|e| anyhow!("cannot subscribe {key}: {e}"))?;
        Ok(Self { _zenoh: zenoh, inbox, key })
    }
}

impl<M: Message> Subscriber<M> {
    /// Next valid message (waits for one as long as the subscription lives).
    pub async fn recv(&self) -> Option<Received<M>> {
        loop {
            let ready = self.inbox.ready.notified();
            if let Some(m) = self.inbox.pop() {
                return Some(m);
            }
            ready.await;
        }
    }

    /// Next valid message if one is waiting.
    pub fn try_recv(&self) -> Option<Received<M>> {
        self.inbox.pop()
    }

    /// The key expression subscribed.
    pub fn key(&self) -> &str {
        &self.key
    }
}

/// What a subscription's callback does with each sample.
struct Check<M> {
    key: String,
    health: Arc<Health>,
    counter: Arc<StreamCounter>,
    guard: Mutex<Guard>,
    inbox: Arc<Inbox<M>>,
}

impl<M: Message> Check<M> {
    fn accept(&self, sample: &Sample) {
        let received_ns = clock::now_ns();
        let bytes = sample.payload().to_bytes();
        let key = sample.key_expr().as_str();
        let (header, body) = match schemas::decode::<M>(&bytes) {
            Ok(decoded) => decoded,
            Err(e) => return self.health.reject(&self.key, e.kind(), &format_args!("{e} (on {key})")),
        };
        let offset_ns = self.health.clock_offset_ns(&header.sender);
        let checked = self.guard.lock().unwrap_or_else(|e| e.into_inner()).check(key, &header, received_ns, offset_ns);
        let missed = match checked {
            Ok(missed) => missed,
            Err(e) => return self.health.reject(&self.key, e.kind(), &format_args!("{e} (on {key})")),
        };
        if missed > 0 {
            self.counter.miss(missed);
            self.health.note_missed(
                &self.key,
                &format_args!("{missed} before seq {} from {} (on {key})", header.seq, header.sender),
            );
        }
        // the latency as stamped: on one host that is the truth, across hosts the
        // offset estimate is too coarse to correct a few milliseconds with
        let age = clock::age_ms(header.capture_ns, received_ns) as f32;
        self.counter.record(bytes.len(), Some(age));
        let captured = header.capture_ns as i128 + offset_ns as i128;
        let captured_ns = captured.clamp(0, received_ns as i128) as u64;
        let message = Received { key: key.to_string(), header, body, received_ns, captured_ns };
        if let Err(m) = self.inbox.push(message) {
            let why = format!(
                "{QUEUE_CAPACITY} messages already wait; seq {} from {} refused",
                m.header.seq, m.header.sender
            );
            self.health.reject(&self.key, "queue_full", &why);
        }
    }
}

#[cfg(test)]
mod inbox_tests {
    use super::*;

    fn message(key: &str, seq: u64) -> Received<u64> {
        let header = schemas::Header { schema: 1, version: 1, sender: "t".into(), session: 1, seq, capture_ns: seq };
        Received { key: key.into(), header, body: seq, received_ns: seq, captured_ns: seq }
    }

    #[test]
    fn a_newest_inbox_keeps_the_newest_of_each_key_in_arrival_order() {
        let inbox = Inbox { queue: Mutex::new(VecDeque::new()), newest: true, ready: Default::default() };
        for (key, seq) in [("sensor/cane/depth", 1), ("sensor/chest/depth", 2), ("sensor/cane/depth", 3)] {
            assert!(inbox.push(message(key, seq)).is_ok());
        }
        let got: Vec<_> = std::iter::from_fn(|| inbox.pop()).map(|m| (m.key, m.body)).collect();
        assert_eq!(got, [("sensor/chest/depth".to_string(), 2), ("sensor/cane/depth".to_string(), 3)]);
    }
}
