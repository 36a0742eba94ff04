//! `feedback-agent`: drive rumble and speech from the intents on the bus.

use clap::Parser;
use feedback_agent::FeedbackConfig;
use tracing_subscriber::EnvFilter;

/// wearnav feedback agent: turns device-neutral haptic and speech intents into Wii
/// remote rumble, espeak-ng speech and console lines, publishes what it did on
/// `feedback/applied`, and tells the user when obstacle detection is offline.
#[derive(Parser)]
#[command(name = "feedback-agent", version)]
struct Cli {
    #[command(flatten)]
    config: FeedbackConfig,
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info")))
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    let shutdown = bus::Shutdown::new();
    shutdown.trigger_on_signals();
    feedback_agent::run(cli.config, shutdown).await
}
