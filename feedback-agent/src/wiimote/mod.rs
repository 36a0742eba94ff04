//! Two Wii remotes as the left and right rumble (Taylor 2017 §2.4: one remote per hand,
//! on/off motors), over hidapi.
//!
//! Each remote keeps the one source of truth for its motor (`Remote::rumble`): every
//! report it writes goes through `Remote::send`, which sets bit 0 of byte 1 from it, so a
//! battery poll can never switch a rumble off by accident. Pulses are timed by the
//! agent (`haptic_cue`); this backend only writes on/off. Rumble is written off on
//! TTL expiry (the agent drives levels to off), on shutdown (`off`) and when a remote
//! is dropped, including while unwinding from a panic (`Drop for Remote`).

pub mod fake;
pub mod link;
pub mod protocol;

use schemas::{AppliedAction, HapticPattern};

use crate::device::{DeviceOutput, Hand, HapticDevice};
use crate::haptic_cue::Levels;
use link::{HidBus, HidLink, LinkError, RemoteId};
use protocol::InputReport;

/// Wiimote backend settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WiimoteConfig {
    /// The left remote's HID path or serial; `None` = the first remote found.
    pub left: Option<String>,
    /// The right remote's HID path or serial; `None` = the next remote found.
    pub right: Option<String>,
    /// Battery status request period, ms.
    pub battery_poll_ms: u64,
    /// How often a missing remote is looked for, ms.
    pub reconnect_ms: u64,
    /// How often input reports are read, ms.
    pub read_poll_ms: u64,
    /// At or below this percentage (or when the remote's own flag says so), the battery
    /// is announced as low.
    pub low_battery_percent: u8,
}

impl Default for WiimoteConfig {
    /// Battery every 60 s, reconnect every 2 s, inputs every 50 ms, low at 15 %.
    fn default() -> Self {
        Self {
            left: None,
            right: None,
            battery_poll_ms: 60_000,
            reconnect_ms: 2_000,
            read_poll_ms: 50,
            low_battery_percent: 15,
        }
    }
}

/// Device names of the two remotes in `feedback/applied`.
const DEVICES: [&str; 2] = ["wiimote-left", "wiimote-right"];

/// The player LED that tells the remotes apart: 1 on the left, 2 on the right.
fn player_led(hand: Hand) -> u8 {
    match hand {
        Hand::Left => 1,
        Hand::Right => 2,
    }
}

struct Remote {
    link: Box<dyn HidLink>,
    id: RemoteId,
    rumble: bool,
    battery_low_said: bool,
}

impl Remote {
    /// Write `report` with byte 1's bit 0 set from the rumble state.
    fn send(&mut self, report: &[u8]) -> Result<(), LinkError> {
        let mut bytes = [0u8; 8];
        let n = report.len().min(bytes.len());
        bytes[..n].copy_from_slice(&report[..n]);
        if n > 1 {
            bytes[1] = (bytes[1] & !1) | self.rumble as u8;
        }
        self.link.write(&bytes[..n])
    }
}

impl Drop for Remote {
    fn drop(&mut self) {
        // Last word to the motor, also while unwinding: never leave it running. A remote
        // that is already gone cannot rumble either, so a failure here is moot.
        let _ = self.link.write(&protocol::rumble_report(false));
    }
}

/// Left and right remotes, found, opened, watched and reconnected.
pub struct WiimoteBackend {
    bus: Box<dyn HidBus>,
    config: WiimoteConfig,
    remotes: [Option<Remote>; 2],
    /// Serial of the remote each hand last had: a hand lost and found again takes
    /// only its own remote back, never the other hand's (the user cannot see LEDs).
    serials: [Option<String>; 2],
    /// "not found" / "disconnected" already said for this hand since it was last seen.
    absence_said: [bool; 2],
    next_scan_ns: u64,
    next_battery_ns: Option<u64>,
    next_read_ns: u64,
    buf: [u8; 32],
}

const MS: u64 = 1_000_000;

impl WiimoteBackend {
    /// A backend on `bus`; remotes are looked for at the first `poll`.
    pub fn new(bus: Box<dyn HidBus>, config: WiimoteConfig) -> Self {
        Self {
            bus,
            config,
            remotes: [None, None],
            serials: [None, None],
            absence_said: [false, false],
            next_scan_ns: 0,
            next_battery_ns: None,
            next_read_ns: 0,
            buf: [0; 32],
        }
    }

    /// True when the remote of `hand` is open.
    pub fn is_connected(&self, hand: Hand) -> bool {
        self.remotes[hand as usize].is_some()
    }

    fn selector(&self, hand: Hand) -> Option<&str> {
        match hand {
            Hand::Left => self.config.left.as_deref(),
            Hand::Right => self.config.right.as_deref(),
        }
    }

    fn matches(selector: &str, id: &RemoteId) -> bool {
        id.path == selector || (!id.serial.is_empty() && id.serial.eq_ignore_ascii_case(selector))
    }

    fn disconnect(&mut self, hand: Hand, why: &LinkError, now_ns: u64, out: &mut DeviceOutput) {
        if let Some(remote) = self.remotes[hand as usize].take() {
            tracing::warn!(path = %remote.id.path, "{} remote lost: {why}", hand.word());
            drop(remote);
            self.absence_said[hand as usize] = true;
            out.status(hand.device(DEVICES), format!("{} controller disconnected", hand.word()), now_ns);
            self.next_scan_ns = now_ns + self.config.reconnect_ms * MS;
        }
    }

    fn scan(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.next_scan_ns = now_ns + self.config.reconnect_ms * MS;
        let ids = match self.bus.remotes() {
            Ok(ids) => ids,
            Err(e) => {
                if !self.absence_said.iter().all(|s| *s) {
                    tracing::warn!("cannot look for Wii remotes: {e}");
                }
                for hand in Hand::BOTH {
                    if self.remotes[hand as usize].is_none() {
                        self.note_absent(hand, now_ns, out);
                    }
                }
                return;
            }
        };
        for hand in Hand::BOTH {
            if self.remotes[hand as usize].is_some() {
                continue;
            }
            let other = match hand {
                Hand::Left => Hand::Right,
                Hand::Right => Hand::Left,
            };
            let serial_of = |h: Hand, id: &RemoteId| {
                !id.serial.is_empty() && self.serials[h as usize].as_ref().is_some_and(|s| s == &id.serial)
            };
            let in_use = |id: &RemoteId| {
                self.remotes.iter().flatten().any(|r| r.id.path == id.path)
                    || self.selector(other).is_some_and(|s| Self::matches(s, id))
                    || serial_of(other, id)
            };
            let pick = match self.selector(hand) {
                Some(sel) => ids.iter().find(|id| Self::matches(sel, id)),
                // its own remote first, else any the other hand has never had
                None => ids.iter().find(|id| serial_of(hand, id)).or_else(|| ids.iter().find(|id| !in_use(id))),
            };
            let Some(id) = pick.cloned() else {
                self.note_absent(hand, now_ns, out);
                continue;
            };
            let link = match self.bus.open(&id) {
                Ok(link) => link,
                Err(e) => {
                    tracing::warn!("cannot open the {} remote: {e}", hand.word());
                    self.note_absent(hand, now_ns, out);
                    continue;
                }
            };
            let mut remote = Remote { link, id, rumble: false, battery_low_said: false };
            let hello = remote
                .send(&protocol::leds_report(&[player_led(hand)], false))
                .and_then(|_| remote.send(&protocol::reporting_mode_report(protocol::MODE_CORE_BUTTONS, false)))
                .and_then(|_| remote.send(&protocol::status_request_report(false)));
            match hello {
                Ok(()) => {
                    tracing::info!(path = %remote.id.path, serial = %remote.id.serial, "{} remote connected", hand.word());
                    if !remote.id.serial.is_empty() {
                        self.serials[hand as usize] = Some(remote.id.serial.clone());
                    }
                    self.remotes[hand as usize] = Some(remote);
                    let text = format!("{} controller connected", hand.word());
                    // Spoken only when its absence was: no chatter at a normal start.
                    if std::mem::take(&mut self.absence_said[hand as usize]) {
                        out.status(hand.device(DEVICES), text, now_ns);
                    } else {
                        out.applied(hand.device(DEVICES), AppliedAction::DeviceStatus { text }, now_ns, 0);
                    }
                }
                Err(e) => {
                    tracing::warn!("{} remote did not answer: {e}", hand.word());
                    self.note_absent(hand, now_ns, out);
                }
            }
        }
    }

    fn note_absent(&mut self, hand: Hand, now_ns: u64, out: &mut DeviceOutput) {
        if !self.absence_said[hand as usize] {
            self.absence_said[hand as usize] = true;
            out.status(hand.device(DEVICES), format!("{} controller not found", hand.word()), now_ns);
        }
    }

    fn read_inputs(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        for hand in Hand::BOTH {
            // A remote floods nothing in "report on change" mode; 8 reads per poll are plenty.
            for _ in 0..8 {
                let Some(remote) = self.remotes[hand as usize].as_mut() else { break };
                let n = match remote.link.read(&mut self.buf) {
                    Ok(0) => break,
                    Ok(n) => n,
                    Err(e) => {
                        self.disconnect(hand, &e, now_ns, out);
                        break;
                    }
                };
                match protocol::parse_input(&self.buf[..n]) {
                    Ok(InputReport::Status(status)) => {
                        // After any 0x20 the remote stops data reports until 0x12 is sent again.
                        if let Err(e) =
                            remote.send(&protocol::reporting_mode_report(protocol::MODE_CORE_BUTTONS, remote.rumble))
                        {
                            self.disconnect(hand, &e, now_ns, out);
                            break;
                        }
                        let low = status.battery_low_flag || status.battery_percent <= self.config.low_battery_percent;
                        out.applied(
                            hand.device(DEVICES),
                            AppliedAction::DeviceStatus { text: format!("battery {} %", status.battery_percent) },
                            now_ns,
                            0,
                        );
                        if low && !remote.battery_low_said {
                            remote.battery_low_said = true;
                            out.status(hand.device(DEVICES), format!("{} controller battery low", hand.word()), now_ns);
                        } else if !low && status.battery_percent > self.config.low_battery_percent + 10 {
                            remote.battery_low_said = false;
                        }
                    }
                    Ok(InputReport::Other(_)) => {}
                    Err(e) => tracing::debug!("{} remote: {e}", hand.word()),
                }
            }
        }
    }
}

impl HapticDevice for WiimoteBackend {
    fn name(&self) -> &str {
        "wiimote"
    }

    fn set_levels(
        &mut self,
        levels: Levels,
        pattern: HapticPattern,
        cause_ns: u64,
        now_ns: u64,
        refresh: bool,
        out: &mut DeviceOutput,
    ) {
        for hand in Hand::BOTH {
            let Some(remote) = self.remotes[hand as usize].as_mut() else { continue };
            let want = hand.level(levels) > 0.0;
            let changed = want != remote.rumble;
            if !(changed || refresh) {
                continue;
            }
            remote.rumble = want;
            match remote.send(&protocol::rumble_report(want)) {
                Ok(()) if changed => {
                    let level = if want { 1.0 } else { 0.0 };
                    let (left, right) = match hand {
                        Hand::Left => (level, 0.0),
                        Hand::Right => (0.0, level),
                    };
                    out.applied(hand.device(DEVICES), AppliedAction::Rumble { left, right, pattern }, now_ns, cause_ns);
                }
                Ok(()) => {}
                Err(e) => self.disconnect(hand, &e, now_ns, out),
            }
        }
    }

    fn poll(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        if now_ns >= self.next_scan_ns && self.remotes.iter().any(Option::is_none) {
            self.scan(now_ns, out);
        }
        if now_ns >= self.next_read_ns {
            self.next_read_ns = now_ns + self.config.read_poll_ms * MS;
            self.read_inputs(now_ns, out);
        }
        // Remotes ask for their status when they connect; the periodic poll starts
        // one period after the first look.
        let due = *self.next_battery_ns.get_or_insert(now_ns + self.config.battery_poll_ms * MS);
        if now_ns >= due {
            self.next_battery_ns = Some(now_ns + self.config.battery_poll_ms * MS);
            for hand in Hand::BOTH {
                let Some(remote) = self.remotes[hand as usize].as_mut() else { continue };
                let rumble = remote.rumble;
                if let Err(e) = remote.send(&protocol::status_request_report(rumble)) {
                    self.disconnect(hand, &e, now_ns, out);
                }
            }
        }
    }

    fn next_poll_ns(&self) -> Option<u64> {
        let mut next = self.next_read_ns.min(self.next_battery_ns.unwrap_or(0));
        if self.remotes.iter().any(Option::is_none) {
            next = next.min(self.next_scan_ns);
        }
        Some(next)
    }

    fn off(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.set_levels(Levels::OFF, HapticPattern::Steady, 0, now_ns, true, out);
    }
}

#[cfg(test)]
mod tests {
    use super::fake::FakeHid;
    use super::*;

    const T0: u64 = 1_700_000_000_000_000_000;
    const LEFT: &str = "/dev/hidraw0";
    const RIGHT: &str = "/dev/hidraw1";

    fn pair(config: WiimoteConfig) -> (FakeHid, WiimoteBackend, DeviceOutput) {
        let hid = FakeHid::new();
        hid.attach(RIGHT, "00:19:1d:00:00:02");
        hid.attach(LEFT, "00:19:1d:00:00:01");
        let mut backend = WiimoteBackend::new(Box::new(hid.clone()), config);
        let mut out = DeviceOutput::default();
        backend.poll(T0, &mut out);
        (hid, backend, out)
    }

    fn left_on() -> Levels {
        Levels { left: 1.0, right: 0.0 }
    }

    #[test]
    fn connecting_lights_led1_left_led2_right_sets_mode_and_asks_status() {
        let (hid, b, out) = pair(WiimoteConfig::default());
        assert!(b.is_connected(Hand::Left) && b.is_connected(Hand::Right));
        assert_eq!(hid.written_to(LEFT), vec![vec![0x11, 0x10], vec![0x12, 0x00, 0x30], vec![0x15, 0x00]]);
        assert_eq!(hid.written_to(RIGHT), vec![vec![0x11, 0x20], vec![0x12, 0x00, 0x30], vec![0x15, 0x00]]);
        assert!(out.say.is_empty(), "a normal start is silent: {:?}", out.said());
        assert_eq!(out.applied.len(), 2);
    }

    #[test]
    fn remotes_are_mapped_by_serial_when_configured() {
        let config = WiimoteConfig { right: Some("00:19:1D:00:00:01".into()), ..Default::default() };
        let (hid, _, _) = pair(config);
        assert_eq!(hid.written_to(LEFT)[0], [0x11, 0x20], "hidraw0 carries the right-hand serial");
        assert_eq!(hid.written_to(RIGHT)[0], [0x11, 0x10]);
    }

    #[test]
    fn rumble_bit_rides_on_every_later_report() {
        let (hid, mut b, mut out) = pair(WiimoteConfig::default());
        hid.clear_written();
        b.set_levels(left_on(), HapticPattern::Steady, T0, T0 + MS, true, &mut out);
        assert_eq!(hid.written_to(LEFT), vec![vec![0x10, 0x01]]);
        assert_eq!(hid.written_to(RIGHT), vec![vec![0x10, 0x00]], "refresh writes the unchanged side too");
        // A status answer while rumbling: the mode re-send keeps the motor on.
        hid.push_input(LEFT, &[0x20, 0x00, 0x00, 0x10, 0x00, 0x00, 0xc0]);
        b.poll(T0 + 100 * MS, &mut out);
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x12, 0x01, 0x30]);
        // The periodic battery poll keeps it on too.
        b.poll(T0 + 60_000 * MS, &mut out);
        assert_eq!(hid.written_to(LEFT).last().unwrap(), &vec![0x15, 0x01]);
        assert_eq!(hid.written_to(RIGHT).last().unwrap(), &vec![0x15, 0x00]);
    }

    #[test]
    fn only_changes_are_reported_as_applied() {
        let (_, mut b, mut out) = pair(WiimoteConfig::default());
        out.applied.clear();
        b.set_levels(left_on(), HapticPattern::Steady, 42, T0 + MS, true, &mut out);
        b.set_levels(left_on(), HapticPattern::Steady, 43, T0 + 2 * MS, true, &mut out);
        b.set_levels(Levels::OFF, HapticPattern::Steady, 44, T0 + 3 * MS, false, &mut out);
        let rumbles: Vec<(String, u64)> = out.applied.iter().map(|a| (a.device.clone(), a.cause_capture_ns)).collect();
        assert_eq!(rumbles, [("wiimote-left".to_string(), 42), ("wiimote-left".to_string(), 44)]);
    }

    #[test]
    fn low_battery_is_said_once_per_discharge() {
        let (hid, mut b, mut out) = pair(WiimoteConfig::default());
        out.say.clear();
        let low = [0x20, 0x00, 0x00, 0x20, 0x00, 0x00, 0x20]; // 12 %
        hid.push_input(RIGHT, &low);
        b.poll(T0 + 100 * MS, &mut out);
        hid.push_input(RIGHT, &low);
        b.poll(T0 + 200 * MS, &mut out);
        assert_eq!(out.said(), ["right controller battery low"]);
        assert!(out.applied.iter().any(|a| a.action == AppliedAction::DeviceStatus { text: "battery 12 %".into() }));
    }

    #[test]
    fn remote_lost_mid_write_is_said_and_reconnected() {
        let (hid, mut b, mut out) = pair(WiimoteConfig::default());
        out.say.clear();
        hid.detach(LEFT);
        b.set_levels(left_on(), HapticPattern::Steady, T0, T0 + MS, true, &mut out);
        assert!(!b.is_connected(Hand::Left));
        assert_eq!(out.said(), ["left controller disconnected"]);
        // Still gone at the next scan: not said again.
        b.poll(T0 + 2_001 * MS, &mut out);
        assert_eq!(out.said().len(), 1);
        hid.attach(LEFT, "00:19:1d:00:00:01");
        hid.clear_written();
        b.poll(T0 + 4_002 * MS, &mut out);
        assert!(b.is_connected(Hand::Left));
        assert_eq!(*out.said().last().unwrap(), "left controller connected");
        assert_eq!(hid.written_to(LEFT)[0], [0x11, 0x10], "LED 1 lit again on the left");
    }

    #[test]
    fn a_hand_lost_and_found_takes_back_only_its_own_remote() {
        let (hid, mut b, mut out) = pair(WiimoteConfig::default());
        // both remotes out of range; the right one comes back first, on the left's old node
        hid.detach(LEFT);
        hid.detach(RIGHT);
        b.set_levels(left_on(), HapticPattern::Steady, T0, T0 + MS, true, &mut out);
        assert!(!b.is_connected(Hand::Left) && !b.is_connected(Hand::Right));
        hid.attach(LEFT, "00:19:1d:00:00:02");
        hid.clear_written();
        out.say.clear();
        b.poll(T0 + 4_000 * MS, &mut out);
        assert!(b.is_connected(Hand::Right) && !b.is_connected(Hand::Left));
        assert_eq!(hid.written_to(LEFT)[0], [0x11, 0x20], "LED 2: it is the right hand's remote");
        assert_eq!(out.said(), ["right controller connected"]);
        hid.attach(RIGHT, "00:19:1d:00:00:01");
        b.poll(T0 + 8_000 * MS, &mut out);
        assert!(b.is_connected(Hand::Left));
        assert_eq!(hid.written_to(RIGHT)[0], [0x11, 0x10]);
        assert_eq!(out.said(), ["right controller connected", "left controller connected"]);
    }

    #[test]
    fn dropping_the_backend_switches_rumble_off() {
        let (hid, mut b, mut out) = pair(WiimoteConfig::default());
        b.set_levels(Levels { left: 1.0, right: 1.0 }, HapticPattern::Steady, T0, T0, false, &mut out);
        hid.clear_written();
        drop(b);
        assert_eq!(hid.written_to(LEFT), vec![vec![0x10, 0x00]]);
        assert_eq!(hid.written_to(RIGHT), vec![vec![0x10, 0x00]]);
    }

    #[test]
    fn a_panic_while_rumbling_still_switches_rumble_off() {
        let hid = FakeHid::new();
        hid.attach(LEFT, "a");
        let probe = hid.clone();
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
            let mut b = WiimoteBackend::new(Box::new(hid), WiimoteConfig::default());
            let mut out = DeviceOutput::default();
            b.poll(T0, &mut out);
            b.set_levels(Levels { left: 1.0, right: 0.0 }, HapticPattern::Steady, T0, T0, false, &mut out);
            panic!("simulated bug while rumbling");
        }));
        assert!(result.is_err());
        assert_eq!(probe.written_to(LEFT).last().unwrap(), &vec![0x10, 0x00]);
    }

    #[test]
    fn no_remote_is_said_once_and_looked_for_again() {
        let hid = FakeHid::new();
        let mut b = WiimoteBackend::new(Box::new(hid.clone()), WiimoteConfig::default());
        let mut out = DeviceOutput::default();
        b.poll(T0, &mut out);
        b.poll(T0 + 2_000 * MS, &mut out);
        assert_eq!(out.said(), ["left controller not found", "right controller not found"]);
        assert_eq!(b.next_poll_ns(), Some(T0 + 2_000 * MS + 50 * MS));
        hid.attach(LEFT, "a");
        b.poll(T0 + 4_000 * MS, &mut out);
        assert!(b.is_connected(Hand::Left));
    }
}
