//! `feedback-agent`: drive rumble and speech from the intents on the bus.

use clap::Parser;
use feedback_agent::FeedbackConfig;

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
    bus::logging::init();
    let cli = Cli::parse();
    let shutdown = bus::Shutdown::new();
    shutdown.trigger_on_signals();
    feedback_agent::run(cli.config, shutdown).await
}
