use super::fake::{Call, FakeFf};
use super::*;
use crate::console::ConsoleSpeech;
use crate::feedback::{Feedback, StepSettings};
use schemas::{GroundState, HapticIntent, Hazard};

const T0: u64 = 1_700_000_000_000_000_000;
const LEFT: &str = "/dev/input/event5";
const RIGHT: &str = "/dev/input/event6";

fn config() -> EvdevConfig {
    EvdevConfig { left: Some(LEFT.into()), right: Some(RIGHT.into()), ..EvdevConfig::default() }
}

fn pair() -> (FakeFf, EvdevBackend, DeviceOutput) {
    let ff = FakeFf::new();
    ff.plug(LEFT);
    ff.plug(RIGHT);
    let mut b = EvdevBackend::new(Box::new(ff.clone()), config());
    let mut out = DeviceOutput::default();
    b.poll(T0, &mut out);
    (ff, b, out)
}

/// The 48 bytes of an FF_RUMBLE effect with `id`, both magnitudes, 2000 ms backstop.
fn rumble_bytes(id: i16, magnitude: u16) -> [u8; 48] {
    let mut b = [0u8; 48];
    b[0..2].copy_from_slice(&0x50u16.to_le_bytes());
    b[2..4].copy_from_slice(&id.to_le_bytes());
    b[10..12].copy_from_slice(&2000u16.to_le_bytes());
    b[16..18].copy_from_slice(&magnitude.to_le_bytes());
    b[18..20].copy_from_slice(&magnitude.to_le_bytes());
    b
}

fn ev_ff(id: u16, value: i32) -> Call {
    let mut b = vec![0u8; 16];
    b.extend_from_slice(&0x15u16.to_le_bytes());
    b.extend_from_slice(&id.to_le_bytes());
    b.extend_from_slice(&value.to_le_bytes());
    Call::Write(b)
}

fn upload(id: i16, magnitude: u16) -> Call {
    Call::Upload { request: 0x4030_4580, effect: rumble_bytes(id, magnitude) }
}

/// A fresh hazard with the floor found: keeps detection online.
fn found() -> Hazard {
    Hazard::nothing_ahead(0, GroundState::Found)
}

fn levels(left: f32, right: f32) -> Levels {
    Levels { left, right }
}

#[test]
fn first_rumble_uploads_an_ff_rumble_effect_then_plays_it() {
    let (ff, mut b, out) = pair();
    assert!(out.say.is_empty(), "a normal start is silent");
    assert!(ff.calls_to(LEFT).is_empty(), "nothing is uploaded before the motor runs");
    let mut out = DeviceOutput::default();
    b.set_levels(levels(1.0, 0.0), HapticPattern::Steady, 42, T0, false, &mut out);
    assert_eq!(ff.calls_to(LEFT), [upload(-1, 0xffff), ev_ff(0, 1)]);
    assert!(ff.calls_to(RIGHT).is_empty());
    let applied: Vec<(&str, u64)> = out.applied.iter().map(|a| (a.device.as_str(), a.cause_capture_ns)).collect();
    assert_eq!(applied, [("evdev-left", 42), ("evdev-right", 42)], "both sides report their first level");
}

#[test]
fn off_stops_and_on_again_replays_without_a_new_upload() {
    let (ff, mut b, mut out) = pair();
    b.set_levels(levels(1.0, 0.0), HapticPattern::Steady, 0, T0, false, &mut out);
    b.set_levels(levels(1.0, 0.0), HapticPattern::Steady, 0, T0, false, &mut out);
    b.set_levels(Levels::OFF, HapticPattern::Steady, 0, T0, false, &mut out);
    b.set_levels(levels(1.0, 0.0), HapticPattern::Steady, 0, T0, false, &mut out);
    assert_eq!(ff.calls_to(LEFT), [upload(-1, 0xffff), ev_ff(0, 1), ev_ff(0, 0), ev_ff(0, 1)]);
}

#[test]
fn a_new_intent_refreshes_the_play_and_a_new_level_updates_the_effect_in_place() {
    let (ff, mut b, mut out) = pair();
    b.set_levels(levels(0.0, 1.0), HapticPattern::Steady, 0, T0, true, &mut out);
    b.set_levels(levels(0.0, 1.0), HapticPattern::Steady, 0, T0, true, &mut out);
    b.set_levels(levels(0.0, 0.5), HapticPattern::Steady, 0, T0, false, &mut out);
    assert_eq!(ff.calls_to(RIGHT), [upload(-1, 0xffff), ev_ff(0, 1), ev_ff(0, 1), upload(0, 0x8000), ev_ff(0, 1)]);
    assert_eq!(ff.calls_to(LEFT), [], "refresh of a motor never started writes nothing");
}

#[test]
fn ttl_expiry_stops_the_motor_through_the_feedback_step() {
    let ff = FakeFf::new();
    ff.plug(LEFT);
    ff.plug(RIGHT);
    let backend = EvdevBackend::new(Box::new(ff.clone()), config());
    let speech = ConsoleSpeech::new(Box::new(std::io::sink()), 175);
    let mut f = Feedback::new(StepSettings::default(), vec![Box::new(backend)], vec![Box::new(speech)], T0);
    f.tick(T0);
    let fresh = |f: &mut Feedback, at: u64| f.on_hazard(&found(), at, at);
    fresh(&mut f, T0);
    f.on_haptic(&HapticIntent { left: 1.0, right: 0.0, pattern: HapticPattern::Steady, ttl_ms: 200 }, T0, T0 + MS)
        .unwrap();
    assert_eq!(ff.calls_to(LEFT).last(), Some(&ev_ff(0, 1)));
    fresh(&mut f, T0 + 199 * MS);
    f.tick(T0 + 199 * MS);
    assert_eq!(ff.calls_to(LEFT).last(), Some(&ev_ff(0, 1)));
    f.tick(T0 + 200 * MS);
    assert_eq!(ff.calls_to(LEFT).last(), Some(&ev_ff(0, 0)), "stopped when the TTL ran out");
}

#[test]
fn pulses_are_timed_by_the_agent_as_on_the_wiimote() {
    let ff = FakeFf::new();
    ff.plug(RIGHT);
    let config = EvdevConfig { right: Some(RIGHT.into()), ..EvdevConfig::default() };
    let backend = EvdevBackend::new(Box::new(ff.clone()), config);
    let mut f = Feedback::new(StepSettings::default(), vec![Box::new(backend)], vec![], T0);
    f.tick(T0);
    let pulses = HapticIntent {
        left: 0.0,
        right: 1.0,
        pattern: HapticPattern::Pulses { period_ms: 200, duty: 0.5 },
        ttl_ms: 1000,
    };
    f.on_hazard(&found(), T0, T0);
    f.on_haptic(&pulses, T0, T0).unwrap();
    let mut at = Vec::new();
    for ms in [50, 100, 150, 200, 300] {
        f.on_hazard(&found(), T0 + ms * MS, T0 + ms * MS);
        f.tick(T0 + ms * MS);
        at.push(ff.calls_to(RIGHT).last().cloned().unwrap());
    }
    assert_eq!(at, [ev_ff(0, 1), ev_ff(0, 0), ev_ff(0, 0), ev_ff(0, 1), ev_ff(0, 0)]);
}

#[test]
fn dropping_the_backend_stops_and_erases_the_effects() {
    let (ff, mut b, mut out) = pair();
    b.set_levels(levels(1.0, 1.0), HapticPattern::Steady, 0, T0, false, &mut out);
    ff.clear_calls();
    drop(b);
    assert_eq!(ff.calls_to(LEFT), [ev_ff(0, 0), Call::Remove { request: 0x4004_4581, id: 0 }]);
    assert_eq!(ff.calls_to(RIGHT), [ev_ff(1, 0), Call::Remove { request: 0x4004_4581, id: 1 }]);
}

#[test]
fn a_panic_while_rumbling_still_stops_the_motor() {
    let ff = FakeFf::new();
    ff.plug(LEFT);
    let probe = ff.clone();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
        let mut b = EvdevBackend::new(Box::new(ff), config());
        let mut out = DeviceOutput::default();
        b.poll(T0, &mut out);
        b.set_levels(levels(1.0, 0.0), HapticPattern::Steady, 0, T0, false, &mut out);
        panic!("simulated bug while rumbling");
    }));
    assert!(result.is_err());
    let calls = probe.calls_to(LEFT);
    assert_eq!(calls[calls.len() - 2..], [ev_ff(0, 0), Call::Remove { request: 0x4004_4581, id: 0 }]);
}

#[test]
fn shutdown_stops_both_motors() {
    let (ff, mut b, mut out) = pair();
    b.set_levels(levels(1.0, 1.0), HapticPattern::Steady, 0, T0, false, &mut out);
    b.off(T0 + MS, &mut out);
    assert_eq!(ff.calls_to(LEFT).last(), Some(&ev_ff(0, 0)));
    assert_eq!(ff.calls_to(RIGHT).last(), Some(&ev_ff(1, 0)));
}

#[test]
fn a_node_lost_mid_write_is_said_and_reopened() {
    let (ff, mut b, mut out) = pair();
    b.set_levels(levels(1.0, 1.0), HapticPattern::Steady, 0, T0, false, &mut out);
    ff.unplug(LEFT);
    b.set_levels(Levels::OFF, HapticPattern::Steady, 0, T0 + MS, false, &mut out);
    assert!(!b.is_open(true));
    assert_eq!(out.said(), ["left controller disconnected"]);
    assert_eq!(b.next_poll_ns(), Some(T0 + MS + 2_000 * MS));
    b.poll(T0 + 2_001 * MS, &mut out);
    assert_eq!(out.said().len(), 1, "still gone: not said again");
    ff.plug(LEFT);
    ff.clear_calls();
    b.poll(T0 + 4_001 * MS, &mut out);
    assert!(b.is_open(true));
    assert_eq!(out.said().last().copied(), Some("left controller connected"));
    b.set_levels(levels(1.0, 0.0), HapticPattern::Steady, 0, T0 + 4_002 * MS, false, &mut out);
    assert_eq!(ff.calls_to(LEFT), [upload(-1, 0xffff), ev_ff(2, 1)], "a new effect on the new file");
}

#[test]
fn a_missing_node_is_said_once_and_only_configured_sides_are_looked_for() {
    let ff = FakeFf::new();
    let config = EvdevConfig { left: Some(LEFT.into()), ..EvdevConfig::default() };
    let mut b = EvdevBackend::new(Box::new(ff.clone()), config);
    let mut out = DeviceOutput::default();
    b.poll(T0, &mut out);
    b.poll(T0 + 2_000 * MS, &mut out);
    assert_eq!(out.said(), ["left controller not found"]);
    ff.plug(LEFT);
    b.poll(T0 + 4_000 * MS, &mut out);
    assert!(b.is_open(true));
    assert_eq!(b.next_poll_ns(), None, "nothing left to look for");
}

#[test]
fn a_node_without_force_feedback_is_said_once_and_left_alone() {
    let ff = FakeFf::new();
    ff.plug_without_ff(LEFT);
    ff.plug(RIGHT);
    let mut b = EvdevBackend::new(Box::new(ff.clone()), config());
    let mut out = DeviceOutput::default();
    b.poll(T0, &mut out);
    b.set_levels(levels(1.0, 1.0), HapticPattern::Steady, 0, T0, false, &mut out);
    b.set_levels(levels(1.0, 1.0), HapticPattern::Steady, 0, T0 + MS, true, &mut out);
    b.poll(T0 + 10_000 * MS, &mut out);
    assert_eq!(out.said(), ["left controller cannot rumble"]);
    assert_eq!(b.next_poll_ns(), None, "not reopened");
    assert_eq!(ff.calls_to(RIGHT).last(), Some(&ev_ff(0, 1)), "the other hand still rumbles");
}
