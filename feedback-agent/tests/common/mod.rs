//! Helpers shared by the bus tests: a free port, hazards at 30 Hz, waiting for an
//! applied action.

#![allow(dead_code)] // each test binary uses its own subset

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use bus::{BusOptions, Health, Lane, Publisher, Subscriber};
use schemas::{Applied, GroundState, Hazard, Keys};

/// A test session listening on a free loopback port, and the bus options an agent
/// under test connects with: one user of its own, no multicast.
pub struct Loopback {
    pub user: String,
    pub test_bus: BusOptions,
    pub agent_bus: BusOptions,
    pub keys: Keys,
    pub session: zenoh::Session,
    pub health: Arc<Health>,
}

impl Loopback {
    pub async fn open(user_prefix: &str) -> Loopback {
        let user = format!("{user_prefix}{}", std::process::id());
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let test_bus = BusOptions { listen: vec![endpoint.clone()], no_multicast: true, ..BusOptions::for_user(&user) };
        let agent_bus = BusOptions { connect: vec![endpoint], no_multicast: true, ..BusOptions::for_user(&user) };
        let keys = Keys::new(&user).expect("test user name");
        let session = bus::open_session(&test_bus).await.expect("test session");
        Loopback { user, test_bus, agent_bus, keys, session, health: Health::new("test") }
    }
}

pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map(|a| a.port()).expect("a free port")
}

pub fn hazard(seq: u64) -> Hazard {
    Hazard::nothing_ahead(seq, GroundState::Found)
}

/// Publishes hazards at 30 Hz while `on` is set; remembers when the last one went out.
pub struct HazardStream {
    on: Arc<AtomicBool>,
    last: Arc<Mutex<Instant>>,
}

impl HazardStream {
    pub fn start(session: zenoh::Session, keys: Keys) -> Self {
        let on = Arc::new(AtomicBool::new(true));
        let last = Arc::new(Mutex::new(Instant::now()));
        let (on2, last2) = (on.clone(), last.clone());
        tokio::spawn(async move {
            let mut p = Publisher::<Hazard>::declare(&session, keys.hazard(), "test-compute", Lane::Perception, None)
                .await
                .expect("hazard publisher");
            let mut seq = 0;
            loop {
                if on2.load(Ordering::SeqCst) {
                    if p.put(bus::now_ns(), &hazard(seq)).await.is_err() {
                        return;
                    }
                    *last2.lock().unwrap() = Instant::now();
                    seq += 1;
                }
                tokio::time::sleep(Duration::from_millis(33)).await;
            }
        });
        Self { on, last }
    }

    pub fn set(&self, on: bool) {
        self.on.store(on, Ordering::SeqCst);
    }

    pub fn last(&self) -> Instant {
        *self.last.lock().unwrap()
    }
}

pub async fn wait_applied(sub: &Subscriber<Applied>, within: Duration, pred: impl Fn(&Applied) -> bool) -> Applied {
    let deadline = Instant::now() + within;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match tokio::time::timeout(left, sub.recv()).await {
            Ok(Some(m)) if pred(&m.body) => return m.body,
            Ok(Some(_)) => {}
            _ => panic!("no matching applied action within {within:?}"),
        }
    }
}
