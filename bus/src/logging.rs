//! Log set-up shared by every binary: `RUST_LOG` filters (default `info` for wearnav,
//! `warn` for Zenoh's own chatter), to stderr so stdout stays for the console backend
//! and machine-readable output.

use std::sync::atomic::{AtomicBool, Ordering};

use tracing_subscriber::filter::{dynamic_filter_fn, FilterExt};
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::{EnvFilter, Layer};

/// Set once the process has begun to close its sessions ([`closing`]).
static CLOSING: AtomicBool = AtomicBool::new(false);

/// The target of Zenoh's session errors.
const ZENOH_SESSION: &str = "zenoh::api::session";

/// Install the global subscriber; a second call is a no-op.
pub fn init() {
    init_with("info,zenoh=warn");
}

/// [`init`] with another filter when `RUST_LOG` is unset.
pub fn init_with(default_filter: &str) {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default_filter));
    let _ = tracing_subscriber::registry().with(layer(filter, std::io::stderr)).try_init();
}

/// Lines to `writer` as `filter` says, less Zenoh's session errors once [`closing`].
fn layer<S, W>(filter: EnvFilter, writer: W) -> impl Layer<S>
where
    S: tracing::Subscriber + for<'a> tracing_subscriber::registry::LookupSpan<'a>,
    W: for<'w> tracing_subscriber::fmt::MakeWriter<'w> + 'static,
{
    let open = dynamic_filter_fn(|meta, _| !(meta.target() == ZENOH_SESSION && CLOSING.load(Ordering::Relaxed)));
    tracing_subscriber::fmt::layer().with_writer(writer).with_filter(filter.and(open))
}

/// The process has begun to close its Zenoh sessions ([`crate::Shutdown::trigger_exit`]
/// says so): Zenoh's session errors are no longer printed. Data a peer still sends
/// while a session closes, or to a subscriber it has just withdrawn, arrives for a key
/// expression it no longer knows, and Zenoh logs each such message at ERROR
/// ("Received Data for unknown expr_id: 11", "... unknown key_expr: Remote resource 12
/// not found"): every demo ended with one to three of them, about nothing wrong.
pub fn closing() {
    CLOSING.store(true, Ordering::Relaxed);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// A writer into a shared buffer.
    #[derive(Clone, Default)]
    struct Lines(Arc<Mutex<Vec<u8>>>);

    impl std::io::Write for Lines {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn zenohs_session_errors_are_printed_until_the_process_closes_its_sessions_and_ours_after_too() {
        let lines = Lines::default();
        let writer = lines.clone();
        let subscriber =
            tracing_subscriber::registry().with(layer(EnvFilter::new("info,zenoh=warn"), move || writer.clone()));
        tracing::subscriber::with_default(subscriber, || {
            tracing::error!(target: "zenoh::api::session", "Received Data for unknown expr_id: 3");
            tracing::info!(target: "zenoh::api::session", "below zenoh's level");
            closing();
            tracing::error!(target: "zenoh::api::session", "Received Data for unknown expr_id: 11");
            tracing::error!(target: "zenoh::net::routing", "another part of zenoh");
            tracing::error!(target: "compute_agent::run", "ours");
        });
        let text = String::from_utf8(lines.0.lock().unwrap().clone()).unwrap();
        assert_eq!(text.lines().count(), 3, "{text}");
        for (said, printed) in [
            ("unknown expr_id: 3", true),
            ("below zenoh's level", false),
            ("unknown expr_id: 11", false),
            ("another part of zenoh", true),
            ("ours", true),
        ] {
            assert_eq!(text.contains(said), printed, "{said:?} in {text}");
        }
    }
}
