//! Rumble through the kernel's force-feedback interface (evdev), one node per hand:
//! the alternative to the hidraw Wiimote backend when the kernel `hid-wiimote` driver
//! keeps the remotes (it exposes `FF_RUMBLE` on its "Nintendo Wii Remote" input node),
//! and the way to drive any other rumble device the kernel knows (gamepads).
//!
//! Per node one `FF_RUMBLE` effect is uploaded with `EVIOCSFF` when the motor first
//! runs (updated in place when the level changes), played and stopped by writing
//! `EV_FF` input events, and erased with `EVIOCRMFF` when the node is closed. Timing
//! (pulses, TTL) is the feedback step's, as for every haptic device; this backend
//! only switches. Motors are stopped when the levels go to zero (TTL expiry), on
//! shutdown (`off`) and when a node is dropped, including while unwinding from a panic
//! (`Drop for Actuator`); the kernel also stops a closed file's effects, so even a killed
//! agent leaves no motor running. Each effect carries a replay length as a last
//! backstop (the kernel's own timer).

pub mod fake;
pub mod ff;

use std::io::Write;
use std::os::fd::AsRawFd;
use std::path::{Path, PathBuf};

use schemas::{AppliedAction, HapticPattern};

use crate::device::{DeviceOutput, Hand, HapticDevice};
use crate::haptic_cue::Levels;
use ff::FfEffect;

const MS: u64 = 1_000_000;

/// One open input node, at the level of its system calls.
pub trait FfNode: Send {
    /// `ioctl(fd, request, effect)` for `EVIOCSFF`: the kernel reads `effect` and
    /// writes the id it assigned into `effect.id`.
    fn upload_effect(&mut self, request: u64, effect: &mut FfEffect) -> std::io::Result<()>;

    /// `ioctl(fd, request, id)` for `EVIOCRMFF` (the id by value).
    fn remove_effect(&mut self, request: u64, id: i32) -> std::io::Result<()>;

    /// `write(fd, bytes)`: one or more `input_event`s.
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()>;
}

/// Opens input nodes.
pub trait FfOpener: Send {
    /// Open the node at `path` for reading and writing.
    fn open(&mut self, path: &Path) -> std::io::Result<Box<dyn FfNode>>;
}

/// The real `/dev/input/eventN` nodes.
#[derive(Debug, Default)]
pub struct EvdevOpener;

struct EvdevNode {
    file: std::fs::File,
}

impl FfOpener for EvdevOpener {
    fn open(&mut self, path: &Path) -> std::io::Result<Box<dyn FfNode>> {
        if !cfg!(all(target_os = "linux", target_pointer_width = "64")) {
            // The structs in `ff` have the 64-bit layouts only.
            return Err(std::io::Error::new(std::io::ErrorKind::Unsupported, "evdev rumble needs 64-bit Linux"));
        }
        let file = std::fs::OpenOptions::new().read(true).write(true).open(path)?;
        Ok(Box::new(EvdevNode { file }))
    }
}

fn check(r: libc::c_int) -> std::io::Result<()> {
    if r < 0 {
        Err(std::io::Error::last_os_error())
    } else {
        Ok(())
    }
}

impl FfNode for EvdevNode {
    fn upload_effect(&mut self, request: u64, effect: &mut FfEffect) -> std::io::Result<()> {
        // SAFETY: `effect` is an exclusively borrowed, fully initialised `struct
        // ff_effect` of the kernel's size (see `ff`); the kernel reads it and writes
        // back only its `id` field, within the same 48 bytes.
        check(unsafe { libc::ioctl(self.file.as_raw_fd(), request as _, effect as *mut FfEffect) })
    }

    fn remove_effect(&mut self, request: u64, id: i32) -> std::io::Result<()> {
        // SAFETY: EVIOCRMFF takes the effect id by value; no memory is passed.
        check(unsafe { libc::ioctl(self.file.as_raw_fd(), request as _, id as libc::c_ulong) })
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.file.write_all(bytes)
    }
}

/// evdev backend settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EvdevConfig {
    /// Input node of the left hand's actuator (`/dev/input/event5`).
    pub left: Option<PathBuf>,
    /// Input node of the right hand's actuator.
    pub right: Option<PathBuf>,
    /// Replay length of every effect, ms: the kernel stops the motor after this even
    /// if the agent never does (the longest TTL honoured, `--max-haptic-ttl-ms`).
    pub backstop_ms: u16,
    /// How often a missing node is opened again, ms.
    pub reconnect_ms: u64,
}

impl Default for EvdevConfig {
    /// 2 s backstop (the default TTL cap), reopened every 2 s (as the Wiimote backend).
    fn default() -> Self {
        Self { left: None, right: None, backstop_ms: 2000, reconnect_ms: 2000 }
    }
}

/// Device names of the two rumble nodes in `feedback/applied`.
const DEVICES: [&str; 2] = ["evdev-left", "evdev-right"];

/// One open node and the effect on it: the single source of truth for its motor.
struct Actuator {
    node: Box<dyn FfNode>,
    /// The uploaded effect and its magnitude.
    effect: Option<(i16, u16)>,
    playing: bool,
    backstop_ms: u16,
}

impl Actuator {
    /// Drive the motor to `magnitude` (0 = stop). `refresh` writes even when nothing
    /// changed, which also restarts the effect's backstop timer.
    fn drive(&mut self, magnitude: u16, refresh: bool) -> std::io::Result<()> {
        if magnitude == 0 {
            if let Some((id, _)) = self.effect {
                if self.playing || refresh {
                    self.node.write(&ff::stop(id))?;
                }
            }
            self.playing = false;
            return Ok(());
        }
        let id = match self.effect {
            Some((id, m)) if m == magnitude => id,
            previous => {
                let mut effect = FfEffect::rumble(previous.map_or(-1, |(id, _)| id), magnitude, self.backstop_ms);
                self.node.upload_effect(ff::EVIOCSFF, &mut effect)?;
                self.effect = Some((effect.id, magnitude));
                // Played again below, so the new magnitude and its backstop start now.
                self.playing = false;
                effect.id
            }
        };
        if !self.playing || refresh {
            self.node.write(&ff::play(id))?;
            self.playing = true;
        }
        Ok(())
    }
}

impl Drop for Actuator {
    fn drop(&mut self) {
        // Last word to the motor, also while unwinding. A node that is gone cannot
        // rumble either (and closing the file makes the kernel stop its effects).
        if let Some((id, _)) = self.effect.take() {
            let _ = self.node.write(&ff::stop(id));
            let _ = self.node.remove_effect(ff::EVIOCRMFF, id as i32);
        }
    }
}

/// Left and right rumble on evdev nodes, opened, watched and reopened.
pub struct EvdevBackend {
    opener: Box<dyn FfOpener>,
    config: EvdevConfig,
    actuators: [Option<Actuator>; 2],
    shown: [Option<u16>; 2],
    absence_said: [bool; 2],
    /// The node refused a rumble effect (not a force-feedback device): never reopened,
    /// so a wrong path is said once instead of connecting and failing forever.
    refused: [bool; 2],
    next_open_ns: u64,
}

impl EvdevBackend {
    /// A backend opening its nodes through `opener` at the first `poll`.
    pub fn new(opener: Box<dyn FfOpener>, config: EvdevConfig) -> Self {
        Self {
            opener,
            config,
            actuators: [None, None],
            shown: [None, None],
            absence_said: [false, false],
            refused: [false, false],
            next_open_ns: 0,
        }
    }

    /// True when the node of the left (`true`) or right hand is open.
    pub fn is_open(&self, left: bool) -> bool {
        self.actuators[if left { 0 } else { 1 }].is_some()
    }

    fn path(&self, side: Hand) -> Option<&Path> {
        match side {
            Hand::Left => self.config.left.as_deref(),
            Hand::Right => self.config.right.as_deref(),
        }
    }

    fn open_missing(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.next_open_ns = now_ns + self.config.reconnect_ms * MS;
        for side in Hand::BOTH {
            let k = side as usize;
            if self.actuators[k].is_some() || self.refused[k] {
                continue;
            }
            let Some(path) = self.path(side).map(Path::to_path_buf) else { continue };
            match self.opener.open(&path) {
                Ok(node) => {
                    tracing::info!(path = %path.display(), "{} rumble node open", side.word());
                    self.actuators[k] =
                        Some(Actuator { node, effect: None, playing: false, backstop_ms: self.config.backstop_ms });
                    self.shown[k] = None;
                    let text = format!("{} controller connected", side.word());
                    if std::mem::take(&mut self.absence_said[k]) {
                        out.status(side.device(DEVICES), text, now_ns);
                    } else {
                        out.applied(side.device(DEVICES), AppliedAction::DeviceStatus { text }, now_ns, 0);
                    }
                }
                Err(e) => {
                    if !self.absence_said[k] {
                        self.absence_said[k] = true;
                        tracing::warn!("cannot open {} for the {} hand: {e}", path.display(), side.word());
                        out.status(side.device(DEVICES), format!("{} controller not found", side.word()), now_ns);
                    }
                }
            }
        }
    }

    fn lose(&mut self, side: Hand, why: &std::io::Error, now_ns: u64, out: &mut DeviceOutput) {
        if let Some(actuator) = self.actuators[side as usize].take() {
            drop(actuator);
            // EINVAL / ENOSYS from EVIOCSFF: the node exists but cannot rumble.
            if matches!(why.kind(), std::io::ErrorKind::InvalidInput | std::io::ErrorKind::Unsupported) {
                tracing::error!(
                    "the {} node refuses FF_RUMBLE ({why}); check --evdev-{} (fftest shows what a node supports)",
                    side.word(),
                    side.word()
                );
                self.refused[side as usize] = true;
                out.status(side.device(DEVICES), format!("{} controller cannot rumble", side.word()), now_ns);
                return;
            }
            tracing::warn!("{} rumble node lost: {why}", side.word());
            self.absence_said[side as usize] = true;
            out.status(side.device(DEVICES), format!("{} controller disconnected", side.word()), now_ns);
            self.next_open_ns = now_ns + self.config.reconnect_ms * MS;
        }
    }
}

impl HapticDevice for EvdevBackend {
    fn name(&self) -> &str {
        "evdev"
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
        for side in Hand::BOTH {
            let k = side as usize;
            let Some(actuator) = self.actuators[k].as_mut() else { continue };
            let magnitude = ff::magnitude(side.level(levels));
            match actuator.drive(magnitude, refresh) {
                Ok(()) if self.shown[k] != Some(magnitude) => {
                    self.shown[k] = Some(magnitude);
                    let level = magnitude as f32 / u16::MAX as f32;
                    let (left, right) = match side {
                        Hand::Left => (level, 0.0),
                        Hand::Right => (0.0, level),
                    };
                    out.applied(side.device(DEVICES), AppliedAction::Rumble { left, right, pattern }, now_ns, cause_ns);
                }
                Ok(()) => {}
                Err(e) => self.lose(side, &e, now_ns, out),
            }
        }
    }

    fn poll(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        if now_ns >= self.next_open_ns {
            self.open_missing(now_ns, out);
        }
    }

    fn next_poll_ns(&self) -> Option<u64> {
        let missing = Hand::BOTH
            .iter()
            .any(|s| self.path(*s).is_some() && self.actuators[*s as usize].is_none() && !self.refused[*s as usize]);
        missing.then_some(self.next_open_ns)
    }

    fn off(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.set_levels(Levels::OFF, HapticPattern::Steady, 0, now_ns, true, out);
    }
}

#[cfg(test)]
mod tests;
