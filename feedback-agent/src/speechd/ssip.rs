//! SSIP, speech-dispatcher's text protocol (SSIP manual, "Speech Synthesis Interface
//! Protocol"), as pure functions: commands out as bytes, bytes in as replies and events.
//! No socket here, so every byte is testable.
//!
//! - Commands are one line each, ended by CR LF (`SET SELF RATE 10\r\n`).
//! - `SPEAK` is answered `230` and then takes the text as data lines ended by a line
//!   holding a single dot; a data line that starts with a dot gets a second one.
//! - A reply is one or more lines `NNN-...` (continuations) closed by `NNN text`;
//!   2xx is success, 3xx/4xx/5xx an error. `225-<id>` carries the message id.
//! - With notifications on, events arrive at any time as 7xx replies:
//!   `702-<msg id>\r\n702-<client id>\r\n702 END\r\n`.

use schemas::Priority;
use thiserror::Error;

/// SSIP line end.
pub const CRLF: &str = "\r\n";

/// speech-dispatcher's priority name for ours (the two share the SSIP model).
pub fn priority_name(priority: Priority) -> &'static str {
    match priority {
        Priority::Important => "important",
        Priority::Message => "message",
        Priority::Text => "text",
        Priority::Notification => "notification",
        Priority::Progress => "progress",
    }
}

/// espeak-ng rates as speech-dispatcher's espeak-ng module maps SSIP rate -100..100
/// (`EspeakMinRate`, `EspeakNormalRate`, `EspeakMaxRate` in
/// `/etc/speech-dispatcher/modules/espeak-ng.conf`, Debian 0.11.4 defaults).
const ESPEAK_MIN_WPM: i64 = 80;
const ESPEAK_NORMAL_WPM: i64 = 170;
const ESPEAK_MAX_WPM: i64 = 449;

/// SSIP rate (-100..100) that makes the espeak-ng module speak at `rate_wpm`: linear
/// between 80 wpm (-100), 170 wpm (0) and 449 wpm (100), as the module maps it back.
pub fn rate_for_wpm(rate_wpm: u32) -> i32 {
    let wpm = (rate_wpm as i64).clamp(ESPEAK_MIN_WPM, ESPEAK_MAX_WPM);
    let (num, den) = if wpm < ESPEAK_NORMAL_WPM {
        ((wpm - ESPEAK_NORMAL_WPM) * 100, ESPEAK_NORMAL_WPM - ESPEAK_MIN_WPM)
    } else {
        ((wpm - ESPEAK_NORMAL_WPM) * 100, ESPEAK_MAX_WPM - ESPEAK_NORMAL_WPM)
    };
    // Rounded to the nearest step, halves away from zero.
    let rate = (2 * num + num.signum() * den) / (2 * den);
    rate.clamp(-100, 100) as i32
}

/// SSIP volume (-100..100) for an espeak-ng amplitude (0..200, 100 = normal).
/// speech-dispatcher's default volume is its loudest (100, `DefaultVolume` in
/// speechd.conf), so our normal 100 maps to it, 0 to silence (-100); louder than
/// 100 cannot be asked for and is capped.
pub fn volume_for_amplitude(amplitude: u32) -> i32 {
    (amplitude.min(100) as i32) * 2 - 100
}

/// A name usable in `CLIENT_NAME` (`user:application:component`, no colons, no spaces).
pub fn client_name_part(s: &str) -> String {
    let clean: String =
        s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).collect();
    if clean.is_empty() {
        "unknown".into()
    } else {
        clean
    }
}

/// `SET SELF CLIENT_NAME user:wearnav:component`.
pub fn set_client_name(user: &str, component: &str) -> String {
    format!("SET SELF CLIENT_NAME {}:wearnav:{}{CRLF}", client_name_part(user), client_name_part(component))
}

/// `SET SELF PRIORITY <name>`.
pub fn set_priority(priority: Priority) -> String {
    format!("SET SELF PRIORITY {}{CRLF}", priority_name(priority))
}

/// `SET SELF RATE n` for `rate_wpm`.
pub fn set_rate(rate_wpm: u32) -> String {
    format!("SET SELF RATE {}{CRLF}", rate_for_wpm(rate_wpm))
}

/// `SET SELF VOLUME n` for an espeak-ng amplitude.
pub fn set_volume(amplitude: u32) -> String {
    format!("SET SELF VOLUME {}{CRLF}", volume_for_amplitude(amplitude))
}

/// `SET SELF LANGUAGE <voice>`: our voices are espeak-ng language voices (`en`,
/// `en-us`, `fr`); a variant after `+` (`en+f3`) has no SSIP equivalent and is left out.
pub fn set_language(voice: &str) -> String {
    let language = voice.split('+').next().unwrap_or(voice);
    let language: String = language.chars().filter(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == '_').collect();
    format!("SET SELF LANGUAGE {}{CRLF}", if language.is_empty() { "en" } else { &language })
}

/// Notifications the agent needs: when a message ends or is cancelled.
pub const NOTIFY_END: &str = "SET SELF NOTIFICATION END on\r\n";
/// See [`NOTIFY_END`].
pub const NOTIFY_CANCEL: &str = "SET SELF NOTIFICATION CANCEL on\r\n";
/// Start of an utterance; the text follows once the server answered 230.
pub const SPEAK: &str = "SPEAK\r\n";
/// Stop what this client says and drop what it has queued.
pub const CANCEL: &str = "CANCEL SELF\r\n";
/// Polite goodbye.
pub const QUIT: &str = "QUIT\r\n";

/// The data block of `SPEAK`: the text's lines with CR LF ends, a line starting with a
/// dot doubled, then the terminating `.` line. Bare CRs and other control characters
/// become spaces (they carry nothing speakable and a lone CR would confuse line ends).
pub fn speak_data(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 8);
    for line in text.split('\n') {
        let line: String = line.chars().map(|c| if c.is_control() { ' ' } else { c }).collect();
        if line.starts_with('.') {
            out.push('.');
        }
        out.push_str(&line);
        out.push_str(CRLF);
    }
    out.push('.');
    out.push_str(CRLF);
    out
}

/// One complete reply from the server (not an event).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reply {
    /// Three-digit code.
    pub code: u16,
    /// Continuation lines (`225-17` gives `17`).
    pub data: Vec<String>,
    /// Text of the closing line (`OK MESSAGE QUEUED`).
    pub text: String,
}

impl Reply {
    /// 2xx.
    pub fn is_ok(&self) -> bool {
        (200..300).contains(&self.code)
    }

    /// The message id of a `225` reply.
    pub fn message_id(&self) -> Option<u64> {
        (self.code == 225).then(|| self.data.first().and_then(|d| d.trim().parse().ok())).flatten()
    }
}

impl std::fmt::Display for Reply {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.code, self.text)
    }
}

/// What an event says happened to a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EventKind {
    /// 700: an index mark was reached.
    IndexMark,
    /// 701: started speaking.
    Begin,
    /// 702: spoke to its end.
    End,
    /// 703: cancelled.
    Cancel,
    /// 704: paused.
    Pause,
    /// 705: resumed.
    Resume,
}

/// An asynchronous notification about one message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Event {
    /// What happened.
    pub kind: EventKind,
    /// The message (as the `225` reply numbered it).
    pub message_id: u64,
}

/// A complete unit read from the server.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Incoming {
    /// The answer to the oldest command not yet answered.
    Reply(Reply),
    /// A notification, at any time.
    Event(Event),
}

/// The server sent something that is not SSIP.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("not an SSIP reply line: {0:?}")]
pub struct ParseError(pub String);

/// Longest line accepted from the server; longer means it is not speaking SSIP.
pub const MAX_LINE_BYTES: usize = 4096;

/// Splits the byte stream from the server into replies and events. Feed it whatever
/// `read` returned; it keeps incomplete lines for the next call.
#[derive(Debug, Default)]
pub struct ReplyParser {
    buf: Vec<u8>,
    data: Vec<String>,
}

impl ReplyParser {
    /// An empty parser.
    pub fn new() -> Self {
        Self::default()
    }

    /// Append bytes received.
    pub fn feed(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// The next complete reply or event, if one is buffered.
    pub fn pop(&mut self) -> Result<Option<Incoming>, ParseError> {
        loop {
            let Some(end) = self.buf.iter().position(|b| *b == b'\n') else {
                if self.buf.len() > MAX_LINE_BYTES {
                    let head = String::from_utf8_lossy(&self.buf[..64]).into_owned();
                    self.buf.clear();
                    return Err(ParseError(head));
                }
                return Ok(None);
            };
            let line: Vec<u8> = self.buf.drain(..=end).collect();
            let line = String::from_utf8_lossy(&line);
            let line = line.trim_end_matches(['\r', '\n']);
            let bytes = line.as_bytes();
            if bytes.len() < 4 || !bytes[..3].iter().all(u8::is_ascii_digit) || !matches!(bytes[3], b'-' | b' ') {
                self.data.clear();
                return Err(ParseError(line.chars().take(64).collect()));
            }
            let code: u16 = line[..3].parse().map_err(|_| ParseError(line.to_string()))?;
            let rest = line[4..].to_string();
            if bytes[3] == b'-' {
                self.data.push(rest);
                continue;
            }
            let data = std::mem::take(&mut self.data);
            if (700..800).contains(&code) {
                let kind = match code {
                    700 => EventKind::IndexMark,
                    701 => EventKind::Begin,
                    702 => EventKind::End,
                    703 => EventKind::Cancel,
                    704 => EventKind::Pause,
                    705 => EventKind::Resume,
                    _ => return Err(ParseError(line.to_string())),
                };
                let message_id =
                    data.first().and_then(|d| d.trim().parse().ok()).ok_or_else(|| ParseError(line.to_string()))?;
                return Ok(Some(Incoming::Event(Event { kind, message_id })));
            }
            return Ok(Some(Incoming::Reply(Reply { code, data, text: rest })));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_all(bytes: &[u8]) -> Vec<Incoming> {
        let mut p = ReplyParser::new();
        p.feed(bytes);
        let mut out = Vec::new();
        while let Some(m) = p.pop().unwrap() {
            out.push(m);
        }
        out
    }

    #[test]
    fn a_line_starting_with_a_dot_is_doubled_and_the_block_ends_with_a_dot_line() {
        assert_eq!(speak_data("stop"), "stop\r\n.\r\n");
        assert_eq!(speak_data(".\n..x\nok"), "..\r\n...x\r\nok\r\n.\r\n");
        assert_eq!(speak_data("a\r\nb"), "a \r\nb\r\n.\r\n", "a CR before LF becomes a space, never a lone line end");
        assert_eq!(speak_data("tab\there"), "tab here\r\n.\r\n");
    }

    #[test]
    fn priorities_map_one_to_one_to_ssip_names() {
        assert_eq!(set_priority(Priority::Important), "SET SELF PRIORITY important\r\n");
        assert_eq!(set_priority(Priority::Message), "SET SELF PRIORITY message\r\n");
        assert_eq!(set_priority(Priority::Text), "SET SELF PRIORITY text\r\n");
        assert_eq!(set_priority(Priority::Notification), "SET SELF PRIORITY notification\r\n");
        assert_eq!(set_priority(Priority::Progress), "SET SELF PRIORITY progress\r\n");
    }

    #[test]
    fn rate_follows_the_espeak_ng_module_mapping() {
        assert_eq!(rate_for_wpm(170), 0);
        assert_eq!(rate_for_wpm(80), -100);
        assert_eq!(rate_for_wpm(449), 100);
        assert_eq!(rate_for_wpm(175), 2, "5/279 of the way up, rounded");
        assert_eq!(rate_for_wpm(125), -50);
        assert_eq!(rate_for_wpm(20), -100);
        assert_eq!(rate_for_wpm(900), 100);
        assert_eq!(set_rate(350), "SET SELF RATE 65\r\n");
    }

    #[test]
    fn volume_keeps_the_normal_amplitude_at_the_daemon_default() {
        assert_eq!(volume_for_amplitude(100), 100);
        assert_eq!(volume_for_amplitude(50), 0);
        assert_eq!(volume_for_amplitude(0), -100);
        assert_eq!(volume_for_amplitude(200), 100);
    }

    #[test]
    fn client_name_and_language_are_single_safe_words() {
        assert_eq!(
            set_client_name("ali ce:x", "feedback-agent"),
            "SET SELF CLIENT_NAME ali_ce_x:wearnav:feedback-agent\r\n"
        );
        assert_eq!(set_language("en+f3"), "SET SELF LANGUAGE en\r\n");
        assert_eq!(set_language("en-us"), "SET SELF LANGUAGE en-us\r\n");
        assert_eq!(set_language("en\r\nQUIT"), "SET SELF LANGUAGE enQUIT\r\n", "no line break gets through");
    }

    #[test]
    fn replies_with_continuations_and_events_are_split_in_order() {
        let got =
            parse_all(b"230 OK RECEIVING DATA\r\n225-17\r\n225 OK MESSAGE QUEUED\r\n702-17\r\n702-3\r\n702 END\r\n");
        assert_eq!(
            got,
            [
                Incoming::Reply(Reply { code: 230, data: vec![], text: "OK RECEIVING DATA".into() }),
                Incoming::Reply(Reply { code: 225, data: vec!["17".into()], text: "OK MESSAGE QUEUED".into() }),
                Incoming::Event(Event { kind: EventKind::End, message_id: 17 }),
            ]
        );
        match &got[1] {
            Incoming::Reply(r) => assert_eq!((r.is_ok(), r.message_id()), (true, Some(17))),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn partial_lines_wait_for_the_rest() {
        let mut p = ReplyParser::new();
        p.feed(b"703-4\r\n703-");
        assert_eq!(p.pop().unwrap(), None);
        p.feed(b"1\r\n703 CANCELED\r\n");
        assert_eq!(p.pop().unwrap(), Some(Incoming::Event(Event { kind: EventKind::Cancel, message_id: 4 })));
    }

    #[test]
    fn error_codes_are_replies_that_are_not_ok() {
        let got = parse_all(b"409 ERR RATE TOO HIGH\r\n");
        let Incoming::Reply(r) = &got[0] else { panic!("{got:?}") };
        assert!(!r.is_ok());
        assert_eq!(r.to_string(), "409 ERR RATE TOO HIGH");
    }

    #[test]
    fn garbage_is_a_parse_error_not_a_panic() {
        let mut p = ReplyParser::new();
        p.feed(b"HTTP/1.1 400 Bad Request\r\n");
        assert!(p.pop().is_err());
        p.feed(&[b'7'; MAX_LINE_BYTES + 1]);
        assert!(p.pop().is_err(), "an endless line is refused");
        p.feed(b"799 WHAT\r\n");
        assert!(p.pop().is_err(), "unknown event code");
    }
}
