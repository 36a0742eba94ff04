//! Beyond the thesis: drop-offs and steps down. Every pixel ray whose crossing with the
//! ground plane falls in the path ahead should see ground there (or something standing
//! on it). When, for enough of those rays, the point lies clearly below the plane (a
//! step down, a platform edge) or there is no return at all (a stairwell beyond range,
//! a hole), the ground ahead is missing or lower: a hazard the cost functions, which only
//! look up, cannot see.
//!
//! Missing returns are only known for depth input (its pixels have rays without a
//! depth); an xyz cloud's invalid points carry no ray, so there only lower ground counts.
//!
//! The survey only looks along the path. A user turning back towards the goal past a
//! step's corner cuts it beside the path, after it left the view: on `step-down`
//! (`wearnav course`, sound guide, hysteresis off) 3 of 10 walks grazed the sunken
//! area's corner with nothing felt. So [`edges`] also gives the edge itself, across the
//! whole view, as obstacle points on the floor: the cost functions steer round it like
//! round a wall, and the memory keeps it once it is out of view.

use super::config::DropoffConfig;
use super::ground_plane::{dot, normalized};
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

/// Fewest lower returns in a degree of bearing before it holds an edge point (a lone
/// noisy return is not a step).
const EDGE_MIN_RAYS: u32 = 3;

/// Lower ground across the whole view: per degree of bearing, the nearest point where
/// a ray that found ground clearly below the plane (a step down, a platform edge)
/// crossed the plane, in the user frame `(x forward, y left)`, up to `lookahead_m`. A
/// ray passing over an edge meets the plane just beyond it, so the nearest crossing
/// per bearing traces the edge. Missing returns do not count here: a black floor or a
/// far floor out of range has no return either, and only the path ahead (the survey)
/// may call those a drop-off.
///
/// Only on a plane the IMU confirms level (within `edge_max_tilt_deg` of gravity's up;
/// nothing without gravity): on `taylor-course`, a flat floor, the ground search now and
/// then accepts for one frame a plane 6-20 degrees off gravity (inside its 20 degree
/// cone) and hundreds of floor returns fall below it; with a level plane (99.9 % of
/// frames within 2 degrees there) a lower floor is a real one.
pub fn edges(
    cloud: &SampledCloud,
    frame: &UserFrame,
    gravity_camera: Option<[f32; 3]>,
    cfg: &DropoffConfig,
    out: &mut Vec<[f32; 2]>,
) {
    out.clear();
    let level = gravity_camera
        .and_then(|g| normalized(&[-g[0], -g[1], -g[2]]))
        .is_some_and(|up| dot(&up, &frame.plane.normal) >= cfg.edge_max_tilt_deg.to_radians().cos());
    if !level {
        return;
    }
    const BINS: usize = 180;
    let mut nearest = [(f32::INFINITY, [0.0f32; 2], 0u32); BINS];
    let n = frame.plane.normal;
    let d = frame.plane.offset_m;
    // every other sampled row and column, as the survey: a degree of bearing still
    // holds a few columns, and the edge is where many rows meet it
    for i in (0..cloud.rows).step_by(2).flat_map(|r| (0..cloud.cols).step_by(2).map(move |c| r * cloud.cols + c)) {
        let p = &cloud.points[i];
        let down = dot(&n, p);
        if !p[2].is_finite() || down + d >= -cfg.min_drop_m || down >= -1e-6 {
            continue; // not clearly below the plane (or a ray that never meets it)
        }
        let t = -d / down;
        let (x, y) = (t * dot(&frame.forward, p), t * dot(&frame.left, p));
        let r = x.hypot(y);
        if x <= 0.0 || r > cfg.lookahead_m {
            continue;
        }
        let bin = ((y.atan2(x).to_degrees() + 90.0) as usize).min(BINS - 1);
        let slot = &mut nearest[bin];
        slot.2 += 1;
        if r < slot.0 {
            (slot.0, slot.1) = (r, [x, y]);
        }
    }
    out.extend(nearest.iter().filter(|s| s.2 >= EDGE_MIN_RAYS).map(|s| s.1));
}

impl PathGround {
    /// True when some slice of the path ahead is mostly lower or missing.
    pub fn is_dropoff(&self) -> bool {
        self.drop_at_m.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::perception::ground_plane::Plane;
    use crate::perception::synthetic_scene::Scene;

    /// The sampled cloud of `scene` (stride 2), the user frame of a floor plane pitched
    /// `plane_error_deg` more than the true one, and the true gravity.
    fn cloud_and_frame(scene: &Scene, plane_error_deg: f32) -> (SampledCloud, UserFrame, Option<[f32; 3]>) {
        let mut cloud = SampledCloud::default();
        let depth = scene.render_depth(0.001);
        cloud.from_depth(&depth, scene.width, scene.height, 0.001, scene.intrinsics, 2).unwrap();
        let (s, c) = (scene.pitch_deg + plane_error_deg).to_radians().sin_cos();
        let plane = Plane { normal: [0.0, -c, -s], offset_m: scene.height_m };
        let [a, b, cz, _] = scene.floor_plane_camera();
        (cloud, UserFrame::from_plane(&plane).unwrap(), Some([-a, -b, -cz]))
    }

    #[test]
    fn a_step_down_across_the_view_is_an_edge_at_its_distance_when_the_imu_agrees() {
        let mut scene = Scene::kinect(1.0, 30.0);
        scene.step = Some((1.3, 0.18));
        let (cloud, frame, gravity) = cloud_and_frame(&scene, 0.0);
        let mut out = Vec::new();
        edges(&cloud, &frame, gravity, &DropoffConfig::default(), &mut out);
        // a degree per bearing across the ~62 degree view, each at the edge's 1.3 m
        assert!(out.len() >= 50, "{} edge points", out.len());
        for &[x, y] in &out {
            assert!((x - 1.3).abs() < 0.05, "edge point at {x}, {y}");
        }
        // no IMU: no way to tell a lower floor from a tilted plane
        edges(&cloud, &frame, None, &DropoffConfig::default(), &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn a_flat_floor_under_a_plane_off_gravity_has_no_edge() {
        let scene = Scene::kinect(1.0, 30.0);
        let (cloud, frame, gravity) = cloud_and_frame(&scene, 0.0);
        let mut out = Vec::new();
        edges(&cloud, &frame, gravity, &DropoffConfig::default(), &mut out);
        assert!(out.is_empty(), "true plane: {out:?}");
        // a plane 8 degrees off (as the ground search accepts now and then for a frame):
        // the floor falls more than 8 cm below it within the 2 m looked at
        let (cloud, frame, gravity) = cloud_and_frame(&scene, 8.0);
        let below = cloud
            .valid
            .iter()
            .map(|&i| &cloud.points[i as usize])
            .filter(|p| frame.plane.height(p) < -0.08)
            .filter(|p| -frame.plane.offset_m / dot(&frame.plane.normal, p) * dot(&frame.forward, p) < 2.0)
            .count();
        assert!(below > 100, "the tilted plane puts {below} returns within 2 m 8 cm under it");
        edges(&cloud, &frame, gravity, &DropoffConfig::default(), &mut out);
        assert!(out.is_empty(), "tilted plane: {} edge points", out.len());
    }
}
