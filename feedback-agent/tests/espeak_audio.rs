//! Speech tests that listen for real: espeak-ng synthesises to WAV, sox measures it.
//! Without espeak-ng or sox (`apt-get install -y espeak-ng sox`) they fail under CI and
//! skip loudly elsewhere (`host_tools::skip_or_fail`).

mod host_tools;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use feedback_agent::device::SpeechEngine;
use feedback_agent::espeak::{EspeakConfig, EspeakEngine, Playback};
use feedback_agent::feedback::{Feedback, StepSettings};
use schemas::{AppliedAction, Priority, SpeechIntent};

/// espeak-ng and sox are installed; if not, fails under CI or says the test is skipped.
fn tools_present() -> bool {
    let ok = host_tools::runs("espeak-ng", "--version") && host_tools::runs("sox", "--version");
    if !ok {
        host_tools::skip_or_fail("needs espeak-ng and sox (apt-get install -y espeak-ng sox)");
    }
    ok
}

/// A folder for one test's WAVs, removed when the test ends (failed too).
fn scratch_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("wearnav-feedback-{name}-")).tempdir().expect("temp dir is writable")
}

/// (duration s, RMS amplitude) from `sox FILE -n stat`.
fn sox_stat(wav: &Path) -> (f64, f64) {
    let out = Command::new("sox").arg(wav).args(["-n", "stat"]).output().expect("sox runs");
    let text = String::from_utf8_lossy(&out.stderr);
    let field = |name: &str| -> f64 {
        text.lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.rsplit(':').next())
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or_else(|| panic!("no {name:?} in sox output:\n{text}"))
    };
    (field("Length (seconds)"), field("RMS     amplitude"))
}

fn engine(wav_dir: &Path, rate_wpm: u32, playback: Playback) -> EspeakEngine {
    let config = EspeakConfig { rate_wpm, wav_dir: Some(wav_dir.to_path_buf()), ..EspeakConfig::default() };
    EspeakEngine::new(config, playback).expect("espeak-ng available")
}

fn speak_to_end(engine: &mut EspeakEngine, text: &str) {
    let mut h = engine.start(text, Priority::Message, 0).expect("starts");
    let t = Instant::now();
    while !h.is_finished(0) {
        assert!(t.elapsed() < Duration::from_secs(20), "espeak-ng did not finish");
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn with_no_audio_output_and_no_wav_folder_the_last_utterance_is_a_scratch_wav_removed_with_the_engine() {
    if !tools_present() {
        return;
    }
    let mut e = EspeakEngine::new(EspeakConfig::default(), Playback::WavOnly).expect("espeak-ng available");
    let scratch = std::env::temp_dir().join(format!("wearnav-espeak-{}.wav", std::process::id()));
    assert!(e.describe().contains(&scratch.display().to_string()), "{}", e.describe());
    speak_to_end(&mut e, "Passing door two hundred and fourteen, on your left.");
    let (length_s, rms) = sox_stat(&scratch);
    assert!(length_s > 1.0 && rms > 0.01, "{length_s} s, RMS {rms}");
    drop(e);
    assert!(!scratch.exists(), "{} left behind", scratch.display());
}

const GUIDANCE: &str =
    "In twelve metres, turn left at the lift, then walk straight along the corridor to room one hundred and four.";

#[test]
fn utterance_wav_is_speech_with_a_duration_that_fits_text_and_rate() {
    if !tools_present() {
        return;
    }
    let words = GUIDANCE.split_whitespace().count() as f64;
    let mut seconds = Vec::new();
    for rate in [175u32, 350] {
        let dir = scratch_dir(&format!("rate{rate}"));
        let mut e = engine(dir.path(), rate, Playback::WavOnly);
        speak_to_end(&mut e, GUIDANCE);
        let (length_s, rms) = sox_stat(&EspeakEngine::wav_path(dir.path(), 0));
        let expected_s = words / rate as f64 * 60.0;
        eprintln!("rate {rate} wpm: {length_s:.2} s (words/rate = {expected_s:.2} s), RMS {rms:.3}");
        assert!(rms > 0.01, "audio is silence (RMS {rms})");
        assert!(
            length_s > 0.6 * expected_s && length_s < 1.6 * expected_s,
            "{length_s:.2} s does not fit {words} words at {rate} wpm ({expected_s:.2} s)"
        );
        seconds.push(length_s);
    }
    let ratio = seconds[1] / seconds[0];
    assert!((0.35..0.75).contains(&ratio), "doubling the rate should about halve the duration, got x{ratio:.2}");
}

/// Time from `on_speech` of a warning to the warning's first audio bytes leaving
/// espeak-ng (a player stand-in records when 1000 bytes, ~20 ms of audio, arrived).
fn interrupt_once(dir: &Path, round: usize) -> (Duration, Duration) {
    let marker = dir.join(format!("first-audio-{round}"));
    let script = format!("head -c 1000 > {m}.tmp && mv {m}.tmp {m}; cat > /dev/null", m = marker.display());
    let player = Playback::Player(vec!["/bin/sh".into(), "-c".into(), script]);
    let wav = dir.join(format!("round{round}"));
    let e = engine(&wav, 175, player);
    let mut f = Feedback::new(StepSettings::default(), vec![], vec![Box::new(e)], 1);
    let say = |text: &str, priority| SpeechIntent {
        text: text.into(),
        priority,
        interrupt: false,
        ttl_ms: 5000,
        dedup_key: String::new(),
        notice: false,
    };
    let now = bus::now_ns();
    f.on_speech(&say(GUIDANCE, Priority::Message), now, now).expect("accepted");
    std::thread::sleep(Duration::from_millis(300));
    // The guidance's own marker may already exist; the warning's is the next one.
    let _ = std::fs::remove_file(&marker);
    let arrival = Instant::now();
    let now = bus::now_ns();
    f.on_speech(&say("Stop. Obstacle ahead.", Priority::Important), now, now).expect("accepted");
    let started = arrival.elapsed();
    let applied: Vec<_> = f.drain_applied().map(|a| a.action).collect();
    assert!(applied.contains(&AppliedAction::SpeechInterrupted { text: GUIDANCE.into() }), "{applied:?}");
    while !marker.exists() {
        assert!(arrival.elapsed() < Duration::from_secs(5), "no audio from the warning");
        std::thread::sleep(Duration::from_micros(200));
    }
    let audio = arrival.elapsed();
    // Let the warning play out so its WAV is whole.
    let mut finished = false;
    while !finished {
        assert!(arrival.elapsed() < Duration::from_secs(10), "warning never finished");
        std::thread::sleep(Duration::from_millis(20));
        f.tick(bus::now_ns());
        finished = f.drain_applied().any(|a| matches!(a.action, AppliedAction::SpeechFinished { .. }));
    }
    f.shutdown(bus::now_ns());
    (started, audio)
}

#[test]
fn warning_interrupts_guidance_and_its_audio_starts_within_100ms() {
    if !tools_present() {
        return;
    }
    let dir = scratch_dir("interrupt");
    let mut started = Vec::new();
    let mut audio = Vec::new();
    for round in 0..10 {
        let (s, a) = interrupt_once(dir.path(), round);
        started.push(s);
        audio.push(a);
    }
    started.sort();
    audio.sort();
    eprintln!(
        "speech interrupt latency over 10 rounds: process started p50 {:?} max {:?}; first audio bytes p50 {:?} max {:?}",
        started[5], started[9], audio[5], audio[9]
    );
    assert!(started[5] < Duration::from_millis(100), "median {:?}", started[5]);
    assert!(audio[5] < Duration::from_millis(100), "median to first audio {:?}", audio[5]);
    // The cut-off guidance's audio ends short, the warning's is whole and not silent.
    let (warning_s, rms) = sox_stat(&EspeakEngine::wav_path(&dir.path().join("round0"), 1));
    assert!(rms > 0.01 && warning_s > 0.5 && warning_s < 3.0, "warning WAV {warning_s:.2} s RMS {rms:.3}");
}
