//! The cues a device with perfect knowledge would give: bounds of what perception could
//! do for the virtual user. Each camera frame the oracle walks a copy of the user ahead
//! in simulated time, once per rumble state held from the moment it would reach the
//! hands, against the true geometry of the world (every obstacle, seen or not, where it
//! will be), and picks a state under which neither the cane nor the body touches
//! anything within the horizon; clear whenever clear is safe. It knows how the user
//! reacts (the instructions and the reaction time). [`Knows::Goal`]: it also knows what
//! the user heads for, which no device does, so what it cannot spare the user, no
//! perception can. [`Knows::Ahead`]: it takes the user to walk on as they face while
//! nothing rumbles, as a device that sees perfectly but cannot read the user's mind
//! must: a bound for perception that is only as good as its sensing. [`Knows::Intent`]:
//! it takes the user to head again the way they last walked free, as a device could
//! learn from the user's walking. [`Sees::Perception`] checks against what the
//! perception holds instead of the world, so only the perception's sensing limits it.

use schemas::Rumble;
use sim::{CaneMount, World};

use super::contacts::{cane_distance_m, RELEASE_M, TOUCH_M};
use super::hands::Felt;
use super::virtual_user::{Guide, Touch, UserParams, VirtualUser};
use super::walk::sweep_scale;

/// What the oracle's look-ahead is checked against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Sees {
    /// The world's true geometry.
    World,
    /// What the perception holds this frame: the obstacle points its cost functions
    /// took (in view, remembered beyond the field of view, edges of lower ground).
    Perception,
}

/// What the oracle knows of where the user goes while nothing rumbles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Knows {
    /// What the user heads for (the goal's sound, the route, the experimenter).
    Goal,
    /// Only the way the user faces: they are taken to walk straight on.
    Ahead,
    /// The way the user walked last when free (nothing felt for a while, at pace): they
    /// are taken to head that way again whenever nothing rumbles, as a device could
    /// learn from the user's own walking.
    Intent,
}

/// What the oracle keeps from being touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Guards {
    /// The cane and the body: nothing is touched.
    All,
    /// The body alone: the cane may touch, and the user is taken to turn away from what
    /// it finds, as a cane user does; a state is unsafe only when the body would touch
    /// something all the same (overhangs, what the cane's sweep misses, a touch found
    /// too late to turn from).
    Body,
}

/// Free walking for this long, at pace, shows where the user wants to go, seconds.
const INTENT_FREE_S: f64 = 2.0;

/// How far ahead, and how finely, the oracle looks.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct OracleConfig {
    /// What it knows of the user's way.
    pub knows: Knows,
    /// What its look-ahead is checked against.
    pub sees: Sees,
    /// What it keeps from being touched.
    pub guards: Guards,
    /// Look-ahead, seconds: a state is safe when nothing is touched this long after it
    /// is sent.
    pub horizon_s: f64,
    /// Closer than this counts as a touch, metres (a margin over the contact test).
    pub margin_m: f64,
    /// Steps per second of the look-ahead.
    pub steps_hz: f64,
    /// Clear is also kept while the user could still be warned this much later, seconds:
    /// a cue comes at the last moment it can still be acted on (earlier ones turn the
    /// user for nothing, and each is a signal).
    pub defer_s: f64,
    /// The turning rate the oracle takes the user to have, degrees per second (`None`:
    /// the user's own).
    pub turn_rate_deg_s: Option<f64>,
    /// Reaction times tried, as fractions of the study's user's mean: a state is safe
    /// only if it is for the quickest and the slowest (each walk's user is up to 25 % off).
    pub reaction_factors: [f64; 2],
}

impl OracleConfig {
    /// An oracle that knows `knows` and checks against `sees`: 2.5 s ahead (a reaction
    /// time, slowing down and a turn), 5 cm margin, 60 steps/s, cues deferred while a
    /// warning 0.1 s later would still do, reaction times 25 % either side of the mean.
    pub fn new(knows: Knows, sees: Sees) -> Self {
        Self {
            knows,
            sees,
            guards: Guards::All,
            horizon_s: 2.5,
            margin_m: 0.05,
            steps_hz: 60.0,
            defer_s: 0.1,
            turn_rate_deg_s: None,
            reaction_factors: [0.75, 1.25],
        }
    }
}

/// The oracle's state between frames: the state it last sent.
#[derive(Debug, Clone)]
pub struct Oracle {
    config: OracleConfig,
    current: Rumble,
    /// Since when nothing has been felt with the user at pace, seconds.
    free_since_s: Option<f64>,
    /// The heading the user walked last when free, map radians.
    intent_rad: Option<f64>,
}

/// The states tried, in the order preferred among the safe ones after clear.
const STATES: [Rumble; 3] = [Rumble::Left, Rumble::Right, Rumble::Both];

impl Oracle {
    /// An oracle that has sent nothing yet.
    pub fn new(config: OracleConfig) -> Self {
        Self { config, current: Rumble::None, free_since_s: None, intent_rad: None }
    }

    /// The configuration.
    pub fn config(&self) -> &OracleConfig {
        &self.config
    }

    /// The rumble state to send at `t_s`: `now` says where the user is (with what they
    /// felt so far and what they head for), feeling `now.felt` until the state reaches
    /// the hands `now.latency_s` later.
    pub fn decide(&mut self, mount: &CaneMount, now: &Now<'_>) -> Rumble {
        let params = now.user.params();
        if now.felt == Felt::None && now.user.speed_m_s() >= 0.8 * params.walk_speed_m_s {
            let since = *self.free_since_s.get_or_insert(now.t_s);
            if now.t_s - since >= INTENT_FREE_S {
                self.intent_rad = Some(now.user.pose().yaw_rad);
            }
        } else {
            self.free_since_s = None;
        }
        let intent_rad = self.intent_rad;
        let defer_s = self.config.defer_s;
        let look = |state: Rumble| first_touch_s(mount, now, felt(state), None, intent_rad, &self.config);
        let deferred = |state: Rumble| {
            first_touch_s(mount, now, Felt::None, Some((defer_s, felt(state))), intent_rad, &self.config)
        };
        let choice = if look(Rumble::None).is_none() {
            Rumble::None
        } else if self.current == Rumble::None && defer_s > 0.0 && STATES.iter().any(|&s| deferred(s).is_none()) {
            // a warning a moment later would still do: one now turns the user for nothing
            Rumble::None
        } else if self.current != Rumble::None && look(self.current).is_none() {
            self.current
        } else {
            // the safe state, or the one that puts the touch off longest
            let mut best = (0.0, self.current);
            for state in STATES {
                match look(state) {
                    None => {
                        best = (f64::INFINITY, state);
                        break;
                    }
                    Some(s) if s > best.0 => best = (s, state),
                    Some(_) => {}
                }
            }
            best.1
        };
        self.current = choice;
        choice
    }
}

/// The walk as it stands when the oracle decides.
pub struct Now<'a> {
    /// Seconds into the walk.
    pub t_s: f64,
    /// The user, with what they felt so far.
    pub user: &'a VirtualUser,
    /// How the oracle takes the user to walk and react: the study's user as configured
    /// (its mean reaction), not this walk's own draw of the reaction time.
    pub assumed: UserParams,
    /// What the user heads for, in its present state.
    pub guide: &'a dyn Guide,
    /// The heading the guide gave last.
    pub target_rad: Option<f64>,
    /// The guide is asked again every this many seconds.
    pub guide_every_s: f64,
    /// When the guide was asked last, seconds into the walk.
    pub guided_at_s: f64,
    /// What the hands feel now, until a state sent now reaches them.
    pub felt: Felt,
    /// From sending a state to the hands feeling it, seconds.
    pub latency_s: f64,
    /// Where the walk ends: the goal, and how near counts as reaching it, metres.
    pub goal: ([f64; 2], f64),
    /// What the oracle checks the look-ahead against.
    pub seen: Seen<'a>,
}

/// What the oracle's look-ahead is checked against.
#[derive(Clone, Copy)]
pub enum Seen<'a> {
    /// The world itself: every obstacle, seen or not, where it will be.
    World(&'a World),
    /// What the perception holds this frame (in view, remembered, edges of lower
    /// ground): each point a column from the floor up, standing still.
    Points(&'a PointGrid),
}

/// Obstacle points on the map, binned so that a look-ahead step only looks at those
/// near the user.
#[derive(Debug, Clone, Default)]
pub struct PointGrid {
    points: Vec<[f64; 2]>,
    origin_m: [f64; 2],
    cols: usize,
    rows: usize,
    /// Start of each cell's run in `order` (`cols * rows + 1` of them).
    starts: Vec<u32>,
    /// Point indices, cell by cell.
    order: Vec<u32>,
}

/// Side of a [`PointGrid`] cell, metres.
const CELL_M: f64 = 0.5;

impl PointGrid {
    /// Bins `points` (map metres; the grid keeps its buffers for the next frame).
    pub fn rebuild(&mut self, points: impl Iterator<Item = [f64; 2]>) {
        self.points.clear();
        self.points.extend(points.filter(|p| p[0].is_finite() && p[1].is_finite()));
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &self.points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if self.points.is_empty() {
            (lo, hi) = ([0.0; 2], [0.0; 2]);
        }
        self.origin_m = lo;
        self.cols = ((hi[0] - lo[0]) / CELL_M) as usize + 1;
        self.rows = ((hi[1] - lo[1]) / CELL_M) as usize + 1;
        let cells = self.cols * self.rows;
        self.starts.clear();
        self.starts.resize(cells + 1, 0);
        for i in 0..self.points.len() {
            let c = self.cell(&self.points[i]);
            self.starts[c + 1] += 1;
        }
        for c in 0..cells {
            self.starts[c + 1] += self.starts[c];
        }
        let mut next = self.starts.clone();
        self.order.clear();
        self.order.resize(self.points.len(), 0);
        for (i, p) in self.points.iter().enumerate() {
            let c = self.cell(p);
            self.order[next[c] as usize] = i as u32;
            next[c] += 1;
        }
    }

    /// How many points there are.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there is no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    fn cell(&self, p: &[f64; 2]) -> usize {
        let c = (((p[0] - self.origin_m[0]) / CELL_M) as usize).min(self.cols - 1);
        let r = (((p[1] - self.origin_m[1]) / CELL_M) as usize).min(self.rows - 1);
        r * self.cols + c
    }

    /// Every point within the box `lo`..`hi` (and some near it), with its index.
    fn near(&self, lo: [f64; 2], hi: [f64; 2], mut f: impl FnMut(usize, [f64; 2])) {
        if self.points.is_empty() {
            return;
        }
        let index = |v: f64, o: f64, n: usize| (((v - o) / CELL_M).floor().max(0.0) as usize).min(n - 1);
        if hi[0] < self.origin_m[0] || hi[1] < self.origin_m[1] {
            return;
        }
        let (c0, c1) = (index(lo[0], self.origin_m[0], self.cols), index(hi[0], self.origin_m[0], self.cols));
        let (r0, r1) = (index(lo[1], self.origin_m[1], self.rows), index(hi[1], self.origin_m[1], self.rows));
        for r in r0..=r1 {
            let (a, b) = (self.starts[r * self.cols + c0] as usize, self.starts[r * self.cols + c1 + 1] as usize);
            for &i in &self.order[a..b] {
                f(i as usize, self.points[i as usize]);
            }
        }
    }
}

impl Seen<'_> {
    /// How many obstacles (or points) there are.
    fn len(&self) -> usize {
        match self {
            Seen::World(w) => w.obstacles().len(),
            Seen::Points(p) => p.len(),
        }
    }

    /// Calls `f` with the index and the body's and the cane's distances (metres) of
    /// every obstacle or point within `reach_m` of either; distances beyond `reach_m`
    /// may be lower bounds, and points beyond it are left out.
    #[allow(clippy::too_many_arguments)]
    fn near_m(
        &self,
        floor: i32,
        t_s: f64,
        body_xy: [f64; 2],
        (hand, tip): ([f64; 3], [f64; 3]),
        (radius_m, height_m): (f64, f64),
        reach_m: f64,
        mut f: impl FnMut(usize, Apart),
    ) {
        match self {
            Seen::World(world) => {
                let far = Apart { body_m: f64::INFINITY, cane_m: f64::INFINITY };
                let mut nearest = [far; 64];
                for (id, shape) in world.obstacles_at(floor, t_s) {
                    let body_m = shape.body_distance_m(body_xy[0], body_xy[1], radius_m, height_m);
                    let cane_m = cane_distance_m(&shape, hand, tip, reach_m);
                    let i = id.0 as usize;
                    match nearest.get_mut(i) {
                        Some(d) => *d = Apart { body_m: d.body_m.min(body_m), cane_m: d.cane_m.min(cane_m) },
                        // more obstacles than the stack holds: report each shape
                        None => f(i, Apart { body_m, cane_m }),
                    }
                }
                for (i, &d) in nearest.iter().enumerate().take(world.obstacles().len()) {
                    f(i, d);
                }
            }
            Seen::Points(grid) => {
                let r = radius_m.max(0.0) + reach_m;
                let lo = [body_xy[0].min(hand[0]).min(tip[0]) - r, body_xy[1].min(hand[1]).min(tip[1]) - r];
                let hi = [body_xy[0].max(hand[0]).max(tip[0]) + r, body_xy[1].max(hand[1]).max(tip[1]) + r];
                // the hot loop of the look-ahead: squares and one root, no `hypot`
                let (ax, ay) = (hand[0], hand[1]);
                let (dx, dy) = (tip[0] - ax, tip[1] - ay);
                let len2 = (dx * dx + dy * dy).max(1e-12);
                grid.near(lo, hi, |i, p| {
                    let (bx, by) = (p[0] - body_xy[0], p[1] - body_xy[1]);
                    let body_m = (bx * bx + by * by).sqrt() - radius_m;
                    let (px, py) = (p[0] - ax, p[1] - ay);
                    let s = ((px * dx + py * dy) / len2).clamp(0.0, 1.0);
                    let (cx, cy) = (px - s * dx, py - s * dy);
                    f(i, Apart { body_m, cane_m: (cx * cx + cy * cy).sqrt() });
                });
            }
        }
    }
}

/// How far an obstacle or point is from the body and from the cane, metres.
#[derive(Debug, Clone, Copy)]
struct Apart {
    body_m: f64,
    cane_m: f64,
}

/// What the hands feel of a rumble state.
fn felt(state: Rumble) -> Felt {
    match state {
        Rumble::None => Felt::None,
        Rumble::Left => Felt::Left,
        Rumble::Right => Felt::Right,
        Rumble::Both => Felt::Both,
    }
}

/// Seconds from now to the first new touch of the cane or the body (within the margin)
/// if the hands feel `state` from when it would reach them; `None` when nothing is
/// touched within the horizon or before the goal. What the cane or body already touches
/// at the start counts only once it has come clear again.
fn first_touch_s(
    mount: &CaneMount,
    now: &Now<'_>,
    state: Felt,
    then: Option<(f64, Felt)>,
    intent_rad: Option<f64>,
    config: &OracleConfig,
) -> Option<f64> {
    config
        .reaction_factors
        .iter()
        .filter_map(|f| {
            let assumed = UserParams { reaction_s: now.assumed.reaction_s * f, ..now.assumed };
            first_touch_one_s(mount, now, assumed, state, then, intent_rad, config)
        })
        .min_by(f64::total_cmp)
}

#[allow(clippy::too_many_arguments)]
fn first_touch_one_s(
    mount: &CaneMount,
    now: &Now<'_>,
    assumed: UserParams,
    state: Felt,
    then: Option<(f64, Felt)>,
    intent_rad: Option<f64>,
    config: &OracleConfig,
) -> Option<f64> {
    let mut u = now.user.with_params(assumed);
    let mut guide = now.guide.boxed_clone();
    let knows_goal = config.knows == Knows::Goal;
    let ahead = Some(u.pose().yaw_rad);
    let mut target_rad = match config.knows {
        Knows::Goal => now.target_rad,
        Knows::Ahead => ahead,
        Knows::Intent => intent_rad.or(ahead),
    };
    let mut guided_at_s = now.guided_at_s;
    let params = *u.params();
    let radius_m = params.shoulder_width_m / 2.0;
    let dt = 1.0 / config.steps_hz;
    let steps = (config.horizon_s * config.steps_hz).ceil() as usize;
    let mut armed = vec![true; now.seen.len()];
    let mut cane_armed = vec![true; now.seen.len()];
    let body_only = config.guards == Guards::Body;
    // near enough to be told from a touch and from its release
    let reach_m = config.margin_m + 2.0 * RELEASE_M;
    let t0_s = now.t_s;
    let ([goal_x, goal_y], goal_radius_m) = now.goal;
    for k in 0..=steps {
        let t = t0_s + k as f64 * dt;
        if k > 0 {
            let from = t0_s + now.latency_s;
            let f = match then {
                Some((after, next)) if t >= from + after => next,
                _ if t >= from => state,
                _ => now.felt,
            };
            u.feel(t, f, None);
            if knows_goal && t - guided_at_s >= now.guide_every_s {
                target_rad = guide.heading_target_rad(&u.pose(), t);
                guided_at_s = t;
            }
            let (pose, speed) = u.propose(t, dt, target_rad);
            u.commit(pose, speed);
        }
        let pose = u.pose();
        if (pose.x_m - goal_x).hypot(pose.y_m - goal_y) <= goal_radius_m {
            return None;
        }
        let sweep = mount.sweep_rad(t) * sweep_scale(u.speed_m_s(), &params);
        let (hand, tip) = mount.cane_segment(&pose, sweep);
        let mut touched = false;
        let mut cane_touch = false;
        now.seen.near_m(
            pose.floor,
            t,
            [pose.x_m, pose.y_m],
            (hand, tip),
            (radius_m, params.height_m),
            reach_m,
            |i, apart| {
                let d = if body_only { apart.body_m } else { apart.body_m.min(apart.cane_m) };
                if let Some(a) = armed.get_mut(i) {
                    if d <= config.margin_m {
                        touched |= *a && k > 0;
                        *a = false;
                    } else if d > config.margin_m + RELEASE_M {
                        *a = true;
                    }
                }
                if let Some(a) = cane_armed.get_mut(i).filter(|_| body_only) {
                    if apart.cane_m <= TOUCH_M {
                        cane_touch |= *a && k > 0;
                        *a = false;
                    } else if apart.cane_m > RELEASE_M {
                        *a = true;
                    }
                }
            },
        );
        if cane_touch {
            // the user turns away from what the cane found, a reaction time later
            u.touch(Touch { t_s: t, on_left: sweep >= 0.0 });
        }
        if touched {
            return Some(t - t0_s);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::virtual_user::GoalSound;
    use sim::UserPose;

    /// A wall 1 m wide standing across the way 4 m ahead of a user at the origin facing
    /// +x, or (`beside`) along the way 0.8 m to the user's left; the goal 8 m ahead.
    fn world(beside: bool) -> World {
        let wall = if beside { "from = [0.5, 0.8]\nto = [6.0, 0.8]" } else { "from = [4.0, -0.5]\nto = [4.0, 0.5]" };
        world_with(&format!("[[walls]]\nlabel = \"wall\"\n{wall}\n"))
    }

    /// The user at the origin facing +x, the goal 8 m ahead, and `obstacles` (scene TOML).
    fn world_with(obstacles: &str) -> World {
        let toml =
            format!("name = \"t\"\nstart = {{ x_m = 0.0, y_m = 0.0 }}\ngoal = {{ x_m = 8.0, y_m = 0.0 }}\n{obstacles}");
        World::from_toml(&toml, "t").unwrap_or_else(|e| panic!("{e}"))
    }

    /// The wall of `world` as columns every 5 cm (what a perception would hold of it).
    fn wall_points(beside: bool) -> PointGrid {
        let mut grid = PointGrid::default();
        grid.rebuild((0..=110).map(|i| i as f64 * 0.05).filter(|&s| beside || s <= 1.0).map(|s| {
            if beside {
                [0.5 + s, 0.8 - 0.05]
            } else {
                [4.0 - 0.05, -0.5 + s]
            }
        }));
        grid
    }

    struct Walked {
        /// Body's x when the oracle first sent something other than clear.
        first_cue_x_m: Option<f64>,
        /// Nearest the cane or the body came to the wall, metres.
        nearest_m: f64,
        /// Nearest the body came to it, metres.
        nearest_body_m: f64,
        /// Touches of the cane (each felt by the user, who turns away).
        cane_touches: u32,
        /// Body's x at the cane's first touch.
        first_cane_touch_x_m: Option<f64>,
    }

    /// The user walks 6 s towards the goal with the oracle's cues felt 50 ms after they
    /// are sent (no rendering, no perception): a closed loop of the oracle alone.
    fn walk_with_oracle(world: &World, seen: Seen<'_>, guards: Guards) -> Walked {
        let params = UserParams::default();
        let mut user = VirtualUser::new(params, UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 });
        let guide = GoalSound { x_m: 8.0, y_m: 0.0 };
        let mount = CaneMount::default();
        let mut oracle = Oracle::new(OracleConfig { guards, ..OracleConfig::new(Knows::Goal, Sees::World) });
        let (dt, latency_s) = (1.0 / 120.0, 0.05);
        let mut cane_armed = true;
        let mut sent: std::collections::VecDeque<(f64, Felt)> = Default::default();
        let mut felt_now = Felt::None;
        let mut out = Walked {
            first_cue_x_m: None,
            nearest_m: f64::INFINITY,
            nearest_body_m: f64::INFINITY,
            cane_touches: 0,
            first_cane_touch_x_m: None,
        };
        for step in 0..720u32 {
            let t = f64::from(step) * dt;
            let pose = user.pose();
            let target = Some((0.0 - pose.y_m).atan2(8.0 - pose.x_m));
            if step % 4 == 0 {
                let now = Now {
                    t_s: t,
                    user: &user,
                    assumed: params,
                    guide: &guide,
                    target_rad: target,
                    guide_every_s: 0.25,
                    guided_at_s: t,
                    felt: felt_now,
                    latency_s,
                    goal: ([8.0, 0.0], 0.5),
                    seen,
                };
                let state = oracle.decide(&mount, &now);
                if state != Rumble::None && out.first_cue_x_m.is_none() {
                    out.first_cue_x_m = Some(pose.x_m);
                }
                sent.push_back((t + latency_s, felt(state)));
            }
            while sent.front().is_some_and(|(at, _)| *at <= t) {
                if let Some((_, f)) = sent.pop_front() {
                    felt_now = f;
                }
            }
            user.feel(t, felt_now, None);
            let (next, speed) = user.propose(t, dt, target);
            user.commit(next, speed);
            let p = user.pose();
            let sweep = mount.sweep_rad(t + dt) * sweep_scale(speed, &params);
            let mut cane_m = f64::INFINITY;
            Seen::World(world).near_m(
                0,
                t,
                [p.x_m, p.y_m],
                mount.cane_segment(&p, sweep),
                (0.225, params.height_m),
                0.05,
                |_, d| {
                    out.nearest_m = out.nearest_m.min(d.body_m.min(d.cane_m));
                    out.nearest_body_m = out.nearest_body_m.min(d.body_m);
                    cane_m = cane_m.min(d.cane_m);
                },
            );
            if cane_m <= TOUCH_M && cane_armed {
                out.cane_touches += 1;
                out.first_cane_touch_x_m.get_or_insert(p.x_m);
                user.touch(Touch { t_s: t, on_left: sweep >= 0.0 });
            }
            cane_armed = if cane_m <= TOUCH_M { false } else { cane_armed || cane_m > RELEASE_M };
        }
        out
    }

    #[test]
    fn a_wall_across_the_way_is_warned_in_time_and_never_touched() {
        let w = world(false);
        let walked = walk_with_oracle(&w, Seen::World(&w), Guards::All);
        let x = walked.first_cue_x_m.unwrap_or_else(|| panic!("no cue"));
        println!("first cue with the body at x = {x:.3} m, nearest {:.3} m", walked.nearest_m);
        // the wall's face is at 3.95 m, the still walking cane's tip 1.08 m ahead of the
        // body: the cue comes before a reaction time of walking (0.5-0.6 m) would bring
        // the tip to it, and not before the wall is within a couple of steps of it
        assert!((1.0..=2.4).contains(&x), "first cue with the body at x = {x:.2} m");
        assert!(walked.nearest_m > 0.04, "came within {:.3} m of the wall", walked.nearest_m);
    }

    #[test]
    fn the_same_wall_held_as_points_is_warned_the_same_way() {
        let w = world(false);
        let points = wall_points(false);
        let from_world = walk_with_oracle(&w, Seen::World(&w), Guards::All);
        let from_points = walk_with_oracle(&w, Seen::Points(&points), Guards::All);
        let (a, b) = (from_world.first_cue_x_m.unwrap_or(f64::NAN), from_points.first_cue_x_m.unwrap_or(f64::NAN));
        assert!((a - b).abs() <= 0.1, "first cue at x = {a:.2} (world) and {b:.2} m (points)");
        assert!(from_points.nearest_m > 0.04, "came within {:.3} m of the wall", from_points.nearest_m);
    }

    #[test]
    fn a_wall_along_the_way_beside_the_user_is_never_warned() {
        let w = world(true);
        let points = wall_points(true);
        for seen in [Seen::World(&w), Seen::Points(&points)] {
            let walked = walk_with_oracle(&w, seen, Guards::All);
            assert_eq!(walked.first_cue_x_m, None);
            assert!(walked.nearest_m > 0.1, "came within {:.3} m of the wall", walked.nearest_m);
        }
    }

    #[test]
    fn guarding_the_body_warns_of_a_wall_later_than_guarding_the_cane_too() {
        let w = world(false);
        let walked = walk_with_oracle(&w, Seen::World(&w), Guards::Body);
        println!(
            "first cue at {:?}, first cane touch at {:?}, body within {:.3} m",
            walked.first_cue_x_m, walked.first_cane_touch_x_m, walked.nearest_body_m
        );
        // the cane reaches the wall 1.08 m ahead of the body, and a user turning from
        // it a reaction time later does not always stop short: the body-only oracle
        // warns too, but later than one that keeps the cane off, and the body never
        // reaches the wall
        let all = walk_with_oracle(&w, Seen::World(&w), Guards::All);
        let (x, x_all) = (walked.first_cue_x_m.unwrap_or(f64::INFINITY), all.first_cue_x_m.unwrap_or(f64::NAN));
        assert!(x >= x_all + 0.3, "body only: first cue at x = {x:.2} m, keeping the cane off too: {x_all:.2} m");
        assert!(walked.nearest_body_m > 0.04, "the body came within {:.3} m", walked.nearest_body_m);
    }

    #[test]
    fn guarding_the_body_warns_of_a_sign_the_cane_sweeps_under() {
        // a sign 1 m wide at 1.5-1.85 m across the way, 4 m ahead
        let w = world_with(
            "[[hanging]]\nlabel = \"sign\"\ncenter = [4.05, 0.0]\nsize_m = [0.1, 1.0]\nbottom_m = 1.5\ntop_m = 1.85\n",
        );
        let off = walk_with_oracle(&w, Seen::World(&w), Guards::Body);
        let x = off.first_cue_x_m.unwrap_or_else(|| panic!("no cue for a sign the cane sweeps under"));
        println!(
            "first cue at x = {x:.3} m, {} cane touches, body within {:.3} m",
            off.cane_touches, off.nearest_body_m
        );
        assert_eq!(off.cane_touches, 0, "the cane cannot touch a sign 1.5 m up");
        // the sign's face is at 4.0 m, the body's front 0.225 m ahead of its centre: the
        // cue comes within the last 2.5 s of walking, in time for the body to miss it
        assert!((1.0..=3.4).contains(&x), "first cue with the body at x = {x:.2} m");
        assert!(off.nearest_body_m > 0.04, "the body came within {:.3} m of the sign", off.nearest_body_m);
    }
}
