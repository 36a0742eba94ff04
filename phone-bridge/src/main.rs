//! `phone-bridge`: serves the wearnav phone app and bridges it to the Zenoh bus.

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;

/// Serve the wearnav phone app (pick a destination, hear guidance, feel cues) and
/// bridge it to one user's Zenoh keys.
///
/// On start it prints the page's address, a QR code of it and a six-digit pairing
/// code (also spoken through the feedback agent); the phone enters the code once.
/// To feel and hear the system on the phone, run the feedback agent with
/// `--haptic phone` and/or `--speech phone`. A desktop browser at `/monitor` shows a
/// sighted helper the scan, the rumble, what is said, the map with the pose and route,
/// and the agents' health.
#[derive(Debug, Parser)]
#[command(version, about, long_about)]
struct Cli {
    #[command(flatten)]
    bus: bus::BusOptions,
    /// Serve HTTPS here (a phone browser needs it for vibration, sensors and speech
    /// input). Default 0.0.0.0:8443.
    #[arg(long, value_name = "ADDR", conflicts_with = "http")]
    https: Option<SocketAddr>,
    /// Serve plain HTTP here instead; loopback addresses only (tests, one machine).
    #[arg(long, value_name = "ADDR")]
    http: Option<SocketAddr>,
    /// Where the bridge keeps the certificate it makes and the paired phones.
    /// Default $XDG_STATE_HOME/wearnav/phone-bridge (~/.local/state/...).
    #[arg(long, value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// Your own certificate chain (PEM) instead of a self-signed one; needs --tls-key.
    #[arg(long, value_name = "FILE", requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// The private key (PEM) of --tls-cert.
    #[arg(long, value_name = "FILE", requires = "tls_cert")]
    tls_key: Option<PathBuf>,
    /// A fixed six-digit pairing code (e.g. for a bridge started at boot), instead of
    /// a new random one each start.
    #[arg(long, value_name = "CODE", env = "WEARNAV_PAIRING_CODE")]
    pairing_code: Option<String>,
    /// The floor map the monitor page draws the pose and route on: the compute agent's
    /// --map (a `building.toml` or its directory).
    #[arg(long, value_name = "PATH")]
    map: Option<PathBuf>,
    /// The compute agent's --perception-config, so the monitor page draws the cost
    /// regions it uses (default: the thesis's).
    #[arg(long, value_name = "FILE")]
    perception_config: Option<PathBuf>,
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    bus::logging::init();
    let cli = Cli::parse();
    let mut config = phone_bridge::PhoneConfig::new(cli.bus);
    if let Some(addr) = cli.http {
        config.serve = phone_bridge::Serve::Http(addr);
    } else if let Some(addr) = cli.https {
        config.serve = phone_bridge::Serve::Https(addr);
    }
    if let Some(dir) = cli.state_dir {
        config.state_dir = dir;
    }
    config.tls = cli.tls_cert.zip(cli.tls_key);
    config.pairing_code = cli.pairing_code;
    if let Some(path) = cli.map {
        let manifest = if path.is_dir() { path.join("building.toml") } else { path };
        let building = map::Building::load(&manifest)
            .with_context(|| format!("cannot load the floor map {} for the monitor page", manifest.display()))?;
        config.map = Some(std::sync::Arc::new(building));
    }
    if let Some(path) = cli.perception_config {
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("cannot read the perception configuration {}", path.display()))?;
        config.perception = perception::PerceptionConfig::from_toml(&text)
            .with_context(|| format!("bad perception configuration {}", path.display()))?;
    }
    let shutdown = bus::Shutdown::new();
    shutdown.trigger_on_signals();
    phone_bridge::run(config, shutdown, None).await
}
