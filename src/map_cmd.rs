//! `wearnav map`: a floor plan as files other tools read: per floor a ROS `map_server`
//! map (YAML + PGM) and a semantic layer (TOML), and a building manifest naming them.
//! The plan comes from a simulated world (walls, doors, rooms, corners and gateways; no
//! furniture: what a building's plan shows, and what the planner plans on) or from an
//! architect's CAD drawing (DXF: walls from its lines, labels from its texts; one floor).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{ArgGroup, Args};
use map::dxf::{DxfImport, DEFAULT_WALL_THICKNESS_M};
use map::{Building, Floor, Units};
use sensor_agent::sim::World;

/// Export a simulated world's floor plan, or import a CAD floor plan (DXF).
#[derive(Debug, Args)]
#[command(
    group(ArgGroup::new("source").required(true).args(["world", "dxf"])),
    after_help = "Examples:\n  wearnav map --world building --out maps/building\n  \
    wearnav plan --map maps/building/floor0.yaml --semantic maps/building/floor0.toml --from 2,7.5 --to entrance\n  \
    wearnav map --dxf compute-agent/map/tests/data/floor.dxf --wall-layers WALLS --out maps/office\n  \
    wearnav plan --map maps/office/floor0.yaml --semantic maps/office/floor0.toml --from 1,6 --to \"room 104\""
)]
pub struct MapArgs {
    /// A built-in world (taylor-course, open-course, corridor, approach, building,
    /// step-down, sign-ahead) or a scene file (TOML).
    #[arg(long, value_name = "WORLD")]
    world: Option<String>,
    /// A CAD floor plan, ASCII DXF (R12 to R2018): LINE, LWPOLYLINE, POLYLINE, ARC and
    /// CIRCLE (also inside inserted blocks) become walls, TEXT and MTEXT labels; the
    /// grid is free inside the drawing's extent, unknown around it. One floor, level 0
    /// (docs/planning.md, "Floor plans from CAD").
    #[arg(long, value_name = "FILE.dxf")]
    dxf: Option<PathBuf>,
    /// Directory to write `building.toml` and `floor<N>.{yaml,pgm,toml}` into (made if
    /// missing; files of the same names are replaced).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// With --world: the map a mapping run would record instead of the plan: also the
    /// furniture and hanging obstacles in the cane camera's obstacle band (0.04-2.0 m),
    /// no people and no chairs (they move). For the compute agent's localization: on
    /// walls alone the filter is metres off in furnished rooms (docs/localization.md);
    /// routes planned on it go round the furniture too.
    #[arg(long, conflicts_with = "dxf")]
    mapped: bool,
    /// Cell size, metres.
    #[arg(long, value_name = "M", default_value_t = study::floor_plan::DEFAULT_RESOLUTION_M)]
    resolution: f64,
    /// With --dxf: the width every wall line is drawn with, metres [default: 0.15]. For
    /// walls drawn as their two faces rather than their centre line, give 0.05.
    #[arg(long, value_name = "M", conflicts_with = "world")]
    wall_thickness: Option<f64>,
    /// With --dxf: the unit the drawing is in, overriding its $INSUNITS; needed when
    /// the drawing has none (every R12 file).
    #[arg(long, value_name = "mm|cm|m|in|ft", conflicts_with = "world")]
    units: Option<Units>,
    /// With --dxf: the layers whose lines are walls (names without case) [default:
    /// every layer]. Leave out door swings, furniture and dimension lines this way: a
    /// door swing drawn as an arc on a wall layer closes the door.
    #[arg(long, value_name = "A,B", value_delimiter = ',', conflicts_with = "world")]
    wall_layers: Option<Vec<String>>,
    /// With --dxf: the layers whose texts become labels [default: every layer].
    #[arg(long, value_name = "A,B", value_delimiter = ',', conflicts_with = "world")]
    label_layers: Option<Vec<String>>,
    /// With --dxf: where north lies on the drawing, degrees counter-clockwise from its
    /// +x axis (90: north is up), as the plan's north arrow shows it. Lets the compute
    /// agent read the worn phone's compass on the map; without it no compass is read.
    /// (A simulated world's north is its +y axis, 90.)
    #[arg(long, value_name = "DEG", conflicts_with = "world", allow_negative_numbers = true)]
    north_deg: Option<f64>,
}

/// Run `wearnav map`.
pub fn run(args: &MapArgs) -> anyhow::Result<()> {
    let (name, building) = match (&args.world, &args.dxf) {
        (Some(world), _) => {
            let world = World::load(world).with_context(|| format!("cannot load world {world:?}"))?;
            use study::floor_plan::LocalizationMap;
            let kind = if args.mapped { LocalizationMap::Mapped } else { LocalizationMap::FloorPlan };
            let building = kind
                .export(&world, args.resolution, &perception::PerceptionConfig::default())
                .with_context(|| format!("cannot make a floor plan of {}", world.name()))?;
            (world.name().to_string(), building)
        }
        (None, Some(dxf)) => (dxf.display().to_string(), import_dxf(args, dxf)?),
        (None, None) => anyhow::bail!("give --world WORLD or --dxf FILE.dxf (see --help)"),
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let manifest = args.out.join("building.toml");
    building.write(&manifest)?;
    let north = building.floors().iter().find_map(|f| f.semantic.north_deg);
    let north = north.map_or("no north: no compass is read on it".to_string(), |n| format!("north at {n:.1}° from +x"));
    println!("{name}: {} ({north})", manifest.display());
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

/// The drawing as a one-floor building, with what was read and left out on stdout.
fn import_dxf(args: &MapArgs, dxf: &Path) -> anyhow::Result<Building> {
    let options = DxfImport {
        resolution_m: args.resolution,
        wall_thickness_m: args.wall_thickness.unwrap_or(DEFAULT_WALL_THICKNESS_M),
        units: args.units,
        wall_layers: args.wall_layers.clone(),
        label_layers: args.label_layers.clone(),
        ..DxfImport::default()
    };
    let floor = options.load(dxf).with_context(|| format!("cannot make a floor map of {}", dxf.display()))?;
    let r = &floor.report;
    let [x0, y0, x1, y1] = r.extent_m;
    let version = if r.version.is_empty() { "no $ACADVER".to_string() } else { r.version.clone() };
    println!(
        "{}: DXF {version}, read in {}{}; {:.2} x {:.2} m from ({x0:.2}, {y0:.2})",
        dxf.display(),
        r.units,
        if args.units.is_some() { " as told" } else { " ($INSUNITS)" },
        x1 - x0,
        y1 - y0
    );
    let walls_on = args.wall_layers.as_ref().map_or("every layer".to_string(), |l| l.join(", "));
    println!(
        "  walls: {} entities ({} segments) on {walls_on}; layers with lines or texts: {}",
        r.wall_entities,
        r.wall_segments,
        r.layers.join(", ")
    );
    if !r.skipped.is_empty() {
        let skipped: Vec<String> = r.skipped.iter().map(|(kind, n)| format!("{n} {kind}")).collect();
        println!("  not read: {}", skipped.join(", "));
    }
    for warning in &r.warnings {
        println!("  warning: {warning}");
    }
    let mut semantic = floor.semantic;
    if let Some(north) = args.north_deg {
        anyhow::ensure!(north.is_finite(), "--north-deg {north}: give an angle in degrees");
        semantic.north_deg = Some(north.rem_euclid(360.0));
    }
    Ok(Building::new(vec![Floor { level: 0, grid: floor.grid, semantic }], dxf)?)
}
