//! espeak-ng (Debian `espeak-ng`) as the speech engine: one child process per
//! utterance, killed to cut it off at once.
//!
//! Audio goes to `aplay` or `paplay` when one is installed (`espeak-ng --stdout` piped
//! into it), so espeak-ng never needs an audio device of its own; with no player the
//! utterance is only synthesised to a WAV file, and the engine says so in its status.
//! With a WAV directory every utterance is also written there as `NNNNNN.wav`.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use schemas::Priority;

use crate::device::{SpeakingHandle, SpeechEngine, SpeechError};

/// espeak-ng settings (the user profile's voice).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EspeakConfig {
    /// Program to run.
    pub program: PathBuf,
    /// Voice (`en`, `en-us`, `fr`...).
    pub voice: String,
    /// Words per minute (espeak-ng's default is 175).
    pub rate_wpm: u32,
    /// Amplitude 0..200 (espeak-ng's default is 100).
    pub volume: u32,
    /// Also write each utterance here as WAV.
    pub wav_dir: Option<PathBuf>,
}

impl Default for EspeakConfig {
    fn default() -> Self {
        Self { program: "espeak-ng".into(), voice: "en".into(), rate_wpm: 175, volume: 100, wav_dir: None }
    }
}

/// How utterances reach the ear.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Playback {
    /// Piped into this player (`aplay -q`, `paplay`).
    Player(Vec<String>),
    /// No player found: synthesised to WAV only.
    WavOnly,
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .map(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
        .unwrap_or(false)
}

fn succeeds_with(program: &str, args: &[&str], needle: &str) -> bool {
    Command::new(program)
        .args(args)
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .output()
        .map(|o| o.status.success() && String::from_utf8_lossy(&o.stdout).contains(needle))
        .unwrap_or(false)
}

/// The first audio player on `PATH` that has somewhere to play: `aplay` when ALSA
/// lists a card, `paplay` when a PulseAudio/PipeWire server answers; else WAV only
/// (a player without a sound card would fail on every utterance, silently).
pub fn find_player() -> Playback {
    if on_path("aplay") && succeeds_with("aplay", &["-l"], "card ") {
        Playback::Player(vec!["aplay".into(), "-q".into()])
    } else if on_path("paplay") && succeeds_with("pactl", &["info"], "Server") {
        Playback::Player(vec!["paplay".into()])
    } else {
        Playback::WavOnly
    }
}

/// The espeak-ng engine.
pub struct EspeakEngine {
    config: EspeakConfig,
    playback: Playback,
    count: u64,
    scratch_wav: PathBuf,
}

impl EspeakEngine {
    /// Check that espeak-ng runs and pick the playback; fails with what to install.
    pub fn new(config: EspeakConfig, playback: Playback) -> Result<Self, SpeechError> {
        let ok = Command::new(&config.program)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        if !ok {
            return Err(SpeechError::Unavailable(format!(
                "{} not found or not working; install it with `apt-get install espeak-ng`",
                config.program.display()
            )));
        }
        // A bad voice makes every utterance fail silently: refuse it at start instead.
        let voice_ok = Command::new(&config.program)
            .args(["-q", "-v", &config.voice, "ok"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .map(|s| s.success())
            .unwrap_or(false);
        if !voice_ok {
            return Err(SpeechError::Unavailable(format!(
                "espeak-ng has no voice {:?}; `espeak-ng --voices` lists them",
                config.voice
            )));
        }
        if let Some(dir) = &config.wav_dir {
            std::fs::create_dir_all(dir).map_err(|e| {
                SpeechError::Unavailable(format!("cannot create the WAV directory {}: {e}", dir.display()))
            })?;
        }
        let scratch_wav = std::env::temp_dir().join(format!("wearnav-espeak-{}.wav", std::process::id()));
        Ok(Self { config, playback, count: 0, scratch_wav })
    }

    /// What the engine does with audio, for the start-up status line.
    pub fn describe(&self) -> String {
        match &self.playback {
            Playback::Player(cmd) => format!("espeak-ng playing through {}", cmd[0]),
            Playback::WavOnly => format!(
                "espeak-ng: no audio output (aplay with a sound card, or paplay with a sound server), synthesising to WAV only ({})",
                self.config.wav_dir.as_deref().unwrap_or(&self.scratch_wav).display()
            ),
        }
    }

    fn synth(&self) -> Command {
        let mut c = Command::new(&self.config.program);
        c.arg("-v")
            .arg(&self.config.voice)
            .arg("-s")
            .arg(self.config.rate_wpm.clamp(80, 500).to_string())
            .arg("-a")
            .arg(self.config.volume.min(200).to_string())
            .stdin(Stdio::null())
            .stderr(Stdio::null());
        c
    }

    fn spawn(cmd: &mut Command) -> Result<Child, SpeechError> {
        cmd.spawn().map_err(|source| SpeechError::Spawn { program: format!("{:?}", cmd.get_program()), source })
    }

    /// WAV path of utterance `n` in `dir`.
    pub fn wav_path(dir: &Path, n: u64) -> PathBuf {
        dir.join(format!("{n:06}.wav"))
    }
}

/// Text as one espeak-ng argument: a leading '-' would be read as an option.
fn as_argument(text: &str) -> String {
    if text.starts_with('-') {
        format!(" {text}")
    } else {
        text.to_string()
    }
}

struct EspeakUtterance {
    children: Vec<Child>,
}

impl SpeakingHandle for EspeakUtterance {
    fn is_finished(&mut self, _now_ns: u64) -> bool {
        // A child we cannot query any more cannot be speaking either.
        self.children.iter_mut().all(|c| !matches!(c.try_wait(), Ok(None)))
    }

    fn cut(&mut self) {
        for c in &mut self.children {
            let _ = c.kill();
        }
        for c in &mut self.children {
            let _ = c.wait();
        }
    }
}

impl Drop for EspeakUtterance {
    fn drop(&mut self) {
        if !self.is_finished(0) {
            self.cut();
        }
    }
}

/// The scratch WAV (no audio output, no WAV directory: the last utterance, the status
/// line names it) goes with the engine: a run leaves nothing in the temporary folder.
impl Drop for EspeakEngine {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.scratch_wav);
    }
}

impl SpeechEngine for EspeakEngine {
    fn name(&self) -> &str {
        "espeak"
    }

    fn start(&mut self, text: &str, _priority: Priority, _now_ns: u64) -> Result<Box<dyn SpeakingHandle>, SpeechError> {
        let words = as_argument(text);
        let mut children = Vec::with_capacity(3);
        match &self.playback {
            Playback::Player(cmd) => {
                let mut synth = self.synth();
                let mut voice = Self::spawn(synth.arg("--stdout").arg(&words).stdout(Stdio::piped()))?;
                let audio = voice.stdout.take().map(Stdio::from).unwrap_or_else(Stdio::null);
                let mut play = Command::new(&cmd[0]);
                play.args(&cmd[1..]).stdin(audio).stdout(Stdio::null()).stderr(Stdio::null());
                match Self::spawn(&mut play) {
                    Ok(player) => children.extend([voice, player]),
                    Err(e) => {
                        let _ = voice.kill();
                        let _ = voice.wait();
                        return Err(e);
                    }
                }
            }
            Playback::WavOnly if self.config.wav_dir.is_none() => {
                let mut synth = self.synth();
                children.push(Self::spawn(synth.arg("-w").arg(&self.scratch_wav).arg(&words).stdout(Stdio::null()))?);
            }
            Playback::WavOnly => {}
        }
        if let Some(dir) = &self.config.wav_dir {
            let path = Self::wav_path(dir, self.count);
            let mut synth = self.synth();
            match Self::spawn(synth.arg("-w").arg(&path).arg(&words).stdout(Stdio::null())) {
                Ok(child) => children.push(child),
                Err(e) => tracing::warn!("cannot write {}: {e}", path.display()),
            }
        }
        self.count += 1;
        if children.is_empty() {
            return Err(SpeechError::Unavailable("espeak-ng could not be started".into()));
        }
        Ok(Box::new(EspeakUtterance { children }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leading_dash_is_not_taken_for_an_option() {
        assert_eq!(as_argument("-v stop"), " -v stop");
        assert_eq!(as_argument("stop"), "stop");
    }

    #[test]
    fn unknown_voice_is_refused_at_start() {
        if Command::new("espeak-ng").arg("--version").output().is_err() {
            // scripts/test installs it: under CI a missing espeak-ng is a broken install
            assert!(
                std::env::var_os("CI").is_none_or(|v| v.is_empty()),
                "espeak-ng is not installed (apt-get install espeak-ng); CI is set, so this fails instead of skipping"
            );
            eprintln!(
                "SKIPPED unknown_voice_is_refused_at_start: espeak-ng not installed (with CI set this is a failure)"
            );
            return;
        }
        let cfg = EspeakConfig { voice: "qqq-missing".into(), ..Default::default() };
        let err = EspeakEngine::new(cfg, Playback::WavOnly).err().expect("must fail");
        assert!(err.to_string().contains("no voice \"qqq-missing\""), "{err}");
    }

    #[test]
    fn missing_program_tells_what_to_install() {
        let cfg = EspeakConfig { program: "/nonexistent/espeak-ng".into(), ..Default::default() };
        let err = EspeakEngine::new(cfg, Playback::WavOnly).err().expect("must fail");
        assert!(err.to_string().contains("apt-get install espeak-ng"), "{err}");
    }
}
