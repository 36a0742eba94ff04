//! `wearnav`: the embedded launcher (every agent in one process) and the tools that
//! run the libraries on recorded data.

mod certs_cmd;
mod codec_cmd;
mod demo;
mod fuzz;
mod guided;
mod localize_cmd;
mod map_cmd;
mod mcap_cmd;
mod perceive;
mod plan_cmd;
mod router_cmd;
mod up_cmd;

use clap::{Parser, Subcommand};

/// wearnav: a navigation aid for blind and visually impaired people. A depth camera on
/// the white cane finds obstacles the cane misses; rumble and speech tell the user.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run every agent in this process on the simulated world, with console feedback
    /// and a live status line; `--destination PLACE` walks the world by the device's
    /// guidance.
    Demo(demo::DemoArgs),
    /// Run the obstacle perception on recorded frames (PCD, 16-bit depth PNG) and
    /// print plane, scan, costs, rumble and stage timings as JSON.
    Perceive(perceive::PerceiveArgs),
    /// Compress a depth image (16-bit PNG or PCD) with the wire codec and print size,
    /// ratio, encode/decode medians and max error: for choosing a mode for your Wi-Fi.
    Codec(codec_cmd::CodecArgs),
    /// Replay Taylor's obstacle-course study with a virtual user who follows the cues,
    /// and print the thesis's table (time, rumble signals, cane and body contacts), then
    /// how many contacts came with no cue felt, with one felt too late to act on (less
    /// than the user's reaction time before), or with one felt in time. A line per walk
    /// goes to stderr as it ends.
    Course(study::CourseArgs),
    /// Feed millions of mutated and random inputs to every decoder of outside input
    /// (wire, depth codec, PCD, PNG, LZF, scene TOML) and report outcomes and panics.
    Fuzz(fuzz::FuzzArgs),
    /// Localize with the particle filter on a recorded laser log (CARMEN) and report the
    /// errors against its poses: RMSE, convergence from a global start, update time.
    Localize(localize_cmd::LocalizeArgs),
    /// Write a floor plan as ROS map_server maps and semantic layers, one per floor:
    /// a simulated world's (walls, doors, rooms, gateways; no furniture) or a CAD
    /// drawing's (DXF: lines and arcs as walls, texts as labels).
    Map(map_cmd::MapArgs),
    /// Plan routes: every scenario of a Moving AI benchmark against its optimal
    /// lengths, or one route on a ROS map_server floor map to a point or a label.
    Plan(plan_cmd::PlanArgs),
    /// Record a user's bus traffic (every message as it crossed the bus) into an MCAP
    /// file, with a progress line a second; until --duration or Ctrl-C.
    Record(mcap_cmd::RecordArgs),
    /// Republish a recorded MCAP session on the bus with its original timing.
    Replay(mcap_cmd::ReplayArgs),
    /// Summarise a recorded MCAP session per key: count, rate, duration, largest gap,
    /// bytes, schema.
    Inspect(mcap_cmd::InspectArgs),
    /// Make the secure profile's certificate authority, a certificate per agent, tool
    /// and monitor, and the router's and clients' Zenoh configurations
    /// (deploy/secure/README.md).
    Certs(certs_cmd::CertsArgs),
    /// Run the deployment's Zenoh router from a configuration file (the secure
    /// profile's enforces its access-control list), until Ctrl-C.
    Router(router_cmd::RouterArgs),
    /// Start this machine's agents from a placement manifest (deploy/hosts/) and
    /// restart one that dies, until Ctrl-C.
    Up(up_cmd::UpArgs),
}

/// Log filter of `wearnav course` (and `localize`, whose `--world` walks the same way)
/// when `RUST_LOG` is unset: a line per walk. The
/// simulated user's devices (detection offline and back, speech) are the walks' own
/// business, counted in their table; `RUST_LOG=info` shows them too.
const COURSE_LOG: &str = "info,zenoh=warn,feedback_agent=error";

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Course(_) | Command::Localize(_) => bus::logging::init_with(COURSE_LOG),
        _ => bus::logging::init(),
    }
    let runtime = tokio::runtime::Runtime::new()?;
    match cli.command {
        Command::Demo(args) => runtime.block_on(demo::run(args)),
        Command::Perceive(args) => perceive::run(&args),
        Command::Codec(args) => codec_cmd::run(&args),
        Command::Course(args) => study::run(&args),
        Command::Fuzz(args) => fuzz::run(&args),
        Command::Localize(args) => localize_cmd::run(&args),
        Command::Map(args) => map_cmd::run(&args),
        Command::Plan(args) => plan_cmd::run(&args),
        Command::Record(args) => runtime.block_on(mcap_cmd::record(args)),
        Command::Replay(args) => runtime.block_on(mcap_cmd::replay(args)),
        Command::Inspect(args) => mcap_cmd::inspect(&args),
        Command::Certs(args) => certs_cmd::run(&args),
        Command::Router(args) => runtime.block_on(router_cmd::run(&args)),
        Command::Up(args) => runtime.block_on(up_cmd::run(&args)),
    }
}
