//! The compute agent's frame step: a depth frame as the wire carries it in; the
//! perception, the hazard and the haptic intent out.
//!
//! The compute agent, `wearnav demo` (through the agent), `wearnav perceive` and the
//! virtual-user study all run frames through [`ComputeStep`], so the study measures
//! exactly what the agent does: decoding, odometry held until its frame, perception,
//! the cue, and the blind state after rejections in a row ([`crate::rejections`]).
//! Only the stamping of latencies and the publishing are the agent's.

use schemas::depth_codec::{self, CodecError};
use schemas::{DepthFrame, GroundState, HapticIntent, Hazard, OdomIncrement, Rumble};

use crate::odometry::{ImplausibleStep, MotionSince};
use crate::predictive::{Ahead, OwnWay, PredictiveConfig, PredictiveCue, Way};
use crate::rejections::{self, Rejections};
use crate::second_view::{Joined, SecondView, ViewState};
use crate::{cue, cue_unavailable, CueConfig, DepthInput, FrameContext, Perception, PerceptionConfig, PerceptionError};
use crate::{Pipeline, StageTimer};

/// One frame and what is known of it.
#[derive(Debug, Clone, Copy)]
pub struct FrameIn<'a> {
    /// The frame.
    pub data: FrameData<'a>,
    /// The sender's sequence number (the hazard's `frame_seq`).
    pub seq: u64,
    /// Capture stamp, ns.
    pub capture_ns: u64,
    /// The body's turn rate about gravity at capture, rad/s, positive left, from a
    /// body-worn gyro ([`FrameContext::body_yaw_rate_rad_s`]).
    pub body_yaw_rate_rad_s: Option<f32>,
    /// Where the user heads, body frame at capture (from the route and the user's place
    /// on the map): with a [`ComputeStep::with_predictive`] step the cue comes from it
    /// ([`crate::predictive`]); `None`: from the cost functions.
    pub way: Option<Way<'a>>,
}

/// A frame as it comes.
#[derive(Debug, Clone, Copy)]
pub enum FrameData<'a> {
    /// A depth frame as the wire carries it (packed samples, intrinsics, gravity).
    Wire(&'a DepthFrame),
    /// An organized point cloud from a file (PCD), camera optical frame, NaN = invalid.
    Xyz {
        /// Points, `width * height` of them.
        points: &'a [[f32; 3]],
        /// Columns.
        width: u32,
        /// Rows.
        height: u32,
        /// Gravity in the camera frame, pointing down, when known.
        gravity_camera: Option<[f32; 3]>,
        /// How the camera is thought to be mounted (without gravity its pitch is where
        /// the floor is looked for first), when known.
        mount: Option<schemas::MountGuess>,
    },
}

/// Why a frame gave no perception.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// The packed samples do not decode.
    #[error("depth frame does not decode: {0}")]
    Decode(#[from] CodecError),
    /// The pipeline refused the frame.
    #[error(transparent)]
    Perception(#[from] PerceptionError),
}

impl StepError {
    /// Short stable name for reject counters.
    pub fn kind(&self) -> &'static str {
        match self {
            StepError::Decode(_) => "depth_decode",
            StepError::Perception(e) => e.kind(),
        }
    }
}

/// What to tell the user while frames keep coming but none can be used: a degraded
/// hazard (rumble `Both`: stop) and the distinct "unavailable" cue, never silence.
#[derive(Debug, Clone, PartialEq)]
pub struct Blind {
    /// Hazard with ground `Degraded` and rumble `Both`.
    pub hazard: Hazard,
    /// The "unavailable" cue.
    pub intent: HapticIntent,
}

/// What one frame gave.
#[derive(Debug, Clone, PartialEq)]
pub enum StepOutput {
    /// The frame was perceived.
    Perceived {
        /// Everything perception found (the scan among it).
        perception: Perception,
        /// The hazard message; `latency` is left empty for the caller who owns the clock.
        hazard: Hazard,
        /// The haptic intent for the user's hands.
        intent: HapticIntent,
    },
    /// The frame was refused.
    Refused {
        /// Why (count it under [`StepError::kind`]).
        error: StepError,
        /// Set when the refusals in a row mean the user must be told perception is
        /// blind now.
        blind: Option<Blind>,
        /// While the refusals in a row mean perception is blind, the blind hazard for
        /// this frame, on every refused frame (with `blind` too): the answer by which the
        /// sensor agent's link pacing knows the frame arrived. Unanswered, a camera facing
        /// a wall at arm's length was taken for a slow link and its frames made coarser
        /// and fewer for seconds after.
        answer: Option<Hazard>,
    },
}

/// Decoding buffer, odometry held for frames, the pipeline and the rejection count:
/// everything the compute agent carries from one frame to the next.
#[derive(Debug)]
pub struct ComputeStep {
    pipeline: Pipeline,
    cue: CueConfig,
    motion: MotionSince,
    rejections: Rejections,
    depth: Vec<u16>,
    predictive: Option<PredictiveCue>,
    /// the user's own way, for frames without one when the predictive cue takes it
    own_way: OwnWay,
    /// a second device's (the chest's) state, joined to every frame's cue, and whether
    /// the last frame perceived was joined to it
    second: Option<(SecondView, Option<Joined>)>,
    /// ways refused for a non-finite number (the cost functions decided those frames)
    ways_refused: u64,
}

impl ComputeStep {
    /// A step with these perception and cue settings.
    pub fn new(perception: PerceptionConfig, cue: CueConfig) -> Self {
        Self {
            pipeline: Pipeline::new(perception),
            cue,
            motion: MotionSince::default(),
            rejections: Rejections::default(),
            depth: Vec::new(),
            predictive: None,
            own_way: OwnWay::default(),
            second: None,
            ways_refused: 0,
        }
    }

    /// The same step with the cue from where the user heads: frames that come with a
    /// [`FrameIn::way`] get the [`PredictiveCue`]'s state (a drop-off in the step zone
    /// still stops the user), frames without one the cost functions', or with
    /// [`PredictiveConfig::own_way`] the cue's on the way the user walked last free.
    pub fn with_predictive(mut self, config: PredictiveConfig) -> Self {
        self.predictive = Some(PredictiveCue::new(config));
        self
    }

    /// The turning rate the predictive cue's model has learnt from this user, degrees
    /// per second ([`PredictiveCue::learnt_turn_rate_deg_s`]).
    pub fn learnt_turn_rate_deg_s(&self) -> Option<f64> {
        self.predictive.as_ref().and_then(PredictiveCue::learnt_turn_rate_deg_s)
    }

    /// The same step with a second depth device's cue joined to every frame's
    /// ([`crate::second_view`]): a chest camera's states, as [`ComputeStep::second_view_heard`]
    /// hands them on, warn the sides they warn of while fresh.
    pub fn with_second_view(mut self, view: SecondView) -> Self {
        self.second = Some((view, None));
        self
    }

    /// A state of the second device (from its own step's hazard) and the obstacle
    /// points its step held, the device's user frame ([`ComputeStep::obstacle_points`];
    /// none for a refused frame): the predictive cue looks ahead among them too.
    pub fn second_view_heard(&mut self, state: ViewState, points: &[[f32; 2]]) {
        if let Some((view, _)) = self.second.as_mut() {
            view.heard(state, points);
        }
    }

    /// With a second device: its view, and whether the last frame perceived was joined
    /// to a fresh state of it (`None` before the first).
    pub fn second_view(&self) -> Option<(&SecondView, Option<Joined>)> {
        self.second.as_ref().map(|(v, j)| (v, *j))
    }

    /// Ways refused so far: a point of the way or of its walls was not finite (a pose
    /// gone wrong upstream); the cost functions decided those frames, and their hazards
    /// say so (`predictive` false).
    pub fn ways_refused(&self) -> u64 {
        self.ways_refused
    }

    /// The perception settings in use.
    pub fn perception_config(&self) -> &PerceptionConfig {
        self.pipeline.config()
    }

    /// The cue settings in use.
    pub fn cue_config(&self) -> &CueConfig {
        &self.cue
    }

    /// Holds an odometry increment for the frame it leads up to; an implausible one is
    /// refused (count it under [`ImplausibleStep::kind`]) and nothing moves.
    pub fn add_odometry(&mut self, inc: &OdomIncrement) -> Result<(), ImplausibleStep> {
        self.motion.add(inc)
    }

    /// Every obstacle point the costs took in the last frame perceived, user frame,
    /// metres `(x forward, y left)` ([`Pipeline::obstacle_points`]).
    pub fn obstacle_points(&self) -> &[[f32; 2]] {
        self.pipeline.obstacle_points()
    }

    /// Runs one frame: decode, perceive with the odometry that ends by its capture,
    /// cue; or refuse it, and after [`rejections::REJECTIONS_BEFORE_BLIND`] refusals in
    /// a row say the system is blind. `timer` times the stages (`decode`, the
    /// pipeline's, and `predictive` when that cue decides).
    pub fn process(&mut self, input: FrameIn<'_>, timer: &mut dyn StageTimer) -> StepOutput {
        let perceived = match input.data {
            FrameData::Wire(f) => {
                timer.start("decode");
                let decoded = depth_codec::decode(&f.data, f.width, f.height, f.encoding, &mut self.depth);
                timer.stop();
                // a frame that does not decode leaves its motion to the next frame
                decoded.map_err(StepError::from).and_then(|()| {
                    let depth = DepthInput::Depth {
                        samples: &self.depth,
                        width: f.width,
                        height: f.height,
                        depth_scale_m: f.depth_scale_m,
                        intrinsics: f.intrinsics,
                    };
                    perceive(&mut self.pipeline, &mut self.motion, depth, (f.gravity_camera, f.mount), &input, timer)
                })
            }
            FrameData::Xyz { points, width, height, gravity_camera, mount } => {
                let xyz = DepthInput::Xyz { points, width, height };
                perceive(&mut self.pipeline, &mut self.motion, xyz, (gravity_camera, mount), &input, timer)
            }
        };
        let active = self.pipeline.config().cost_function;
        match perceived {
            Ok(mut perception) => {
                self.rejections.record(true);
                let t_s = input.capture_ns as f64 * 1e-9;
                if let Some(p) = self.predictive.as_mut() {
                    let yaw_rate = perception.body_yaw_rate_rad_s.map(f64::from);
                    let speed = f64::from(perception.speed_m_s);
                    if perception.ground == GroundState::Degraded {
                        p.offline_at(t_s);
                    }
                    p.observe_turn(t_s, yaw_rate);
                    let own = p.config().own_way;
                    if own {
                        self.own_way.update(t_s, yaw_rate, speed, p.last_sent(), p.config().user.walk_speed_m_s);
                    }
                    let given = input.way.is_some();
                    let way = input.way.filter(|w| {
                        let finite = w.is_finite();
                        self.ways_refused += u64::from(!finite);
                        finite
                    });
                    // a way that is no way is refused, never replaced by the user's own
                    let way = if given { way } else { own.then(|| self.own_way.way()) };
                    if let Some(way) = way.filter(|_| !perception.dropoff_ahead) {
                        // what the second device holds overhangs: only the body touches it
                        let body_points =
                            self.second.as_ref().map_or(&[][..], |(v, _)| v.fresh_points(input.capture_ns));
                        timer.start("predictive");
                        perception.rumble = p.decide(&Ahead {
                            t_s,
                            way,
                            points: self.pipeline.obstacle_points(),
                            cane_finds: self.pipeline.cane_finds(),
                            body_points,
                            sweep_rad: f64::from(perception.sweep_rad),
                            speed_m_s: speed,
                            yaw_rate_rad_s: yaw_rate,
                        });
                        timer.stop();
                        perception.predictive = true;
                    }
                }
                if let Some((view, joined)) = self.second.as_mut() {
                    // the predictive cue took the second device's points too: its state
                    // is joined all the same (a head-high touch is an injury)
                    *joined = Some(view.join(input.capture_ns, &mut perception));
                }
                if let Some(p) = self.predictive.as_mut() {
                    p.sent(t_s, perception.rumble);
                }
                let hazard = perception.hazard(input.seq, active, Vec::new());
                let intent = cue(&perception, &self.cue);
                StepOutput::Perceived { perception, hazard, intent }
            }
            Err(error) => {
                let tell = self.rejections.record(false);
                let answer = self.rejections.blind().then(|| rejections::blind().hazard(input.seq, active, Vec::new()));
                let blind =
                    answer.clone().filter(|_| tell).map(|hazard| Blind { hazard, intent: cue_unavailable(&self.cue) });
                if let Some(p) = self.predictive.as_mut() {
                    let t_s = input.capture_ns as f64 * 1e-9;
                    p.offline_at(t_s);
                    if blind.is_some() {
                        p.sent(t_s, Rumble::Both);
                    }
                }
                StepOutput::Refused { error, blind, answer }
            }
        }
    }
}

/// The pipeline on one decoded frame, with its gravity and mount guess and the motion
/// that ends by its capture.
fn perceive(
    pipeline: &mut Pipeline,
    motion: &mut MotionSince,
    depth: DepthInput<'_>,
    (gravity_camera, mount): (Option<[f32; 3]>, Option<schemas::MountGuess>),
    input: &FrameIn<'_>,
    timer: &mut dyn StageTimer,
) -> Result<Perception, StepError> {
    let ctx = FrameContext {
        stamp_ns: input.capture_ns,
        gravity_camera,
        motion: motion.take_until(input.capture_ns),
        body_yaw_rate_rad_s: input.body_yaw_rate_rad_s,
        mount_height_m: mount.map(|m| m.height_m),
        mount_pitch_deg: mount.map(|m| m.pitch_deg),
    };
    Ok(pipeline.process(depth, &ctx, timer)?.clone())
}

#[cfg(test)]
mod tests {
    use schemas::{DepthEncoding, GroundState, Rumble};

    use super::*;
    use crate::synthetic_scene::Scene;
    use crate::NoTimer;

    /// A wall 1.2 m ahead of a Kinect 0.9 m up, pitched 30 degrees down (the floor in
    /// view before it), packed as the sensor agent packs it.
    fn wall_frame(encoding: DepthEncoding) -> DepthFrame {
        let mut scene = Scene::kinect(0.9, 30.0);
        scene.walls_x_m.push(1.2);
        scene.depth_frame(encoding).unwrap()
    }

    fn input(frame: &DepthFrame, seq: u64) -> FrameIn<'_> {
        FrameIn {
            data: FrameData::Wire(frame),
            seq,
            capture_ns: seq * 33_333_333,
            body_yaw_rate_rad_s: None,
            way: None,
        }
    }

    #[test]
    fn a_packed_frame_gives_what_the_pipeline_and_the_cue_give_on_its_samples() {
        let frame = wall_frame(DepthEncoding::Lossless);
        let mut step = ComputeStep::new(PerceptionConfig::default(), CueConfig::default());
        let StepOutput::Perceived { perception, hazard, intent } = step.process(input(&frame, 7), &mut NoTimer) else {
            panic!("the wall frame was refused");
        };
        let mut samples = Vec::new();
        depth_codec::decode(&frame.data, frame.width, frame.height, frame.encoding, &mut samples).unwrap();
        let mut pipeline = Pipeline::new(PerceptionConfig::default());
        let depth = DepthInput::Depth {
            samples: &samples,
            width: frame.width,
            height: frame.height,
            depth_scale_m: 0.001,
            intrinsics: frame.intrinsics,
        };
        let ctx = FrameContext { stamp_ns: 7 * 33_333_333, gravity_camera: frame.gravity_camera, ..Default::default() };
        let direct = pipeline.process(depth, &ctx, &mut NoTimer).unwrap().clone();
        assert_eq!(perception, direct);
        assert_eq!(hazard, direct.hazard(7, schemas::CostFunction::Ficf, Vec::new()));
        assert_eq!(intent, cue(&direct, &CueConfig::default()));
        assert_eq!(hazard.ground, GroundState::Found);
        assert!(hazard.gravity, "the frame carried gravity");
        assert!(hazard.ficf.forward > 0.0, "{hazard:?}");
        assert!((hazard.nearest_m - 1.2).abs() < 0.05, "{}", hazard.nearest_m);
    }

    #[test]
    fn a_frame_without_gravity_is_perceived_and_its_hazard_says_so() {
        // a camera without IMU, 10 degrees down: the floor is found around its down axis
        // and a box 1.2 m ahead warned of, and the hazard says the frame had no gravity (the
        // feedback agent tells the user); at 30 degrees no floor is found around that
        // axis, but around the pitch the mount guess gives
        for (pitch_deg, mount, perceived) in [
            (10.0, None, true),
            (30.0, None, false),
            (30.0, Some(schemas::MountGuess { height_m: 0.9, pitch_deg: 28.0 }), true),
        ] {
            let mut scene = Scene::kinect(0.9, pitch_deg);
            scene.walls_x_m.push(2.5);
            scene.blocks.push(crate::synthetic_scene::Block { min: [1.2, -0.3, 0.0], max: [1.5, 0.3, 0.8] });
            let mut frame = scene.depth_frame(DepthEncoding::Lossless).unwrap();
            frame.gravity_camera = None;
            frame.mount = mount;
            let mut step = ComputeStep::new(PerceptionConfig::default(), CueConfig::default());
            match step.process(input(&frame, 7), &mut NoTimer) {
                StepOutput::Perceived { hazard, .. } => {
                    assert!(perceived, "pitch {pitch_deg}: {hazard:?}");
                    assert!(!hazard.gravity);
                    assert_eq!(hazard.ground, GroundState::Found);
                    assert!((hazard.nearest_m - 1.2).abs() < 0.05, "{}", hazard.nearest_m);
                    assert!(hazard.ficf.forward > 0.0, "{hazard:?}");
                }
                StepOutput::Refused { error, .. } => {
                    assert!(!perceived, "pitch {pitch_deg}: {error}");
                    assert_eq!(error.kind(), "no_ground");
                }
            }
        }
    }

    #[test]
    fn with_a_way_the_cue_comes_from_where_the_user_heads() {
        // the wall 1.2 m ahead: the cost functions warn; a user standing before it whose
        // way leads back the way they came turns round without the cane reaching it, so
        // the predictive cue sends nothing; a way into the wall is warned
        let frame = wall_frame(DepthEncoding::Lossless);
        let rumble = |way: Option<&[[f64; 2]]>| {
            let mut step = ComputeStep::new(PerceptionConfig::default(), CueConfig::default())
                .with_predictive(PredictiveConfig::default());
            let way = way.map(|points| Way { points, ends_at_goal: true, walls: &[] });
            match step.process(FrameIn { way, ..input(&frame, 7) }, &mut NoTimer) {
                StepOutput::Perceived { perception, hazard, .. } => {
                    assert_eq!(hazard.rumble, perception.rumble);
                    assert_eq!(hazard.predictive, way.is_some());
                    perception.rumble
                }
                StepOutput::Refused { error, .. } => panic!("{error}"),
            }
        };
        assert_ne!(rumble(None), Rumble::None, "the cost functions");
        assert_eq!(rumble(Some(&[[0.0, 0.0], [-5.0, 0.0]])), Rumble::None, "a way back");
        assert_ne!(rumble(Some(&[[0.0, 0.0], [5.0, 0.0]])), Rumble::None, "a way into the wall");
        // a way with a NaN (a pose gone wrong upstream) is refused and counted: the cost
        // functions decide, never a "clear" from a way that is no way
        let mut step = ComputeStep::new(PerceptionConfig::default(), CueConfig::default())
            .with_predictive(PredictiveConfig::default());
        let broken = [[0.0, 0.0], [f64::NAN, 0.0]];
        let way = Some(Way { points: &broken, ends_at_goal: true, walls: &[] });
        match step.process(FrameIn { way, ..input(&frame, 7) }, &mut NoTimer) {
            StepOutput::Perceived { perception, hazard, .. } => {
                assert!(!hazard.predictive);
                assert_eq!(perception.rumble, rumble(None), "the cost functions' cue");
            }
            StepOutput::Refused { error, .. } => panic!("{error}"),
        }
        assert_eq!(step.ways_refused(), 1);
    }

    #[test]
    fn guarding_the_body_on_the_users_own_way_needs_no_route_but_refuses_a_broken_one() {
        let frame = wall_frame(DepthEncoding::Lossless);
        let config = PredictiveConfig { guards: crate::predictive::Guards::Body, own_way: true, ..Default::default() };
        let mut step = ComputeStep::new(PerceptionConfig::default(), CueConfig::default()).with_predictive(config);
        let mut decided = |way: Option<Way<'_>>| match step.process(FrameIn { way, ..input(&frame, 7) }, &mut NoTimer) {
            StepOutput::Perceived { perception, hazard, .. } => (hazard.predictive, perception.rumble),
            StepOutput::Refused { error, .. } => panic!("{error}"),
        };
        // no way given: the cue decides on the way the user walks
        assert!(decided(None).0, "no route: the user's own way");
        // a way that is no way is refused, not replaced: the cost functions decide
        let broken = [[0.0, 0.0], [f64::NAN, 0.0]];
        let (predictive, rumble) = decided(Some(Way { points: &broken, ends_at_goal: true, walls: &[] }));
        assert!(!predictive);
        assert_ne!(rumble, Rumble::None, "the cost functions warn of the wall");
        assert_eq!(step.ways_refused(), 1);
    }

    /// The same `block` seen by a cane camera (0.99 m up, 30 degrees down) and a chest
    /// camera (1.3 m up, 10 degrees down), each frame with its mount guess.
    fn cane_and_chest_frames(block: crate::synthetic_scene::Block) -> (DepthFrame, DepthFrame) {
        let frame = |height_m: f32, pitch_deg: f32| {
            let mut scene = Scene::kinect(height_m, pitch_deg);
            scene.blocks.push(block);
            let mut f = scene.depth_frame(DepthEncoding::Raw).unwrap();
            f.mount = Some(schemas::MountGuess { height_m, pitch_deg });
            f
        };
        (frame(0.99, 30.0), frame(1.3, 10.0))
    }

    #[test]
    fn a_chest_camera_warns_of_a_head_high_sign_the_cane_camera_cannot_see() {
        // a sign hanging 1.6-1.95 m up, 1.2 m ahead, 0.8 m wide across the way: under the
        // cane camera's view (0.99 m up, 30 degrees down), in the chest camera's (1.3 m,
        // 10 degrees down)
        let sign = crate::synthetic_scene::Block { min: [1.2, -0.4, 1.6], max: [1.3, 0.4, 1.95] };
        let (cane_frame, chest_frame) = cane_and_chest_frames(sign);
        let perceived = |out: StepOutput| match out {
            StepOutput::Perceived { hazard, intent, .. } => (hazard, intent),
            StepOutput::Refused { error, .. } => panic!("{error}"),
        };
        let mut chest = ComputeStep::new(PerceptionConfig::default().for_chest(), CueConfig::default());
        let mut cane =
            ComputeStep::new(PerceptionConfig::default(), CueConfig::default()).with_second_view(SecondView::default());
        let mut alone = ComputeStep::new(PerceptionConfig::default(), CueConfig::default());
        for seq in 1..=3 {
            let (chest_hazard, _) = perceived(chest.process(input(&chest_frame, seq), &mut NoTimer));
            assert_ne!(chest_hazard.rumble, Rumble::None, "the chest camera sees the sign");
            assert!((chest_hazard.nearest_m - 1.2).abs() < 0.05, "{}", chest_hazard.nearest_m);
            cane.second_view_heard(ViewState::of(&chest_hazard, seq * 33_333_333), chest.obstacle_points());
            let (hazard, intent) = perceived(cane.process(input(&cane_frame, seq), &mut NoTimer));
            let (hazard_alone, _) = perceived(alone.process(input(&cane_frame, seq), &mut NoTimer));
            assert_eq!((hazard_alone.rumble, hazard_alone.nearest_m), (Rumble::None, f32::INFINITY), "never in view");
            assert_eq!(hazard.rumble, chest_hazard.rumble, "joined");
            assert_eq!(hazard.nearest_m, chest_hazard.nearest_m);
            assert!(intent.left.max(intent.right) > 0.0, "{intent:?}");
            assert_eq!(cane.second_view().map(|(_, j)| j), Some(Some(Joined::Joined)));
        }
        // the chest falls silent: 300 ms on the cane's cue is its own, and says so
        let late = FrameIn { capture_ns: 3 * 33_333_333 + 300_000_001, ..input(&cane_frame, 4) };
        let (hazard, _) = perceived(cane.process(late, &mut NoTimer));
        assert_eq!(hazard.rumble, Rumble::None);
        assert_eq!(cane.second_view().map(|(v, j)| (v.counts(), j)), Some(((3, 1), Some(Joined::Stale))));
    }

    #[test]
    fn the_predictive_cue_looks_ahead_among_the_chest_cameras_points() {
        // a wall cabinet 1.1-1.5 m up, 0.6 m ahead, 0.8 m wide across the way: above
        // the cane camera's view, in the chest camera's
        let cabinet = crate::synthetic_scene::Block { min: [0.6, -0.4, 1.1], max: [0.9, 0.4, 1.5] };
        let (cane_frame, chest_frame) = cane_and_chest_frames(cabinet);
        let way = [[0.0, 0.0], [10.0, 0.0]];
        let way = Some(Way { points: &way, ends_at_goal: false, walls: &[] });
        let predictive = || {
            ComputeStep::new(PerceptionConfig::default(), CueConfig::default())
                .with_predictive(PredictiveConfig::default())
        };
        let mut chest = ComputeStep::new(PerceptionConfig::default().for_chest(), CueConfig::default());
        let mut cane = predictive().with_second_view(SecondView::default());
        let mut alone = predictive();
        for seq in 1..=3 {
            let chest_hazard = match chest.process(input(&chest_frame, seq), &mut NoTimer) {
                StepOutput::Perceived { hazard, .. } => hazard,
                StepOutput::Refused { error, .. } => panic!("{error}"),
            };
            let near = chest.obstacle_points().iter().map(|p| p[0].hypot(p[1])).fold(f32::INFINITY, f32::min);
            assert!((near - 0.6).abs() < 0.05, "the chest holds the cabinet's front: {near}");
            // the chest's own state taken to be clear: whatever the cue warns of, it
            // found among the chest's points
            let clear = ViewState { rumble: Rumble::None, ..ViewState::of(&chest_hazard, seq * 33_333_333) };
            cane.second_view_heard(clear, chest.obstacle_points());
            let decided =
                |step: &mut ComputeStep| match step.process(FrameIn { way, ..input(&cane_frame, seq) }, &mut NoTimer) {
                    StepOutput::Perceived { hazard, .. } => {
                        assert!(hazard.predictive);
                        hazard.rumble
                    }
                    StepOutput::Refused { error, .. } => panic!("{error}"),
                };
            assert_eq!(decided(&mut alone), Rumble::None, "the cane camera alone sees nothing");
            assert_ne!(decided(&mut cane), Rumble::None, "the body would walk into the cabinet");
            assert_eq!(cane.second_view().map(|(_, j)| j), Some(Some(Joined::Joined)));
        }
    }

    #[test]
    fn frames_that_do_not_decode_are_refused_and_the_third_in_a_row_says_blind() {
        let mut broken = wall_frame(DepthEncoding::Lossless);
        broken.data.truncate(broken.data.len() / 2);
        let mut step = ComputeStep::new(PerceptionConfig::default(), CueConfig::default());
        let (mut blinds, mut answers) = (Vec::new(), Vec::new());
        for seq in 1..=64 {
            match step.process(input(&broken, seq), &mut NoTimer) {
                StepOutput::Refused { error, blind, answer } => {
                    assert_eq!(error.kind(), "depth_decode", "{error}");
                    blinds.push(blind);
                    answers.push(answer);
                }
                StepOutput::Perceived { .. } => panic!("a truncated frame was perceived"),
            }
        }
        assert!(blinds[0].is_none() && blinds[1].is_none(), "one or two bad frames keep the last cue");
        assert!(answers[0].is_none() && answers[1].is_none(), "one or two bad frames keep the last hazard");
        let blind = blinds[2].clone().expect("the third refusal in a row says blind");
        assert_eq!((blind.hazard.rumble, blind.hazard.ground), (Rumble::Both, GroundState::Degraded));
        assert_eq!(blind.hazard.frame_seq, 3);
        assert_eq!(blind.intent, cue_unavailable(&CueConfig::default()));
        // the user is told again every 30th frame; every frame from the third on is
        // answered with the blind hazard (the sensor agent paces its link by the answers)
        let told: Vec<usize> = blinds.iter().enumerate().filter(|(_, b)| b.is_some()).map(|(i, _)| i + 1).collect();
        assert_eq!(told, [3, 30, 60]);
        for (i, answer) in answers.iter().enumerate().skip(2) {
            let hazard = answer.as_ref().unwrap_or_else(|| panic!("frame {} unanswered", i + 1));
            assert_eq!(
                (hazard.rumble, hazard.ground, hazard.frame_seq),
                (Rumble::Both, GroundState::Degraded, i as u64 + 1)
            );
            if let Some(b) = &blinds[i] {
                assert_eq!(&b.hazard, hazard);
            }
        }
        // a good frame ends the run of refusals
        let good = wall_frame(DepthEncoding::Raw);
        assert!(matches!(step.process(input(&good, 65), &mut NoTimer), StepOutput::Perceived { .. }));
        let after = step.process(input(&broken, 66), &mut NoTimer);
        assert!(matches!(after, StepOutput::Refused { blind: None, answer: None, .. }), "{after:?}");
    }

    #[test]
    fn odometry_is_held_for_its_frame_and_an_absurd_step_is_refused() {
        let frame = wall_frame(DepthEncoding::Raw);
        let mut step = ComputeStep::new(PerceptionConfig::default(), CueConfig::default());
        let inc = |to_ns, forward_m| OdomIncrement { from_ns: 0, to_ns, forward_m, left_m: 0.0, yaw_rad: 0.0 };
        assert!(step.add_odometry(&inc(10, 0.03)).is_ok());
        let e = step.add_odometry(&inc(10, f32::NAN)).unwrap_err();
        assert_eq!(e.kind(), "odom_implausible");
        // the step ending after frame 1's capture waits for frame 2
        assert!(step.add_odometry(&inc(2 * 33_333_333, 0.03)).is_ok());
        assert!(matches!(step.process(input(&frame, 1), &mut NoTimer), StepOutput::Perceived { .. }));
        assert_eq!(step.motion.take_until(u64::MAX).map(|m| m.forward_m), Some(0.03));
    }
}
