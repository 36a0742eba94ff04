//! Typed publishers and subscribers: encode/decode with the `schemas` wire contract,
//! QoS per lane, counted and logged rejects.

use std::marker::PhantomData;
use std::sync::Arc;

use anyhow::anyhow;
use schemas::{Header, Message};
use zenoh::bytes::Encoding;
use zenoh::handlers::{FifoChannel, FifoChannelHandler, RingChannel, RingChannelHandler};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::Sample;
use zenoh::Session;

use crate::{clock, Health, StreamCounter};

/// Quality of service of a stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lane {
    /// Depth frames: large, must not be dropped by the sender's queue (block), but
    /// yield to everything else (low priority); sent at once rather than batched
    /// (measured: batching added ~5 ms to capture -> intent in the demo). Subscribers
    /// keep only the newest.
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
            Lane::Bulk => (Priority::DataLow, CongestionControl::Block, true),
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

/// Publishes messages of one schema on one key, numbering them.
pub struct Publisher<M: Message> {
    inner: zenoh::pubsub::Publisher<'static>,
    sender: String,
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
        Ok(Self { inner, sender: sender.to_string(), seq: 0, counter, _m: PhantomData })
    }

    /// Publish `body` with capture stamp `capture_ns`; returns its sequence number.
    pub async fn put(&mut self, capture_ns: u64, body: &M) -> anyhow::Result<u64> {
        let seq = self.seq;
        let bytes = schemas::encode(&self.sender, seq, capture_ns, body);
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
}

impl<M> Received<M> {
    /// Age at receipt, milliseconds.
    pub fn age_ms(&self) -> f64 {
        clock::age_ms(self.header.capture_ns, self.received_ns)
    }
}

enum Inbox {
    Fifo(zenoh::pubsub::Subscriber<FifoChannelHandler<Sample>>),
    Newest(zenoh::pubsub::Subscriber<RingChannelHandler<Sample>>),
}

/// Receives messages of one schema; rejects (wrong schema or version, truncated,
/// oversized, malformed, invalid) are counted and logged in `health`, never returned.
pub struct Subscriber<M: Message> {
    inbox: Inbox,
    key: String,
    health: Arc<Health>,
    counter: Arc<StreamCounter>,
    _m: PhantomData<fn() -> M>,
}

impl<M: Message> Subscriber<M> {
    /// Subscribe to `key`. With `keep_newest` only the latest unread sample is kept
    /// (consumers of depth frames must never work through a backlog of old frames);
    /// otherwise samples queue (up to 256).
    pub async fn declare(
        session: &Session,
        key: String,
        keep_newest: bool,
        health: &Arc<Health>,
    ) -> anyhow::Result<Self> {
        let builder = session.declare_subscriber(key.clone());
        let inbox = if keep_newest {
            Inbox::Newest(builder.with(RingChannel::new(1)).await.map_err(|e| anyhow!("cannot subscribe {key}: {e}"))?)
        } else {
            Inbox::Fifo(builder.with(FifoChannel::new(256)).await.map_err(|e| anyhow!("cannot subscribe {key}: {e}"))?)
        };
        let counter = health.stream(&key, true);
        Ok(Self { inbox, key, health: health.clone(), counter, _m: PhantomData })
    }

    /// Next valid message; `None` once the subscription is closed.
    pub async fn recv(&self) -> Option<Received<M>> {
        loop {
            let sample = match &self.inbox {
                Inbox::Fifo(s) => s.recv_async().await.ok()?,
                Inbox::Newest(s) => s.recv_async().await.ok()?,
            };
            if let Some(msg) = self.accept(&sample) {
                return Some(msg);
            }
        }
    }

    /// Next valid message if one is waiting.
    pub fn try_recv(&self) -> Option<Received<M>> {
        loop {
            let sample = match &self.inbox {
                Inbox::Fifo(s) => s.try_recv().ok()??,
                Inbox::Newest(s) => s.try_recv().ok()??,
            };
            if let Some(msg) = self.accept(&sample) {
                return Some(msg);
            }
        }
    }

    fn accept(&self, sample: &Sample) -> Option<Received<M>> {
        let bytes = sample.payload().to_bytes();
        let key = sample.key_expr().as_str();
        match schemas::decode::<M>(&bytes) {
            Ok((header, body)) => {
                let received_ns = clock::now_ns();
                let age = clock::age_ms(header.capture_ns, received_ns) as f32;
                self.counter.record(bytes.len(), Some(age));
                Some(Received { key: key.to_string(), header, body, received_ns })
            }
            Err(e) => {
                self.health.reject(&self.key, e.kind(), &format_args!("{e} (on {key})"));
                None
            }
        }
    }

    /// The key expression subscribed.
    pub fn key(&self) -> &str {
        &self.key
    }
}
