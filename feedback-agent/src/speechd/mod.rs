//! speech-dispatcher as a speech engine, spoken to in SSIP over its Unix socket (no C
//! library). The protocol itself is [`ssip`]; this module owns the socket.
//!
//! On connecting, the agent names itself (`CLIENT_NAME`), asks for END and CANCEL
//! notifications and sets the profile's rate, volume and language. Each utterance sets
//! the SSIP priority matching ours (only when it changes) and is sent with `SPEAK`;
//! cutting it off is `CANCEL SELF`. The speech queue of the agent still decides what
//! speaks; the SSIP priority makes speech-dispatcher rank our messages right against
//! other clients on the same machine (a screen reader).
//!
//! Replies are awaited with a short timeout so a hung daemon cannot stall the agent's
//! loop (haptic TTLs run on the same thread): at most one timeout per utterance, and
//! after a failed connection attempt the next one waits `reconnect_ms`. An error reply (3xx/4xx/5xx) is counted
//! and reported; a lost connection is logged once and reopened at the next utterance,
//! which is retried once on the new connection.

pub mod ssip;

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use schemas::Priority;
use thiserror::Error;

use crate::console::spoken_duration_ns;
use crate::device::{SpeakingHandle, SpeechEngine, SpeechError};
use ssip::{Incoming, Reply, ReplyParser};

const MS: u64 = 1_000_000;

/// speech-dispatcher backend settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpeechdConfig {
    /// The daemon's Unix socket.
    pub socket: PathBuf,
    /// User part of `CLIENT_NAME` (the wearnav user).
    pub user: String,
    /// Language voice (`en`, `en-us`), sent as `SET SELF LANGUAGE`.
    pub voice: String,
    /// Words per minute, mapped to the SSIP rate.
    pub rate_wpm: u32,
    /// espeak-ng style amplitude 0..200, mapped to the SSIP volume.
    pub volume: u32,
    /// Longest wait for one reply, ms.
    pub reply_timeout_ms: u64,
    /// After a failed connection attempt, wait this long before the next, ms.
    pub reconnect_ms: u64,
}

impl Default for SpeechdConfig {
    /// 200 ms reply timeout (a local daemon answers in well under 1 ms; 200 ms bounds
    /// the stall of the agent loop by a hung one), reconnect attempts at most once a second.
    fn default() -> Self {
        Self {
            socket: PathBuf::from("speechd.sock"),
            user: "wearnav".into(),
            voice: "en".into(),
            rate_wpm: 175,
            volume: 100,
            reply_timeout_ms: 200,
            reconnect_ms: 1000,
        }
    }
}

/// Where speech-dispatcher listens: `explicit` if given, else `SPEECHD_ADDRESS`
/// (`unix_socket:/path`, or `unix_socket` for the default), else
/// `$XDG_RUNTIME_DIR/speech-dispatcher/speechd.sock`, else the daemon's own fallback
/// `~/.cache/speech-dispatcher/speechd.sock`. Pure: the environment is passed in.
pub fn socket_path(
    explicit: Option<&Path>,
    speechd_address: Option<&str>,
    xdg_runtime_dir: Option<&Path>,
    home: Option<&Path>,
) -> Result<PathBuf, String> {
    if let Some(p) = explicit {
        return Ok(p.to_path_buf());
    }
    if let Some(address) = speechd_address.map(str::trim).filter(|a| !a.is_empty()) {
        let (method, rest) = address.split_once(':').unwrap_or((address, ""));
        match method {
            "unix_socket" if !rest.is_empty() => return Ok(PathBuf::from(rest)),
            "unix_socket" => {}
            _ => {
                return Err(format!(
                    "SPEECHD_ADDRESS={address}: only unix_socket is supported; use --speechd-socket PATH"
                ))
            }
        }
    }
    let dir = match (xdg_runtime_dir, home) {
        (Some(run), _) => run.to_path_buf(),
        (None, Some(home)) => home.join(".cache"),
        (None, None) => return Err("neither XDG_RUNTIME_DIR nor HOME is set; use --speechd-socket PATH".into()),
    };
    Ok(dir.join("speech-dispatcher").join("speechd.sock"))
}

/// [`socket_path`] with this process's environment.
pub fn socket_path_from_env(explicit: Option<&Path>) -> Result<PathBuf, String> {
    let address = std::env::var("SPEECHD_ADDRESS").ok();
    let run = std::env::var_os("XDG_RUNTIME_DIR").map(PathBuf::from);
    let home = std::env::var_os("HOME").map(PathBuf::from);
    socket_path(explicit, address.as_deref(), run.as_deref(), home.as_deref())
}

/// Why talking to the daemon failed.
#[derive(Debug, Error)]
pub enum SsipError {
    /// The socket cannot be opened (daemon not running, wrong path, no permission).
    #[error("cannot connect to {path}: {source}")]
    Connect {
        /// Socket path.
        path: String,
        /// OS error.
        source: std::io::Error,
    },
    /// Reading or writing the socket failed.
    #[error("socket error: {0}")]
    Io(#[from] std::io::Error),
    /// No reply in time.
    #[error("no reply within {0} ms")]
    Timeout(u64),
    /// The daemon closed the connection.
    #[error("the daemon closed the connection")]
    Closed,
    /// No connection, and the next attempt is not due yet.
    #[error("not connected; retrying every {0} ms")]
    NotConnected(u64),
    /// The daemon sent something that is not SSIP.
    #[error(transparent)]
    Parse(#[from] ssip::ParseError),
    /// An error reply (3xx, 4xx, 5xx) or an unexpected one.
    #[error("{command} refused: {reply}")]
    Refused {
        /// The command, without its line end.
        command: String,
        /// The reply.
        reply: Reply,
    },
}

/// Counters of one speech-dispatcher engine, readable while it runs.
#[derive(Debug, Default)]
pub struct SpeechdCounters {
    errors: AtomicU64,
    losses: AtomicU64,
    connects: AtomicU64,
}

impl SpeechdCounters {
    /// Error replies (3xx/4xx/5xx) and unexpected replies received.
    pub fn errors(&self) -> u64 {
        self.errors.load(Ordering::Relaxed)
    }

    /// Connections lost (socket error, timeout, daemon gone).
    pub fn losses(&self) -> u64 {
        self.losses.load(Ordering::Relaxed)
    }

    /// Successful connections, the first one included.
    pub fn connects(&self) -> u64 {
        self.connects.load(Ordering::Relaxed)
    }
}

struct Connection {
    stream: UnixStream,
    parser: ReplyParser,
    timeout_ms: u64,
}

impl Connection {
    fn send(&mut self, bytes: &str) -> Result<(), SsipError> {
        self.stream.write_all(bytes.as_bytes()).map_err(SsipError::Io)
    }

    fn fill(&mut self) -> Result<(), SsipError> {
        let mut buf = [0u8; 1024];
        match self.stream.read(&mut buf) {
            Ok(0) => Err(SsipError::Closed),
            Ok(n) => {
                self.parser.feed(&buf[..n]);
                Ok(())
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                Err(SsipError::Timeout(self.timeout_ms))
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => Ok(()),
            Err(e) => Err(SsipError::Io(e)),
        }
    }
}

/// Message ids remembered as ended, per connection (one utterance speaks at a time,
/// so a handful is plenty).
const ENDED_KEPT: usize = 32;

struct Link {
    config: SpeechdConfig,
    conn: Option<Connection>,
    /// Incremented per connection: a handle from an older one is finished.
    generation: u64,
    /// Priority last set on this connection.
    priority: Option<Priority>,
    /// The daemon accepted END and CANCEL notifications on this connection.
    notifications: bool,
    ended: VecDeque<u64>,
    next_connect_ns: u64,
    /// The latest `now` the engine was given (handles' `cut` gets none).
    last_now_ns: u64,
    /// "connection lost" already logged since the last successful connection.
    loss_logged: bool,
    counters: Arc<SpeechdCounters>,
}

impl Link {
    fn refused(&self, command: &str, reply: Reply) -> SsipError {
        self.counters.errors.fetch_add(1, Ordering::Relaxed);
        SsipError::Refused { command: command.trim_end().to_string(), reply }
    }

    fn conn(&mut self) -> Result<&mut Connection, SsipError> {
        self.conn.as_mut().ok_or(SsipError::Closed)
    }

    /// The next reply; events read on the way are recorded.
    fn reply(&mut self) -> Result<Reply, SsipError> {
        loop {
            let conn = self.conn()?;
            match conn.parser.pop()? {
                Some(Incoming::Reply(r)) => return Ok(r),
                Some(Incoming::Event(e)) => self.note_event(e),
                None => conn.fill()?,
            }
        }
    }

    fn note_event(&mut self, e: ssip::Event) {
        if matches!(e.kind, ssip::EventKind::End | ssip::EventKind::Cancel) {
            if self.ended.len() == ENDED_KEPT {
                self.ended.pop_front();
            }
            self.ended.push_back(e.message_id);
        }
    }

    /// Send `commands` (one or more lines) and collect one reply per line; error
    /// replies are counted and logged but do not fail the batch.
    fn batch(&mut self, commands: &[String]) -> Result<Vec<Reply>, SsipError> {
        let joined: String = commands.concat();
        self.conn()?.send(&joined)?;
        let mut replies = Vec::with_capacity(commands.len());
        for command in commands {
            let r = self.reply()?;
            if !r.is_ok() {
                let e = self.refused(command, r.clone());
                tracing::warn!("speech-dispatcher: {e}");
            }
            replies.push(r);
        }
        Ok(replies)
    }

    fn connect(&mut self, now_ns: u64) -> Result<(), SsipError> {
        self.conn = None;
        self.next_connect_ns = now_ns + self.config.reconnect_ms * MS;
        let path = self.config.socket.display().to_string();
        let stream = UnixStream::connect(&self.config.socket).map_err(|source| SsipError::Connect { path, source })?;
        let timeout = Duration::from_millis(self.config.reply_timeout_ms.max(1));
        stream.set_read_timeout(Some(timeout))?;
        stream.set_write_timeout(Some(timeout))?;
        self.conn = Some(Connection { stream, parser: ReplyParser::new(), timeout_ms: self.config.reply_timeout_ms });
        self.generation += 1;
        self.priority = None;
        self.ended.clear();
        let setup = [
            ssip::set_client_name(&self.config.user, crate::run::AGENT),
            ssip::NOTIFY_END.to_string(),
            ssip::NOTIFY_CANCEL.to_string(),
            ssip::set_rate(self.config.rate_wpm),
            ssip::set_volume(self.config.volume),
            ssip::set_language(&self.config.voice),
        ];
        let replies = match self.batch(&setup) {
            Ok(r) => r,
            Err(e) => {
                self.conn = None;
                return Err(e);
            }
        };
        self.notifications = replies[1].is_ok() && replies[2].is_ok();
        self.counters.connects.fetch_add(1, Ordering::Relaxed);
        if std::mem::take(&mut self.loss_logged) {
            tracing::info!("speech-dispatcher connected again at {}", self.config.socket.display());
        }
        Ok(())
    }

    fn lose(&mut self, e: &SsipError) {
        if self.conn.take().is_some() {
            self.counters.losses.fetch_add(1, Ordering::Relaxed);
            if !self.loss_logged {
                tracing::warn!("speech-dispatcher connection lost ({e}); reconnecting at the next utterance");
            }
            self.loss_logged = true;
            // A closed socket: the next utterance may try at once (the daemon may just
            // have restarted). A daemon that stopped answering gets `reconnect_ms`, so
            // it cannot stall the agent loop on every utterance.
            self.next_connect_ns = match e {
                SsipError::Timeout(_) => self.last_now_ns + self.config.reconnect_ms * MS,
                _ => 0,
            };
        }
    }

    fn ensure(&mut self, now_ns: u64) -> Result<(), SsipError> {
        self.last_now_ns = now_ns;
        if self.conn.is_some() {
            return Ok(());
        }
        if now_ns < self.next_connect_ns {
            return Err(SsipError::NotConnected(self.config.reconnect_ms));
        }
        match self.connect(now_ns) {
            Ok(()) => Ok(()),
            Err(e) => {
                if !self.loss_logged {
                    tracing::warn!(
                        "speech-dispatcher unreachable ({e}); retrying every {} ms",
                        self.config.reconnect_ms
                    );
                    self.loss_logged = true;
                }
                Err(e)
            }
        }
    }

    /// Queue `text` at `priority`; returns the daemon's message id.
    fn speak(&mut self, text: &str, priority: Priority) -> Result<u64, SsipError> {
        let set = (self.priority != Some(priority)).then(|| ssip::set_priority(priority));
        let mut head = set.clone().unwrap_or_default();
        head.push_str(ssip::SPEAK);
        self.conn()?.send(&head)?;
        if let Some(command) = set {
            let r = self.reply()?;
            if r.is_ok() {
                self.priority = Some(priority);
            } else {
                let e = self.refused(&command, r);
                tracing::warn!("speech-dispatcher: {e}");
            }
        }
        let r = self.reply()?;
        if r.code != 230 {
            return Err(self.refused(ssip::SPEAK, r));
        }
        self.conn()?.send(&ssip::speak_data(text))?;
        let r = self.reply()?;
        match r.message_id() {
            Some(id) => Ok(id),
            None => Err(self.refused("SPEAK data", r)),
        }
    }

    /// Read whatever arrived, without waiting.
    fn pump(&mut self) -> Result<(), SsipError> {
        let Some(conn) = self.conn.as_mut() else { return Ok(()) };
        conn.stream.set_nonblocking(true)?;
        let read = loop {
            match conn.fill() {
                Ok(()) => continue,
                Err(SsipError::Timeout(_)) => break Ok(()),
                Err(e) => break Err(e),
            }
        };
        conn.stream.set_nonblocking(false)?;
        read?;
        loop {
            let Some(conn) = self.conn.as_mut() else { return Ok(()) };
            match conn.parser.pop()? {
                Some(Incoming::Event(e)) => self.note_event(e),
                Some(Incoming::Reply(r)) => {
                    // No command is waiting for it: the daemon and we disagree.
                    return Err(SsipError::Parse(ssip::ParseError(format!("unexpected reply {r}"))));
                }
                None => return Ok(()),
            }
        }
    }
}

/// speech-dispatcher, over SSIP on its Unix socket.
pub struct SpeechdEngine {
    link: Arc<Mutex<Link>>,
    counters: Arc<SpeechdCounters>,
    rate_wpm: u32,
}

fn lock(link: &Mutex<Link>) -> MutexGuard<'_, Link> {
    link.lock().unwrap_or_else(|e| e.into_inner())
}

impl SpeechdEngine {
    /// Connect to the daemon at `config.socket` and set the profile; fails with what to
    /// do when the daemon is not there.
    pub fn new(config: SpeechdConfig) -> Result<Self, SpeechError> {
        let counters = Arc::new(SpeechdCounters::default());
        let rate_wpm = config.rate_wpm;
        let mut link = Link {
            config,
            conn: None,
            generation: 0,
            priority: None,
            notifications: false,
            ended: VecDeque::new(),
            next_connect_ns: 0,
            last_now_ns: 0,
            loss_logged: false,
            counters: counters.clone(),
        };
        link.connect(0).map_err(|e| {
            SpeechError::Unavailable(format!(
                "speech-dispatcher: {e}; start it with `speech-dispatcher -d` (Debian: apt-get install speech-dispatcher speech-dispatcher-espeak-ng) or give --speechd-socket"
            ))
        })?;
        Ok(Self { link: Arc::new(Mutex::new(link)), counters, rate_wpm })
    }

    /// Error, loss and connection counts, shared with the running engine.
    pub fn counters(&self) -> Arc<SpeechdCounters> {
        self.counters.clone()
    }

    /// What the engine talks to, for the start-up status line.
    pub fn describe(&self) -> String {
        let link = lock(&self.link);
        let ends =
            if link.notifications { "end notifications on" } else { "no end notifications: utterance ends estimated" };
        format!("speech-dispatcher at {} ({ends})", link.config.socket.display())
    }
}

impl Drop for SpeechdEngine {
    fn drop(&mut self) {
        let mut link = lock(&self.link);
        if let Some(conn) = link.conn.as_mut() {
            // Best effort: the daemon drops a client's state when its socket closes anyway.
            let _ = conn.send(ssip::QUIT);
        }
    }
}

struct SpeechdUtterance {
    link: Arc<Mutex<Link>>,
    generation: u64,
    message_id: u64,
    /// Without end notifications the utterance is taken as finished at this estimate.
    estimated_end_ns: u64,
    /// Even with notifications, never wait past this (a lost event must not stall the queue).
    give_up_ns: u64,
    done: bool,
}

impl SpeakingHandle for SpeechdUtterance {
    fn is_finished(&mut self, now_ns: u64) -> bool {
        if self.done {
            return true;
        }
        let mut link = lock(&self.link);
        link.last_now_ns = link.last_now_ns.max(now_ns);
        if link.generation != self.generation || link.conn.is_none() {
            self.done = true;
            return true;
        }
        if let Err(e) = link.pump() {
            link.lose(&e);
            self.done = true;
            return true;
        }
        self.done = link.ended.contains(&self.message_id)
            || (!link.notifications && now_ns >= self.estimated_end_ns)
            || now_ns >= self.give_up_ns;
        self.done
    }

    fn cut(&mut self) {
        self.done = true;
        let mut link = lock(&self.link);
        if link.generation != self.generation || link.conn.is_none() {
            return;
        }
        let cancelled = link.batch(&[ssip::CANCEL.to_string()]);
        if let Err(e) = cancelled {
            link.lose(&e);
        }
    }
}

impl SpeechEngine for SpeechdEngine {
    fn name(&self) -> &str {
        "speechd"
    }

    fn start(&mut self, text: &str, priority: Priority, now_ns: u64) -> Result<Box<dyn SpeakingHandle>, SpeechError> {
        let mut link = lock(&self.link);
        let mut attempts = 0;
        let message_id = loop {
            attempts += 1;
            let fresh = link.conn.is_none();
            if let Err(e) = link.ensure(now_ns) {
                return Err(SpeechError::Unavailable(format!("speech-dispatcher: {e}")));
            }
            match link.speak(text, priority) {
                Ok(id) => break id,
                Err(e @ SsipError::Refused { .. }) => {
                    let n = link.counters.errors();
                    return Err(SpeechError::Unavailable(format!("speech-dispatcher: {e} (error {n} since start)")));
                }
                Err(e) => {
                    // A connection that worked before may just be stale (daemon
                    // restarted): one retry on a new one. Not after a timeout: a hung
                    // daemon would stall the agent's loop twice.
                    let stale = matches!(e, SsipError::Closed | SsipError::Io(_));
                    link.lose(&e);
                    if fresh || attempts > 1 || !stale {
                        return Err(SpeechError::Unavailable(format!("speech-dispatcher: {e}")));
                    }
                }
            }
        };
        let estimate_ns = spoken_duration_ns(text, self.rate_wpm);
        Ok(Box::new(SpeechdUtterance {
            link: self.link.clone(),
            generation: link.generation,
            message_id,
            estimated_end_ns: now_ns + estimate_ns,
            give_up_ns: now_ns + 2 * estimate_ns + 5_000 * MS,
            done: false,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explicit_socket_wins_then_speechd_address_then_runtime_dir() {
        let run = Path::new("/run/user/1000");
        let home = Path::new("/home/a");
        assert_eq!(
            socket_path(Some(Path::new("/tmp/s")), Some("unix_socket:/x"), Some(run), None).unwrap(),
            PathBuf::from("/tmp/s")
        );
        assert_eq!(
            socket_path(None, Some("unix_socket:/x/y.sock"), Some(run), None).unwrap(),
            PathBuf::from("/x/y.sock")
        );
        assert_eq!(
            socket_path(None, Some("unix_socket"), Some(run), None).unwrap(),
            PathBuf::from("/run/user/1000/speech-dispatcher/speechd.sock")
        );
        assert_eq!(
            socket_path(None, None, None, Some(home)).unwrap(),
            PathBuf::from("/home/a/.cache/speech-dispatcher/speechd.sock")
        );
        let inet = socket_path(None, Some("inet_socket:127.0.0.1:6560"), Some(run), None).unwrap_err();
        assert!(inet.contains("only unix_socket"), "{inet}");
        assert!(socket_path(None, None, None, None).is_err());
    }

    #[test]
    fn missing_daemon_tells_how_to_start_it() {
        let config = SpeechdConfig { socket: "/nonexistent/speechd.sock".into(), ..Default::default() };
        let err = SpeechdEngine::new(config).err().expect("no daemon there");
        let text = err.to_string();
        assert!(text.contains("cannot connect to /nonexistent/speechd.sock"), "{text}");
        assert!(text.contains("speech-dispatcher -d"), "{text}");
    }
}
