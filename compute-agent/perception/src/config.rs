//! Every tunable of the perception pipeline, with where its default comes from.
//!
//! "Thesis" means Taylor 2017 (BYU, augmented white cane), chapter 2; "measured" means a
//! measurement on this project's captures or synthetic frames, named in the field doc.

use serde::Deserialize;

use schemas::CostFunction;

/// Configuration of the whole pipeline (serde, every field defaulted).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PerceptionConfig {
    /// Cost function that drives [`super::Perception::rumble`]. Default FICF: the thesis's
    /// primary function.
    pub cost_function: CostFunction,
    /// Keep every n-th pixel of every n-th row. The thesis used a 1 cm approximate voxel
    /// grid, which only cut ~290k points to ~200k on our captures (PCL baseline); striding
    /// the organized image keeps its structure and costs nothing. 2 = 76,800 of 307,200
    /// pixels: a 12 cm box at 1.5 m still covers hundreds of them (measured, synthetic).
    /// For a VGA-wide image; a narrower one (a QVGA camera mode, or a frame the sensor
    /// agent halved for a slow link) is sampled with the stride scaled to its width
    /// ([`PerceptionConfig::stride_for`]), so the same rays are sampled.
    pub stride_px: u32,
    /// Ground-plane search.
    pub ground: GroundConfig,
    /// Beyond the thesis: the ground predicted from gravity while a near wall hides it.
    pub ground_prediction: GroundPredictionConfig,
    /// Obstacle classification and the nearest-point scan.
    pub scan: ScanConfig,
    /// Fully-Integrated Cost Function (thesis eq. 2.11-2.13).
    pub ficf: CostConfig,
    /// Cushioned Avoidance Cost Function (thesis eq. 2.14-2.15).
    pub cacf: CostConfig,
    /// Beyond the thesis: debounce of the rumble state.
    pub hysteresis: HysteresisConfig,
    /// Beyond the thesis: obstacles remembered outside the field of view.
    pub memory: MemoryConfig,
    /// Beyond the thesis: missing or lower ground ahead.
    pub dropoff: DropoffConfig,
    /// Beyond the thesis: time to collision with approaching obstacles.
    pub ttc: TtcConfig,
    /// Beyond the thesis: the costs along the heading a turning user will face.
    pub turn_ahead: TurnAheadConfig,
    /// Beyond the thesis: the costs along the way the user walks, not the swept camera.
    pub walking_frame: WalkingFrameConfig,
}

/// A perception configuration that cannot be used: the TOML does not parse, names a
/// field that does not exist (a typo would otherwise leave the default in force
/// without a word), or gives a value outside what the pipeline can work with.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ConfigError {
    /// Not TOML, an unknown field, or a value of the wrong type.
    #[error("{0}")]
    Syntax(String),
    /// A field whose value is out of range.
    #[error("{field} = {value}: {rule}")]
    OutOfRange {
        /// Dotted path of the field (`ttc.min_closing_speed_m_s`).
        field: String,
        /// The value given.
        value: String,
        /// What the value must be.
        rule: String,
    },
}

/// From this height above the floor a chest camera's obstacles count, metres
/// ([`PerceptionConfig::for_chest`]): the cane camera, pitched down from under the
/// handle, sees and the cane touches what is lower.
pub const CHEST_OVERHANGS_FROM_M: f32 = 1.0;

/// How long after its floor was last seen a chest camera's floor predicted from gravity
/// stands in, ns ([`PerceptionConfig::for_chest`]; the cane camera's is 3 s): worn on
/// the body, it stays at one height over the floor the user stands on, where a hand's
/// drifts (our choice: longer than a stop at a wall to read a sign or find a door).
pub const CHEST_GROUND_HELD_NS: u64 = 10_000_000_000;

impl PerceptionConfig {
    /// These settings for a second camera worn at the chest, whose cue is joined to
    /// the cane camera's ([`crate::second_view`]): it warns only of what overhangs
    /// from [`CHEST_OVERHANGS_FROM_M`] up (`scan.overhangs_from_m`: a lamp, a sign, a
    /// cabinet standing out from a wall, not the wall, a bin or a bench the cane camera
    /// already warns of), and leaves drop-offs to the cane camera (it sees the floor
    /// only from about 2 m on), so it takes a lower floor at once. Its floor is out of
    /// view whenever something stands within 2 m ahead of the user: there the floor
    /// predicted from gravity stands in for [`CHEST_GROUND_HELD_NS`], also while it
    /// warns of nothing (`ground_prediction.while_clear`).
    pub fn for_chest(&self) -> Self {
        let mut c = self.clone();
        c.scan.overhangs_from_m = Some(CHEST_OVERHANGS_FROM_M);
        c.dropoff.enabled = false;
        // The cane camera keeps its floor when a lower one appears (a step down in view
        // must stop the user, not become the ground); the chest camera looks for no
        // drop-offs, and a lower floor after its running ground drifted up (a wall
        // filling its view gave planes on what stands before it) is its floor again.
        // Waiting 5 s for it left the chest blind exactly while the user walked on.
        c.ground.max_offset_drop_m = c.ground.max_offset_jump_m;
        c.ground.reseed_lower_after_frames = c.ground.reseed_after_frames;
        // A user who stood at a wall, the floor out of the chest camera's view, had the
        // cane camera's cue alone: the wall is no overhang, so the chest warned of
        // nothing, and a predicted floor was trusted only while it warned. Its "clear"
        // is never the user's (joined, it takes nothing from the cane camera's cue),
        // and what overhangs in front of the wall is still warned of.
        c.ground_prediction.while_clear = true;
        c.ground_prediction.max_age_ns = CHEST_GROUND_HELD_NS;
        c
    }

    /// The stride for an image `width` pixels wide: `stride_px` from 640 pixels up;
    /// below, scaled by the width (at least 1): a 320-wide image at 1 samples the rays
    /// a 640-wide one of the same camera does at 2.
    pub fn stride_for(&self, width: u32) -> u32 {
        if width >= 640 {
            self.stride_px
        } else {
            (self.stride_px * width / 640).max(1)
        }
    }

    /// Parses a TOML configuration (every field optional, defaults as documented) and
    /// checks it with [`PerceptionConfig::validate`].
    pub fn from_toml(text: &str) -> Result<Self, ConfigError> {
        let cfg: Self = toml::from_str(text).map_err(|e| ConfigError::Syntax(e.to_string().trim().to_string()))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks every field against the range the pipeline works in: every length, time
    /// and threshold finite and positive where zero or less would silence a warning or
    /// make every frame warn (a negative closing speed would make time to collision warn
    /// on everything; a zero cost scale would never warn), fractions within 0..1.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let mut c = Checker::default();
        c.within("stride_px", self.stride_px as f32, 1.0, 16.0);
        let g = &self.ground;
        c.above_within("ground.up_cone_deg", g.up_cone_deg, 0.0, 90.0);
        c.within("ground.ransac_iterations", g.ransac_iterations as f32, 1.0, 100_000.0);
        c.within("ground.sample_points", g.sample_points as f32, 3.0, 1_000_000.0);
        c.positive("ground.ransac_band_m", g.ransac_band_m);
        c.positive("ground.refine_band_m", g.refine_band_m);
        c.above_within("ground.min_inlier_fraction", g.min_inlier_fraction, 0.0, 1.0);
        c.within("ground.min_spread_m", g.min_spread_m, 0.0, 10.0);
        c.above_within("ground.camera_height_range_m[0]", g.camera_height_range_m[0], 0.0, 10.0);
        c.within("ground.camera_height_range_m[1]", g.camera_height_range_m[1], g.camera_height_range_m[0], 10.0);
        c.above_within("ground.mount_tolerance_m", g.mount_tolerance_m, 0.0, 10.0);
        c.positive("ground.max_offset_jump_m", g.max_offset_jump_m);
        c.above_within("ground.average_weight", g.average_weight, 0.0, 1.0);
        c.at_least("ground.reseed_after_frames", g.reseed_after_frames as f32, 1.0);
        c.positive("ground.max_offset_drop_m", g.max_offset_drop_m);
        c.within("ground.max_step_down_m", g.max_step_down_m, g.max_offset_drop_m, 10.0);
        c.at_least("ground.reseed_lower_after_frames", g.reseed_lower_after_frames as f32, 1.0);
        let p = &self.ground_prediction;
        c.above_within("ground_prediction.max_tilt_deg", p.max_tilt_deg, 0.0, 90.0);
        c.within("ground_prediction.min_obstacle_fraction", p.min_obstacle_fraction, 0.0, 1.0);
        let s = &self.scan;
        c.within("scan.min_obstacle_height_m", s.min_obstacle_height_m, 0.0, 1.0);
        c.within("scan.noise_per_depth_sq", s.noise_per_depth_sq, 0.0, 1.0);
        c.within("scan.max_obstacle_height_m", s.max_obstacle_height_m, s.min_obstacle_height_m, 10.0);
        c.above_within("scan.range_max_m", s.range_max_m, 0.0, 100.0);
        c.above_within("scan.bin_deg", s.bin_deg, 0.0, 45.0);
        if let Some(fov) = s.xyz_horizontal_fov_deg {
            c.above_within("scan.xyz_horizontal_fov_deg", fov, 0.0, 179.0);
        }
        c.at_least("scan.min_points_per_bin", s.min_points_per_bin as f32, 1.0);
        c.within("scan.fallback_band_scale", s.fallback_band_scale, 1.0, 10.0);
        if let Some(h) = s.overhangs_from_m {
            c.within("scan.overhangs_from_m", h, s.min_obstacle_height_m, s.max_obstacle_height_m);
        }
        for (name, f) in [("ficf", &self.ficf), ("cacf", &self.cacf)] {
            c.positive(&format!("{name}.forward_width_m"), f.forward_width_m);
            c.positive(&format!("{name}.forward_depth_m"), f.forward_depth_m);
            c.positive(&format!("{name}.side_width_m"), f.side_width_m);
            c.positive(&format!("{name}.side_depth_m"), f.side_depth_m);
            c.positive(&format!("{name}.forward_threshold"), f.forward_threshold);
            c.positive(&format!("{name}.side_threshold"), f.side_threshold);
            c.positive(&format!("{name}.scale"), f.scale);
        }
        let m = &self.memory;
        c.within("memory.cell_m", m.cell_m, 0.01, 1.0);
        c.positive("memory.radius_m", m.radius_m);
        c.above_within("memory.xyz_vertical_fov_deg", m.xyz_vertical_fov_deg, 0.0, 179.0);
        c.within("memory.view_margin_deg", m.view_margin_deg, 0.0, 45.0);
        c.positive("memory.forget_after_m", m.forget_after_m);
        c.positive("memory.overhead_from_m", m.overhead_from_m);
        let d = &self.dropoff;
        c.positive("dropoff.min_drop_m", d.min_drop_m);
        c.above_within("dropoff.lookahead_m", d.lookahead_m, 0.0, 10.0);
        c.positive("dropoff.path_width_m", d.path_width_m);
        c.above_within("dropoff.min_fraction", d.min_fraction, 0.0, 1.0);
        c.at_least("dropoff.min_samples", d.min_samples as f32, 1.0);
        c.within("dropoff.edge_max_tilt_deg", d.edge_max_tilt_deg, 0.0, 90.0);
        c.within("dropoff.feet_behind_camera_m", d.feet_behind_camera_m, 0.0, 1.0);
        let t = &self.ttc;
        c.positive("ttc.path_width_m", t.path_width_m);
        c.positive("ttc.min_closing_speed_m_s", t.min_closing_speed_m_s);
        c.above_within("ttc.smoothing", t.smoothing, 0.0, 1.0);
        c.positive("ttc.warn_s", t.warn_s);
        c.positive("ttc.baseline_s", t.baseline_s);
        c.positive("ttc.max_step_m", t.max_step_m);
        let a = &self.turn_ahead;
        c.within("turn_ahead.ahead_s", a.ahead_s, 0.0, 2.0);
        c.within("turn_ahead.min_rate_deg_s", a.min_rate_deg_s, 0.0, 360.0);
        c.within("turn_ahead.max_turn_deg", a.max_turn_deg, 0.0, 180.0);
        let w = &self.walking_frame;
        c.above_within("walking_frame.time_constant_s", w.time_constant_s, 0.0, 60.0);
        c.within("walking_frame.max_sweep_deg", w.max_sweep_deg, 0.0, 90.0);
        c.first.map_or(Ok(()), Err)
    }
}

/// Collects the first out-of-range field of [`PerceptionConfig::validate`].
#[derive(Default)]
struct Checker {
    first: Option<ConfigError>,
}

impl Checker {
    fn fail(&mut self, field: &str, value: f32, rule: impl FnOnce() -> String) {
        if self.first.is_none() {
            self.first =
                Some(ConfigError::OutOfRange { field: field.to_string(), value: value.to_string(), rule: rule() });
        }
    }

    /// `lo <= v <= hi`.
    fn within(&mut self, field: &str, v: f32, lo: f32, hi: f32) {
        if !(v.is_finite() && lo <= v && v <= hi) {
            self.fail(field, v, || format!("must be from {lo} to {hi}"));
        }
    }

    /// `lo < v <= hi`.
    fn above_within(&mut self, field: &str, v: f32, lo: f32, hi: f32) {
        if !(v.is_finite() && lo < v && v <= hi) {
            self.fail(field, v, || format!("must be above {lo} and at most {hi}"));
        }
    }

    /// `lo <= v`.
    fn at_least(&mut self, field: &str, v: f32, lo: f32) {
        if v < lo {
            self.fail(field, v, || format!("must be at least {lo}"));
        }
    }

    /// `0 < v`, finite.
    fn positive(&mut self, field: &str, v: f32) {
        if !(v.is_finite() && v > 0.0) {
            self.fail(field, v, || "must be a positive finite number".to_string());
        }
    }
}

impl Default for PerceptionConfig {
    fn default() -> Self {
        Self {
            cost_function: CostFunction::Ficf,
            stride_px: 2,
            ground: GroundConfig::default(),
            ground_prediction: GroundPredictionConfig::default(),
            scan: ScanConfig::default(),
            ficf: CostConfig::ficf(),
            cacf: CostConfig::cacf(),
            hysteresis: HysteresisConfig::default(),
            memory: MemoryConfig::default(),
            dropoff: DropoffConfig::default(),
            ttc: TtcConfig::default(),
            turn_ahead: TurnAheadConfig::default(),
            walking_frame: WalkingFrameConfig::default(),
        }
    }
}

/// RANSAC ground plane with a prior on the up direction.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GroundConfig {
    /// Largest angle between the plane normal and the prior up axis. Thesis: 20 deg around
    /// camera -y. With an IMU gravity prior the same cone holds at any cane pitch.
    pub up_cone_deg: f32,
    /// Most RANSAC hypotheses. Thesis: 1000 on the whole cloud; we score each on a small
    /// random subset (`sample_points`) and stop as soon as the best plane's support makes
    /// a miss unlikely (99.9 %, at least 60 draws). With 200 and no adaptive stop, 2 of 40
    /// five_people frames came out 0.5 deg / 3.3 cm off (measured); 400 caps the worst case.
    pub ransac_iterations: u32,
    /// Size of the random subset RANSAC scores hypotheses on.
    pub sample_points: usize,
    /// Inlier distance for RANSAC scoring and the first least-squares pass. Thesis: 0.1 m;
    /// at 0.1 m a tilted plane through a floor and a step 20 cm below it scores well.
    pub ransac_band_m: f32,
    /// Inlier distance of the later least-squares passes. Tighter than the thesis so 5 cm
    /// obstacles stay obstacles.
    pub refine_band_m: f32,
    /// Fewest RANSAC inliers (fraction of the scored subset) for a plane to count as ground.
    pub min_inlier_fraction: f32,
    /// Smallest spread (standard deviation) of the ground's inliers across their narrower
    /// in-plane direction: a floor seen as a thin strip does not fix a plane's tilt. A
    /// 30 cm strip has ~9 cm; the floor ahead of a cane camera 15-50 cm and more.
    pub min_spread_m: f32,
    /// Heights of the camera above a ground candidate, metres, when the frame gives no
    /// mount guess: a cane camera is held at 0.5-2 m (the real captures in the tests:
    /// 1.27 and 1.77 m). A surface nearer than 0.5 m below the camera is a table, bench
    /// or box top, never the floor (issue 29: a 0.45 m box top 0.54 m below a 0.99 m
    /// camera was the ground, even with the exact gravity).
    pub camera_height_range_m: [f32; 2],
    /// With a mount guess (`FrameContext::mount_height_m`), the ground is looked for
    /// only this far above or below it, metres: the camera bobs a few centimetres with
    /// the walk and a step changes the floor by 0.15-0.2 m; a seat (0.45 m) or a sunken
    /// lounge (0.3 m and deeper) is farther.
    pub mount_tolerance_m: f32,
    /// Thesis false-ground guard: a new plane whose offset D is further than this from the
    /// running average is rejected (a table top) and the average plane used instead.
    pub max_offset_jump_m: f32,
    /// Weight of a new plane in the running average (exponential).
    pub average_weight: f32,
    /// After this many consecutive guard rejections the new plane is taken as the truth
    /// (the user really stepped up, or the cane height changed for good).
    pub reseed_after_frames: u32,
    /// Beyond the thesis: a plane lower than the running average by more than this is
    /// a floor below the user's (a step down seen from above: stepping down moves the
    /// camera with the user, so the user's own floor keeps its offset), not the ground.
    /// The thesis's symmetric guard (`max_offset_jump_m`, 0.2 m) took an 18 cm step's
    /// lower floor for the ground the moment it filled the view, and the drop-off
    /// vanished under a user standing at the edge. Metres.
    pub max_offset_drop_m: f32,
    /// A plane lower by up to this is a floor a step (or a curb, a platform) below,
    /// metres; farther below, the thesis's reseed applies (after a false ground such as
    /// a seat, the true floor shows up 0.4-0.6 m lower and must be taken back quickly).
    pub max_step_down_m: f32,
    /// After this many consecutive frames of a floor a step below it is taken as the
    /// truth (the cane held higher for good), frames: 5 s at 30 Hz, longer than a stop
    /// at an edge.
    pub reseed_lower_after_frames: u32,
    /// Ground not found for more than this many frames in a row -> `Degraded`. 5 frames is
    /// 170 ms at 30 Hz: shorter than a step, longer than one bad frame.
    pub max_lost_frames: u32,
    /// Seed of the deterministic RANSAC sampler (replays give identical output).
    pub seed: u64,
}

impl Default for GroundConfig {
    fn default() -> Self {
        Self {
            up_cone_deg: 20.0,
            ransac_iterations: 400,
            sample_points: 1024,
            ransac_band_m: 0.05,
            refine_band_m: 0.03,
            min_inlier_fraction: 0.08,
            min_spread_m: 0.1,
            camera_height_range_m: [0.5, 2.0],
            mount_tolerance_m: 0.25,
            max_offset_jump_m: 0.2,
            average_weight: 0.3,
            reseed_after_frames: 10,
            max_offset_drop_m: 0.08,
            max_step_down_m: 0.3,
            reseed_lower_after_frames: 150,
            max_lost_frames: 5,
            seed: 0x5eed_ca9e,
        }
    }
}

impl GroundConfig {
    /// Heights of the camera above the floor a ground candidate may give, metres: within
    /// `mount_tolerance_m` of a usable mount guess, else `camera_height_range_m`.
    pub fn camera_heights_m(&self, mount_height_m: Option<f32>) -> [f32; 2] {
        match mount_height_m.filter(|h| h.is_finite() && *h > 0.0) {
            Some(h) => [(h - self.mount_tolerance_m).max(0.1), h + self.mount_tolerance_m],
            None => self.camera_height_range_m,
        }
    }
}

/// The ground predicted from the IMU while the floor is out of view.
///
/// Measured with the simulator (worlds `approach` and `taylor-course`; camera 0.885 m up,
/// pitched 30 deg down, 45 deg vertical FOV): from ~0.7-0.9 m before a wall the wall fills
/// the view, the floor is a thin strip or gone, the search loses the ground and after
/// `GroundConfig::max_lost_frames` reported `Degraded` ("detection offline") exactly when
/// the user needed "stop". With a gravity vector the floor's normal is still known, and
/// a cane's camera height barely changes over a few seconds, so the plane `-gravity`,
/// running-average offset D stands in. It stays `Lost` (never `Degraded`) only while all
/// of these hold; otherwise the frame-count rule of `GroundConfig::max_lost_frames` is
/// kept unchanged.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GroundPredictionConfig {
    /// Switch. Off (or no gravity in the frame): the thesis's rule only.
    pub enabled: bool,
    /// Largest angle between gravity's up and the normal of the last ground found. The
    /// simulator's cane wobbles +-1.5 deg in pitch at 1 m/s (3 deg peak to peak); a cane
    /// lifted or tilted further no longer stands where the last ground was seen.
    pub max_tilt_deg: f32,
    /// Longest time since the last ground found, ns: the hand's height drifts (3 s).
    /// A frame whose stamp does not advance past that ground's is not trusted.
    pub max_age_ns: u64,
    /// Fewest obstacle points (fraction of the valid sampled points) for the frame to
    /// count as a blocked view. A near wall gives ~1; a frame that shows nothing
    /// classifiable must never pass for a clear path, so it degrades as before.
    pub min_obstacle_fraction: f32,
    /// The predicted floor stands in also while the frame warns of nothing. Off: only
    /// while it warns (a floor the camera cannot see, black or shiny, ahead of a far
    /// wall must not be the basis of a "clear" lasting seconds). On only for a camera
    /// whose cue is joined to another's and never stands alone (the chest camera's,
    /// [`PerceptionConfig::for_chest`]): its "clear" takes nothing from the other's cue.
    pub while_clear: bool,
}

impl Default for GroundPredictionConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            max_tilt_deg: 5.0,
            max_age_ns: 3_000_000_000,
            min_obstacle_fraction: 0.25,
            while_clear: false,
        }
    }
}

/// Which points are obstacles, and the scan they make.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScanConfig {
    /// A point is an obstacle when it is more than this above the plane, plus the depth
    /// noise term below. The thesis removed everything within 0.1 m of the plane, which
    /// erases curbs and bags; 4 cm keeps a 5 cm step.
    pub min_obstacle_height_m: f32,
    /// Depth-noise allowance added to the band: this times depth squared (Kinect-class
    /// sensors: sigma ~ 1.2 mm * z^2, so 3.6e-3 is 3 sigma).
    pub noise_per_depth_sq: f32,
    /// Points higher than this above the ground are above the head (thesis: ~2.0 m).
    pub max_obstacle_height_m: f32,
    /// Horizontal ranges beyond this are not trusted (sensor range).
    pub range_max_m: f32,
    /// Bin width, degrees. Thesis: 1.
    pub bin_deg: f32,
    /// Horizontal field of view for organized xyz input (no intrinsics); `None` measures it
    /// from the frame's own rays. Depth input always derives it from the intrinsics.
    pub xyz_horizontal_fov_deg: Option<f32>,
    /// Fewest obstacle points in a bin before its range counts (rejects lone flying pixels).
    pub min_points_per_bin: u32,
    /// Band multiplier while the previous (average) plane stands in for a lost ground
    /// (thesis: the average plane is used "with a wider inlier band").
    pub fallback_band_scale: f32,
    /// Only what overhangs: a bin's range is that of its points this high or higher
    /// above the floor, and only where they are nearer (by
    /// [`crate::nearest_scan::OVERHANG_MARGIN_M`]) than the bin's obstacle points below
    /// this height and the view below this height reaches past them (the floor or
    /// something farther seen under them): a sign or lamp hanging before a wall, a
    /// cabinet standing out from it, not the wall, nor a wall so near that the camera
    /// does not see its foot. For a camera at the chest whose cue is joined to the cane camera's
    /// ([`PerceptionConfig::for_chest`]); `None` (the default): every obstacle.
    pub overhangs_from_m: Option<f32>,
    /// Also measure how far each bin saw the floor free
    /// ([`crate::nearest_scan::ScanBuilder::floor_seen_m`], the localization's free
    /// space). Off by default: it bins every floor point too, +0.25-0.3 ms a frame where
    /// the floor fills the view (`cargo bench -p perception`, the 30-degree frames).
    pub floor_seen: bool,
}

impl Default for ScanConfig {
    fn default() -> Self {
        Self {
            min_obstacle_height_m: 0.04,
            noise_per_depth_sq: 3.6e-3,
            max_obstacle_height_m: 2.0,
            range_max_m: 5.0,
            bin_deg: 1.0,
            xyz_horizontal_fov_deg: None,
            min_points_per_bin: 2,
            fallback_band_scale: 2.0,
            overhangs_from_m: None,
            floor_seen: false,
        }
    }
}

/// One of Taylor's cost functions: a forward region and a side region in front of the
/// user, and two thresholds (see `cost_function` for the formula).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CostConfig {
    /// Width of the forward region, metres.
    pub forward_width_m: f32,
    /// Depth of the forward region, metres.
    pub forward_depth_m: f32,
    /// Width of the region whose halves give the left and right costs, metres.
    pub side_width_m: f32,
    /// Depth of the side region, metres.
    pub side_depth_m: f32,
    /// Forward cost at or above which the user must turn.
    pub forward_threshold: f32,
    /// Left and right costs both at or above this: blocked, stop.
    pub side_threshold: f32,
    /// Scale of every cost term (our stand-in for the thesis's "/100"): calibrated on the
    /// thesis's own wall test so the forward threshold is crossed with the cane tip 75 cm
    /// from the wall (see `cost_function` tests).
    pub scale: f32,
}

impl CostConfig {
    /// Thesis FICF: path 0.75 m wide, 3.5 m deep; thresholds forward 3.0, left-right 6.0.
    pub fn ficf() -> Self {
        Self {
            forward_width_m: 0.75,
            forward_depth_m: 3.5,
            side_width_m: 0.75,
            side_depth_m: 3.5,
            forward_threshold: 3.0,
            side_threshold: 6.0,
            scale: 0.0238,
        }
    }

    /// Thesis CACF: inner 0.5 m x 2.0 m, outer 1.5 m x 2.0 m; thresholds 3.8 and 7.0.
    pub fn cacf() -> Self {
        Self {
            forward_width_m: 0.5,
            forward_depth_m: 2.0,
            side_width_m: 1.5,
            side_depth_m: 2.0,
            forward_threshold: 3.8,
            side_threshold: 7.0,
            scale: 0.385,
        }
    }
}

impl Default for CostConfig {
    fn default() -> Self {
        Self::ficf()
    }
}

/// Debounce of the rumble state: a stop (`Both`) is released only once a calmer state
/// has held for `relax_frames`. While the user turns in place on `Both`, a clear of a
/// few frames (felt once it outlasts a pulse gap) sent them walking on for a second,
/// and the stop came back too late: 13 body contacts with a divider in view in 20
/// sound-following CACF walks with no debounce, 7 with it. Side cues are not held by
/// default: holding them turned the user 133 ms further past the clear heading and
/// saved no signals (FICF route, 20 walks: 15.2 signals, 2.70 cane and 0.35 body
/// contacts per walk holding sides, 9.7, 1.90 and 0.10 not; README, virtual user study).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HysteresisConfig {
    /// Switch. Off: the rumble is the raw Table 2.1 state of every frame.
    pub enabled: bool,
    /// Frames a calmer state must persist before it replaces the one held. Escalations
    /// (clear -> warn, warn -> both) act at once: a late warning is worse than a long
    /// one. 4 frames = 133 ms at 30 Hz.
    pub relax_frames: u32,
    /// Also hold a side cue against clear and against the other side (the debounce of
    /// every state, as first built).
    pub hold_sides: bool,
}

impl Default for HysteresisConfig {
    fn default() -> Self {
        Self { enabled: true, relax_frames: 4, hold_sides: false }
    }
}

/// Egocentric memory of obstacles that left the view.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MemoryConfig {
    /// Switch.
    pub enabled: bool,
    /// Cell size, metres.
    pub cell_m: f32,
    /// Obstacles farther than this from the user are not kept, metres.
    pub radius_m: f32,
    /// A remembered obstacle is forgotten after this long unseen, nanoseconds, however
    /// still the user stands (10 s: a person who walked off is not kept for long).
    pub ttl_ns: u64,
    /// Assumed vertical field of view for the visibility test of xyz input, degrees
    /// (Kinect-class: 45).
    pub xyz_vertical_fov_deg: f32,
    /// A remembered cell is taken as seen (the camera's word replaces it) only this far
    /// inside the image's top and bottom edges, degrees: the scan needs a few rows of an
    /// obstacle to range it.
    pub view_margin_deg: f32,
    /// A remembered obstacle is forgotten once it has moved this far in the user's frame
    /// since it was last seen (walking on, turning away), metres: odometry error grows
    /// with motion, not with time.
    pub forget_after_m: f32,
    /// Obstacles higher than this above the floor are overhead: out of the cane's reach
    /// (its handle is about 1 m up), and seen only from afar by a camera that looks
    /// down (one 10° down sees a sign 1.55 m up from 1.9 m on, never nearer; one 30°
    /// down never sees above its own height, so with that mount this changes nothing).
    /// An overhead obstacle is not forgotten for moving `forget_after_m` in the user's
    /// frame (turning away from a sign 3.5 m ahead moves it 7 m), only after
    /// `overhead_ttl_ns` or beyond `radius_m`: a user who turned away from a sign and
    /// comes back under it has nothing else to warn them. A cell's height is that of
    /// the point the scan ranged there, so a wall or a person whose nearest point in a
    /// bin was above this is kept as long out of view (`corridor`, camera 10° down, 40
    /// walks: body contacts out of view fell by 0.68 a walk, signals unchanged). Metres.
    pub overhead_from_m: f32,
    /// Time to live of an overhead obstacle, nanoseconds (a minute: within the memory's
    /// 5 m the simulated VO's errors over a minute, 1 % scale, 2 % noise and about a
    /// degree of heading, come to about 0.2 m, less than a sign).
    pub overhead_ttl_ns: u64,
}

impl Default for MemoryConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            cell_m: 0.1,
            radius_m: 5.0,
            ttl_ns: 10_000_000_000,
            xyz_vertical_fov_deg: 45.0,
            view_margin_deg: 3.0,
            forget_after_m: 5.0,
            overhead_from_m: 1.2,
            overhead_ttl_ns: 60_000_000_000,
        }
    }
}

/// Drop-off (step down, stairwell, platform edge) detection.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DropoffConfig {
    /// Switch.
    pub enabled: bool,
    /// Ground lower than the plane by more than this is a step down (a stair riser is
    /// 15-18 cm; a curb 10-15 cm).
    pub min_drop_m: f32,
    /// Look this far ahead along the path, metres.
    pub lookahead_m: f32,
    /// Width of the path checked, metres (the FICF path).
    pub path_width_m: f32,
    /// Fraction of the expected ground samples in one slice of the path (an eighth of
    /// `lookahead_m`) that must be lower or missing.
    pub min_fraction: f32,
    /// Fewest expected ground samples over the whole path (split evenly over the slices)
    /// before the check says anything.
    pub min_samples: u32,
    /// Also hand the edge of lower ground anywhere in view (up to `lookahead_m`) to the
    /// cost functions and the memory, as obstacle points on the floor (see
    /// `dropoff::edges`): a step's corner beside the path is steered round and kept
    /// once out of view. With it, the floor below the view before lower ground that
    /// begins at the view's bottom counts as lower unless it was seen as floor.
    pub edges: bool,
    /// Edges only on a ground plane within this of gravity's up, degrees (the sim's IMU
    /// has 0.5 degrees of noise per axis; 99.9 % of the planes found on `taylor-course`
    /// are within 2 degrees).
    pub edge_max_tilt_deg: f32,
    /// How far behind the camera the user's feet stand, metres (a cane camera: the
    /// hand 0.25 m ahead of the body, the camera 0.15 m down the cane). The unseen
    /// floor that may be lower reaches back to them.
    pub feet_behind_camera_m: f32,
}

impl Default for DropoffConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            min_drop_m: 0.08,
            lookahead_m: 2.0,
            path_width_m: 0.75,
            min_fraction: 0.5,
            min_samples: 80,
            edges: true,
            edge_max_tilt_deg: 3.0,
            feet_behind_camera_m: 0.35,
        }
    }
}

/// Time to collision with an obstacle moving towards the user, from the frame-to-frame
/// change of its range with the user's own motion taken out (see `time_to_collision`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TtcConfig {
    /// Switch.
    pub enabled: bool,
    /// Width of the path watched, metres.
    pub path_width_m: f32,
    /// The obstacle's own closing speeds below this are noise (or a static obstacle), m/s.
    pub min_closing_speed_m_s: f32,
    /// Weight of a new closing-speed measurement (exponential smoothing).
    pub smoothing: f32,
    /// An obstacle closer in time than this raises a warning even below the cost
    /// thresholds (a person walking towards the user).
    pub warn_s: f32,
    /// The range is compared with the newest frame at least this old, seconds (see
    /// `time_to_collision`: shorter reads the scan's bin steps as motion).
    pub baseline_s: f32,
    /// Range changes larger than this over the baseline are a different obstacle, not
    /// motion (a person at 1.5 m/s and the user at 1 m/s close 0.63 m in 0.25 s).
    pub max_step_m: f32,
}

impl Default for TtcConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            path_width_m: 0.75,
            min_closing_speed_m_s: 0.3,
            smoothing: 0.5,
            warn_s: 2.0,
            baseline_s: 0.25,
            max_step_m: 1.0,
        }
    }
}

/// The costs along the heading the body will face (see `turn_ahead`); needs the body's
/// turn rate from a body-worn gyro ([`super::FrameContext::body_yaw_rate_rad_s`]), and
/// does nothing without it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TurnAheadConfig {
    /// Switch.
    pub enabled: bool,
    /// How far on the heading is taken, seconds. 0.3 s (FICF assisted, 40 walks, cane
    /// contacts per walk: 0.2 s 4.45, 0.3 s 3.73, 0.4 s 3.92, 0.5 s 3.50, with signals
    /// 23.7, 22.7, 25.4, 29.6; CACF's signals rise from 0.4 s: README, study notes).
    pub ahead_s: f32,
    /// Turns slower than this are walking straight, degrees per second: a body-worn
    /// gyro sways with each step (3 degrees each way at 0.9 Hz peaks at 17 degrees/s)
    /// and drifts. At 10 degrees/s a gyro swaying three times as much found the
    /// corridor's walls at every step (40 walks: 16 more signals a walk, body contacts
    /// in view 0.10 -> 0.25); at 25 neither the course nor the corridor lost anything
    /// (study notes, "Warning the way the user turns").
    pub min_rate_deg_s: f32,
    /// The look never turns further than this, degrees (a bad gyro sample must not
    /// turn it round to the wall behind).
    pub max_turn_deg: f32,
}

impl Default for TurnAheadConfig {
    fn default() -> Self {
        Self { enabled: true, ahead_s: 0.3, min_rate_deg_s: 25.0, max_turn_deg: 45.0 }
    }
}

/// The costs in the frame of the way the user walks (see `walking_frame`): the cane
/// camera's angle to the body estimated from the camera's and a body-worn gyro's turns.
/// Needs the body's turn rate; without it the costs look along the camera.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WalkingFrameConfig {
    /// Switch.
    pub enabled: bool,
    /// Leak of the estimate back to zero, seconds: 5 keeps a 0.7 Hz sweep's amplitude
    /// within a degree, as the localization tracker's.
    pub time_constant_s: f32,
    /// The estimate never exceeds this, degrees (a cane swept wider is not a cane).
    pub max_sweep_deg: f32,
}

impl Default for WalkingFrameConfig {
    fn default() -> Self {
        Self { enabled: false, time_constant_s: 5.0, max_sweep_deg: 45.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_pass_and_an_empty_file_is_the_defaults() {
        assert_eq!(PerceptionConfig::default().validate(), Ok(()));
        assert_eq!(PerceptionConfig::from_toml(""), Ok(PerceptionConfig::default()));
    }

    #[test]
    fn a_partial_file_changes_only_what_it_names() {
        let cfg = PerceptionConfig::from_toml("cost_function = \"Cacf\"\n[ttc]\nwarn_s = 3.0\n").unwrap();
        let mut want = PerceptionConfig { cost_function: CostFunction::Cacf, ..PerceptionConfig::default() };
        want.ttc.warn_s = 3.0;
        assert_eq!(cfg, want);
    }

    #[test]
    fn a_misspelt_field_is_refused_by_name_not_left_at_its_default() {
        let err = PerceptionConfig::from_toml("[ttc]\nwarn_seconds = 3.0\n").unwrap_err().to_string();
        assert!(err.contains("unknown field `warn_seconds`") && err.contains("warn_s"), "{err}");
        let err = PerceptionConfig::from_toml("[ficf]\nforward_treshold = 1.0\n").unwrap_err().to_string();
        assert!(err.contains("forward_treshold"), "{err}");
    }

    #[test]
    fn values_that_would_silence_or_flood_the_warnings_are_refused() {
        let err = |text: &str| PerceptionConfig::from_toml(text).unwrap_err();
        // a negative closing speed would make time to collision warn on everything
        assert_eq!(
            err("[ttc]\nmin_closing_speed_m_s = -1.0\n"),
            ConfigError::OutOfRange {
                field: "ttc.min_closing_speed_m_s".into(),
                value: "-1".into(),
                rule: "must be a positive finite number".into()
            }
        );
        // a zero scale would never warn; NaN compares false everywhere
        assert!(matches!(err("[cacf]\nscale = 0.0\n"), ConfigError::OutOfRange { field, .. } if field == "cacf.scale"));
        assert!(
            matches!(err("[ficf]\nforward_threshold = nan\n"), ConfigError::OutOfRange { field, .. } if field == "ficf.forward_threshold")
        );
        assert_eq!(
            err("[ground]\naverage_weight = 1.5\n").to_string(),
            "ground.average_weight = 1.5: must be above 0 and at most 1"
        );
        assert_eq!(err("stride_px = 0\n").to_string(), "stride_px = 0: must be from 1 to 16");
        assert_eq!(
            err("[scan]\nmin_points_per_bin = 0\n").to_string(),
            "scan.min_points_per_bin = 0: must be at least 1"
        );
        // a step down larger than what counts as one
        assert!(matches!(
            err("[ground]\nmax_offset_drop_m = 0.4\n"),
            ConfigError::OutOfRange { field, .. } if field == "ground.max_step_down_m"
        ));
        assert!(matches!(err("stride_px = \"two\"\n"), ConfigError::Syntax(_)));
        // the drop-off's floor grid is sized by its look-ahead: 1 km would take gigabytes
        assert_eq!(
            err("[dropoff]\nlookahead_m = 1000.0\n").to_string(),
            "dropoff.lookahead_m = 1000: must be above 0 and at most 10"
        );
        assert_eq!(err("[turn_ahead]\nahead_s = -0.3\n").to_string(), "turn_ahead.ahead_s = -0.3: must be from 0 to 2");
        assert!(matches!(
            err("[dropoff]\nfeet_behind_camera_m = -0.3\n"),
            ConfigError::OutOfRange { field, .. } if field == "dropoff.feet_behind_camera_m"
        ));
    }
}
