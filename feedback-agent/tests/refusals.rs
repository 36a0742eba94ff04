//! The built binary refuses the phone backends: nothing forwards their intents to a
//! phone or confirms them, so `feedback/applied` would report what the user never felt
//! or heard. It must say so, name what to use instead, and stop before it opens a
//! session.

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
fn haptic_phone_is_refused_with_the_backends_to_use_instead() {
    let started = Instant::now();
    let (ok, stderr) = feedback_agent(&["--haptic", "phone"]);
    assert!(!ok, "must exit non-zero; stderr: {stderr}");
    assert!(stderr.contains("--haptic phone is not available yet"), "{stderr}");
    assert!(stderr.contains("rumbles nobody felt"), "says what is wrong: {stderr}");
    assert!(stderr.contains("use --haptic console, wiimote or evdev"), "says what to use: {stderr}");
    assert!(!stderr.contains("Zenoh"), "refused before opening a session: {stderr}");
    assert!(started.elapsed() < Duration::from_secs(10), "refused at once");
}

#[test]
fn speech_phone_is_refused_with_the_backends_to_use_instead() {
    let (ok, stderr) = feedback_agent(&["--haptic", "console", "--speech", "console,phone"]);
    assert!(!ok, "must exit non-zero; stderr: {stderr}");
    assert!(stderr.contains("--speech phone is not available yet"), "{stderr}");
    assert!(stderr.contains("speech nobody heard"), "says what is wrong: {stderr}");
    assert!(stderr.contains("use --speech console, espeak or speechd"), "says what to use: {stderr}");
    assert!(!stderr.contains("Zenoh"), "refused before opening a session: {stderr}");
}

#[test]
fn help_does_not_offer_the_phone() {
    let output =
        Command::new(env!("CARGO_BIN_EXE_feedback-agent")).arg("--help").output().expect("feedback-agent starts");
    let help = String::from_utf8_lossy(&output.stdout);
    assert!(help.contains("evdev") && help.contains("speechd"), "{help}");
    assert!(!help.contains("phone"), "{help}");
}
