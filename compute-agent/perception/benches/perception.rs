//! Per-stage medians of the perception pipeline on the real captures, on analytic
//! synthetic frames and on the simulator's noisy frames at 10 and 30 deg pitch:
//! `cargo bench -p perception --bench perception`.
//! One core, one frame at a time, the pipeline reused across runs as in the agent.
//! `PERCEPTION_BENCH_RUNS` sets the runs per frame (default 200). Last, the memory
//! beyond the field of view alone, full of a walk's worth of obstacles.

use std::path::Path;
use std::time::Instant;

use perception::config::{DropoffConfig, MemoryConfig};
use perception::dropoff::StepZone;
use perception::obstacle_memory::{ObstacleMemory, ViewCone};
use perception::synthetic_scene::{Block, Scene};
use perception::{DepthInput, FrameContext, InstantTimer, Motion, PerceptionConfig, Pipeline, StageMedians};
use schemas::Intrinsics;

enum Frame {
    Depth { samples: Vec<u16>, width: u32, height: u32, scale_m: f32, k: Intrinsics },
    Xyz { points: Vec<[f32; 3]>, width: u32, height: u32 },
}

struct Case {
    name: String,
    frame: Frame,
    gravity: Option<[f32; 3]>,
    up_cone_deg: Option<f32>,
}

const KINECT: Intrinsics = Intrinsics { fx: 525.0, fy: 525.0, cx: 319.5, cy: 239.5 };

/// The organized cloud a depth image deprojects to (NaN where invalid): how PCL's
/// grabbers made the PCDs the two derived PNGs come from (tests/data/README.md).
fn deproject(samples: &[u16], width: u32, scale_m: f32, k: Intrinsics) -> Vec<[f32; 3]> {
    let w = width as usize;
    samples
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            if d == 0 {
                return [f32::NAN; 3];
            }
            let z = d as f32 * scale_m;
            let (u, v) = ((i % w) as f32, (i / w) as f32);
            [(u - k.cx) * z / k.fx, (v - k.cy) * z / k.fy, z]
        })
        .collect()
}

/// The real captures kept in the repository (`tests/data/real/`); a missing or broken
/// one is a broken checkout, so it panics with the path.
fn real_cases() -> Vec<Case> {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/real"));
    let mut cases = Vec::new();
    let path = dir.join("five_people.pcd");
    let cloud = sensor_agent::formats::pcd::read(&path).unwrap_or_else(|e| panic!("{e}"));
    cases.push(Case {
        name: "five_people.pcd".into(),
        frame: Frame::Xyz { points: cloud.points, width: cloud.width, height: cloud.height },
        gravity: None,
        up_cone_deg: None,
    });
    // The two other PCL captures, kept as depth PNGs, run as the clouds they were.
    let (s, c) = 46f32.to_radians().sin_cos();
    for (origin, file, scale_m, k, gravity) in [
        (
            "table_scene_mug_stereo_textured.pcd",
            "table_scene_depth_640x480_u16_100um.png",
            0.0001,
            Intrinsics { fx: 964.36, fy: 964.36, cx: 319.81, cy: 223.36 },
            None,
        ),
        (
            "frame_20121214T142255.814212.pcd",
            "desk_openni_depth_640x480_u16_mm.png",
            0.001,
            Intrinsics { fx: 525.0, fy: 525.0, cx: 320.0, cy: 240.0 },
            Some([0.0, c, s]),
        ),
    ] {
        let png = sensor_agent::formats::depth_png::read(&dir.join(file)).unwrap_or_else(|e| panic!("{e}"));
        cases.push(Case {
            name: format!("{origin} (from {file})"),
            frame: Frame::Xyz {
                points: deproject(&png.samples, png.width, scale_m, k),
                width: png.width,
                height: png.height,
            },
            gravity,
            up_cone_deg: None,
        });
    }
    // TUM's floor is ~29 deg from camera -y: outside the thesis's 20 deg cone
    for (file, scale_m, up_cone_deg) in [
        ("tum_depth_640x480_u16_5000perm.png", 0.0002, Some(35.0)),
        ("redwood_00000_depth_640x480_u16_mm.png", 0.001, None),
    ] {
        let png = sensor_agent::formats::depth_png::read(&dir.join(file)).unwrap_or_else(|e| panic!("{e}"));
        cases.push(Case {
            name: file.into(),
            frame: Frame::Depth { samples: png.samples, width: png.width, height: png.height, scale_m, k: KINECT },
            gravity: None,
            up_cone_deg,
        });
    }
    cases
}

fn synthetic_cases() -> Vec<Case> {
    [10.0f32, 30.0]
        .into_iter()
        .map(|pitch| {
            let mut scene = Scene::kinect(1.0, pitch);
            scene.walls_x_m.push(3.5);
            scene.blocks.push(Block { min: [1.5, -0.15, 0.0], max: [1.8, 0.15, 0.12] });
            scene.blocks.push(Block { min: [2.2, 0.4, 0.0], max: [2.6, 0.9, 1.1] });
            let [a, b, c, _] = scene.floor_plane_camera();
            Case {
                name: format!("synthetic floor+wall+boxes, pitch {pitch} deg"),
                frame: Frame::Depth {
                    samples: scene.render_depth(0.001),
                    width: scene.width,
                    height: scene.height,
                    scale_m: 0.001,
                    k: scene.intrinsics,
                },
                gravity: Some([-a, -b, -c]),
                up_cone_deg: None,
            }
        })
        .collect()
}

/// Noisy simulator frames (Xtion-class noise, dropouts, shadow bands) in the corridor
/// world, camera 1.0 m up.
fn simulator_cases() -> Vec<Case> {
    use sensor_agent::sim::{camera::CameraProfile, pose::CameraPose, random::SimRng, render::Renderer, world::World};
    let world = World::builtin("corridor").expect("the corridor world is built in").expect("it parses");
    let start = world.start();
    [10.0f64, 30.0]
        .into_iter()
        .map(|pitch| {
            let pose =
                CameraPose::from_yaw_pitch(start.x_m, start.y_m, 1.0, start.yaw_rad, pitch.to_radians(), start.floor);
            let mut renderer = Renderer::new(CameraProfile::xtion());
            let mut samples = Vec::new();
            renderer.render(&world, &pose, 0.0, &mut SimRng::seed_from(7), &mut samples);
            let g = pose.gravity_camera();
            let p = renderer.profile();
            Case {
                name: format!("simulator corridor, pitch {pitch} deg"),
                frame: Frame::Depth {
                    samples,
                    width: p.width,
                    height: p.height,
                    scale_m: 0.001,
                    k: renderer.intrinsics(),
                },
                gravity: Some([g.x as f32, g.y as f32, g.z as f32]),
                up_cone_deg: None,
            }
        })
        .collect()
}

fn main() {
    let runs: usize = std::env::var("PERCEPTION_BENCH_RUNS").ok().and_then(|s| s.parse().ok()).unwrap_or(200);
    println!("perception pipeline, {runs} runs per frame, medians in ms (shared machine: expect noise)");
    for case in real_cases().into_iter().chain(synthetic_cases()).chain(simulator_cases()) {
        let mut config = PerceptionConfig::default();
        if let Some(deg) = case.up_cone_deg {
            config.ground.up_cone_deg = deg;
        }
        let mut pipeline = Pipeline::new(config);
        let mut timer = InstantTimer::default();
        let mut medians = StageMedians::default();
        let mut last = None;
        for k in 0..runs {
            let input = match &case.frame {
                Frame::Depth { samples, width, height, scale_m, k } => DepthInput::Depth {
                    samples,
                    width: *width,
                    height: *height,
                    depth_scale_m: *scale_m,
                    intrinsics: *k,
                },
                Frame::Xyz { points, width, height } => DepthInput::Xyz { points, width: *width, height: *height },
            };
            let ctx = FrameContext {
                stamp_ns: k as u64 * 33_333_333,
                gravity_camera: case.gravity,
                motion: None,
                body_yaw_rate_rad_s: None,
                mount_height_m: None,
                mount_pitch_deg: None,
            };
            timer.clear();
            let t0 = Instant::now();
            let result = pipeline.process(input, &ctx, &mut timer).map(|p| (p.ground, p.plane_camera));
            medians.add(&timer.stages, t0.elapsed());
            last = Some(result);
        }
        let stages: Vec<String> = medians.stages_ms().iter().map(|(n, ms)| format!("{n}={ms:.3}")).collect();
        println!("{}\n  total={:.3}  {}", case.name, medians.total_ms(), stages.join(" "));
        match last {
            Some(Ok((ground, plane))) => println!("  ground {ground:?}, plane {plane:.4?}"),
            Some(Err(e)) => println!("  error: {e}"),
            None => {}
        }
    }
    memory_bench(runs);
    predictive_bench(runs, false);
    predictive_bench(runs, true);
}

/// The predictive cue on its own in a corridor 1.6 m wide with a bin on the way 2.5 m
/// ahead (what the perception would hold of them every 5 cm, about 350 points) and the
/// corridor's walls known: each frame the user steps 3 cm with the cane sweeping, and
/// the cue walks its model ahead under each state it needs. Prints the median per frame
/// and the share of frames that needed more than the look-ahead of clear. With
/// `sign`, a sign 0.8 m wide hangs across the way 1.5 m past the bin, held by a chest
/// camera (points only the body can touch: each state is walked straight on too).
fn predictive_bench(runs: usize, sign: bool) {
    use perception::predictive::{Ahead, PredictiveConfig, PredictiveCue, Way};
    let line = |a: [f64; 2], b: [f64; 2]| {
        let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / 0.05).ceil() as usize;
        (0..=n).map(move |i| {
            let f = i as f64 / n as f64;
            [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]
        })
    };
    let mut cue = PredictiveCue::new(PredictiveConfig::default());
    let sweep = |k: usize| 17f64.to_radians() * (std::f64::consts::TAU * 0.7 * k as f64 / 30.0).sin();
    let mut times = Vec::with_capacity(runs);
    let mut warned = 0;
    let frames = 30 + runs;
    for k in 0..frames {
        // the body 3 cm further each frame, the bin and walls as seen from the camera
        let x0 = 0.03 * (k % 60) as f64;
        let walls: Vec<[f64; 2]> =
            line([-1.0 - x0, 0.8], [6.0 - x0, 0.8]).chain(line([-1.0 - x0, -0.8], [6.0 - x0, -0.8])).collect();
        let camera_x = 0.25 + 0.096;
        let points: Vec<[f32; 2]> = walls
            .iter()
            .copied()
            .chain(line([2.5 - x0, -0.2], [2.5 - x0, 0.2]))
            .map(|p| [(p[0] - camera_x) as f32, p[1] as f32])
            .collect();
        let way = [[0.0, 0.0], [10.0, 0.0]];
        let body_points: Vec<[f32; 2]> = if sign {
            line([4.0 - x0, -0.4], [4.0 - x0, 0.4]).map(|p| [p[0] as f32, p[1] as f32]).collect()
        } else {
            Vec::new()
        };
        let now = Ahead {
            t_s: k as f64 / 30.0,
            way: Way { points: &way, ends_at_goal: true, walls: &walls },
            points: &points,
            cane_finds: &[],
            body_points: &body_points,
            sweep_rad: sweep(k),
            speed_m_s: 1.0,
            yaw_rate_rad_s: Some(0.0),
        };
        let t0 = Instant::now();
        let state = cue.decide(&now);
        let elapsed = t0.elapsed().as_secs_f64() * 1e3;
        cue.sent(now.t_s, state);
        if k >= 30 {
            times.push(elapsed);
            warned += usize::from(state != schemas::Rumble::None);
        }
    }
    times.sort_by(f64::total_cmp);
    println!(
        "predictive cue, corridor 1.6 m with a bin on the way{}\n  decide={:.3} ms median, p90 {:.3} ms, {} of {} frames warned",
        if sign { " and a chest camera's sign past it" } else { "" },
        times[times.len() / 2],
        times[times.len() * 9 / 10],
        warned,
        times.len()
    );
}

/// The memory's update on its own, as on a walk down a corridor lined with obstacles:
/// each frame the user steps 3 cm and the cane sweeps, and the scan adds 60 points
/// (one per degree) 1-4 m ahead. Prints the median per frame, that of the check for lower
/// ground between the feet and the camera over the same cells, and the cells held.
fn memory_bench(runs: usize) {
    let cfg = MemoryConfig::default();
    let view = ViewCone {
        half_hfov_rad: 29f32.to_radians(),
        half_vfov_rad: 22.5f32.to_radians(),
        pitch_down_rad: 30f32.to_radians(),
        camera_height_m: 0.9,
        range_max_m: 4.0,
    };
    let mut memory = ObstacleMemory::default();
    let zone = StepZone::new(&DropoffConfig::default());
    let frames = 300 + runs;
    let mut times = Vec::with_capacity(runs);
    let sweep = |k: usize| 17f32.to_radians() * (std::f32::consts::TAU * 0.7 * k as f32 / 30.0).sin();
    for k in 1..=frames {
        let d = sweep(k) - sweep(k - 1);
        let motion = Motion { forward_m: 0.03, left_m: 0.0, yaw_rad: d };
        let scan = (0..60).map(|b| {
            let bearing = (b as f32 - 29.5).to_radians();
            let r = 1.0 + 3.0 * ((k * 7 + b * 13) % 29) as f32 / 29.0;
            [r * bearing.cos(), r * bearing.sin(), 0.5]
        });
        let t0 = Instant::now();
        memory.update(k as u64 * 33_333_333, Some(motion), &view, scan, &cfg);
        let t1 = Instant::now();
        // every cell is looked at: none is lower ground here
        std::hint::black_box(memory.lower_ground_where(|p| zone.contains(p)));
        if k > 300 {
            times.push(((t1 - t0).as_secs_f64() * 1e3, t1.elapsed().as_secs_f64() * 1e3));
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "obstacle memory, walking and sweeping\n  update={:.3} ms median, step zone check={:.4} ms, {} cells held, {} out of view",
        median(times.iter().map(|t| t.0).collect()),
        median(times.iter().map(|t| t.1).collect()),
        memory.len(),
        memory.out_of_view.len()
    );
}
