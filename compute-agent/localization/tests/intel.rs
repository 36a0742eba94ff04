//! The filter on real data: the Intel Research Lab log (910 laser scans, 180 beams).
//! The map is built from the scans at their reference poses; the filter sees the
//! reference increments with seeded AMCL-style noise (alpha = 0.1 on all four terms,
//! the figure) and the scans. Figures in docs/localization.md.

mod support;

use localization::{FilterConfig, Status};
use support::{filter, intel, noisy_increments, quantile, rmse, run};

fn summary(name: &str, r: &support::Run, from: usize) {
    let e = &r.position_error_m[from..];
    let h: Vec<f64> = r.heading_error_rad[from..].iter().map(|x| x.to_degrees()).collect();
    let mut ms = r.update_ms.clone();
    ms.sort_by(f64::total_cmp);
    eprintln!(
        "{name}: scans {}..{}: position median {:.3} m, p95 {:.3} m, max {:.3} m, rmse {:.3} m; heading median {:.2} deg, \
         p95 {:.2} deg, rmse {:.2} deg; tracking {:.1} % (while > 1 m off: {}); particles median {}; update median {:.2} ms",
        from,
        r.position_error_m.len(),
        quantile(e, 0.5),
        quantile(e, 0.95),
        quantile(e, 1.0),
        rmse(e),
        quantile(&h, 0.5),
        quantile(&h, 0.95),
        rmse(&h),
        100.0 * r.status[from..].iter().filter(|s| **s == Status::Tracking).count() as f64 / e.len() as f64,
        r.status[from..].iter().zip(e).filter(|(s, e)| **s == Status::Tracking && **e > 1.0).count(),
        {
            let mut p = r.particles[from..].to_vec();
            p.sort();
            p[p.len() / 2]
        },
        ms[ms.len() / 2],
    );
}

#[test]
fn intel_map_is_built_from_the_log() {
    let i = intel();
    assert_eq!(i.lasers.len(), 910);
    let g = &i.grid;
    eprintln!(
        "Intel map: {} x {} cells at {} m, {} occupied, {} free",
        g.width(),
        g.height(),
        g.resolution_m(),
        g.count(map::Cell::Occupied),
        g.count(map::Cell::Free)
    );
    assert!(g.count(map::Cell::Occupied) > 10_000);
    assert!(g.count(map::Cell::Free) > 100_000);
}

/// Seeds of the filter; the odometry noise of seed `s` is drawn with seed `s + 5`.
const SEEDS: [u64; 3] = [1, 2, 3];

#[test]
fn tracks_the_intel_log_from_the_known_start() {
    let i = intel();
    for seed in SEEDS {
        let mut pf = filter(FilterConfig::default(), seed);
        pf.init_pose(0, i.lasers[0].pose, 0.1, 0.05).expect("start");
        let r = run(&mut pf, &noisy_increments(0.1, seed + 5));
        summary(&format!("known start, seed {seed}"), &r, 0);
        let e = &r.position_error_m;
        assert!(quantile(e, 0.5) < 0.2, "seed {seed}: median {}", quantile(e, 0.5));
        assert!(quantile(e, 0.95) < 0.5, "seed {seed}: p95 {}", quantile(e, 0.95));
    }
}

#[test]
// diagnostics (prints the run scan by scan): `cargo test -p localization --features diagnostics -- --nocapture NAME`
#[cfg(feature = "diagnostics")]
fn trace_known_start() {
    let i = intel();
    let seed: u64 = std::env::var("SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    let mut pf = filter(FilterConfig::default(), seed);
    pf.init_pose(0, i.lasers[0].pose, 0.1, 0.05).expect("start");
    let r = run(&mut pf, &noisy_increments(0.1, seed + 5));
    for k in (0..r.position_error_m.len()).filter(|&k| k % 5 == 0 || r.position_error_m[k] > 0.5) {
        eprintln!(
            "{k:4} err {:.3} m {:5.1} deg  fit {:.3}  n {:5} {:?}",
            r.position_error_m[k],
            r.heading_error_rad[k].to_degrees(),
            r.fit[k],
            r.particles[k],
            r.status[k]
        );
    }
}

/// Updates a global start may take to be within 0.5 m (and stay there for 20 updates).
/// Measured with 40,000 global particles: 29 of seeds 1 to 30 within 18 updates, one
/// after 92 (the `global_seeds` diagnostic; docs/localization.md).
const GLOBAL_MAX_UPDATES: usize = 30;

#[test]
fn converges_on_the_intel_log_from_a_global_start() {
    for seed in SEEDS {
        let mut pf = filter(FilterConfig::default(), seed);
        pf.init_global();
        let r = run(&mut pf, &noisy_increments(0.1, seed + 5));
        let c = r.converged_at(0.5, 20);
        eprintln!(
            "global start, seed {seed}: within 0.5 m for 20 updates from update {c:?} ({:.1} m walked)",
            c.map(|k| r.walked_m[k]).unwrap_or(f64::NAN)
        );
        let c = c.unwrap_or_else(|| panic!("seed {seed}: never converged"));
        assert!(c <= GLOBAL_MAX_UPDATES, "seed {seed}: converged only at update {c}");
        summary(&format!("global start, seed {seed}, after convergence"), &r, c);
        let e = &r.position_error_m[c..];
        assert!(quantile(e, 0.5) < 0.2, "seed {seed}: median {}", quantile(e, 0.5));
        assert!(quantile(e, 0.95) < 0.5, "seed {seed}: p95 {}", quantile(e, 0.95));
    }
}

#[test]
// diagnostics (variants of the configuration): `cargo test -p localization --features diagnostics -- --nocapture NAME`
#[cfg(feature = "diagnostics")]
fn variants() {
    for (n, k) in [(5000, 1.0 / 3.0), (5000, 0.2), (5000, 0.5), (10000, 0.2)] {
        for seed in [2, 3, 4] {
            let cfg = FilterConfig { max_particles: n, scan_weight_exponent: k, ..Default::default() };
            let mut pf = filter(cfg.clone(), seed);
            pf.init_global();
            let r = run(&mut pf, &noisy_increments(0.1, seed + 5));
            let c = r.converged_at(0.5, 20);
            let wrong =
                r.status.iter().zip(&r.position_error_m).filter(|(s, e)| **s == Status::Tracking && **e > 1.0).count();
            let after = c.map(|c| (quantile(&r.position_error_m[c..], 0.5), quantile(&r.position_error_m[c..], 0.95)));
            let mut pf = filter(cfg, seed);
            pf.init_pose(0, intel().lasers[0].pose, 0.1, 0.05).expect("start");
            let t = run(&mut pf, &noisy_increments(0.1, seed + 5));
            let e = &t.position_error_m;
            eprintln!(
                "n {n} k {k:.2} seed {seed}: global converged at {c:?} ({:.1} m), then median/p95 {after:.3?}; wrong tracking {wrong} | known: median {:.3} p95 {:.3} rmse {:.3} max {:.2} heading rmse {:.1}",
                c.map(|k| r.walked_m[k]).unwrap_or(f64::NAN),
                quantile(e, 0.5), quantile(e, 0.95), rmse(e), quantile(e, 1.0),
                rmse(&t.heading_error_rad).to_degrees()
            );
        }
    }
}

#[test]
// diagnostics (recovery variants on the known start): `cargo test -p localization --features diagnostics -- --nocapture NAME`
#[cfg(feature = "diagnostics")]
fn recovery_variants() {
    let variants: Vec<(&str, FilterConfig)> = vec![
        ("default", FilterConfig::default()),
        ("Thrun (no dead band)", FilterConfig { recovery_ratio: 1.0, ..Default::default() }),
        ("dead band 0.6", FilterConfig { recovery_ratio: 0.6, ..Default::default() }),
        ("no inject", FilterConfig { max_inject_fraction: 0.0, ..Default::default() }),
        ("k 1/3", FilterConfig { scan_weight_exponent: 1.0 / 3.0, ..Default::default() }),
        ("61 beams", FilterConfig { max_beams: 61, ..Default::default() }),
        ("61 beams, k 1/6", FilterConfig { max_beams: 61, scan_weight_exponent: 1.0 / 6.0, ..Default::default() }),
    ];
    for (name, cfg) in variants {
        let mut line = String::new();
        for seed in 1..=16 {
            let mut pf = filter(cfg.clone(), seed);
            pf.init_pose(0, intel().lasers[0].pose, 0.1, 0.05).expect("start");
            let t = run(&mut pf, &noisy_increments(0.1, seed + 5));
            let e = &t.position_error_m;
            line += &format!(" {:.3}/{:.1}", rmse(e), quantile(e, 1.0));
        }
        eprintln!("{name:>20}: RMSE / max per seed (1-16):{line}");
    }
}

#[test]
// diagnostics (where heading errors are large): `cargo test -p localization --features diagnostics -- --nocapture NAME`
#[cfg(feature = "diagnostics")]
fn trace_heading() {
    let i = intel();
    let mut pf = filter(FilterConfig::default(), 1);
    pf.init_pose(0, i.lasers[0].pose, 0.1, 0.05).expect("start");
    let inc = noisy_increments(0.1, 6);
    let r = run(&mut pf, &inc);
    for k in 1..r.position_error_m.len() {
        if r.heading_error_rad[k] > 10f64.to_radians() {
            let (f, l, y) = i.lasers[k - 1].pose.between(&i.lasers[k].pose);
            eprintln!(
                "{k:4} herr {:5.1} deg perr {:.2} | true inc {f:.2} {l:.2} {:.1} deg | noisy yaw {:.1} deg | n {} {:?}",
                r.heading_error_rad[k].to_degrees(),
                r.position_error_m[k],
                y.to_degrees(),
                inc[k - 1].yaw_rad.to_degrees(),
                r.particles[k],
                r.status[k]
            );
        }
    }
}

#[test]
// diagnostics (global start over thirty seeds): `cargo test -p localization --features diagnostics -- --nocapture NAME`
#[cfg(feature = "diagnostics")]
fn global_seeds() {
    for n in [10_000, 20_000, 40_000] {
        let mut line = String::new();
        for seed in 1..=30 {
            let mut pf = filter(FilterConfig { global_particles: n, ..Default::default() }, seed);
            pf.init_global();
            let r = run(&mut pf, &noisy_increments(0.1, seed + 5));
            let c = r.converged_at(0.5, 20);
            let wrong =
                r.status.iter().zip(&r.position_error_m).filter(|(s, e)| **s == Status::Tracking && **e > 1.0).count();
            line += &format!(" {c:?}/{wrong}");
        }
        eprintln!("global {n}: converged at update / tracking while > 1 m off, per seed:{line}");
    }
}

#[test]
// diagnostics (a global start, guidance waiting until `Tracking` has held for some metres
// of walking): `cargo test -p localization --features diagnostics -- --nocapture NAME`
#[cfg(feature = "diagnostics")]
fn global_tracking_held() {
    for held_m in [0.0, 2.0, 5.0, 10.0] {
        let mut line = String::new();
        let (mut before_total, mut after_total, mut started) = (0, 0, vec![]);
        for seed in 1..=30 {
            let mut pf = filter(FilterConfig::default(), seed);
            pf.init_global();
            let r = run(&mut pf, &noisy_increments(0.1, seed + 5));
            let c = r.converged_at(0.5, 20).unwrap_or(r.status.len());
            // metres walked when the current `Tracking` streak began
            let mut since: Option<f64> = None;
            let (mut before, mut first) = (0, None);
            for k in 0..r.status.len() {
                since = if r.status[k] == Status::Tracking { Some(since.unwrap_or(r.walked_m[k])) } else { None };
                let taken = since.is_some_and(|s| r.walked_m[k] - s >= held_m);
                first = first.or(taken.then_some(k));
                if taken && r.position_error_m[k] > 1.0 {
                    if k < c {
                        before += 1;
                    } else {
                        after_total += 1;
                    }
                }
            }
            before_total += before;
            started.extend(first.map(|k| r.walked_m[k]));
            line += &format!(" {before}/{:.1}", first.map_or(f64::NAN, |k| r.walked_m[k]));
        }
        eprintln!(
            "held {held_m} m: updates taken while > 1 m off before convergence {before_total} (after it {after_total}); \
             walked when first taken: median {:.1} m, max {:.1} m; per seed (before / walked):{line}",
            quantile(&started, 0.5),
            quantile(&started, 1.0)
        );
    }
}
