//! `wearnav up` with the real agents on loopback: it starts a host's agents from a
//! placement manifest, restarts the compute agent after a `kill -9` (hazards flowing
//! again within 3 s), and stops every agent on SIGTERM.

use std::io::{BufRead, BufReader};
use std::net::{Ipv4Addr, TcpListener};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use bus::{BusOptions, Health, Subscriber};
use schemas::Hazard;

/// `wearnav up`, stopped with SIGTERM when dropped so that a failing test leaves no
/// agent behind (up stops its agents on SIGTERM), killed if it does not exit.
struct Up(std::process::Child);

impl Drop for Up {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            // SAFETY: kill(2) on our own child.
            unsafe { libc::kill(self.0.id() as i32, libc::SIGTERM) };
            let deadline = Instant::now() + Duration::from_secs(8);
            while matches!(self.0.try_wait(), Ok(None)) && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

fn free_port() -> u16 {
    TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).unwrap().local_addr().unwrap().port()
}

fn alive(pid: i32) -> bool {
    // SAFETY: signal 0 only asks whether the process exists.
    unsafe { libc::kill(pid, 0) == 0 }
}

/// The pid in an `[up] NAME: started (pid N)` line.
fn started_pid(line: &str, name: &str) -> Option<i32> {
    line.strip_prefix(&format!("[up] {name}: started (pid "))?.strip_suffix(')')?.parse().ok()
}

/// Lines of `up`'s stdout until one satisfies `want`, within `limit`.
fn until(lines: &mpsc::Receiver<String>, limit: Duration, mut want: impl FnMut(&str) -> bool) -> Option<String> {
    let deadline = Instant::now() + limit;
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        match lines.recv_timeout(left) {
            Ok(l) if want(&l) => return Some(l),
            Ok(_) => continue,
            Err(_) => return None,
        }
    }
    None
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn up_starts_a_hosts_agents_restarts_a_killed_one_and_stops_them_all() {
    let user = "up-test";
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let dir = tempfile::Builder::new().prefix("wearnav-up-").tempdir().unwrap();
    let manifest = dir.path().join("site.toml");
    std::fs::write(
        &manifest,
        format!(
            r#"
user = "{user}"
[[hosts.backpack.agent]]
name = "sensor"
program = "sensor-agent"
args = ["--source", "sim:approach", "--listen", "{endpoint}", "--no-multicast"]
[[hosts.backpack.agent]]
name = "compute"
program = "compute-agent"
args = ["--connect", "{endpoint}", "--no-multicast"]
[[hosts.backpack.agent]]
name = "feedback"
program = "feedback-agent"
args = ["--connect", "{endpoint}", "--no-multicast", "--haptic", "console", "--speech", "console"]
[[hosts.phone.agent]]
name = "bridge"
program = "phone-bridge"
"#
        ),
    )
    .unwrap();
    let mut up = Up(Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(["up", "--manifest"])
        .arg(&manifest)
        .args(["--host", "backpack"])
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("wearnav up starts"));
    let (tx, lines) = mpsc::channel();
    let out = up.0.stdout.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    // the three start side by side: their lines come in any order
    let mut pids = std::collections::BTreeMap::new();
    until(&lines, Duration::from_secs(10), |l| {
        for name in ["sensor", "compute", "feedback"] {
            if let Some(pid) = started_pid(l, name) {
                pids.insert(name, pid);
            }
        }
        pids.len() == 3
    });
    assert_eq!(pids.len(), 3, "up started only {pids:?}");

    let options = BusOptions { connect: vec![endpoint.clone()], no_multicast: true, ..BusOptions::for_user(user) };
    let session = bus::open_session(&options).await.unwrap();
    let keys = options.keys().unwrap();
    let health = Health::new("up-test");
    let hazards = Subscriber::<Hazard>::declare(&session, keys.hazard(), false, &health).await.unwrap();
    let first = tokio::time::timeout(Duration::from_secs(30), hazards.recv()).await;
    let Ok(Some(first)) = first else { panic!("no hazard from the agents up started") };

    // kill -9 the compute agent: up restarts it and the hazards come back within 3 s
    let compute = pids["compute"];
    // SAFETY: kill(2) on a child of the process under test.
    unsafe { libc::kill(compute, libc::SIGKILL) };
    let killed_at = Instant::now();
    let said = until(&lines, Duration::from_secs(5), |l| l.starts_with("[up] compute: killed by signal 9"));
    assert!(said.as_deref().is_some_and(|l| l.contains("restarting in 0.5 s")), "up said: {said:?}");
    let again = until(&lines, Duration::from_secs(5), |l| started_pid(l, "compute").is_some())
        .expect("up restarted the compute agent");
    assert_ne!(started_pid(&again, "compute"), Some(compute));
    // the new agent's hazards: another publisher session than the killed one's
    let back = tokio::time::timeout(Duration::from_secs(5), async {
        while let Some(h) = hazards.recv().await {
            if h.header.session != first.header.session {
                return true;
            }
        }
        false
    })
    .await;
    let back_after = killed_at.elapsed();
    assert_eq!(back, Ok(true), "no hazard from the restarted compute agent");
    println!("hazards back {:.2} s after kill -9", back_after.as_secs_f64());
    assert!(back_after < Duration::from_secs(3), "hazards back only {back_after:?} after kill -9");

    // SIGTERM: every agent stopped, up exits
    let compute = started_pid(&again, "compute").unwrap();
    // SAFETY: kill(2) on our own child.
    unsafe { libc::kill(up.0.id() as i32, libc::SIGTERM) };
    let deadline = Instant::now() + Duration::from_secs(10);
    let status = loop {
        if let Some(s) = up.0.try_wait().unwrap() {
            break Some(s);
        }
        if Instant::now() > deadline {
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(status.is_some_and(|s| s.success()), "up did not exit cleanly on SIGTERM: {status:?}");
    for (name, pid) in [("sensor", pids["sensor"]), ("compute", compute), ("feedback", pids["feedback"])] {
        assert!(!alive(pid), "{name} (pid {pid}) still running after up stopped");
    }
}
