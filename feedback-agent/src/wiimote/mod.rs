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

use crate::device::{DeviceOutput, HapticDevice};
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

/// Which hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hand {
    /// Left hand: player LED 1.
    Left,
    /// Right hand: player LED 2.
    Right,
}

impl Hand {
    const BOTH: [Hand; 2] = [Hand::Left, Hand::Right];

    fn word(self) -> &'static str {
        match self {
            Hand::Left => "left",
            Hand::Right => "right",
        }
    }

    fn device(self) -> &'static str {
        match self {
            Hand::Left => "wiimote-left",
            Hand::Right => "wiimote-right",
        }
    }

    fn player_led(self) -> u8 {
        match self {
            Hand::Left => 1,
            Hand::Right => 2,
        }
    }

    fn level(self, levels: Levels) -> f32 {
        match self {
            Hand::Left => levels.left,
            Hand::Right => levels.right,
        }
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
    /// "not found" / "disconnected" already said for this hand since it was last seen.
    absence_said: [bool; 2],
    next_scan_ns: u64,
    next_battery_ns: u64,
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
            absence_said: [false, false],
            next_scan_ns: 0,
            next_battery_ns: 0,
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
            out.status(hand.device(), format!("{} controller disconnected", hand.word()), now_ns);
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
            let in_use = |id: &RemoteId| {
                self.remotes.iter().flatten().any(|r| r.id.path == id.path)
                    || self.selector(other).is_some_and(|s| Self::matches(s, id))
            };
            let pick = match self.selector(hand) {
                Some(sel) => ids.iter().find(|id| Self::matches(sel, id)),
                None => ids.iter().find(|id| !in_use(id)),
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
                .send(&protocol::leds_report(&[hand.player_led()], false))
                .and_then(|_| remote.send(&protocol::reporting_mode_report(protocol::MODE_CORE_BUTTONS, false)))
                .and_then(|_| remote.send(&protocol::status_request_report(false)));
            match hello {
                Ok(()) => {
                    tracing::info!(path = %remote.id.path, serial = %remote.id.serial, "{} remote connected", hand.word());
                    self.remotes[hand as usize] = Some(remote);
                    self.absence_said[hand as usize] = false;
                    out.status(hand.device(), format!("{} controller connected", hand.word()), now_ns);
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
            out.status(hand.device(), format!("{} controller not found", hand.word()), now_ns);
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
                        if let Err(e) = remote.send(&protocol::reporting_mode_report(protocol::MODE_CORE_BUTTONS, remote.rumble)) {
                            self.disconnect(hand, &e, now_ns, out);
                            break;
                        }
                        let low = status.battery_low_flag || status.battery_percent <= self.config.low_battery_percent;
                        out.applied(
                            hand.device(),
                            AppliedAction::DeviceStatus { text: format!("battery {} %", status.battery_percent) },
                            now_ns,
                            0,
                        );
                        if low && !remote.battery_low_said {
                            remote.battery_low_said = true;
                            out.status(hand.device(), format!("{} controller battery low", hand.word()), now_ns);
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

    fn set_levels(&mut self, levels: Levels, pattern: HapticPattern, cause_ns: u64, now_ns: u64, refresh: bool, out: &mut DeviceOutput) {
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
                    out.applied(hand.device(), AppliedAction::Rumble { left, right, pattern }, now_ns, cause_ns);
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
        if now_ns >= self.next_battery_ns {
            self.next_battery_ns = now_ns + self.config.battery_poll_ms * MS;
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
        let mut next = self.next_read_ns.min(self.next_battery_ns);
        if self.remotes.iter().any(Option::is_none) {
            next = next.min(self.next_scan_ns);
        }
        Some(next)
    }

    fn off(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.set_levels(Levels::OFF, HapticPattern::Steady, 0, now_ns, true, out);
    }
}
