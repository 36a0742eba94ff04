//! Beyond the thesis: drop-offs and steps down. Every pixel ray whose crossing with the
//! ground plane falls in the path ahead should see ground there (or something standing
//! on it). When, for enough of those rays, the point lies clearly below the plane (a
//! step down, a platform edge) or there is no return at all (a stairwell beyond range,
//! a hole), the ground ahead is missing or lower: a hazard the cost functions, which only
//! look up, cannot see.
//!
//! Missing returns are only known for depth input (its pixels have rays without a
//! depth); an xyz cloud's invalid points carry no ray, so there only lower ground counts.

use super::config::DropoffConfig;
use super::ground_plane::dot;
use super::nearest_scan::UserFrame;
use super::organized_cloud::SampledCloud;

/// Slices of the path ahead the survey counts separately: a step at 1.3 m fills only
/// the slices beyond it, so a fraction over the whole path would dilute it.
pub const SLICES: usize = 8;

/// What the rays into the path ahead found.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PathGround {
    /// Rays whose ground crossing lies in the path.
    pub expected: u32,
    /// Of those, returns clearly below the plane.
    pub lower: u32,
    /// Of those, no return.
    pub missing: u32,
    /// Nearest distance ahead where the ground is lower or missing, metres.
    pub drop_at_m: Option<f32>,
}

/// Counts the rays into the path ahead by what they found.
pub fn survey(cloud: &SampledCloud, frame: &UserFrame, cfg: &DropoffConfig) -> PathGround {
    let n = frame.plane.normal;
    let d = frame.plane.offset_m;
    let half_w = cfg.path_width_m * 0.5;
    let slice_m = cfg.lookahead_m / SLICES as f32;
    let mut expected = [0u32; SLICES];
    let mut absent = [0u32; SLICES];
    let mut g = PathGround::default();
    // every other sampled row and column: the slices need hundreds of rays, not thousands
    for i in (0..cloud.rows).step_by(2).flat_map(|r| (0..cloud.cols).step_by(2).map(move |c| r * cloud.cols + c)) {
        let p = &cloud.points[i];
        let valid = p[2].is_finite();
        let ray = if valid {
            *p
        } else {
            match cloud.ray(i) {
                Some(r) => r,
                None => continue,
            }
        };
        let down = dot(&n, &ray);
        if down >= -1e-6 {
            continue; // the ray never meets the ground
        }
        let t = -d / down;
        let (x, y) = (t * dot(&frame.forward, &ray), t * dot(&frame.left, &ray));
        if x <= 0.0 || x >= cfg.lookahead_m || y.abs() > half_w {
            continue;
        }
        let s = ((x / slice_m) as usize).min(SLICES - 1);
        expected[s] += 1;
        g.expected += 1;
        if !valid {
            g.missing += 1;
            absent[s] += 1;
        } else if down + d < -cfg.min_drop_m {
            // `down` is n.p for a valid point, so `down + d` is its height
            g.lower += 1;
            absent[s] += 1;
        }
    }
    let slice_min = (cfg.min_samples as usize).div_ceil(SLICES) as u32;
    g.drop_at_m = (0..SLICES)
        .find(|&s| expected[s] >= slice_min.max(1) && absent[s] as f32 >= cfg.min_fraction * expected[s] as f32)
        .map(|s| s as f32 * slice_m);
    g
}

impl PathGround {
    /// True when some slice of the path ahead is mostly lower or missing.
    pub fn is_dropoff(&self) -> bool {
        self.drop_at_m.is_some()
    }
}
