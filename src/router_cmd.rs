//! `wearnav router`: the secure profile's Zenoh router (deploy/secure/README.md), the
//! one node every agent, the phone bridge and every monitor connects to, and the one
//! that enforces the access-control list in its configuration.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context};
use clap::Args;

/// Run a Zenoh router with a configuration file (the secure profile's is written by
/// `wearnav certs`), until Ctrl-C or SIGTERM.
#[derive(Debug, Args)]
pub struct RouterArgs {
    /// Zenoh JSON5 configuration with `mode: "router"` (e.g. DIR/router.json5 from
    /// `wearnav certs --out DIR`).
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: PathBuf,
}

pub async fn run(args: &RouterArgs) -> anyhow::Result<()> {
    let path = &args.zenoh_config;
    let config = zenoh::Config::from_file(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let mode = config.get_json("mode").unwrap_or_default();
    if mode.trim_matches('"') != "router" {
        bail!("{}: mode is {mode}, not \"router\"; this command runs the deployment's router", path.display());
    }
    let listen = config.get_json("listen/endpoints").unwrap_or_default();
    let acl = config.get_json("access_control/enabled").unwrap_or_default();
    let session =
        zenoh::open(config).await.map_err(|e| anyhow!("cannot start the router from {}: {e}", path.display()))?;
    println!("router {} listening on {listen}; access control enabled: {acl}", session.zid());
    tracing::info!("router {} up from {}", session.zid(), path.display());
    wait_for_stop().await.context("waiting for Ctrl-C")?;
    session.close().await.map_err(|e| anyhow!("closing the router: {e}"))?;
    Ok(())
}

async fn wait_for_stop() -> std::io::Result<()> {
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
    tokio::select! {
        r = tokio::signal::ctrl_c() => r,
        _ = term.recv() => Ok(()),
    }
}
