//! `wearnav localize`: the particle filter measured against a reference. `--carmen`: on
//! a recorded 2-D laser log, the map from the logged scans at the logged (scan-matched)
//! poses, the odometry increments between scans perturbed with seeded noise, the
//! estimate at every scan compared with the logged pose. `--world`: on a simulated
//! walk, the floor plan of the world, the simulator's odometry and body gyro and the
//! cane camera's nearest-point scan, compared with the simulator's truth
//! (`study::localize_walk`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use localization::log_run::{quantile, rmse, LoggedRun};
use localization::mapping::MappingConfig;
use localization::{FilterConfig, Status};
use serde_json::json;

/// Localize on a CARMEN laser log or a simulated walk and report the errors.
#[derive(Debug, Args)]
#[command(after_help = "Examples:\n  \
    wearnav localize --carmen compute-agent/localization/tests/data/intel-corrected.log.gz --global\n  \
    wearnav localize --world corridor --seed 2 --scans sweep\n  \
    wearnav localize --world corridor --misread-after 20")]
pub struct LocalizeArgs {
    /// A CARMEN log (`FLASER` and `ODOM` lines), plain or gzip-compressed. Its poses are
    /// the reference: use a scan-matched ("corrected") log.
    #[arg(long, value_name = "FILE", required_unless_present = "world", conflicts_with = "world")]
    carmen: Option<PathBuf>,
    /// A simulated world (built-in name or scene file): the walk's user is localized on
    /// the world's floor plan from a known start (0.1 m, 2 degrees off; `--global`: from
    /// nothing).
    #[arg(long, value_name = "WORLD")]
    world: Option<String>,
    /// With `--world`: which scans correct the filter (`none`: odometry and gyro alone;
    /// `frame`: each frame's scan; `sweep`: the frames of a cane sweep merged).
    #[arg(long, value_enum, default_value = "frame", requires = "world")]
    scans: study::localize_walk::ScanUse,
    /// With `--world`: the map the filter localizes on: `floor-plan` (walls only, what
    /// `wearnav map` exports) or `mapped` (also the furniture and hanging obstacles in the
    /// camera's obstacle band, no people or chairs: what a mapping run would record).
    #[arg(long, value_enum, default_value = "floor-plan", requires = "world")]
    map: study::localize_walk::LocalizationMap,
    /// With `--world`: do not use the body gyro's yaw rate.
    #[arg(long, requires = "world")]
    no_imu: bool,
    /// With `--world`: no door numbers (by default a simulated chest camera reads each
    /// door sign as it comes into view: 3 m, ±35°, 0.15 m noise, 2 % misread).
    #[arg(long, requires = "world")]
    no_signs: bool,
    /// With `--world`: the share of door signs misread as another door's number.
    #[arg(long, value_name = "P", requires = "world", conflicts_with = "no_signs", value_parser = parse_share)]
    misread: Option<f64>,
    /// With `--world`: the first sign read after M metres of walking is misread; the
    /// report says how far the user walked before the estimate was back within 0.5 m.
    #[arg(long, value_name = "M", requires = "world", conflicts_with = "no_signs")]
    misread_after: Option<f64>,
    /// Leave out of each correction, while tracking, the beams that end in open floor more
    /// than M metres from every wall of the map with nothing of the map before them
    /// (people, bins, chairs: what a floor plan does not have). Off by default; see
    /// docs/localization.md, "Beams on what the map does not have".
    #[arg(long, value_name = "M", value_parser = parse_gate)]
    unmapped_gate: Option<f64>,
    /// With `--world`: at each update also give the filter the direction of the longest
    /// straight wall in the frame's scan, matched against the map's wall directions (the
    /// wall-angle correction, for the heading). Off by default: it holds the heading but
    /// moves the place along a corridor without door signs (docs/localization.md, "The
    /// wall angle"). Without it the walls are still looked for, and the report says how
    /// well they match the map.
    #[arg(long, requires = "world")]
    wall_angles: bool,
    /// With `--world`: at each update also give the filter the corners where two
    /// straight walls of the frame's scan meet, matched against the corners of the map's
    /// outline (Zhang et al.'s corridor corners, a landmark that is not unique). Without
    /// it the corners are still looked for, and the report says how far they lie from
    /// the map's.
    #[arg(long, requires = "world")]
    corners: bool,
    /// With `--world`: also weigh free space, the floor the camera saw along each bearing,
    /// which a pose must not put a wall of the map across (the scan's hits alone let a
    /// place shifted back from an opening fit as well as the true one). Off by default:
    /// better in a building's halls, no better along a uniform corridor, and worse on a
    /// map that marks what overhangs the floor (docs/localization.md, "Free space").
    /// Without it the report still says how much of the floor seen free the map puts a
    /// wall on.
    #[arg(long, requires = "world")]
    free_space: bool,
    /// With `--carmen`: odometry noise, AMCL's alpha1..alpha4 (rotation from rotation,
    /// rotation from translation, translation from translation, translation from
    /// rotation); default 0.1 each. A simulated walk has the simulator's own.
    #[arg(long, value_name = "A1,A2,A3,A4", value_parser = parse_alpha, conflicts_with = "world")]
    odom_noise: Option<[f64; 4]>,
    /// With `--world`: the odometry noise the filter assumes (AMCL's alpha1..alpha4, as
    /// for `--odom-noise`); default AMCL's 0.2 each. Smaller trusts the odometry more
    /// (docs/localization.md, "An EKF before the filter").
    #[arg(long, value_name = "A1,A2,A3,A4", value_parser = parse_alpha, requires = "world")]
    motion_noise: Option<[f64; 4]>,
    /// Most particles while tracking (a global start begins with more, spread over the
    /// whole map; see `FilterConfig::global_particles`).
    #[arg(long, value_name = "N", default_value_t = FilterConfig::default().max_particles)]
    particles: usize,
    /// Seed of the filter; the odometry noise is drawn with seed + 5.
    #[arg(long, value_name = "S", default_value_t = 1)]
    seed: u64,
    /// Start from nothing (particles over all free space, any heading) instead of near
    /// the first logged pose, or with `--world` the walk's true start: as the agent does
    /// when it is given no start. With `--carmen`, reports when the estimate came within
    /// 0.5 m to stay.
    #[arg(long)]
    global: bool,
    /// With `--world`: also write every camera frame (time, metres walked, truth,
    /// estimate, errors along and across, status, whether the filter corrected, usable
    /// beams, door signs read, the scan's wall against the map, whether guidance may take
    /// the place) to FILE as CSV, for plotting where the estimate went.
    #[arg(long, value_name = "FILE", requires = "world")]
    frames: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

fn parse_gate(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("{s:?}: give metres, more than 0 (e.g. 0.5)")),
    }
}

fn parse_share(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("{s:?}: give a share between 0 and 1 (e.g. 0.05)")),
    }
}

fn parse_alpha(s: &str) -> Result<[f64; 4], String> {
    let values: Vec<f64> = s
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{s:?}: {e} (four numbers, e.g. 0.1,0.1,0.1,0.1)"))?;
    match values[..] {
        [a, b, c, d] if values.iter().all(|v| v.is_finite() && (0.0..=2.0).contains(v)) => Ok([a, b, c, d]),
        _ => Err(format!("{s:?}: give four numbers between 0 and 2 (AMCL's alpha1..alpha4)")),
    }
}

/// Within this of the logged pose, and for [`HOLD_UPDATES`] updates, the estimate has
/// converged (the figure for a global start).
const CONVERGED_M: f64 = 0.5;
const HOLD_UPDATES: usize = 20;

/// Run `wearnav localize`.
pub fn run(args: &LocalizeArgs) -> anyhow::Result<()> {
    if args.particles < 100 || args.particles > 1_000_000 {
        bail!("--particles {}: give between 100 and 1,000,000", args.particles);
    }
    match (&args.carmen, &args.world) {
        (Some(log), _) => on_log(args, log),
        (None, Some(world)) => on_world(args, world),
        (None, None) => bail!("give --carmen FILE or --world WORLD (see --help)"),
    }
}

fn on_world(args: &LocalizeArgs, name: &str) -> anyhow::Result<()> {
    use sensor_agent::sim::SignReaderConfig;
    use study::localize_walk::{localize_walk, LocalizeWalkConfig};
    let world = sensor_agent::sim::World::load(name).with_context(|| format!("cannot load world {name:?}"))?;
    let defaults = LocalizeWalkConfig::default();
    let filter = FilterConfig {
        max_particles: args.particles,
        min_particles: defaults.filter.min_particles.min(args.particles),
        unmapped_gate_m: args.unmapped_gate.unwrap_or(defaults.filter.unmapped_gate_m),
        free_space: args.free_space.then(localization::FreeSpaceConfig::default),
        motion: match args.motion_noise {
            Some([alpha1, alpha2, alpha3, alpha4]) => {
                localization::MotionNoise { alpha1, alpha2, alpha3, alpha4, ..defaults.filter.motion }
            }
            None => defaults.filter.motion,
        },
        ..defaults.filter.clone()
    };
    if args.misread_after.is_some_and(|m| !(m.is_finite() && m >= 0.0)) {
        bail!("--misread-after: give metres of walking, 0 or more");
    }
    let signs = (!args.no_signs).then(|| {
        let c = defaults.signs.unwrap_or_default();
        SignReaderConfig { misread_probability: args.misread.unwrap_or(c.misread_probability), ..c }
    });
    let config = LocalizeWalkConfig {
        filter,
        scans: args.scans,
        map: args.map,
        imu: !args.no_imu,
        signs,
        misread_after_m: args.misread_after,
        wall_angles: args.wall_angles.then(localization::WallFitConfig::default),
        corners: args.corners.then(localization::CornerConfig::default),
        global_start: args.global,
        ..defaults
    };
    let clock = Instant::now();
    let r = localize_walk(&world, args.seed, &config, || clock.elapsed().as_secs_f64() * 1e3)?;
    if let Some(path) = &args.frames {
        write_frames(path, &r.frames).with_context(|| format!("cannot write {}", path.display()))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r.summary)?);
    } else {
        println!("{}", r.summary_text());
    }
    Ok(())
}

/// A CSV field: quoted (quotes doubled) when it holds a comma, a quote or a line break.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// The walk's frames as CSV, one row per camera frame.
fn write_frames(path: &std::path::Path, frames: &[study::localize_walk::FrameLocalization]) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        out,
        "t_s,walked_m,truth_x_m,truth_y_m,truth_heading_deg,estimate_x_m,estimate_y_m,estimate_heading_deg,\
         position_error_m,along_error_m,across_error_m,heading_error_deg,status,updated,beams,doors_read,misread,wall_residual_deg,wall_used,corner_residuals_m,corners_used,guides"
    )?;
    for f in frames {
        writeln!(
            out,
            "{:.3},{:.3},{:.3},{:.3},{:.2},{:.3},{:.3},{:.2},{:.3},{:.3},{:.3},{:.2},{:?},{},{},{},{},{},{},{},{},{}",
            f.t_s,
            f.walked_m,
            f.truth[0],
            f.truth[1],
            f.truth[2],
            f.estimate[0],
            f.estimate[1],
            f.estimate[2],
            f.position_error_m,
            f.along_error_m,
            f.across_error_m,
            f.heading_error_deg,
            f.status,
            f.updated,
            f.beams,
            csv_field(&f.doors_read.join(" ")),
            f.misread,
            f.wall_residual_deg.map_or(String::new(), |d| format!("{d:.2}")),
            f.wall_used,
            f.corner_residuals_m.iter().map(|d| format!("{d:.2}")).collect::<Vec<_>>().join(" "),
            f.corners_used,
            f.guides
        )?;
    }
    out.flush()?;
    Ok(())
}

fn on_log(args: &LocalizeArgs, path: &std::path::Path) -> anyhow::Result<()> {
    let log = localization::carmen::read_log(path)?;
    let logged = LoggedRun::new(&log, &MappingConfig::default())
        .with_context(|| format!("cannot localize on {}", path.display()))?;
    let defaults = FilterConfig::default();
    let config = FilterConfig {
        max_particles: args.particles,
        min_particles: defaults.min_particles.min(args.particles),
        unmapped_gate_m: args.unmapped_gate.unwrap_or(defaults.unmapped_gate_m),
        ..defaults
    };
    let mut pf = logged.filter(config, args.seed)?;
    let first = logged.lasers[0].pose;
    if args.global {
        pf.init_global();
    } else {
        pf.init_pose(0, first, 0.1, 0.05)?;
    }
    let odom_noise = args.odom_noise.unwrap_or([0.1; 4]);
    let increments = logged.noisy_increments(odom_noise, args.seed + 5);
    let clock = Instant::now();
    let run = logged.run(&mut pf, &increments, || clock.elapsed().as_secs_f64() * 1e3)?;

    let converged = run.converged_at(CONVERGED_M, HOLD_UPDATES);
    // the errors that count: from convergence on (a global start searches first)
    let from = if args.global { converged.unwrap_or(run.position_error_m.len()) } else { 0 };
    let position = &run.position_error_m[from..];
    let heading_deg: Vec<f64> = run.heading_error_rad[from..].iter().map(|h| h.to_degrees()).collect();
    let start_s = logged.lasers[0].timestamp_s;
    let converge_s = converged.map(|k| logged.lasers[k].timestamp_s - start_s);
    let converge_walked_m = converged.map(|k| run.walked_m[k]);
    let tracking = run.status[from..].iter().filter(|s| **s == Status::Tracking).count();
    let update_ms_median = quantile(&run.update_ms, 0.5);
    let g = &logged.grid;
    if args.json {
        let out = json!({
            "log": path, "scans": logged.lasers.len(), "global": args.global, "seed": args.seed,
            "odom_noise": odom_noise, "particles": args.particles,
            "map": { "width": g.width(), "height": g.height(), "resolution_m": g.resolution_m() },
            "position_rmse_m": rmse(position), "position_median_m": quantile(position, 0.5),
            "position_p95_m": quantile(position, 0.95), "heading_rmse_deg": rmse(&heading_deg),
            "converge_s": converge_s, "converge_walked_m": converge_walked_m,
            "tracking_fraction": tracking as f64 / position.len().max(1) as f64,
            "update_ms_median": update_ms_median,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{}: {} scans, map {}x{} cells at {} m; {} start, odometry noise {:?}, seed {}",
            path.display(),
            logged.lasers.len(),
            g.width(),
            g.height(),
            g.resolution_m(),
            if args.global { "global" } else { "known" },
            odom_noise,
            args.seed
        );
        match (converged, args.global) {
            (Some(k), true) => println!(
                "converged within {CONVERGED_M} m at scan {k}: {:.1} s, {:.1} m walked",
                converge_s.unwrap_or(f64::NAN),
                converge_walked_m.unwrap_or(f64::NAN)
            ),
            (None, true) => println!("never came within {CONVERGED_M} m to stay ({HOLD_UPDATES} updates)"),
            _ => {}
        }
        println!(
            "position_rmse_m {:.3} (median {:.3}, p95 {:.3}), heading_rmse_deg {:.2}, tracking {:.0} %, update_ms_median {:.2}",
            rmse(position),
            quantile(position, 0.5),
            quantile(position, 0.95),
            rmse(&heading_deg),
            100.0 * tracking as f64 / position.len().max(1) as f64,
            update_ms_median
        );
    }
    if args.global && converged.is_none() {
        bail!("the filter never converged from the global start");
    }
    Ok(())
}
