//! Simulator speed on one core: frames per second of the ray-cast depth camera along
//! the taylor-course walk (render + sensor model), and of a whole `SimSource` frame
//! (render + IMU + odometry + copy). Prints medians over the walk.
//!
//! Run: `cargo bench -p sim --bench sim`

use std::time::Instant;

use sim::FrameSource;
use sim::{CameraProfile, CaneMount, Renderer, ScriptedWalker, SimConfig, SimRng, SimSource, World};

const FRAMES: usize = 300;

fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs[xs.len() / 2]
}

fn bench_render(world_name: &str, profile: CameraProfile) {
    let world = match World::load(world_name) {
        Ok(w) => w,
        Err(e) => panic!("{e}"),
    };
    let walker = match world.walker() {
        Some(spec) => ScriptedWalker::new(world.start(), spec),
        None => ScriptedWalker::standing(world.start()),
    };
    let mount = CaneMount::default();
    let mut renderer = Renderer::new(profile.clone());
    let mut rng = SimRng::seed_from(1);
    let mut out = Vec::new();
    let mut times = Vec::with_capacity(FRAMES);
    let span_s = walker.script_duration_s().max(1.0);
    for k in 0..FRAMES {
        let t = span_s * k as f64 / FRAMES as f64;
        let pose = mount.camera_pose(&walker.pose_at(t), mount.sweep_rad(t));
        let start = Instant::now();
        renderer.render(&world, &pose, t, &mut rng, &mut out);
        times.push(start.elapsed().as_secs_f64());
    }
    let m = median(times);
    println!(
        "render {world_name:>14} {:>5} {}x{}: median {:.2} ms/frame = {:.0} frames/s (single core, {FRAMES} frames along the walk)",
        profile.name,
        profile.width,
        profile.height,
        m * 1e3,
        1.0 / m
    );
}

fn bench_source() {
    let mut source = match SimSource::new(SimConfig::default()) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    };
    let period = source.period_ns();
    let mut times = Vec::with_capacity(FRAMES);
    for k in 0..FRAMES as u64 {
        let start = Instant::now();
        let frame = source.next_frame(1_000_000_000 + k * period);
        times.push(start.elapsed().as_secs_f64());
        assert!(matches!(frame, Ok(Some(_))));
    }
    let m = median(times);
    println!("SimSource::next_frame taylor-course xtion: median {:.2} ms/frame = {:.0} frames/s", m * 1e3, 1.0 / m);
}

fn main() {
    bench_render("taylor-course", CameraProfile::xtion());
    bench_render("corridor", CameraProfile::xtion());
    bench_render("building", CameraProfile::xtion());
    bench_render("taylor-course", CameraProfile::d435());
    bench_source();
}
