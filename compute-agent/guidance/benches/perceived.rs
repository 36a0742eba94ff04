//! `cargo bench -p guidance`: medians of `Navigator::perceived`, which the compute agent
//! calls with every camera frame while it guides: a frame of 240 held points of which
//! nothing is new (the usual frame: the route ahead checked against what was found),
//! and a frame whose new points block the route ahead
//! (cells onto the graph, the way round planned and taken). A 30 x 20 m room at 5 cm,
//! the route 26 m across it. Prints medians; no harness.

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use guidance::{GuidanceProfile, Navigator, UserPose};
use map::{Building, Cell, Floor, OccupancyGrid, Origin, SemanticLayer};
use planning::UserProfile;
use schemas::Command;

const LAYER: &str = r#"
[[label]]
name = "west door"
x = 2.0
y = 10.0
floor = 0

[[label]]
name = "east door"
x = 28.0
y = 10.0
floor = 0
"#;

fn navigator() -> Navigator {
    let res = 0.05;
    let (w, h) = ((30.0 / res) as usize, (20.0 / res) as usize);
    let o = Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 };
    let mut g = OccupancyGrid::filled(w, h, res, o, Cell::Occupied).unwrap();
    for r in 0..h {
        for c in 0..w {
            let (x, y) = g.cell_center(c, r);
            if (0.5..=29.5).contains(&x) && (0.5..=19.5).contains(&y) {
                g.set(c, r, Cell::Free);
            }
        }
    }
    let layer = SemanticLayer::parse(LAYER, Path::new("bench.toml")).unwrap();
    let floor = Floor { level: 0, grid: g, semantic: layer.floor(0) };
    let building = Building::new(vec![floor], Path::new("bench")).unwrap();
    Navigator::new(&building, UserProfile::default(), GuidanceProfile::default())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let user = UserPose { x_m: 6.0, y_m: 10.0, heading_rad: 0.0, floor: 0, confident: true };
    let camera = [6.35, 10.0];
    // what a frame holds: a desk's front across the way 3 m ahead (y 8.5-11.5) and a
    // table top beside it, 240 points every 2.5 cm
    let desk: Vec<[f64; 2]> = (0..120).map(|k| [9.0, 8.5 + 0.025 * f64::from(k)]).collect();
    let table: Vec<[f64; 2]> = (0..120).map(|k| [7.0 + 0.025 * f64::from(k), 13.0]).collect();
    let held: Vec<[f64; 2]> = desk.iter().chain(&table).copied().collect();

    let (mut seen, mut round) = (Vec::new(), Vec::new());
    for run in 0..200u64 {
        let mut nav = navigator();
        nav.command(&Command::Destination { label: "east door".into() }, &user, 0);
        let t0 = Instant::now();
        nav.perceived(&user, camera, black_box(&held), 1000);
        round.push(t0.elapsed().as_secs_f64() * 1e3);
        assert_eq!(nav.detours().0, 1, "run {run}: the desk is on the route");
        // the same points again, 5 s on: nothing new, the new route checked against
        // what was found (clear of it: nothing to plan)
        for k in 0..20u64 {
            let t0 = Instant::now();
            nav.perceived(&user, camera, black_box(&held), 6000 + 33 * k);
            seen.push(t0.elapsed().as_secs_f64() * 1e3);
        }
        assert_eq!(nav.detours(), (1, 0, 0), "run {run}: the way round is clear of the desk");
    }
    println!("Navigator::perceived, 240 held points, nothing new (route checked) median {:.4} ms", median(seen));
    println!("Navigator::perceived, a desk on the route: cells + way round         median {:.4} ms", median(round));
}
