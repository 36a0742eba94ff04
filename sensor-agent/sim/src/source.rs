//! `sim:<world>`: the simulated camera as a [`FrameSource`]. A scripted walker carries
//! the cane through the world; each call renders the depth the camera sees at that
//! moment and adds the IMU samples, odometry and ground truth since the last frame.

use nalgebra::Vector3;
use schemas::{GroundTruth, ImuSample, MountGuess, PhoneMotion, Pressure};

use super::barometer::{BarometerModel, BarometerNoise};
use super::body::BodyMount;
use super::camera::CameraProfile;
use super::cane::CaneMount;
use super::chest::ChestMount;
use super::compass::{CompassModel, CompassNoise, SIM_NORTH_DEG};
use super::guided::{DirectionsHandle, GuidedWalker};
use super::imu::{ImuModel, ImuNoise};
use super::odometry::{OdometryModel, OdometryNoise};
use super::random::SimRng;
use super::render::{Renderer, DEPTH_UNITS_PER_M};
use super::scene::{SceneError, WalkerSpec};
use super::walker::{Ride, ScriptedWalker, Trajectory};
use super::world::{UserPose, World};
use crate::frame::{FrameSource, SourceError, SourceFrame};

/// Everything that makes one simulated run.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Built-in world name or scene file path.
    pub world: String,
    /// Depth camera.
    pub camera: CameraProfile,
    /// Seed of every random draw of the run.
    pub seed: u64,
    /// Cane and camera mounting, sweep.
    pub mount: CaneMount,
    /// Scripted walk; `None` uses the world's own, or stands at the start without one.
    pub walker: Option<WalkerSpec>,
    /// Walk by the device's guidance instead of a script ([`GuidedWalker`]).
    pub guided_by: Option<Guidance>,
    /// IMU sample rate, Hz.
    pub imu_rate_hz: f64,
    /// IMU errors.
    pub imu_noise: ImuNoise,
    /// Sample rate of the IMU worn on the body, Hz (0: none worn).
    pub body_imu_rate_hz: f64,
    /// How the body-worn IMU is worn (its errors are `imu_noise`'s).
    pub body_mount: BodyMount,
    /// Odometry errors.
    pub odometry_noise: OdometryNoise,
    /// Error of the gravity direction sent with each frame, degrees (1 sigma per axis),
    /// as an IMU attitude filter would give it.
    pub gravity_noise_deg: f64,
    /// A second camera (the same model) worn at the chest, rendered with every frame
    /// (`SourceFrame::chest`); `None`: the cane camera alone.
    pub chest: Option<ChestMount>,
    /// The compass of the body-worn phone (read at the phone's heading, so its mount is
    /// the body IMU's, `body_mount`), sent at 10 Hz; `None`: no compass.
    pub compass: Option<CompassNoise>,
    /// The cane board's barometer, read with every frame; `None`: no barometer.
    pub barometer: Option<BarometerNoise>,
    /// A fault: the barometer stops sending when the first elevator ride starts, and
    /// does not come back (what the compute agent does when it no longer hears it).
    pub barometer_stops_in_ride: bool,
}

impl Default for SimConfig {
    /// The taylor-course with the Xtion, default cane, 200 Hz IMU, a 100 Hz IMU on the
    /// body, seed 1.
    fn default() -> Self {
        SimConfig {
            world: "taylor-course".into(),
            camera: CameraProfile::xtion(),
            seed: 1,
            mount: CaneMount::default(),
            walker: None,
            guided_by: None,
            imu_rate_hz: 200.0,
            imu_noise: ImuNoise::default(),
            body_imu_rate_hz: 100.0,
            body_mount: BodyMount::default(),
            odometry_noise: OdometryNoise::default(),
            gravity_noise_deg: 0.5,
            chest: None,
            compass: Some(CompassNoise { mount_deg: 0.0, ..CompassNoise::default() }),
            barometer: Some(BarometerNoise::default()),
            barometer_stops_in_ride: false,
        }
    }
}

/// The directions a guided walker follows (two configs are equal when they share them).
#[derive(Debug, Clone)]
pub struct Guidance(pub DirectionsHandle);

impl PartialEq for Guidance {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Who walks: a script, or a user following guidance.
#[derive(Debug)]
enum Walker {
    Scripted(ScriptedWalker),
    Guided(GuidedWalker),
}

impl Trajectory for Walker {
    fn pose_at(&self, t_s: f64) -> UserPose {
        match self {
            Walker::Scripted(w) => w.pose_at(t_s),
            Walker::Guided(w) => Trajectory::pose_at(w, t_s),
        }
    }

    fn speed_at(&self, t_s: f64) -> f64 {
        match self {
            Walker::Scripted(w) => w.speed_at(t_s),
            Walker::Guided(w) => Trajectory::speed_at(w, t_s),
        }
    }

    fn ride_at(&self, t_s: f64) -> Option<Ride> {
        match self {
            Walker::Scripted(_) => None,
            Walker::Guided(w) => w.ride_at(t_s),
        }
    }
}

/// How far ahead of a frame a guided walker is walked, seconds: the IMUs' differences
/// and the walking speed (10 ms either side) look a little past the frame.
const GUIDED_LEAD_S: f64 = 0.05;

/// The IMU worn on the body.
#[derive(Debug)]
struct BodyImu {
    imu: ImuModel,
    mount: BodyMount,
    rate_hz: f64,
    /// Index of the next sample.
    next: u64,
}

/// The camera worn at the chest: its own renderer, noise and odometry (of the body it
/// turns with).
#[derive(Debug)]
struct ChestCamera {
    mount: ChestMount,
    renderer: Renderer,
    depth_rng: SimRng,
    gravity_rng: SimRng,
    odometry: OdometryModel,
    last: Option<(UserPose, u64)>,
}

/// The body-worn phone's compass and step count.
#[derive(Debug)]
struct PhoneCompass {
    model: CompassModel,
    /// index of the next 10 Hz reading
    next: u64,
    walked_m: f64,
}

/// Compass readings a second.
const COMPASS_HZ: f64 = 10.0;
/// A step's length, for the phone's step count, metres.
const STRIDE_M: f64 = 0.7;

/// What the last frame was taken at.
#[derive(Debug, Clone, Copy)]
struct LastFrame {
    stamp_ns: u64,
    user: UserPose,
}

/// The simulated depth camera on the cane.
#[derive(Debug)]
pub struct SimSource {
    world: World,
    renderer: Renderer,
    walker: Walker,
    mount: CaneMount,
    depth_rng: SimRng,
    gravity_rng: SimRng,
    imu: ImuModel,
    odometry: OdometryModel,
    imu_rate_hz: f64,
    body: BodyImu,
    chest: Option<ChestCamera>,
    compass: Option<PhoneCompass>,
    barometer: Option<BarometerModel>,
    /// stop the barometer for good when a ride starts (`SimConfig::barometer_stops_in_ride`)
    barometer_stops_in_ride: bool,
    gravity_noise_rad: f64,
    start_ns: Option<u64>,
    next_imu: u64,
    last: Option<LastFrame>,
    scratch: Vec<u16>,
}

impl SimSource {
    /// Loads the world and sets up the run.
    pub fn new(config: SimConfig) -> Result<Self, SceneError> {
        let world = World::load(&config.world)?;
        let walker = match (&config.guided_by, config.walker.as_ref().or(world.walker())) {
            (Some(g), _) => Walker::Guided(GuidedWalker::new(world.start(), g.0.clone(), world.elevators().to_vec())),
            (None, Some(spec)) => Walker::Scripted(ScriptedWalker::new(world.start(), spec)),
            (None, None) => Walker::Scripted(ScriptedWalker::standing(world.start())),
        };
        let mut rng = SimRng::seed_from(config.seed);
        Ok(SimSource {
            renderer: Renderer::new(config.camera.clone()),
            walker,
            mount: config.mount,
            depth_rng: rng.fork(),
            gravity_rng: rng.fork(),
            imu: ImuModel::new(config.imu_noise, rng.fork()),
            odometry: OdometryModel::new(config.odometry_noise, rng.fork()),
            imu_rate_hz: config.imu_rate_hz,
            // forked after every other stream, so they draw what they always drew
            body: BodyImu {
                imu: ImuModel::new(config.imu_noise, rng.fork()),
                mount: config.body_mount,
                rate_hz: config.body_imu_rate_hz,
                next: 0,
            },
            chest: config.chest.map(|mount| ChestCamera {
                mount,
                renderer: Renderer::new(config.camera.clone()),
                depth_rng: rng.fork(),
                gravity_rng: rng.fork(),
                odometry: OdometryModel::new(config.odometry_noise, rng.fork()),
                last: None,
            }),
            // after every other stream, so they draw what they always drew
            compass: config.compass.map(|noise| PhoneCompass {
                model: CompassModel::new(noise, rng.fork()),
                next: 0,
                walked_m: 0.0,
            }),
            // after every other stream, so they draw what they always drew
            barometer: config.barometer.map(|noise| BarometerModel::new(noise, rng.fork())),
            barometer_stops_in_ride: config.barometer_stops_in_ride,
            gravity_noise_rad: config.gravity_noise_deg.to_radians(),
            start_ns: None,
            next_imu: 0,
            last: None,
            scratch: Vec::new(),
            world,
        })
    }

    /// The world being walked.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The walker's pose `t_s` seconds after the first frame.
    pub fn user_pose_at(&self, t_s: f64) -> UserPose {
        self.walker.pose_at(t_s)
    }

    fn noisy_gravity(&mut self, g: Vector3<f64>) -> [f32; 3] {
        noisy_gravity(&mut self.gravity_rng, self.gravity_noise_rad, g)
    }

    /// The chest camera's frame at `t_s` (the moment of the cane camera's `stamp_ns`).
    fn chest_frame(&mut self, t_s: f64, stamp_ns: u64) -> Option<SourceFrame> {
        let chest = self.chest.as_mut()?;
        let (walker, mount) = (&self.walker, self.mount);
        let user = walker.pose_at(t_s);
        let camera = chest.mount.camera_pose(&user, mount.bob_at(t_s, walker.speed_at(t_s)));
        let mut depth = Vec::new();
        chest.renderer.render(&self.world, &camera, t_s, &mut chest.depth_rng, &mut depth);
        // the chest's floor frame turns with the body: a visual odometry on it measures that
        let floor = UserPose {
            x_m: camera.position_m.x,
            y_m: camera.position_m.y,
            yaw_rad: camera.yaw_rad(),
            floor: camera.floor,
        };
        let odom = chest.last.map(|(from, from_ns)| chest.odometry.increment(&from, &floor, from_ns, stamp_ns));
        chest.last = Some((floor, stamp_ns));
        let profile = chest.renderer.profile();
        Some(SourceFrame {
            stamp_ns,
            width: profile.width,
            height: profile.height,
            depth_scale_m: 1.0 / DEPTH_UNITS_PER_M,
            intrinsics: chest.renderer.intrinsics(),
            depth,
            gravity_camera: Some(noisy_gravity(
                &mut chest.gravity_rng,
                self.gravity_noise_rad,
                camera.gravity_camera(),
            )),
            mount: Some(MountGuess { height_m: chest.mount.height_m as f32, pitch_deg: chest.mount.pitch_deg as f32 }),
            imu: Vec::new(),
            body_imu: Vec::new(),
            motion: None,
            pressure: None,
            odom,
            truth: None,
            chest: None,
        })
    }
}

/// `g` tipped by an attitude filter's error (`sigma_rad` per axis), unit length: the
/// gravity a frame is sent with.
pub fn noisy_gravity(rng: &mut SimRng, sigma_rad: f64, g: Vector3<f64>) -> [f32; 3] {
    let tilted = g + Vector3::new(rng.gaussian() * sigma_rad, rng.gaussian() * sigma_rad, rng.gaussian() * sigma_rad);
    let u = tilted.normalize();
    [u.x as f32, u.y as f32, u.z as f32]
}

/// How high the user's floor is at `t_s` above the building's zero, metres: `floor`'s
/// elevation (the floor the user stands on then), and in a lift the car's (smoothly
/// from stop to stop).
fn user_height_m(world: &World, walker: &impl Trajectory, t_s: f64, floor: i32) -> f64 {
    let elevation = |floor: i32| world.floors().iter().find(|f| f.index == floor).map_or(0.0, |f| f.elevation_m);
    match walker.ride_at(t_s) {
        Some(r) => {
            let f = r.done.clamp(0.0, 1.0);
            let (from, to) = (elevation(r.from_floor), elevation(r.to_floor));
            from + (to - from) * (3.0 * f * f - 2.0 * f * f * f)
        }
        None => elevation(floor),
    }
}

/// The camera at `t_s`: the walker's pose, the cane's sweep and the walking bob.
fn camera_pose_at(walker: &impl Trajectory, mount: &CaneMount, t_s: f64) -> super::pose::CameraPose {
    let user = walker.pose_at(t_s);
    mount.camera_pose_bobbing(&user, mount.sweep_rad(t_s), mount.bob_at(t_s, walker.speed_at(t_s)))
}

impl FrameSource for SimSource {
    fn describe(&self) -> String {
        format!("sim:{}", self.world.name())
    }

    fn next_frame(&mut self, now_ns: u64) -> Result<Option<SourceFrame>, SourceError> {
        let start_ns = *self.start_ns.get_or_insert(now_ns);
        // Simulated time never runs backwards, whatever the caller's clock does.
        let stamp_ns = self.last.map_or(now_ns, |l| now_ns.max(l.stamp_ns));
        let t_s = stamp_ns.saturating_sub(start_ns) as f64 * 1e-9;
        if let Walker::Guided(w) = &mut self.walker {
            w.advance_to(t_s + GUIDED_LEAD_S);
        }

        let user = self.walker.pose_at(t_s);
        let sweep = self.mount.sweep_rad(t_s);
        let (walker, mount) = (&self.walker, self.mount);
        let camera_at = |t: f64| camera_pose_at(walker, &mount, t);
        let camera = camera_at(t_s);
        self.renderer.render(&self.world, &camera, t_s, &mut self.depth_rng, &mut self.scratch);

        let mut imu = Vec::new();
        loop {
            let t_k = self.next_imu as f64 / self.imu_rate_hz;
            if t_k > t_s {
                break;
            }
            let (gyro, accel) = self.imu.sample(t_k, camera_at);
            imu.push(ImuSample {
                stamp_ns: start_ns + (t_k * 1e9).round() as u64,
                gyro_rad_s: gyro,
                accel_m_s2: accel,
            });
            self.next_imu += 1;
        }
        let mut body_imu = Vec::new();
        let body = &mut self.body;
        while body.rate_hz > 0.0 {
            let t_k = body.next as f64 / body.rate_hz;
            if t_k > t_s {
                break;
            }
            let mount = body.mount;
            let (gyro, accel) = body.imu.sample(t_k, |t| mount.pose_at(walker, t));
            body_imu.push(ImuSample {
                stamp_ns: start_ns + (t_k * 1e9).round() as u64,
                gyro_rad_s: gyro,
                accel_m_s2: accel,
            });
            body.next += 1;
        }
        let motion = self.compass.as_mut().and_then(|c| {
            c.walked_m += self.last.map_or(0.0, |l| (user.x_m - l.user.x_m).hypot(user.y_m - l.user.y_m));
            if (c.next as f64 / COMPASS_HZ) > t_s {
                return None;
            }
            c.next = (t_s * COMPASS_HZ).floor() as u64 + 1;
            let phone = self.body.mount.pose_at(walker, t_s).yaw_rad();
            let heading = c.model.read(user.x_m, user.y_m, phone, SIM_NORTH_DEG.to_radians());
            Some(PhoneMotion { heading_deg: Some(heading), accuracy_deg: None, steps: (c.walked_m / STRIDE_M) as u64 })
        });
        let height_m = user_height_m(&self.world, &self.walker, t_s, user.floor);
        if self.barometer_stops_in_ride && self.walker.ride_at(t_s).is_some() {
            self.barometer = None;
        }
        let pressure = self.barometer.as_mut().map(|b| Pressure { stamp_ns, pressure_pa: b.read(t_s, height_m) });
        let odom = self.last.map(|l| self.odometry.increment(&l.user, &user, l.stamp_ns, stamp_ns));
        let gravity = self.noisy_gravity(camera.gravity_camera());
        self.last = Some(LastFrame { stamp_ns, user });
        let chest = self.chest_frame(t_s, stamp_ns).map(Box::new);

        let profile = self.renderer.profile();
        Ok(Some(SourceFrame {
            stamp_ns,
            width: profile.width,
            height: profile.height,
            depth_scale_m: 1.0 / DEPTH_UNITS_PER_M,
            intrinsics: self.renderer.intrinsics(),
            depth: self.scratch.clone(),
            gravity_camera: Some(gravity),
            mount: Some(MountGuess {
                height_m: self.mount.camera_height_m() as f32,
                pitch_deg: self.mount.pitch_deg as f32,
            }),
            imu,
            body_imu,
            motion,
            pressure,
            odom,
            truth: Some(GroundTruth {
                x_m: user.x_m as f32,
                y_m: user.y_m as f32,
                yaw_rad: user.yaw_rad as f32,
                floor: user.floor,
                camera_height_m: camera.position_m.z as f32,
                camera_pitch_deg: camera.pitch_down_rad().to_degrees() as f32,
                sweep_deg: sweep.to_degrees() as f32,
            }),
            chest,
        }))
    }

    fn period_ns(&self) -> u64 {
        (1e9 / self.renderer.profile().rate_hz).round() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn source(config: SimConfig) -> SimSource {
        match SimSource::new(config) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        }
    }

    /// Standing on floor 1 of `building` until 10 s, then a 5 s lift ride down to 0.
    struct RideDown;

    impl Trajectory for RideDown {
        fn pose_at(&self, t_s: f64) -> UserPose {
            UserPose { x_m: 19.0, y_m: 5.0, yaw_rad: 0.0, floor: if t_s < 15.0 { 1 } else { 0 } }
        }

        fn speed_at(&self, _t_s: f64) -> f64 {
            0.0
        }

        fn ride_at(&self, t_s: f64) -> Option<Ride> {
            (10.0..15.0).contains(&t_s).then(|| Ride { from_floor: 1, to_floor: 0, done: (t_s - 10.0) / 5.0 })
        }
    }

    #[test]
    fn the_barometers_height_is_the_floors_and_in_a_lift_the_cars_between_them() {
        let world = World::load("building").unwrap();
        let heights: Vec<f64> = [0.0, 10.0, 12.5, 14.9, 15.0, 30.0]
            .map(|t| user_height_m(&world, &RideDown, t, RideDown.pose_at(t).floor))
            .to_vec();
        // floor 1 is 3.5 m up
        assert_eq!(heights[0], 3.5);
        assert_eq!(heights[1], 3.5);
        assert!((heights[2] - 1.75).abs() < 1e-9, "{heights:?}");
        assert!(heights[3] < 0.01 && heights[3] > 0.0, "{heights:?}");
        assert_eq!(heights[4..], [0.0, 0.0]);
        // and the frames carry the pressure at the user's floor, every frame
        let mut s = source(SimConfig { world: "building".into(), ..SimConfig::default() });
        let first = frame(&mut s, 1_000_000_000);
        let p = first.pressure.expect("a pressure with the frame");
        assert_eq!(p.stamp_ns, first.stamp_ns);
        // the ground floor 120 m above the sea: 99.9 kPa, give or take the noise
        assert!((p.pressure_pa - 99_893.0).abs() < 10.0, "{p:?}");
        let quiet = source(SimConfig { world: "building".into(), barometer: None, ..SimConfig::default() });
        assert_eq!(frame(&mut { quiet }, 1_000_000_000).pressure, None);
    }

    fn frame(s: &mut SimSource, now_ns: u64) -> SourceFrame {
        match s.next_frame(now_ns) {
            Ok(Some(f)) => f,
            other => panic!("no frame: {other:?}"),
        }
    }

    #[test]
    fn a_generated_world_is_walked_along_the_way_its_generator_found() {
        let s = source(SimConfig { world: "gen:street:3".into(), ..SimConfig::default() });
        assert_eq!(s.describe(), "sim:gen:street:3");
        let (start, goal) = (s.user_pose_at(0.0), s.world().goal().clone());
        let end = s.user_pose_at(120.0);
        assert!((end.x_m - goal.x_m).hypot(end.y_m - goal.y_m) < 1e-6, "stops at the goal: {end:?} {goal:?}");
        assert!((goal.x_m - start.x_m) > 20.0, "a street at least 25 m long: {start:?} {goal:?}");
    }

    #[test]
    fn sim_source_streams_xtion_frames_with_imu_odometry_and_truth() {
        let mut s = source(SimConfig::default());
        assert_eq!(s.describe(), "sim:taylor-course");
        assert_eq!(s.period_ns(), 33_333_333);
        let t0 = 1_700_000_000_000_000_000u64;
        let first = frame(&mut s, t0);
        assert_eq!((first.width, first.height, first.depth.len()), (640, 480, 640 * 480));
        assert_eq!(first.depth_scale_m, 0.001);
        assert_eq!(first.stamp_ns, t0);
        assert!(first.odom.is_none(), "no motion before the first frame");
        assert_eq!(first.imu.len(), 1);
        let valid = first.depth.iter().filter(|&&d| d != 0).count();
        assert!(valid > 640 * 480 / 2, "only {valid} valid pixels");
        let truth = first.truth.unwrap_or_else(|| panic!("sim frames carry truth"));
        assert_eq!((truth.x_m, truth.y_m, truth.floor), (0.7, 5.0, 0));
        assert!((truth.camera_pitch_deg - 30.0).abs() < 1e-3);
        let mount = first.mount.unwrap_or_else(|| panic!("mount guess"));
        assert!((mount.height_m - 0.885).abs() < 0.01 && mount.pitch_deg == 30.0);

        let mut imu_count = first.imu.len();
        let mut body_count = first.body_imu.len();
        let mut compass = Vec::from_iter(first.motion);
        let mut last = first;
        for k in 1..=30u64 {
            let now = t0 + k * s.period_ns();
            let f = frame(&mut s, now);
            let odom = f.odom.unwrap_or_else(|| panic!("odometry from the second frame on"));
            assert_eq!((odom.from_ns, odom.to_ns), (last.stamp_ns, f.stamp_ns));
            assert!(f.imu.iter().all(|i| i.stamp_ns > last.stamp_ns && i.stamp_ns <= f.stamp_ns));
            let g = f.gravity_camera.unwrap_or([0.0; 3]);
            assert!(((g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt() - 1.0).abs() < 1e-5);
            // The cane only yaws: true gravity is (0, cos 30, sin 30) in the camera
            // frame; the attitude estimate is within a few degrees of it.
            let cos_err = g[1] * 30f32.to_radians().cos() + g[2] * 30f32.to_radians().sin();
            assert!(cos_err > 3f32.to_radians().cos(), "gravity {g:?}");
            assert!(f.body_imu.iter().all(|i| i.stamp_ns > last.stamp_ns && i.stamp_ns <= f.stamp_ns));
            imu_count += f.imu.len();
            body_count += f.body_imu.len();
            compass.extend(f.motion);
            last = f;
        }
        // 30 frames span 0.99999999 s: 200 Hz samples at 0, 5, ..., 995 ms, each once;
        // the body's 100 Hz at 0, 10, ..., 990 ms.
        assert_eq!((imu_count, body_count), (200, 100));
        // the phone's compass at 10 Hz (0, 100, ..., 900 ms): the walker heads east
        // (north is +y: 90 degrees on the compass) with the phone 10 degrees askew to
        // the left (80), give or take the building's disturbance
        assert_eq!(compass.len(), 10);
        for m in &compass {
            let heading = m.heading_deg.unwrap_or(f32::NAN);
            assert!((heading - 80.0).abs() < 60.0, "compass {heading}");
        }
        // under a stride walked in the first second: no step counted yet
        assert!(compass.iter().all(|m| m.steps == 0), "{compass:?}");
        // The walker set off towards +x at up to 1 m/s.
        let moved = last.truth.map_or(0.0, |t| t.x_m - 0.7);
        assert!((0.4..1.0).contains(&moved), "moved {moved} m in 1 s");
    }

    #[test]
    fn walking_bob_shows_in_camera_height_and_vertical_acceleration() {
        let mut s = source(SimConfig { world: "corridor".into(), ..SimConfig::default() });
        let period = s.period_ns();
        let mut heights = Vec::new();
        let mut up_accel = Vec::new();
        for k in 0..=90u64 {
            let f = frame(&mut s, k * period);
            if k < 30 {
                continue; // first second: setting off
            }
            heights.push(f.truth.map_or(0.0, |t| t.camera_height_m));
            // Specific force along "up" (the reading at rest is +9.81 along -gravity).
            let g = f.gravity_camera.unwrap_or([0.0; 3]);
            for i in &f.imu {
                up_accel.push(-(i.accel_m_s2[0] * g[0] + i.accel_m_s2[1] * g[1] + i.accel_m_s2[2] * g[2]) as f64);
            }
        }
        let span = heights.iter().copied().fold(f32::MIN, f32::max) - heights.iter().copied().fold(f32::MAX, f32::min);
        assert!((0.025..0.035).contains(&span), "camera height varies by {span} m");
        let n = up_accel.len() as f64;
        let mean = up_accel.iter().sum::<f64>() / n;
        let sd = (up_accel.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / n).sqrt();
        // 1.5 cm at 1.8 Hz: (2 pi 1.8)^2 * 0.015 = 1.9 m/s^2 peak, 1.35 RMS.
        assert!((mean - 9.81).abs() < 0.3, "mean {mean}");
        assert!((1.0..1.8).contains(&sd), "vertical acceleration RMS {sd}");
    }

    #[test]
    fn a_guided_walk_moves_the_imus_as_smoothly_as_a_scripted_one() {
        use crate::guided::Directions;
        use schemas::{LocalizationStatus, MapPoint, Pose, RouteStatus};
        let directions = std::sync::Arc::new(std::sync::Mutex::new(Directions {
            status: Some(RouteStatus::Guiding),
            next: Some(MapPoint { x_m: 8.0, y_m: 6.0, floor: 0 }),
            next_floor: None,
            estimate: Some(Pose {
                x_m: 1.0,
                y_m: 5.0,
                yaw_rad: 0.0,
                floor: 0,
                covariance: [0.0; 9],
                status: LocalizationStatus::Tracking,
                guides: true,
            }),
            said_floor: None,
        }));
        let guided =
            SimConfig { world: "building".into(), guided_by: Some(Guidance(directions)), ..SimConfig::default() };
        let scripted = SimConfig { world: "building".into(), ..SimConfig::default() };
        let largest = |config: SimConfig| {
            let mut s = source(config);
            let mut worst = (0f32, 0f32);
            let mut end = None;
            for k in 0..150u64 {
                let period = s.period_ns();
                let f = frame(&mut s, k * period);
                for i in f.imu.iter().chain(&f.body_imu) {
                    let norm = |v: [f32; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    worst = (worst.0.max(norm(i.accel_m_s2)), worst.1.max(norm(i.gyro_rad_s)));
                }
                end = f.truth;
            }
            (worst, end.map(|t| (t.x_m, t.y_m)))
        };
        let ((accel, gyro), end) = largest(guided);
        let ((accel_scripted, gyro_scripted), _) = largest(scripted);
        // it walked towards (8, 6) from (1, 5)
        let (x, y) = end.unwrap_or_default();
        assert!(x > 4.0 && y > 5.1, "ended at ({x}, {y})");
        assert!(accel < accel_scripted * 1.5 && accel < 30.0, "{accel} m/s^2 (scripted {accel_scripted})");
        assert!(gyro < gyro_scripted * 1.5 + 0.5, "{gyro} rad/s (scripted {gyro_scripted})");
    }

    #[test]
    fn sim_source_repeats_exactly_for_a_seed() {
        let frames = |seed: u64| {
            let mut s = source(SimConfig { world: "corridor".into(), seed, ..SimConfig::default() });
            (0..3u64).map(|k| frame(&mut s, 5_000_000_000 + k * 33_333_333)).collect::<Vec<_>>()
        };
        assert_eq!(frames(4), frames(4));
        assert_ne!(frames(4), frames(5));
    }

    #[test]
    fn approach_walker_brings_the_wall_near_and_backs_away_in_a_loop() {
        let mut s = source(SimConfig { world: "approach".into(), ..SimConfig::default() });
        let period = s.period_ns();
        // Median valid reading of the central 41 x 41 pixels, mm, per frame; 24 s.
        let mut series = Vec::new();
        for k in 0..720u64 {
            let f = frame(&mut s, k * period);
            let mut centre: Vec<u16> = (220..=260)
                .flat_map(|v| (300..=340).map(move |u| v * 640 + u))
                .map(|i| f.depth[i])
                .filter(|&d| d != 0)
                .collect();
            centre.sort_unstable();
            series.push(centre.get(centre.len() / 2).copied().unwrap_or(0));
        }
        // Far: the centre sees the floor 1.77 m ahead. Near: the wall 0.7 m ahead (0.81 m
        // along the tipped axis). Then far again, and near again.
        let far = |d: u16| d > 1700;
        let near = |d: u16| d != 0 && d < 900;
        let mut phases = Vec::new();
        for &d in &series {
            let phase = if far(d) {
                'F'
            } else if near(d) {
                'N'
            } else {
                continue;
            };
            if phases.last() != Some(&phase) {
                phases.push(phase);
            }
        }
        assert!(phases.len() >= 4 && phases[..4] == ['F', 'N', 'F', 'N'], "phases {phases:?}");
    }
}
