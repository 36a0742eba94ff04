//! Per-agent health: stream counters (rate, bytes/s, capture->receipt latency
//! percentiles), rejected inputs by kind (each kind logged once), a liveliness token
//! at `health/<agent>` and a periodic [`HealthStats`] publication, run by a
//! [`HealthTask`] that the agent's loop watches.

use std::collections::{BTreeMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use schemas::{HealthStats, Keys, RejectCount, StreamStats};
use tokio::task::JoinHandle;
use zenoh::Session;

use crate::{now_ns, stream::Lane, Publisher, Shutdown, Subscriber};
use schemas::guard::Clocks;

/// Latency samples kept per stream per reporting period (older ones are dropped).
const MAX_LATENCY_SAMPLES: usize = 8192;

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic while holding one of these short locks leaves plain counters behind,
    // still meaningful: keep going rather than poison every later health report.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

#[derive(Debug)]
struct Window {
    started: Instant,
    count_at_start: u64,
    bytes_at_start: u64,
    latencies_ms: Vec<f32>,
}

/// Counters of one stream.
#[derive(Debug)]
pub struct StreamCounter {
    key: String,
    inbound: bool,
    count: AtomicU64,
    bytes: AtomicU64,
    rejects: AtomicU64,
    missed: AtomicU64,
    window: Mutex<Window>,
}

impl StreamCounter {
    fn new(key: &str, inbound: bool) -> Self {
        Self {
            key: key.to_string(),
            inbound,
            count: AtomicU64::new(0),
            bytes: AtomicU64::new(0),
            rejects: AtomicU64::new(0),
            missed: AtomicU64::new(0),
            window: Mutex::new(Window {
                started: Instant::now(),
                count_at_start: 0,
                bytes_at_start: 0,
                latencies_ms: Vec::with_capacity(256),
            }),
        }
    }

    /// Count one message of `bytes` payload bytes, `latency_ms` old when seen.
    pub fn record(&self, bytes: usize, latency_ms: Option<f32>) {
        self.count.fetch_add(1, Ordering::Relaxed);
        self.bytes.fetch_add(bytes as u64, Ordering::Relaxed);
        if let Some(l) = latency_ms.filter(|l| l.is_finite()) {
            let mut w = lock(&self.window);
            if w.latencies_ms.len() < MAX_LATENCY_SAMPLES {
                w.latencies_ms.push(l);
            }
        }
    }

    /// Messages since start.
    pub fn count(&self) -> u64 {
        self.count.load(Ordering::Relaxed)
    }

    /// Rejected payloads since start.
    pub fn rejects(&self) -> u64 {
        self.rejects.load(Ordering::Relaxed)
    }

    /// Count `n` messages numbered by their publisher that never arrived (gaps in its
    /// sequence numbers).
    pub fn miss(&self, n: u64) {
        self.missed.fetch_add(n, Ordering::Relaxed);
    }

    /// Messages lost on the way since start.
    pub fn missed(&self) -> u64 {
        self.missed.load(Ordering::Relaxed)
    }

    /// Close the current period and report it.
    fn roll(&self) -> StreamStats {
        let count = self.count();
        let bytes = self.bytes.load(Ordering::Relaxed);
        let mut w = lock(&self.window);
        let secs = w.started.elapsed().as_secs_f32().max(1e-3);
        let (p50, p99) = percentiles(&mut w.latencies_ms);
        let stats = StreamStats {
            key: self.key.clone(),
            inbound: self.inbound,
            count,
            rate_hz: (count - w.count_at_start) as f32 / secs,
            bytes_per_s: (bytes - w.bytes_at_start) as f32 / secs,
            rejects: self.rejects(),
            missed: self.missed(),
            latency_p50_ms: p50,
            latency_p99_ms: p99,
        };
        w.started = Instant::now();
        w.count_at_start = count;
        w.bytes_at_start = bytes;
        w.latencies_ms.clear();
        stats
    }
}

/// Median and 99th percentile (nearest rank) of `samples`; NaN when empty.
pub fn percentiles(samples: &mut [f32]) -> (f32, f32) {
    if samples.is_empty() {
        return (f32::NAN, f32::NAN);
    }
    samples.sort_by(|a, b| a.total_cmp(b));
    let at = |q: f32| samples[((q * samples.len() as f32).ceil() as usize).clamp(1, samples.len()) - 1];
    (at(0.5), at(0.99))
}

/// Health of one agent, shared by all its tasks.
#[derive(Debug)]
pub struct Health {
    agent: String,
    started: Instant,
    streams: Mutex<Vec<Arc<StreamCounter>>>,
    rejects: Mutex<BTreeMap<String, u64>>,
    logged: Mutex<HashSet<(String, String)>>,
    status: Mutex<(bool, String)>,
    nudge: tokio::sync::Notify,
    /// The other agents' clock offsets, from their health messages.
    clocks: Mutex<Clocks>,
    /// The tightest freshness bound of this agent's subscriptions: a sender whose clock
    /// is off by more is named in the status.
    clock_bound: Mutex<Option<Duration>>,
    /// Senders already warned about (a clock found off is logged once).
    clock_warned: Mutex<HashSet<String>>,
}

impl Health {
    /// Health for `agent` (also its liveliness token name).
    pub fn new(agent: &str) -> Arc<Self> {
        Arc::new(Self {
            agent: agent.to_string(),
            started: Instant::now(),
            streams: Mutex::new(Vec::new()),
            rejects: Mutex::new(BTreeMap::new()),
            logged: Mutex::new(HashSet::new()),
            status: Mutex::new((true, "starting".to_string())),
            nudge: tokio::sync::Notify::new(),
            clocks: Mutex::new(Clocks::default()),
            clock_bound: Mutex::new(None),
            clock_warned: Mutex::new(HashSet::new()),
        })
    }

    /// A subscription refuses inputs older than `max_age`: senders whose clock is off
    /// by more than the tightest such bound are named in the status.
    pub fn bound_clock_offsets(&self, max_age: Duration) {
        let mut bound = lock(&self.clock_bound);
        *bound = Some(bound.map_or(max_age, |b| b.min(max_age)));
    }

    /// How far `sender`'s clock reads behind ours (trip included), from its health
    /// messages; 0 until one is heard.
    pub fn clock_offset_ns(&self, sender: &str) -> i64 {
        lock(&self.clocks).offset_ns(sender)
    }

    /// A health message of `sender` stamped `stamp_ns` arrived at `received_ns`.
    pub fn observe_clock(&self, sender: &str, stamp_ns: u64, received_ns: u64) {
        if sender != self.agent {
            lock(&self.clocks).observe(sender, stamp_ns, received_ns);
        }
    }

    /// "clock of X 2001 ms behind" for each sender off by more than the bound.
    fn clock_notes(&self) -> Vec<String> {
        let Some(bound) = *lock(&self.clock_bound) else { return Vec::new() };
        let off = lock(&self.clocks).off_by_more_than(bound);
        let mut warned = lock(&self.clock_warned);
        off.into_iter()
            .map(|(sender, ms)| {
                let trusted = ms.unsigned_abs() as u128 <= schemas::guard::MAX_TRUSTED_OFFSET.as_millis();
                let side = if ms > 0 { "behind" } else { "ahead" };
                let note = if trusted {
                    format!("clock of {sender} {} ms {side}", ms.abs())
                } else {
                    format!("clock of {sender} {} ms {side}, not trusted", ms.abs())
                };
                if warned.insert(sender) {
                    let reading = if trusted {
                        "its stamps are read through that offset"
                    } else {
                        "past the 10 s a LAN's clocks can be apart, so its stamps are read as they are and its input is refused as stale (or replayed health)"
                    };
                    tracing::warn!(agent = %self.agent, "{note} (more than the {} ms input bound): {reading}; check NTP on its host", bound.as_millis());
                }
                note
            })
            .collect()
    }

    /// Agent name.
    pub fn agent(&self) -> &str {
        &self.agent
    }

    /// Register a stream and get its counter.
    pub fn stream(&self, key: &str, inbound: bool) -> Arc<StreamCounter> {
        let counter = Arc::new(StreamCounter::new(key, inbound));
        lock(&self.streams).push(counter.clone());
        counter
    }

    /// Count a rejected input of `kind` seen on `source` (a key or a file); the first
    /// rejection of each kind per source is logged with its reason, later ones only
    /// counted, so a flood of garbage cannot flood the log.
    pub fn reject(&self, source: &str, kind: &str, reason: &dyn std::fmt::Display) {
        *lock(&self.rejects).entry(kind.to_string()).or_insert(0) += 1;
        if let Some(c) = lock(&self.streams).iter().find(|c| c.key == source) {
            c.rejects.fetch_add(1, Ordering::Relaxed);
        }
        if lock(&self.logged).insert((source.to_string(), kind.to_string())) {
            tracing::warn!(agent = %self.agent, %source, kind, "rejected input: {reason} (further '{kind}' rejects on this source are only counted)");
        }
    }

    /// Messages lost on the way to `source` (gaps in a publisher's sequence numbers,
    /// counted in its stream): logged the first time on each source, then only counted.
    pub fn note_missed(&self, source: &str, what: &dyn std::fmt::Display) {
        if lock(&self.logged).insert((source.to_string(), "missed".to_string())) {
            tracing::warn!(agent = %self.agent, %source, "messages lost on the way: {what} (further losses on this source are only counted)");
        }
    }

    /// Rejects of `kind` so far.
    pub fn rejects_of(&self, kind: &str) -> u64 {
        lock(&self.rejects).get(kind).copied().unwrap_or(0)
    }

    /// All rejects so far.
    pub fn rejects_total(&self) -> u64 {
        lock(&self.rejects).values().sum()
    }

    /// Set whether the agent is doing its job, and a short state summary. A change of
    /// `ok` is published at once, not at the next period: watchers must learn within
    /// the safety deadline that a source stalled.
    pub fn set_status(&self, ok: bool, status: impl Into<String>) {
        let mut current = lock(&self.status);
        let changed = current.0 != ok;
        *current = (ok, status.into());
        if changed {
            self.nudge.notify_one();
        }
    }

    /// Current status.
    pub fn status(&self) -> (bool, String) {
        lock(&self.status).clone()
    }

    /// Close the reporting period and return the stats message.
    pub fn snapshot(&self) -> HealthStats {
        let (ok, mut status) = self.status();
        for note in self.clock_notes() {
            status.push_str("; ");
            status.push_str(&note);
        }
        HealthStats {
            agent: self.agent.clone(),
            uptime_ms: self.started.elapsed().as_millis() as u64,
            ok,
            status,
            streams: lock(&self.streams).iter().map(|c| c.roll()).collect(),
            rejects: lock(&self.rejects)
                .iter()
                .map(|(kind, count)| RejectCount { kind: kind.clone(), count: *count })
                .collect(),
        }
    }

    /// Start the task that declares the liveliness token `health/<agent>` and
    /// publishes stats every `period` until shutdown or [`HealthTask::join`]. Dropping
    /// the token (when the task ends or the process dies) tells every watcher the agent
    /// is gone.
    pub fn spawn(self: &Arc<Self>, session: Session, keys: Keys, period: Duration, shutdown: Shutdown) -> HealthTask {
        // Its own stop as well: an agent may end before shutdown (a recording ran out)
        // without stopping the other agents of the process, as the demo runs them.
        let stop = Shutdown::new();
        let task = tokio::spawn(self.clone().serve(session, keys, period, shutdown.clone(), stop.clone()));
        HealthTask { task: Some(task), shutdown, stop }
    }

    async fn serve(
        self: Arc<Self>,
        session: Session,
        keys: Keys,
        period: Duration,
        shutdown: Shutdown,
        stop: Shutdown,
    ) -> anyhow::Result<()> {
        let key = keys.health(&self.agent);
        let token = session
            .liveliness()
            .declare_token(key.clone())
            .await
            .map_err(|e| anyhow!("cannot declare liveliness token {key}: {e}"))?;
        let mut publisher =
            Publisher::<HealthStats>::declare(&session, key, &self.agent, Lane::Telemetry, None).await?;
        // the other agents' health stamps give their clock offsets
        let others = Subscriber::<HealthStats>::declare(&session, keys.health_any(), false, &self).await?;
        let mut tick = tokio::time::interval(period);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        tick.tick().await;
        loop {
            tokio::select! {
                _ = shutdown.triggered() => break,
                _ = stop.triggered() => break,
                _ = self.nudge.notified() => {}
                _ = tick.tick() => {}
                Some(h) = others.recv() => {
                    self.observe_clock(&h.header.sender, h.header.capture_ns, h.received_ns);
                    continue;
                }
            }
            let stats = self.snapshot();
            if let Err(e) = publisher.put(now_ns(), &stats).await {
                tracing::warn!("health publish failed: {e:#}");
            }
        }
        drop(token);
        Ok(())
    }
}

/// The running task behind [`Health::spawn`]. Without it the agent has no liveliness
/// token, so every watchdog believes it is gone while it runs: the agent's loop selects
/// on [`HealthTask::failed`] and ends with that error, and joins the task when it stops.
#[derive(Debug)]
#[must_use = "a health task nobody watches fails unnoticed: select on `failed()`, then `join()` it"]
pub struct HealthTask {
    /// `None` once the task has ended and [`HealthTask::failed`] has taken its outcome.
    task: Option<JoinHandle<anyhow::Result<()>>>,
    shutdown: Shutdown,
    stop: Shutdown,
}

impl HealthTask {
    /// Resolves with the reason if the task ends before shutdown (`health task failed:
    /// cannot declare liveliness token ...`); stays pending while it runs and after a
    /// clean stop. Cancel-safe: call it in every round of a `select!`.
    pub async fn failed(&mut self) -> anyhow::Error {
        let Some(task) = self.task.as_mut() else { return std::future::pending().await };
        let ended = task.await;
        self.task = None;
        match ended {
            Ok(Ok(())) if self.shutdown.is_triggered() => std::future::pending().await,
            Ok(Ok(())) => anyhow!("health task failed: it ended before shutdown"),
            Ok(Err(e)) => e.context("health task failed"),
            Err(e) => anyhow!("health task failed: {e}"),
        }
    }

    /// Stop the task (if shutdown has not already) and wait for it, which withdraws the
    /// liveliness token: its error if it failed.
    pub async fn join(mut self) -> anyhow::Result<()> {
        self.stop.trigger();
        let Some(task) = self.task.take() else { return Ok(()) };
        task.await.map_err(|e| anyhow!("{e}")).and_then(|r| r).context("health task failed")
    }
}

impl Drop for HealthTask {
    /// An agent that returns early (an error) takes its token with it, even when its
    /// session lives on in the same process (the demo).
    fn drop(&mut self) {
        if let Some(task) = &self.task {
            task.abort();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BusOptions;

    fn loopback() -> BusOptions {
        // no endpoints, no multicast: a session that meets nobody
        BusOptions { no_multicast: true, ..BusOptions::for_user("healthtest") }
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_token_that_cannot_be_declared_fails_the_task_at_once() {
        let opts = loopback();
        let session = crate::open_session(&opts).await.unwrap();
        // The one way zenoh 1.10 refuses a token: the session is closed.
        session.close().await.unwrap();
        let mut task =
            Health::new("test-agent").spawn(session, opts.keys().unwrap(), Duration::from_millis(50), Shutdown::new());
        let error = tokio::time::timeout(Duration::from_secs(5), task.failed())
            .await
            .expect("the failure surfaces at once, not at shutdown");
        let text = format!("{error:#}");
        assert!(
            text.starts_with(
                "health task failed: cannot declare liveliness token wearnav/healthtest/health/test-agent"
            ),
            "{text}"
        );
        assert!(text.contains("session closed"), "{text}");
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_running_task_is_not_a_failure_and_joins_cleanly_at_shutdown() {
        let opts = loopback();
        let session = crate::open_session(&opts).await.unwrap();
        let keys = opts.keys().unwrap();
        let shutdown = Shutdown::new();
        let watch = session.liveliness().declare_subscriber(keys.health("test-agent")).history(true).await.unwrap();
        let mut task =
            Health::new("test-agent").spawn(session.clone(), keys.clone(), Duration::from_millis(50), shutdown.clone());
        let declared = tokio::time::timeout(Duration::from_secs(5), watch.recv_async()).await;
        assert!(matches!(declared, Ok(Ok(_))), "the token is declared while the task runs");
        assert!(
            tokio::time::timeout(Duration::from_millis(200), task.failed()).await.is_err(),
            "no failure while running"
        );
        shutdown.trigger();
        tokio::time::timeout(Duration::from_secs(2), task.join()).await.expect("stops at shutdown").unwrap();
        let gone = tokio::time::timeout(Duration::from_secs(2), watch.recv_async()).await;
        assert!(matches!(gone, Ok(Ok(s)) if s.kind() == zenoh::sample::SampleKind::Delete), "the token goes with it");
        session.close().await.unwrap();
    }

    #[test]
    fn percentiles_use_nearest_rank() {
        let mut v: Vec<f32> = (1..=100).map(|i| i as f32).collect();
        assert_eq!(percentiles(&mut v), (50.0, 99.0));
        let mut one = vec![7.0];
        assert_eq!(percentiles(&mut one), (7.0, 7.0));
        assert!(percentiles(&mut []).0.is_nan());
    }

    #[test]
    fn rejects_are_counted_per_kind_and_per_stream() {
        let h = Health::new("test-agent");
        let c = h.stream("wearnav/a/perception/hazard", true);
        h.reject("wearnav/a/perception/hazard", "truncated", &"short");
        h.reject("wearnav/a/perception/hazard", "truncated", &"short");
        h.reject("file.pcd", "malformed", &"bad header");
        assert_eq!(h.rejects_of("truncated"), 2);
        assert_eq!(h.rejects_total(), 3);
        assert_eq!(c.rejects(), 2);
        let snap = h.snapshot();
        assert_eq!(snap.rejects.len(), 2);
        assert_eq!(snap.streams[0].rejects, 2);
    }

    #[test]
    fn stream_stats_report_counts_and_latency() {
        let h = Health::new("x");
        let c = h.stream("k", true);
        for i in 0..10 {
            c.record(100, Some(i as f32));
        }
        let s = h.snapshot();
        assert_eq!(s.streams[0].count, 10);
        assert_eq!(s.streams[0].latency_p50_ms, 4.0);
        assert_eq!(s.streams[0].latency_p99_ms, 9.0);
        assert!(s.streams[0].bytes_per_s > 0.0);
        // The next period starts empty.
        assert!(h.snapshot().streams[0].latency_p50_ms.is_nan());
    }

    #[test]
    fn a_sender_whose_clock_is_off_by_more_than_the_bound_is_named_in_the_status() {
        let h = Health::new("compute-agent");
        h.set_status(true, "seeing");
        let t = 1_800_000_000_000_000_000u64;
        // no bound registered yet: nothing to compare with
        h.observe_clock("sensor-agent", t - 2_000_000_000, t + 1_000_000);
        assert_eq!(h.snapshot().status, "seeing");
        h.bound_clock_offsets(Duration::from_millis(250));
        h.bound_clock_offsets(Duration::from_millis(150));
        h.observe_clock("feedback-agent", t + 100_000_000, t + 100_500_000); // 0.5 ms trip: fine
        h.observe_clock("phone-bridge", t + 400_000_000, t); // 400 ms ahead
        h.observe_clock("compute-agent", t - 9_000_000_000, t); // its own messages are not another's clock
        assert_eq!(
            h.snapshot().status,
            "seeing; clock of phone-bridge 400 ms ahead; clock of sensor-agent 2001 ms behind"
        );
        assert_eq!(h.clock_offset_ns("sensor-agent"), 2_001_000_000);
        assert_eq!(h.clock_offset_ns("compute-agent"), 0);
    }
}
