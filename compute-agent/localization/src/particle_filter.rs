//! Monte Carlo localization over (x, y, heading, floor): AMCL's structure (Thrun,
//! Burgard & Fox, *Probabilistic Robotics*, ch. 8; ROS `amcl`) with Zhang et al.'s
//! landmark and wall-angle corrections.
//!
//! One cycle:
//! 1. [`ParticleFilter::predict`] accumulates odometry increments (and the IMU's yaw)
//!    until the user has moved `update_min_distance_m` or turned `update_min_angle_rad`
//!    (AMCL's `update_min_d` 0.25 m, `update_min_a` 0.2 rad);
//! 2. [`ParticleFilter::correct`] then moves every particle by a noisy draw of the
//!    accumulated motion and weights it by the scan's likelihood field, the landmarks
//!    and the wall angles (a landmark forces a correction: they are rare);
//! 3. when the effective sample size falls below half the particle count, low-variance
//!    resampling draws a new set whose size follows the spread of the weights (a
//!    KLD bound over occupied bins, see [`FilterConfig::kld_error`]);
//! 4. augmented MCL: short- and long-term averages of how well the scan fits
//!    (`w_fast`, `w_slow`) — when the short-term one drops well below the long-term one
//!    (a dead band: [`FilterConfig::recovery_ratio`]), a fraction of the new set is
//!    drawn uniformly in free space, so a wrong start, a kidnap or a belief dragged off
//!    by a misread door is recovered from;
//! 5. for a person ([`FilterConfig::recovery_anchor`]): a person does not jump. The last
//!    `Tracking` estimate (or the told start), carried by the odometry, is the anchor;
//!    the recovery draws near it instead of anywhere (a room's furniture, which a floor
//!    plan does not have, makes the scan fit badly where the user is and well enough in
//!    some other place of the map), and a `Tracking` estimate out of its reach is a
//!    look-alike the scans fell into: the particles are drawn again around the anchor.
//!    After a long walk without `Tracking` the anchor is forgotten.
//!
//! Everything random comes from one seeded [`Rng`]: the same inputs and seed give the
//! same particles, bit for bit.

use map::Gateway;
use serde::{Deserialize, Serialize};

use crate::bin_sums::BinSums;
use crate::floor_model::FloorModel;
use crate::landmarks::{
    compass_log_p, mixture_log_p, wall_residual, CompassHeading, Landmark, LandmarkConfig, WallAngle,
};
use crate::likelihood_field::{FreeSpaceConfig, GridPoses, LikelihoodField};
use crate::motion::{MotionDraw, MotionNoise, OdometryIncrement, RotTransRot};
use crate::pose::{fast_sin_cos, wrap_angle, Pose2};
use crate::rng::Rng;
use crate::scan::Scan;
use crate::LocalizationError;

/// How the filter behaves. Defaults are AMCL's unless a field says otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct FilterConfig {
    /// odometry (and IMU) noise
    pub motion: MotionNoise,
    /// landmark and wall-angle trust
    pub landmarks: LandmarkConfig,
    /// correct after this much walking, metres (`update_min_d`, 0.25)
    pub update_min_distance_m: f64,
    /// ... or this much turning, radians (`update_min_a`, 0.2)
    pub update_min_angle_rad: f64,
    /// beams used per scan, evenly spread (`laser_max_beams`, 30)
    pub max_beams: usize,
    /// exponent on the scan's likelihood: beams are correlated and the map is
    /// imperfect, so the product over beams is far too confident. 1/3 keeps the 30-beam
    /// product about as peaked as 10 independent beams. On the Intel log, over six
    /// seeds, 1/3 gave a position RMSE of 0.112-0.150 m against 0.127-0.155 m for 0.2,
    /// and global starts converged as fast; 1/2 lost tracks (docs/localization.md).
    /// AMCL tempers with a sum of cubes instead.
    pub scan_weight_exponent: f64,
    /// free space: the floor the camera saw along a ray, which a pose should not put a
    /// wall across, weighed with the scan's exponent. `None` (the default): not weighed.
    /// Better where the scan's walls end ahead (a building's halls: RMSE 0.16 -> 0.11 m),
    /// no better along a uniform corridor, worse on a map that marks what overhangs the
    /// floor (docs/localization.md, "Free space").
    pub free_space: Option<FreeSpaceConfig>,
    /// fewest particles (`min_particles`, 500)
    pub min_particles: usize,
    /// most particles after a resampling (`max_particles`, 5000)
    pub max_particles: usize,
    /// particles of a global start (spread over all free space; the first resampling
    /// brings the count within [min, max]). 40,000: on the Intel log, over ten seeds,
    /// 10,000 needed up to 578 updates (settling on look-alikes meanwhile), 20,000 up to
    /// 570 on one seed, 40,000 at most 13 (docs/localization.md). One update of 40,000
    /// costs ~10 ms, once.
    pub global_particles: usize,
    /// KLD bound: allowed error between the sample and the true posterior (`kld_err`, 0.01)
    pub kld_error: f64,
    /// KLD bound: the normal quantile (`kld_z` as AMCL uses it, 0.99)
    pub kld_z: f64,
    /// KLD bin size in x and y, metres (AMCL: 0.5)
    pub kld_bin_m: f64,
    /// KLD bin size in heading, radians (AMCL: 10 degrees)
    pub kld_bin_rad: f64,
    /// resample when the effective sample size falls below this fraction of the count
    pub resample_ess_fraction: f64,
    /// long-term average rate (`recovery_alpha_slow`; AMCL suggests 0.001 when enabled:
    /// a memory of ~1000 updates = 250 m. Ours is 0.01, ~25 m: a user's walks are short)
    pub alpha_slow: f64,
    /// short-term average rate (`recovery_alpha_fast`, 0.1 as AMCL suggests)
    pub alpha_fast: f64,
    /// at most this fraction of a resampled set is injected at random
    pub max_inject_fraction: f64,
    /// A person does not jump. `None` (the default, AMCL's): the recovery draws
    /// uniformly over the free space of every floor, and any `Tracking` estimate is
    /// taken. `Some`: the anchor is the last `Tracking` estimate or the told start,
    /// carried by the odometry; while the user has walked less than
    /// [`RecoveryAnchor::forget_m`] since it, the recovery draws within its reach, and a
    /// `Tracking` estimate out of its reach is a look-alike (a room that is the same
    /// turned 180°, a row of like offices): counted, and the particles drawn again
    /// around the anchor, with half its reach as their spread.
    /// For a person ([`crate::TrackerConfig`], `study::localize_walk`): on the generated
    /// worlds' floor plans (furnished offices, lobbies, streets) the uniform draw found
    /// places where the furniture's beams fit the plan's walls and lost tracks the
    /// odometry alone kept within a metre; on Taylor's course the spoken guide's filter
    /// said `Tracking` in the room turned 180° (docs/localization.md, "A person does not
    /// jump").
    pub recovery_anchor: Option<RecoveryAnchor>,
    /// A person does not walk through walls: a particle whose motion since the last
    /// correction passes through a wall of its floor's map (an occupied cell,
    /// [`FloorModel::crosses_wall`]) loses this much log-likelihood, about as much as a
    /// scan that fits nowhere (a whole set that crossed loses nothing against itself).
    /// `None` (the default, AMCL's, as the Intel log's figures were measured): no
    /// check. For a person on a floor plan
    /// ([`crate::TrackerConfig`], `study::localize_walk`): `Some(`[`WALL_CROSSING_LOG_P`]`)`;
    /// without it, in an office of two like halves the estimate went through the
    /// partition into the other half and said `Tracking` there (docs/localization.md,
    /// "A person does not walk through walls").
    pub wall_crossing_log_p: Option<f64>,
    /// once the recovery has started, it keeps injecting at least
    /// `recovery_hold_fraction` for this many updates even when the fit comes back: the
    /// first place that fits after a kidnap is often a look-alike (in the kidnap test,
    /// without the hold 7 seeds of 20 settled on one; docs/localization.md)
    pub recovery_hold_updates: u32,
    /// the fraction injected during the hold
    pub recovery_hold_fraction: f64,
    /// dead band of the recovery: particles are injected only when `w_fast / w_slow`
    /// falls below this, a fraction `1 - (w_fast / w_slow) / recovery_ratio`. Thrun's
    /// `1 - w_fast / w_slow` injects on every dip of an ordinary scan; on the Intel log
    /// those few random particles, when one fit a corridor by chance while the true
    /// cluster had a poor scan, took over a good track in 4 runs of 6
    /// (docs/localization.md). 0.75: while tracking the Intel log the ratio stays
    /// above ~0.9; at 0.6 a kidnapped filter stopped searching once it had found a
    /// mirror image of the true place that fitted 60 % of the beams.
    pub recovery_ratio: f64,
    /// `Tracking` needs the larger position standard deviation below this, metres
    pub tracking_max_std_m: f64,
    /// ... and the heading standard deviation below this, radians
    pub tracking_max_heading_std_rad: f64,
    /// ... and (once a scan was seen) the short-term scan fit and the last scan's fit
    /// at least this (on the Intel log a tracked scan fits 0.3 to 0.6)
    pub tracking_min_fit: f64,
    /// `Tracking` also needs this share of the weight in the main cluster
    pub tracking_min_cluster_weight: f64,
    /// ... and all of the above for this many corrections in a row: a look-alike found
    /// after a global start or a kidnap fits for a few updates before it fails
    /// (docs/localization.md: "Tracking while > 1 m off")
    pub tracking_min_updates: u32,
    /// A correction whose scan had fewer usable beams than this neither extends nor ends
    /// a `Tracking` streak: a handful of beams (a cane camera facing open space, or a
    /// person close in front) cannot support the claim. On a simulated corridor walk the
    /// streak was completed by a correction on 7 beams, with the estimate 1 m off
    /// (docs/localization.md).
    pub tracking_min_beams: usize,
    /// `Tracking` also needs the streak's scans, laid from the estimate, to have fixed
    /// the place in their least fixed direction by at least this many beams' worth in
    /// all ([`scan_constraint`]; a door number read counts as all of it, and a told
    /// start or a gateway's stop stands in for it until `Tracking` first ends): a
    /// corridor's two walls say where across it the user is, not where along it, and a
    /// look-alike place along it fits them as well as the true one. On a corridor without door
    /// signs, 2 of 16 walks claimed `Tracking` more than 1 m off (89 and 193 frames,
    /// established while the user turned round mid-corridor); with it none, at 2, 3, 5 or
    /// 10 alike (docs/localization.md, "Where along a corridor"). 0: off.
    pub tracking_min_constraint: f64,
    /// A beam counts in [`FilterConfig::tracking_min_constraint`] when its end point lies
    /// this close to a wall of the map, metres.
    pub constraint_wall_m: f64,
    /// A beam whose end point, seen from the prior's mean, lies in open floor more than
    /// this far from every wall, with nothing of the map between the sensor and it, is
    /// something the map does not have (a person, a bin, a chair): it is left out of the
    /// correction, which it would otherwise pull towards a place where a wall is there.
    /// Only while `Tracking` (a prior not yet borne out must not choose its own
    /// evidence: a kidnapped filter's recovery found the true place less often), and
    /// never more than half of a scan's beams (then the prior is more likely wrong than
    /// the room full). 0 (the default): every beam is weighed, as AMCL does. Measured
    /// at 0.5 m (`wearnav localize --world W --unmapped-gate 0.5`, docs/localization.md
    /// "Beams on what the map does not have"): better in a room of chairs, worse in a
    /// corridor without door signs, so not on by default.
    pub unmapped_gate_m: f64,
    /// `Lost` when the main cluster holds less than this share of the weight
    pub lost_max_cluster_weight: f64,
    /// how far from a gateway's stop a particle may be and still be taken through it by
    /// [`ParticleFilter::take_gateway`], metres (a lift lobby)
    pub gateway_radius_m: f64,
    /// the main cluster's radius, metres (see [`Estimate`])
    pub cluster_radius_m: f64,
    /// ... and its half-width in heading, radians
    pub cluster_heading_rad: f64,
    /// ... or the last scan's fit falls below this (likelihood collapse); `Lost` too
    /// while the recovery injects (`w_fast < recovery_ratio * w_slow`: the scans fit far
    /// worse than they have been)
    pub lost_max_fit: f64,
    /// odometry faster than this is refused, metres per second (a running person: 3)
    pub max_speed_m_s: f64,
    /// odometry turning faster than this is refused, radians per second
    pub max_yaw_rate_rad_s: f64,
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self {
            motion: MotionNoise::default(),
            landmarks: LandmarkConfig::default(),
            update_min_distance_m: 0.25,
            update_min_angle_rad: 0.2,
            max_beams: 30,
            scan_weight_exponent: 1.0 / 3.0,
            free_space: None,
            min_particles: 500,
            max_particles: 5000,
            global_particles: 40_000,
            kld_error: 0.01,
            kld_z: 0.99,
            kld_bin_m: 0.5,
            kld_bin_rad: 10f64.to_radians(),
            resample_ess_fraction: 0.5,
            alpha_slow: 0.01,
            alpha_fast: 0.1,
            max_inject_fraction: 0.5,
            recovery_anchor: None,
            wall_crossing_log_p: None,
            recovery_hold_updates: 30,
            recovery_hold_fraction: 0.1,
            recovery_ratio: 0.75,
            tracking_max_std_m: 0.5,
            tracking_max_heading_std_rad: 10f64.to_radians(),
            tracking_min_fit: 0.25,
            tracking_min_cluster_weight: 0.8,
            tracking_min_updates: 5,
            tracking_min_beams: 15,
            tracking_min_constraint: 3.0,
            constraint_wall_m: 0.2,
            unmapped_gate_m: 0.0,
            lost_max_cluster_weight: 0.25,
            gateway_radius_m: 3.0,
            cluster_radius_m: 1.5,
            cluster_heading_rad: 45f64.to_radians(),
            lost_max_fit: 0.12,
            max_speed_m_s: 3.0,
            max_yaw_rate_rad_s: 6.0,
        }
    }
}

/// What a particle that walked through a wall loses ([`FilterConfig::wall_crossing_log_p`]):
/// e^-20, some 2e-9 of the weight it had: none, unless the whole set crossed. (A
/// twentieth, e^-3, was tried: better on the one world it was chosen on, worse on the
/// generated ones; docs/localization.md, "A person does not walk through walls".)
pub const WALL_CROSSING_LOG_P: f64 = -20.0;

/// Where a person can be: within `radius_m + per_walked_m * walked` of the anchor,
/// headings within `heading_rad` of its heading ([`FilterConfig::recovery_anchor`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RecoveryAnchor {
    /// radius at the anchor, metres
    pub radius_m: f64,
    /// radius added per metre walked since the anchor (visual odometry errs by a few
    /// percent)
    pub per_walked_m: f64,
    /// half-width of the headings drawn, radians
    pub heading_rad: f64,
    /// after this much walking without `Tracking` the anchor is forgotten (its heading
    /// may have drifted too far) and the recovery draws over the whole map, metres; a
    /// place not followed from the last known one is then a search's
    /// ([`Estimate::searched`])
    pub forget_m: f64,
}

impl Default for RecoveryAnchor {
    fn default() -> Self {
        Self { radius_m: 1.0, per_walked_m: 0.1, heading_rad: 45f64.to_radians(), forget_m: 50.0 }
    }
}

/// The anchor of a person's recovery: a pose on a floor and the walking since.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Anchor {
    pose: Pose2,
    floor: u16,
    walked_m: f64,
}

/// A door number or a named place told while the place was a search's, that may yet
/// confirm it ([`ParticleFilter::confirm_searched`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Told {
    /// floor index
    floor: usize,
    /// where it is on the map
    at: [f64; 2],
    /// where it is from the user now (forward, left), metres: where the reading put it,
    /// moved by the odometry since
    offset: [f64; 2],
    /// how near the estimate must put it, metres
    near: f64,
    /// walked since it was told, metres
    walked_m: f64,
}

/// One hypothesis of where the user is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Particle {
    /// pose in the map frame of floor `level`
    pub pose: Pose2,
    /// the floor's level
    pub level: i32,
    /// normalised weight (the set sums to 1)
    pub weight: f64,
    /// index of the floor in the filter's floors
    #[serde(skip)]
    floor: u16,
}

/// How sure the filter is (thresholds in [`FilterConfig`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Status {
    /// one tight cluster holding most of the weight that fits the scans, for
    /// `tracking_min_updates` corrections in a row: guidance may rely on it
    Tracking,
    /// converging or spread out, but the scans still fit
    Uncertain,
    /// no dominant hypothesis, or the scans no longer fit (likelihood collapse)
    Lost,
}

/// The filter's answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// weighted mean pose (circular mean heading) of the main cluster: the particles
    /// within `cluster_radius_m` and `cluster_heading_rad` of the heaviest part of the
    /// most likely floor
    pub pose: Pose2,
    /// the most likely floor's level
    pub level: i32,
    /// covariance of (x, y, heading) of the main cluster about its mean, m^2 / m rad / rad^2
    pub covariance: [[f64; 3]; 3],
    /// the main cluster's share of the weight (1: a single hypothesis)
    pub cluster_weight: f64,
    /// see [`Status`]
    pub status: Status,
    /// Route guidance may take this place ([`Estimate::guides`]): `Tracking`, or, not
    /// `Lost`, followed by the motion from a known place (a told start, a gateway's
    /// stop, a `Tracking` estimate) with every correction since meeting `Tracking`'s
    /// conditions but the streak (the main cluster's weight and spread, the scans' fit,
    /// the compass; the heading within [`FOLLOW_MAX_HEADING_STD_DEG`]) and none moving
    /// the place more than [`FOLLOW_MAX_JUMP_M`] from where the motion took it. Where
    /// the scans have too few beams to confirm the place (a cane camera facing open
    /// pavement), it is still where the motion took it. The predictive cue takes
    /// `Tracking` alone.
    #[serde(default)]
    pub followed: bool,
    /// The place was found by a search over every floor (a global start: no start
    /// told; or a recovery drawing over the whole map once the anchor of a person's
    /// recovery was lost, [`RecoveryAnchor::forget_m`], and the place was no longer
    /// followed from the last known one) and no word of the user's has confirmed it
    /// since: a door number read at it, or a place named near it
    /// ([`ParticleFilter::correct`]). On a floor plan
    /// with look-alikes (a rectangular room, a symmetric corridor) such a search
    /// settles on a mirror image of the place as readily as on the place, and calls it
    /// `Tracking` (docs/localization.md, "A global start is not a place"): guidance
    /// does not take it ([`Estimate::guides`]).
    #[serde(default)]
    pub searched: bool,
    /// short-term scan fit in (0, 1]: weighted mean over particles of the mean, over
    /// beams, of a beam's likelihood relative to a beam on a wall (how much of the scan
    /// the map explains); 1 when no scan was seen
    pub fit: f64,
    /// number of particles
    pub particles: usize,
}

impl Estimate {
    /// Whether route guidance may take this place: `Tracking`, or followed from a known
    /// place ([`Estimate::followed`]); never a place a search found and the user has
    /// not confirmed ([`Estimate::searched`]).
    pub fn guides(&self) -> bool {
        (self.status == Status::Tracking || self.followed) && !self.searched
    }

    /// Whether the filter tracks a place a search found that only the user's word can
    /// confirm ([`Estimate::searched`]): a door number or a named place, not turning on
    /// the spot (`guidance::Navigator::set_awaiting_word`).
    pub fn awaits_word(&self) -> bool {
        self.status == Status::Tracking && self.searched
    }

    /// Standard deviation along the covariance's major axis, metres.
    pub fn position_std_m(&self) -> f64 {
        let [[a, b, _], [_, d, _], _] = self.covariance;
        symmetric_2x2_eigenvalues(a, b, d).1.max(0.0).sqrt()
    }

    /// Standard deviation of the heading, radians.
    pub fn heading_std_rad(&self) -> f64 {
        self.covariance[2][2].max(0.0).sqrt()
    }
}

/// What was refused or done, for the agent's counters and logs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// odometry increments refused (NaN, jumps)
    pub odometry_rejected: u64,
    /// landmarks refused (door number not on any floor, non-finite offsets)
    pub landmarks_rejected: u64,
    /// wall angles refused (non-finite)
    pub wall_angles_rejected: u64,
    /// beams skipped (NaN, non-positive, max range)
    pub beams_unusable: u64,
    /// beams left out of a correction as something the map does not have
    /// ([`FilterConfig::unmapped_gate_m`])
    pub beams_unmapped: u64,
    /// corrections done
    pub updates: u64,
    /// resamplings done
    pub resamples: u64,
    /// particles drawn at random by recovery
    pub particles_injected: u64,
    /// particles drawn where a door reading puts the user (sensor resetting)
    pub particles_at_doors: u64,
    /// corrections after which every weight was zero or non-finite (reset to uniform)
    pub weight_collapses: u64,
    /// `Tracking` estimates out of the anchor's reach, refused as look-alikes
    /// ([`FilterConfig::recovery_anchor`])
    pub look_alikes: u64,
    /// searched places a door number or a named place confirmed ([`Estimate::searched`])
    pub searches_confirmed: u64,
    /// anchors of a person's recovery lost by walking past [`RecoveryAnchor::forget_m`]
    /// without `Tracking` (the recovery then draws over the whole map)
    pub anchors_lost: u64,
    /// compass readings refused (not a finite heading)
    pub compass_rejected: u64,
    /// particles whose motion passed through a wall ([`FilterConfig::wall_crossing_log_p`])
    pub wall_crossings: u64,
    /// corrections that would have been `Tracking` but for a heading the compass
    /// contradicted ([`LandmarkConfig::compass_gate_rad`])
    pub compass_disagreements: u64,
}

/// What one correction did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Correction {
    /// whether the particles were moved and weighted (false: not enough motion yet)
    pub updated: bool,
    /// whether they were resampled
    pub resampled: bool,
    /// particles injected at random
    pub injected: usize,
    /// particles drawn where a door reading puts the user
    pub at_doors: usize,
    /// landmarks refused (a door number on no floor, a non-finite offset); also counted
    /// in [`Counters::landmarks_rejected`]
    pub landmarks_refused: usize,
}

/// Observations offered to [`ParticleFilter::correct`].
#[derive(Clone, Copy, Debug, Default)]
pub struct Observations<'a> {
    /// the latest range scan
    pub scan: Option<&'a Scan>,
    /// landmarks seen since the last call
    pub landmarks: &'a [Landmark],
    /// wall directions seen beside the user
    pub wall_angles: &'a [WallAngle],
    /// the body's heading as a compass gives it (the tracker's is averaged over the
    /// walking), weighed loosely ([`LandmarkConfig::compass_tolerance_rad`])
    pub compass: Option<CompassHeading>,
}

/// Why an input was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Rejected {
    /// an odometry increment that cannot be a person's motion
    #[error("odometry increment refused: {0}")]
    Odometry(&'static str),
    /// an IMU yaw rate that is not finite or too fast
    #[error("IMU yaw rate refused: {0} rad/s")]
    ImuYawRate(f64),
}

/// The particle filter. See the module documentation.
#[derive(Clone, Debug)]
pub struct ParticleFilter {
    floors: Vec<FloorModel>,
    config: FilterConfig,
    rng: Rng,
    particles: Vec<Particle>,
    /// motion since the last correction, in the body frame at the last correction
    pending: Pose2,
    /// gyro yaw over the same interval, when every increment came with one
    pending_imu_yaw: Option<f64>,
    pending_dt_s: f64,
    pending_increments: usize,
    force_update: bool,
    w_slow: f64,
    w_fast: f64,
    last_w_avg: f64,
    scans_since_init: u64,
    /// updates the recovery keeps injecting for
    hold_left: u32,
    /// corrections in a row that met the `Tracking` conditions
    tracking_streak: u32,
    /// usable beams of this correction's scan (`None`: no scan in it)
    scan_beams: Option<usize>,
    /// the compass's heading at the last correction, if it gave one
    compass_now: Option<f64>,
    /// how many beams' worth this correction's scan fixed the place by in its least
    /// fixed direction, from the estimate (`None`: no scan in it)
    scan_constraint: Option<f64>,
    /// whether this correction applied a door number
    door_read: bool,
    /// door numbers and named places told while the place was a search's
    /// ([`Estimate::searched`]), kept for [`CONFIRM_WITHIN_M`] of walking
    told: Vec<Told>,
    /// the place descends from a search over the whole map (a global start), confirmed
    /// since or not: a jump from it is a place no word confirmed
    from_search: bool,
    /// the scan constraint summed over the corrections of the `Tracking` streak
    streak_constraint: f64,
    /// a told start or gateway stop stands in for the scan constraint until `Tracking`
    /// first ends
    start_vouches: bool,
    /// the place descends from a known one by the motion, every correction since
    /// meeting `Tracking`'s conditions but the streak ([`Estimate::followed`])
    from_known: bool,
    /// where the user was last known to be, carried by the odometry; only with
    /// [`FilterConfig::recovery_anchor`]
    anchor: Option<Anchor>,
    /// the anchor was lost (walked past [`RecoveryAnchor::forget_m`], or left behind at
    /// a gateway far from it) and neither a new anchor nor the user's word has come
    /// since: the recovery draws over the whole map, as a global start's search does
    anchor_lost: bool,
    scan_seen: bool,
    estimate: Estimate,
    counters: Counters,
    // buffers reused across corrections
    /// (sin, cos) of each particle's heading, as of the last motion
    trig: Vec<(f64, f64)>,
    log_w: Vec<f64>,
    /// whether each particle's last motion passed through a wall (only with
    /// [`FilterConfig::wall_crossing_log_p`])
    crossed: Vec<bool>,
    scan_fit: Vec<f64>,
    endpoints: Vec<[f64; 2]>,
    /// the same in f32, for the likelihood field's inner loop
    endpoints32: Vec<[f32; 2]>,
    /// one floor's particles at a time: their indices, grid poses and sums
    batch_index: Vec<usize>,
    batch_pose: GridPoses,
    batch_sums: Vec<[f32; 2]>,
    /// free space: body-frame points along the free rays (and in f32), where each ray
    /// ends among them, each particle's cost over the rays in a batch, and a ray's
    /// nearest distance code to a wall per particle
    free_points: Vec<[f64; 2]>,
    free_points32: Vec<[f32; 2]>,
    free_ray_ends: Vec<usize>,
    free_crossed: Vec<f32>,
    free_nearest: Vec<u8>,
    bins: BinSums,
    next: Vec<Particle>,
    /// door numbers and places told that few particles agreed with: (floor index, where,
    /// body-frame offset, sigma)
    door_resets: Vec<(u16, [f64; 2], [f64; 2], f64)>,
}

impl ParticleFilter {
    /// A filter over `floors` (at least one, levels unique), seeded with `seed`,
    /// starting spread uniformly over their free space ([`Self::init_global`]).
    pub fn new(floors: Vec<FloorModel>, config: FilterConfig, seed: u64) -> Result<Self, LocalizationError> {
        if floors.is_empty() {
            return Err(LocalizationError::NoFloors);
        }
        for (i, f) in floors.iter().enumerate() {
            if floors[..i].iter().any(|g| g.level == f.level) {
                return Err(LocalizationError::DuplicateFloor { level: f.level });
            }
        }
        if floors.len() > u16::MAX as usize {
            return Err(LocalizationError::TooManyFloors);
        }
        if !(config.min_particles >= 1 && config.min_particles <= config.max_particles) {
            return Err(LocalizationError::BadConfig("need 1 <= min_particles <= max_particles".into()));
        }
        if config.max_particles > 1_000_000 || config.global_particles > 1_000_000 {
            return Err(LocalizationError::BadConfig("max_particles or global_particles above 1,000,000".into()));
        }
        let mut f = Self {
            floors,
            config,
            rng: Rng::new(seed),
            particles: Vec::new(),
            pending: Pose2::default(),
            pending_imu_yaw: Some(0.0),
            pending_dt_s: 0.0,
            pending_increments: 0,
            force_update: true,
            w_slow: 0.0,
            w_fast: 0.0,
            last_w_avg: 0.0,
            scans_since_init: 0,
            hold_left: 0,
            tracking_streak: 0,
            scan_beams: None,
            compass_now: None,
            scan_constraint: None,
            door_read: false,
            told: Vec::new(),
            from_search: true,
            streak_constraint: 0.0,
            start_vouches: false,
            from_known: false,
            anchor: None,
            anchor_lost: false,
            scan_seen: false,
            estimate: Estimate {
                pose: Pose2::default(),
                level: 0,
                covariance: [[0.0; 3]; 3],
                cluster_weight: 0.0,
                status: Status::Lost,
                followed: false,
                searched: true,
                fit: 1.0,
                particles: 0,
            },
            counters: Counters::default(),
            trig: Vec::new(),
            log_w: Vec::new(),
            crossed: Vec::new(),
            scan_fit: Vec::new(),
            endpoints: Vec::new(),
            endpoints32: Vec::new(),
            batch_index: Vec::new(),
            batch_pose: GridPoses::default(),
            batch_sums: Vec::new(),
            free_points: Vec::new(),
            free_points32: Vec::new(),
            free_ray_ends: Vec::new(),
            free_crossed: Vec::new(),
            free_nearest: Vec::new(),
            bins: BinSums::default(),
            next: Vec::new(),
            door_resets: Vec::new(),
        };
        f.init_global();
        Ok(f)
    }

    /// Forget everything: `global_particles` particles uniform over the free space of
    /// all floors (in proportion to their free area), uniform heading.
    pub fn init_global(&mut self) {
        let n = self.config.global_particles.max(self.config.min_particles);
        self.particles.clear();
        for _ in 0..n {
            let p = self.random_particle(1.0 / n as f64);
            self.particles.push(p);
        }
        self.after_init();
        self.anchor = None;
        self.anchor_lost = false;
        self.estimate.searched = true;
        self.from_search = true;
        self.told.clear();
    }

    /// Start near a known pose: `min_particles.max(1000).min(max_particles)` particles,
    /// Gaussian around `pose` on floor `level`.
    pub fn init_pose(
        &mut self,
        level: i32,
        pose: Pose2,
        sigma_xy_m: f64,
        sigma_heading_rad: f64,
    ) -> Result<(), LocalizationError> {
        let floor = self.floor_index(level).ok_or(LocalizationError::UnknownFloor { level })?;
        if ![pose.x_m, pose.y_m, pose.heading_rad, sigma_xy_m, sigma_heading_rad].iter().all(|v| v.is_finite()) {
            return Err(LocalizationError::BadConfig("initial pose and spread must be finite".into()));
        }
        let n = self.config.min_particles.max(1000).min(self.config.max_particles);
        self.particles.clear();
        for _ in 0..n {
            let p = self.draw_free(floor, |rng| {
                Pose2::new(
                    pose.x_m + rng.normal(sigma_xy_m),
                    pose.y_m + rng.normal(sigma_xy_m),
                    pose.heading_rad + rng.normal(sigma_heading_rad),
                )
            });
            self.particles.push(Particle { pose: p, level, weight: 1.0 / n as f64, floor: floor as u16 });
        }
        self.after_init();
        // the told place says where along a corridor the user is, until the first
        // `Tracking` ends; a streak after that must find it in the scans
        self.start_vouches = true;
        self.from_known = true;
        self.estimate.searched = false;
        self.from_search = false;
        self.told.clear();
        self.follow(None);
        self.anchor = self.config.recovery_anchor.map(|_| Anchor { pose, floor: floor as u16, walked_m: 0.0 });
        self.anchor_lost = false;
        Ok(())
    }

    /// A pose from `draw` on floor `floor`: a person stands in free space, so a draw in
    /// a wall or off the map is drawn again (a few times: a place given in a wall keeps
    /// its spread).
    fn draw_free(&mut self, floor: usize, mut draw: impl FnMut(&mut Rng) -> Pose2) -> Pose2 {
        let mut p = draw(&mut self.rng);
        for _ in 1..START_DRAWS {
            if self.floors[floor].is_free(p.x_m, p.y_m) {
                break;
            }
            p = draw(&mut self.rng);
        }
        p
    }

    fn after_init(&mut self) {
        self.pending = Pose2::default();
        self.pending_imu_yaw = Some(0.0);
        self.pending_dt_s = 0.0;
        self.pending_increments = 0;
        self.force_update = true;
        self.w_slow = 0.0;
        self.w_fast = 0.0;
        self.last_w_avg = 0.0;
        self.scans_since_init = 0;
        self.hold_left = 0;
        self.scan_seen = false;
        self.estimate.fit = 1.0;
        self.fill_trig();
        self.compute_estimate();
        // a start is a claim, not an observation: `Tracking` comes from corrections
        self.tracking_streak = 0;
        self.streak_constraint = 0.0;
        self.start_vouches = false;
        self.from_known = false;
        self.estimate.followed = false;
        if self.estimate.status == Status::Tracking {
            self.estimate.status = Status::Uncertain;
        }
    }

    /// One sin_cos per particle, shared by the scan, the landmarks and the estimate.
    fn fill_trig(&mut self) {
        self.trig.clear();
        self.trig.extend(self.particles.iter().map(|p| fast_sin_cos(p.pose.heading_rad)));
    }

    fn floor_index(&self, level: i32) -> Option<usize> {
        self.floors.iter().position(|f| f.level == level)
    }

    fn random_particle(&mut self, weight: f64) -> Particle {
        let total: usize = self.floors.iter().map(|f| f.free_cells.len()).sum();
        let mut k = self.rng.index(total);
        let mut fi = 0;
        while k >= self.floors[fi].free_cells.len() {
            k -= self.floors[fi].free_cells.len();
            fi += 1;
        }
        let f = &self.floors[fi];
        let [cx, cy] = f.free_cells[k];
        let half = f.cell_m / 2.0;
        let pose = Pose2::new(
            cx + self.rng.range(-half, half),
            cy + self.rng.range(-half, half),
            self.rng.range(-std::f64::consts::PI, std::f64::consts::PI),
        );
        Particle { pose, level: f.level, weight, floor: fi as u16 }
    }

    /// A particle for the recovery: near the anchor while there is one
    /// ([`FilterConfig::recovery_anchor`]), else anywhere.
    fn recovery_particle(&mut self, weight: f64) -> Particle {
        let (Some(a), Some(c)) = (self.anchor, self.config.recovery_anchor) else {
            return self.random_particle(weight);
        };
        let r = c.radius_m + c.per_walked_m * a.walked_m;
        let compass = self.compass_now.map(|h| (h, self.config.landmarks.compass_tolerance_rad));
        // uniform over the disc, headings within the anchor's reach
        let pose = self.draw_free(a.floor as usize, |rng| {
            let d = r * rng.uniform().sqrt();
            let (s, co) = rng.range(-std::f64::consts::PI, std::f64::consts::PI).sin_cos();
            // the compass's heading when there is one: the anchor's may be the turned
            // copy the recovery has to leave
            let h = match compass {
                Some((heading, tolerance)) => heading + rng.range(-tolerance, tolerance),
                None => a.pose.heading_rad + rng.range(-c.heading_rad, c.heading_rad),
            };
            Pose2::new(a.pose.x_m + d * co, a.pose.y_m + d * s, h)
        });
        Particle { pose, level: self.floors[a.floor as usize].level, weight, floor: a.floor }
    }

    /// The user took `gateway` (lift, stairs, ramp) to floor `to_level`: the agent saw
    /// a lift ride or a climb (barometer, the user's words). Odometry cannot say it, so
    /// it is an event. Particles within `gateway_radius_m` of the gateway's stop on their
    /// own floor move to its stop on `to_level`, keeping their offset from the stop and
    /// their heading (with 0.3 rad of noise: one turns in a lift); the others (the belief
    /// that the user was elsewhere) are dropped, the moved ones resampled by weight to
    /// the same count. When no particle was near, all are drawn around the destination
    /// stop (`gateway_radius_m / 2`, any heading). Returns how many were near. `Tracking`
    /// must be earned again by corrections.
    pub fn take_gateway(&mut self, gateway: &Gateway, to_level: i32) -> Result<usize, LocalizationError> {
        let to_floor = self.floor_index(to_level).ok_or(LocalizationError::UnknownFloor { level: to_level })?;
        let dest = gateway
            .stop(to_level)
            .ok_or_else(|| LocalizationError::GatewayNotOnFloor { gateway: gateway.name.clone(), level: to_level })?;
        let (dx0, dy0) = (dest.x, dest.y);
        let r = self.config.gateway_radius_m;
        // the anchor goes through with the user when it was near a stop, as the
        // particles do; otherwise the recovery has no place to start from
        let anchored = self.anchor.is_some();
        self.anchor = self.anchor.and_then(|a| {
            let stop = gateway.stop(self.floors[a.floor as usize].level)?;
            let (ox, oy) = (a.pose.x_m - stop.x, a.pose.y_m - stop.y);
            (ox * ox + oy * oy <= r * r).then(|| Anchor {
                pose: Pose2::new(dx0 + ox, dy0 + oy, a.pose.heading_rad),
                floor: to_floor as u16,
                walked_m: 0.0,
            })
        });
        self.anchor_lost |= anchored && self.anchor.is_none();
        let n = self.particles.len().max(1);
        // moved copies of the particles near a stop, with their weights
        self.next.clear();
        for p in &self.particles {
            let Some(stop) = gateway.stop(p.level) else { continue };
            let (ox, oy) = (p.pose.x_m - stop.x, p.pose.y_m - stop.y);
            if ox * ox + oy * oy <= r * r {
                let pose = Pose2::new(dx0 + ox, dy0 + oy, p.pose.heading_rad);
                self.next.push(Particle { pose, level: to_level, weight: p.weight, floor: to_floor as u16 });
            }
        }
        let near = self.next.len();
        let mut fresh = Vec::with_capacity(n);
        if near > 0 {
            let total: f64 = self.next.iter().map(|p| p.weight).sum();
            let step = total / n as f64;
            let mut u = self.rng.uniform() * step;
            let (mut i, mut c) = (0, self.next[0].weight);
            for _ in 0..n {
                while u > c && i + 1 < near {
                    i += 1;
                    c += self.next[i].weight;
                }
                let mut p = self.next[i];
                p.pose = Pose2::new(p.pose.x_m, p.pose.y_m, p.pose.heading_rad + self.rng.normal(0.3));
                p.weight = 1.0 / n as f64;
                fresh.push(p);
                u += step;
            }
        } else {
            for _ in 0..n {
                let pose = Pose2::new(
                    dx0 + self.rng.normal(r / 2.0),
                    dy0 + self.rng.normal(r / 2.0),
                    self.rng.range(-std::f64::consts::PI, std::f64::consts::PI),
                );
                fresh.push(Particle { pose, level: to_level, weight: 1.0 / n as f64, floor: to_floor as u16 });
            }
        }
        self.particles = fresh;
        self.pending = Pose2::default();
        self.pending_imu_yaw = Some(0.0);
        self.pending_dt_s = 0.0;
        self.pending_increments = 0;
        self.force_update = true;
        self.fill_trig();
        self.compute_estimate();
        self.tracking_streak = 0;
        self.streak_constraint = 0.0;
        // the gateway's stop is a told place, as a start is
        self.start_vouches = true;
        self.from_known = true;
        self.follow(None);
        if self.estimate.status == Status::Tracking {
            self.estimate.status = Status::Uncertain;
        }
        Ok(near)
    }

    /// Adds an odometry increment (and the IMU's yaw rate over the same interval, if
    /// any). Implausible input is refused, counted, and changes nothing.
    pub fn predict(&mut self, odometry: &OdometryIncrement, imu_yaw_rate_rad_s: Option<f64>) -> Result<(), Rejected> {
        if let Some(why) = odometry.implausible(self.config.max_speed_m_s, self.config.max_yaw_rate_rad_s) {
            self.counters.odometry_rejected += 1;
            return Err(Rejected::Odometry(why));
        }
        if let Some(rate) = imu_yaw_rate_rad_s {
            if !rate.is_finite() || rate.abs() > self.config.max_yaw_rate_rad_s {
                self.counters.odometry_rejected += 1;
                return Err(Rejected::ImuYawRate(rate));
            }
        }
        let imu_yaw = imu_yaw_rate_rad_s.map(|r| r * odometry.dt_s);
        let yaw = imu_yaw.unwrap_or(odometry.yaw_rad);
        self.pending_imu_yaw = match (self.pending_imu_yaw, imu_yaw) {
            (Some(a), Some(b)) => Some(a + b),
            _ => None,
        };
        self.pending = self.pending.compose(odometry.forward_m, odometry.left_m, yaw);
        let step_m = odometry.forward_m.hypot(odometry.left_m);
        let (sin, cos) = (-yaw).sin_cos();
        for t in &mut self.told {
            let [fx, lx] = [t.offset[0] - odometry.forward_m, t.offset[1] - odometry.left_m];
            t.offset = [cos * fx - sin * lx, sin * fx + cos * lx];
            t.walked_m += step_m;
        }
        self.told.retain(|t| t.walked_m <= CONFIRM_WITHIN_M);
        if let (Some(a), Some(c)) = (&mut self.anchor, self.config.recovery_anchor) {
            a.pose = a.pose.compose(odometry.forward_m, odometry.left_m, yaw);
            a.walked_m += odometry.forward_m.hypot(odometry.left_m);
            // after a long walk without `Tracking` the odometry's place is no better
            // than the filter's (its heading may have drifted too far)
            if a.walked_m > c.forget_m {
                self.anchor = None;
                self.anchor_lost = true;
                self.counters.anchors_lost += 1;
            }
        }
        self.pending_dt_s += odometry.dt_s;
        self.pending_increments += 1;
        Ok(())
    }

    /// The next [`ParticleFilter::correct`] updates whatever the motion since the last:
    /// the sensor itself turned enough to see something new (a swept cane while the
    /// user stands).
    pub fn force_update(&mut self) {
        self.force_update = true;
    }

    /// Whether enough motion has accumulated for a correction.
    pub fn update_due(&self) -> bool {
        self.force_update
            || self.pending.x_m.hypot(self.pending.y_m) >= self.config.update_min_distance_m
            || self.pending.heading_rad.abs() >= self.config.update_min_angle_rad
    }

    /// Applies the accumulated motion and the observations, if an update is due (or a
    /// landmark was seen); otherwise does nothing. Landmarks not on the map and
    /// non-finite wall angles are refused and counted; the rest still apply.
    pub fn correct(&mut self, obs: &Observations) -> Correction {
        // landmarks the maps cannot place (a door number on no floor, a non-finite
        // offset) are refused and counted before anything moves: a refused reading
        // must not even trigger a resampling
        let mut landmarks = Vec::with_capacity(obs.landmarks.len());
        for lm in obs.landmarks {
            if self.landmark_usable(lm) {
                landmarks.push(lm);
            } else {
                self.counters.landmarks_rejected += 1;
            }
        }
        let landmarks_refused = obs.landmarks.len() - landmarks.len();
        let has_landmark = !landmarks.is_empty();
        if !(self.update_due() || has_landmark) {
            return Correction { landmarks_refused, ..Default::default() };
        }
        // where the motion alone takes the place: a correction that moves it further is
        // a jump
        let predicted = self.estimate();
        self.apply_motion();
        self.fill_trig();
        self.force_update = false;
        self.counters.updates += 1;

        let n = self.particles.len();
        self.door_resets.clear();
        self.log_w.clear();
        self.log_w.resize(n, 0.0);
        if let Some(log_p) = self.config.wall_crossing_log_p {
            for (lw, _) in self.log_w.iter_mut().zip(&self.crossed).filter(|(_, &c)| c) {
                *lw += log_p;
            }
        }
        let scan_used = match obs.scan {
            Some(scan) => {
                self.weigh_free_space(scan);
                self.weigh_scan(scan)
            }
            None => false,
        };
        self.scan_beams = obs.scan.map(|_| self.endpoints.len());
        self.door_read = false;
        for lm in landmarks {
            self.weigh_landmark(lm);
        }
        for wall in obs.wall_angles {
            self.weigh_wall(wall);
        }
        self.compass_now = match obs.compass {
            Some(c) if c.heading_rad.is_finite() => Some(c.heading_rad),
            Some(_) => {
                self.counters.compass_rejected += 1;
                None
            }
            None => None,
        };
        if let Some(heading) = self.compass_now {
            let cfg = self.config.landmarks;
            for (p, lw) in self.particles.iter().zip(self.log_w.iter_mut()) {
                *lw += compass_log_p(p.pose.heading_rad - heading, &cfg);
            }
        }

        if scan_used {
            self.update_fit_averages();
        }
        self.normalise_weights();
        if self.scan_seen {
            self.estimate.fit = self.w_fast;
        }
        self.compute_estimate();
        // the anchor lost, the recovery has drawn over the whole map: a place no longer
        // followed from the last known one (or that jumped from it) is a search's, for
        // the user's word to confirm, as a global start's is
        if self.anchor_lost && (!self.from_known || self.jumped(Some(&predicted))) {
            self.estimate.searched = true;
            self.from_search = true;
        }
        self.confirm_searched();
        self.hold_to_anchor();
        self.follow(Some(&predicted));

        let ess = 1.0 / self.particles.iter().map(|p| p.weight * p.weight).sum::<f64>();
        let inject_fraction = self.recovery_fraction();
        let mut out = Correction { updated: true, landmarks_refused, ..Default::default() };
        let inject_wanted = (inject_fraction * self.config.min_particles as f64) >= 1.0;
        let door_fraction = if self.door_resets.is_empty() { 0.0 } else { self.config.landmarks.door_reset_fraction };
        let door_wanted = door_fraction * self.config.min_particles as f64 >= 1.0;
        if ess < self.config.resample_ess_fraction * n as f64 || inject_wanted || door_wanted {
            (out.injected, out.at_doors) = self.resample(inject_fraction, door_fraction);
            out.resampled = true;
        }
        out
    }

    /// A searched place ([`Estimate::searched`]) the user's word confirms: a door number
    /// or named place told in the last [`CONFIRM_WITHIN_M`] of walking is where the
    /// estimate puts it, on its floor ([`CONFIRM_DOOR_M`], a place's `place_sigma_m`,
    /// and [`CONFIRM_PER_WALKED`] per metre walked since), and the main cluster holds
    /// `tracking_min_cluster_weight` of the belief. Confirmed, it vouches for the place
    /// as a told start does, and anchors the look-alike check there; a later jump of the
    /// estimate ([`FOLLOW_MAX_JUMP_M`]: the belief went to a look-alike) makes it a
    /// search's place again, for a word to confirm anew.
    fn confirm_searched(&mut self) {
        let e = &self.estimate;
        // the word must have made the place the filter's own: where look-alikes still
        // hold much of the belief, its main cluster may be a stride off the place
        if !e.searched || e.cluster_weight < self.config.tracking_min_cluster_weight {
            return;
        }
        // a door's number says where the user is, not which way they face: where a
        // compass is read, a place turned from its heading is a turned copy (anchored
        // there, the place itself would be refused as its look-alike)
        if !self.compass_agrees(e.pose.heading_rad) {
            return;
        }
        let Some(fi) = self.floor_index(e.level) else { return };
        let confirmed = self.told.iter().any(|t| {
            let seen = e.pose.compose(t.offset[0], t.offset[1], 0.0);
            t.floor == fi && (seen.x_m - t.at[0]).hypot(seen.y_m - t.at[1]) <= t.near + CONFIRM_PER_WALKED * t.walked_m
        });
        if confirmed {
            // the user's word for the place, as a told start is: it vouches for the
            // place, and a person does not jump from it
            let pose = e.pose;
            self.estimate.searched = false;
            self.start_vouches = true;
            self.from_known = true;
            self.anchor = self.config.recovery_anchor.map(|_| Anchor { pose, floor: fi as u16, walked_m: 0.0 });
            self.anchor_lost = false;
            self.told.clear();
            self.counters.searches_confirmed += 1;
        }
    }

    /// A person does not jump: a `Tracking` estimate within the anchor's reach becomes
    /// the anchor; one out of it is a look-alike, and the particles are drawn again
    /// around the anchor (which stays, and keeps moving with the odometry).
    fn hold_to_anchor(&mut self) {
        let Some(c) = self.config.recovery_anchor else { return };
        let e = &self.estimate;
        // a searched place is no person's place yet: anchored to it, the place itself
        // would be refused as its look-alike
        if e.status != Status::Tracking || e.searched {
            return;
        }
        let (pose, level) = (e.pose, e.level);
        let Some(floor) = self.floor_index(level) else { return };
        if let Some(a) = self.anchor.filter(|a| a.floor as usize == floor) {
            let reach = c.radius_m + c.per_walked_m * a.walked_m;
            let turned = wrap_angle(pose.heading_rad - a.pose.heading_rad).abs();
            if pose.distance_m(&a.pose) > reach || turned > c.heading_rad {
                self.counters.look_alikes += 1;
                let sigma = [reach / 2.0, c.heading_rad / 2.0];
                if self.init_pose(level, a.pose, sigma[0], sigma[1]).is_ok() {
                    self.anchor = Some(a);
                    return;
                }
            }
        }
        self.anchor = Some(Anchor { pose, floor: floor as u16, walked_m: 0.0 });
        self.anchor_lost = false;
    }

    /// Starts the particles about `pose` on the first floor as a told start would, but
    /// keeps the anchor: a filter that fell into a look-alike, for the tests of the
    /// look-alike check.
    #[cfg(test)]
    pub(crate) fn throw_to(&mut self, pose: Pose2) {
        let (anchor, lost) = (self.anchor, self.anchor_lost);
        self.init_pose(self.floors[0].level, pose, 0.05, 0.02).expect("a finite pose");
        (self.anchor, self.anchor_lost) = (anchor, lost);
    }

    /// Whether the anchor of a person's recovery is lost (walked off, or left at a
    /// gateway far from it), for the tests.
    #[cfg(test)]
    pub(crate) fn anchor_lost(&self) -> bool {
        self.anchor_lost
    }

    /// Forgets the anchor ([`FilterConfig::recovery_anchor`]): the user said where
    /// they are (a door's number), so the next `Tracking` estimate is taken as it is.
    pub fn forget_anchor(&mut self) {
        self.anchor = None;
        self.anchor_lost = false;
    }

    /// Augmented MCL's averages of the scan fit under the predicted (prior-weighted)
    /// set. Bias-corrected: the plain mean of the scans so far until there are 1/alpha
    /// of them, so the first scan (often a perfect fit at a known start) does not set
    /// the long-term level for hundreds of updates.
    fn update_fit_averages(&mut self) {
        let w_avg: f64 = self.particles.iter().zip(&self.scan_fit).map(|(p, f)| p.weight * f).sum();
        self.scans_since_init += 1;
        let n = self.scans_since_init as f64;
        let slow = self.config.alpha_slow.max(1.0 / n);
        let fast = self.config.alpha_fast.max(1.0 / n);
        self.w_slow += slow * (w_avg - self.w_slow);
        self.w_fast += fast * (w_avg - self.w_fast);
        self.last_w_avg = w_avg;
        self.scan_seen = true;
    }

    /// Posterior weights from `log_w`, taken against the best so nothing underflows;
    /// uniform again (and counted) if every weight vanished.
    fn normalise_weights(&mut self) {
        let max_lw = self.log_w.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let mut sum = 0.0;
        for (p, lw) in self.particles.iter_mut().zip(&self.log_w) {
            p.weight *= (lw - max_lw).exp();
            sum += p.weight;
        }
        let n = self.particles.len() as f64;
        if sum > 0.0 && sum.is_finite() {
            for p in &mut self.particles {
                p.weight /= sum;
            }
        } else {
            self.counters.weight_collapses += 1;
            for p in &mut self.particles {
                p.weight = 1.0 / n;
            }
        }
    }

    /// The share of the next set to draw at random: below the dead band
    /// `1 - (w_fast / w_slow) / recovery_ratio`, then `recovery_hold_fraction` for
    /// `recovery_hold_updates` more updates.
    fn recovery_fraction(&mut self) -> f64 {
        let below = if self.scan_seen && self.w_slow > 0.0 {
            let ratio = self.w_fast / self.w_slow;
            (1.0 - ratio / self.config.recovery_ratio.max(1e-9)).clamp(0.0, self.config.max_inject_fraction)
        } else {
            0.0
        };
        if below > 0.0 {
            self.hold_left = self.config.recovery_hold_updates;
            below
        } else if self.hold_left > 0 {
            self.hold_left -= 1;
            self.config.recovery_hold_fraction.min(self.config.max_inject_fraction)
        } else {
            0.0
        }
    }

    fn apply_motion(&mut self) {
        self.crossed.clear();
        if self.pending_increments == 0 {
            return;
        }
        let (f, l, y) = (self.pending.x_m, self.pending.y_m, self.pending.heading_rad);
        let motion = RotTransRot::from_motion(f, l, y);
        let imu = self.pending_imu_yaw;
        let dt = self.pending_dt_s;
        let draw = MotionDraw::new(&motion, imu, dt, &self.config.motion);
        let walls = self.config.wall_crossing_log_p.is_some();
        for p in &mut self.particles {
            let from = [p.pose.x_m, p.pose.y_m];
            p.pose = draw.sample(&p.pose, &mut self.rng);
            if walls {
                let crossed = self.floors[p.floor as usize].crosses_wall(from, [p.pose.x_m, p.pose.y_m]);
                self.counters.wall_crossings += crossed as u64;
                self.crossed.push(crossed);
            }
        }
        self.pending = Pose2::default();
        self.pending_imu_yaw = Some(0.0);
        self.pending_dt_s = 0.0;
        self.pending_increments = 0;
    }

    /// Adds the scan's tempered log-likelihood to every particle; fills `scan_fit`.
    /// Returns false when the scan had no usable beam.
    fn weigh_scan(&mut self, scan: &Scan) -> bool {
        let unusable = scan.endpoints_into(self.config.max_beams, &mut self.endpoints);
        self.counters.beams_unusable += unusable as u64;
        // the fit is over every usable beam: one the map does not explain fits nothing
        let nb = self.endpoints.len();
        self.leave_out_unmapped(scan);
        if self.endpoints.is_empty() {
            return false;
        }
        let k = self.config.scan_weight_exponent;
        self.scan_fit.clear();
        self.scan_fit.resize(self.particles.len(), 0.0);
        self.endpoints32.clear();
        self.endpoints32.extend(self.endpoints.iter().map(|&[x, y]| [x as f32, y as f32]));
        for (fi, floor) in self.floors.iter().enumerate() {
            floor_batch(&self.particles, &self.trig, fi, &floor.field, &mut self.batch_index, &mut self.batch_pose);
            let m = self.batch_index.len();
            if m == 0 {
                continue;
            }
            self.batch_sums.clear();
            self.batch_sums.resize(m, [0.0; 2]);
            floor.field.add_scan_log_p(&mut self.batch_pose, &self.endpoints32, &mut self.batch_sums);
            for (&i, &[ll, fit]) in self.batch_index.iter().zip(&self.batch_sums) {
                self.log_w[i] += k * ll as f64;
                self.scan_fit[i] = fit as f64 / nb as f64;
            }
        }
        true
    }

    /// Subtracts the free-space penalty (tempered like the scan) for each of the scan's
    /// free rays a particle puts across a wall ([`FilterConfig::free_space`]).
    fn weigh_free_space(&mut self, scan: &Scan) {
        let Some(cfg) = self.config.free_space else { return };
        if !(cfg.penalty > 0.0 && cfg.penalty.is_finite()) {
            return;
        }
        scan.free_points_into(&cfg, &mut self.free_points, &mut self.free_ray_ends);
        if self.free_ray_ends.is_empty() {
            return;
        }
        self.free_points32.clear();
        self.free_points32.extend(self.free_points.iter().map(|&[x, y]| [x as f32, y as f32]));
        let cost = self.config.scan_weight_exponent * cfg.penalty;
        for (fi, floor) in self.floors.iter().enumerate() {
            floor_batch(&self.particles, &self.trig, fi, &floor.field, &mut self.batch_index, &mut self.batch_pose);
            if self.batch_index.is_empty() {
                continue;
            }
            self.free_crossed.clear();
            self.free_crossed.resize(self.batch_index.len(), 0.0);
            floor.field.add_free_crossings(
                &mut self.batch_pose,
                &self.free_points32,
                &self.free_ray_ends,
                cfg.wall_m,
                &mut self.free_nearest,
                &mut self.free_crossed,
            );
            for (&i, &n) in self.batch_index.iter().zip(&self.free_crossed) {
                self.log_w[i] -= cost * f64::from(n);
            }
        }
    }

    /// Leaves out of `endpoints` the ones the map does not explain from the prior's
    /// mean ([`FilterConfig::unmapped_gate_m`]).
    fn leave_out_unmapped(&mut self, scan: &Scan) {
        let gate = self.config.unmapped_gate_m;
        let e = &self.estimate;
        if gate <= 0.0 || e.status != Status::Tracking {
            return;
        }
        let Some(fi) = self.floors.iter().position(|f| f.level == e.level) else { return };
        let pose = weighted_mean(self.particles.iter().zip(&self.trig).filter(|(p, _)| p.floor as usize == fi));
        let (s, c) = pose.heading_rad.sin_cos();
        let to_map = |[bx, by]: [f64; 2]| [pose.x_m + c * bx - s * by, pose.y_m + s * bx + c * by];
        let field = &self.floors[fi].field;
        let origin = to_map([scan.sensor_forward_m, scan.sensor_left_m]);
        let unmapped: Vec<bool> = self
            .endpoints
            .iter()
            .map(|&b| {
                let m = to_map(b);
                field.distance_m(m[0], m[1]) > gate && field.segment_free(origin, m)
            })
            .collect();
        let dropped = unmapped.iter().filter(|&&u| u).count();
        if dropped == 0 || 2 * dropped > self.endpoints.len() {
            return;
        }
        let mut flags = unmapped.iter();
        self.endpoints.retain(|_| !flags.next().copied().unwrap_or(false));
        self.counters.beams_unmapped += dropped as u64;
    }

    /// Whether a landmark can be weighed: finite offsets, and a door number some floor has.
    fn landmark_usable(&self, lm: &Landmark) -> bool {
        let (fwd, left) = lm.offset_m();
        fwd.is_finite()
            && left.is_finite()
            && match lm {
                Landmark::Door { number, .. } => self.floors.iter().any(|f| f.door(number).is_some()),
                Landmark::Corner { .. } => true,
                Landmark::Place { level, x_m, y_m } => {
                    x_m.is_finite() && y_m.is_finite() && self.floor_index(*level).is_some()
                }
            }
    }

    /// While the place is a search's, keeps a door number or named place told (`at`: its
    /// point on each floor that has it, `offset` from the user, to be within `near`) for
    /// [`ParticleFilter::confirm_searched`].
    fn remember_told(&mut self, at: &[Option<[f64; 2]>], offset: [f64; 2], near: f64) {
        if self.estimate.searched {
            let told =
                |(floor, p): (usize, &Option<[f64; 2]>)| Some(Told { floor, at: (*p)?, offset, near, walked_m: 0.0 });
            self.told.extend(at.iter().enumerate().filter_map(told));
        }
    }

    /// Adds a usable landmark's log-likelihood ([`ParticleFilter::landmark_usable`]).
    fn weigh_landmark(&mut self, lm: &Landmark) {
        let (fwd, left) = lm.offset_m();
        let cfg = self.config.landmarks;
        match lm {
            Landmark::Door { number, .. } => {
                self.door_read = true;
                // the door on each floor, once per floor, not once per particle
                let doors: Vec<Option<[f64; 2]>> = self.floors.iter().map(|f| f.door(number)).collect();
                self.remember_told(&doors, [fwd, left], CONFIRM_DOOR_M);
                self.weigh_told_place(&doors, [fwd, left], cfg.sigma_m, cfg.door_reset_below_support);
            }
            Landmark::Place { level, x_m, y_m } => {
                // a few metres: the scans still have to fix the place along a corridor
                // before `Tracking` (a door's number does that itself). The user's word
                // is that they may be elsewhere than a told start or a gateway's stop
                // put them: that no longer vouches for the place, nor is the place
                // followed from it
                self.start_vouches = false;
                self.from_known = false;
                let at: Vec<Option<[f64; 2]>> =
                    self.floors.iter().map(|f| (f.level == *level).then_some([*x_m, *y_m])).collect();
                self.remember_told(&at, [0.0, 0.0], cfg.place_sigma_m);
                // always some particles about the place: a belief a few metres off may
                // agree with it, and then none would be where the user is
                self.weigh_told_place(&at, [0.0, 0.0], cfg.place_sigma_m, f64::INFINITY);
            }
            Landmark::Corner { .. } => {
                for (p, lw) in self.particles.iter().zip(self.log_w.iter_mut()) {
                    let seen = p.pose.compose(fwd, left, 0.0);
                    let d = self.floors[p.floor as usize].corner_field().distance_m(seen.x_m, seen.y_m);
                    *lw += mixture_log_p(d, cfg.sigma_m, cfg.corner_false_probability);
                }
            }
        }
    }

    /// Weighs a place the user was told (a door's number, a named place): `at` is where
    /// it is on each floor (none where the floor has no such place), `offset` where it
    /// is from the user (forward, left), `sigma` how near. When the weight of the
    /// particles that agree is below `reset_below`, resets are queued where the reading
    /// puts the user (see [`LandmarkConfig::door_reset_fraction`]).
    fn weigh_told_place(&mut self, at: &[Option<[f64; 2]>], [fwd, left]: [f64; 2], sigma: f64, reset_below: f64) {
        let misread = self.config.landmarks.door_misread_probability;
        let floor_miss = misread.max(1e-6).ln();
        let mut support = 0.0;
        for (p, lw) in self.particles.iter().zip(self.log_w.iter_mut()) {
            *lw += match at[p.floor as usize] {
                Some([dx, dy]) => {
                    let seen = p.pose.compose(fwd, left, 0.0);
                    let d = (seen.x_m - dx).hypot(seen.y_m - dy);
                    support += p.weight * (-d * d / (2.0 * sigma * sigma)).exp();
                    mixture_log_p(d, sigma, misread)
                }
                None => floor_miss,
            };
        }
        if support < reset_below {
            for (fi, xy) in at.iter().enumerate() {
                if let Some(xy) = xy {
                    self.door_resets.push((fi as u16, *xy, [fwd, left], sigma));
                }
            }
        }
    }

    fn weigh_wall(&mut self, wall: &WallAngle) {
        if !wall.angle_rad.is_finite() {
            self.counters.wall_angles_rejected += 1;
            return;
        }
        let cfg = self.config.landmarks;
        for (p, lw) in self.particles.iter().zip(self.log_w.iter_mut()) {
            let dirs = &self.floors[p.floor as usize].wall_directions_rad;
            let r = wall_residual(p.pose.heading_rad + wall.angle_rad, dirs);
            *lw += mixture_log_p(r, cfg.wall_sigma_rad, cfg.wall_outlier_probability);
        }
    }

    /// How many particles the current weights call for: the KLD bound (Fox 2003) on the
    /// number of histogram bins that would receive a particle (a bin's weight at least
    /// 1 / max_particles), clamped to [min, max]. Fox draws samples until the bound is
    /// met; counting the bins of the weighted set before drawing is our simplification
    /// (one pass, deterministic, no per-draw bookkeeping).
    fn kld_count(&mut self) -> usize {
        let (bm, br) = (self.config.kld_bin_m, self.config.kld_bin_rad);
        self.bins.reset(self.particles.len());
        for p in &self.particles {
            let ix = floor_i64(p.pose.x_m / bm) & 0xFFFFF;
            let iy = floor_i64(p.pose.y_m / bm) & 0xFFFFF;
            let ih = floor_i64(p.pose.heading_rad / br) & 0xFF;
            let key = ((p.floor as u64) << 48) ^ ((ix as u64) << 28) ^ ((iy as u64) << 8) ^ ih as u64;
            self.bins.add(key, p.weight);
        }
        let threshold = 1.0 / self.config.max_particles as f64;
        let k = self.bins.iter().filter(|&(_, w)| w >= threshold).count();
        let n = if k <= 1 {
            self.config.min_particles
        } else {
            let km1 = (k - 1) as f64;
            let b = 2.0 / (9.0 * km1);
            let x = 1.0 - b + b.sqrt() * self.config.kld_z;
            (km1 / (2.0 * self.config.kld_error) * x * x * x).ceil() as usize
        };
        n.clamp(self.config.min_particles, self.config.max_particles)
    }

    /// Low-variance (systematic) resampling to the KLD count, a fraction of which is
    /// drawn uniformly in free space and a fraction where unsupported door readings put
    /// the user. Returns how many of each.
    fn resample(&mut self, inject_fraction: f64, door_fraction: f64) -> (usize, usize) {
        let n_new = self.kld_count();
        let n_inject = ((inject_fraction * n_new as f64).round() as usize).min(n_new);
        let n_door = ((door_fraction * n_new as f64).round() as usize).min(n_new - n_inject);
        let n_draw = n_new - n_inject - n_door;
        let w = 1.0 / n_new as f64;
        self.next.clear();
        if n_draw > 0 {
            let step = 1.0 / n_draw as f64;
            let r = self.rng.uniform() * step;
            let mut c = self.particles[0].weight;
            let mut i = 0;
            let last = self.particles.len() - 1;
            for m in 0..n_draw {
                let u = r + m as f64 * step;
                while u > c && i < last {
                    i += 1;
                    c += self.particles[i].weight;
                }
                self.next.push(Particle { weight: w, ..self.particles[i] });
            }
        }
        for _ in 0..n_inject {
            let p = self.recovery_particle(w);
            self.next.push(p);
        }
        for _ in 0..n_door {
            let (fi, [dx, dy], [fwd, left], sigma) = self.door_resets[self.rng.index(self.door_resets.len())];
            // the door fixes where, not which way: the heading comes from the belief
            // (IMU, wall angles), uniform when that is uniform
            let h = self.particles[self.rng.index(self.particles.len())].pose.heading_rad + self.rng.normal(0.1);
            let (s, c) = fast_sin_cos(h);
            let pose = Pose2::new(
                dx - (c * fwd - s * left) + self.rng.normal(sigma),
                dy - (s * fwd + c * left) + self.rng.normal(sigma),
                h,
            );
            self.next.push(Particle { pose, level: self.floors[fi as usize].level, weight: w, floor: fi });
        }
        std::mem::swap(&mut self.particles, &mut self.next);
        self.counters.resamples += 1;
        self.counters.particles_injected += n_inject as u64;
        self.counters.particles_at_doors += n_door as u64;
        self.estimate.particles = self.particles.len();
        (n_inject, n_door)
    }

    /// Mean, covariance and status from the weighted particles: of the main cluster,
    /// not of the whole set (a few particles injected across the map, or a second
    /// hypothesis in a similar corridor, must not drag the mean into a wall). AMCL
    /// reports its heaviest cluster the same way.
    fn compute_estimate(&mut self) {
        let (fi, centre) = self.main_cluster();
        let total: f64 = self.particles.iter().map(|p| p.weight).sum::<f64>().max(1e-300);
        let mut cov = [[0.0; 3]; 3];
        let mut wsum = 0.0;
        for p in self.particles.iter().filter(|p| self.in_cluster(fi, &centre, p)) {
            let d =
                [p.pose.x_m - centre.x_m, p.pose.y_m - centre.y_m, wrap_angle(p.pose.heading_rad - centre.heading_rad)];
            for i in 0..3 {
                for j in 0..3 {
                    cov[i][j] += p.weight * d[i] * d[j];
                }
            }
            wsum += p.weight;
        }
        for row in &mut cov {
            for v in row {
                *v /= wsum.max(1e-300);
            }
        }
        self.estimate.pose = centre;
        self.estimate.level = self.floors[fi as usize].level;
        self.estimate.covariance = cov;
        self.estimate.cluster_weight = wsum / total;
        self.estimate.particles = self.particles.len();
        self.scan_constraint = self.scan_beams.map(|_| {
            let field = &self.floors[fi as usize].field;
            scan_constraint(field, &centre, &self.endpoints, self.config.constraint_wall_m)
        });
        self.update_status();
    }

    /// The main cluster's floor and weighted mean: on the most likely floor, the
    /// particles within `cluster_radius_m` and `cluster_heading_rad` of the weighted
    /// mean of the heaviest 3 x 3 m block of 1 m bins, re-centred twice.
    fn main_cluster(&mut self) -> (u16, Pose2) {
        let mut floor_w = vec![0.0; self.floors.len()];
        for p in &self.particles {
            floor_w[p.floor as usize] += p.weight;
        }
        let fi = (0..floor_w.len()).max_by(|&a, &b| floor_w[a].total_cmp(&floor_w[b])).unwrap_or(0) as u16;
        let (bx, by) = self.heaviest_block(fi);
        let in_block = |p: &Particle| {
            let dx = (floor_i64(p.pose.x_m) as u64).wrapping_sub(bx) & 0xFFFF_FFFF;
            let dy = (floor_i64(p.pose.y_m) as u64).wrapping_sub(by) & 0xFFFF_FFFF;
            p.floor == fi && (dx <= 1 || dx == 0xFFFF_FFFF) && (dy <= 1 || dy == 0xFFFF_FFFF)
        };
        let mut centre = weighted_mean(self.particles.iter().zip(&self.trig).filter(|(p, _)| in_block(p)));
        for _ in 0..2 {
            let c = centre;
            centre = weighted_mean(self.particles.iter().zip(&self.trig).filter(|(p, _)| self.in_cluster(fi, &c, p)));
        }
        (fi, centre)
    }

    /// The 1 m bin (x, y, each as a wrapped u32) on floor `fi` whose 3 x 3 neighbourhood
    /// holds the most weight (a cluster straddling a bin corner must not lose to a
    /// compact wrong one).
    fn heaviest_block(&mut self, fi: u16) -> (u64, u64) {
        const MASK: u64 = 0xFFFF_FFFF;
        self.bins.reset(self.particles.len());
        for p in self.particles.iter().filter(|p| p.floor == fi) {
            let ix = floor_i64(p.pose.x_m) as u64 & MASK;
            let iy = floor_i64(p.pose.y_m) as u64 & MASK;
            self.bins.add((ix << 32) | iy, p.weight);
        }
        // the heaviest neighbourhood; of equals, the smallest key (as when sorted)
        let (mut best_key, mut best_w) = (0u64, -1.0);
        for (key, _) in self.bins.iter() {
            let (ix, iy) = (key >> 32, key & MASK);
            let mut w = 0.0;
            for dx in [MASK, 0, 1] {
                for dy in [MASK, 0, 1] {
                    w += self.bins.get((((ix + dx) & MASK) << 32) | ((iy + dy) & MASK));
                }
            }
            if w > best_w || (w == best_w && key < best_key) {
                (best_key, best_w) = (key, w);
            }
        }
        (best_key >> 32, best_key & MASK)
    }

    /// Whether `p` belongs to the cluster about `centre` on floor `fi`.
    fn in_cluster(&self, fi: u16, centre: &Pose2, p: &Particle) -> bool {
        let r = self.config.cluster_radius_m;
        p.floor == fi
            && (p.pose.x_m - centre.x_m).powi(2) + (p.pose.y_m - centre.y_m).powi(2) <= r * r
            && wrap_angle(p.pose.heading_rad - centre.heading_rad).abs() <= self.config.cluster_heading_rad
    }

    /// `Lost`, `Uncertain` or `Tracking` from the estimate and the fit (thresholds in
    /// [`FilterConfig`]).
    fn update_status(&mut self) {
        let (std_m, std_h) = (self.estimate.position_std_m(), self.estimate.heading_std_rad());
        let c = &self.config;
        let (fit, share) = (self.estimate.fit, self.estimate.cluster_weight);
        // the last scan's own fit reacts at once; w_fast only after a few scans
        let now = self.last_w_avg;
        let collapsed = self.scan_seen && (now < c.lost_max_fit || self.w_fast < c.recovery_ratio * self.w_slow);
        let tracking_now = share >= c.tracking_min_cluster_weight
            && std_m <= c.tracking_max_std_m
            && std_h <= c.tracking_max_heading_std_rad
            && (!self.scan_seen || fit.min(now) >= c.tracking_min_fit);
        // a heading the compass contradicts is a turned copy of the place, not the place
        let compass_agrees = self.compass_agrees(self.estimate.pose.heading_rad);
        if tracking_now && !compass_agrees {
            self.counters.compass_disagreements += 1;
        }
        let tracking_now = tracking_now && compass_agrees;
        let few_beams = self.scan_beams.is_some_and(|n| n < c.tracking_min_beams);
        self.tracking_streak = if tracking_now && !collapsed {
            if few_beams {
                self.tracking_streak
            } else {
                self.streak_constraint +=
                    if self.door_read { c.tracking_min_constraint } else { self.scan_constraint.unwrap_or(0.0) };
                self.tracking_streak.saturating_add(1)
            }
        } else {
            self.streak_constraint = 0.0;
            0
        };
        let constrained = self.start_vouches || self.streak_constraint >= c.tracking_min_constraint;
        let was_tracking = self.estimate.status == Status::Tracking;
        self.estimate.status = if share < c.lost_max_cluster_weight || collapsed {
            Status::Lost
        } else if self.tracking_streak >= c.tracking_min_updates && constrained {
            Status::Tracking
        } else {
            Status::Uncertain
        };
        if was_tracking && self.estimate.status != Status::Tracking {
            self.start_vouches = false;
        }
    }

    /// Whether the place is still followed from a known one ([`Estimate::followed`]),
    /// `predicted` being the last estimate moved by the motion alone (`None`: a place
    /// just told).
    fn follow(&mut self, predicted: Option<&Estimate>) {
        let jumped = self.jumped(predicted);
        let c = &self.config;
        let e = &self.estimate;
        let compass_agrees = self.compass_agrees(e.pose.heading_rad);
        // `Tracking`'s conditions on this correction, the heading's looser, without the
        // streak of corrections on enough beams that would confirm the place
        let holds = e.cluster_weight >= c.tracking_min_cluster_weight
            && e.position_std_m() <= c.tracking_max_std_m
            && e.heading_std_rad() <= FOLLOW_MAX_HEADING_STD_DEG.to_radians()
            && (!self.scan_seen || e.fit.min(self.last_w_avg) >= c.tracking_min_fit)
            && compass_agrees;
        self.from_known = e.status == Status::Tracking || (self.from_known && holds && !jumped);
        self.estimate.followed = self.from_known && self.estimate.status != Status::Lost;
        // a search's place that jumped is not the place the user's word confirmed
        if jumped && self.from_search {
            self.estimate.searched = true;
        }
    }

    /// Whether `heading` is within the compass's gate of its last reading
    /// ([`LandmarkConfig::compass_gate_rad`]); true without one.
    fn compass_agrees(&self, heading: f64) -> bool {
        let gate = self.config.landmarks.compass_gate_rad;
        self.compass_now.is_none_or(|h| wrap_angle(heading - h).abs() <= gate)
    }

    /// Whether the estimate moved further than [`FOLLOW_MAX_JUMP_M`] from `predicted`,
    /// the last estimate moved by the motion alone, or to another floor.
    fn jumped(&self, predicted: Option<&Estimate>) -> bool {
        let e = &self.estimate;
        predicted.is_some_and(|p| {
            p.level != e.level || (p.pose.x_m - e.pose.x_m).hypot(p.pose.y_m - e.pose.y_m) > FOLLOW_MAX_JUMP_M
        })
    }

    /// The current estimate: the last correction's, moved by the motion since.
    pub fn estimate(&self) -> Estimate {
        let mut e = self.estimate.clone();
        e.pose = e.pose.compose(self.pending.x_m, self.pending.y_m, self.pending.heading_rad);
        e
    }

    /// The particles (for monitors), as of the last correction.
    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }

    /// The floors the filter knows.
    pub fn floors(&self) -> &[FloorModel] {
        &self.floors
    }

    /// Counts of refused inputs and of the filter's work.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// The configuration in use.
    pub fn config(&self) -> &FilterConfig {
        &self.config
    }

    /// Short- and long-term scan-fit averages (augmented MCL's `w_fast`, `w_slow`) and
    /// the last correction's fit.
    pub fn fit_averages(&self) -> (f64, f64, f64) {
        (self.w_fast, self.w_slow, self.last_w_avg)
    }
}

/// A door's number confirms a searched place ([`Estimate::searched`]) when the
/// estimate puts the door within this of where the reading says, metres (at the door,
/// not at a mirror image of it metres away, nor on a floor alike); a named place,
/// within its own `place_sigma_m`.
pub const CONFIRM_DOOR_M: f64 = 1.0;

/// A door number or named place confirms a searched place until the user has walked
/// this far since saying it, metres (the belief may need a few metres of scans to
/// gather where the word put it), with its reach growing by [`CONFIRM_PER_WALKED`].
pub const CONFIRM_WITHIN_M: f64 = 10.0;

/// How much a told place's reach grows per metre walked since (the odometry that
/// carries it errs by a few percent).
pub const CONFIRM_PER_WALKED: f64 = 0.05;

/// A correction that moves the place further than this from where the motion alone
/// took it ends [`Estimate::followed`], metres: a person does not jump, and the scans
/// that moved it so far may have found a look-alike (the anchor's reach starts at 1 m).
pub const FOLLOW_MAX_JUMP_M: f64 = 1.0;

/// [`Estimate::followed`] needs the heading's standard deviation below this, degrees:
/// twice `Tracking`'s, so that a told start (10 degrees) is followed; a turn's words
/// span 40 degrees or more ("slightly": 20-60, `guidance::GuidanceProfile`).
pub const FOLLOW_MAX_HEADING_STD_DEG: f64 = 20.0;

/// Draws per particle of a start spread before one in a wall is kept.
const START_DRAWS: usize = 20;

/// The particles on floor `fi` (`trig`: each one's heading's sin and cos): their
/// indices into `index`, their poses in the floor field's grid units into `poses`.
fn floor_batch(
    particles: &[Particle],
    trig: &[(f64, f64)],
    fi: usize,
    field: &LikelihoodField,
    index: &mut Vec<usize>,
    poses: &mut GridPoses,
) {
    index.clear();
    poses.clear();
    for (i, (p, &(s, c))) in particles.iter().zip(trig).enumerate() {
        if p.floor as usize == fi {
            index.push(i);
            poses.push(field.grid_pose(p.pose.x_m, p.pose.y_m, c, s));
        }
    }
}

/// Weighted mean position and circular-mean heading (the origin for an empty set).
/// Takes each particle with the (sin, cos) of its heading.
fn weighted_mean<'a>(particles: impl Iterator<Item = (&'a Particle, &'a (f64, f64))>) -> Pose2 {
    let (mut w, mut x, mut y, mut s, mut c) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (p, &(sin, cos)) in particles {
        w += p.weight;
        x += p.weight * p.pose.x_m;
        y += p.weight * p.pose.y_m;
        s += p.weight * sin;
        c += p.weight * cos;
    }
    if w <= 0.0 {
        return Pose2::default();
    }
    Pose2::new(x / w, y / w, s.atan2(c))
}

/// Step of the distance field's differences in [`scan_constraint`], metres.
const CONSTRAINT_STEP_M: f64 = 0.05;

/// How many beams' worth `endpoints` (robot frame), laid from `pose`, fix the place in
/// their least fixed direction: the smallest eigenvalue of the sum of `n n^T` over the
/// beams within `wall_m` of a wall of `field`, `n` the unit direction away from that
/// wall (the distance field's gradient). Beams on two parallel walls give 0: nothing
/// says where along them the scan lies.
pub fn scan_constraint(field: &LikelihoodField, pose: &Pose2, endpoints: &[[f64; 2]], wall_m: f64) -> f64 {
    // a cell either side (maps at 5 cm)
    let h = CONSTRAINT_STEP_M;
    let (mut a, mut b, mut d) = (0.0f64, 0.0f64, 0.0f64);
    for &[ex, ey] in endpoints {
        let Pose2 { x_m: x, y_m: y, .. } = pose.compose(ex, ey, 0.0);
        if field.distance_m(x, y) > wall_m {
            continue;
        }
        let gx = field.distance_m(x + h, y) - field.distance_m(x - h, y);
        let gy = field.distance_m(x, y + h) - field.distance_m(x, y - h);
        let len = (gx * gx + gy * gy).sqrt();
        if len < 1e-9 {
            continue;
        }
        let (nx, ny) = (gx / len, gy / len);
        a += nx * nx;
        b += nx * ny;
        d += ny * ny;
    }
    symmetric_2x2_eigenvalues(a, b, d).0.max(0.0)
}

/// The (smaller, larger) eigenvalues of the symmetric matrix `[[a, b], [b, d]]`.
fn symmetric_2x2_eigenvalues(a: f64, b: f64, d: f64) -> (f64, f64) {
    let mean = (a + d) / 2.0;
    let half_gap = ((a - d) * (a - d) / 4.0 + b * b).sqrt();
    (mean - half_gap, mean + half_gap)
}

/// `v.floor() as i64` without the libm call (the bins of every particle, every update).
#[inline]
fn floor_i64(v: f64) -> i64 {
    let t = v as i64;
    t - (v < t as f64) as i64
}

#[cfg(test)]
mod tests {
    use super::*;
    use map::{Cell, OccupancyGrid, Origin, SemanticLayer};

    /// A filter on an empty 60 x 20 m hall, started at (5, 10) facing +x.
    fn hall(anchor: Option<RecoveryAnchor>) -> ParticleFilter {
        let g = OccupancyGrid::filled(1200, 400, 0.05, Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, Cell::Free)
            .expect("grid");
        let floor = FloorModel::new(0, &g, &SemanticLayer::default(), &Default::default()).expect("floor");
        let config = FilterConfig { recovery_anchor: anchor, ..FilterConfig::default() };
        let mut pf = ParticleFilter::new(vec![floor], config, 3).expect("filter");
        pf.init_pose(0, Pose2::new(5.0, 10.0, 0.0), 0.1, 0.03).expect("start");
        pf
    }

    fn walk(pf: &mut ParticleFilter, metres: f64) {
        let step = OdometryIncrement { forward_m: 0.5, left_m: 0.0, yaw_rad: 0.0, dt_s: 0.5 };
        for _ in 0..(metres / 0.5).round() as usize {
            pf.predict(&step, Some(0.0)).expect("plausible");
        }
    }

    #[test]
    fn a_door_number_does_not_confirm_a_searched_place_the_compass_says_is_turned_about() {
        let mut pf = hall(Some(RecoveryAnchor::default()));
        // a search's place at (5, 10) facing +x, the number of a door 1 m ahead told
        pf.estimate.searched = true;
        pf.from_search = true;
        pf.anchor = None;
        let told = Told { floor: 0, at: [6.0, 10.0], offset: [1.0, 0.0], near: CONFIRM_DOOR_M, walked_m: 0.0 };
        assert!(pf.estimate.cluster_weight >= 0.8, "{:?}", pf.estimate);
        // the compass says the user faces -x: the place turned about, not confirmed
        pf.told = vec![told];
        pf.compass_now = Some(std::f64::consts::PI);
        pf.confirm_searched();
        assert!(pf.estimate.searched && pf.anchor.is_none() && pf.counters.searches_confirmed == 0);
        // within the compass's gate (60 degrees), or with no compass: confirmed
        for compass in [Some(50f64.to_radians()), None] {
            pf.estimate.searched = true;
            pf.anchor = None;
            pf.told = vec![told];
            pf.compass_now = compass;
            pf.confirm_searched();
            assert!(!pf.estimate.searched && pf.anchor.is_some(), "compass {compass:?}");
        }
        assert_eq!(pf.counters.searches_confirmed, 2);
    }

    #[test]
    fn a_place_that_moves_further_than_the_motion_took_it_is_no_longer_followed() {
        let mut pf = hall(None);
        assert!(pf.estimate.followed && pf.estimate.status == Status::Uncertain, "{:?}", pf.estimate);
        let mut predicted = pf.estimate.clone();
        // a correction that kept the place within a stride of the motion's
        predicted.pose.x_m -= 0.5;
        pf.follow(Some(&predicted));
        assert!(pf.estimate.followed);
        // one that moved it 1.5 m: a look-alike taken over, whatever the spread says
        predicted.pose.x_m -= 1.0;
        pf.follow(Some(&predicted));
        assert!(!pf.estimate.followed);
        // and once ended, only `Tracking` or a told place follows again
        pf.follow(Some(&pf.estimate.clone()));
        assert!(!pf.estimate.followed);
    }

    #[test]
    fn the_recovery_draws_where_the_odometry_took_the_user_until_the_anchor_is_forgotten() {
        let mut pf = hall(Some(RecoveryAnchor::default()));
        walk(&mut pf, 10.0);
        // 10 m walked from the told start: within 1 + 0.1 * 10 = 2 m of (15, 10), 45°
        for _ in 0..2000 {
            let p = pf.recovery_particle(1.0);
            assert!(p.pose.distance_m(&Pose2::new(15.0, 10.0, 0.0)) <= 2.0 + 1e-9, "{:?}", p.pose);
            assert!(wrap_angle(p.pose.heading_rad).abs() <= 45f64.to_radians() + 1e-9, "{:?}", p.pose);
        }
        // 45 m more without `Tracking` (past `forget_m`): anywhere in the hall
        walk(&mut pf, 45.0);
        let far = (0..2000).filter(|_| pf.recovery_particle(1.0).pose.distance_m(&Pose2::new(60.0, 10.0, 0.0)) > 10.0);
        assert!(far.count() > 1000);
    }

    #[test]
    fn without_an_anchor_config_the_recovery_draws_anywhere_as_amcl_does() {
        let mut pf = hall(None);
        walk(&mut pf, 10.0);
        let far = (0..2000).filter(|_| pf.recovery_particle(1.0).pose.distance_m(&Pose2::new(15.0, 10.0, 0.0)) > 5.0);
        assert!(far.count() > 1500);
    }

    /// A hall with a wall across its upper half (x 5.3-5.45 m, y 10-20 m), the set
    /// started at (5, 10) facing +x with headings spread ±30°, walked 0.6 m on.
    fn through_the_end_of_a_wall(wall_crossing_log_p: Option<f64>) -> ParticleFilter {
        let mut g = OccupancyGrid::filled(1200, 400, 0.05, Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, Cell::Free)
            .expect("grid");
        for col in 106..109 {
            for row in 200..400 {
                g.set(col, row, Cell::Occupied);
            }
        }
        let floor = FloorModel::new(0, &g, &SemanticLayer::default(), &Default::default()).expect("floor");
        let config = FilterConfig { wall_crossing_log_p, ..FilterConfig::default() };
        let mut pf = ParticleFilter::new(vec![floor], config, 3).expect("filter");
        pf.init_pose(0, Pose2::new(5.0, 10.0, 0.0), 0.0, 30f64.to_radians()).expect("start");
        let step = OdometryIncrement { forward_m: 0.3, left_m: 0.0, yaw_rad: 0.0, dt_s: 0.3 };
        for _ in 0..2 {
            pf.predict(&step, Some(0.0)).expect("plausible");
        }
        assert!(pf.correct(&Observations::default()).updated);
        pf
    }

    /// The weight on the particles that went beyond the wall in the upper half
    /// (through it), and on those in the lower half (past its end).
    fn upper_and_lower(pf: &ParticleFilter) -> (f64, f64) {
        let upper = pf.particles.iter().filter(|p| p.pose.x_m > 5.45 && p.pose.y_m > 10.05).map(|p| p.weight).sum();
        let lower = pf.particles.iter().filter(|p| p.pose.y_m < 9.95).map(|p| p.weight).sum();
        (upper, lower)
    }

    #[test]
    fn a_particle_that_walked_through_a_wall_keeps_no_weight() {
        let pf = through_the_end_of_a_wall(Some(WALL_CROSSING_LOG_P));
        let (upper, lower) = upper_and_lower(&pf);
        // beyond the wall in its half only through it; headed right, past its end
        assert!(upper < 1e-6, "{upper} of the weight went through the wall");
        assert!(lower > 0.4, "{lower}");
        let crossed = pf.counters.wall_crossings as usize;
        let n = pf.particles.len();
        assert!(crossed > n / 5 && crossed < n / 2, "{crossed} of {n} crossed");
        // AMCL's, without the check: the motion alone weighs nothing
        let (upper, lower) = upper_and_lower(&through_the_end_of_a_wall(None));
        assert!(upper > 0.2 && lower > 0.4, "{upper} {lower}");
    }

    #[test]
    fn a_whole_set_through_a_wall_loses_nothing_against_itself() {
        let mut pf = hall(None);
        pf.config.wall_crossing_log_p = Some(WALL_CROSSING_LOG_P);
        let floor = &pf.floors[0];
        assert!(!floor.crosses_wall([5.0, 10.0], [5.6, 10.0]), "the hall has no wall");
        // every particle in a wall cell (a map whose walls are off by a stride): as if
        // there were none
        let mut g = OccupancyGrid::filled(1200, 400, 0.05, Origin { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0 }, Cell::Occupied)
            .expect("grid");
        g.set(0, 0, Cell::Free);
        let walled = FloorModel::new(0, &g, &SemanticLayer::default(), &Default::default()).expect("floor");
        assert!(walled.crosses_wall([5.0, 10.0], [5.0, 10.0]), "a point in a wall");
        pf.floors = vec![walled];
        let before: Vec<f64> = pf.particles.iter().map(|p| p.weight).collect();
        walk(&mut pf, 0.5);
        assert!(pf.correct(&Observations::default()).updated);
        assert_eq!(pf.counters.weight_collapses, 0);
        for (p, w) in pf.particles.iter().zip(&before) {
            assert!((p.weight - w).abs() < 1e-12, "{} against {w}", p.weight);
        }
    }
}
