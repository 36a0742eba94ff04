//! Beyond the thesis: memory of obstacles outside the field of view. Taylor's users
//! collided mostly with what the camera no longer saw: a divider beside them, a sign at
//! head height that left the top of the 45 deg vertical view as they came close. We keep
//! the scan's obstacles in a small egocentric grid, move it by the user's own motion
//! (odometry / IMU yaw) and forget a cell once it has moved `forget_after_m` in the
//! user's frame since it was seen (odometry error grows with motion: a user standing
//! before a sign keeps it) or after `ttl_ns`; an overhead one (higher than
//! `overhead_from_m`, where only the camera can find it, and only from afar) only after
//! `overhead_ttl_ns`. Every cell goes beyond `radius_m`. The cell's own displacement is the
//! measure, not the path the camera travelled: a camera on a sweeping cane swings
//! +-17 deg and sideways about once a second, which adds up to metres of path and
//! radians of turn without taking the user anywhere, and summing it forgot a head-high
//! sign seen 3 m ahead before the user reached it (`wearnav course`, camera 10 deg
//! down). Each frame a remembered cell is either in view (the camera is authoritative
//! there: the cell is dropped and re-added only if the scan still sees it) or out of
//! view (it is handed to the cost functions).
//!
//! In view means `view_margin_deg` inside the image's top and bottom edges: a sign in
//! the top rows is seen by too few pixels for the scan to range it, and dropping it
//! there forgot it the moment it mattered. Where the scan ranges such a cell all the
//! same, it is counted twice, the scan's point and the memory's: what makes a chest
//! camera warn of a sign 1.4 m ahead. Counted once, the generated worlds' walks showed
//! no difference beyond the spread of the seeds and `hanging-lamp` one head-high contact
//! more in ten walks (docs/beyond-the-course.md, "Found, left as it is").
//!
//! Handed to the costs, a cell stands for every degree of bearing it covers, as the
//! scan's one point per degree would: one point per 10 cm cell made a remembered sign
//! 1.5 m ahead weigh a quarter of the same sign in view, and the user walked into it
//! (`wearnav course`, sign 1.2 m wide in the path, camera 10 deg down: 10 of 10 walks
//! before, 0-1 after).

use std::collections::HashMap;
use std::f32::consts::PI;

use super::config::MemoryConfig;
use super::Motion;

/// Floor seen stays floor (unlike a person, it does not move off): it is kept this long,
/// nanoseconds, while within the memory's radius. A user stopped before a drop, turning
/// in place for more than the obstacles' 10 s, still knows the floor walked over.
const FLOOR_TTL_NS: u64 = 60_000_000_000;

/// The floor seen is pruned (by age and distance) this often, nanoseconds: a walk of a
/// minute holds thousands of cells, too many to visit every frame.
const FLOOR_PRUNE_NS: u64 = 1_000_000_000;

/// Where the camera can see this frame, in user terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewCone {
    /// Half horizontal field of view, radians.
    pub half_hfov_rad: f32,
    /// Half vertical field of view, radians.
    pub half_vfov_rad: f32,
    /// Downward pitch of the optical axis, radians.
    pub pitch_down_rad: f32,
    /// Camera height above the floor, metres.
    pub camera_height_m: f32,
    /// Ranges beyond this are not seen.
    pub range_max_m: f32,
}

impl ViewCone {
    /// True when a point at user `(x, y)` and height `h` projects into the image, at
    /// least `margin_rad` inside its top and bottom edges.
    pub fn sees(&self, x: f32, y: f32, h: f32, margin_rad: f32) -> bool {
        let r = (x * x + y * y).sqrt();
        if x <= 0.0 || r > self.range_max_m || y.abs() > x * self.half_hfov_rad.tan() {
            return false;
        }
        let elevation = (h - self.camera_height_m).atan2(r);
        (elevation + self.pitch_down_rad).abs() <= self.half_vfov_rad - margin_rad
    }
}

#[derive(Debug, Clone, Copy)]
struct Cell {
    // where it is in the odometry frame: it stays put there, only the user moves
    x_m: f64,
    y_m: f64,
    seen_ns: u64,
    // where it lay in the user's frame when last seen
    seen_x_m: f32,
    seen_y_m: f32,
    height_m: f32,
    /// The cane would find it (it reached down near the floor when seen).
    cane_finds: bool,
}

/// A scan obstacle as the memory takes it: `[x, y, height]` (user frame, metres), and
/// whether the cane would find it (false for a bare point).
pub trait ScanObstacle {
    /// `[x, y, height]`.
    fn point(&self) -> [f32; 3];
    /// Whether the cane would find it.
    fn cane_finds(&self) -> bool {
        false
    }
}

impl ScanObstacle for [f32; 3] {
    fn point(&self) -> [f32; 3] {
        *self
    }
}

impl ScanObstacle for ([f32; 3], bool) {
    fn point(&self) -> [f32; 3] {
        self.0
    }
    fn cane_finds(&self) -> bool {
        self.1
    }
}

/// The remembered obstacles, binned in cells of the odometry frame.
///
/// The cells stay where they were seen and the user's pose moves among them: moving
/// the grid with the user instead re-binned every cell each frame, and under a cane's
/// sweep two cells often rounded into one, so a 0.9 m sign seen at 3 m shrank to two
/// cells at one end before the user reached it.
#[derive(Debug, Default)]
pub struct ObstacleMemory {
    // user pose in the odometry frame: x, y, heading
    pose: [f64; 3],
    cells: HashMap<(i64, i64), Cell>,
    // cells of the odometry frame where the floor plane was seen, and when
    floor_seen: HashMap<(i64, i64), u64>,
    floor_pruned_ns: u64,
    nearest_by_degree: Vec<(f32, bool)>,
    /// Remembered obstacles out of view this frame, user `(x, y)`, one per degree of
    /// bearing (the nearest cell covering it), like the scan's own density.
    pub out_of_view: Vec<[f32; 2]>,
    /// Per `out_of_view`, whether the cane would find it (as seen when it was stored).
    pub out_of_view_cane: Vec<bool>,
}

impl ObstacleMemory {
    /// Number of remembered cells, in view or not.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// True when nothing is remembered.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Moves the user by their motion since the last frame, forgets old cells, hands
    /// out-of-view cells to `out_of_view`, drops in-view ones, and stores this frame's
    /// scan obstacles `(x, y, height)`.
    pub fn update(
        &mut self,
        stamp_ns: u64,
        motion: Option<Motion>,
        view: &ViewCone,
        scan_obstacles: impl Iterator<Item = impl ScanObstacle>,
        cfg: &MemoryConfig,
    ) {
        if let Some(m) = motion.filter(Motion::is_finite) {
            let [px, py, yaw] = self.pose;
            let (s, c) = yaw.sin_cos();
            let (f, l) = (f64::from(m.forward_m), f64::from(m.left_m));
            self.pose = [px + c * f - s * l, py + s * f + c * l, yaw + f64::from(m.yaw_rad)];
        }
        let to_user = self.user_at_pose();
        self.nearest_by_degree.clear();
        self.nearest_by_degree.resize(360, (f32::INFINITY, false));
        let nearest = &mut self.nearest_by_degree;
        let margin_rad = cfg.view_margin_deg.to_radians();
        self.cells.retain(|_, cell| {
            let [x, y] = to_user(cell.x_m, cell.y_m);
            let r = x.hypot(y);
            let moved_m = (x - cell.seen_x_m).hypot(y - cell.seen_y_m);
            let (forget_m, ttl_ns) = if cell.height_m > cfg.overhead_from_m {
                (f32::INFINITY, cfg.overhead_ttl_ns)
            } else {
                (cfg.forget_after_m, cfg.ttl_ns)
            };
            let expired = moved_m > forget_m || stamp_ns.abs_diff(cell.seen_ns) > ttl_ns;
            if expired || r > cfg.radius_m || view.sees(x, y, cell.height_m, margin_rad) {
                return false;
            }
            // a cell stands for every degree of bearing it covers, as the scan would
            let centre = (y.atan2(x) + PI).to_degrees();
            let half = (0.5 * cfg.cell_m / r.max(cfg.cell_m)).to_degrees();
            for d in (centre - half).floor() as i32..=(centre + half).floor() as i32 {
                let deg = d.rem_euclid(360) as usize;
                if r < nearest[deg].0 {
                    nearest[deg] = (r, cell.cane_finds);
                }
            }
            true
        });
        self.out_of_view.clear();
        self.out_of_view_cane.clear();
        for (deg, &(r, cane)) in self.nearest_by_degree.iter().enumerate() {
            if r.is_finite() {
                let b = (deg as f32 + 0.5).to_radians() - PI;
                self.out_of_view.push([r * b.cos(), r * b.sin()]);
                self.out_of_view_cane.push(cane);
            }
        }
        let cell_of = self.cells_at_pose(cfg);
        for seen in scan_obstacles {
            let ([x, y, h], cane_finds) = (seen.point(), seen.cane_finds());
            if !(x.is_finite() && y.is_finite() && h.is_finite()) || x.hypot(y) > cfg.radius_m {
                continue;
            }
            let (key, [ox, oy]) = cell_of(x, y);
            let cell = Cell { x_m: ox, y_m: oy, seen_ns: stamp_ns, seen_x_m: x, seen_y_m: y, height_m: h, cane_finds };
            self.cells.insert(key, cell);
        }
    }

    /// For this frame's pose: odometry point `(x, y)` in the user frame.
    fn user_at_pose(&self) -> impl Fn(f64, f64) -> [f32; 2] {
        let [px, py, yaw] = self.pose;
        let (s, c) = yaw.sin_cos();
        move |x, y| {
            let (dx, dy) = (x - px, y - py);
            [(c * dx + s * dy) as f32, (-s * dx + c * dy) as f32]
        }
    }

    /// For this frame's pose: the cell of the odometry frame holding user point
    /// `(x, y)`, and the point there (the pose's turn worked out once, not per point).
    fn cells_at_pose(&self, cfg: &MemoryConfig) -> impl Fn(f32, f32) -> ((i64, i64), [f64; 2]) {
        let [px, py, yaw] = self.pose;
        let (s, c) = yaw.sin_cos();
        let cell_m = f64::from(cfg.cell_m.max(0.01));
        move |x, y| {
            let (xf, yf) = (f64::from(x), f64::from(y));
            let (ox, oy) = (px + c * xf - s * yf, py + s * xf + c * yf);
            (((ox / cell_m).round() as i64, (oy / cell_m).round() as i64), [ox, oy])
        }
    }

    /// Whether remembered lower ground lies where `inside` says (user frame): drop edges
    /// and floor that may be lower, the cells kept at floor height (obstacles are kept
    /// at their height above the floor, always above 0).
    pub fn lower_ground_where(&self, inside: impl Fn([f32; 2]) -> bool) -> bool {
        let to_user = self.user_at_pose();
        self.cells.values().filter(|cell| cell.height_m <= 0.0).any(|cell| inside(to_user(cell.x_m, cell.y_m)))
    }

    /// After [`Self::update`] of this frame: of the `unseen` floor that may be lower
    /// (see [`super::dropoff::LowerGround::unseen`]), appends to `out` and remembers
    /// (at floor height) the points the floor was not seen at (within `FLOOR_TTL_NS`
    /// and the memory's radius); then notes this frame's `floor` returns. A user
    /// walking up to a sunken area saw the floor before its edge as it came: that floor
    /// is no drop; floor never seen beside it may be.
    pub fn unseen_lower(
        &mut self,
        stamp_ns: u64,
        floor: &[[f32; 2]],
        unseen: &[[f32; 2]],
        cfg: &MemoryConfig,
        out: &mut Vec<[f32; 2]>,
    ) {
        if stamp_ns.abs_diff(self.floor_pruned_ns) >= FLOOR_PRUNE_NS {
            let [px, py, _] = self.pose;
            let cell_m = f64::from(cfg.cell_m.max(0.01));
            let radius_m = f64::from(cfg.radius_m);
            self.floor_seen.retain(|&(i, j), seen_ns| {
                let near = (i as f64 * cell_m - px).hypot(j as f64 * cell_m - py) <= radius_m;
                near && stamp_ns.abs_diff(*seen_ns) <= FLOOR_TTL_NS
            });
            self.floor_pruned_ns = stamp_ns;
        }
        let cell_of = self.cells_at_pose(cfg);
        for &[x, y] in unseen {
            if !(x.is_finite() && y.is_finite()) {
                continue;
            }
            let (key, [ox, oy]) = cell_of(x, y);
            if self.floor_seen.contains_key(&key) {
                continue;
            }
            out.push([x, y]);
            // lower ground: the cane's tip drops at its edge
            let cell =
                Cell { x_m: ox, y_m: oy, seen_ns: stamp_ns, seen_x_m: x, seen_y_m: y, height_m: 0.0, cane_finds: true };
            self.cells.insert(key, cell);
        }
        let mut last = None;
        for &[x, y] in floor {
            if !(x.is_finite() && y.is_finite()) || x.hypot(y) > cfg.radius_m {
                continue;
            }
            let (key, _) = cell_of(x, y);
            // neighbouring returns mostly share a cell: hash each run once
            if last != Some(key) {
                self.floor_seen.insert(key, stamp_ns);
                last = Some(key);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view() -> ViewCone {
        ViewCone {
            half_hfov_rad: 29f32.to_radians(),
            half_vfov_rad: 22.5f32.to_radians(),
            pitch_down_rad: 10f32.to_radians(),
            camera_height_m: 1.0,
            range_max_m: 5.0,
        }
    }

    const FRAME_NS: u64 = 33_333_333;

    #[test]
    fn head_high_sign_that_leaves_the_view_is_remembered_as_the_user_walks() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        // sign 1.9 m high, 3.0 m ahead: in view (elevation 16.7 deg up, top of view 12.5 deg)?
        // at 3.0 m it is at atan(0.9/3.0)=16.7 deg > 12.5: start further, at 4.5 m (11.3 deg).
        let mut x = 4.5f32;
        assert!(view().sees(x, 0.0, 1.9, 0.0));
        m.update(0, None, &view(), [[x, 0.0, 1.9]].into_iter(), &cfg);
        for k in 1..=30u64 {
            let step = 0.05; // 1.5 m/s
            x -= step;
            let visible = view().sees(x, 0.0, 1.9, 0.0);
            let seen = visible.then_some([x, 0.0, 1.9]);
            m.update(
                k * FRAME_NS,
                Some(Motion { forward_m: step, left_m: 0.0, yaw_rad: 0.0 }),
                &view(),
                seen.into_iter(),
                &cfg,
            );
        }
        assert!(!view().sees(x, 0.0, 1.9, 0.0), "sign left the view at {x}");
        let nearest = m.out_of_view.iter().map(|p| p[0]).fold(f32::INFINITY, f32::min);
        assert!((nearest - x).abs() < 0.12, "remembered at {nearest}, truly at {x}");
    }

    #[test]
    fn what_the_cane_would_find_is_remembered_as_such() {
        // a bin's foot (the cane finds it) to the left, a table top's edge (it does not)
        // to the right; out of view after a half turn, each keeps what it was
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        m.update(0, None, &view(), [([1.0, 0.3, 0.1], true), ([1.0, -0.3, 0.72], false)].into_iter(), &cfg);
        let turn = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 180f32.to_radians() };
        m.update(FRAME_NS, Some(turn), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert_eq!(m.out_of_view.len(), m.out_of_view_cane.len());
        // behind the user now: the bin on their right, the table on their left
        let bin: Vec<bool> =
            m.out_of_view.iter().zip(&m.out_of_view_cane).filter(|(p, _)| p[1] < 0.0).map(|(_, &c)| c).collect();
        let table: Vec<bool> =
            m.out_of_view.iter().zip(&m.out_of_view_cane).filter(|(p, _)| p[1] > 0.0).map(|(_, &c)| c).collect();
        assert!(!bin.is_empty() && bin.iter().all(|&c| c), "{bin:?}");
        assert!(!table.is_empty() && table.iter().all(|&c| !c), "{table:?}");
    }

    #[test]
    fn turning_left_moves_an_obstacle_ahead_to_the_right_and_it_decays() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        m.update(0, None, &view(), [[1.0, 0.0, 0.5]].into_iter(), &cfg);
        let turn = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 90f32.to_radians() };
        m.update(FRAME_NS, Some(turn), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        // one 10 cm cell 1 m away covers 5.7 degrees of bearing
        assert!((5..=7).contains(&m.out_of_view.len()), "{}", m.out_of_view.len());
        for &[x, y] in &m.out_of_view {
            assert!(x.abs() < 0.1 && (y + 1.0).abs() < 0.1, "({x}, {y})");
        }
        m.update(FRAME_NS + cfg.ttl_ns + 1, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!(m.out_of_view.is_empty());
    }

    #[test]
    fn a_sign_in_the_top_rows_of_the_image_is_kept_until_it_is_well_inside() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        // 1.6 m high, 3.2 m ahead: 11.1 deg above the axis of a camera at 1 m pitched
        // 10 deg down, 1.4 deg inside the top edge (12.5 deg): in the image, but the scan
        // no longer ranges it there
        m.update(0, None, &view(), [[3.2, 0.0, 1.6]].into_iter(), &cfg);
        assert!(view().sees(3.2, 0.0, 1.6, 0.0));
        m.update(FRAME_NS, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!(!m.out_of_view.is_empty(), "kept");
        // well inside (3 deg from the edge or more), the camera's word counts
        m.update(2 * FRAME_NS, None, &view(), [[6.0, 0.0, 1.6]].into_iter(), &cfg);
        m.update(3 * FRAME_NS, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!(m.out_of_view.iter().all(|p| p[0] < 5.0), "{:?}", m.out_of_view);
    }

    #[test]
    fn a_near_cell_weighs_as_many_degrees_as_it_covers() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        // beside the user, out of view: 0.5 m away a 10 cm cell covers 11.4 degrees
        m.update(0, None, &view(), [[0.0, 0.5, 0.5]].into_iter(), &cfg);
        m.update(FRAME_NS, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!((11..=13).contains(&m.out_of_view.len()), "{}", m.out_of_view.len());
        assert!(m.out_of_view.iter().all(|p| (p[0].hypot(p[1]) - 0.5).abs() < 1e-3));
        // 4 m away it covers 1.4: one or two degrees
        let mut far = ObstacleMemory::default();
        far.update(0, None, &view(), [[0.0, 4.0, 0.5]].into_iter(), &cfg);
        far.update(FRAME_NS, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!((1..=2).contains(&far.out_of_view.len()), "{}", far.out_of_view.len());
    }

    #[test]
    fn standing_still_keeps_an_obstacle_that_walking_on_forgets() {
        let cfg = MemoryConfig::default();
        let still = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 0.0 };
        let mut m = ObstacleMemory::default();
        m.update(0, None, &view(), [[0.0, 1.0, 0.5]].into_iter(), &cfg);
        // 5 s standing beside it: still there (the old 3 s time to live forgot it)
        for k in 1..=150u64 {
            m.update(k * FRAME_NS, Some(still), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        }
        assert!(!m.out_of_view.is_empty());
        // past the time to live, even standing, it goes
        m.update(cfg.ttl_ns + 1, Some(still), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!(m.out_of_view.is_empty());
        // walking on away from one behind the user (never in view) forgets it after
        // `forget_after_m`
        let cfg = MemoryConfig { forget_after_m: 2.0, ..cfg };
        let mut w = ObstacleMemory::default();
        w.update(0, None, &view(), [[-0.5, 0.0, 0.5]].into_iter(), &cfg);
        let back = Motion { forward_m: 0.02, left_m: 0.0, yaw_rad: 0.0 };
        let steps = (cfg.forget_after_m / 0.02).round() as u64;
        for k in 1..steps - 1 {
            w.update(k * FRAME_NS, Some(back), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        }
        assert!(!w.out_of_view.is_empty(), "kept until {} m walked", cfg.forget_after_m);
        for k in steps - 1..steps + 2 {
            w.update(k * FRAME_NS, Some(back), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        }
        assert!(w.out_of_view.is_empty());
    }

    #[test]
    fn unseen_floor_that_may_be_lower_is_kept_unless_the_floor_was_seen_there() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        let mut out = Vec::new();
        // walking up, the floor 1 m ahead was seen (the strip x 0.95..1.05, y -0.3..0.3)
        let floor: Vec<[f32; 2]> = (-6..=6).map(|k| [1.0, 0.05 * k as f32]).collect();
        m.update(0, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        m.unseen_lower(0, &floor, &[], &cfg, &mut out);
        assert!(out.is_empty());
        // 0.6 m on, lower ground fills the bottom of the view: the floor under it may
        // be lower, except where it was seen (now 0.4 m ahead)
        let on = Motion { forward_m: 0.6, left_m: 0.0, yaw_rad: 0.0 };
        m.update(FRAME_NS, Some(on), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        let unseen = [[0.4, 0.0], [0.4, 0.2], [0.3, 0.0], [0.4, -0.6]];
        m.unseen_lower(FRAME_NS, &[], &unseen, &cfg, &mut out);
        assert_eq!(out, vec![[0.3, 0.0], [0.4, -0.6]]);
        // and both are remembered once the user turns away
        let turn = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 90f32.to_radians() };
        m.update(2 * FRAME_NS, Some(turn), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        let near = |p: [f32; 2]| m.out_of_view.iter().any(|q| (q[0] - p[0]).hypot(q[1] - p[1]) < 0.05);
        assert!(near([0.0, -0.3]) && near([-0.6, -0.4]), "{:?}", m.out_of_view);
        // the floor seen (now on the right) outlasts the obstacles' time to live, and is
        // forgotten after its own
        let seen_floor = [[0.0, -0.4]];
        out.clear();
        m.update(cfg.ttl_ns + 1, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        m.unseen_lower(cfg.ttl_ns + 1, &[], &seen_floor, &cfg, &mut out);
        assert!(out.is_empty(), "{out:?}");
        m.update(FLOOR_TTL_NS + 1, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        m.unseen_lower(FLOOR_TTL_NS + 1, &[], &seen_floor, &cfg, &mut out);
        assert_eq!(out, seen_floor);
    }

    #[test]
    fn lower_ground_before_the_camera_is_told_until_the_user_turns_away_from_it() {
        let cfg = MemoryConfig::default();
        // the box between the feet (0.35 m behind the camera) and the camera
        let zone = |from: f32, to: f32, half: f32| move |p: [f32; 2]| (from..=to).contains(&p[0]) && p[1].abs() <= half;
        let (from, to, half) = (-0.25, 0.0, 0.2);
        let mut m = ObstacleMemory::default();
        m.update(0, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        let mut out = Vec::new();
        // the floor 0.25 m ahead of the feet may be lower
        m.unseen_lower(0, &[], &[[-0.1, 0.05]], &cfg, &mut out);
        assert!(m.lower_ground_where(zone(from, to, half)));
        assert!(!m.lower_ground_where(zone(from, to, 0.01)), "0.05 m to the left");
        // turned round in place (the camera swings 0.7 m back round the feet): behind
        let turn = Motion { forward_m: -0.7, left_m: 0.0, yaw_rad: PI };
        m.update(FRAME_NS, Some(turn), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!(!m.lower_ground_where(zone(from, to, half)));
        assert!(m.lower_ground_where(zone(-0.65, -0.55, half)), "still remembered, 0.25 m behind the feet");
        // an obstacle there is no lower ground: the costs and the body see to it
        let mut bag = ObstacleMemory::default();
        bag.update(0, None, &view(), [[-0.1, 0.05, 0.3]].into_iter(), &cfg);
        assert_eq!(bag.len(), 1);
        assert!(!bag.lower_ground_where(zone(from, to, half)));
    }

    #[test]
    fn an_overhead_obstacle_is_kept_through_a_turn_away_that_forgets_a_low_one() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        // a sign 1.55 m up and a chair back 0.8 m up, both 3.5 m to the left
        m.update(0, None, &view(), [[0.3, 3.5, 1.55], [-0.3, 3.5, 0.8]].into_iter(), &cfg);
        // the user turns round to the right (both move 7 m in the user's frame, behind
        // the user, never in view) and stands 30 s
        let half_turn = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: -PI / 30.0 };
        for k in 1..=30u64 {
            m.update(k * FRAME_NS, Some(half_turn), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        }
        let still = Motion { forward_m: 0.0, left_m: 0.0, yaw_rad: 0.0 };
        m.update(30_000_000_000, Some(still), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        // the sign alone, now on the right (the chair back, 0.6 m behind it, is gone)
        let sign = |p: &[f32; 2]| (p[0] + 0.3).abs() < 0.1 && (p[1] + 3.5).abs() < 0.1;
        assert!(!m.out_of_view.is_empty() && m.out_of_view.iter().all(sign), "{:?}", m.out_of_view);
        // past a minute it goes too
        m.update(cfg.overhead_ttl_ns + 1, Some(still), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!(m.out_of_view.is_empty());
        // beyond the memory's radius it goes at once
        let mut w = ObstacleMemory::default();
        w.update(0, None, &view(), [[-0.5, 0.0, 1.55]].into_iter(), &cfg);
        let on = Motion { forward_m: 0.5, left_m: 0.0, yaw_rad: 0.0 };
        let steps = ((cfg.radius_m - 0.5) / 0.5).round() as u64;
        for k in 1..steps {
            w.update(k * FRAME_NS, Some(on), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        }
        assert!(!w.out_of_view.is_empty(), "kept within {} m", cfg.radius_m);
        w.update(steps * FRAME_NS, Some(on), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        w.update((steps + 1) * FRAME_NS, Some(on), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!(w.out_of_view.is_empty());
    }

    #[test]
    fn obstacle_still_in_view_but_gone_is_dropped() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        m.update(0, None, &view(), [[2.0, 0.0, 0.5]].into_iter(), &cfg);
        m.update(FRAME_NS, None, &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        assert!(m.out_of_view.is_empty());
    }

    #[test]
    fn a_sign_beside_a_sweeping_cane_is_remembered_whole() {
        let cfg = MemoryConfig::default();
        let mut m = ObstacleMemory::default();
        // a 0.9 m sign 2.5 m ahead, above the view (23.5 deg above the axis), as the
        // scan gave it: one point per degree of bearing
        let sign: Vec<[f32; 3]> = (-9..=9).map(|k| [2.5, 0.05 * k as f32, 1.6]).collect();
        assert!(sign.iter().all(|p| !view().sees(p[0], p[1], p[2], 0.0)));
        m.update(0, None, &view(), sign.iter().copied(), &cfg);
        let stored = m.len();
        // the user stands and sweeps: the camera, 0.5 m out from the hand, swings
        // +-17 deg at 0.75 Hz for four sweeps
        let (arm_m, amplitude) = (0.5f32, 17f32.to_radians());
        let angle = |k: u64| amplitude * (std::f32::consts::TAU * 0.75 * k as f32 / 30.0).sin();
        for k in 1..=160u64 {
            let d = angle(k) - angle(k - 1);
            let motion = Motion { forward_m: arm_m * (d.cos() - 1.0), left_m: arm_m * d.sin(), yaw_rad: d };
            m.update(k * FRAME_NS, Some(motion), &view(), std::iter::empty::<[f32; 3]>(), &cfg);
        }
        // back where it started: all of the sign is still there, where it was
        let ys: Vec<f32> = m.out_of_view.iter().map(|p| p[1]).collect();
        let (lo, hi) = ys.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &y| (a.min(y), b.max(y)));
        assert!(lo < -0.4 && hi > 0.4, "the sign now spans {lo:.2}..{hi:.2} m, truly -0.45..0.45");
        assert!(m.out_of_view.iter().all(|p| (p[0] - 2.5).abs() < 0.06), "{:?}", m.out_of_view);
        assert_eq!(m.len(), stored, "cells merged");
    }
}
