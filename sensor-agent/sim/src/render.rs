//! Depth rendering by ray casting, then the camera's error model.
//!
//! Per frame every shape of the camera's floor is moved once into its own frame of
//! reference and given a screen rectangle (its corners clipped at the near plane and
//! projected); only pixels inside that rectangle test it, with an analytic ray–box,
//! ray–cylinder or ray–hole intersection. Pixel ray directions are precomputed; the
//! buffers are allocated once. The floor is the plane z = 0 of the camera's floor.
//! The clean depth then goes through the model of [`CameraProfile`]: shadow bands at
//! depth edges, range-dependent dropouts, disparity noise and rounding (so depth
//! error grows with range squared, in layers), u16 mm.

use nalgebra::{Matrix3, Rotation3, Vector3};
use schemas::Intrinsics;

use super::camera::CameraProfile;
use super::pose::CameraPose;
use super::random::SimRng;
use super::shape::{DropOff, OrientedBox, VerticalCylinder};
use super::world::{ObstacleId, World};

/// Id written for a pixel that sees the floor.
pub const FLOOR_PIXEL: u32 = u32::MAX - 1;
/// Id written for a pixel that sees nothing.
pub const EMPTY_PIXEL: u32 = u32::MAX;

/// Depth units per metre of the output (millimetres).
pub const DEPTH_UNITS_PER_M: f32 = 1000.0;

/// Nearest distance a surface is rendered at, metres (nearer geometry is clipped).
const NEAR_M: f64 = 0.02;
/// Standard normal samples the noise draws from (a power of two).
const NORMAL_TABLE_LEN: usize = 4096;
/// Widest projector shadow band, pixels.
const MAX_SHADOW_PX: usize = 64;

/// A screen rectangle, inclusive pixel bounds.
#[derive(Debug, Clone, Copy)]
struct Rect {
    u0: usize,
    u1: usize,
    v0: usize,
    v1: usize,
}

/// Most points of a solid's projection: 8 corners and 12 edges cut by the near plane.
const MAX_OUTLINE: usize = 20;

/// The convex outline of a solid's projection (pixel coordinates, counter-clockwise
/// in `u`, `v`), so a row tests only the pixels between its edges.
#[derive(Debug, Clone, Copy)]
struct Outline {
    points: [[f64; 2]; MAX_OUTLINE],
    len: usize,
    /// Smallest and largest `v` of the points.
    rows: (f64, f64),
}

impl Outline {
    /// Convex hull of `points` (Andrew's monotone chain).
    fn hull(points: &mut [[f64; 2]]) -> Self {
        points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
        let turn =
            |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
        let rows = points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| (lo.min(p[1]), hi.max(p[1])));
        let mut out = Outline { points: [[0.0; 2]; MAX_OUTLINE], len: 0, rows };
        if points.len() < 3 {
            out.points[..points.len()].copy_from_slice(points);
            out.len = points.len();
            return out;
        }
        // Lower chain left to right, then upper chain right to left.
        let mut hull = [[0.0; 2]; 2 * MAX_OUTLINE];
        let mut n = 0;
        for &p in points.iter() {
            while n >= 2 && turn(hull[n - 2], hull[n - 1], p) <= 0.0 {
                n -= 1;
            }
            hull[n] = p;
            n += 1;
        }
        let lower = n + 1;
        for &p in points.iter().rev().skip(1) {
            while n >= lower && turn(hull[n - 2], hull[n - 1], p) <= 0.0 {
                n -= 1;
            }
            hull[n] = p;
            n += 1;
        }
        // The last point is the first again.
        n -= 1;
        let len = n.clamp(1, MAX_OUTLINE);
        out.points[..len].copy_from_slice(&hull[..len]);
        out.len = len;
        out
    }

    /// The `u` span of the outline on the line `v` (clamped into the outline's rows).
    fn span_at(&self, v: f64) -> (f64, f64) {
        let pts = &self.points[..self.len];
        let v = v.clamp(self.rows.0, self.rows.1);
        let (mut lo, mut hi) = (f64::MAX, f64::MIN);
        for (i, a) in pts.iter().enumerate() {
            let b = pts[(i + 1) % pts.len()];
            if (a[1] <= v && v <= b[1]) || (b[1] <= v && v <= a[1]) {
                let u = if a[1] == b[1] { a[0] } else { a[0] + (v - a[1]) * (b[0] - a[0]) / (b[1] - a[1]) };
                let other = if a[1] == b[1] { b[0] } else { u };
                lo = lo.min(u).min(other);
                hi = hi.max(u).max(other);
            }
        }
        (lo, hi)
    }
}

/// A box in its own frame for this frame: ray origin, camera-to-box rotation, size.
#[derive(Debug, Clone, Copy)]
struct FrameBox {
    origin: [f32; 3],
    rot: [[f32; 3]; 3],
    half: [f32; 3],
    rect: Rect,
    outline: Outline,
    id: u32,
}

/// A vertical cylinder for this frame: origin relative to the axis, camera-to-map rotation.
#[derive(Debug, Clone, Copy)]
struct FrameCylinder {
    origin: [f32; 3],
    radius2: f32,
    bottom: f32,
    top: f32,
    rect: Rect,
    id: u32,
}

/// A floor hole in its own frame.
#[derive(Debug, Clone, Copy)]
struct FrameHole {
    origin: [f32; 3],
    rot: [[f32; 3]; 3],
    half: [f32; 2],
    depth: f32,
    rect: Rect,
    id: u32,
}

/// Renders depth images of a [`World`] for one camera profile. Reuse it across
/// frames: all buffers are allocated in [`Renderer::new`].
#[derive(Debug, Clone)]
pub struct Renderer {
    profile: CameraProfile,
    intrinsics: Intrinsics,
    width: usize,
    height: usize,
    ray_x: Vec<f32>,
    ray_y: Vec<f32>,
    normals: Box<[f32; NORMAL_TABLE_LEN]>,
    /// The reading for each whole number of disparity steps, up to a little beyond
    /// the nearest range (one division per pixel fewer; the same bits).
    depth_of_step: Vec<u16>,
    depth_m: Vec<f32>,
    ids: Vec<u32>,
    boxes: Vec<FrameBox>,
    cylinders: Vec<FrameCylinder>,
    holes: Vec<FrameHole>,
    camera_to_map: [[f32; 3]; 3],
}

/// The u16 millimetres a disparity reads as.
fn measured_mm(focal_baseline: f32, disparity_px: f32) -> u16 {
    let mm = focal_baseline / disparity_px * DEPTH_UNITS_PER_M;
    (mm + 0.5).clamp(1.0, u16::MAX as f32) as u16
}

fn to_f32_rows(m: &Matrix3<f64>) -> [[f32; 3]; 3] {
    // Stored by columns: rot[c] is column c, so d = rot[0]*x + rot[1]*y + rot[2]*z.
    let mut out = [[0f32; 3]; 3];
    for (c, col) in out.iter_mut().enumerate() {
        for (r, v) in col.iter_mut().enumerate() {
            *v = m[(r, c)] as f32;
        }
    }
    out
}

impl Renderer {
    /// A renderer for this camera.
    pub fn new(profile: CameraProfile) -> Self {
        let k = profile.intrinsics();
        let width = profile.width as usize;
        let height = profile.height as usize;
        let ray_x = (0..width).map(|u| (u as f32 - k.cx) / k.fx).collect();
        let ray_y = (0..height).map(|v| (v as f32 - k.cy) / k.fy).collect();
        // A fixed table: the per-frame seed picks from it, so frames stay reproducible
        // while the inner loop pays one table lookup instead of a Box–Muller transform.
        let mut table_rng = SimRng::seed_from(0x5eed_4e01);
        let normals = Box::new(std::array::from_fn(|_| table_rng.gaussian() as f32));
        let focal_baseline = k.fx * profile.baseline_m as f32;
        let step_px = profile.disparity_step_px as f32;
        let depth_of_step = if step_px > 0.0 {
            let nearest_steps = (focal_baseline / profile.min_depth_m as f32 / step_px) as usize;
            (0..=nearest_steps * 2).map(|n| measured_mm(focal_baseline, n.max(1) as f32 * step_px)).collect()
        } else {
            Vec::new()
        };
        Renderer {
            profile,
            intrinsics: k,
            width,
            height,
            ray_x,
            ray_y,
            normals,
            depth_of_step,
            depth_m: vec![f32::INFINITY; width * height],
            ids: vec![EMPTY_PIXEL; width * height],
            boxes: Vec::with_capacity(256),
            cylinders: Vec::with_capacity(256),
            holes: Vec::with_capacity(16),
            camera_to_map: [[0.0; 3]; 3],
        }
    }

    /// The camera profile.
    pub fn profile(&self) -> &CameraProfile {
        &self.profile
    }

    /// The pinhole intrinsics of the images.
    pub fn intrinsics(&self) -> Intrinsics {
        self.intrinsics
    }

    /// Which obstacle each pixel of the last rendered frame saw (an [`ObstacleId`]'s
    /// number, [`FLOOR_PIXEL`] or [`EMPTY_PIXEL`]), before the error model; row-major.
    /// Shapes wholly beyond the camera's range limit are not drawn at all.
    pub fn obstacle_ids(&self) -> &[u32] {
        &self.ids
    }

    /// True when any pixel of the last frame saw `id` at a depth the camera reports
    /// (within its range limits, before dropouts): "was it in the field of view".
    pub fn saw_obstacle(&self, id: ObstacleId) -> bool {
        let (lo, hi) = (self.profile.min_depth_m as f32, self.profile.max_depth_m as f32);
        self.ids.iter().zip(&self.depth_m).any(|(&i, &z)| i == id.0 && z.abs() >= lo && z.abs() <= hi)
    }

    /// Renders what the camera at `pose` sees at time `t_s` into `out` (row-major u16
    /// millimetres, 0 = no reading), drawing noise from `rng`.
    pub fn render(&mut self, world: &World, pose: &CameraPose, t_s: f64, rng: &mut SimRng, out: &mut Vec<u16>) {
        self.render_clean(world, pose, t_s);
        self.mark_shadow_edges();
        self.apply_sensor_model(rng, out);
    }

    /// Ray-casts the exact depth (metres along the optical axis) into the z-buffer.
    fn render_clean(&mut self, world: &World, pose: &CameraPose, t_s: f64) {
        let r = pose.camera_to_map;
        let c = pose.position_m;
        let geometry = world.geometry(pose.floor);
        self.boxes.clear();
        self.cylinders.clear();
        self.holes.clear();
        self.camera_to_map = to_f32_rows(r.matrix());
        for (b, id) in &geometry.boxes {
            self.prepare_box(b, *id, &r, &c);
        }
        for (cyl, id) in &geometry.cylinders {
            self.prepare_cylinder(cyl, *id, &r, &c);
        }
        for person in world.people().iter().filter(|p| p.floor == pose.floor) {
            self.prepare_cylinder(&person.shape_at(t_s), person.id, &r, &c);
        }
        for (d, id) in &geometry.drop_offs {
            self.prepare_hole(d, *id, &r, &c);
        }
        self.draw_floor(&r, c.z);
        self.draw_holes();
        self.draw_boxes();
        self.draw_cylinders();
    }

    /// Screen rectangle of a convex solid given by its 8 corners (map frame, bit 0 =
    /// x side, bit 1 = y side, bit 2 = top), or `None` when it is behind the camera,
    /// off screen or entirely beyond the camera's range.
    fn screen_rect(&self, corners: &[Vector3<f64>; 8], r: &Rotation3<f64>, c: &Vector3<f64>) -> Option<Rect> {
        self.screen_projection(corners, r, c).map(|(rect, _, _)| rect)
    }

    /// [`Self::screen_rect`] and the projected points it bounds (`count` of them).
    fn screen_projection(
        &self,
        corners: &[Vector3<f64>; 8],
        r: &Rotation3<f64>,
        c: &Vector3<f64>,
    ) -> Option<(Rect, [[f64; 2]; MAX_OUTLINE], usize)> {
        let k = &self.intrinsics;
        let cam: [Vector3<f64>; 8] = corners.map(|p| r.inverse() * (p - c));
        let (mut u_min, mut u_max, mut v_min, mut v_max) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        let mut z_min = f64::MAX;
        let mut any = false;
        let mut projected = [[0.0; 2]; MAX_OUTLINE];
        let mut count = 0;
        let mut add = |p: &Vector3<f64>| {
            let u = k.fx as f64 * p.x / p.z + k.cx as f64;
            let v = k.fy as f64 * p.y / p.z + k.cy as f64;
            projected[count] = [u, v];
            count += 1;
            u_min = u_min.min(u);
            u_max = u_max.max(u);
            v_min = v_min.min(v);
            v_max = v_max.max(v);
            z_min = z_min.min(p.z);
            any = true;
        };
        for p in &cam {
            if p.z >= NEAR_M {
                add(p);
            }
        }
        for a in 0..8usize {
            for bit in [1usize, 2, 4] {
                let b = a | bit;
                if b == a {
                    continue;
                }
                let (pa, pb) = (&cam[a], &cam[b]);
                if (pa.z < NEAR_M) != (pb.z < NEAR_M) {
                    let f = (NEAR_M - pa.z) / (pb.z - pa.z);
                    add(&(pa + (pb - pa) * f));
                }
            }
        }
        if !any || z_min > self.profile.max_depth_m {
            return None;
        }
        let u0 = u_min.floor().max(0.0);
        let u1 = u_max.ceil().min(self.width as f64 - 1.0);
        let v0 = v_min.floor().max(0.0);
        let v1 = v_max.ceil().min(self.height as f64 - 1.0);
        if u0 > u1 || v0 > v1 {
            return None;
        }
        let rect = Rect { u0: u0 as usize, u1: u1 as usize, v0: v0 as usize, v1: v1 as usize };
        Some((rect, projected, count))
    }

    fn footprint_corners(center: [f64; 2], half: [f64; 2], yaw: f64, bottom: f64, top: f64) -> [Vector3<f64>; 8] {
        let (s, co) = yaw.sin_cos();
        std::array::from_fn(|i| {
            let x = if i & 1 == 0 { -half[0] } else { half[0] };
            let y = if i & 2 == 0 { -half[1] } else { half[1] };
            let z = if i & 4 == 0 { bottom } else { top };
            Vector3::new(center[0] + co * x - s * y, center[1] + s * x + co * y, z)
        })
    }

    fn prepare_box(&mut self, b: &OrientedBox, id: ObstacleId, r: &Rotation3<f64>, c: &Vector3<f64>) {
        let corners = Self::footprint_corners(b.center_m, b.half_size_m, b.yaw_rad, b.bottom_m, b.top_m);
        let Some((rect, mut projected, count)) = self.screen_projection(&corners, r, c) else { return };
        let outline = Outline::hull(&mut projected[..count]);
        let to_box = Rotation3::from_axis_angle(&Vector3::z_axis(), -b.yaw_rad);
        let mid = Vector3::new(b.center_m[0], b.center_m[1], (b.bottom_m + b.top_m) / 2.0);
        let o = to_box * (c - mid);
        self.boxes.push(FrameBox {
            origin: [o.x as f32, o.y as f32, o.z as f32],
            rot: to_f32_rows((to_box * r).matrix()),
            half: [b.half_size_m[0] as f32, b.half_size_m[1] as f32, ((b.top_m - b.bottom_m) / 2.0) as f32],
            rect,
            outline,
            id: id.0,
        });
    }

    fn prepare_cylinder(&mut self, cyl: &VerticalCylinder, id: ObstacleId, r: &Rotation3<f64>, c: &Vector3<f64>) {
        let corners = Self::footprint_corners(cyl.center_m, [cyl.radius_m, cyl.radius_m], 0.0, cyl.bottom_m, cyl.top_m);
        let Some(rect) = self.screen_rect(&corners, r, c) else { return };
        self.cylinders.push(FrameCylinder {
            origin: [(c.x - cyl.center_m[0]) as f32, (c.y - cyl.center_m[1]) as f32, c.z as f32],
            radius2: (cyl.radius_m * cyl.radius_m) as f32,
            bottom: cyl.bottom_m as f32,
            top: cyl.top_m as f32,
            rect,
            id: id.0,
        });
    }

    fn prepare_hole(&mut self, d: &DropOff, id: ObstacleId, r: &Rotation3<f64>, c: &Vector3<f64>) {
        let corners = Self::footprint_corners(d.center_m, d.half_size_m, d.yaw_rad, -d.depth_m, 0.0);
        let Some(rect) = self.screen_rect(&corners, r, c) else { return };
        let to_hole = Rotation3::from_axis_angle(&Vector3::z_axis(), -d.yaw_rad);
        let o = to_hole * (c - Vector3::new(d.center_m[0], d.center_m[1], 0.0));
        self.holes.push(FrameHole {
            origin: [o.x as f32, o.y as f32, o.z as f32],
            rot: to_f32_rows((to_hole * r).matrix()),
            half: [d.half_size_m[0] as f32, d.half_size_m[1] as f32],
            depth: d.depth_m as f32,
            rect,
            id: id.0,
        });
    }

    /// The floor plane under the camera, everywhere (holes are cut next).
    fn draw_floor(&mut self, r: &Rotation3<f64>, height_m: f64) {
        let m = r.matrix();
        let (gx, gy, gz) = (m[(2, 0)] as f32, m[(2, 1)] as f32, m[(2, 2)] as f32);
        let h = height_m as f32;
        for (v, &ry) in self.ray_y.iter().enumerate() {
            let row_dz = gy * ry + gz;
            let row = v * self.width;
            let depth = &mut self.depth_m[row..row + self.width];
            let ids = &mut self.ids[row..row + self.width];
            for ((z, id), &rx) in depth.iter_mut().zip(ids.iter_mut()).zip(&self.ray_x) {
                let dz = gx * rx + row_dz;
                if dz < 0.0 && h > 0.0 {
                    *z = -h / dz;
                    *id = FLOOR_PIXEL;
                } else {
                    *z = f32::INFINITY;
                    *id = EMPTY_PIXEL;
                }
            }
        }
    }

    /// Where a ray meets the floor inside a hole, the far side of the hole is seen.
    fn draw_holes(&mut self) {
        for hole in &self.holes {
            let [ox, oy, oz] = hole.origin;
            if oz <= 0.0 {
                continue;
            }
            let [c0, c1, c2] = hole.rot;
            for v in hole.rect.v0..=hole.rect.v1 {
                let ry = self.ray_y[v];
                let base = [c1[0] * ry + c2[0], c1[1] * ry + c2[1], c1[2] * ry + c2[2]];
                for u in hole.rect.u0..=hole.rect.u1 {
                    let rx = self.ray_x[u];
                    let d = [c0[0] * rx + base[0], c0[1] * rx + base[1], c0[2] * rx + base[2]];
                    if d[2] >= 0.0 {
                        continue;
                    }
                    let t_floor = -oz / d[2];
                    let px = ox + t_floor * d[0];
                    let py = oy + t_floor * d[1];
                    if px.abs() > hole.half[0] || py.abs() > hole.half[1] {
                        continue;
                    }
                    let tx = if d[0] != 0.0 { (hole.half[0].copysign(d[0]) - ox) / d[0] } else { f32::INFINITY };
                    let ty = if d[1] != 0.0 { (hole.half[1].copysign(d[1]) - oy) / d[1] } else { f32::INFINITY };
                    let tz = (-hole.depth - oz) / d[2];
                    let i = v * self.width + u;
                    self.depth_m[i] = tx.min(ty).min(tz);
                    self.ids[i] = hole.id;
                }
            }
        }
    }

    fn draw_boxes(&mut self) {
        for b in &self.boxes {
            let [ox, oy, oz] = b.origin;
            let [hx, hy, hz] = b.half;
            let [c0, c1, c2] = b.rot;
            let Rect { u0, u1, v0, v1 } = b.rect;
            if ox.abs() <= hx && oy.abs() <= hy && oz.abs() <= hz {
                // A camera inside a solid sees nothing it could range.
                for v in v0..=v1 {
                    let row = v * self.width;
                    self.depth_m[row + u0..=row + u1].fill(0.0);
                    self.ids[row + u0..=row + u1].fill(b.id);
                }
                continue;
            }
            for v in v0..=v1 {
                // Only the pixels within the outline's span, and one either side.
                let (lo, hi) = b.outline.span_at(v as f64);
                let first = ((lo.floor() - 1.0).max(u0 as f64) as usize).min(u1);
                let last = ((hi.ceil() + 1.0).max(0.0) as usize).clamp(first, u1);
                let ry = self.ray_y[v];
                let base = [c1[0] * ry + c2[0], c1[1] * ry + c2[1], c1[2] * ry + c2[2]];
                let row = v * self.width;
                let rays = &self.ray_x[first..=last];
                let depth = &mut self.depth_m[row + first..=row + last];
                let ids = &mut self.ids[row + first..=row + last];
                // Branch-free so the row vectorises: every pixel is written back.
                for ((z, id), &rx) in depth.iter_mut().zip(ids.iter_mut()).zip(rays) {
                    let ix = 1.0 / (c0[0] * rx + base[0]);
                    let iy = 1.0 / (c0[1] * rx + base[1]);
                    let iz = 1.0 / (c0[2] * rx + base[2]);
                    let (x1, x2) = ((-hx - ox) * ix, (hx - ox) * ix);
                    let (y1, y2) = ((-hy - oy) * iy, (hy - oy) * iy);
                    let (z1, z2) = ((-hz - oz) * iz, (hz - oz) * iz);
                    let t_in = x1.min(x2).max(y1.min(y2)).max(z1.min(z2));
                    let t_out = x1.max(x2).min(y1.max(y2)).min(z1.max(z2));
                    let hit = (t_in <= t_out) & (t_in > 0.0) & (t_in < *z);
                    *z = if hit { t_in } else { *z };
                    *id = if hit { b.id } else { *id };
                }
            }
        }
    }

    fn draw_cylinders(&mut self) {
        // Cylinders are vertical, so the map frame (shifted to the axis) is their frame.
        let [c0, c1, c2] = self.camera_to_map;
        for cyl in &self.cylinders {
            let [ox, oy, oz] = cyl.origin;
            let c = ox * ox + oy * oy - cyl.radius2;
            let inside = c <= 0.0 && oz >= cyl.bottom && oz <= cyl.top;
            for v in cyl.rect.v0..=cyl.rect.v1 {
                let ry = self.ray_y[v];
                let base = [c1[0] * ry + c2[0], c1[1] * ry + c2[1], c1[2] * ry + c2[2]];
                let row = v * self.width;
                for u in cyl.rect.u0..=cyl.rect.u1 {
                    let rx = self.ray_x[u];
                    let i = row + u;
                    if inside {
                        self.depth_m[i] = 0.0;
                        self.ids[i] = cyl.id;
                        continue;
                    }
                    let d = [c0[0] * rx + base[0], c0[1] * rx + base[1], c0[2] * rx + base[2]];
                    let mut t_hit = f32::INFINITY;
                    let a = d[0] * d[0] + d[1] * d[1];
                    let b = ox * d[0] + oy * d[1];
                    let disc = b * b - a * c;
                    if c > 0.0 && disc >= 0.0 && a > 0.0 {
                        let t = (-b - disc.sqrt()) / a;
                        let z = oz + t * d[2];
                        if t > 0.0 && z >= cyl.bottom && z <= cyl.top {
                            t_hit = t;
                        }
                    }
                    let cap = if oz > cyl.top && d[2] < 0.0 {
                        Some(cyl.top)
                    } else if oz < cyl.bottom && d[2] > 0.0 {
                        Some(cyl.bottom)
                    } else {
                        None
                    };
                    if let Some(zc) = cap {
                        let t = (zc - oz) / d[2];
                        let (px, py) = (ox + t * d[0], oy + t * d[1]);
                        if px * px + py * py <= cyl.radius2 && t < t_hit {
                            t_hit = t;
                        }
                    }
                    if t_hit < self.depth_m[i] {
                        self.depth_m[i] = t_hit;
                        self.ids[i] = cyl.id;
                    }
                }
            }
        }
    }

    /// Projector shadows: where depth jumps, the background next to the edge gets no
    /// depth. The shadow falls on the background's left (projector to the camera's
    /// right), as wide as the disparity jump; other edges lose one mixed pixel.
    /// Marked pixels are negated so the comparisons that follow still see their depth.
    fn mark_shadow_edges(&mut self) {
        let keep = 1.0 - self.profile.edge_jump_ratio as f32;
        let disparity_px = self.intrinsics.fx * self.profile.baseline_m as f32;
        let max_m = self.profile.max_depth_m as f32;
        let w = self.width;
        // Marks only set sign bits and every test reads magnitudes, so the order of the
        // marks does not matter and most of the work is a branch-free scan for edges.
        let usable = |z: f32| (z > 0.0) & (z <= max_m);
        let jump = |a: f32, b: f32| usable(a) & usable(b) & ((b < a * keep) | (a < b * keep));
        const LANES: usize = 16;
        for v in 0..self.height {
            let row = &mut self.depth_m[v * w..(v + 1) * w];
            let mut u = 0;
            while u < w - 1 {
                if u + LANES < w {
                    let any = (u..u + LANES).fold(false, |any, k| any | jump(row[k].abs(), row[k + 1].abs()));
                    if !any {
                        u += LANES;
                        continue;
                    }
                }
                let (a, b) = (row[u].abs(), row[u + 1].abs());
                if usable(a) & usable(b) {
                    if b < a * keep {
                        let band = ((disparity_px * (1.0 / b - 1.0 / a)).ceil() as usize).clamp(1, MAX_SHADOW_PX);
                        for z in &mut row[(u + 1).saturating_sub(band)..=u] {
                            *z = -z.abs();
                        }
                    } else if a < b * keep {
                        row[u + 1] = -b;
                    }
                }
                u += 1;
            }
        }
        let sign = |z: f32, mark: bool| f32::from_bits(z.to_bits() | (u32::from(mark) << 31));
        for v in 0..self.height - 1 {
            let (upper, lower) = self.depth_m[v * w..(v + 2) * w].split_at_mut(w);
            for (top, bottom) in upper.iter_mut().zip(lower.iter_mut()) {
                let (a, b) = (top.abs(), bottom.abs());
                let both = usable(a) & usable(b);
                let mark_top = both & (b < a * keep);
                let mark_bottom = both & !mark_top & (a < b * keep);
                *top = sign(*top, mark_top);
                *bottom = sign(*bottom, mark_bottom);
            }
        }
    }

    /// Range limits, dropouts, disparity noise and rounding; metres to u16 millimetres.
    fn apply_sensor_model(&self, rng: &mut SimRng, out: &mut Vec<u16>) {
        let p = &self.profile;
        let (min_m, max_m) = (p.min_depth_m as f32, p.max_depth_m as f32);
        let (near_m, far_m) = (p.reliable_from_m as f32, p.reliable_to_m as f32);
        let base = p.dropout as f32;
        let edge = p.edge_dropout as f32;
        let near_slope = (edge - base) / (near_m - min_m).max(1e-6);
        let far_slope = (edge - base) / (max_m - far_m).max(1e-6);
        // Noise in disparity units gives the axial sigma noise_per_m2 * z^2 to first order.
        let focal_baseline = self.intrinsics.fx * p.baseline_m as f32;
        let disparity_sigma_px = p.noise_per_m2 as f32 * focal_baseline;
        let step_px = p.disparity_step_px as f32;
        // Dividing by a power of two is multiplying by its inverse, bit for bit.
        let per_step = 1.0 / step_px;
        let step_is_power_of_two = step_px.is_normal() && step_px.to_bits() & 0x007f_ffff == 0;
        let mask = (NORMAL_TABLE_LEN - 1) as u64;
        out.clear();
        out.resize(self.depth_m.len(), 0);
        // A local copy keeps the generator's state in registers.
        let mut draws = rng.clone();
        for (o, &z) in out.iter_mut().zip(&self.depth_m) {
            if !(z >= min_m && z <= max_m) {
                continue;
            }
            let bits = draws.next_u64();
            let dropout = if z < near_m {
                base + (near_m - z) * near_slope
            } else if z > far_m {
                base + (z - far_m) * far_slope
            } else {
                base
            };
            if ((bits >> 40) as f32) * (1.0 / (1u64 << 24) as f32) < dropout {
                continue;
            }
            let mut disparity_px = focal_baseline / z + disparity_sigma_px * self.normals[(bits & mask) as usize];
            if disparity_px <= 0.0 {
                continue;
            }
            // Rounding of positive values by truncation: `f32::round` is a libm call
            // on baseline x86-64 and cost 9 % of the frame.
            if step_px > 0.0 {
                let in_steps = if step_is_power_of_two { disparity_px * per_step } else { disparity_px / step_px };
                let steps = ((in_steps + 0.5) as u32).max(1);
                if let Some(&mm) = self.depth_of_step.get(steps as usize) {
                    *o = mm;
                    continue;
                }
                disparity_px = steps as f32 * step_px;
            }
            *o = measured_mm(focal_baseline, disparity_px);
        }
        *rng = draws;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "name = \"t\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 1.0, y_m = 0.0 }\n";

    fn world(items: &str) -> World {
        match World::from_toml(&format!("{HEAD}{items}"), "test") {
            Ok(w) => w,
            Err(e) => panic!("{e}"),
        }
    }

    fn render(world: &World, pose: &CameraPose, seed: u64) -> (Renderer, Vec<u16>) {
        let mut r = Renderer::new(CameraProfile::xtion());
        let mut out = Vec::new();
        r.render(world, pose, 0.0, &mut SimRng::seed_from(seed), &mut out);
        (r, out)
    }

    /// Valid samples (mm) in a square window around a pixel.
    fn window(depth: &[u16], u: usize, v: usize, half: usize) -> Vec<f64> {
        let mut out = Vec::new();
        for y in v - half..=v + half {
            for x in u - half..=u + half {
                let d = depth[y * 640 + x];
                if d != 0 {
                    out.push(d as f64);
                }
            }
        }
        out
    }

    fn mean(xs: &[f64]) -> f64 {
        xs.iter().sum::<f64>() / xs.len() as f64
    }

    #[test]
    fn empty_floor_seen_from_1m_pitched_30deg_reads_the_analytic_depth() {
        let w = world("");
        let pose = CameraPose::from_yaw_pitch(0.0, 0.0, 1.0, 0.0, 30f64.to_radians(), 0);
        let (r, depth) = render(&w, &pose, 1);
        let k = r.intrinsics();
        let sigma_mm = CameraProfile::xtion().noise_sigma_m(2.0) * 1000.0;
        let mut analytic = Vec::new();
        let mut measured = Vec::new();
        for v in 236..=244usize {
            for u in 316..=324usize {
                let ray =
                    Vector3::new((u as f64 - k.cx as f64) / k.fx as f64, (v as f64 - k.cy as f64) / k.fy as f64, 1.0);
                let dz = (pose.camera_to_map * ray).z;
                let exact_mm = -1.0 / dz * 1000.0;
                let d = depth[v * 640 + u];
                if d != 0 {
                    assert!((d as f64 - exact_mm).abs() < 5.0 * sigma_mm, "pixel ({u},{v}): {d} vs {exact_mm}");
                    analytic.push(exact_mm);
                    measured.push(d as f64);
                }
            }
        }
        // The optical axis meets the floor 2 m away (1 m / sin 30 deg).
        assert!((mean(&analytic) - 2000.0).abs() < 15.0, "{}", mean(&analytic));
        assert!(measured.len() >= 75, "only {} of 81 pixels valid", measured.len());
        let bias = mean(&measured) - mean(&analytic);
        assert!(bias.abs() < 3.0 * sigma_mm / (measured.len() as f64).sqrt() + 0.5, "bias {bias} mm");
    }

    #[test]
    fn wall_2m_straight_ahead_reads_2000mm_at_the_centre() {
        // 10 cm thick wall centred at x = 2.05: its face is at 2.0 m.
        let w = world("[[walls]]\nfrom = [2.05, -3.0]\nto = [2.05, 3.0]\n");
        let pose = CameraPose::from_yaw_pitch(0.0, 0.0, 0.9, 0.0, 0.0, 0);
        let (r, depth) = render(&w, &pose, 2);
        let samples = window(&depth, 320, 240, 3);
        assert!(samples.len() >= 45, "{} valid", samples.len());
        let sigma_mm = CameraProfile::xtion().noise_sigma_m(2.0) * 1000.0;
        for s in &samples {
            assert!((s - 2000.0).abs() < 5.0 * sigma_mm, "{s}");
        }
        assert!((mean(&samples) - 2000.0).abs() < 3.0, "{}", mean(&samples));
        assert_eq!(r.obstacle_ids()[240 * 640 + 320], 0);
    }

    #[test]
    fn d435_profile_renders_848_wide_and_reads_the_wall() {
        let w = world("[[walls]]\nfrom = [2.05, -3.0]\nto = [2.05, 3.0]\n");
        let pose = CameraPose::from_yaw_pitch(0.0, 0.0, 0.9, 0.0, 0.0, 0);
        let mut r = Renderer::new(CameraProfile::d435());
        let mut out = Vec::new();
        r.render(&w, &pose, 0.0, &mut SimRng::seed_from(1), &mut out);
        assert_eq!(out.len(), 848 * 480);
        let centre: Vec<f64> = (236..=244)
            .flat_map(|v| (420..=428).map(move |u| v * 848 + u))
            .map(|i| out[i] as f64)
            .filter(|&d| d != 0.0)
            .collect();
        assert!(centre.len() > 70, "{}", centre.len());
        assert!((mean(&centre) - 2000.0).abs() < 8.0, "{}", mean(&centre));
        // 58 degrees of vertical view: the bottom row looks 29 degrees down.
        let k = r.intrinsics();
        let bottom_angle = ((479.0 - k.cy) / k.fy).atan().to_degrees();
        assert!((bottom_angle - 29.0).abs() < 0.2, "{bottom_angle}");
    }

    #[test]
    fn head_high_obstacle_appears_only_in_the_upper_rows() {
        let w = world("[[hanging]]\ncenter = [2.15, 0.0]\nsize_m = [0.3, 0.8]\nbottom_m = 1.55\ntop_m = 1.85\n");
        // Level camera at the cane camera's height: the sign is 18-24 degrees up.
        let level = CameraPose::from_yaw_pitch(0.0, 0.0, 0.885, 0.0, 0.0, 0);
        let (r, depth) = render(&w, &level, 3);
        let rows: Vec<usize> =
            (0..640 * 480).filter(|&i| r.obstacle_ids()[i] == 0 && depth[i] != 0).map(|i| i / 640).collect();
        assert!(rows.len() > 1000, "sign covers {} valid pixels", rows.len());
        let lowest = rows.iter().max().copied().unwrap_or(0);
        // Bottom face's far edge: atan(0.665 / 2.3) = 16.1 deg up, row ~ 72.
        assert!(lowest < 80, "sign seen down to row {lowest}");
        // Pitched 30 degrees down, as on the cane, the camera's top ray is 7.5 degrees
        // below the horizon: the head-high sign is out of view (Taylor's contacts).
        let cane = CameraPose::from_yaw_pitch(0.0, 0.0, 0.885, 0.0, 30f64.to_radians(), 0);
        let (r, _) = render(&w, &cane, 3);
        assert!(!r.saw_obstacle(ObstacleId(0)));
    }

    #[test]
    fn nothing_is_reported_beyond_the_range_limit() {
        let far = world("[[walls]]\nfrom = [6.05, -5.0]\nto = [6.05, 5.0]\n");
        let pose = CameraPose::from_yaw_pitch(0.0, 0.0, 0.9, 0.0, 0.0, 0);
        let (r, depth) = render(&far, &pose, 4);
        assert!(window(&depth, 320, 240, 5).is_empty(), "wall at 6 m must read 0");
        // Wholly beyond the range limit, the wall is not even drawn.
        assert_eq!(r.obstacle_ids()[200 * 640 + 320], EMPTY_PIXEL);
        let max_mm = depth.iter().copied().max().unwrap_or(0);
        let limit_mm = 4500.0 + 4.0 * CameraProfile::xtion().noise_sigma_m(4.5) * 1000.0;
        assert!((max_mm as f64) < limit_mm, "max reading {max_mm} mm");
        // Between the reliable limit and the range limit readings thin out but exist.
        let near = world("[[walls]]\nfrom = [4.05, -5.0]\nto = [4.05, 5.0]\n");
        let (_, depth) = render(&near, &pose, 4);
        let valid = window(&depth, 320, 200, 10).len();
        assert!((200..400).contains(&valid), "{valid} of 441 valid at 4 m (about 75 % expected)");
    }

    #[test]
    fn xtion_depth_comes_in_eighth_pixel_disparity_layers() {
        let w = world("");
        let pose = CameraPose::from_yaw_pitch(0.0, 0.0, 1.0, 0.0, 20f64.to_radians(), 0);
        let (r, depth) = render(&w, &pose, 8);
        let focal_baseline = r.intrinsics().fx as f64 * 0.075;
        let mut layers = std::collections::BTreeSet::new();
        for v in 150..200usize {
            for &d in &depth[v * 640 + 300..v * 640 + 340] {
                if d == 0 {
                    continue;
                }
                // Back to disparity in eighths of a pixel: an integer, up to mm rounding.
                let eighths = focal_baseline / (d as f64 / 1000.0) * 8.0;
                assert!((eighths - eighths.round()).abs() < 0.05, "{d} mm is {eighths} eighths");
                layers.insert(d);
            }
        }
        // Rows 150-200 see the floor about 2.6-3.5 m out: a handful of layers, not a
        // continuum of millimetres.
        assert!((5..60).contains(&layers.len()), "{} distinct depths: {layers:?}", layers.len());
    }

    #[test]
    fn same_seed_renders_the_same_frame_and_another_seed_differs() {
        let w = World::builtin("taylor-course").and_then(Result::ok).unwrap_or_else(|| panic!("taylor-course"));
        let pose = CameraPose::from_yaw_pitch(0.7, 5.0, 0.885, 0.0, 30f64.to_radians(), 0);
        let (_, a) = render(&w, &pose, 9);
        let (_, b) = render(&w, &pose, 9);
        let (_, c) = render(&w, &pose, 10);
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn projector_shadow_blanks_background_left_of_a_near_box() {
        let w = world(
            "[[walls]]\nfrom = [3.05, -5.0]\nto = [3.05, 5.0]\n[[boxes]]\ncenter = [1.25, -0.5]\nsize_m = [0.5, 1.0]\ntop_m = 2.0\n",
        );
        let pose = CameraPose::from_yaw_pitch(0.0, 0.0, 0.9, 0.0, 0.0, 0);
        let (r, depth) = render(&w, &pose, 5);
        let row = 240 * 640;
        let ids = &r.obstacle_ids()[row..row + 640];
        // The box spans y in [-1, 0] at x = 1: its left edge is at the image centre.
        let edge = (0..640).find(|&u| ids[u] == 1).unwrap_or(640);
        assert!((318..=322).contains(&edge), "box edge at column {edge}");
        // Band width fx * baseline * (1/1 - 1/3) = 28.9 px of wall without depth.
        let band = (0..edge).rev().take_while(|&u| depth[row + u] == 0).count();
        assert!((26..=32).contains(&band), "shadow band {band} px");
        let beyond: usize = (edge - 40..edge - 32).filter(|&u| depth[row + u] != 0).count();
        assert!(beyond >= 6, "wall beyond the band must read");
    }

    #[test]
    fn drop_off_reads_deeper_than_the_floor_around_it() {
        let w = world("[[floor_regions]]\ncenter = [2.0, 0.0]\nsize_m = [1.0, 2.0]\nheight_m = -0.3\n");
        let pose = CameraPose::from_yaw_pitch(0.0, 0.0, 1.0, 0.0, 30f64.to_radians(), 0);
        let (_, depth) = render(&w, &pose, 6);
        // The optical axis passes the rim at 1.73 m and meets the pit floor 2.6 m out.
        let centre = mean(&window(&depth, 320, 240, 2));
        assert!((centre - 2600.0).abs() < 10.0, "{centre}");
        // Near the bottom of the image the axis still meets the floor before the pit.
        let bottom = mean(&window(&depth, 320, 470, 2));
        assert!(bottom < 1500.0, "{bottom}");
    }

    #[test]
    fn low_cylinder_shows_its_top_and_table_its_top_over_its_legs() {
        // Camera 1 m up looking straight down: a 0.5 m stool top reads 500 mm.
        let w = world("[[cylinders]]\ncenter = [0.0, 0.0]\nradius_m = 0.1\ntop_m = 0.5\n");
        let down = CameraPose::from_yaw_pitch(0.0, 0.0, 1.0, 0.0, 90f64.to_radians(), 0);
        let mut r = Renderer::new(CameraProfile::xtion());
        let mut out = Vec::new();
        r.render(&w, &down, 0.0, &mut SimRng::seed_from(1), &mut out);
        assert_eq!(r.obstacle_ids()[240 * 640 + 320], 0);
        // 0.5 m is inside the Xtion's minimum range ramp: some pixels read, near 500 mm.
        let top = window(&out, 320, 240, 10);
        assert!(!top.is_empty() && top.iter().all(|d| (d - 500.0).abs() < 5.0), "{top:?}");
        // Beside the stool (its top spans rows 124-355) the floor reads 1 m.
        assert!((mean(&window(&out, 320, 60, 3)) - 1000.0).abs() < 5.0);

        // A table 1.5 m ahead: the level camera at 0.9 m sees its edge at 0.71-0.75 m
        // just below the axis, and a leg below that.
        let w = world("[[tables]]\ncenter = [2.0, 0.0]\nsize_m = [1.0, 1.6]\n");
        let level = CameraPose::from_yaw_pitch(0.0, 0.0, 0.9, 0.0, 0.0, 0);
        r.render(&w, &level, 0.0, &mut SimRng::seed_from(1), &mut out);
        let k = r.intrinsics();
        let row_of = |z: f64, x: f64| (k.cy as f64 + k.fy as f64 * (0.9 - z) / x).round() as usize;
        let edge = mean(&window(&out, 320, row_of(0.73, 1.5), 1));
        assert!((edge - 1500.0).abs() < 10.0, "table edge {edge}");
        // Leg centres 0.075 m in from the corners: x = 1.575, y = +-0.725.
        let leg_u = (k.cx as f64 - k.fx as f64 * 0.725 / 1.575).round() as usize;
        let leg = r.obstacle_ids()[row_of(0.3, 1.575) * 640 + leg_u];
        assert_eq!(leg, 0, "leg of the table at column {leg_u}");
    }

    #[test]
    fn pole_and_walking_person_are_drawn_where_they_are() {
        let w = world(
            "[[poles]]\ncenter = [2.0, 0.0]\nradius_m = 0.1\nheight_m = 2.0\n[[people]]\nwaypoints = [[3.0, -3.0], [3.0, 3.0]]\nspeed_m_s = 1.0\n",
        );
        let pose = CameraPose::from_yaw_pitch(0.0, 0.0, 0.9, 0.0, 0.0, 0);
        let (_, depth) = render(&w, &pose, 7);
        let pole = mean(&window(&depth, 320, 240, 1));
        assert!((pole - 1900.0).abs() < 15.0, "{pole}");
        // At t = 3 s the person (radius 0.25) is straight ahead at 3 m; behind the pole
        // it shows on both sides of it.
        let mut r = Renderer::new(CameraProfile::xtion());
        let mut out = Vec::new();
        r.render(&w, &pose, 3.0, &mut SimRng::seed_from(7), &mut out);
        // 50 px right of the axis the ray passes 0.26 m from the person's axis.
        let person_u = 320 + 50;
        let ids = r.obstacle_ids();
        assert_eq!(ids[240 * 640 + 320], 0, "pole in front");
        assert_eq!(ids[240 * 640 + 320 - 30], 1, "person left of the pole");
        assert_ne!(ids[240 * 640 + person_u], 1, "0.26 m off-axis at 3 m is beside the person");
    }

    #[test]
    fn outline_is_the_convex_hull_and_gives_each_row_its_span() {
        let mut square = [[0.0, 0.0], [5.0, 0.0], [10.0, 0.0], [5.0, 5.0], [10.0, 10.0], [0.0, 10.0], [2.0, 7.0]];
        let outline = Outline::hull(&mut square);
        assert_eq!(outline.len, 4, "{:?}", &outline.points[..outline.len]);
        assert_eq!(outline.span_at(5.0), (0.0, 10.0));
        assert_eq!(outline.span_at(-3.0), (0.0, 10.0), "rows above clamp to the top edge");
        let mut triangle = [[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]];
        let outline = Outline::hull(&mut triangle);
        assert_eq!(outline.len, 3);
        assert_eq!(outline.span_at(5.0), (0.0, 5.0));
        assert_eq!(outline.span_at(10.0), (0.0, 0.0));
        let mut segment = [[3.0, 1.0], [7.0, 1.0]];
        assert_eq!(Outline::hull(&mut segment).span_at(1.0), (3.0, 7.0));
    }

    #[test]
    fn disparity_table_reads_as_the_division_it_replaces() {
        let r = Renderer::new(CameraProfile::xtion());
        let fb = r.intrinsics.fx * r.profile.baseline_m as f32;
        let step = r.profile.disparity_step_px as f32;
        assert!(r.depth_of_step.len() > (fb / 0.5 / step) as usize, "covers the nearest range");
        for (n, &mm) in r.depth_of_step.iter().enumerate().skip(1) {
            assert_eq!(mm, measured_mm(fb, n as f32 * step), "step {n}");
        }
        assert_eq!(r.depth_of_step[1], u16::MAX, "one step of disparity is beyond u16 millimetres");
    }

    #[test]
    fn every_pixel_a_box_covers_lies_within_its_outline_span() {
        // The slab test over each box's whole screen rectangle, against the span each
        // row tests: a hit outside it would be a piece of wall the renderer leaves out.
        let w = match World::load("taylor-course") {
            Ok(w) => w,
            Err(e) => panic!("{e}"),
        };
        let mut rng = SimRng::seed_from(11);
        let mut r = Renderer::new(CameraProfile::xtion());
        let mut out = Vec::new();
        let mut hits = 0usize;
        for _ in 0..150 {
            // anywhere in the room, walls within a few centimetres included
            let (x, y) = (0.05 + 9.9 * rng.uniform(), 0.05 + 9.9 * rng.uniform());
            let yaw = std::f64::consts::TAU * rng.uniform();
            let pitch = (-20.0 + 70.0 * rng.uniform()).to_radians();
            let pose = CameraPose::from_yaw_pitch(x, y, 0.5 + 1.2 * rng.uniform(), yaw, pitch, 0);
            r.render(&w, &pose, 0.0, &mut rng, &mut out);
            for b in &r.boxes {
                let [ox, oy, oz] = b.origin;
                let [hx, hy, hz] = b.half;
                let [c0, c1, c2] = b.rot;
                if ox.abs() <= hx && oy.abs() <= hy && oz.abs() <= hz {
                    continue;
                }
                for v in b.rect.v0..=b.rect.v1 {
                    let (lo, hi) = b.outline.span_at(v as f64);
                    let ry = r.ray_y[v];
                    for u in b.rect.u0..=b.rect.u1 {
                        let rx = r.ray_x[u];
                        let d = [0, 1, 2].map(|k| c0[k] * rx + c1[k] * ry + c2[k]);
                        let (o, h) = ([ox, oy, oz], [hx, hy, hz]);
                        let slab = |k: usize| {
                            let (t1, t2) = ((-h[k] - o[k]) / d[k], (h[k] - o[k]) / d[k]);
                            (t1.min(t2), t1.max(t2))
                        };
                        let (t_in, t_out) =
                            (0..3).map(slab).fold((f32::MIN, f32::MAX), |(a, b), (lo, hi)| (a.max(lo), b.min(hi)));
                        if t_in <= t_out && t_in > 0.0 {
                            hits += 1;
                            assert!(
                                (u as f64) >= lo.floor() - 1.0 && (u as f64) <= hi.ceil() + 1.0,
                                "box {} at pixel ({u}, {v}) outside its span {lo:.1}..{hi:.1} from {pose:?}",
                                b.id
                            );
                        }
                    }
                }
            }
        }
        assert!(hits > 1_000_000, "only {hits} box pixels tried");
    }
}
