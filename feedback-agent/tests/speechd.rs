//! The speech-dispatcher engine against a fake SSIP server on a Unix socket (a thread
//! that accepts, records every byte and answers codes), and against the real daemon
//! (`speech-dispatcher` must be installed: without it that test fails under CI and skips
//! loudly elsewhere, `host_tools::skip_or_fail`).

mod host_tools;

use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use feedback_agent::device::{SpeakingHandle, SpeechEngine};
use feedback_agent::speechd::{SpeechdConfig, SpeechdEngine};
use schemas::Priority;

const MS: u64 = 1_000_000;

/// A folder for one test's socket and files, removed when the test ends (failed too).
fn scratch_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("wearnav-speechd-{name}-")).tempdir().expect("temp dir is writable")
}

/// What the fake server does besides answering `2xx` to everything.
#[derive(Clone, Default)]
struct Script {
    /// Lines starting with the first string are answered with the second.
    refuse: Vec<(&'static str, &'static str)>,
    /// Lines starting with this are never answered (a hung daemon).
    hang_on: Option<&'static str>,
}

#[derive(Default)]
struct Shared {
    /// Every byte received, per connection.
    received: Vec<Vec<u8>>,
    /// The open connection's writing end, to push events from the test.
    writer: Option<UnixStream>,
}

/// A fake speech-dispatcher: accepts connections one after another, records, answers.
struct FakeSpeechd {
    path: PathBuf,
    shared: Arc<Mutex<Shared>>,
    /// The socket's folder, removed with the server.
    _dir: tempfile::TempDir,
}

impl FakeSpeechd {
    fn start(name: &str, script: Script) -> Self {
        let dir = scratch_dir(name);
        let path = dir.path().join("speechd.sock");
        let listener = UnixListener::bind(&path).expect("bind the fake socket");
        let shared = Arc::new(Mutex::new(Shared::default()));
        let s = shared.clone();
        std::thread::spawn(move || {
            for stream in listener.incoming() {
                let Ok(stream) = stream else { return };
                serve(stream, &s, &script);
            }
        });
        Self { path, shared, _dir: dir }
    }

    fn config(&self) -> SpeechdConfig {
        SpeechdConfig { socket: self.path.clone(), user: "alice".into(), ..SpeechdConfig::default() }
    }

    /// Bytes received on connection `k`, as text.
    fn received(&self, k: usize) -> String {
        let s = self.shared.lock().unwrap();
        String::from_utf8_lossy(s.received.get(k).map(Vec::as_slice).unwrap_or(&[])).into_owned()
    }

    fn connections(&self) -> usize {
        self.shared.lock().unwrap().received.len()
    }

    /// Send raw bytes (events) on the open connection.
    fn push(&self, bytes: &str) {
        let mut s = self.shared.lock().unwrap();
        s.writer.as_mut().expect("a connection").write_all(bytes.as_bytes()).expect("write event");
    }

    /// Close the open connection, as a daemon that exits does.
    fn hang_up(&self) {
        let mut s = self.shared.lock().unwrap();
        if let Some(w) = s.writer.take() {
            let _ = w.shutdown(std::net::Shutdown::Both);
        }
    }
}

fn serve(stream: UnixStream, shared: &Arc<Mutex<Shared>>, script: &Script) {
    let Ok(writer) = stream.try_clone() else { return };
    let k = {
        let mut s = shared.lock().unwrap();
        s.received.push(Vec::new());
        s.writer = Some(writer);
        s.received.len() - 1
    };
    let mut reader = BufReader::new(stream);
    let mut in_data = false;
    let mut next_id = 1;
    loop {
        let mut line = Vec::new();
        match reader.read_until(b'\n', &mut line) {
            Ok(0) | Err(_) => return,
            Ok(_) => {}
        }
        let mut s = shared.lock().unwrap();
        s.received[k].extend_from_slice(&line);
        let text = String::from_utf8_lossy(&line).trim_end().to_string();
        let answer = if in_data {
            if text == "." {
                in_data = false;
                next_id += 1;
                format!("225-{}\r\n225 OK MESSAGE QUEUED\r\n", next_id - 1)
            } else {
                continue;
            }
        } else if script.hang_on.is_some_and(|prefix| text.starts_with(prefix)) {
            continue;
        } else if let Some((_, reply)) = script.refuse.iter().find(|(prefix, _)| text.starts_with(prefix)) {
            format!("{reply}\r\n")
        } else if text == "SPEAK" {
            in_data = true;
            "230 OK RECEIVING DATA\r\n".into()
        } else if text == "CANCEL SELF" {
            format!("213 OK CANCELED\r\n703-{}\r\n703-1\r\n703 CANCELED\r\n", next_id - 1)
        } else if text == "QUIT" {
            "231 HAPPY HACKING\r\n".into()
        } else if text.starts_with("SET SELF PRIORITY") {
            "202 OK PRIORITY SET\r\n".into()
        } else if text.starts_with("SET SELF") {
            "200 OK SET\r\n".into()
        } else {
            "500 ERR UNKNOWN COMMAND\r\n".into()
        };
        let Some(w) = s.writer.as_mut() else { return };
        if w.write_all(answer.as_bytes()).is_err() {
            return;
        }
    }
}

fn wait_finished(h: &mut Box<dyn SpeakingHandle>, within: Duration) -> Duration {
    let t = Instant::now();
    while !h.is_finished(0) {
        assert!(t.elapsed() < within, "utterance did not finish within {within:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
    t.elapsed()
}

const SETUP: &str = "SET SELF CLIENT_NAME alice:wearnav:feedback-agent\r\n\
                     SET SELF NOTIFICATION END on\r\n\
                     SET SELF NOTIFICATION CANCEL on\r\n\
                     SET SELF RATE 2\r\n\
                     SET SELF VOLUME 100\r\n\
                     SET SELF LANGUAGE en\r\n";

#[test]
fn speechd_engine_speaks_ssip_byte_for_byte() {
    let server = FakeSpeechd::start("bytes", Script::default());
    let mut engine = SpeechdEngine::new(server.config()).expect("fake daemon answers");
    assert!(engine.describe().contains("end notifications on"), "{}", engine.describe());
    assert_eq!(server.received(0), SETUP);

    let mut warning = engine.start("stop, wall ahead\n.dot line", Priority::Important, 0).expect("spoken");
    let mut again = engine.start("stop", Priority::Important, 0).expect("spoken");
    let _turn = engine.start("turn left", Priority::Message, 0).expect("spoken");
    assert_eq!(
        &server.received(0)[SETUP.len()..],
        "SET SELF PRIORITY important\r\nSPEAK\r\nstop, wall ahead\r\n..dot line\r\n.\r\n\
         SPEAK\r\nstop\r\n.\r\n\
         SET SELF PRIORITY message\r\nSPEAK\r\nturn left\r\n.\r\n",
        "priority set only when it changes; a leading dot doubled"
    );

    // Speaking until the daemon says END (message ids 1, 2, 3 in order).
    assert!(!warning.is_finished(0));
    server.push("702-1\r\n702-1\r\n702 END\r\n");
    wait_finished(&mut warning, Duration::from_secs(2));
    assert!(!again.is_finished(0), "only message 1 ended");

    // Cutting off is CANCEL SELF.
    again.cut();
    assert!(again.is_finished(0));
    assert!(server.received(0).ends_with("SPEAK\r\nturn left\r\n.\r\nCANCEL SELF\r\n"));
    assert_eq!(engine.counters().errors(), 0);
    drop(engine);
    std::thread::sleep(Duration::from_millis(50));
    assert!(server.received(0).ends_with("CANCEL SELF\r\nQUIT\r\n"), "a polite goodbye");
}

#[test]
fn error_replies_are_counted_and_reported_clearly() {
    let script = Script {
        refuse: vec![("SET SELF RATE", "409 ERR RATE TOO HIGH"), ("SPEAK", "401 ERR NOT ALLOWED")],
        ..Script::default()
    };
    let server = FakeSpeechd::start("errors", script);
    let mut engine = SpeechdEngine::new(server.config()).expect("a refused setting does not prevent speaking");
    let counters = engine.counters();
    assert_eq!(counters.errors(), 1, "the refused RATE");
    let err = engine.start("turn left", Priority::Message, 0).err().expect("SPEAK is refused");
    let text = err.to_string();
    assert!(text.contains("SPEAK refused: 401 ERR NOT ALLOWED"), "{text}");
    assert_eq!(counters.errors(), 2);
    assert_eq!(counters.losses(), 0, "an error reply keeps the connection");
}

#[test]
fn daemon_gone_is_noticed_and_the_next_utterance_reconnects() {
    let server = FakeSpeechd::start("reconnect", Script::default());
    let mut engine = SpeechdEngine::new(server.config()).expect("fake daemon answers");
    let counters = engine.counters();
    let mut h = engine.start("in ten metres turn left", Priority::Message, 0).expect("spoken");
    server.hang_up();
    wait_finished(&mut h, Duration::from_secs(2));
    assert_eq!(counters.losses(), 1, "noticed while idle");
    // The next utterance opens a new connection, set up again from scratch.
    let _h = engine.start("stop", Priority::Important, 10 * MS).expect("spoken after reconnecting");
    assert_eq!(server.connections(), 2);
    assert_eq!(server.received(1), format!("{SETUP}SET SELF PRIORITY important\r\nSPEAK\r\nstop\r\n.\r\n"));
    assert_eq!(counters.connects(), 2);
}

#[test]
fn a_hung_daemon_stalls_one_utterance_by_the_reply_timeout_only() {
    let server = FakeSpeechd::start("hung", Script { hang_on: Some("SPEAK"), ..Script::default() });
    let config = SpeechdConfig { reply_timeout_ms: 100, reconnect_ms: 1000, ..server.config() };
    let mut engine = SpeechdEngine::new(config).expect("set-up is answered");
    let t = Instant::now();
    let err = engine.start("stop", Priority::Important, 0).err().expect("no answer to SPEAK");
    let stalled = t.elapsed();
    assert!(err.to_string().contains("no reply within 100 ms"), "{err}");
    assert!(stalled < Duration::from_millis(180), "one timeout, no retry: stalled {stalled:?}");
    // Within the reconnect period the engine does not even try.
    let t = Instant::now();
    let err = engine.start("stop", Priority::Important, 500 * MS).err().expect("still waiting to reconnect");
    assert!(t.elapsed() < Duration::from_millis(20), "{err}");
    assert!(err.to_string().contains("not connected; retrying every 1000 ms"), "{err}");
    assert_eq!(engine.counters().losses(), 1);
}

#[test]
fn a_stale_connection_is_retried_once_on_a_new_one() {
    let server = FakeSpeechd::start("stale", Script::default());
    let mut engine = SpeechdEngine::new(server.config()).expect("fake daemon answers");
    // The daemon restarts between two utterances: the engine only finds out on writing.
    server.hang_up();
    std::thread::sleep(Duration::from_millis(20));
    let _h = engine.start("stop", Priority::Important, 0).expect("spoken on the new connection");
    assert_eq!(server.connections(), 2);
    assert!(server.received(1).ends_with("SPEAK\r\nstop\r\n.\r\n"));
    assert_eq!(engine.counters().losses(), 1);
}

#[test]
fn no_daemon_at_start_is_refused_with_what_to_do() {
    let dir = scratch_dir("absent");
    let config = SpeechdConfig { socket: dir.path().join("speechd.sock"), ..SpeechdConfig::default() };
    let err = SpeechdEngine::new(config).err().expect("nothing listens");
    assert!(err.to_string().contains("speech-dispatcher -d"), "{err}");
}

// ---------------------------------------------------------------------------------
// The real daemon.

/// speech-dispatcher in single mode on a private socket, with the espeak-ng module and
/// ALSA's null PCM as the sound card (the container has none), so it runs headless.
struct RealDaemon {
    child: Child,
    socket: PathBuf,
}

/// speech-dispatcher is installed; if not, fails under CI or says the test is skipped.
fn speechd_installed() -> bool {
    let ok = host_tools::runs("speech-dispatcher", "--version");
    if !ok {
        host_tools::skip_or_fail(
            "needs speech-dispatcher (apt-get install -y speech-dispatcher speech-dispatcher-espeak-ng)",
        );
    }
    ok
}

impl RealDaemon {
    fn start(dir: &Path) -> Self {
        let conf = dir.join("conf");
        std::fs::create_dir_all(conf.join("modules")).unwrap();
        std::fs::write(
            conf.join("speechd.conf"),
            "LogLevel 1\nDefaultVolume 100\nAddModule \"espeak-ng\" \"sd_espeak-ng\" \"espeak-ng.conf\"\n\
             DefaultModule espeak-ng\nAudioOutputMethod \"alsa\"\n",
        )
        .unwrap();
        std::fs::write(conf.join("modules").join("espeak-ng.conf"), "").unwrap();
        let home = dir.join("home");
        std::fs::create_dir_all(&home).unwrap();
        std::fs::write(home.join(".asoundrc"), "pcm.!default { type null }\n").unwrap();
        // Without a runtime folder libpulse (loaded by the output module) makes one of its
        // own in /tmp and leaves it there; this one goes with the test's folder.
        let runtime = dir.join("run");
        std::fs::create_dir_all(&runtime).unwrap();
        let socket = dir.join("speechd.sock");
        let _ = std::fs::remove_file(&socket);
        let child = Command::new("speech-dispatcher")
            .args(["-s", "-t", "30", "-l", "1", "-c", "unix_socket"])
            .arg("-S")
            .arg(&socket)
            .arg("-C")
            .arg(&conf)
            .arg("-P")
            .arg(dir.join("speechd.pid"))
            .arg("-L")
            .arg(dir)
            .env("HOME", &home)
            .env("XDG_RUNTIME_DIR", &runtime)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("speech-dispatcher starts");
        let t = Instant::now();
        while UnixStream::connect(&socket).is_err() {
            assert!(t.elapsed() < Duration::from_secs(10), "speech-dispatcher did not open {}", socket.display());
            std::thread::sleep(Duration::from_millis(20));
        }
        Self { child, socket }
    }

    fn stop(&mut self) {
        if !matches!(self.child.try_wait(), Ok(None)) {
            return;
        }
        // SIGTERM lets it stop its output module; then reap it.
        terminate(self.child.id());
        let t = Instant::now();
        while matches!(self.child.try_wait(), Ok(None)) && t.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// SIGTERM through the `kill` program (no unsafe needed in a test).
fn terminate(pid: u32) {
    let _ = Command::new("kill").arg("-TERM").arg(pid.to_string()).status();
}

impl Drop for RealDaemon {
    fn drop(&mut self) {
        self.stop();
    }
}

#[test]
fn real_speech_dispatcher_speaks_cuts_and_comes_back() {
    if !speechd_installed() {
        return;
    }
    // Made first, so it is removed last: after both daemons writing into it have stopped.
    let dir = scratch_dir("real");
    let mut daemon = RealDaemon::start(dir.path());
    let config = SpeechdConfig { socket: daemon.socket.clone(), user: "test".into(), ..SpeechdConfig::default() };
    let mut engine = SpeechdEngine::new(config).expect("the real daemon answers");
    let counters = engine.counters();
    assert!(engine.describe().contains("end notifications on"), "{}", engine.describe());

    // A short utterance plays to its END event.
    let mut h = engine.start("turn left at the lift", Priority::Message, 0).expect("queued");
    let took = wait_finished(&mut h, Duration::from_secs(10));
    eprintln!("real speech-dispatcher: short utterance ended after {took:?} (ALSA null output)");

    // Interrupt: a long guidance text cut for a warning, timed over CANCEL + SPEAK.
    let long =
        "In twelve metres, turn left at the lift, then walk straight along the corridor to room one hundred and four. "
            .repeat(8);
    let mut rounds = Vec::new();
    for _ in 0..10 {
        let mut guidance = engine.start(&long, Priority::Message, 0).expect("queued");
        std::thread::sleep(Duration::from_millis(30));
        let t = Instant::now();
        guidance.cut();
        let mut warning = engine.start("stop, wall ahead", Priority::Important, 0).expect("queued");
        rounds.push(t.elapsed().as_secs_f64() * 1e3);
        assert!(guidance.is_finished(0));
        wait_finished(&mut warning, Duration::from_secs(10));
    }
    rounds.sort_by(f64::total_cmp);
    let (median, max) = (rounds[rounds.len() / 2], rounds[rounds.len() - 1]);
    eprintln!(
        "real speech-dispatcher, 10 rounds: CANCEL SELF + SPEAK queued in {median:.2} ms median, {max:.2} ms max"
    );
    assert!(max < 100.0, "interrupt round trips took {rounds:?} ms");
    assert_eq!(counters.errors(), 0, "the daemon accepted every command");

    // The daemon goes away: the next utterance fails clearly; once it is back, speech resumes.
    daemon.stop();
    let err = engine.start("stop", Priority::Important, 0).err().expect("no daemon");
    eprintln!("with the daemon gone: {err}");
    assert_eq!(counters.losses(), 1);
    let _daemon = RealDaemon::start(dir.path());
    let mut h = engine.start("obstacle detection back", Priority::Important, 2_000 * MS).expect("reconnected");
    wait_finished(&mut h, Duration::from_secs(10));
    assert_eq!(counters.connects(), 2);
}
