//! The secure profile (deploy/secure/) with the real binaries on loopback: `wearnav
//! certs` makes the authority, certificates and configurations, `wearnav router`
//! carries the access-control list, and the agents and the test's own clients connect
//! to it with their certificates. What must hold: the agents' traffic flows (depth ->
//! hazard -> feedback/applied); a monitor sees it but cannot make the rumble say
//! anything; a command goes through from a tool and not from a monitor; a node whose
//! certificate another authority signed cannot connect at all.

use std::io::{BufRead, BufReader};
use std::net::{Ipv4Addr, TcpListener};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use bus::{BusOptions, Health, Lane, Publisher, Subscriber};
use schemas::{Applied, AppliedAction, HapticIntent, HapticPattern, Hazard, Keys};

/// A process killed when dropped, so a failing test leaves nothing behind.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn bin(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_BIN_EXE_wearnav")).parent().expect("bin dir").to_path_buf();
    let path = dir.join(name);
    assert!(path.exists(), "{} missing: build the workspace first (cargo build --workspace)", path.display());
    path
}

fn free_port() -> u16 {
    TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).unwrap().local_addr().unwrap().port()
}

/// `wearnav certs --out dir --router endpoint`, checked.
fn certs(dir: &Path, endpoint: &str) {
    let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(["certs", "--out"])
        .arg(dir)
        .args(["--router", endpoint])
        .output()
        .expect("wearnav certs runs");
    assert!(out.status.success(), "wearnav certs failed: {}", String::from_utf8_lossy(&out.stderr));
}

/// The router, and the line it printed when it listened.
fn router(config: &Path) -> (Proc, String) {
    let mut child = Proc(
        Command::new(env!("CARGO_BIN_EXE_wearnav"))
            .args(["router", "--zenoh-config"])
            .arg(config)
            .env("RUST_LOG", "warn")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .spawn()
            .expect("wearnav router starts"),
    );
    let mut line = String::new();
    BufReader::new(child.0.stdout.take().expect("stdout")).read_line(&mut line).expect("router prints");
    (child, line)
}

fn agent(name: &str, user: &str, config: &Path, extra: &[&str]) -> Proc {
    let child = Command::new(bin(name))
        .args(["--user", user, "--zenoh-config"])
        .arg(config)
        .args(extra)
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
    Proc(child)
}

fn options(user: &str, config: PathBuf) -> BusOptions {
    BusOptions { zenoh_config: Some(config), ..BusOptions::for_user(user) }
}

/// Senders of the messages `sub` receives within `window`.
async fn senders<M: schemas::Message>(sub: &Subscriber<M>, window: Duration) -> Vec<String> {
    let deadline = tokio::time::Instant::now() + window;
    let mut seen = Vec::new();
    while let Ok(Some(m)) = tokio::time::timeout_at(deadline, sub.recv()).await {
        seen.push(m.header.sender.clone());
    }
    seen
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_secure_profile_carries_the_agents_and_refuses_a_monitor_that_writes_and_a_stranger() {
    let user = "secure-test";
    let scratch = tempfile::Builder::new().prefix("wearnav-secure-").tempdir().unwrap();
    let dir = scratch.path();
    let endpoint = format!("tls/127.0.0.1:{}", free_port());
    certs(dir, &endpoint);
    for f in ["ca.pem", "router.pem", "router.key", "router.json5", "monitor.pem", "monitor.json5"] {
        assert!(dir.join(f).is_file(), "wearnav certs wrote no {f}");
    }
    let (_router, said) = router(&dir.join("router.json5"));
    assert!(said.contains("listening on") && said.contains("access control enabled: true"), "router said: {said}");
    let _sensor = agent("sensor-agent", user, &dir.join("sensor.json5"), &["--source", "sim:approach"]);
    let _compute = agent("compute-agent", user, &dir.join("compute.json5"), &[]);
    let _feedback =
        agent("feedback-agent", user, &dir.join("feedback.json5"), &["--haptic", "console", "--speech", "console"]);

    let keys = Keys::new(user).unwrap();
    let health = Health::new("secure-test");
    let monitor = bus::open_session(&options(user, dir.join("monitor.json5"))).await.expect("a monitor connects");
    let hazards = Subscriber::<Hazard>::declare(&monitor, keys.hazard(), false, &health).await.unwrap();
    let intents = Subscriber::<HapticIntent>::declare(&monitor, keys.haptic(), false, &health).await.unwrap();
    let applied = Subscriber::<Applied>::declare(&monitor, keys.applied(), false, &health).await.unwrap();
    let commands = Subscriber::<schemas::Command>::declare(&monitor, keys.cmd_any(), false, &health).await.unwrap();

    // depth -> hazard -> feedback/applied, across the router
    let first = tokio::time::timeout(Duration::from_secs(30), hazards.recv()).await;
    assert!(matches!(first, Ok(Some(_))), "no hazard reached the monitor through the router in 30 s");
    let rumble = tokio::time::timeout(Duration::from_secs(10), async {
        while let Some(a) = applied.recv().await {
            if matches!(a.body.action, AppliedAction::Rumble { .. }) && a.body.cause_capture_ns > 0 {
                return true;
            }
        }
        false
    })
    .await;
    assert_eq!(rumble, Ok(true), "the feedback agent applied no intent of the compute agent's");

    // A monitor's certificate may not make the rumble say anything: its intents stop at
    // the router, while the compute agent's keep coming.
    let rogue = bus::open_session(&options(user, dir.join("monitor.json5"))).await.expect("a second monitor");
    let mut fake =
        Publisher::<HapticIntent>::declare(&rogue, keys.haptic(), "rogue-monitor", Lane::RealTime, None).await.unwrap();
    let clear = HapticIntent { left: 0.0, right: 0.0, pattern: HapticPattern::Steady, ttl_ms: 250 };
    let watching = tokio::spawn(async move { senders(&intents, Duration::from_secs(3)).await });
    for _ in 0..30 {
        fake.put(bus::now_ns(), &clear).await.unwrap();
        tokio::time::sleep(Duration::from_millis(33)).await;
    }
    let seen = watching.await.unwrap();
    assert!(seen.iter().any(|s| s == "compute-agent"), "the compute agent's intents stopped: {seen:?}");
    assert!(!seen.iter().any(|s| s == "rogue-monitor"), "a monitor's intent went through the router");

    // Commands: from a tool, yes; from a monitor, no.
    let tool = bus::open_session(&options(user, dir.join("tool.json5"))).await.expect("a tool connects");
    let mut from_tool =
        Publisher::<schemas::Command>::declare(&tool, keys.cmd("where-am-i"), "tool", Lane::Events, None)
            .await
            .unwrap();
    let mut from_monitor =
        Publisher::<schemas::Command>::declare(&rogue, keys.cmd("where-am-i"), "rogue-monitor", Lane::Events, None)
            .await
            .unwrap();
    let watching = tokio::spawn(async move { senders(&commands, Duration::from_secs(3)).await });
    tokio::time::sleep(Duration::from_millis(500)).await;
    for _ in 0..3 {
        from_tool.put(bus::now_ns(), &schemas::Command::WhereAmI).await.unwrap();
        from_monitor.put(bus::now_ns(), &schemas::Command::WhereAmI).await.unwrap();
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let seen = watching.await.unwrap();
    assert!(seen.iter().any(|s| s == "tool"), "the tool's command did not go through: {seen:?}");
    assert!(!seen.iter().any(|s| s == "rogue-monitor"), "a monitor's command went through: {seen:?}");

    // A stranger with certificates from another authority cannot connect.
    let elsewhere = dir.join("elsewhere");
    certs(&elsewhere, &endpoint);
    let stranger = tokio::time::timeout(
        Duration::from_secs(15),
        bus::open_session(&options(user, elsewhere.join("monitor.json5"))),
    )
    .await;
    assert!(!matches!(stranger, Ok(Ok(_))), "a client of another authority connected to the router");
}
