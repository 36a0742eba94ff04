//! `cargo bench -p localization`: median time of one filter update — motion sample,
//! scan correction (likelihood field), weights, estimate, low-variance resampling — on
//! the Intel lab log (180-beam scans subsampled to 30, and to 61 for the issue's
//! figure), at fixed particle counts (min = max, resampling every update, so every
//! timed update does all the work); with free space weighed too (each laser beam
//! seen free up to its hit: 15 rays tested at 0.1 m steps); and with each particle's
//! motion checked against the walls, as a person's filter does
//! (`FilterConfig::wall_crossing_log_p`). Prints a table; no harness.

#[path = "../tests/support/mod.rs"]
mod support;

use std::hint::black_box;
use std::time::Instant;

use localization::{FilterConfig, FreeSpaceConfig, Observations, Scan, WALL_CROSSING_LOG_P};
use support::{filter, intel, noisy_increments};

/// Median and 90th percentile microseconds of one update over the whole log, `runs` times.
fn time_updates(particles: usize, beams: usize, free_space: bool, walls: bool, runs: usize) -> (f64, f64) {
    let i = intel();
    let inc = noisy_increments(0.1, 7);
    let config = FilterConfig {
        min_particles: particles,
        max_particles: particles,
        max_beams: beams,
        resample_ess_fraction: 2.0, // always resample: the worst case
        free_space: free_space.then(FreeSpaceConfig::default),
        wall_crossing_log_p: walls.then_some(WALL_CROSSING_LOG_P),
        ..Default::default()
    };
    let scans: Vec<Scan> = i
        .scans
        .iter()
        .map(|s| Scan { free: if free_space { s.beams.clone() } else { Vec::new() }, ..s.clone() })
        .collect();
    let mut us = Vec::new();
    for run in 0..runs {
        let mut pf = filter(config.clone(), run as u64 + 1);
        pf.init_pose(0, i.lasers[0].pose, 0.1, 0.05).expect("start");
        for k in 1..i.lasers.len() {
            let t0 = Instant::now();
            let _ = pf.predict(&inc[k - 1], None);
            let c = pf.correct(&Observations { scan: Some(&scans[k]), ..Default::default() });
            black_box(pf.estimate());
            let elapsed = t0.elapsed().as_secs_f64() * 1e6;
            // a few increments of the log are under AMCL's 0.25 m / 0.2 rad: no update
            if c.updated {
                assert!(c.resampled, "every timed update must do the whole cycle");
                us.push(elapsed);
            }
        }
        assert_eq!(pf.particles().len(), particles);
    }
    us.sort_by(f64::total_cmp);
    (us[us.len() / 2], us[us.len() * 9 / 10])
}

fn main() {
    // the map and field are built once, outside the timing
    let t0 = Instant::now();
    let i = intel();
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t0 = Instant::now();
    let _ = black_box(filter(FilterConfig::default(), 1));
    let field_ms = t0.elapsed().as_secs_f64() * 1e3;
    println!(
        "Intel log: {} scans, map {} x {} cells at {} m (read + map {load_ms:.0} ms; floor model + 40k-particle global start {field_ms:.0} ms)",
        i.lasers.len(),
        i.grid.width(),
        i.grid.height(),
        i.grid.resolution_m()
    );
    println!("| particles | beams used | update median | update p90 |");
    println!("| ---: | ---: | ---: | ---: |");
    for (n, beams, free, walls) in [
        (500, 30, false, false),
        (2000, 30, false, false),
        (2000, 61, false, false),
        (2000, 61, false, true),
        (5000, 30, false, false),
        (500, 30, true, false),
        (2000, 30, true, false),
    ] {
        let (median, p90) = time_updates(n, beams, free, walls, 3);
        let free = if free { " + free space" } else { "" };
        let walls = if walls { " + walls crossed" } else { "" };
        println!("| {n} | {beams} of 180{free}{walls} | {:.3} ms | {:.3} ms |", median / 1e3, p90 / 1e3);
    }
}
