//! Log set-up shared by every binary: `RUST_LOG` filters (default `info` for wearnav,
//! `warn` for Zenoh's own chatter), to stderr so stdout stays for the console backend
//! and machine-readable output.

use tracing_subscriber::EnvFilter;

/// Install the global subscriber; a second call is a no-op.
pub fn init() {
    init_with("info,zenoh=warn");
}

/// [`init`] with another filter when `RUST_LOG` is unset.
pub fn init_with(default_filter: &str) {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default_filter));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).try_init();
}
