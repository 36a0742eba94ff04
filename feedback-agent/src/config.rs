//! Feedback agent configuration: which devices, the user's voice, the safety deadline.
//! One struct serves the CLI (clap), config files (serde) and the in-process demo; the
//! clap defaults are the only defaults (`Default` parses an empty command line).

use std::path::PathBuf;

use clap::{Parser, ValueEnum};
use serde::{Deserialize, Serialize};

use crate::espeak::EspeakConfig;
use crate::evdev::EvdevConfig;
use crate::feedback::StepSettings;
use crate::haptic_cue::CueLimits;
use crate::speech_queue::QueueConfig;
use crate::speechd::{socket_path_from_env, SpeechdConfig};
use crate::wiimote::WiimoteConfig;

/// A haptic backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HapticBackend {
    /// `RUMBLE left` lines on stdout.
    Console,
    /// Two Wii remotes over hidapi (one per hand).
    Wiimote,
    /// Force-feedback rumble on evdev input nodes (`--evdev-left`, `--evdev-right`),
    /// e.g. the kernel hid-wiimote driver's, or a gamepad's.
    Evdev,
    /// The phone's vibration, through the phone bridge (one motor: the side is the
    /// rhythm); reported only when the page confirms it vibrated.
    Phone,
}

/// A speech backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SpeechBackend {
    /// `SPEAK "..."` lines on stdout, timed like a voice.
    Console,
    /// espeak-ng, played through aplay/paplay, or synthesised to WAV without one.
    Espeak,
    /// speech-dispatcher, over SSIP on its Unix socket (`--speechd-socket`).
    Speechd,
    /// The phone's voice (`speechSynthesis` in the page), through the phone bridge;
    /// reported when the page says it started, ended or was cut.
    Phone,
}

/// A configuration the agent refuses to run with.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// A backend named twice would drive one device twice and report each action twice.
    #[error("--{option} names {backend} twice; name each backend once (e.g. --{option} console,{backend})")]
    Twice {
        /// `haptic` or `speech`.
        option: &'static str,
        /// The backend named twice.
        backend: String,
    },
}

fn default_bus() -> bus::BusOptions {
    bus::BusOptions::for_user("demo")
}

/// Everything the feedback agent needs to run.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(default)]
pub struct FeedbackConfig {
    /// Bus connection and user.
    #[command(flatten)]
    #[serde(skip, default = "default_bus")]
    pub bus: bus::BusOptions,

    /// Haptic backends, comma-separated; several run at once (e.g. `wiimote,console`).
    #[arg(long, value_delimiter = ',', default_value = "console")]
    pub haptic: Vec<HapticBackend>,

    /// Speech backends, comma-separated (e.g. `espeak,console`).
    #[arg(long, value_delimiter = ',', default_value = "console")]
    pub speech: Vec<SpeechBackend>,

    /// Obstacle detection counts as offline when no hazard arrived for this long, or
    /// at once when the compute agent's liveliness token disappears (safety rule 1).
    #[arg(long, default_value_t = 500, value_name = "MS")]
    pub offline_after_ms: u64,

    /// Oldest haptic intent or hazard acted on, in milliseconds from the capture of the
    /// frame behind it (its sender's clock offset taken out): an older one (a stalled
    /// link, a replay) is refused and counted as `stale`, and counts as no input for
    /// the offline watchdog.
    #[arg(long, default_value_t = 250, value_name = "MS", value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub max_intent_age_ms: u64,

    /// Oldest speech intent or user command acted on, in milliseconds from when it was
    /// made (utterances also end with their own time to live).
    #[arg(long, default_value_t = 2000, value_name = "MS", value_parser = clap::value_parser!(u64).range(1..=60_000))]
    pub max_speech_age_ms: u64,

    /// While offline, repeat the left-right alert rumble this often (0 = only once).
    #[arg(long, default_value_t = 5000, value_name = "MS")]
    pub offline_repeat_ms: u64,

    /// Name of the agent whose liveliness token means "obstacle detection runs".
    #[arg(long, default_value = "compute-agent", value_name = "AGENT")]
    pub compute_agent: String,

    /// Longest haptic TTL honoured; a cue never rumbles longer than this (rule 2).
    #[arg(long, default_value_t = 2000, value_name = "MS")]
    pub max_haptic_ttl_ms: u32,

    /// An utterance with the same dedup key is not repeated within this window.
    #[arg(long, default_value_t = 3000, value_name = "MS")]
    pub dedup_window_ms: u64,

    /// Also write every utterance as a WAV file into this directory (espeak backend).
    #[arg(long, value_name = "DIR")]
    pub speech_wav_dir: Option<PathBuf>,

    /// espeak-ng voice (`espeak-ng --voices` lists them).
    #[arg(long, default_value = "en", value_name = "VOICE")]
    pub voice: String,

    /// Speech rate, words per minute (espeak-ng accepts 80-500).
    #[arg(long, default_value_t = 175, value_name = "WPM")]
    pub rate_wpm: u32,

    /// Speech volume, espeak-ng amplitude 0-200.
    #[arg(long, default_value_t = 100, value_name = "AMP")]
    pub volume: u32,

    /// HID path (`/dev/hidraw3`) or serial (Bluetooth address) of the LEFT remote;
    /// default: the first remote found. It lights player LED 1.
    #[arg(long, value_name = "PATH_OR_SERIAL")]
    pub wiimote_left: Option<String>,

    /// HID path or serial of the RIGHT remote; default: the next remote found. It
    /// lights player LED 2.
    #[arg(long, value_name = "PATH_OR_SERIAL")]
    pub wiimote_right: Option<String>,

    /// evdev input node of the LEFT hand's rumble (`/dev/input/event5`; the
    /// hid-wiimote node is named "Nintendo Wii Remote" in /proc/bus/input/devices).
    #[arg(long, value_name = "PATH")]
    pub evdev_left: Option<PathBuf>,

    /// evdev input node of the RIGHT hand's rumble.
    #[arg(long, value_name = "PATH")]
    pub evdev_right: Option<PathBuf>,

    /// speech-dispatcher's socket; default `SPEECHD_ADDRESS` (`unix_socket:PATH`),
    /// else `$XDG_RUNTIME_DIR/speech-dispatcher/speechd.sock`.
    #[arg(long, value_name = "PATH")]
    pub speechd_socket: Option<PathBuf>,

    /// Remote battery poll period.
    #[arg(long, default_value_t = 60, value_name = "S")]
    pub battery_poll_s: u64,

    /// Battery at or below this percentage is announced as low.
    #[arg(long, default_value_t = 15, value_name = "PERCENT")]
    pub low_battery_percent: u8,

    /// Health stats period.
    #[arg(long, default_value_t = 1000, value_name = "MS")]
    pub health_period_ms: u64,
}

#[derive(Parser)]
struct DefaultsOnly {
    #[command(flatten)]
    config: FeedbackConfig,
}

impl Default for FeedbackConfig {
    fn default() -> Self {
        match DefaultsOnly::try_parse_from(["feedback-agent"]) {
            Ok(d) => d.config,
            // Only reachable if a default above stops parsing: a build-time bug that
            // `defaults_parse_and_match_the_documentation` catches.
            Err(e) => panic!("feedback-agent defaults do not parse: {e}"),
        }
    }
}

impl FeedbackConfig {
    /// Defaults on the given bus (what `wearnav demo` uses).
    pub fn with_bus(bus: bus::BusOptions) -> Self {
        Self { bus, ..Self::default() }
    }

    /// Refuse what the agent cannot honestly do: `feedback/applied` says the user felt
    /// or heard something once per action, so no backend may be named twice.
    pub fn check(&self) -> Result<(), ConfigError> {
        fn twice<T: PartialEq + std::fmt::Debug>(option: &'static str, list: &[T]) -> Result<(), ConfigError> {
            match list.iter().enumerate().find(|(k, b)| list[..*k].contains(b)) {
                Some((_, b)) => Err(ConfigError::Twice { option, backend: format!("{b:?}").to_lowercase() }),
                None => Ok(()),
            }
        }
        twice("haptic", &self.haptic)?;
        twice("speech", &self.speech)
    }

    /// Settings of the feedback step.
    pub fn step_settings(&self) -> StepSettings {
        StepSettings {
            limits: CueLimits { max_ttl_ms: self.max_haptic_ttl_ms, ..CueLimits::default() },
            queue: QueueConfig { dedup_window_ms: self.dedup_window_ms, ..QueueConfig::default() },
            offline_after_ms: self.offline_after_ms,
            alert_repeat_ms: self.offline_repeat_ms,
            ..StepSettings::default()
        }
    }

    /// espeak-ng settings.
    pub fn espeak(&self) -> EspeakConfig {
        EspeakConfig {
            voice: self.voice.clone(),
            rate_wpm: self.rate_wpm,
            volume: self.volume,
            wav_dir: self.speech_wav_dir.clone(),
            ..EspeakConfig::default()
        }
    }

    /// speech-dispatcher settings (the socket resolved from the environment).
    pub fn speechd(&self) -> Result<SpeechdConfig, String> {
        Ok(SpeechdConfig {
            socket: socket_path_from_env(self.speechd_socket.as_deref())?,
            user: self.bus.user.clone(),
            voice: self.voice.clone(),
            rate_wpm: self.rate_wpm,
            volume: self.volume,
            ..SpeechdConfig::default()
        })
    }

    /// evdev rumble settings; the backstop is the longest TTL honoured.
    pub fn evdev(&self) -> EvdevConfig {
        EvdevConfig {
            left: self.evdev_left.clone(),
            right: self.evdev_right.clone(),
            backstop_ms: self.max_haptic_ttl_ms.clamp(1, u16::MAX as u32) as u16,
            ..EvdevConfig::default()
        }
    }

    /// Wiimote settings.
    pub fn wiimote(&self) -> WiimoteConfig {
        WiimoteConfig {
            left: self.wiimote_left.clone(),
            right: self.wiimote_right.clone(),
            battery_poll_ms: self.battery_poll_s.saturating_mul(1000),
            low_battery_percent: self.low_battery_percent,
            ..WiimoteConfig::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_parse_and_match_the_documentation() {
        let c = FeedbackConfig::default();
        assert_eq!(c.haptic, [HapticBackend::Console]);
        assert_eq!(c.speech, [SpeechBackend::Console]);
        assert_eq!(c.offline_after_ms, 500);
        assert_eq!(c.rate_wpm, 175);
        assert_eq!(c.compute_agent, "compute-agent");
    }

    #[test]
    fn backends_are_comma_separated_lists() {
        let d = DefaultsOnly::try_parse_from([
            "feedback-agent",
            "--haptic",
            "wiimote,console",
            "--speech",
            "espeak,console",
            "--offline-after-ms",
            "300",
        ])
        .unwrap();
        assert_eq!(d.config.haptic, [HapticBackend::Wiimote, HapticBackend::Console]);
        assert_eq!(d.config.speech, [SpeechBackend::Espeak, SpeechBackend::Console]);
        assert_eq!(d.config.step_settings().offline_after_ms, 300);
        assert!(DefaultsOnly::try_parse_from(["x", "--haptic", "belt"]).is_err());
        let d = DefaultsOnly::try_parse_from([
            "x",
            "--haptic",
            "evdev",
            "--evdev-left",
            "/dev/input/event5",
            "--speech",
            "speechd",
            "--speechd-socket",
            "/tmp/s.sock",
        ])
        .unwrap();
        assert_eq!(d.config.haptic, [HapticBackend::Evdev]);
        assert_eq!(d.config.speech, [SpeechBackend::Speechd]);
        assert_eq!(d.config.evdev().left.as_deref(), Some(std::path::Path::new("/dev/input/event5")));
        assert_eq!(d.config.evdev().backstop_ms, 2000);
        assert_eq!(d.config.speechd().unwrap().socket, PathBuf::from("/tmp/s.sock"));
    }

    #[test]
    fn the_phone_is_a_backend_and_a_backend_named_twice_is_refused() {
        let parse = |args: &[&str]| DefaultsOnly::try_parse_from(args).unwrap().config;
        let c = parse(&["x", "--haptic", "wiimote,phone", "--speech", "phone"]);
        assert_eq!(
            (c.haptic.as_slice(), c.speech.as_slice(), c.check()),
            (&[HapticBackend::Wiimote, HapticBackend::Phone][..], &[SpeechBackend::Phone][..], Ok(()))
        );
        let twice = parse(&["x", "--haptic", "phone,console,phone"]).check().unwrap_err();
        assert_eq!(twice, ConfigError::Twice { option: "haptic", backend: "phone".into() });
        assert!(twice.to_string().contains("names phone twice"), "{twice}");
        // config files too
        let c: FeedbackConfig = serde_json::from_str(r#"{"speech": ["espeak", "espeak"]}"#).unwrap();
        assert_eq!(c.check(), Err(ConfigError::Twice { option: "speech", backend: "espeak".into() }));
        assert_eq!(
            parse(&["x", "--haptic", "wiimote,evdev,console", "--speech", "espeak,speechd,console"]).check(),
            Ok(())
        );
    }

    #[test]
    fn config_files_fill_missing_fields_with_the_defaults() {
        let c: FeedbackConfig = serde_json::from_str(r#"{"haptic": ["wiimote"], "rate_wpm": 200}"#).unwrap();
        assert_eq!(c.haptic, [HapticBackend::Wiimote]);
        assert_eq!(c.rate_wpm, 200);
        assert_eq!(c.offline_after_ms, 500);
    }
}
