//! Latency from a haptic intent's capture stamp to the HID write on a (fake) remote.
//!
//! Two figures, p50/p99:
//! 1. in the agent: payload bytes decoded -> feedback step -> HID write (no transport);
//! 2. over the bus: capture stamp at the publisher -> Zenoh loopback -> agent loop ->
//!    HID write, with intents published at 30 Hz as the compute agent does.
//!
//! `cargo bench -p feedback-agent --bench haptic_latency`; `FEEDBACK_BENCH_INTENTS`
//! (default 10000) and `FEEDBACK_BENCH_HZ` (default 30) change the run (10,000 intents
//! at 30 Hz take about 5.5 minutes).

use std::time::{Duration, Instant};

use bus::{BusOptions, Lane, Publisher, Shutdown};
use feedback_agent::console::ConsoleSpeech;
use feedback_agent::feedback::{Feedback, StepSettings};
use feedback_agent::wiimote::fake::FakeHid;
use feedback_agent::wiimote::{WiimoteBackend, WiimoteConfig};
use feedback_agent::{Devices, FeedbackConfig};
use schemas::{GroundState, HapticIntent, HapticPattern, Hazard, Keys};

const LEFT: &str = "/dev/hidraw0";
const RIGHT: &str = "/dev/hidraw1";

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn fake_pair() -> FakeHid {
    let hid = FakeHid::new();
    hid.attach(LEFT, "l");
    hid.attach(RIGHT, "r");
    hid
}

fn intent(k: u64) -> HapticIntent {
    let on = if k & 1 == 0 { (1.0, 0.0) } else { (0.0, 1.0) };
    HapticIntent { left: on.0, right: on.1, pattern: HapticPattern::Steady, ttl_ms: 200 }
}

fn report(what: &str, mut us: Vec<f64>) {
    us.sort_by(|a, b| a.total_cmp(b));
    let at = |q: f64| us[((q * us.len() as f64).ceil() as usize).clamp(1, us.len()) - 1];
    println!("{what}: n={} p50={:.1} us p99={:.1} us max={:.1} us", us.len(), at(0.5), at(0.99), us[us.len() - 1]);
}

/// Writes of rumble reports (0x10), with their stamps, in order.
fn rumble_writes(hid: &FakeHid) -> Vec<u64> {
    hid.written().iter().filter(|w| w.bytes.first() == Some(&0x10)).map(|w| w.at_ns).collect()
}

fn in_agent(n: u64) {
    let hid = fake_pair();
    let wii = WiimoteBackend::new(Box::new(hid.clone()), WiimoteConfig::default());
    let speech = ConsoleSpeech::new(Box::new(std::io::sink()), 175);
    let mut f = Feedback::new(StepSettings::default(), vec![Box::new(wii)], vec![Box::new(speech)], bus::now_ns());
    f.tick(bus::now_ns());
    let mut us = Vec::with_capacity(n as usize);
    let mut payload = Vec::with_capacity(64);
    for k in 0..n {
        payload.clear();
        let capture = bus::now_ns();
        schemas::encode_into(&schemas::Origin { sender: "bench", session: 1 }, k, capture, &intent(k), &mut payload);
        hid.clear_written();
        let t = bus::now_ns();
        if let Ok((header, body)) = schemas::decode::<HapticIntent>(&payload) {
            let _ = f.on_haptic(&body, header.capture_ns, bus::now_ns());
        }
        f.drain_applied();
        if let Some(w) = rumble_writes(&hid).first() {
            us.push((w - t) as f64 / 1e3);
        }
        if k % 10 == 0 {
            let now = bus::now_ns();
            f.on_hazard(&hazard(), now, now);
        }
    }
    report("in the agent (decode -> HID write)", us);
}

fn hazard() -> Hazard {
    Hazard::nothing_ahead(0, GroundState::Found)
}

async fn over_bus(n: u64, hz: u64) -> anyhow::Result<()> {
    let user = format!("fbbench{}", std::process::id());
    let port = std::net::TcpListener::bind("127.0.0.1:0")?.local_addr()?.port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let test_bus = BusOptions { listen: vec![endpoint.clone()], no_multicast: true, ..BusOptions::for_user(&user) };
    let agent_bus = BusOptions { connect: vec![endpoint], no_multicast: true, ..BusOptions::for_user(&user) };
    let keys = Keys::new(&user)?;
    let session = bus::open_session(&test_bus).await?;
    let hid = fake_pair();
    let devices = Devices {
        haptics: vec![Box::new(WiimoteBackend::new(Box::new(hid.clone()), WiimoteConfig::default()))],
        engines: vec![Box::new(ConsoleSpeech::new(Box::new(std::io::sink()), 175))],
        notes: vec![],
        phone: None,
    };
    let shutdown = Shutdown::new();
    let agent = tokio::spawn(feedback_agent::run_with(FeedbackConfig::with_bus(agent_bus), devices, shutdown.clone()));
    let mut hazards = Publisher::<Hazard>::declare(&session, keys.hazard(), "bench", Lane::Perception, None).await?;
    let mut haptic = Publisher::<HapticIntent>::declare(&session, keys.haptic(), "bench", Lane::RealTime, None).await?;
    tokio::time::sleep(Duration::from_millis(500)).await;
    hazards.put(bus::now_ns(), &hazard()).await?;
    tokio::time::sleep(Duration::from_millis(200)).await;

    let period = Duration::from_nanos(1_000_000_000 / hz.max(1));
    let mut tick = tokio::time::interval(period);
    let mut captures = Vec::with_capacity(n as usize);
    let started = Instant::now();
    hid.clear_written();
    for k in 0..n {
        tick.tick().await;
        let capture = bus::now_ns();
        haptic.put(capture, &intent(k)).await?;
        captures.push(capture);
        // Hazards keep detection online, so no offline alert mixes into the writes.
        hazards.put(bus::now_ns(), &hazard()).await?;
    }
    tokio::time::sleep(Duration::from_millis(100)).await;
    shutdown.trigger();
    agent.await??;
    let writes = rumble_writes(&hid);
    let mut us = Vec::with_capacity(captures.len());
    let mut w = 0;
    for (k, &c) in captures.iter().enumerate() {
        let next = captures.get(k + 1).copied().unwrap_or(u64::MAX);
        while w < writes.len() && writes[w] < c {
            w += 1;
        }
        if w < writes.len() && writes[w] < next {
            us.push((writes[w] - c) as f64 / 1e3);
        }
    }
    println!(
        "over the bus: {} intents at {hz} Hz in {:.0} s, {} matched to a HID write",
        n,
        started.elapsed().as_secs_f64(),
        us.len()
    );
    report("capture stamp -> Zenoh loopback -> agent -> HID write", us);
    Ok(())
}

fn main() -> anyhow::Result<()> {
    // `cargo bench` passes `--bench`; `cargo test --all-targets` does not, and must not
    // spend minutes here.
    if !std::env::args().any(|a| a == "--bench") {
        println!("haptic_latency: run with `cargo bench -p feedback-agent --bench haptic_latency`");
        return Ok(());
    }
    let n = env_or("FEEDBACK_BENCH_INTENTS", 10_000);
    let hz = env_or("FEEDBACK_BENCH_HZ", 30);
    in_agent(n);
    tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?.block_on(over_bus(n, hz))
}
