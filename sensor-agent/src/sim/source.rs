//! `sim:<world>`: the simulated camera as a [`FrameSource`]. A scripted walker carries
//! the cane through the world; each call renders the depth the camera sees at that
//! moment and adds the IMU samples, odometry and ground truth since the last frame.

use nalgebra::Vector3;
use schemas::{GroundTruth, ImuSample, MountGuess};

use super::camera::CameraProfile;
use super::cane::CaneMount;
use super::imu::{ImuModel, ImuNoise};
use super::odometry::{OdometryModel, OdometryNoise};
use super::random::SimRng;
use super::render::{Renderer, DEPTH_UNITS_PER_M};
use super::scene::{SceneError, WalkerSpec};
use super::walker::ScriptedWalker;
use super::world::{UserPose, World};
use crate::source::{FrameSource, SourceError, SourceFrame};

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
    /// IMU sample rate, Hz.
    pub imu_rate_hz: f64,
    /// IMU errors.
    pub imu_noise: ImuNoise,
    /// Odometry errors.
    pub odometry_noise: OdometryNoise,
    /// Error of the gravity direction sent with each frame, degrees (1 sigma per axis),
    /// as an IMU attitude filter would give it.
    pub gravity_noise_deg: f64,
}

impl Default for SimConfig {
    /// The taylor-course with the Xtion, default cane, 200 Hz IMU, seed 1.
    fn default() -> Self {
        SimConfig {
            world: "taylor-course".into(),
            camera: CameraProfile::xtion(),
            seed: 1,
            mount: CaneMount::default(),
            walker: None,
            imu_rate_hz: 200.0,
            imu_noise: ImuNoise::default(),
            odometry_noise: OdometryNoise::default(),
            gravity_noise_deg: 0.5,
        }
    }
}

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
    walker: ScriptedWalker,
    mount: CaneMount,
    depth_rng: SimRng,
    gravity_rng: SimRng,
    imu: ImuModel,
    odometry: OdometryModel,
    imu_rate_hz: f64,
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
        let walker = match config.walker.as_ref().or(world.walker()) {
            Some(spec) => ScriptedWalker::new(world.start(), spec),
            None => ScriptedWalker::standing(world.start()),
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
        let s = self.gravity_noise_rad;
        let tilted = g + Vector3::new(self.gravity_rng.gaussian() * s, self.gravity_rng.gaussian() * s, self.gravity_rng.gaussian() * s);
        let u = tilted.normalize();
        [u.x as f32, u.y as f32, u.z as f32]
    }
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

        let user = self.walker.pose_at(t_s);
        let sweep = self.mount.sweep_rad(t_s);
        let camera = self.mount.camera_pose(&user, sweep);
        self.renderer.render(&self.world, &camera, t_s, &mut self.depth_rng, &mut self.scratch);

        let mut imu = Vec::new();
        let (walker, mount) = (&self.walker, self.mount);
        let camera_at = |t: f64| mount.camera_pose(&walker.pose_at(t), mount.sweep_rad(t));
        loop {
            let t_k = self.next_imu as f64 / self.imu_rate_hz;
            if t_k > t_s {
                break;
            }
            let (gyro, accel) = self.imu.sample(t_k, camera_at);
            imu.push(ImuSample { stamp_ns: start_ns + (t_k * 1e9).round() as u64, gyro_rad_s: gyro, accel_m_s2: accel });
            self.next_imu += 1;
        }
        let odom = self.last.map(|l| self.odometry.increment(&l.user, &user, l.stamp_ns, stamp_ns));
        let gravity = self.noisy_gravity(camera.gravity_camera());
        self.last = Some(LastFrame { stamp_ns, user });

        let profile = self.renderer.profile();
        Ok(Some(SourceFrame {
            stamp_ns,
            width: profile.width,
            height: profile.height,
            depth_scale_m: 1.0 / DEPTH_UNITS_PER_M,
            intrinsics: self.renderer.intrinsics(),
            depth: self.scratch.clone(),
            gravity_camera: Some(gravity),
            mount: Some(MountGuess { height_m: self.mount.camera_height_m() as f32, pitch_deg: self.mount.pitch_deg as f32 }),
            imu,
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
        }))
    }

    fn period_ns(&self) -> u64 {
        (1e9 / self.renderer.profile().rate_hz).round() as u64
    }
}
