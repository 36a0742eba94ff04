//! Stage 2: the ground plane, by RANSAC constrained to a cone around an expected up
//! axis, refined by least squares, and guarded against false ground.
//!
//! Taylor 2017, sec. 2.2: PCL `SACMODEL_PERPENDICULAR_PLANE`, axis camera -y, 20 deg,
//! 1000 iterations, 0.1 m inlier distance, and a running average of the offset D that
//! rejects a new plane more than 0.2 m away (a table top). Changes, each measured:
//! - the up axis is the IMU gravity when the frame has one, else the previous plane,
//!   else camera -y: the fixed camera -y cone rejects the real floor at 30 deg pitch;
//! - hypotheses are scored on a small random subset of points below the camera (the
//!   floor is never above it), which is what makes 200 hypotheses cost ~0.1 ms;
//! - the score is MSAC's truncated quadratic (Torr & Zisserman 2000: an inlier at height
//!   `h` counts `1 - (h / band)^2`) weighted by `1 / depth^2`: the ground is the floor
//!   nearest the user, fitted tightly, not the largest plane. With a plain inlier count
//!   a plane tilted 4 deg through the floor underfoot and the lower floor beyond a step
//!   down wins (measured, synthetic step at 1.3 m, 30 deg pitch);
//! - each new best hypothesis is refitted to its inliers and rescored (LO-RANSAC, Chum
//!   et al. 2003);
//! - the final inliers must spread in two directions (`min_spread_m`): with the floor
//!   outside the cone, the best plane is a thin strip of floor at the image's edge with
//!   the rest of the floor above it (PCL's wrong, tilted plane at 30 deg pitch); we say
//!   "no ground" instead.
//! - the winner is refined by least squares on its inliers, first within `ransac_band_m`,
//!   then three times within `refine_band_m` (iterated to convergence: with two passes,
//!   1 of 40 five_people frames ended 1 cm off the others), so the plane is good to ~1 cm
//!   and the obstacle band can be tight; the scoring band itself is 5 cm, not 0.1 m (see
//!   `GroundConfig::ransac_band_m`). A refit that leaves the cone means the inliers were
//!   a slice of a surface that is no ground candidate: no ground, not the slice;

use nalgebra::{Matrix3, SymmetricEigen};
use schemas::GroundState;

use super::config::GroundConfig;
use super::organized_cloud::SampledCloud;

/// A plane `n . p + d = 0` in the camera frame, unit normal pointing up, so `d` is the
/// camera's height above it and `height(p)` a point's height above it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Unit normal, pointing up (away from the floor, towards the camera side).
    pub normal: [f32; 3],
    /// Offset: the camera's height above the plane, metres.
    pub offset_m: f32,
}

impl Plane {
    /// Height of `p` above the plane, metres (negative below).
    #[inline]
    pub fn height(&self, p: &[f32; 3]) -> f32 {
        dot(&self.normal, p) + self.offset_m
    }

    /// `[a, b, c, d]`.
    pub fn coefficients(&self) -> [f32; 4] {
        [self.normal[0], self.normal[1], self.normal[2], self.offset_m]
    }
}

/// RANSAC result before the false-ground guard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFit {
    /// The refined plane.
    pub plane: Plane,
    /// Inliers of the winning hypothesis in the scored subset.
    pub subset_inliers: usize,
    /// Size of the scored subset.
    pub subset_len: usize,
}

/// RANSAC search with its reusable subset buffer and deterministic sampler.
#[derive(Debug)]
pub struct GroundSearch {
    subset: Vec<[f32; 3]>,
    weights: Vec<f32>,
    rng: u64,
}

impl GroundSearch {
    /// A search whose random draws start from `seed`.
    pub fn new(seed: u64) -> Self {
        Self { subset: Vec::new(), weights: Vec::new(), rng: seed | 1 }
    }

    /// Best plane within `cfg.up_cone_deg` of `up` (unit), with the camera at a height
    /// above it that the `mount_height_m` guess allows
    /// ([`GroundConfig::camera_heights_m`]), and, when the running ground gives an
    /// `expected_offset_m`, within `cfg.max_offset_jump_m` of it; `None` when nothing
    /// plane-like below the camera holds enough points, or only points of several
    /// surfaces. Without a mount guess or a running ground, a seat or box top is told
    /// from the floor by what lies under it (`GroundSearch::under`).
    pub fn fit(
        &mut self,
        cloud: &SampledCloud,
        up: [f32; 3],
        up_is_gravity: bool,
        expected_offset_m: Option<f32>,
        mount_height_m: Option<f32>,
        cfg: &GroundConfig,
    ) -> Option<PlaneFit> {
        let mount_height_m = mount_height_m.filter(|h| h.is_finite() && *h > 0.0);
        let heights_m = cfg.camera_heights_m(mount_height_m);
        let n_valid = cloud.valid.len();
        if n_valid < 3 {
            return None;
        }
        // Subset of valid points below the prior horizon.
        self.subset.clear();
        let want = cfg.sample_points.max(3);
        for _ in 0..want * 3 {
            if self.subset.len() == want {
                break;
            }
            let p = cloud.points[cloud.valid[self.below(n_valid)] as usize];
            if dot(&p, &up) < 0.0 {
                self.subset.push(p);
            }
        }
        let m = self.subset.len();
        if m < 3 {
            return None;
        }
        // The ground is the floor the user stands on: nearer inliers weigh more, so a
        // lower floor beyond a step (or a table top beyond the floor) does not outvote
        // the floor at the user's feet by sheer area.
        self.weights.clear();
        self.weights.extend(self.subset.iter().map(|p| 1.0 / p[2].max(0.5).powi(2)));
        let cos_cone = cfg.up_cone_deg.to_radians().cos();
        // The thesis's false-ground guard, applied to each hypothesis: with a running
        // ground, a plane at another height (a table top) is not a candidate at all.
        let plausible = |p: &Plane| {
            dot(&p.normal, &up) >= cos_cone
                && (heights_m[0]..=heights_m[1]).contains(&p.offset_m)
                && expected_offset_m.is_none_or(|d| (p.offset_m - d).abs() <= cfg.max_offset_jump_m)
        };
        let inv_band_sq = 1.0 / (cfg.ransac_band_m * cfg.ransac_band_m);
        let score_of = |plane: &Plane, subset: &[[f32; 3]], weights: &[f32]| -> f32 {
            subset
                .iter()
                .zip(weights)
                .map(|(p, w)| {
                    let h = plane.height(p);
                    w * (1.0 - h * h * inv_band_sq).max(0.0)
                })
                .sum()
        };
        let mut best: Option<(Plane, f32)> = None;
        let mut needed = cfg.ransac_iterations;
        let mut iteration = 0;
        while iteration < needed {
            iteration += 1;
            let (i, j, k) = (self.below(m), self.below(m), self.below(m));
            if i == j || j == k || i == k {
                continue;
            }
            let (a, b, c) = (self.subset[i], self.subset[j], self.subset[k]);
            let Some(plane) = plane_through(&a, &b, &c, &up) else {
                continue;
            };
            if !plausible(&plane) {
                continue;
            }
            let score = score_of(&plane, &self.subset, &self.weights);
            if best.is_none_or(|(_, s)| score > s) {
                best = Some((plane, score));
                // Local optimisation (LO-RANSAC, Chum et al. 2003): a new best is refit
                // to its subset inliers, so three noisy far points that happen to span a
                // tilted plane cannot win over the floor they lie on.
                let inliers = self.subset.iter().filter(|p| plane.height(p).abs() < cfg.ransac_band_m).copied();
                if let Some((lo, _)) = fit_plane(inliers, &up).filter(|(lo, _)| plausible(lo)) {
                    let lo_score = score_of(&lo, &self.subset, &self.weights);
                    if lo_score > score {
                        best = Some((lo, lo_score));
                    }
                }
                // Adaptive termination (Hartley & Zisserman, alg. 4.5): enough draws that
                // an all-inlier triple of the best plane's support had a 99.9 % chance.
                if let Some((b, _)) = best {
                    let inliers = self.subset.iter().filter(|p| b.height(p).abs() < cfg.ransac_band_m).count();
                    needed = needed.min(draws_needed(inliers as f32 / m as f32, 0.999).max(MIN_DRAWS));
                }
            }
        }
        let Some((coarse, _)) = best else {
            // No triple drawn spans a candidate: the floor may hold too few of the points
            // for three of them to come up together (a far patch beyond a box top that
            // is itself out of the camera's height range).
            return self.by_height(cloud, up, heights_m, mount_height_m, &plausible, cfg);
        };
        let score = self.subset.iter().filter(|p| coarse.height(p).abs() < cfg.ransac_band_m).count();
        if (score as f32) < cfg.min_inlier_fraction * m as f32 || score < 3 {
            return None;
        }
        let mut plane = coarse;
        let support = self.subset.iter().filter(|p| coarse.height(p).abs() < cfg.ransac_band_m).copied();
        let mut spread_m = fit_plane(support, &up).map_or(0.0, |(_, s)| s);
        for band in [cfg.ransac_band_m, cfg.refine_band_m, cfg.refine_band_m, cfg.refine_band_m] {
            match least_squares(cloud, &plane, band, &up) {
                Some((refined, spread)) if plausible(&refined) => {
                    plane = refined;
                    spread_m = spread;
                }
                // The surface the inliers lie on leaves the cone (or jumps in height): the
                // hypothesis was a slice of something that is not a ground candidate, such
                // as a floor pitched beyond the cone. Say so rather than keep the slice.
                Some(_) => return None,
                None => break,
            }
        }
        if spread_m < cfg.min_spread_m {
            return None;
        }
        // without gravity the prior (a mount guess's pitch, camera -y) may itself be a
        // few degrees off: every plane found without a running ground must be a surface
        let tilted = !up_is_gravity || dot(&plane.normal, &up) < TILT_CHECKED_COS;
        if expected_offset_m.is_none() && tilted && !self.surface(&plane, cfg) {
            // a plane across surfaces (through a box top's far edge and the floor beyond,
            // tilted within the cone): its points do not lie on it
            return self.by_height(cloud, up, heights_m, mount_height_m, &plausible, cfg);
        }
        let mut fit = PlaneFit { plane, subset_inliers: score, subset_len: m };
        if expected_offset_m.is_none() && mount_height_m.is_none() {
            // a box top on a table top on ...: a few at most
            for _ in 0..3 {
                match self.under(cloud, &fit.plane, None, &plausible, cfg) {
                    Below::Nothing => break,
                    Below::Floor(lower) => fit = lower,
                    Below::Unfit => return None,
                }
            }
        }
        Some(fit)
    }

    /// The floor by height along `up`: the surface within the camera's `heights_m`
    /// nearest the mount guess (without one, the lowest), as [`GroundSearch::under`] an
    /// imagined plane just above the highest allowed.
    fn by_height(
        &self,
        cloud: &SampledCloud,
        up: [f32; 3],
        heights_m: [f32; 2],
        mount_height_m: Option<f32>,
        plausible: &dyn Fn(&Plane) -> bool,
        cfg: &GroundConfig,
    ) -> Option<PlaneFit> {
        // `under` looks from two scoring bands below its plane on, in refine bands
        let above = Plane { normal: up, offset_m: heights_m[0] - 2.0 * cfg.ransac_band_m - cfg.refine_band_m };
        self.under(cloud, &above, mount_height_m, plausible, cfg).floor()
    }

    /// What lies parallel to `top` (within the cone), lower than it: the floor beyond or
    /// around a box, bench or table top that the fit, which weighs the nearest floor
    /// most, chose. The depths below the camera along `top`'s normal of the scored
    /// points under it are binned; the lowest pair of bins that holds a surface (a
    /// thin layer spread in two directions, see [`GroundSearch::surface`]) of at least a
    /// quarter of `min_inlier_fraction` of the points is looked at. With the whole
    /// `min_inlier_fraction` it is refined as the fit is and is the floor; with less it
    /// still shows that `top` is not the floor ([`Below::Unfit`]). A wall's points
    /// spread over every bin, and a slice of one is no thin layer.
    ///
    /// With `nearest_to_m`, the layer nearest that far below the camera is looked at
    /// instead of the lowest (the floor by height under a mount guess: at a step's edge
    /// the user's floor, not the one below the step).
    fn under(
        &self,
        cloud: &SampledCloud,
        top: &Plane,
        nearest_to_m: Option<f32>,
        plausible: &dyn Fn(&Plane) -> bool,
        cfg: &GroundConfig,
    ) -> Below {
        let bin_m = cfg.refine_band_m;
        let first_m = top.offset_m + 2.0 * cfg.ransac_band_m;
        let mut bins = [0u32; LOWER_BINS];
        for p in &self.subset {
            let k = ((-dot(&top.normal, p) - first_m) / bin_m).floor();
            if k >= 0.0 && (k as usize) < LOWER_BINS {
                bins[k as usize] += 1;
            }
        }
        let m = self.subset.len();
        let needed = ((cfg.min_inlier_fraction * m as f32).ceil() as u32).max(3);
        let witness = (needed / 4).max(3);
        // the points of bins k and k + 1, and that pair's middle below the camera
        let layer_points = |k: usize| {
            let (lo, hi) = (first_m + k as f32 * bin_m, first_m + (k + 2) as f32 * bin_m);
            self.subset.iter().filter(move |p| (lo..hi).contains(&-dot(&top.normal, p)))
        };
        let centre_m = |k: usize| first_m + (k as f32 + 1.0) * bin_m;
        let layer = |k: usize| {
            fit_plane(layer_points(k).copied(), &top.normal)
                .filter(|(plane, spread)| *spread >= cfg.min_spread_m && plausible(plane) && self.surface(plane, cfg))
        };
        let holds = |k: &usize| bins[*k] + bins[*k + 1] >= witness && layer(*k).is_some();
        let found = match nearest_to_m {
            None => (0..LOWER_BINS - 1).rev().find(holds),
            Some(h) => (0..LOWER_BINS - 1)
                .filter(holds)
                .min_by(|a, b| (centre_m(*a) - h).abs().total_cmp(&(centre_m(*b) - h).abs())),
        };
        let Some(k) = found else {
            return Below::Nothing;
        };
        // Seen only beyond `top`, a lower surface may as well be the floor below a step
        // down from `top` as the floor beyond a bench. A step's depth below: keep `top`,
        // the edge of lower ground stops the user. Deeper: `top` may be a seat or a box
        // top, the lower floor may lie beyond a ledge; neither is trusted. Seen beside or
        // nearer than `top`'s far end, the lower surface is the floor the user stands on.
        let layer_near_m = quantile(layer_points(k).map(|p| horizontal_m(top, p)), 0.05);
        let top_far_m = quantile(
            self.subset.iter().filter(|p| top.height(p).abs() < cfg.ransac_band_m).map(|p| horizontal_m(top, p)),
            0.95,
        );
        if top_far_m.is_some_and(|far| layer_near_m.is_none_or(|near| near >= far)) {
            let deeper_than_a_step = centre_m(k) - top.offset_m > cfg.max_step_down_m;
            return if deeper_than_a_step { Below::Unfit } else { Below::Nothing };
        }
        if bins[k] + bins[k + 1] < needed {
            return Below::Unfit;
        }
        let mut plane = Plane { normal: top.normal, offset_m: centre_m(k) };
        let mut spread_m = 0.0;
        for band in [cfg.ransac_band_m, cfg.refine_band_m, cfg.refine_band_m, cfg.refine_band_m] {
            match least_squares(cloud, &plane, band, &top.normal) {
                Some((refined, spread)) if plausible(&refined) => {
                    plane = refined;
                    spread_m = spread;
                }
                _ => return Below::Unfit,
            }
        }
        let inliers = self.subset.iter().filter(|p| plane.height(p).abs() < cfg.ransac_band_m).count();
        if spread_m >= cfg.min_spread_m
            && plane.offset_m > top.offset_m + cfg.ransac_band_m
            && inliers as u32 >= needed
            && self.surface(&plane, cfg)
        {
            Below::Floor(PlaneFit { plane, subset_inliers: inliers, subset_len: m })
        } else {
            Below::Unfit
        }
    }

    /// Whether the scored points near `plane` lie in a thin layer on it, as points on
    /// a floor or a table top do (within the noise: most of them within `refine_band_m`
    /// of those within three times that), not spread through the band as a horizontal
    /// slice of walls is.
    fn surface(&self, plane: &Plane, cfg: &GroundConfig) -> bool {
        let (mut thin, mut near) = (0u32, 0u32);
        for p in &self.subset {
            let h = plane.height(p).abs();
            thin += u32::from(h < cfg.refine_band_m);
            near += u32::from(h < 3.0 * cfg.refine_band_m);
        }
        near > 0 && thin as f32 >= SURFACE_FRACTION * near as f32
    }

    /// Uniform index below `n` (xorshift64*; deterministic, allocation-free).
    fn below(&mut self, n: usize) -> usize {
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        let r = self.rng.wrapping_mul(0x2545_f491_4f6c_dd1d);
        // in u64: on a 32-bit target (an armv7 board) a usize product would overflow
        (((r >> 32) * n as u64) >> 32) as usize
    }
}

/// Draws after which an all-inlier triple was drawn with probability `confidence`, for
/// an inlier fraction `fraction`.
fn draws_needed(fraction: f32, confidence: f32) -> u32 {
    let all_three = fraction.clamp(0.0, 1.0).powi(3);
    if all_three <= 1e-6 {
        return u32::MAX;
    }
    if all_three >= 1.0 - 1e-6 {
        return 1;
    }
    ((1.0 - confidence).ln() / (1.0 - all_three).ln()).ceil().min(u32::MAX as f32) as u32
}

/// Distance of `p` from the camera along `plane` (its horizontal distance when the
/// plane is level), metres.
fn horizontal_m(plane: &Plane, p: &[f32; 3]) -> f32 {
    let along = dot(&plane.normal, p);
    (dot(p, p) - along * along).max(0.0).sqrt()
}

/// The `q` quantile (0..1) of `values`, `None` when there are none.
fn quantile(values: impl Iterator<Item = f32>, q: f32) -> Option<f32> {
    let mut v: Vec<f32> = values.collect();
    if v.is_empty() {
        return None;
    }
    let k = ((v.len() - 1) as f32 * q).round() as usize;
    Some(*v.select_nth_unstable_by(k, f32::total_cmp).1)
}

/// What [`GroundSearch::under`] found under a surface.
enum Below {
    /// No surface lower than it: it may be the floor.
    Nothing,
    /// The floor, lower than it.
    Floor(PlaneFit),
    /// A surface lower than it with too few points to fit the floor to: it is not the
    /// floor, and no floor is known.
    Unfit,
}

impl Below {
    fn floor(self) -> Option<PlaneFit> {
        match self {
            Below::Floor(fit) => Some(fit),
            Below::Nothing | Below::Unfit => None,
        }
    }
}

/// Cosine of the tilt from gravity beyond which a fit's points must lie on it
/// ([`GroundSearch::surface`]), 10 deg: a plane through a box top and the floor beyond
/// it (within the 20 deg cone) was 12.5 deg off. At 5 deg the simulated cane's
/// gravity (the sweep's accelerations in it) tilted floors that far at a step's edge.
const TILT_CHECKED_COS: f32 = 0.984_807_8;

/// Of the scored points within three refine bands of a surface, the fewest within one:
/// uniform through the band (a slice of walls) gives a third, a floor's nearly all.
const SURFACE_FRACTION: f32 = 0.7;

/// Bins of `refine_band_m` (3 cm: 2.4 m) searched below a fit for a lower surface.
const LOWER_BINS: usize = 80;

/// Fewest hypotheses drawn whatever the inlier fraction: the support of an early,
/// wrong best plane (a wall strip) can look large enough to stop too soon.
const MIN_DRAWS: u32 = 60;

fn plane_through(a: &[f32; 3], b: &[f32; 3], c: &[f32; 3], up: &[f32; 3]) -> Option<Plane> {
    let u = sub(b, a);
    let v = sub(c, a);
    let mut n = cross(&u, &v);
    let len = dot(&n, &n).sqrt();
    if len.is_nan() || len <= 1e-6 {
        return None;
    }
    let sign = if dot(&n, up) < 0.0 { -1.0 } else { 1.0 };
    n = [n[0] * sign / len, n[1] * sign / len, n[2] * sign / len];
    Some(Plane { normal: n, offset_m: -dot(&n, a) })
}

const LSQ_POINTS: usize = 4096;

/// Total least squares plane of the valid points within `band` of `around`.
fn least_squares(cloud: &SampledCloud, around: &Plane, band: f32, up: &[f32; 3]) -> Option<(Plane, f32)> {
    // 4k evenly spread points fix a plane to well under a millimetre; more only cost
    let step = (cloud.valid.len() / LSQ_POINTS).max(1);
    let near =
        cloud.valid.iter().step_by(step).map(|&i| cloud.points[i as usize]).filter(|p| around.height(p).abs() < band);
    fit_plane(near, up)
}

/// Total least squares plane through `points` (smallest eigenvector of their
/// covariance), normal oriented along `up`, with the points' spread in their narrower
/// in-plane direction (square root of the middle eigenvalue, metres); `None` for fewer
/// than 3 or degenerate points.
fn fit_plane(points: impl Iterator<Item = [f32; 3]>, up: &[f32; 3]) -> Option<(Plane, f32)> {
    let mut n = 0usize;
    let mut s = [0f64; 3];
    let mut ss = [0f64; 6]; // xx xy xz yy yz zz
    for p in points {
        let (x, y, z) = (p[0] as f64, p[1] as f64, p[2] as f64);
        n += 1;
        s[0] += x;
        s[1] += y;
        s[2] += z;
        ss[0] += x * x;
        ss[1] += x * y;
        ss[2] += x * z;
        ss[3] += y * y;
        ss[4] += y * z;
        ss[5] += z * z;
    }
    if n < 3 {
        return None;
    }
    let nf = n as f64;
    let m = [s[0] / nf, s[1] / nf, s[2] / nf];
    let cov = Matrix3::new(
        ss[0] / nf - m[0] * m[0],
        ss[1] / nf - m[0] * m[1],
        ss[2] / nf - m[0] * m[2],
        ss[1] / nf - m[0] * m[1],
        ss[3] / nf - m[1] * m[1],
        ss[4] / nf - m[1] * m[2],
        ss[2] / nf - m[0] * m[2],
        ss[4] / nf - m[1] * m[2],
        ss[5] / nf - m[2] * m[2],
    );
    let eig = SymmetricEigen::new(cov);
    let k = eig.eigenvalues.imin();
    let mut sorted = [eig.eigenvalues[0], eig.eigenvalues[1], eig.eigenvalues[2]];
    sorted.sort_by(f64::total_cmp);
    let spread_m = sorted[1].max(0.0).sqrt() as f32;
    let v = eig.eigenvectors.column(k);
    let mut normal = [v[0] as f32, v[1] as f32, v[2] as f32];
    let len = dot(&normal, &normal).sqrt();
    if len.is_nan() || len <= 0.5 {
        return None;
    }
    let sign = if dot(&normal, up) < 0.0 { -1.0 } else { 1.0 };
    normal = [normal[0] * sign / len, normal[1] * sign / len, normal[2] * sign / len];
    let centroid = [m[0] as f32, m[1] as f32, m[2] as f32];
    Some((Plane { normal, offset_m: -dot(&normal, &centroid) }, spread_m))
}

/// What the tracker decided for this frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundDecision {
    /// Plane to classify with.
    pub plane: Plane,
    /// Found, or stood in for by the running average.
    pub state: GroundState,
}

/// The thesis's running average of the ground, its false-ground guard, and the count of
/// frames the ground has been lost for.
#[derive(Debug, Default)]
pub struct GroundTracker {
    average: Option<Plane>,
    lost_frames: u32,
    rejected_frames: u32,
}

impl GroundTracker {
    /// Up axis to search around: against gravity when the frame has a usable gravity
    /// vector, else the running plane while the ground is trusted, else the up axis of
    /// a camera pitched `mount_pitch_deg` down (the mount guess, no roll), else camera
    /// -y.
    pub fn prior_up(
        &self,
        gravity_camera: Option<[f32; 3]>,
        mount_pitch_deg: Option<f32>,
        cfg: &GroundConfig,
    ) -> [f32; 3] {
        if let Some(up) = gravity_camera.and_then(|g| normalized(&[-g[0], -g[1], -g[2]])) {
            return up;
        }
        match self.average {
            Some(avg) if self.lost_frames <= cfg.max_lost_frames => avg.normal,
            _ => mount_pitch_deg.filter(|p| p.is_finite() && p.abs() <= 90.0).map_or([0.0, -1.0, 0.0], up_of_pitch),
        }
    }

    /// Offset the running ground expects, while it is trusted (not `Degraded`).
    pub fn expected_offset_m(&self, cfg: &GroundConfig) -> Option<f32> {
        self.average.filter(|_| self.lost_frames <= cfg.max_lost_frames).map(|a| a.offset_m)
    }

    /// Folds this frame's fit into the running ground. `None` when there has never been a
    /// ground to stand in (the caller reports it; nothing is made up).
    pub fn update(
        &mut self,
        fit: Option<PlaneFit>,
        gravity_camera: Option<[f32; 3]>,
        cfg: &GroundConfig,
    ) -> Option<GroundDecision> {
        let accepted = match (fit, self.average) {
            (Some(f), None) => Some(f.plane),
            (Some(f), Some(avg)) => {
                let lower_by = f.plane.offset_m - avg.offset_m;
                if lower_by.abs() <= cfg.max_offset_jump_m && lower_by <= cfg.max_offset_drop_m {
                    Some(f.plane)
                } else {
                    self.rejected_frames += 1;
                    // a floor a step below waits long; a jump beyond the guard either
                    // way is the thesis's case (a table top, or the true floor after one)
                    let step_below = lower_by > 0.0 && lower_by <= cfg.max_step_down_m;
                    let reseed = if step_below { cfg.reseed_lower_after_frames } else { cfg.reseed_after_frames };
                    (self.rejected_frames > reseed).then(|| {
                        self.average = None;
                        f.plane
                    })
                }
            }
            (None, _) => None,
        };
        if let Some(plane) = accepted {
            self.rejected_frames = 0;
            self.lost_frames = 0;
            self.average = Some(match self.average {
                None => plane,
                Some(avg) => blend(&avg, &plane, cfg.average_weight),
            });
            return Some(GroundDecision { plane, state: GroundState::Found });
        }
        self.lost_frames = self.lost_frames.saturating_add(1);
        let avg = self.average?;
        // The cane turns while the ground is lost: trust gravity for the normal if known.
        let normal = gravity_camera.and_then(|g| normalized(&[-g[0], -g[1], -g[2]])).unwrap_or(avg.normal);
        let state = if self.lost_frames > cfg.max_lost_frames { GroundState::Degraded } else { GroundState::Lost };
        Some(GroundDecision { plane: Plane { normal, offset_m: avg.offset_m }, state })
    }

    /// Frames in a row without an accepted ground.
    pub fn lost_frames(&self) -> u32 {
        self.lost_frames
    }
}

/// The world's up axis in the optical frame (x right, y down, z ahead) of a camera
/// pitched `pitch_deg` below the horizontal with no roll.
pub fn up_of_pitch(pitch_deg: f32) -> [f32; 3] {
    let (s, c) = pitch_deg.to_radians().sin_cos();
    [0.0, -c, -s]
}

fn blend(avg: &Plane, new: &Plane, w: f32) -> Plane {
    let n = [
        avg.normal[0] * (1.0 - w) + new.normal[0] * w,
        avg.normal[1] * (1.0 - w) + new.normal[1] * w,
        avg.normal[2] * (1.0 - w) + new.normal[2] * w,
    ];
    Plane { normal: normalized(&n).unwrap_or(new.normal), offset_m: avg.offset_m * (1.0 - w) + new.offset_m * w }
}

/// `v / |v|`, or `None` for a zero or non-finite vector.
pub fn normalized(v: &[f32; 3]) -> Option<[f32; 3]> {
    let len = dot(v, v).sqrt();
    (len.is_finite() && len > 1e-6).then(|| [v[0] / len, v[1] / len, v[2] / len])
}

/// Dot product.
#[inline]
pub fn dot(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
#[inline]
pub fn cross(a: &[f32; 3], b: &[f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[inline]
fn sub(a: &[f32; 3], b: &[f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(found: bool, offset_m: f32) -> Option<PlaneFit> {
        found.then_some(PlaneFit {
            plane: Plane { normal: [0.0, -1.0, 0.0], offset_m },
            subset_inliers: 100,
            subset_len: 200,
        })
    }

    /// A tracker whose running average is a floor `offset_m` below the camera.
    fn tracking(offset_m: f32, cfg: &GroundConfig) -> GroundTracker {
        let mut t = GroundTracker::default();
        t.update(fit(true, offset_m), None, cfg);
        t
    }

    #[test]
    fn table_top_jump_is_rejected_and_average_plane_stands_in() {
        let cfg = GroundConfig::default();
        let mut t = GroundTracker::default();
        assert_eq!(t.update(fit(true, 1.0), None, &cfg).unwrap().state, GroundState::Found);
        let d = t.update(fit(true, 0.3), None, &cfg).unwrap();
        assert_eq!(d.state, GroundState::Lost);
        assert!((d.plane.offset_m - 1.0).abs() < 1e-6);
    }

    #[test]
    fn ground_lost_beyond_max_frames_degrades_then_recovers() {
        let cfg = GroundConfig::default();
        let mut t = GroundTracker::default();
        assert!(t.update(fit(false, 0.0), None, &cfg).is_none(), "no ground ever: nothing made up");
        t.update(fit(true, 1.0), None, &cfg);
        for i in 1..=cfg.max_lost_frames {
            assert_eq!(t.update(None, None, &cfg).unwrap().state, GroundState::Lost, "frame {i}");
        }
        assert_eq!(t.update(None, None, &cfg).unwrap().state, GroundState::Degraded);
        assert_eq!(t.update(fit(true, 1.05), None, &cfg).unwrap().state, GroundState::Found);
    }

    #[test]
    fn persistent_new_height_is_accepted_after_reseed_frames() {
        let cfg = GroundConfig::default();
        // nearer (a step up, the cane held lower): after `reseed_after_frames`
        let mut t = tracking(1.0, &cfg);
        let mut last = None;
        for _ in 0..=cfg.reseed_after_frames {
            last = t.update(fit(true, 0.7), None, &cfg);
        }
        let d = last.unwrap();
        assert_eq!(d.state, GroundState::Found);
        assert!((d.plane.offset_m - 0.7).abs() < 1e-6);
        // farther below than a step (the true floor after a false one): the same
        let mut t = tracking(1.0, &cfg);
        for _ in 0..cfg.reseed_after_frames {
            t.update(fit(true, 1.5), None, &cfg);
        }
        assert!((t.update(fit(true, 1.5), None, &cfg).unwrap().plane.offset_m - 1.5).abs() < 1e-6);
        // a step below (the cane held higher for good): only after `reseed_lower_after_frames`
        let mut t = tracking(1.0, &cfg);
        for i in 0..cfg.reseed_lower_after_frames {
            let d = t.update(fit(true, 1.15), None, &cfg).unwrap();
            assert!((d.plane.offset_m - 1.0).abs() < 1e-6 && d.state != GroundState::Found, "frame {i}: {d:?}");
        }
        let d = t.update(fit(true, 1.15), None, &cfg).unwrap();
        assert_eq!(d.state, GroundState::Found);
        assert!((d.plane.offset_m - 1.15).abs() < 1e-6);
    }

    #[test]
    fn floor_a_step_below_is_not_taken_for_the_ground() {
        let cfg = GroundConfig::default();
        let mut t = tracking(1.0, &cfg);
        // within the thesis's 0.2 m guard, but lower than the user's floor: a step down
        let d = t.update(fit(true, 1.15), None, &cfg).unwrap();
        assert_eq!(d.state, GroundState::Lost);
        assert!((d.plane.offset_m - 1.0).abs() < 1e-6);
        // a few centimetres either way are the cane's bob and the fit's noise
        assert_eq!(t.update(fit(true, 1.05), None, &cfg).unwrap().state, GroundState::Found);
        assert_eq!(t.update(fit(true, 0.9), None, &cfg).unwrap().state, GroundState::Found);
    }

    #[test]
    fn draws_needed_follows_the_inlier_fraction() {
        assert_eq!(draws_needed(0.5, 0.999), 52);
        assert_eq!(draws_needed(0.3, 0.999), 253);
        assert_eq!(draws_needed(0.0, 0.999), u32::MAX);
        assert_eq!(draws_needed(1.0, 0.999), 1);
    }

    #[test]
    fn gravity_overrides_the_prior() {
        let cfg = GroundConfig::default();
        let t = GroundTracker::default();
        let up = t.prior_up(Some([0.0, 0.0, 2.0]), None, &cfg);
        assert_eq!(up, [0.0, 0.0, -1.0]);
        assert_eq!(t.prior_up(Some([f32::NAN, 0.0, 0.0]), None, &cfg), [0.0, -1.0, 0.0]);
        assert_eq!(t.prior_up(Some([0.0, 0.0, 2.0]), Some(30.0), &cfg), [0.0, 0.0, -1.0]);
    }

    #[test]
    fn without_gravity_the_mount_pitch_gives_the_prior_until_a_ground_is_tracked() {
        let cfg = GroundConfig::default();
        let mut t = GroundTracker::default();
        for pitch in [0.0f32, 10.0, 30.0, 60.0] {
            let truth = crate::synthetic_scene::Scene::kinect(0.9, pitch).floor_plane_camera();
            let up = t.prior_up(None, Some(pitch), &cfg);
            assert!((0..3).all(|i| (up[i] - truth[i]).abs() < 1e-5), "pitch {pitch}: {up:?} vs the floor's {truth:?}");
        }
        // a guess no camera could have is not used
        assert_eq!(t.prior_up(None, Some(f32::NAN), &cfg), [0.0, -1.0, 0.0]);
        assert_eq!(t.prior_up(None, Some(120.0), &cfg), [0.0, -1.0, 0.0]);
        // a tracked ground is a better prior than the guess
        let tracked = Plane { normal: up_of_pitch(25.0), offset_m: 0.9 };
        t.update(Some(PlaneFit { plane: tracked, subset_inliers: 100, subset_len: 200 }), None, &cfg);
        assert_eq!(t.prior_up(None, Some(30.0), &cfg), tracked.normal);
    }
}
