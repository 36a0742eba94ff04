//! Console backends: one clear line per change, for the demo and for sighted helpers
//! (`RUMBLE left`, `RUMBLE off`, `SPEAK "..."`).

use std::io::Write;
use std::sync::{Arc, Mutex};

use schemas::{AppliedAction, HapticPattern, Priority};

use crate::device::{DeviceOutput, HapticDevice, SpeakingHandle, SpeechEngine, SpeechError};
use crate::haptic_cue::Levels;

/// Where console lines go (stdout for the binary, a buffer in tests).
pub type Sink = Box<dyn Write + Send>;

/// The words of a rumble line: `off`, `left`, `right`, `both`, with levels below 1.
pub fn rumble_words(levels: Levels) -> String {
    let side = |v: f32| v > 0.0;
    let name = match (side(levels.left), side(levels.right)) {
        (false, false) => return "off".to_string(),
        (true, false) => "left",
        (false, true) => "right",
        (true, true) => "both",
    };
    let weak: Vec<String> = [("left", levels.left), ("right", levels.right)]
        .iter()
        .filter(|(_, v)| *v > 0.0 && *v < 1.0)
        .map(|(s, v)| format!("{s} {v:.2}"))
        .collect();
    if weak.is_empty() {
        name.to_string()
    } else {
        format!("{name} ({})", weak.join(", "))
    }
}

/// Prints `RUMBLE ...` whenever the felt levels change.
pub struct ConsoleHaptic {
    sink: Sink,
    shown: Option<Levels>,
}

impl ConsoleHaptic {
    /// Print to `sink`.
    pub fn new(sink: Sink) -> Self {
        Self { sink, shown: None }
    }

    /// Print to stdout.
    pub fn stdout() -> Self {
        Self::new(Box::new(std::io::stdout()))
    }
}

impl HapticDevice for ConsoleHaptic {
    fn name(&self) -> &str {
        "console"
    }

    fn set_levels(
        &mut self,
        levels: Levels,
        pattern: HapticPattern,
        cause_ns: u64,
        now_ns: u64,
        _refresh: bool,
        out: &mut DeviceOutput,
    ) {
        if self.shown == Some(levels) {
            return;
        }
        // A console that cannot be written to is not a reason to stop feeding the
        // other devices; the applied record still says what was meant.
        let _ = writeln!(self.sink, "RUMBLE {}", rumble_words(levels));
        let _ = self.sink.flush();
        self.shown = Some(levels);
        out.applied(
            "console",
            AppliedAction::Rumble { left: levels.left, right: levels.right, pattern },
            now_ns,
            cause_ns,
        );
    }

    fn off(&mut self, now_ns: u64, out: &mut DeviceOutput) {
        self.set_levels(Levels::OFF, HapticPattern::Steady, 0, now_ns, false, out);
    }
}

/// Prints `SPEAK "..."` (and `SPEAK cut "..."` when one is cut off) and pretends to
/// speak for as long as a voice at `rate_wpm` would, so queueing and cut-offs behave
/// as with a real voice.
pub struct ConsoleSpeech {
    sink: Arc<Mutex<Sink>>,
    rate_wpm: u32,
}

fn print_line(sink: &Mutex<Sink>, line: std::fmt::Arguments<'_>) {
    // A console that cannot be written to must not stop the other devices.
    let mut sink = sink.lock().unwrap_or_else(|e| e.into_inner());
    let _ = sink.write_fmt(line);
    let _ = sink.write_all(b"\n");
    let _ = sink.flush();
}

impl ConsoleSpeech {
    /// Print to `sink`, timing utterances at `rate_wpm` words per minute.
    pub fn new(sink: Sink, rate_wpm: u32) -> Self {
        Self { sink: Arc::new(Mutex::new(sink)), rate_wpm: rate_wpm.max(1) }
    }

    /// Print to stdout.
    pub fn stdout(rate_wpm: u32) -> Self {
        Self::new(Box::new(std::io::stdout()), rate_wpm)
    }
}

/// How long `text` takes to say at `rate_wpm`, ns (at least 300 ms).
pub fn spoken_duration_ns(text: &str, rate_wpm: u32) -> u64 {
    let words = text.split_whitespace().count().max(1) as u64;
    (words * 60_000_000_000 / rate_wpm.max(1) as u64).max(300_000_000)
}

struct ConsoleUtterance {
    sink: Arc<Mutex<Sink>>,
    text: String,
    ends_ns: u64,
    cut: bool,
}

impl SpeakingHandle for ConsoleUtterance {
    fn is_finished(&mut self, now_ns: u64) -> bool {
        self.cut || now_ns >= self.ends_ns
    }

    fn cut(&mut self) {
        if !self.cut {
            self.cut = true;
            print_line(&self.sink, format_args!("SPEAK cut {:?}", self.text));
        }
    }
}

impl SpeechEngine for ConsoleSpeech {
    fn name(&self) -> &str {
        "console"
    }

    fn start(&mut self, text: &str, _priority: Priority, now_ns: u64) -> Result<Box<dyn SpeakingHandle>, SpeechError> {
        print_line(&self.sink, format_args!("SPEAK {text:?}"));
        Ok(Box::new(ConsoleUtterance {
            sink: self.sink.clone(),
            text: text.to_string(),
            ends_ns: now_ns + spoken_duration_ns(text, self.rate_wpm),
            cut: false,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);
    impl Write for Shared {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(b);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn one_line_per_change_only() {
        let buf = Shared::default();
        let mut c = ConsoleHaptic::new(Box::new(buf.clone()));
        let mut out = DeviceOutput::default();
        let left = Levels { left: 1.0, right: 0.0 };
        c.set_levels(left, HapticPattern::Steady, 5, 10, true, &mut out);
        c.set_levels(left, HapticPattern::Steady, 6, 11, true, &mut out);
        c.set_levels(Levels::OFF, HapticPattern::Steady, 7, 12, false, &mut out);
        c.set_levels(Levels { left: 0.5, right: 1.0 }, HapticPattern::Steady, 8, 13, false, &mut out);
        let text = String::from_utf8(buf.0.lock().unwrap().clone()).unwrap();
        assert_eq!(text, "RUMBLE left\nRUMBLE off\nRUMBLE both (left 0.50)\n");
        assert_eq!(out.applied.len(), 3);
        assert_eq!(out.applied[0].cause_capture_ns, 5);
    }

    #[test]
    fn console_speech_lasts_as_long_as_the_words_at_the_rate() {
        let buf = Shared::default();
        let mut s = ConsoleSpeech::new(Box::new(buf.clone()), 120);
        let mut h = s.start("turn left now please", Priority::Message, 0).unwrap();
        assert!(!h.is_finished(1_999_999_999));
        assert!(h.is_finished(2_000_000_000));
        h.cut();
        h.cut();
        assert!(h.is_finished(0));
        assert_eq!(
            String::from_utf8(buf.0.lock().unwrap().clone()).unwrap(),
            "SPEAK \"turn left now please\"\nSPEAK cut \"turn left now please\"\n"
        );
    }
}
