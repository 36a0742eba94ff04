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
//! round a wall, and the memory keeps it once it is out of view. Lower ground that
//! begins at the bottom of the view may begin anywhere on the unseen floor nearer the
//! user: [`LowerGround::unseen`] fills it, and the memory keeps the part of it the
//! floor was not seen at as the user came.

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

/// Lower ground whose nearest crossing is within this of the nearest ground the view
/// reaches in that degree starts where the view does, metres (sampled rows meet the
/// floor about 2 cm apart at the bottom of a view pitched 30 degrees down).
const VIEW_EDGE_MARGIN_M: f32 = 0.05;

/// The unseen floor is guessed only from lower ground at most this far below the
/// plane, metres (a stair step, a curb): a floor read farther below is mostly a plane
/// on a false ground (a seat; at 10 degrees pitch the tracker now and then holds a
/// plane 0.3 m under the camera), and guessing from it filled the path to the toes on
/// a flat course (`wearnav course --pitch-deg 10`, FICF, 20 walks: 5.15 -> 5.60 cane
/// contacts a walk). A deeper drop is still an edge, and the survey's stop.
const UNSEEN_MAX_DROP_M: f32 = 0.3;

/// Spacing of the points that fill the unseen floor between the user and lower ground
/// starting at the bottom of the view, metres (the memory's cell).
const UNSEEN_STEP_M: f32 = 0.1;

/// Nearest of those points along the degree, metres; from there they head for the
/// toes.
const UNSEEN_MIN_M: f32 = 0.2;

/// How far ahead of the feet the toes reach, metres: the feet stand on the floor, so
/// the unseen floor that may be lower stops there.
const TOES_M: f32 = 0.15;

/// The floor the next step lands on begins this far ahead of the feet, metres (the
/// feet's own floor is stood on): from there to the camera, where the cost functions'
/// view begins, nothing but this check watches it.
const STEP_FROM_M: f32 = 0.1;

/// Half the width of that floor, metres (the feet, a shoulder width apart at most).
const STEP_HALF_WIDTH_M: f32 = 0.2;

/// The floor between the feet and the camera that the next step lands on, user frame.
/// The cost functions take only what lies ahead of the camera, so lower ground here (a
/// user who turned in place at a step's edge and faces along it, or off its corner)
/// would otherwise be walked onto unwarned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepZone {
    /// Where it begins, `x` metres (behind the camera: negative).
    pub from_m: f32,
    /// Where it ends, `x` metres (at most 0: the camera).
    pub to_m: f32,
    /// Half its width, metres.
    pub half_width_m: f32,
}

impl StepZone {
    /// The zone for feet `cfg.feet_behind_camera_m` behind the camera.
    pub fn new(cfg: &DropoffConfig) -> Self {
        Self { from_m: (STEP_FROM_M - cfg.feet_behind_camera_m).min(0.0), to_m: 0.0, half_width_m: STEP_HALF_WIDTH_M }
    }

    /// Whether user point `p` lies in it.
    pub fn contains(&self, p: [f32; 2]) -> bool {
        (self.from_m..=self.to_m).contains(&p[0]) && p[1].abs() <= self.half_width_m
    }
}

/// Side of the squares the floor returns are thinned to, metres (half the memory's
/// 10 cm cell, so every cell the floor was seen in gets one).
const FLOOR_GRID_M: f32 = 0.05;

/// What [`edges`] found, user frame `(x forward, y left)`, metres.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct LowerGround {
    /// Per degree of bearing, where lower ground begins in view.
    pub edge: Vec<[f32; 2]>,
    /// Floor the camera cannot see between the user and lower ground that begins at the
    /// bottom of the view: the edge may be anywhere there. Floor seen before (walked
    /// towards) is not lower; the memory tells them apart
    /// ([`super::obstacle_memory::ObstacleMemory::unseen_lower`]).
    pub unseen: Vec<[f32; 2]>,
    /// Returns on the floor plane (within `min_drop_m` of it), one per `FLOOR_GRID_M`
    /// square: the memory keeps 10 cm cells, and a view of floor holds thousands.
    pub floor: Vec<[f32; 2]>,
    // which squares of the grid hold a floor return this frame
    floor_grid: Vec<bool>,
}

impl LowerGround {
    /// Empties every list.
    pub fn clear(&mut self) {
        self.edge.clear();
        self.unseen.clear();
        self.floor.clear();
        self.floor_grid.clear();
    }
}

/// Lower ground across the whole view: per degree of bearing, the nearest point where
/// a ray that found ground clearly below the plane (a step down, a platform edge)
/// crossed the plane, in the user frame `(x forward, y left)`, up to `lookahead_m`. A
/// ray passing over an edge meets the plane just beyond it, so the nearest crossing
/// per bearing traces the edge. Missing returns do not count here: a black floor or a
/// far floor out of range has no return either, and only the path ahead (the survey)
/// may call those a drop-off.
///
/// Lower ground that starts at the bottom of the view has its edge somewhere on the
/// floor the camera cannot see, between the user's feet and the view: that degree also
/// gets `unseen` points every `UNSEEN_STEP_M` down to `UNSEEN_MIN_M`, then on to the
/// toes (`TOES_M` ahead of the feet, `feet_behind_camera_m` behind the camera).
/// Standing at the edge of a sunken area, a user turning in place saw only its far
/// floor (the view starts 0.72 m ahead with the camera 30 degrees down), the edge under
/// the feet was never seen, and walking along it the body stepped off it with nothing
/// felt (`wearnav course`, `step-down`, sound guide, seed 4).
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
    out: &mut LowerGround,
) {
    out.clear();
    let level = gravity_camera
        .and_then(|g| normalized(&[-g[0], -g[1], -g[2]]))
        .is_some_and(|up| dot(&up, &frame.plane.normal) >= cfg.edge_max_tilt_deg.to_radians().cos());
    if !level {
        return;
    }
    const BINS: usize = 180;
    // per degree: range, point and height of the nearest lower return, lower returns
    let mut nearest = [(f32::INFINITY, [0.0f32; 2], 0u32, 0.0f32); BINS];
    // per degree, the nearest floor the view reaches (the bottom rows' rays, returned
    // or not: the floor nearest in a column is its bottom row's)
    let mut view_starts = [f32::INFINITY; BINS];
    let n = frame.plane.normal;
    let d = frame.plane.offset_m;
    let lookahead2 = cfg.lookahead_m * cfg.lookahead_m;
    let bottom_from = cloud.rows.saturating_sub(4);
    // the floor returns a grid of FLOOR_GRID_M over x 0..lookahead, y -lookahead..lookahead
    let grid_w = (2.0 * cfg.lookahead_m / FLOOR_GRID_M) as usize + 1;
    out.floor_grid.resize(grid_w * ((cfg.lookahead_m / FLOOR_GRID_M) as usize + 1), false);
    // every other sampled row and column, as the survey: a degree of bearing still
    // holds a few columns, and the edge is where many rows meet it
    for row in (0..cloud.rows).step_by(2) {
        let bottom = row >= bottom_from;
        for i in (0..cloud.cols).step_by(2).map(|c| row * cloud.cols + c) {
            let p = &cloud.points[i];
            let valid = p[2].is_finite();
            // a return's height above the plane
            let h = if valid { dot(&n, p) + d } else { f32::NAN };
            if valid && h.abs() < cfg.min_drop_m {
                // on the floor: the point is its own crossing; one per grid cell
                let (x, y) = (dot(&frame.forward, p), dot(&frame.left, p));
                if x > 0.0 && x * x + y * y <= lookahead2 {
                    let (gx, gy) = ((x / FLOOR_GRID_M) as usize, ((y + cfg.lookahead_m) / FLOOR_GRID_M) as usize);
                    if let Some(cell) = out.floor_grid.get_mut(gx * grid_w + gy).filter(|c| !**c) {
                        *cell = true;
                        out.floor.push([x, y]);
                    }
                }
            }
            let lower = valid && h <= -cfg.min_drop_m;
            if !(lower || bottom) {
                continue; // only lower returns and the view's start need the crossing
            }
            let Some(ray) = (if valid { Some(*p) } else { cloud.ray(i) }) else {
                continue;
            };
            let down = dot(&n, &ray);
            if down >= -1e-6 {
                continue; // a ray that never meets the ground
            }
            let t = -d / down;
            let (x, y) = (t * dot(&frame.forward, &ray), t * dot(&frame.left, &ray));
            let r = x.hypot(y);
            if x <= 0.0 || r > cfg.lookahead_m {
                continue;
            }
            let bin = ((y.atan2(x).to_degrees() + 90.0) as usize).min(BINS - 1);
            if bottom {
                view_starts[bin] = view_starts[bin].min(r);
            }
            if lower {
                let slot = &mut nearest[bin];
                slot.2 += 1;
                if r < slot.0 {
                    (slot.0, slot.1, slot.3) = (r, [x, y], h);
                }
            }
        }
    }
    for (slot, &start) in nearest.iter().zip(&view_starts) {
        if slot.2 < EDGE_MIN_RAYS {
            continue;
        }
        out.edge.push(slot.1);
        let step = slot.3 >= -UNSEEN_MAX_DROP_M;
        if step && start.is_finite() && slot.0 <= start + VIEW_EDGE_MARGIN_M {
            // along the degree, then on to the toes
            let [x, y] = slot.1;
            let mut r = slot.0 - UNSEEN_STEP_M;
            let mut last = [x, y];
            while r >= UNSEEN_MIN_M {
                let f = r / slot.0;
                last = [x * f, y * f];
                out.unseen.push(last);
                r -= UNSEEN_STEP_M;
            }
            let toes = [TOES_M - cfg.feet_behind_camera_m, 0.0];
            let span = (last[0] - toes[0]).hypot(last[1] - toes[1]);
            let steps = (span / UNSEEN_STEP_M) as usize;
            for k in 1..steps {
                let f = k as f32 / steps as f32;
                out.unseen.push([last[0] + f * (toes[0] - last[0]), last[1] + f * (toes[1] - last[1])]);
            }
        }
    }
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
    use crate::ground_plane::Plane;
    use crate::synthetic_scene::Scene;

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
        let mut out = LowerGround::default();
        edges(&cloud, &frame, gravity, &DropoffConfig::default(), &mut out);
        // a degree per bearing across the ~62 degree view, each at the edge's 1.3 m
        assert!(out.edge.len() >= 50, "{} edge points", out.edge.len());
        for &[x, y] in &out.edge {
            assert!((x - 1.3).abs() < 0.05, "edge point at {x}, {y}");
        }
        // the floor before it is seen: nothing is left to guess
        assert!(out.unseen.is_empty(), "{:?}", out.unseen);
        // ... seen as floor, one return per 5 cm square (0.72-1.3 m ahead, 0.8-1.5 m wide)
        assert!(out.floor.iter().all(|p| p[0] < 1.3), "{:?}", out.floor);
        assert!((250..500).contains(&out.floor.len()), "{} floor points", out.floor.len());
        // no IMU: no way to tell a lower floor from a tilted plane
        edges(&cloud, &frame, None, &DropoffConfig::default(), &mut out);
        assert!(out.edge.is_empty() && out.floor.is_empty());
    }

    #[test]
    fn lower_ground_from_the_bottom_of_the_view_may_begin_anywhere_nearer() {
        // the view (30 deg down) reaches the floor about 0.72 m ahead: a step at 0.5 m
        // is lower ground in every row, its edge unseen
        let mut scene = Scene::kinect(1.0, 30.0);
        scene.step = Some((0.5, 0.18));
        let (cloud, frame, gravity) = cloud_and_frame(&scene, 0.0);
        let mut out = LowerGround::default();
        edges(&cloud, &frame, gravity, &DropoffConfig::default(), &mut out);
        assert!(out.edge.len() >= 50, "{} edge points", out.edge.len());
        let nearest_edge = out.edge.iter().map(|p| p[0]).fold(f32::INFINITY, f32::min);
        assert!((0.68..0.76).contains(&nearest_edge), "the view begins at {nearest_edge}");
        // every 0.1 m from there down to 0.2 m along each degree, then on to the toes
        // (0.35 m behind the camera, 0.15 m ahead of the feet: x = -0.2 m)
        let straight_ahead: Vec<f32> =
            out.unseen.iter().filter(|p| p[1].abs() < 0.01).map(|p| (p[0] * 100.0).round() / 100.0).collect();
        assert!(straight_ahead.len() >= 8, "{straight_ahead:?}");
        assert!(straight_ahead.iter().all(|&x| (-0.2..nearest_edge).contains(&x)), "{straight_ahead:?}");
        assert!(straight_ahead.iter().any(|&x| x < -0.05), "{straight_ahead:?}");
        // the outermost degrees head for the toes too
        let toes = out.unseen.iter().filter(|p| p[0] < 0.0 && p[1].abs() > 0.02).count();
        assert!(toes > 50, "{toes} points behind the camera off its axis");
        // a floor 0.5 m below the plane is more likely a plane on a false ground than a
        // step: an edge, but nothing guessed from it
        scene.step = Some((0.5, 0.5));
        let (cloud, frame, gravity) = cloud_and_frame(&scene, 0.0);
        edges(&cloud, &frame, gravity, &DropoffConfig::default(), &mut out);
        assert!(out.edge.len() >= 50 && out.unseen.is_empty(), "{} edge, {} unseen", out.edge.len(), out.unseen.len());
        assert!(out.floor.is_empty(), "no floor in view: {} points", out.floor.len());
    }

    #[test]
    fn a_flat_floor_under_a_plane_off_gravity_has_no_edge() {
        let scene = Scene::kinect(1.0, 30.0);
        let (cloud, frame, gravity) = cloud_and_frame(&scene, 0.0);
        let mut out = LowerGround::default();
        edges(&cloud, &frame, gravity, &DropoffConfig::default(), &mut out);
        assert!(out.edge.is_empty() && out.unseen.is_empty(), "true plane: {out:?}");
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
        assert!(out.edge.is_empty() && out.unseen.is_empty(), "tilted plane: {} edge points", out.edge.len());
    }

    #[test]
    fn the_step_zone_runs_from_just_ahead_of_the_feet_to_the_camera() {
        let cfg = DropoffConfig::default();
        let zone = StepZone::new(&cfg);
        assert_eq!((zone.from_m, zone.to_m, zone.half_width_m), (0.1 - cfg.feet_behind_camera_m, 0.0, 0.2));
        // the toes' guess (0.15 m ahead of the feet) is in it, the feet's own floor and
        // what lies ahead of the camera (the costs' own) are not, nor floor beside the feet
        let toes = [0.15 - cfg.feet_behind_camera_m, 0.0];
        assert!(zone.contains(toes));
        assert!(!zone.contains([0.05 - cfg.feet_behind_camera_m, 0.0]));
        assert!(![[0.05, 0.0], [-0.1, 0.25], [-0.1, -0.25]].into_iter().any(|p| zone.contains(p)));
        // a camera 5 cm ahead of the feet: no floor the next step lands on lies before it
        let near = StepZone::new(&DropoffConfig { feet_behind_camera_m: 0.05, ..cfg });
        assert_eq!(near.from_m, 0.0);
        assert!(!near.contains(toes) && !near.contains([-0.01, 0.0]));
    }
}
