//! Stages 3-5: classify points against the ground, level them into the user frame, and
//! keep the nearest obstacle per 1-degree bearing bin.
//!
//! Taylor 2017, sec. 2.2-2.3. The thesis rotates the cloud by `acos(-B)` about
//! `(C, 0, -A)`; we build the user frame directly from the upward plane normal `n`:
//! up = `n`, forward = the optical axis projected onto the floor, left = up x forward.
//! That fixes the sign question the thesis formula leaves open (a downward normal
//! mirrors left and right) and defines bearing 0 as where the camera looks.
//!
//! Bins are centred on whole multiples of the bin width; the bin of a point is found
//! from `y / x` with a table over the tangents of the bin edges (one look-up, one
//! comparison), so no point needs an `atan`, and ranges are compared squared (one
//! `sqrt` per bin).

use schemas::Scan;

use super::config::ScanConfig;
use super::ground_plane::{cross, dot, normalized, Plane};
use super::organized_cloud::SampledCloud;

/// Camera -> user frame (x forward, y left, z up, origin on the floor below the camera).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UserFrame {
    /// User x axis in camera coordinates.
    pub forward: [f32; 3],
    /// User y axis in camera coordinates.
    pub left: [f32; 3],
    /// The ground plane (user z axis = its normal, height = its offset).
    pub plane: Plane,
}

impl UserFrame {
    /// User frame of `plane`; `None` when the camera looks straight along the normal
    /// (no forward direction).
    pub fn from_plane(plane: &Plane) -> Option<Self> {
        let n = plane.normal;
        let along = n[2];
        if 1.0 - along.abs() < 1e-4 {
            return None;
        }
        let forward = normalized(&[-along * n[0], -along * n[1], 1.0 - along * n[2]])?;
        let left = cross(&n, &forward);
        Some(Self { forward, left, plane: *plane })
    }

    /// Camera point -> user point `[x forward, y left, z up]`.
    #[inline]
    pub fn to_user(&self, p: &[f32; 3]) -> [f32; 3] {
        [dot(&self.forward, p), dot(&self.left, p), self.plane.height(p)]
    }

    /// User point -> camera point.
    pub fn to_camera(&self, u: &[f32; 3]) -> [f32; 3] {
        let (f, l, n) = (self.forward, self.left, self.plane.normal);
        let h = u[2] - self.plane.offset_m;
        [
            f[0] * u[0] + l[0] * u[1] + n[0] * h,
            f[1] * u[0] + l[1] * u[1] + n[1] * h,
            f[2] * u[0] + l[2] * u[1] + n[2] * h,
        ]
    }

    /// Downward pitch of the optical axis below the floor's horizontal, radians.
    pub fn pitch_down_rad(&self) -> f32 {
        (-self.plane.normal[2]).clamp(-1.0, 1.0).asin()
    }
}

/// Bearing bins across the horizontal field of view.
#[derive(Debug, Clone, PartialEq)]
pub struct BinLayout {
    /// Bins each side of the centre bin.
    pub half_bins: i32,
    /// Bin width, degrees.
    pub bin_deg: f32,
    edges_tan: Vec<f32>,
    // bin of the lower end of each of LUT_CELLS equal cells of tan between the outer
    // edges; the cells are narrower than any bin, so one edge comparison finishes
    lut: Vec<u16>,
    lut_scale: f32,
}

const LUT_CELLS: usize = 4096;

impl BinLayout {
    /// Bins covering a field of view of `2 * half_fov_rad`, with one margin bin each side
    /// (Taylor's 58 deg camera: 61 bins, -30..=30).
    pub fn for_fov(half_fov_rad: f32, bin_deg: f32) -> Self {
        let (half_bins, bin_deg) = Self::shape(half_fov_rad, bin_deg);
        let edges_tan: Vec<f32> =
            (-half_bins..=half_bins + 1).map(|k| ((k as f32 - 0.5) * bin_deg).to_radians().tan()).collect();
        let (lo, hi) = (edges_tan[0], edges_tan[edges_tan.len() - 1]);
        let lut_scale = LUT_CELLS as f32 / (hi - lo);
        let lut = (0..LUT_CELLS)
            .map(|c| {
                let t = lo + c as f32 / lut_scale;
                (edges_tan.partition_point(|&e| e <= t).max(1) - 1) as u16
            })
            .collect();
        Self { half_bins, bin_deg, edges_tan, lut, lut_scale }
    }

    /// True when this layout is the one [`BinLayout::for_fov`] would build.
    pub fn fits(&self, half_fov_rad: f32, bin_deg: f32) -> bool {
        Self::shape(half_fov_rad, bin_deg) == (self.half_bins, self.bin_deg)
    }

    fn shape(half_fov_rad: f32, bin_deg: f32) -> (i32, f32) {
        let bin_deg = if bin_deg.is_finite() && bin_deg > 0.01 { bin_deg } else { 1.0 };
        let half_fov_deg = if half_fov_rad.is_finite() { half_fov_rad.to_degrees().clamp(0.0, 80.0) } else { 30.0 };
        ((half_fov_deg / bin_deg).floor() as i32 + 1, bin_deg)
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        (2 * self.half_bins + 1) as usize
    }

    /// Always false: a layout has at least one bin.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Bin of a user-frame point with `x > 0`.
    #[inline]
    pub fn bin_of(&self, x: f32, y: f32) -> Option<usize> {
        let t = y / x;
        let cell = (t - self.edges_tan[0]) * self.lut_scale;
        if !(cell >= 0.0 && cell < LUT_CELLS as f32) {
            return None;
        }
        let mut b = self.lut[cell as usize] as usize;
        if t >= self.edges_tan[b + 1] {
            b += 1;
        }
        (b < self.len() && t >= self.edges_tan[b]).then_some(b)
    }

    /// Bearing of bin `i`'s centre, degrees, positive left.
    pub fn bearing_deg(&self, i: usize) -> f32 {
        (i as i32 - self.half_bins) as f32 * self.bin_deg
    }
}

/// With `scan.overhangs_from_m`, points from that height up count where they are at
/// least this much nearer than the bin's lower points, metres: a sign before a wall, a
/// cabinet standing 30 cm out from it, not the wall's own depth noise.
pub const OVERHANG_MARGIN_M: f32 = 0.15;

/// A cane whose tip slides on the floor with the hand about 1 m up passes under what
/// hangs higher than this near its tip, metres: a bin's nearest obstacle counts as found
/// by the cane only with points this low as near ([`ScanBuilder::cane_finds`]).
pub const CANE_FINDS_BELOW_M: f32 = 0.3;

/// Reusable state of the scan stage.
#[derive(Debug, Default)]
pub struct ScanBuilder {
    nearest_sq: Vec<[f32; 4]>,
    nearest_height: Vec<[f32; 4]>,
    /// With `overhangs_from_m`: the nearest obstacle points below that height, and the
    /// farthest point below it, floor included (how far the view under it reaches).
    lower_sq: Vec<[f32; 4]>,
    lower_height: Vec<[f32; 4]>,
    below_far_sq: Vec<f32>,
    /// Per bin, the farthest floor points (squared ranges, farthest first).
    floor_far_sq: Vec<[f32; 4]>,
    /// Height above the floor of the point that set each bin's range.
    pub heights_m: Vec<f32>,
    /// Per bin with a range: whether the cane would find what set it, i.e. whether it
    /// reaches down below [`CANE_FINDS_BELOW_M`] there (points that low no more than
    /// [`OVERHANG_MARGIN_M`] farther); not for a table top or a bench seat whose legs
    /// stand back, a sign, a lamp. False where the bin has no range.
    pub cane_finds: Vec<bool>,
    /// Per bin, the nearest obstacle points below [`CANE_FINDS_BELOW_M`].
    low_sq: Vec<[f32; 4]>,
    /// With [`ScanConfig::floor_seen`], per bin, how far the floor was seen free: the
    /// range of its `min_points_per_bin`-th farthest floor point (within 4 cm of the
    /// plane and `range_max_m`), no farther than the bin's nearest obstacle; 0 where no
    /// floor was seen. Nothing stands on the floor short of it (the localization's free
    /// space: a wall there would have hidden that floor). Empty without.
    pub floor_seen_m: Vec<f32>,
    /// Obstacle points (after the height band) this frame.
    pub obstacle_points: usize,
}

impl ScanBuilder {
    /// Fills `scan` with the nearest obstacle per bin of `layout`. Obstacles are points
    /// higher than `band_scale * (min_obstacle_height_m + noise * z^2)` and lower than
    /// `max_obstacle_height_m` above the plane; with `overhangs_from_m`, only those of
    /// them that overhang (see [`ScanConfig::overhangs_from_m`]).
    pub fn build(
        &mut self,
        cloud: &SampledCloud,
        frame: &UserFrame,
        layout: &BinLayout,
        cfg: &ScanConfig,
        band_scale: f32,
        scan: &mut Scan,
    ) {
        let bins = layout.len();
        let k = cfg.min_points_per_bin.clamp(1, 4) as usize;
        self.nearest_sq.clear();
        self.nearest_sq.resize(bins, [f32::INFINITY; 4]);
        self.nearest_height.clear();
        self.nearest_height.resize(bins, [0.0; 4]);
        self.lower_sq.clear();
        self.lower_height.clear();
        self.below_far_sq.clear();
        self.floor_far_sq.clear();
        self.floor_far_sq.resize(bins, [0.0; 4]);
        self.low_sq.clear();
        self.low_sq.resize(bins, [f32::INFINITY; 4]);
        if cfg.overhangs_from_m.is_some() {
            self.lower_sq.resize(bins, [f32::INFINITY; 4]);
            self.lower_height.resize(bins, [0.0; 4]);
            self.below_far_sq.resize(bins, 0.0);
        }
        let range_max_sq = cfg.range_max_m * cfg.range_max_m;
        let min_h = cfg.min_obstacle_height_m * band_scale;
        let noise = cfg.noise_per_depth_sq * band_scale;
        let mut obstacles = 0;
        for &i in &cloud.valid {
            let p = cloud.points[i as usize];
            let h = frame.plane.height(&p);
            let floor = h <= min_h + noise * p[2] * p[2];
            let binned = !floor || cfg.overhangs_from_m.is_some() || (cfg.floor_seen && h >= -min_h);
            if !binned || h >= cfg.max_obstacle_height_m {
                continue;
            }
            obstacles += usize::from(!floor);
            let x = dot(&frame.forward, &p);
            if x <= 0.0 {
                continue;
            }
            let y = dot(&frame.left, &p);
            let r_sq = x * x + y * y;
            if r_sq > range_max_sq {
                continue;
            }
            if let Some(b) = layout.bin_of(x, y) {
                if cfg.floor_seen && h.abs() <= min_h {
                    insert_farthest(&mut self.floor_far_sq[b], r_sq);
                }
                if cfg.overhangs_from_m.is_some_and(|from| h < from) {
                    self.below_far_sq[b] = self.below_far_sq[b].max(r_sq);
                    if !floor {
                        insert_sorted(&mut self.lower_sq[b], &mut self.lower_height[b], r_sq, h);
                    }
                } else if !floor {
                    insert_sorted(&mut self.nearest_sq[b], &mut self.nearest_height[b], r_sq, h);
                }
                if !floor && h < CANE_FINDS_BELOW_M {
                    let _ = insert_nearest(&mut self.low_sq[b], r_sq);
                }
            }
        }
        self.obstacle_points = obstacles;
        scan.angle_min_deg = -(layout.half_bins as f32) * layout.bin_deg;
        scan.angle_increment_deg = layout.bin_deg;
        scan.range_max_m = cfg.range_max_m;
        scan.ranges_m.clear();
        self.heights_m.clear();
        self.cane_finds.clear();
        self.floor_seen_m.clear();
        for (b, (sq, hs)) in self.nearest_sq.iter().zip(&self.nearest_height).enumerate() {
            // the k-th nearest: a lone flying pixel does not make an obstacle
            let mut range = sq[k - 1].sqrt();
            if let (Some(lower), Some(&below_far_sq)) = (self.lower_sq.get(b), self.below_far_sq.get(b)) {
                // it overhangs when nothing lower stands as near and the view under it
                // reaches past it (nearer, a camera looking down from above cannot tell)
                let past = range + OVERHANG_MARGIN_M;
                if past >= lower[k - 1].sqrt() || below_far_sq.sqrt() <= past {
                    range = f32::INFINITY;
                }
            }
            scan.ranges_m.push(range);
            self.heights_m.push(hs[k - 1]);
            self.cane_finds.push(range.is_finite() && self.low_sq[b][k - 1].sqrt() <= range + OVERHANG_MARGIN_M);
            if cfg.floor_seen {
                self.floor_seen_m.push(self.floor_far_sq[b][k - 1].sqrt().min(sq[0].sqrt()));
            }
        }
    }
}

/// Keeps the four largest squared ranges, largest first.
fn insert_farthest(r: &mut [f32; 4], r_sq: f32) {
    if r_sq <= r[3] {
        return;
    }
    let mut j = 3;
    while j > 0 && r[j - 1] < r_sq {
        r[j] = r[j - 1];
        j -= 1;
    }
    r[j] = r_sq;
}

/// Keeps the four smallest squared ranges, smallest first; returns where `r_sq` went.
fn insert_nearest(r: &mut [f32; 4], r_sq: f32) -> Option<usize> {
    if r_sq >= r[3] {
        return None;
    }
    let j = r.partition_point(|&v| v <= r_sq);
    r.copy_within(j..3, j + 1);
    r[j] = r_sq;
    Some(j)
}

/// [`insert_nearest`], with each range's height kept beside it.
fn insert_sorted(r: &mut [f32; 4], h: &mut [f32; 4], r_sq: f32, height: f32) {
    if let Some(j) = insert_nearest(r, r_sq) {
        h.copy_within(j..3, j + 1);
        h[j] = height;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fifty_eight_degree_camera_gets_sixty_one_bins() {
        let layout = BinLayout::for_fov(29f32.to_radians(), 1.0);
        assert_eq!(layout.len(), 61);
        assert_eq!(layout.bearing_deg(0), -30.0);
        assert_eq!(layout.bearing_deg(60), 30.0);
    }

    #[test]
    fn bins_follow_bearing_positive_left() {
        let layout = BinLayout::for_fov(29f32.to_radians(), 1.0);
        let at = |deg: f32| {
            let r = deg.to_radians();
            layout.bin_of(r.cos(), r.sin()).map(|b| layout.bearing_deg(b))
        };
        assert_eq!(at(0.2), Some(0.0));
        assert_eq!(at(10.4), Some(10.0));
        assert_eq!(at(-10.6), Some(-11.0));
        assert_eq!(at(30.4), Some(30.0));
        assert_eq!(at(31.0), None);
        assert_eq!(at(-31.0), None);
        // every bin edge lands on the bin above it, exactly as the tangents say
        for k in -30..=30 {
            let edge = (k as f32 - 0.5).to_radians();
            assert_eq!(at(edge.to_degrees() + 1e-3), Some(k as f32), "edge below bin {k}");
        }
    }

    #[test]
    fn level_camera_user_frame_has_left_as_minus_camera_x() {
        let plane = Plane { normal: [0.0, -1.0, 0.0], offset_m: 1.0 };
        let f = UserFrame::from_plane(&plane).unwrap();
        // camera point 1 m right, on the floor (y down = +1), 2 m ahead
        let u = f.to_user(&[1.0, 1.0, 2.0]);
        assert!((u[0] - 2.0).abs() < 1e-6 && (u[1] + 1.0).abs() < 1e-6 && u[2].abs() < 1e-6);
        let back = f.to_camera(&u);
        assert!((back[0] - 1.0).abs() < 1e-6 && (back[1] - 1.0).abs() < 1e-6 && (back[2] - 2.0).abs() < 1e-6);
        assert!(f.pitch_down_rad().abs() < 1e-6);
    }

    #[test]
    fn camera_looking_straight_down_has_no_user_frame() {
        let plane = Plane { normal: [0.0, 0.0, -1.0], offset_m: 1.0 };
        assert!(UserFrame::from_plane(&plane).is_none());
    }
}
