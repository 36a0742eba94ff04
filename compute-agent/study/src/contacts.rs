//! Contacts by geometry, counted as Taylor (2017, Tables 3.2-3.3) counted them: the
//! cane (its line from hand to tip) and the body (a vertical cylinder of shoulder width,
//! 1.8 m tall, so head-high obstacles count) against the world's obstacles. A contact
//! is counted once per obstacle per touch: when it begins; it ends only once the part
//! is [`RELEASE_M`] clear again, so grazing along a wall is one contact, not hundreds.
//!
//! Each contact records whether the obstacle was in the camera's field of view at that
//! moment (any point of its surface inside the image and the camera's depth range,
//! occlusion ignored) and how long ago the camera last got depth from it: the first
//! says which contacts the camera could have prevented then, the second whether
//! memory beyond the field of view could have.

use nalgebra::Vector3;
use sim::render::{EMPTY_PIXEL, FLOOR_PIXEL};
use sim::shape::Shape;
use sim::{CameraPose, CameraProfile, ObstacleId, World};

/// A part touching is at most this far from the obstacle, metres (the cane's distance
/// is sampled every 1 cm along it, so exact to 5 mm).
pub const TOUCH_M: f64 = 0.005;
/// A contact ends once the part is this far clear, metres.
pub const RELEASE_M: f64 = 0.03;
/// Spacing of the surface points the field-of-view test projects, metres.
const SURFACE_STEP_M: f64 = 0.05;
/// Most surface points per shape edge (a 10 m wall is sampled every 5 cm up to this).
const MAX_STEPS: usize = 400;

/// Distance from the cane (the segment `hand`–`tip`) to `shape`, metres: exact within
/// `exact_within_m`, a cheap lower bound beyond it; a drop-off is never touched by the
/// cane (the feet find it).
pub fn cane_distance_m(shape: &Shape, hand: [f64; 3], tip: [f64; 3], exact_within_m: f64) -> f64 {
    match shape {
        Shape::DropOff(_) => f64::INFINITY,
        _ => match shape.segment_distance_lower_bound_m(hand, tip) {
            far if far > exact_within_m => far,
            _ => shape.segment_distance_m(hand, tip),
        },
    }
}

/// Which part of the user touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    /// The cane, hand to tip.
    Cane,
    /// The body cylinder.
    Body,
}

/// One contact.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Contact {
    /// When it began, seconds into the walk.
    pub t_s: f64,
    /// Cane or body.
    pub part: Part,
    /// Obstacle index in the world.
    pub obstacle: u32,
    /// Obstacle label.
    pub label: String,
    /// Obstacle kind (`Wall`, `Hanging`, ...).
    pub kind: String,
    /// Some of its surface was inside the camera's image and depth range at that moment.
    pub in_fov: bool,
    /// Seconds since the camera last got depth from it; `None`: never in this walk.
    pub seen_ago_s: Option<f64>,
    /// Seconds the user's hands had felt a cue (a rumble, or detection offline) without
    /// a break when the contact began; `None`: nothing was felt. Shorter than the
    /// walk's reaction time: the warning came too late to act on.
    pub warned_ago_s: Option<f64>,
    /// The touched part of the obstacle is entirely above the cane's handle: only the
    /// camera (or the head) can find it.
    pub head_high: bool,
}

/// Per-obstacle contact state of one part, and the distances of the last query.
#[derive(Debug, Clone, Default)]
pub struct Touching {
    in_contact: Vec<bool>,
    /// Distance per obstacle at the last query, metres (`INFINITY`: not on this floor;
    /// farther than [`RELEASE_M`] it may be a lower bound, as the caller's `distance` gave it).
    pub distance_m: Vec<f64>,
    /// Lowest bottom of the shapes within [`TOUCH_M`] per obstacle, metres.
    pub touch_bottom_m: Vec<f64>,
}

impl Touching {
    /// State for a world with `obstacles` obstacles.
    pub fn new(obstacles: usize) -> Self {
        Self {
            in_contact: vec![false; obstacles],
            distance_m: vec![f64::INFINITY; obstacles],
            touch_bottom_m: vec![f64::INFINITY; obstacles],
        }
    }

    /// Measures every obstacle with `distance` (per shape) into `distance_m`.
    pub fn measure(&mut self, world: &World, floor: i32, t_s: f64, distance: impl Fn(&Shape) -> f64) {
        self.distance_m.iter_mut().for_each(|d| *d = f64::INFINITY);
        self.touch_bottom_m.iter_mut().for_each(|d| *d = f64::INFINITY);
        for (id, shape) in world.obstacles_at(floor, t_s) {
            let i = id.0 as usize;
            if i >= self.distance_m.len() {
                continue;
            }
            let d = distance(&shape);
            self.distance_m[i] = self.distance_m[i].min(d);
            if d <= TOUCH_M {
                self.touch_bottom_m[i] = self.touch_bottom_m[i].min(shape.bounds_m().0[2]);
            }
        }
    }

    /// Obstacles whose contact begins with the last measurement; updates the state.
    pub fn entering(&mut self) -> Vec<ObstacleId> {
        let mut out = Vec::new();
        for (i, (&d, touching)) in self.distance_m.iter().zip(self.in_contact.iter_mut()).enumerate() {
            if d <= TOUCH_M && !*touching {
                *touching = true;
                out.push(ObstacleId(i as u32));
            } else if d > RELEASE_M {
                *touching = false;
            }
        }
        out
    }

    /// Smallest distance of the last measurement, metres.
    pub fn nearest_m(&self) -> f64 {
        self.distance_m.iter().copied().fold(f64::INFINITY, f64::min)
    }
}

/// When the camera last got a depth reading from each obstacle.
#[derive(Debug, Clone, Default)]
pub struct SeenLog {
    last_s: Vec<Option<f64>>,
}

impl SeenLog {
    /// A log for `obstacles` obstacles.
    pub fn new(obstacles: usize) -> Self {
        Self { last_s: vec![None; obstacles] }
    }

    /// Marks what a frame saw: the renderer's per-pixel obstacle ids, counted where the
    /// frame delivered depth (after dropouts and range limits).
    pub fn update(&mut self, ids: &[u32], depth: &[u16], t_s: f64) {
        for (&id, &z) in ids.iter().zip(depth) {
            if z != 0 && id != FLOOR_PIXEL && id != EMPTY_PIXEL {
                if let Some(slot) = self.last_s.get_mut(id as usize) {
                    *slot = Some(t_s);
                }
            }
        }
    }

    /// Seconds since `id` was last seen at `t_s`.
    pub fn ago_s(&self, id: ObstacleId, t_s: f64) -> Option<f64> {
        self.last_s.get(id.0 as usize).copied().flatten().map(|s| t_s - s)
    }
}

/// True when a map point (height above the floor) projects into the image within the
/// camera's depth range.
fn projects(camera: &CameraPose, profile: &CameraProfile, p: [f64; 3]) -> bool {
    let c = camera.camera_to_map.inverse() * (Vector3::new(p[0], p[1], p[2]) - camera.position_m);
    if c.z < profile.min_depth_m || c.z > profile.max_depth_m {
        return false;
    }
    let k = profile.intrinsics();
    let u = k.fx as f64 * c.x / c.z + k.cx as f64;
    let v = k.fy as f64 * c.y / c.z + k.cy as f64;
    (-0.5..=profile.width as f64 - 0.5).contains(&u) && (-0.5..=profile.height as f64 - 0.5).contains(&v)
}

fn steps(length_m: f64) -> usize {
    ((length_m / SURFACE_STEP_M).ceil() as usize).clamp(1, MAX_STEPS)
}

/// Samples of `0..=1` at about [`SURFACE_STEP_M`] over `length_m`.
fn fractions(length_m: f64) -> impl Iterator<Item = f64> + Clone {
    let n = steps(length_m);
    (0..=n).map(move |i| i as f64 / n as f64)
}

/// Surface points of a turned footprint (rectangle) between two heights: the four sides
/// and the top and bottom faces.
fn box_surface_any(
    center: [f64; 2],
    half: [f64; 2],
    yaw: f64,
    bottom: f64,
    top: f64,
    hit: &mut dyn FnMut([f64; 3]) -> bool,
) -> bool {
    let (s, c) = yaw.sin_cos();
    let at = |a: f64, b: f64, z: f64| [center[0] + c * a - s * b, center[1] + s * a + c * b, z];
    let (lx, ly, lz) = (2.0 * half[0], 2.0 * half[1], top - bottom);
    for fz in fractions(lz) {
        let z = bottom + fz * lz;
        for fa in fractions(lx) {
            let a = -half[0] + fa * lx;
            if hit(at(a, -half[1], z)) || hit(at(a, half[1], z)) {
                return true;
            }
        }
        for fb in fractions(ly) {
            let b = -half[1] + fb * ly;
            if hit(at(-half[0], b, z)) || hit(at(half[0], b, z)) {
                return true;
            }
        }
    }
    for fa in fractions(lx) {
        for fb in fractions(ly) {
            let (a, b) = (-half[0] + fa * lx, -half[1] + fb * ly);
            if hit(at(a, b, top)) || hit(at(a, b, bottom)) {
                return true;
            }
        }
    }
    false
}

/// True when any surface point of obstacle `id` at `t_s` is inside the camera's image
/// and depth range (occlusion ignored).
pub fn in_field_of_view(world: &World, id: ObstacleId, camera: &CameraPose, profile: &CameraProfile, t_s: f64) -> bool {
    let mut hit = |p: [f64; 3]| projects(camera, profile, p);
    for (_, shape) in world.obstacles_at(camera.floor, t_s).filter(|(i, _)| *i == id) {
        let found = match shape {
            Shape::Box(b) => box_surface_any(b.center_m, b.half_size_m, b.yaw_rad, b.bottom_m, b.top_m, &mut hit),
            Shape::DropOff(d) => box_surface_any(d.center_m, d.half_size_m, d.yaw_rad, -d.depth_m, 0.0, &mut hit),
            Shape::Cylinder(cyl) => {
                let around = std::f64::consts::TAU * cyl.radius_m;
                let height = cyl.top_m - cyl.bottom_m;
                let mut any = false;
                'outer: for fz in fractions(height) {
                    let z = cyl.bottom_m + fz * height;
                    for fa in fractions(around.max(8.0 * SURFACE_STEP_M)) {
                        let (s, c) = (fa * std::f64::consts::TAU).sin_cos();
                        for r in [cyl.radius_m, 0.5 * cyl.radius_m, 0.0] {
                            // the side, and the caps at the top and bottom rows
                            if (r < cyl.radius_m && fz > 0.0 && fz < 1.0)
                                || !hit([cyl.center_m[0] + r * c, cyl.center_m[1] + r * s, z])
                            {
                                continue;
                            }
                            any = true;
                            break 'outer;
                        }
                    }
                }
                any
            }
        };
        if found {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use sim::{CaneMount, UserPose};

    fn world(items: &str) -> World {
        let text =
            format!("name = \"t\"\nstart = {{ x_m = 0.0, y_m = 0.0 }}\ngoal = {{ x_m = 9.0, y_m = 0.0 }}\n{items}");
        match World::from_toml(&text, "test") {
            Ok(w) => w,
            Err(e) => panic!("{e}"),
        }
    }

    #[test]
    fn grazing_a_wall_is_one_contact_until_clear_again() {
        let w = world("[[walls]]\nfrom = [0.0, 1.0]\nto = [9.0, 1.0]\n");
        let mut t = Touching::new(w.obstacles().len());
        let mut count = 0;
        // body radius 0.225: wall face at y = 0.95; body centre walks at 0.73, then 0.70, 0.74, 0.60
        for y in [0.70, 0.726, 0.73, 0.72, 0.74, 0.60, 0.73] {
            t.measure(&w, 0, 0.0, |s| s.body_distance_m(1.0, y, 0.225, 1.8));
            count += t.entering().len();
        }
        assert_eq!(count, 2, "touch at 0.726, graze, clear at 0.60, touch again at 0.73");
    }

    #[test]
    fn head_high_sign_is_outside_a_camera_pitched_30_degrees_down_but_a_low_box_ahead_is_inside() {
        let w = world(
            "[[hanging]]\nlabel = \"sign\"\ncenter = [2.0, 0.0]\nsize_m = [0.3, 0.9]\nbottom_m = 1.55\ntop_m = 1.85\n\
             [[boxes]]\nlabel = \"box\"\ncenter = [2.0, 3.0]\nsize_m = [0.5, 0.5]\ntop_m = 0.4\n",
        );
        let mount = CaneMount::default();
        let profile = CameraProfile::xtion();
        // scene tables are built in a fixed order: boxes before hanging obstacles
        let id = |label: &str| ObstacleId(w.obstacles().iter().position(|o| o.label == label).unwrap() as u32);
        let (sign, low_box) = (id("sign"), id("box"));
        let facing = |yaw: f64| mount.camera_pose(&UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: yaw, floor: 0 }, 0.0);
        assert!(!in_field_of_view(&w, sign, &facing(0.0), &profile, 0.0), "above the view's top edge");
        let to_box = 3f64.atan2(2.0);
        assert!(in_field_of_view(&w, low_box, &facing(to_box), &profile, 0.0));
        assert!(!in_field_of_view(&w, low_box, &facing(to_box + 1.0), &profile, 0.0), "57 degrees off to the left");
    }
}
