//! `wearnav localize` as a user runs it, on the Intel Research Lab log in the repository.

use std::path::Path;
use std::process::Command;

fn localize(args: &[&str]) -> (bool, String, String) {
    let log =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("compute-agent/localization/tests/data/intel-corrected.log.gz");
    let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(["localize", "--carmen", log.to_str().unwrap()])
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("wearnav runs");
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

fn report(out: &str) -> serde_json::Value {
    serde_json::from_str(out).unwrap_or_else(|e| panic!("{e}: {out}"))
}

#[test]
fn from_the_known_start_the_position_rmse_is_within_the_issues_figure() {
    let (ok, out, err) = localize(&["--json"]);
    assert!(ok, "{err}");
    let r = report(&out);
    assert_eq!(r["scans"], 910);
    let rmse = r["position_rmse_m"].as_f64().unwrap();
    // issue 30: odometry noise 0.1 on all four terms, position RMSE <= 0.15 m
    assert!(rmse <= 0.15, "position RMSE {rmse} m");
    assert!(r["heading_rmse_deg"].as_f64().unwrap() < 6.0, "{}", r["heading_rmse_deg"]);
    assert!(r["update_ms_median"].as_f64().unwrap() > 0.0);
}

#[test]
fn from_nothing_it_converges_within_half_a_metre() {
    let (ok, out, err) = localize(&["--global", "--seed", "2", "--json"]);
    assert!(ok, "{err}");
    let r = report(&out);
    let walked = r["converge_walked_m"].as_f64().expect("converged");
    assert!(walked < 20.0, "converged only after {walked} m");
    assert!(r["position_rmse_m"].as_f64().unwrap() <= 0.2, "{}", r["position_rmse_m"]);
}

#[test]
fn bad_input_is_refused_with_its_reason() {
    let (ok, _, err) = localize(&["--odom-noise", "0.1,0.2"]);
    assert!(!ok && err.contains("four numbers"), "{err}");
    let (ok, _, err) = localize(&["--particles", "5"]);
    assert!(!ok && err.contains("between 100"), "{err}");
    let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(["localize", "--carmen", "/nonexistent/run.log"])
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("/nonexistent/run.log"), "{err}");
    // a simulated walk's sign reader: a share is between 0 and 1, a distance not negative
    for (arg, says) in [
        ("--misread=1.5", "between 0 and 1"),
        ("--misread-after=-3", "0 or more"),
        ("--unmapped-gate=0", "more than 0"),
        ("--unmapped-gate=nan", "more than 0"),
        ("--motion-noise=0.1,0.2", "four numbers between 0 and 2"),
        ("--motion-noise=0.1,0.1,0.1,nan", "four numbers between 0 and 2"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
            .args(["localize", "--world", "building", arg])
            .env("RUST_BACKTRACE", "0")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says), "{arg}: {err}");
    }
}

#[test]
fn the_unmapped_gate_leaves_out_the_beams_on_the_chairs_of_taylors_course_and_says_how_many() {
    // the course's floor plan has its walls and dividers, not its chairs or hanging
    // obstacles: the gate leaves out what the camera sees of them while tracking
    let run = |extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
            .args(["localize", "--world", "taylor-course", "--seed", "4", "--json"])
            .args(extra)
            .env("RUST_BACKTRACE", "0")
            .output()
            .expect("wearnav runs");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        report(&String::from_utf8_lossy(&out.stdout))
    };
    assert_eq!(run(&[])["beams_unmapped"], 0);
    let gated = run(&["--unmapped-gate", "0.5"]);
    let left_out = gated["beams_unmapped"].as_u64().expect("a count");
    assert!(left_out >= 10, "{left_out} beams left out");
}

#[test]
fn on_a_simulated_walk_the_scan_holds_the_user_on_the_floor_plan() {
    let dir = tempfile::Builder::new().prefix("wearnav-localize-").tempdir().unwrap();
    let frames_csv = dir.path().join("frames.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(["localize", "--world", "building", "--seed", "1", "--json", "--frames"])
        .arg(&frames_csv)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("wearnav runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let with_scan = report(&String::from_utf8_lossy(&out.stdout));
    // every frame in the CSV, with the summary's walk and door signs in it
    let csv = std::fs::read_to_string(&frames_csv).expect("the frames file");
    let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
    assert!(rows[0].starts_with(&["t_s", "walked_m", "truth_x_m"]) && rows[0].len() == 22, "{:?}", rows[0]);
    assert_eq!(rows[0][17..], ["wall_residual_deg", "wall_used", "corner_residuals_m", "corners_used", "guides"]);
    assert_eq!(rows.len() - 1, with_scan["frames"].as_u64().unwrap() as usize);
    let walked: f64 = rows.last().unwrap()[1].parse().unwrap();
    assert!((walked - with_scan["walked_m"].as_f64().unwrap()).abs() < 0.01, "{walked}");
    // (the building's door numbers have no spaces: one word per sign read)
    let read: usize = rows[1..].iter().map(|r| r[15].split_whitespace().count()).sum();
    assert_eq!(read as u64, with_scan["doors_read"].as_u64().unwrap());
    // the straight walls each frame's scan holds, against the plan's directions at the
    // true heading (measured: 442 frames, median 0.5°); none given to the filter by default
    let walls: Vec<f64> = rows[1..].iter().filter(|r| !r[17].is_empty()).map(|r| r[17].parse().unwrap()).collect();
    assert_eq!(walls.len() as u64, with_scan["walls_found"].as_u64().unwrap());
    assert!(walls.len() * 3 > rows.len(), "{} frames with a wall of {}", walls.len(), rows.len() - 1);
    assert!(with_scan["wall_residual_median_deg"].as_f64().unwrap() < 1.0, "{with_scan}");
    assert!(rows[1..].iter().all(|r| r[18] == "false") && with_scan["wall_angles_used"] == 0);
    // the corners where two walls of a frame's scan meet, each's distance from the map's
    // nearest at the true pose (measured: 11, all within 0.3 m); none given by default
    let corners: Vec<f64> =
        rows[1..].iter().flat_map(|r| r[19].split_whitespace()).map(|d| d.parse().unwrap()).collect();
    assert_eq!(corners.len() as u64, with_scan["corners_found"].as_u64().unwrap());
    assert!(corners.len() >= 5 && corners.iter().all(|&d| d <= 0.3), "{corners:?}");
    assert!(rows[1..].iter().all(|r| r[20] == "false") && with_scan["corners_used"] == 0);
    let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(["localize", "--world", "building", "--seed", "1", "--scans", "none", "--no-signs", "--json"])
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("wearnav runs");
    let dead_reckoning = report(&String::from_utf8_lossy(&out.stdout));
    let rmse = |r: &serde_json::Value| r["position_rmse_m"].as_f64().unwrap();
    // measured 0.199 m with the scan and door signs, 0.813 m on odometry and gyro alone
    // (docs/localization.md)
    assert!(rmse(&with_scan) < 0.35, "{with_scan}");
    assert!(rmse(&dead_reckoning) > 2.0 * rmse(&with_scan), "{dead_reckoning}");
    assert_eq!(with_scan["tracking_over_1m"], 0, "said Tracking while more than 1 m off");
    // free space (the floor seen free along each bin), counted either way, weighed only
    // with --free-space (measured: 7,070 rays, 1.6 % through a wall of the plan at the
    // true pose; 0.199 -> 0.136 m)
    let rays = |r: &serde_json::Value| r["free_rays"].as_u64().unwrap();
    assert!(rays(&with_scan) > 5_000, "{with_scan}");
    assert!(with_scan["free_rays_through_walls_fraction"].as_f64().unwrap() < 0.03, "{with_scan}");
    let out = Command::new(env!("CARGO_BIN_EXE_wearnav"))
        .args(["localize", "--world", "building", "--seed", "1", "--free-space", "--json"])
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("wearnav runs");
    let free = report(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(rays(&free), rays(&with_scan));
    assert!(rmse(&free) < rmse(&with_scan) - 0.04, "{free}");
}
