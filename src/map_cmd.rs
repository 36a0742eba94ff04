//! `wearnav map`: a simulated world's floor plan as files other tools read: per floor a
//! ROS `map_server` map (YAML + PGM) and a semantic layer (TOML), and a building
//! manifest naming them. Walls, doors, rooms, corners and gateways only; no furniture:
//! what a building's plan shows, and what the planner plans on.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use sensor_agent::sim::World;

/// Export a simulated world's floor plan.
#[derive(Debug, Args)]
#[command(after_help = "Example:\n  wearnav map --world building --out maps/building\n  \
    wearnav plan --map maps/building/floor0.yaml --semantic maps/building/floor0.toml --from 2,7.5 --to entrance")]
pub struct MapArgs {
    /// A built-in world (taylor-course, open-course, corridor, approach, building,
    /// step-down, sign-ahead) or a scene file (TOML).
    #[arg(long, value_name = "WORLD")]
    world: String,
    /// Directory to write `building.toml` and `floor<N>.{yaml,pgm,toml}` into (made if
    /// missing; files of the same names are replaced).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Cell size, metres.
    #[arg(long, value_name = "M", default_value_t = study::floor_plan::DEFAULT_RESOLUTION_M)]
    resolution: f64,
}

/// Run `wearnav map`.
pub fn run(args: &MapArgs) -> anyhow::Result<()> {
    let world = World::load(&args.world).with_context(|| format!("cannot load world {:?}", args.world))?;
    let building = study::floor_plan::export(&world, args.resolution)
        .with_context(|| format!("cannot make a floor plan of {}", world.name()))?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let manifest = args.out.join("building.toml");
    building.write(&manifest)?;
    println!("{}: {}", world.name(), manifest.display());
    for floor in building.floors() {
        let s = &floor.semantic;
        println!(
            "  floor {}: {}x{} cells at {} m, {} labels, {} doors, {} corners, {} areas, {} gateways -> floor{}.yaml, floor{}.toml",
            floor.level,
            floor.grid.width(),
            floor.grid.height(),
            floor.grid.resolution_m(),
            s.labels.len(),
            s.doors.len(),
            s.corners.len(),
            s.areas.len(),
            s.gateways.len(),
            floor.level,
            floor.level
        );
    }
    Ok(())
}
