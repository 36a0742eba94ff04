//! The narrow interfaces every feedback backend implements, so devices are chosen by
//! configuration alone (ARCHITECTURE.md: compute never knows which devices exist).

use schemas::{Applied, AppliedAction, HapticPattern, Priority};
use thiserror::Error;

use crate::haptic_cue::Levels;

/// What devices did during one call, and what they need said to the user.
#[derive(Debug, Default)]
pub struct DeviceOutput {
    /// Actions performed (published on `feedback/applied`).
    pub applied: Vec<Applied>,
    /// Device news for the user ("left controller disconnected"), spoken as messages.
    pub say: Vec<DeviceNews>,
}

/// A device's news for the user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceNews {
    /// The device it is about (its backend name): not said by its own voice, if it has
    /// one ("Phone not connected" on the phone is heard by nobody, or heard wrongly
    /// once it is back).
    pub device: String,
    /// The words.
    pub text: String,
}

impl DeviceOutput {
    /// Record an action of `device` at `now_ns` caused by an intent captured at `cause_ns`.
    pub fn applied(&mut self, device: &str, action: AppliedAction, now_ns: u64, cause_ns: u64) {
        self.applied.push(Applied {
            device: device.to_string(),
            action,
            applied_ns: now_ns,
            cause_capture_ns: cause_ns,
        });
    }

    /// Record a status change and have it spoken.
    pub fn status(&mut self, device: &str, text: String, now_ns: u64) {
        self.applied(device, AppliedAction::DeviceStatus { text: text.clone() }, now_ns, 0);
        self.say.push(DeviceNews { device: device.to_string(), text });
    }

    /// The words of the news waiting to be said, oldest first.
    #[cfg(test)]
    pub fn said(&self) -> Vec<&str> {
        self.say.iter().map(|n| n.text.as_str()).collect()
    }
}

/// A pair of actuators, left and right hand.
pub trait HapticDevice: Send {
    /// Backend name (`console`, `wiimote`, `phone`).
    fn name(&self) -> &str;

    /// Drive both sides to `levels`. `refresh` asks the device to write even when the
    /// levels did not change (a new intent arrived); devices that only report changes
    /// may ignore it. Actions go to `out`.
    fn set_levels(
        &mut self,
        levels: Levels,
        pattern: HapticPattern,
        cause_ns: u64,
        now_ns: u64,
        refresh: bool,
        out: &mut DeviceOutput,
    );

    /// Background work due at `now_ns` (battery polls, input reports, reconnects).
    fn poll(&mut self, _now_ns: u64, _out: &mut DeviceOutput) {}

    /// When `poll` must next run, if ever.
    fn next_poll_ns(&self) -> Option<u64> {
        None
    }

    /// Stop every motor at once (shutdown).
    fn off(&mut self, now_ns: u64, out: &mut DeviceOutput);
}

/// Why a speech engine could not start an utterance.
#[derive(Debug, Error)]
pub enum SpeechError {
    /// The synthesiser process could not be started.
    #[error("cannot start {program}: {source}")]
    Spawn {
        /// Program name.
        program: String,
        /// OS error.
        source: std::io::Error,
    },
    /// The engine is unusable on this machine.
    #[error("{0}")]
    Unavailable(String),
}

/// What a confirming engine ([`SpeechEngine::confirms`]) says happened to an
/// utterance, with the device's own time, ns.
#[derive(Debug, Clone, PartialEq)]
pub enum SpeechEvent {
    /// It began playing.
    Started(u64),
    /// It played to its end.
    Ended(u64),
    /// It was cut off.
    Interrupted(u64),
    /// The device could not say it.
    Failed {
        /// When this was known.
        at_ns: u64,
        /// Why.
        reason: String,
    },
}

/// An utterance being spoken.
pub trait SpeakingHandle: Send {
    /// True once the audio has played to its end (or the engine gave up).
    fn is_finished(&mut self, now_ns: u64) -> bool;

    /// Stop at once.
    fn cut(&mut self);

    /// What the device reported since the last call (confirming engines only).
    fn take_events(&mut self, _now_ns: u64) -> Vec<SpeechEvent> {
        Vec::new()
    }
}

/// A text-to-speech engine.
pub trait SpeechEngine: Send {
    /// Backend name (`console`, `espeak`, `speechd`, `phone`).
    fn name(&self) -> &str;

    /// True when the device itself says when an utterance started, ended or was cut
    /// ([`SpeakingHandle::take_events`]): `feedback/applied` then reports those, not
    /// the moment the engine was asked (the phone: only what the page confirmed).
    fn confirms(&self) -> bool {
        false
    }

    /// Start saying `text` at `now_ns`. The agent's queue has already ordered it;
    /// `priority` is for engines that rank against other clients (speech-dispatcher).
    fn start(&mut self, text: &str, priority: Priority, now_ns: u64) -> Result<Box<dyn SpeakingHandle>, SpeechError>;
}

/// Which hand a two-handed backend (two remotes, two rumble nodes) drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hand {
    /// Left hand.
    Left,
    /// Right hand.
    Right,
}

impl Hand {
    /// Both hands, left first.
    pub const BOTH: [Hand; 2] = [Hand::Left, Hand::Right];

    /// "left" or "right", for logs and what is spoken.
    pub fn word(self) -> &'static str {
        match self {
            Hand::Left => "left",
            Hand::Right => "right",
        }
    }

    /// This hand's entry of a backend's `[left, right]` device names.
    pub fn device(self, names: [&'static str; 2]) -> &'static str {
        match self {
            Hand::Left => names[0],
            Hand::Right => names[1],
        }
    }

    /// This hand's rumble level.
    pub fn level(self, levels: Levels) -> f32 {
        match self {
            Hand::Left => levels.left,
            Hand::Right => levels.right,
        }
    }
}
