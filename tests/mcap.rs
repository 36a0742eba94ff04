//! `wearnav record`, `inspect` and `replay` as a user runs them: the real binary
//! recording a running `wearnav demo` over loopback, the file summarised, replayed into
//! a second recorder, and damaged files refused.

use std::collections::BTreeMap;
use std::io::Read;
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant};

/// A process killed when dropped, so a failing test leaves nothing behind.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start(args: &[&str]) -> Proc {
    // the demo's status lines are not read: they must not fill a pipe
    let stderr = if args[0] == "demo" { Stdio::null() } else { Stdio::piped() };
    let child = Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(args)
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .expect("wearnav starts");
    Proc(child)
}

/// Wait for the process to end by itself: its exit status and stderr.
fn finish(mut proc: Proc, limit: Duration) -> (ExitStatus, String) {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(status) = proc.0.try_wait().expect("wait") {
            let mut err = String::new();
            if let Some(mut pipe) = proc.0.stderr.take() {
                pipe.read_to_string(&mut err).expect("stderr");
            }
            return (status, err);
        }
        assert!(Instant::now() < deadline, "process did not end within {limit:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn wearnav(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(args)
        .env("RUST_LOG", "warn")
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("wearnav runs")
}

fn free_port() -> u16 {
    TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).unwrap().local_addr().unwrap().port()
}

fn wait_listening(port: u16, limit: Duration) {
    let deadline = Instant::now() + limit;
    while TcpStream::connect((Ipv4Addr::LOCALHOST, port)).is_err() {
        assert!(Instant::now() < deadline, "nothing listens on port {port} after {limit:?}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// A folder for one test's recordings, removed when the test ends (failed too). Each
/// test makes it first, so it is removed last: after every process writing into it is
/// killed (locals drop in reverse order).
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("wearnav-mcap-").tempdir().unwrap()
}

/// (sequence, log_time, payload) of every message, per key, in file order.
type PerKey = BTreeMap<String, Vec<(u32, u64, Vec<u8>)>>;

fn messages(path: &Path) -> PerKey {
    let bytes = std::fs::read(path).unwrap();
    let mut per_key = PerKey::new();
    for m in mcap::MessageStream::new(&bytes).expect("a complete MCAP") {
        let m = m.expect("a readable message");
        per_key.entry(m.channel.topic.clone()).or_default().push((m.sequence, m.log_time, m.data.into_owned()));
    }
    per_key
}

fn inspect_json(path: &Path) -> serde_json::Value {
    let out = wearnav(&["inspect", path.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "inspect failed: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("inspect --json prints JSON")
}

fn channel<'a>(summary: &'a serde_json::Value, suffix: &str) -> &'a serde_json::Value {
    summary["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["key"].as_str().unwrap().ends_with(suffix))
        .unwrap_or_else(|| panic!("no channel on */{suffix} in {summary:#}"))
}

fn sigterm(proc: &Proc) {
    let status = Command::new("kill").args(["-TERM", &proc.0.id().to_string()]).status().expect("kill runs");
    assert!(status.success());
}

/// Records 5 s of a demo, checks the summary, replays the file into a second recorder
/// (stopped by SIGTERM, as Ctrl-C would) and compares the two files message by message.
#[test]
fn a_recorded_demo_is_summarised_and_replays_the_same_messages_with_the_same_timing() {
    let dir = scratch();
    let demo_port = free_port();
    let demo_endpoint = format!("tcp/127.0.0.1:{demo_port}");
    let demo = start(&["demo", "--duration", "10s", "--user", "rec", "--listen", &demo_endpoint]);
    wait_listening(demo_port, Duration::from_secs(20));
    std::thread::sleep(Duration::from_secs(1));
    let first = dir.path().join("first.mcap");
    let recorder = start(&[
        "record",
        "--user",
        "rec",
        "--connect",
        &demo_endpoint,
        "--no-multicast",
        "--duration",
        "5s",
        "--out",
        first.to_str().unwrap(),
    ]);
    let (status, progress) = finish(recorder, Duration::from_secs(30));
    assert!(status.success(), "record failed: {progress}");
    assert!(progress.contains("msgs/s"), "no progress line: {progress}");
    drop(demo);

    let summary = inspect_json(&first);
    assert!(summary["damage"].is_null(), "{}", summary["damage"]);
    let hazard = channel(&summary, "perception/hazard");
    assert_eq!(hazard["schema"], "wearnav/hazard/v5");
    let rate = hazard["rate_hz"].as_f64().unwrap();
    let expected = 30.0 * hazard["duration_s"].as_f64().unwrap();
    let count = hazard["count"].as_f64().unwrap();
    assert!(hazard["duration_s"].as_f64().unwrap() > 4.0, "{hazard}");
    assert!((count - expected).abs() <= 0.2 * expected, "{count} hazards, {rate:.1}/s: {hazard}");
    let depth = channel(&summary, "/depth");
    assert_eq!(depth["schema"], "wearnav/depth_frame/v2");
    assert!(depth["count"].as_u64().unwrap() > 100, "{depth}");
    for c in summary["channels"].as_array().unwrap() {
        assert_eq!(c["sequence_breaks"], 0, "{c}");
        assert!(c["bytes"].as_u64().unwrap() > 0, "{c}");
        assert_ne!(c["schema"], "unknown", "{c}");
    }

    // replay into a second recorder listening on a fresh port
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let second = dir.path().join("second.mcap");
    let recorder =
        start(&["record", "--user", "rec", "--listen", &endpoint, "--no-multicast", "--out", second.to_str().unwrap()]);
    wait_listening(port, Duration::from_secs(20));
    let out = wearnav(&["replay", first.to_str().unwrap(), "--connect", &endpoint, "--no-multicast"]);
    assert!(out.status.success(), "replay failed: {}", String::from_utf8_lossy(&out.stderr));
    std::thread::sleep(Duration::from_millis(500));
    sigterm(&recorder);
    let (status, err) = finish(recorder, Duration::from_secs(20));
    assert!(status.success(), "record after SIGTERM failed: {err}");

    let (original, replayed) = (messages(&first), messages(&second));
    assert_eq!(original.keys().collect::<Vec<_>>(), replayed.keys().collect::<Vec<_>>());
    let mut errors_ms = Vec::new();
    for (key, a) in &original {
        let b = &replayed[key];
        assert_eq!(a.len(), b.len(), "{key}: {} messages recorded, {} after replay", a.len(), b.len());
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert_eq!((x.0, &x.2), (y.0, &y.2), "{key}: message {i} differs");
        }
        for (x, y) in a.windows(2).zip(b.windows(2)) {
            let gap_a = x[1].1 as f64 - x[0].1 as f64;
            let gap_b = y[1].1 as f64 - y[0].1 as f64;
            errors_ms.push((gap_b - gap_a).abs() / 1e6);
        }
    }
    // Both files stamp arrival, so the error holds the jitter of two recordings and the
    // replay's sleeps. On an idle machine every gap was within 5 ms (p99 2.1, max 3.2);
    // with the other suites running on the same 2 cores, p99 reached 7 ms and one gap
    // 17 ms. The VM's own jitter varies too: alone on it, minutes apart, p95 was 4.45 ms
    // once and 1.3-1.6 ms (p50 0.44-0.46) three times, and in two CI runs 5.9 and 6.5 ms.
    // The median says whether the schedule is kept, p95 and the maximum how far the
    // machine let it slip: a replay 10 % fast (`--rate 1.1`) gave p50 3.77 ms, p95 19.3.
    errors_ms.sort_by(f64::total_cmp);
    let quantile = |q: usize| errors_ms[(errors_ms.len() * q) / 100];
    let (p50, p95, p99, max) = (quantile(50), quantile(95), quantile(99), errors_ms[errors_ms.len() - 1]);
    let report = format!("p50 {p50:.2} ms, p95 {p95:.2} ms, p99 {p99:.2} ms, max {max:.2} ms");
    eprintln!("replay timing error over {} gaps: {report}", errors_ms.len());
    assert!(p50 <= 2.0 && p95 <= 10.0, "inter-message gaps changed: {report}");
    assert!(max <= 100.0, "an inter-message gap changed by {max:.2} ms");
}

#[test]
fn inspect_refuses_a_file_that_is_not_mcap() {
    let dir = scratch();
    let path = dir.path().join("not.mcap");
    std::fs::write(&path, b"this is not an MCAP file at all").unwrap();
    let out = wearnav(&["inspect", path.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("not an MCAP file"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// A recording cut short (as by a crash or a full disk) and one with damaged bytes:
/// inspect says so and exits non-zero, never panics; replay plays what precedes the
/// cut, and `--loop` replays it again and again. A recorder whose disk fills says so and
/// exits non-zero, and what it wrote before reads back; one that rotates files by size
/// leaves every file complete.
#[test]
fn inspect_reports_damaged_recordings_a_full_disk_fails_and_rotated_files_are_complete() {
    let dir = scratch();
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let demo = start(&["demo", "--duration", "16s", "--user", "cut", "--listen", &endpoint]);
    wait_listening(port, Duration::from_secs(20));
    let path = dir.path().join("whole.mcap");
    let out = wearnav(&[
        "record",
        "--user",
        "cut",
        "--connect",
        &endpoint,
        "--no-multicast",
        "--duration",
        "4s",
        "--out",
        path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "record failed: {}", String::from_utf8_lossy(&out.stderr));
    // a disk that fills: a 3 MB tmpfs in a mount namespace of its own (unshare maps us
    // to root in a user namespace, so no privilege is needed), about 1.5 s of the demo.
    // The recorder says so and exits non-zero; the chunks it wrote before read back.
    let full = dir.path().join("full");
    std::fs::create_dir_all(&full).unwrap();
    let kept = dir.path().join("kept-from-full-disk.mcap");
    let script = r#"mount -t tmpfs -o size=3m tmpfs "$1" || exit 99
"$2" record --user cut --connect "$3" --no-multicast --duration 8s --out "$1/walk.mcap"
code=$?; cp "$1/walk.mcap" "$4"; exit $code"#;
    let out = Command::new("unshare")
        .args(["--user", "--map-root-user", "--mount", "sh", "-c", script, "sh"])
        .args([full.as_os_str(), Path::new(env!("CARGO_BIN_EXE_wearnav")).as_os_str()])
        .args([std::ffi::OsStr::new(&endpoint), kept.as_os_str()])
        .env("RUST_LOG", "warn")
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("unshare (util-linux) runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(99), "cannot mount a tmpfs in a user namespace here: {err}");
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("No space left on device"), "{err}");
    let out = wearnav(&["inspect", kept.to_str().unwrap()]);
    let (table, why) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(1), "{why}");
    assert!(why.contains("damaged after message") || why.contains("truncated"), "{why}");
    let count: u64 = table
        .lines()
        .next()
        .and_then(|l| l.split(": ").nth(1)?.split(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no message count in {table}"));
    // 3 MB at about 2 MB and 260 messages a second, less the chunk being written
    assert!(count >= 200, "{count} messages read back from the full disk: {table}");
    assert!(table.contains("perception/hazard"), "{table}");
    // rotation by size: numbered files, each complete, nothing lost between them
    let split = dir.path().join("split.mcap");
    let out = wearnav(&[
        "record",
        "--user",
        "cut",
        "--connect",
        &endpoint,
        "--no-multicast",
        "--duration",
        "3s",
        "--split-size-mb",
        "2",
        "--out",
        split.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let recorded: u64 = err
        .lines()
        .find_map(|l| l.strip_prefix("recorded ")?.split(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no total in {err}"));
    let mut in_files = 0;
    for index in 0.. {
        let file = dir.path().join(format!("split-{index:03}.mcap"));
        if !file.exists() {
            assert!(index >= 3, "{index} files from 3 s at 2 MB/s split every 2 MB: {err}");
            break;
        }
        let summary = inspect_json(&file);
        assert!(summary["damage"].is_null(), "{}", summary["damage"]);
        // the JSON and Foxglove twins are the recorder's own, not received messages
        let channels = summary["channels"].as_array().unwrap();
        let twin = |c: &serde_json::Value| {
            c["schema"] == "json" || c["schema"].as_str().is_some_and(|s| s.starts_with("foxglove."))
        };
        in_files += channels.iter().filter(|c| !twin(c)).map(|c| c["count"].as_u64().unwrap()).sum::<u64>();
    }
    assert_eq!(in_files, recorded, "{err}");
    drop(demo);
    let whole = std::fs::read(&path).unwrap();
    assert!(whole.len() > 100_000, "{} bytes recorded", whole.len());

    let truncated = dir.path().join("truncated.mcap");
    std::fs::write(&truncated, &whole[..whole.len() * 2 / 3]).unwrap();
    let out = wearnav(&["inspect", truncated.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("truncated") || err.contains("damaged"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // what precedes the cut is still summarised, and replayed
    assert!(String::from_utf8_lossy(&out.stdout).contains("perception/hazard"), "{err}");
    let out =
        wearnav(&["replay", truncated.to_str().unwrap(), "--rate", "4", "--keys", "perception/*", "--no-multicast"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("replayed what precedes it"), "{err}");
    // --loop goes round until stopped
    let looping = start(&["replay", truncated.to_str().unwrap(), "--rate", "20", "--loop", "--no-multicast"]);
    std::thread::sleep(Duration::from_secs(4));
    sigterm(&looping);
    let (status, err) = finish(looping, Duration::from_secs(10));
    assert!(status.success(), "{err}");
    let rounds: u64 = err
        .lines()
        .find_map(|l| l.split(" messages (").nth(1)?.split(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no round count in {err}"));
    assert!(rounds >= 3, "{rounds} rounds in 2 s at 20 times the speed: {err}");

    let mut corrupted = whole.clone();
    for b in &mut corrupted[whole.len() / 3..whole.len() / 3 + 64] {
        *b ^= 0xA5;
    }
    let damaged = dir.path().join("corrupted.mcap");
    std::fs::write(&damaged, &corrupted).unwrap();
    let out = wearnav(&["inspect", damaged.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

fn agent_bin(name: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_BIN_EXE_wearnav")).with_file_name(name);
    assert!(path.exists(), "{} missing: build the workspace first (cargo build --workspace)", path.display());
    path
}

/// frame_seq -> every hazard in a recording, its latencies (this run's timing) left out.
fn hazards(path: &Path) -> BTreeMap<u64, schemas::Hazard> {
    let per_key = messages(path);
    let (_, list) = per_key.iter().find(|(k, _)| k.ends_with("perception/hazard")).expect("hazards recorded");
    list.iter()
        .map(|(_, _, bytes)| {
            let (_, hazard) = schemas::decode::<schemas::Hazard>(bytes).expect("a valid hazard");
            (hazard.frame_seq, schemas::Hazard { latency: Vec::new(), ..hazard })
        })
        .collect()
}

/// A compute agent listening on a free port: (the process, its endpoint).
fn compute_agent(user: &str) -> (Proc, String) {
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let agent = Proc(
        Command::new(agent_bin("compute-agent"))
            .args(["--user", user, "--listen", &endpoint, "--no-multicast"])
            .env("RUST_LOG", "warn")
            .stdin(Stdio::null())
            .spawn()
            .expect("compute-agent starts"),
    );
    wait_listening(port, Duration::from_secs(20));
    (agent, endpoint)
}

/// Deterministic replay: a walk recorded from the first frame a compute agent saw, its
/// sensors replayed with `--restamp` into a fresh compute agent, gives the same hazard
/// for every frame, field for field (the latencies aside). The recording starts before
/// the sensor does, so the fresh agent starts from the same (empty) state as the
/// original, and `--restamp` moves every stamp by the same amount, inside the IMU and
/// odometry messages too, so it perceives with the same intervals.
#[test]
fn sensors_replayed_into_a_fresh_compute_agent_give_the_same_hazards_as_the_original_run() {
    let dir = scratch();
    let user = "again";
    let (original_agent, endpoint) = compute_agent(user);
    let original = dir.path().join("original.mcap");
    let recorder = start(&[
        "record",
        "--user",
        user,
        "--connect",
        &endpoint,
        "--no-multicast",
        "--out",
        original.to_str().unwrap(),
    ]);
    std::thread::sleep(Duration::from_millis(1500));
    let sensor = Proc(
        Command::new(agent_bin("sensor-agent"))
            .args(["--user", user, "--connect", &endpoint, "--no-multicast", "--source", "sim:approach"])
            .env("RUST_LOG", "warn")
            .stdin(Stdio::null())
            .spawn()
            .expect("sensor-agent starts"),
    );
    std::thread::sleep(Duration::from_secs(6));
    drop(sensor);
    std::thread::sleep(Duration::from_millis(500));
    sigterm(&recorder);
    let (status, recorded_err) = finish(recorder, Duration::from_secs(20));
    assert!(status.success(), "record failed: {recorded_err}");
    drop(original_agent);

    let (_agent, endpoint) = compute_agent(user);
    let rerun = dir.path().join("rerun.mcap");
    let recorder = start(&[
        "record",
        "--user",
        user,
        "--connect",
        &endpoint,
        "--no-multicast",
        "--keys",
        "perception/hazard",
        "--out",
        rerun.to_str().unwrap(),
    ]);
    std::thread::sleep(Duration::from_secs(1));
    let out = wearnav(&[
        "replay",
        original.to_str().unwrap(),
        "--keys",
        "sensor/**",
        "--restamp",
        "--connect",
        &endpoint,
        "--no-multicast",
    ]);
    assert!(out.status.success(), "replay failed: {}", String::from_utf8_lossy(&out.stderr));
    std::thread::sleep(Duration::from_millis(500));
    sigterm(&recorder);
    let (status, err) = finish(recorder, Duration::from_secs(20));
    assert!(status.success(), "record failed: {err}");

    let (before, after) = (hazards(&original), hazards(&rerun));
    let recorded: std::collections::BTreeSet<u64> = messages(&original)
        .iter()
        .filter(|(k, _)| k.ends_with("/depth"))
        .flat_map(|(_, v)| {
            v.iter().map(|(_, _, bytes)| schemas::decode::<schemas::DepthFrame>(bytes).expect("a frame").0.seq)
        })
        .collect();
    assert!(recorded.len() >= 150, "{} frames in 6 s of a 30 Hz camera", recorded.len());
    let unheard: Vec<u64> = recorded.iter().filter(|f| !before.contains_key(f)).copied().collect();
    assert!(unheard.is_empty(), "recorded frames without the original agent's hazard: {unheard:?}");
    // The camera's lane drops a frame rather than queue it: the recorder, a subscriber
    // on another link, can miss one the agent perceived (once in a CI run: 179 hazards,
    // 178 frames recorded). From there the fresh agent, without it, may differ; what
    // comes before must not. More than that is a recorder that loses frames.
    let missed: Vec<u64> = before.keys().filter(|f| !recorded.contains(f)).copied().collect();
    assert!(missed.len() <= 2, "{} of {} frames not recorded: {missed:?}", missed.len(), before.len());
    // the recorder says what it lacks: the numbers missing between its first and last
    let (first, last) = (recorded.first().copied().unwrap_or(0), recorded.last().copied().unwrap_or(0));
    let inside = (last + 1 - first) as usize - recorded.len();
    let report = format!("{inside} on wearnav/{user}/sensor/cane/depth");
    assert_eq!(
        recorded_err.contains(&report),
        inside > 0,
        "{inside} frames lost inside the recording:\n{recorded_err}"
    );
    let compared: Vec<u64> = before.keys().copied().take_while(|f| missed.first().is_none_or(|m| f < m)).collect();
    assert!(compared.len() >= 30, "only {} frames before the first not recorded ({missed:?})", compared.len());
    let differ: Vec<u64> = compared.iter().filter(|f| after.get(f) != before.get(f)).copied().collect();
    eprintln!(
        "{} hazards from {} frames recorded ({} not recorded); {} of the {} compared differ from the original's",
        after.len(),
        recorded.len(),
        missed.len(),
        differ.len(),
        compared.len()
    );
    if let Some(f) = differ.first() {
        panic!("frame {f}: originally {:?}, replayed {:?} ({} frames differ)", before[f], after.get(f), differ.len());
    }
    if missed.is_empty() {
        assert_eq!(after.len(), before.len());
    }
}

/// A file whose publisher skipped three numbers: `inspect` counts them, and a recorder
/// fed that file by `replay` reports them at its end and writes a file that says so.
#[test]
fn messages_lost_on_the_way_are_counted_by_the_recorder_and_by_inspect() {
    let dir = scratch();
    let (user, skipped) = ("lossy", [5u64, 9, 10]);
    let key = format!("wearnav/{user}/feedback/haptic");
    let gappy = dir.path().join("gappy.mcap");
    {
        let mut writer = mcap::Writer::new(std::io::BufWriter::new(std::fs::File::create(&gappy).unwrap())).unwrap();
        let name = schemas::SchemaId::HapticIntent.encoding_schema();
        let schema = writer.add_schema(&name, "", &[]).unwrap();
        let metadata = BTreeMap::from([("zenoh_encoding".to_string(), format!("application/octet-stream;{name}"))]);
        let channel = writer.add_channel(schema, &key, "wearnav-bincode", &metadata).unwrap();
        let origin = schemas::Origin { sender: "lossy-compute", session: 42 };
        let still =
            schemas::HapticIntent { left: 0.0, right: 0.0, pattern: schemas::HapticPattern::Steady, ttl_ms: 300 };
        let t0 = 1_800_000_000_000_000_000u64;
        for seq in (0..20u64).filter(|s| !skipped.contains(s)) {
            let t = t0 + seq * 20_000_000;
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence: seq as u32,
                log_time: t,
                publish_time: t,
            };
            writer.write_to_known_channel(&header, &schemas::encode(&origin, seq, t, &still)).unwrap();
        }
        writer.finish().unwrap();
    }
    assert_eq!(channel(&inspect_json(&gappy), "feedback/haptic")["missed"], 3, "the gaps in the file");
    let table = wearnav(&["inspect", gappy.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&table.stdout);
    assert!(text.lines().next_back().is_some_and(|l| l.ends_with(" 0      3")), "seq! 0, lost 3 in:\n{text}");

    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let out = dir.path().join("heard.mcap");
    let recorder = start(&[
        "record",
        "--user",
        user,
        "--listen",
        &endpoint,
        "--no-multicast",
        "--keys",
        "feedback/**",
        "--out",
        out.to_str().unwrap(),
    ]);
    wait_listening(port, Duration::from_secs(20));
    let played = wearnav(&["replay", gappy.to_str().unwrap(), "--connect", &endpoint, "--no-multicast"]);
    assert!(played.status.success(), "replay failed: {}", String::from_utf8_lossy(&played.stderr));
    std::thread::sleep(Duration::from_millis(300));
    sigterm(&recorder);
    let (status, err) = finish(recorder, Duration::from_secs(20));
    assert!(status.success(), "record failed: {err}");
    assert!(
        err.contains(&format!("not recorded: 3 messages lost on the way to the recorder (gaps in their publishers' numbering): 3 on {key}")),
        "the recorder's report:\n{err}"
    );
    let heard = inspect_json(&out);
    let haptic = channel(&heard, "feedback/haptic");
    assert_eq!((haptic["count"].as_u64(), haptic["missed"].as_u64()), (Some(17), Some(3)), "{haptic:#}");
}
