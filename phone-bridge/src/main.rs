//! `phone-bridge`: serves the wearnav page to the user's phone.

use std::net::SocketAddr;

use clap::Parser;

/// Serve the wearnav phone page and bridge it to the Zenoh bus.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(flatten)]
    bus: bus::BusOptions,
    /// Address the phone connects to (reachable from the LAN with 0.0.0.0).
    #[arg(long, default_value = "0.0.0.0:8080")]
    http: SocketAddr,
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    bus::logging::init();
    let cli = Cli::parse();
    let mut config = phone_bridge::PhoneConfig::new(cli.bus);
    config.http = cli.http;
    let shutdown = bus::Shutdown::new();
    shutdown.trigger_on_signals();
    phone_bridge::run(config, shutdown, None).await
}
