//! The built binary refuses a configuration it cannot honestly run: a backend named
//! twice would drive one device twice and report each action twice on
//! `feedback/applied`. It must say so, say what to write instead, and stop before it
//! opens a session.

use std::process::Command;
use std::time::{Duration, Instant};

/// Runs `feedback-agent` with `args`; its exit success and stderr.
fn feedback_agent(args: &[&str]) -> (bool, String) {
    // A Zenoh config that does not exist: an agent that got as far as opening a session
    // would fail on it, with another message.
    let output = Command::new(env!("CARGO_BIN_EXE_feedback-agent"))
        .args(args)
        .args(["--zenoh-config", "/nonexistent/zenoh.json5", "--user", "refusal-test"])
        .env_remove("ZENOH_CONFIG")
        .output()
        .expect("feedback-agent starts");
    (output.status.success(), String::from_utf8_lossy(&output.stderr).into_owned())
}

#[test]
fn a_backend_named_twice_is_refused_before_a_session_opens() {
    let started = Instant::now();
    let (ok, stderr) = feedback_agent(&["--haptic", "phone,console,phone"]);
    assert!(!ok, "must exit non-zero; stderr: {stderr}");
    assert!(stderr.contains("--haptic names phone twice"), "{stderr}");
    assert!(stderr.contains("name each backend once"), "says what to do: {stderr}");
    assert!(!stderr.contains("Zenoh"), "refused before opening a session: {stderr}");
    assert!(started.elapsed() < Duration::from_secs(10), "refused at once");
    let (ok, stderr) = feedback_agent(&["--haptic", "console", "--speech", "espeak,espeak"]);
    assert!(!ok && stderr.contains("--speech names espeak twice"), "{stderr}");
}

#[test]
fn help_offers_the_phone_through_the_bridge() {
    let output =
        Command::new(env!("CARGO_BIN_EXE_feedback-agent")).arg("--help").output().expect("feedback-agent starts");
    let help = String::from_utf8_lossy(&output.stdout);
    assert!(help.contains("evdev") && help.contains("speechd"), "{help}");
    assert!(help.contains("phone"), "{help}");
}
