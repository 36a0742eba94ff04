//! Opening a Zenoh session from a JSON5 file, `ZENOH_CONFIG`, or the zero-configuration
//! default (peer mode, multicast scouting: agents on one LAN find each other).

use std::path::PathBuf;

use anyhow::{anyhow, Context};
use zenoh::{Config, Session};

/// How an agent reaches the bus and whose key space it uses; every agent CLI flattens
/// these flags, so they read the same everywhere.
#[derive(Debug, Clone, clap::Args)]
pub struct BusOptions {
    /// User name: the key prefix `wearnav/<user>` (several people can share a LAN).
    #[arg(long, default_value = "demo", env = "WEARNAV_USER")]
    pub user: String,
    /// Zenoh JSON5 configuration file (default: $ZENOH_CONFIG, else peer mode with
    /// multicast scouting, so agents on one LAN find each other with no configuration).
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
    /// Endpoint to connect to, e.g. `tcp/192.168.1.20:7447` (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Endpoint to listen on, e.g. `tcp/0.0.0.0:7447` (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Turn multicast scouting off (loopback tests, networks that block multicast).
    #[arg(long)]
    pub no_multicast: bool,
}

impl BusOptions {
    /// Options for `user` with the zero-configuration defaults.
    pub fn for_user(user: &str) -> Self {
        Self { user: user.to_string(), zenoh_config: None, connect: vec![], listen: vec![], no_multicast: false }
    }

    /// The user's typed key builder; fails on a name that cannot be a key chunk.
    pub fn keys(&self) -> anyhow::Result<schemas::Keys> {
        schemas::Keys::new(&self.user).with_context(|| format!("bad --user {:?}", self.user))
    }
}

fn json_list(items: &[String]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("{s:?}")).collect();
    format!("[{}]", quoted.join(","))
}

/// Build the Zenoh configuration the options describe.
pub fn zenoh_config(opts: &BusOptions) -> anyhow::Result<Config> {
    let mut config = match &opts.zenoh_config {
        Some(path) => Config::from_file(path)
            .map_err(|e| anyhow!("{e}"))
            .with_context(|| format!("cannot read Zenoh config {}", path.display()))?,
        None if std::env::var_os("ZENOH_CONFIG").is_some() => Config::from_env()
            .map_err(|e| anyhow!("{e}"))
            .context("cannot read the Zenoh config named by $ZENOH_CONFIG")?,
        None => Config::default(),
    };
    if !opts.connect.is_empty() {
        config
            .insert_json5("connect/endpoints", &json_list(&opts.connect))
            .map_err(|e| anyhow!("{e}"))
            .context("bad --connect endpoint")?;
    }
    if !opts.listen.is_empty() {
        config
            .insert_json5("listen/endpoints", &json_list(&opts.listen))
            .map_err(|e| anyhow!("{e}"))
            .context("bad --listen endpoint")?;
    }
    if opts.no_multicast {
        config.insert_json5("scouting/multicast/enabled", "false").map_err(|e| anyhow!("{e}"))?;
    }
    Ok(config)
}

/// Open a session as the options say.
pub async fn open_session(opts: &BusOptions) -> anyhow::Result<Session> {
    let config = zenoh_config(opts)?;
    zenoh::open(config)
        .await
        .map_err(|e| anyhow!("{e}"))
        .context("cannot open the Zenoh session (check --connect/--listen endpoints and the config file)")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deploy_configs_load_and_flags_override_them() {
        for file in ["lan-peer.json5", "peer-lan.json5", "loopback-test.json5", "router.json5", "client.json5"] {
            let mut opts = BusOptions::for_user("x");
            opts.zenoh_config = Some(PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy/")).join(file));
            opts.connect = vec!["tcp/127.0.0.1:7447".into()];
            let config = zenoh_config(&opts).unwrap_or_else(|e| panic!("{file}: {e:#}"));
            let connect = config.get_json("connect/endpoints").unwrap();
            assert!(connect.contains("tcp/127.0.0.1:7447"), "{file}: {connect}");
        }
    }

    #[test]
    fn a_missing_config_file_is_named_in_the_error() {
        let mut opts = BusOptions::for_user("x");
        opts.zenoh_config = Some(PathBuf::from("/nonexistent/zenoh.json5"));
        let err = format!("{:#}", zenoh_config(&opts).unwrap_err());
        assert!(err.contains("/nonexistent/zenoh.json5"), "{err}");
    }

    #[test]
    fn bad_endpoints_are_refused() {
        let mut opts = BusOptions::for_user("x");
        opts.connect = vec!["not an endpoint".into()];
        assert!(zenoh_config(&opts).is_err());
    }
}
