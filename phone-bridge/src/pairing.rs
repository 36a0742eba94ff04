//! Pairing a phone: a six-digit code shown and spoken by the bridge, entered once on
//! the phone, exchanged for a token the page keeps. Without a token the WebSocket is
//! refused, so a stranger on the same Wi-Fi can neither command the system nor read
//! the user's position. Wrong codes are slowed down. Pure apart from the token file.

use std::collections::BTreeSet;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;

/// Wrong codes allowed before each further try must wait.
pub const FREE_TRIES: u32 = 3;
/// Longest wait between tries, seconds.
pub const MAX_WAIT_S: u64 = 60;

/// What a pairing attempt gave.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Attempt {
    /// The code was right: the page keeps this token.
    Paired(String),
    /// The code was wrong; the next try must wait this long (0: at once).
    Wrong {
        /// Seconds until the next try is read.
        retry_after_s: u64,
    },
    /// Tried too soon after too many wrong codes; the code was not even read.
    TooSoon {
        /// Seconds until the next try is read.
        retry_after_s: u64,
    },
}

/// The bridge's pairing state.
#[derive(Debug)]
pub struct Pairing {
    code: String,
    tokens: BTreeSet<String>,
    wrong: u32,
    /// No try is read before this time, ms on the caller's clock.
    locked_until_ms: u64,
    file: Option<PathBuf>,
}

/// Equal without an early exit, so the time taken does not tell how much matched.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len() && a.bytes().zip(b.bytes()).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// A fresh six-digit code.
pub fn new_code() -> String {
    format!("{:06}", rand::random_range(0..1_000_000u32))
}

fn new_token() -> String {
    let bytes: [u8; 16] = rand::random();
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

impl Pairing {
    /// Pairing with `code`, tokens kept only in memory.
    pub fn in_memory(code: String) -> Self {
        Self { code, tokens: BTreeSet::new(), wrong: 0, locked_until_ms: 0, file: None }
    }

    /// Pairing with `code` and the tokens kept in `file` (one per line; made with
    /// owner-only permissions), so phones paired before stay paired after a restart.
    pub fn with_file(code: String, file: &Path) -> anyhow::Result<Self> {
        let tokens = match fs::read_to_string(file) {
            Ok(text) => text.lines().map(str::trim).filter(|t| t.len() == 32).map(str::to_string).collect(),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => BTreeSet::new(),
            Err(e) => return Err(e).with_context(|| format!("cannot read the paired phones in {}", file.display())),
        };
        Ok(Self { file: Some(file.to_path_buf()), tokens, ..Self::in_memory(code) })
    }

    /// The code a phone must enter.
    pub fn code(&self) -> &str {
        &self.code
    }

    /// Phones paired.
    pub fn paired(&self) -> usize {
        self.tokens.len()
    }

    /// Whether `token` was issued by this bridge.
    pub fn is_paired(&self, token: &str) -> bool {
        self.tokens.iter().fold(false, |found, t| found | same(t, token))
    }

    /// Try `code` at `now_ms`. A right code pairs (and the token is saved); after
    /// [`FREE_TRIES`] wrong ones each further try must wait 1, 2, 4 ... up to
    /// [`MAX_WAIT_S`] seconds, and a try before then is not read at all.
    pub fn attempt(&mut self, code: &str, now_ms: u64) -> anyhow::Result<Attempt> {
        if now_ms < self.locked_until_ms {
            return Ok(Attempt::TooSoon { retry_after_s: (self.locked_until_ms - now_ms).div_ceil(1000) });
        }
        if same(code.trim(), &self.code) {
            self.wrong = 0;
            let token = new_token();
            self.tokens.insert(token.clone());
            self.save()?;
            return Ok(Attempt::Paired(token));
        }
        self.wrong += 1;
        let wait_s = match self.wrong.checked_sub(FREE_TRIES) {
            None => 0,
            Some(k) => 1u64.checked_shl(k).unwrap_or(MAX_WAIT_S).min(MAX_WAIT_S),
        };
        self.locked_until_ms = now_ms + wait_s * 1000;
        Ok(Attempt::Wrong { retry_after_s: wait_s })
    }

    fn save(&self) -> anyhow::Result<()> {
        let Some(file) = &self.file else { return Ok(()) };
        let text: String = self.tokens.iter().map(|t| format!("{t}\n")).collect();
        let tmp = file.with_extension("tmp");
        let mut options = fs::OpenOptions::new();
        options.write(true).create(true).truncate(true);
        #[cfg(unix)]
        std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
        let mut f = options.open(&tmp).with_context(|| format!("cannot write {}", tmp.display()))?;
        f.write_all(text.as_bytes())?;
        f.sync_all()?;
        fs::rename(&tmp, file).with_context(|| format!("cannot replace {}", file.display()))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_right_code_gives_a_token_that_opens_and_others_do_not() {
        let mut p = Pairing::in_memory("123456".into());
        assert!(!p.is_paired(""));
        let Attempt::Paired(token) = p.attempt(" 123456 ", 0).unwrap() else { panic!("not paired") };
        assert_eq!(token.len(), 32);
        assert!(p.is_paired(&token));
        assert!(!p.is_paired(&token[..31]) && !p.is_paired(&"0".repeat(32)));
        // a second phone gets its own token
        let Attempt::Paired(other) = p.attempt("123456", 0).unwrap() else { panic!() };
        assert_ne!(token, other);
        assert_eq!(p.paired(), 2);
    }

    #[test]
    fn wrong_codes_are_slowed_down_and_tries_while_waiting_are_not_read() {
        let mut p = Pairing::in_memory("123456".into());
        for _ in 0..FREE_TRIES - 1 {
            assert_eq!(p.attempt("000000", 0).unwrap(), Attempt::Wrong { retry_after_s: 0 });
        }
        assert_eq!(p.attempt("000000", 0).unwrap(), Attempt::Wrong { retry_after_s: 1 });
        // even the right code is not read before the wait is over
        assert_eq!(p.attempt("123456", 500).unwrap(), Attempt::TooSoon { retry_after_s: 1 });
        assert_eq!(p.attempt("000001", 1000).unwrap(), Attempt::Wrong { retry_after_s: 2 });
        assert_eq!(p.attempt("000002", 3000).unwrap(), Attempt::Wrong { retry_after_s: 4 });
        let mut t = 7000;
        for _ in 0..10 {
            let Attempt::Wrong { retry_after_s } = p.attempt("999999", t).unwrap() else { panic!() };
            assert!(retry_after_s <= MAX_WAIT_S);
            t += retry_after_s * 1000;
        }
        assert_eq!(p.attempt("999999", t).unwrap(), Attempt::Wrong { retry_after_s: MAX_WAIT_S });
        assert!(matches!(p.attempt("123456", t + MAX_WAIT_S * 1000).unwrap(), Attempt::Paired(_)));
    }

    #[test]
    fn tokens_survive_a_restart_in_an_owner_only_file() {
        let dir = tempfile::Builder::new().prefix("wearnav-pairing-").tempdir().unwrap();
        let file = dir.path().join("paired-phones");
        let mut p = Pairing::with_file("111111".into(), &file).unwrap();
        let Attempt::Paired(token) = p.attempt("111111", 0).unwrap() else { panic!() };
        let again = Pairing::with_file(new_code(), &file).unwrap();
        assert!(again.is_paired(&token));
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(fs::metadata(&file).unwrap().permissions().mode() & 0o777, 0o600);
        }
    }

    #[test]
    fn codes_are_six_digits() {
        for _ in 0..100 {
            let c = new_code();
            assert!(c.len() == 6 && c.bytes().all(|b| b.is_ascii_digit()), "{c}");
        }
    }
}
