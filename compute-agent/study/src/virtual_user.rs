//! The virtual user: a person walking with the augmented cane, reacting to the rumble
//! as Taylor's volunteers were instructed (Taylor 2017, sec. 3.1): left rumble — turn
//! left until it stops; right — turn right; both — stop and turn in place until the
//! path is clear; none — walk straight towards the goal they can hear (bearing only,
//! the thesis's music source). What they head for comes from a [`Guide`], so spoken
//! route guidance can replace the sound without touching the user.
//!
//! The user acts on what they felt `reaction_s` earlier, turns at most at
//! `turn_rate_deg_s`, speeds up and slows down at most at `accel_m_s2` (about 0.5 s from
//! standing to 1 m/s, as the sim's scripted walker), and sweeps the cane while walking
//! (holding it still, pointing ahead, while standing and turning in place). A
//! cane or body touch is felt at once and, after the reaction time, makes the user stop
//! and turn away from it for `bump_turn_s`, as any cane user does.

use std::collections::VecDeque;
use std::rc::Rc;

use sim::walker::wrap_pi;
use sim::UserPose;

use super::hands::Felt;

/// What the user heads for.
pub trait Guide {
    /// Map heading (radians, counter-clockwise from +x) the user wants to walk, from
    /// where the user is at `t_s`; `None` when there is nothing to head for.
    fn heading_target_rad(&mut self, pose: &UserPose, t_s: f64) -> Option<f64>;

    /// Times someone had to lead the user back on course (0 for a guide that never does).
    fn assists(&self) -> u32 {
        0
    }

    /// A copy in the same state, to walk the user ahead with (the oracle's look-ahead).
    fn boxed_clone(&self) -> Box<dyn Guide + '_>;

    /// Turn on the spot at this rate (radians a second, positive left) instead of
    /// heading anywhere, when nothing is felt (told to turn slowly while the device
    /// looks for the position); `None` for a guide that never asks it.
    fn spin_rad_s(&self) -> Option<f64> {
        None
    }
}

/// A sound source at the goal: the user hears its bearing, nothing else (Taylor's music).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GoalSound {
    /// Map x of the source, metres.
    pub x_m: f64,
    /// Map y of the source, metres.
    pub y_m: f64,
}

impl Guide for GoalSound {
    fn heading_target_rad(&mut self, pose: &UserPose, _t_s: f64) -> Option<f64> {
        let (dx, dy) = (self.x_m - pose.x_m, self.y_m - pose.y_m);
        (dx.hypot(dy) > 1e-6).then(|| dy.atan2(dx))
    }

    fn boxed_clone(&self) -> Box<dyn Guide + '_> {
        Box::new(*self)
    }
}

/// Whether the user can walk straight from a pose to a point (the map's answer).
type InSight<'a> = Rc<dyn Fn(&UserPose, [f64; 2]) -> bool + 'a>;

/// Route guidance stand-in (until the planner speaks real instructions): a fixed
/// route, and the user is pointed at the farthest waypoint in line of sight, as
/// ISANA's line-of-sight smoothing and deviation recovery would. Line of sight is
/// given by the caller (the map), so the guide itself knows no geometry.
#[derive(Clone)]
pub struct RouteWaypoints<'a> {
    waypoints: Vec<[f64; 2]>,
    in_sight: InSight<'a>,
    target: usize,
}

impl<'a> RouteWaypoints<'a> {
    /// A route through `waypoints` (map metres, the goal last); `in_sight` says whether
    /// the user can walk straight from where they are to a point.
    pub fn new(waypoints: Vec<[f64; 2]>, in_sight: impl Fn(&UserPose, [f64; 2]) -> bool + 'a) -> Self {
        Self { waypoints, in_sight: Rc::new(in_sight), target: 0 }
    }
}

impl Guide for RouteWaypoints<'_> {
    fn heading_target_rad(&mut self, pose: &UserPose, _t_s: f64) -> Option<f64> {
        if let Some(k) = (0..self.waypoints.len()).rev().find(|&k| (self.in_sight)(pose, self.waypoints[k])) {
            self.target = k;
        }
        let w = self.waypoints.get(self.target)?;
        let (dx, dy) = (w[0] - pose.x_m, w[1] - pose.y_m);
        (dx.hypot(dy) > 1e-6).then(|| dy.atan2(dx))
    }

    fn boxed_clone(&self) -> Box<dyn Guide + '_> {
        Box::new(self.clone())
    }
}

/// Route guidance stand-in that keeps the user on the route and announces turns ahead
/// of the corner, as turn-by-turn guidance does ("turn right in one metre"): the route
/// is a line from the start through the waypoints to the goal; the user's progress is
/// the nearest point of it at most [`PROGRESS_WINDOW_M`] past the last (never back),
/// and the user heads for the point `lookahead_m` further along, or the farthest point
/// short of it in sight. With a lookahead of 0, or where no point of the route ahead is
/// in sight (the user pushed off it), the user heads for the farthest waypoint in sight
/// ([`RouteWaypoints`]): that walks the user right up to each corner, facing whatever
/// lies past it.
#[derive(Clone)]
pub struct RouteFollow<'a> {
    points: Vec<[f64; 2]>,
    /// Distance along the route of each point, metres.
    along_m: Vec<f64>,
    in_sight: InSight<'a>,
    lookahead_m: f64,
    progress_m: f64,
    /// Where the route cannot be seen from (the user pushed off it): the farthest
    /// waypoint in sight.
    recover: RouteWaypoints<'a>,
}

/// How far past the last progress the nearest route point is looked for, metres (a
/// few steps: the user never jumps to a later leg seen through a gap).
pub const PROGRESS_WINDOW_M: f64 = 3.0;
/// Spacing of the route points tested for line of sight, metres.
const ROUTE_STEP_M: f64 = 0.1;

impl<'a> RouteFollow<'a> {
    /// A route from `start` through `waypoints` (map metres, the goal last); the user
    /// heads `lookahead_m` along it; `in_sight` says whether the user can walk straight
    /// from where they are to a point.
    pub fn new(
        start: [f64; 2],
        waypoints: Vec<[f64; 2]>,
        lookahead_m: f64,
        in_sight: impl Fn(&UserPose, [f64; 2]) -> bool + Clone + 'a,
    ) -> Self {
        let mut points = vec![start];
        points.extend_from_slice(&waypoints);
        if points.len() == 1 {
            // no waypoints: a route of no length, the user heads for where it starts
            points.push(start);
        }
        let mut along_m = vec![0.0];
        for w in points.windows(2) {
            let last = along_m[along_m.len() - 1];
            along_m.push(last + (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]));
        }
        Self {
            points,
            along_m,
            in_sight: Rc::new(in_sight.clone()),
            lookahead_m,
            progress_m: 0.0,
            recover: RouteWaypoints::new(waypoints, in_sight),
        }
    }

    /// Length of the route, metres.
    fn length_m(&self) -> f64 {
        self.along_m[self.along_m.len() - 1]
    }

    /// The route's point `s_m` along it (clamped to the route).
    fn point_at(&self, s_m: f64) -> [f64; 2] {
        let s = s_m.clamp(0.0, self.length_m());
        let k = self.along_m.partition_point(|&a| a <= s).clamp(1, self.points.len() - 1);
        let (a, b) = (self.points[k - 1], self.points[k]);
        let len = self.along_m[k] - self.along_m[k - 1];
        let f = if len > 0.0 { (s - self.along_m[k - 1]) / len } else { 0.0 };
        [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]
    }

    /// Takes up the route again from wherever the user is: progress moves (back or on)
    /// to the nearest route point in sight, or the nearest at all when none is.
    pub fn rejoin(&mut self, pose: &UserPose) {
        let (x, y) = (pose.x_m, pose.y_m);
        let mut best = (f64::INFINITY, f64::INFINITY, 0.0);
        for k in 1..self.points.len() {
            let s = self.nearest_along_m(x, y, self.along_m[k - 1], self.along_m[k]);
            let p = self.point_at(s);
            let d = (p[0] - x).hypot(p[1] - y);
            let key = if (self.in_sight)(pose, p) { d } else { f64::INFINITY };
            if (key, d) < (best.0, best.1) {
                best = (key, d, s);
            }
        }
        self.progress_m = best.2;
    }

    /// Distance along the route of the point nearest `(x, y)` between `from_m` and
    /// `to_m` along it.
    fn nearest_along_m(&self, x: f64, y: f64, from_m: f64, to_m: f64) -> f64 {
        let mut best = (f64::INFINITY, from_m);
        for k in 1..self.points.len() {
            let (s0, s1) = (self.along_m[k - 1], self.along_m[k]);
            if s1 < from_m || s0 > to_m || s1 <= s0 {
                continue;
            }
            let (a, b) = (self.points[k - 1], self.points[k]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len = s1 - s0;
            let f = (((x - a[0]) * dx + (y - a[1]) * dy) / (len * len)).clamp(0.0, 1.0);
            let s = (s0 + f * len).clamp(from_m, to_m);
            let p = self.point_at(s);
            let d = (p[0] - x).hypot(p[1] - y);
            if d < best.0 {
                best = (d, s);
            }
        }
        best.1
    }
}

impl Guide for RouteFollow<'_> {
    fn heading_target_rad(&mut self, pose: &UserPose, t_s: f64) -> Option<f64> {
        if self.lookahead_m <= 0.0 {
            return self.recover.heading_target_rad(pose, t_s);
        }
        let (x, y) = (pose.x_m, pose.y_m);
        self.progress_m = self.nearest_along_m(x, y, self.progress_m, self.progress_m + PROGRESS_WINDOW_M);
        let far = (self.progress_m + self.lookahead_m).min(self.length_m());
        let steps = ((far - self.progress_m) / ROUTE_STEP_M).ceil() as usize;
        let ahead = (0..=steps)
            .map(|i| self.point_at(far - i as f64 * ROUTE_STEP_M))
            .find(|&p| (p[0] - x).hypot(p[1] - y) > ROUTE_STEP_M && (self.in_sight)(pose, p));
        match ahead {
            Some(p) => Some((p[1] - y).atan2(p[0] - x)),
            None => self.recover.heading_target_rad(pose, t_s),
        }
    }

    fn boxed_clone(&self) -> Box<dyn Guide + '_> {
        Box::new(self.clone())
    }
}

/// The goal's sound, with an experimenter standing by as in Taylor's study (2017, sec.
/// 3.2: users who lost their way were reoriented): when the user has come no nearer the
/// goal for `stuck_after_s`, the experimenter leads them along the course (taking up the
/// route from the nearest point of it in sight, as [`RouteFollow`]) until the goal is in
/// a straight line of walking, then leaves them to the sound again. The rumble still
/// decides every step; only what the user heads for changes.
#[derive(Clone)]
pub struct ExperimenterAssist<'a> {
    sound: GoalSound,
    route: RouteFollow<'a>,
    goal_in_sight: Rc<dyn Fn(&UserPose) -> bool + 'a>,
    stuck_after_s: f64,
    best_m: f64,
    best_t_s: f64,
    leading: bool,
    assists: u32,
}

/// Coming this much nearer the goal counts as progress, metres.
const PROGRESS_M: f64 = 0.3;

impl<'a> ExperimenterAssist<'a> {
    /// Sound at `sound`, the course's `route` for leading, `goal_in_sight` from the map.
    pub fn new(
        sound: GoalSound,
        route: RouteFollow<'a>,
        goal_in_sight: impl Fn(&UserPose) -> bool + 'a,
        stuck_after_s: f64,
    ) -> Self {
        Self {
            sound,
            route,
            goal_in_sight: Rc::new(goal_in_sight),
            stuck_after_s,
            best_m: f64::INFINITY,
            best_t_s: 0.0,
            leading: false,
            assists: 0,
        }
    }
}

impl Guide for ExperimenterAssist<'_> {
    fn heading_target_rad(&mut self, pose: &UserPose, t_s: f64) -> Option<f64> {
        let d = (self.sound.x_m - pose.x_m).hypot(self.sound.y_m - pose.y_m);
        if d < self.best_m - PROGRESS_M {
            self.best_m = d;
            self.best_t_s = t_s;
        }
        if self.leading && (self.goal_in_sight)(pose) {
            self.leading = false;
            (self.best_m, self.best_t_s) = (d, t_s);
        } else if !self.leading && t_s - self.best_t_s > self.stuck_after_s && !(self.goal_in_sight)(pose) {
            // (a user held up with the goal in sight is not lost: nobody leads them)
            self.leading = true;
            self.assists += 1;
            self.route.rejoin(pose);
        }
        if self.leading {
            self.route.heading_target_rad(pose, t_s)
        } else {
            self.sound.heading_target_rad(pose, t_s)
        }
    }

    fn assists(&self) -> u32 {
        self.assists
    }

    fn boxed_clone(&self) -> Box<dyn Guide + '_> {
        Box::new(self.clone())
    }
}

/// How the user walks and reacts. Defaults: normal walking (about 1 m/s) and a simple
/// tactile choice reaction (0.5 s).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct UserParams {
    /// Walking speed with nothing felt, m/s.
    pub walk_speed_m_s: f64,
    /// Walking speed while turning away from a one-sided rumble, m/s.
    pub turn_walk_speed_m_s: f64,
    /// Largest turning rate, degrees per second.
    pub turn_rate_deg_s: f64,
    /// Delay from feeling something to acting on it, seconds.
    pub reaction_s: f64,
    /// Largest change of walking speed, m/s^2.
    pub accel_m_s2: f64,
    /// A user told that the pulses quicken as the obstacle nears: a side rumble pulsing
    /// at this period or faster makes them stop and turn in place, ms. 0: the thesis's
    /// instruction (turn while walking slowly), pulse rate ignored.
    pub fast_pulse_ms: f64,
    /// How long the user turns away after a cane or body touch, seconds.
    pub bump_turn_s: f64,
    /// After a rumble episode ends the user keeps the cleared heading this long before
    /// turning back towards the guide, seconds.
    pub commit_s: f64,
    /// Body width (the contact cylinder's diameter), metres.
    pub shoulder_width_m: f64,
    /// Body height (the contact cylinder's top), metres.
    pub height_m: f64,
}

impl Default for UserParams {
    fn default() -> Self {
        Self {
            walk_speed_m_s: 1.0,
            turn_walk_speed_m_s: 0.4,
            turn_rate_deg_s: 60.0,
            reaction_s: 0.5,
            accel_m_s2: 2.0,
            fast_pulse_ms: 0.0,
            bump_turn_s: 1.0,
            commit_s: 1.0,
            shoulder_width_m: 0.45,
            height_m: 1.8,
        }
    }
}

/// A touch felt through the cane or the body, on one side of the heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Touch {
    /// When, seconds.
    pub t_s: f64,
    /// True when the touched thing is on the user's left.
    pub on_left: bool,
}

/// The walking person: pose, speed, and what they felt recently.
#[derive(Debug, Clone)]
pub struct VirtualUser {
    params: UserParams,
    pose: UserPose,
    speed_m_s: f64,
    /// What was felt, and whether the pulses were fast, from when.
    felt: VecDeque<(f64, Felt, bool)>,
    touches: VecDeque<Touch>,
    acting: Felt,
    in_place_left: bool,
    bump_until_s: f64,
    bump_left: bool,
    /// When the last touch was acted on, and which way it turned the user (left).
    last_turn: Option<(f64, bool)>,
    commit_until_s: f64,
    /// told to turn on the spot at this rate (radians a second, positive left)
    spin_rad_s: Option<f64>,
}

impl VirtualUser {
    /// A user standing at `start`.
    pub fn new(params: UserParams, start: UserPose) -> Self {
        Self {
            params,
            pose: start,
            speed_m_s: 0.0,
            felt: VecDeque::new(),
            touches: VecDeque::new(),
            acting: Felt::None,
            in_place_left: true,
            bump_until_s: f64::NEG_INFINITY,
            bump_left: true,
            last_turn: None,
            commit_until_s: f64::NEG_INFINITY,
            spin_rad_s: None,
        }
    }

    /// Turn on the spot at this rate (radians a second, positive left) whenever nothing
    /// is felt, until told otherwise ([`Guide::spin_rad_s`]); `None`: head for the target.
    pub fn spin(&mut self, rate_rad_s: Option<f64>) {
        self.spin_rad_s = rate_rad_s;
    }

    /// Parameters.
    pub fn params(&self) -> &UserParams {
        &self.params
    }

    /// The same user, in the same state, with other parameters (how someone who knows
    /// only the typical user would picture this one).
    pub fn with_params(&self, params: UserParams) -> VirtualUser {
        VirtualUser { params, ..self.clone() }
    }

    /// Where the user is.
    pub fn pose(&self) -> UserPose {
        self.pose
    }

    /// Current walking speed, m/s.
    pub fn speed_m_s(&self) -> f64 {
        self.speed_m_s
    }

    /// Records what the hands feel at `t_s` (called every step, in time order), with
    /// the pulse period felt, ms (`None`: steady, or not yet two pulses).
    pub fn feel(&mut self, t_s: f64, felt: Felt, pulse_ms: Option<f64>) {
        let fast = self.params.fast_pulse_ms > 0.0 && pulse_ms.is_some_and(|ms| ms <= self.params.fast_pulse_ms);
        if self.felt.back().is_none_or(|&(_, f, q)| (f, q) != (felt, fast)) {
            self.felt.push_back((t_s, felt, fast));
        }
    }

    /// Records a touch of the cane or the body.
    pub fn touch(&mut self, touch: Touch) {
        self.touches.push_back(touch);
    }

    /// The body pushed against an obstacle at `t_s` and was stopped: no speed left, and
    /// the push is felt like a touch unless the user is already turning away from one.
    pub fn stopped_by(&mut self, t_s: f64, on_left: bool) {
        self.speed_m_s = 0.0;
        if self.touches.is_empty() && t_s >= self.bump_until_s {
            self.touches.push_back(Touch { t_s, on_left });
        }
    }

    /// What the user acts on at `t_s`: the newest sensation at least `reaction_s` old,
    /// and whether its pulses were fast.
    fn perceived(&mut self, t_s: f64) -> (Felt, bool) {
        let due = t_s - self.params.reaction_s;
        while self.felt.len() > 1 && self.felt[1].0 <= due {
            self.felt.pop_front();
        }
        match self.felt.front() {
            Some(&(t, f, fast)) if t <= due => (f, fast),
            _ => (Felt::None, false),
        }
    }

    /// The pose after `dt_s` more of walking, given the guide's heading. The caller
    /// decides whether the body may go there (see [`VirtualUser::commit`]).
    pub fn propose(&mut self, t_s: f64, dt_s: f64, target_rad: Option<f64>) -> (UserPose, f64) {
        let p = self.params;
        let turn = p.turn_rate_deg_s.to_radians();
        while self.touches.front().is_some_and(|touch| touch.t_s <= t_s - p.reaction_s) {
            if let Some(touch) = self.touches.pop_front() {
                // turn away, then walk on in the new direction before heading back; a
                // turn in place that bumped keeps going the other way. A touch on the
                // other side while still turning away from the last one, or walking on
                // from it, means a corner: turning back and forth between its two sides
                // finds no way out, so the user keeps turning the same way
                let away_left = !touch.on_left;
                self.bump_left = match self.last_turn {
                    Some((t0, left)) if t_s - t0 < p.bump_turn_s + p.commit_s => left,
                    _ => away_left,
                };
                self.last_turn = Some((t_s, self.bump_left));
                self.bump_until_s = t_s + p.bump_turn_s;
                self.in_place_left = self.bump_left;
                self.commit_until_s = self.bump_until_s + p.commit_s;
            }
        }
        let (felt, fast) = self.perceived(t_s);
        // near (fast pulses): stop while turning away, as for both sides; told to turn on
        // the spot: stay on it
        let side_speed = if fast || self.spin_rad_s.is_some() { 0.0 } else { p.turn_walk_speed_m_s };
        if felt != self.acting {
            let in_place = |f: Felt| f == Felt::Both || f == Felt::Offline;
            if in_place(felt) && !in_place(self.acting) && t_s >= self.bump_until_s + p.commit_s {
                // turn towards the side the guide points to, and stay with that side
                // (from Both to Offline and back the user is still turning in place:
                // turning back towards the guide there undoes a turn away from a bump,
                // and between two obstacles the user swings between them for ever);
                // just after a touch, keep turning away from what was touched
                let err = target_rad.map_or(0.0, |h| wrap_pi(h - self.pose.yaw_rad));
                self.in_place_left = err >= 0.0;
            }
            if felt == Felt::None && self.acting != Felt::Offline {
                self.commit_until_s = t_s + p.commit_s;
            }
            self.acting = felt;
        }
        let (want_speed, yaw_rate) = if t_s < self.bump_until_s {
            (0.0, if self.bump_left { turn } else { -turn })
        } else {
            match felt {
                Felt::Left => (side_speed, turn),
                Felt::Right => (side_speed, -turn),
                Felt::Both => (0.0, if self.in_place_left { turn } else { -turn }),
                // not seeing (a wall filling the view hides the floor): no step forward,
                // but turn slowly so the camera can find the floor again
                Felt::Offline => (0.0, if self.in_place_left { 0.5 * turn } else { -0.5 * turn }),
                // told to turn on the spot, the user stays on it: no walking on after
                // turning away from what was felt
                Felt::None if self.spin_rad_s.is_some() => (0.0, self.spin_rad_s.map_or(0.0, |r| r.clamp(-turn, turn))),
                Felt::None if t_s < self.commit_until_s => (p.walk_speed_m_s, 0.0),
                Felt::None => match target_rad {
                    Some(h) => {
                        let err = wrap_pi(h - self.pose.yaw_rad);
                        // walk on while roughly facing the target, turn first when not
                        (p.walk_speed_m_s * err.cos().max(0.0), (2.0 * err).clamp(-turn, turn))
                    }
                    None => (0.0, 0.0),
                },
            }
        };
        let dv = (want_speed - self.speed_m_s).clamp(-p.accel_m_s2 * dt_s, p.accel_m_s2 * dt_s);
        let speed = self.speed_m_s + dv;
        let yaw = wrap_pi(self.pose.yaw_rad + yaw_rate * dt_s);
        let mid = self.pose.yaw_rad + 0.5 * yaw_rate * dt_s;
        let pose = UserPose {
            x_m: self.pose.x_m + speed * dt_s * mid.cos(),
            y_m: self.pose.y_m + speed * dt_s * mid.sin(),
            yaw_rad: yaw,
            floor: self.pose.floor,
        };
        (pose, speed)
    }

    /// Accepts a proposed pose (or a pose the caller allowed instead) with its speed.
    pub fn commit(&mut self, pose: UserPose, speed_m_s: f64) {
        self.pose = pose;
        self.speed_m_s = speed_m_s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn user(reaction_s: f64) -> VirtualUser {
        VirtualUser::new(
            UserParams { reaction_s, ..UserParams::default() },
            UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 },
        )
    }

    fn walk(u: &mut VirtualUser, from_s: f64, to_s: f64, felt: Felt) {
        let dt = 0.01;
        let mut t = from_s;
        while t < to_s {
            u.feel(t, felt, None);
            let (p, v) = u.propose(t, dt, Some(0.0));
            u.commit(p, v);
            t += dt;
        }
    }

    #[test]
    fn left_rumble_turns_left_only_after_the_reaction_time() {
        let mut u = user(0.5);
        walk(&mut u, 0.0, 2.0, Felt::None);
        assert!((u.speed_m_s() - 1.0).abs() < 1e-9);
        walk(&mut u, 2.0, 2.45, Felt::Left);
        assert!(u.pose().yaw_rad.abs() < 1e-9, "not yet reacting");
        walk(&mut u, 2.45, 3.5, Felt::Left);
        assert!(u.pose().yaw_rad > 0.5, "turned left: {}", u.pose().yaw_rad);
        assert!(u.speed_m_s() < 0.5);
    }

    #[test]
    fn a_user_told_about_the_pulse_rate_stops_to_turn_when_the_pulses_are_fast() {
        let run = |fast_pulse_ms: f64, pulse_ms: f64| {
            let mut u = VirtualUser::new(
                UserParams { reaction_s: 0.2, fast_pulse_ms, ..UserParams::default() },
                UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 },
            );
            walk(&mut u, 0.0, 1.0, Felt::None);
            let dt = 0.01;
            let mut t = 1.0;
            while t < 2.5 {
                u.feel(t, Felt::Left, Some(pulse_ms));
                let (p, v) = u.propose(t, dt, Some(0.0));
                u.commit(p, v);
                t += dt;
            }
            (u.speed_m_s(), u.pose().yaw_rad)
        };
        // thesis instruction: turn left walking slowly, whatever the rate
        let (v, yaw) = run(0.0, 200.0);
        assert!((v - 0.4).abs() < 1e-9 && yaw > 0.5, "{v} {yaw}");
        // told about the rate: fast pulses (near) -> turn in place; slow ones -> walk on
        let (v, yaw) = run(350.0, 200.0);
        assert!(v == 0.0 && yaw > 0.5, "{v} {yaw}");
        let (v, _) = run(350.0, 600.0);
        assert!((v - 0.4).abs() < 1e-9, "{v}");
    }

    #[test]
    fn a_user_turning_on_the_spot_stays_on_it_when_something_is_felt() {
        let mut u = user(0.2);
        u.spin(Some(0.5));
        let dt = 0.01;
        let mut t = 0.0;
        // a wall comes into the turning view (both sides), then one side, then nothing:
        // turned on, never walked off
        for (until_s, felt) in [(2.0, Felt::None), (3.0, Felt::Both), (4.0, Felt::Left), (8.0, Felt::None)] {
            while t < until_s {
                u.feel(t, felt, None);
                let (p, v) = u.propose(t, dt, None);
                u.commit(p, v);
                t += dt;
            }
        }
        let moved = u.pose().x_m.hypot(u.pose().y_m);
        assert!(moved < 1e-9, "walked {moved} m");
        assert!(u.pose().yaw_rad.abs() > 0.5, "turned: {}", u.pose().yaw_rad);
        // told to walk again: walks
        u.spin(None);
        walk(&mut u, t, t + 2.0, Felt::None);
        assert!(u.pose().x_m.hypot(u.pose().y_m) > 0.5);
    }

    #[test]
    fn both_stops_and_turns_in_place_towards_the_guide_side() {
        let mut u = user(0.2);
        walk(&mut u, 0.0, 1.0, Felt::None);
        let before = u.pose();
        let dt = 0.01;
        let mut t = 1.0;
        while t < 3.0 {
            u.feel(t, Felt::Both, None);
            // the goal is to the right
            let (p, v) = u.propose(t, dt, Some(-1.0));
            u.commit(p, v);
            t += dt;
        }
        assert_eq!(u.speed_m_s(), 0.0);
        assert!(u.pose().yaw_rad < -1.0, "turned right: {}", u.pose().yaw_rad);
        assert!(u.pose().x_m - before.x_m < 0.5, "stopped within a reaction time and a ramp");
    }

    #[test]
    fn turning_in_place_away_from_a_bump_goes_on_when_both_becomes_offline() {
        let mut u = user(0.2);
        let dt = 0.01;
        let mut t = 0.0;
        // stopped by Both, the goal to the left: turns left
        while t < 0.5 {
            u.feel(t, Felt::Both, None);
            let (p, v) = u.propose(t, dt, Some(1.5));
            u.commit(p, v);
            t += dt;
        }
        assert!(u.pose().yaw_rad > 0.0);
        // the cane hits something on the left: turns right, away from it
        u.touch(Touch { t_s: t, on_left: true });
        while t < 2.0 {
            u.feel(t, Felt::Both, None);
            let (p, v) = u.propose(t, dt, Some(1.5));
            u.commit(p, v);
            t += dt;
        }
        let after_bump = u.pose().yaw_rad;
        // a wall fills the view: still turning in place, still to the right (turning
        // back towards the goal would swing into what was just hit)
        while t < 3.0 {
            u.feel(t, Felt::Offline, None);
            let (p, v) = u.propose(t, dt, Some(1.5));
            u.commit(p, v);
            t += dt;
        }
        assert!(u.pose().yaw_rad < after_bump - 0.3, "{} then {}", after_bump, u.pose().yaw_rad);
        assert_eq!(u.speed_m_s(), 0.0);
    }

    /// Steps `u` from `*t` to `to_s` feeling `felt`, the guide at `target`.
    fn stand(u: &mut VirtualUser, t: &mut f64, to_s: f64, felt: Felt, target: f64) {
        let dt = 0.01;
        while *t < to_s {
            u.feel(*t, felt, None);
            let (p, v) = u.propose(*t, dt, Some(target));
            u.commit(p, v);
            *t += dt;
        }
    }

    #[test]
    fn a_touch_turns_the_user_away_and_one_on_the_other_side_soon_after_is_turned_past() {
        let mut u = user(0.2);
        let mut t = 0.0;
        // stopped by Both, the goal to the right: turns right in place
        stand(&mut u, &mut t, 0.5, Felt::Both, -1.5);
        let yaw = u.pose().yaw_rad;
        assert!(yaw < 0.0 && u.speed_m_s() == 0.0);
        // the still cane swings into something on the right: turns left, away from it
        u.touch(Touch { t_s: t, on_left: false });
        stand(&mut u, &mut t, 1.5, Felt::Both, -1.5);
        let away = u.pose().yaw_rad;
        assert!(away > yaw + 0.3, "turned left: {yaw} then {away}");
        // and within a second something else on the left: in a corner, the user does
        // not swing back into the first, but turns on past the second
        u.touch(Touch { t_s: t, on_left: true });
        stand(&mut u, &mut t, 2.5, Felt::Both, -1.5);
        assert!(u.pose().yaw_rad > away + 0.3, "still turning left: {away} then {}", u.pose().yaw_rad);
        // a touch well after (walking again) turns the user away again
        let heading = u.pose().yaw_rad;
        stand(&mut u, &mut t, 4.0, Felt::None, heading);
        assert!(u.speed_m_s() > 0.0);
        let walking = u.pose().yaw_rad;
        u.touch(Touch { t_s: t, on_left: true });
        stand(&mut u, &mut t, 5.0, Felt::None, walking);
        assert!(u.pose().yaw_rad < walking - 0.3, "turned right, away: {walking} then {}", u.pose().yaw_rad);
    }

    #[test]
    fn a_stop_right_after_a_touch_keeps_turning_away_from_it() {
        let mut u = user(0.2);
        let mut t = 0.0;
        stand(&mut u, &mut t, 1.0, Felt::None, 0.0);
        // the cane hits something on the right while walking: turn left, away...
        u.touch(Touch { t_s: t, on_left: false });
        stand(&mut u, &mut t, 1.5, Felt::None, 0.0);
        let turning = u.pose().yaw_rad;
        assert!(turning > 0.0);
        // ...and the rumble says stop, with the goal to the right: the user goes on
        // turning left rather than back into what the cane hit
        stand(&mut u, &mut t, 2.5, Felt::Both, -1.0);
        assert!(u.pose().yaw_rad > turning + 0.3, "{turning} then {}", u.pose().yaw_rad);
    }

    #[test]
    fn nobody_leads_a_user_held_up_with_the_goal_in_sight() {
        let route = RouteFollow::new([0.0, 0.0], vec![[5.0, 0.0]], 0.0, |_: &UserPose, _: [f64; 2]| true);
        let mut g = ExperimenterAssist::new(GoalSound { x_m: 5.0, y_m: 0.0 }, route, |_: &UserPose| true, 10.0);
        let here = UserPose { x_m: 1.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 };
        for i in 0..200 {
            assert!(g.heading_target_rad(&here, i as f64 * 0.25).is_some_and(|h| h.abs() < 1e-9));
        }
        assert_eq!(g.assists(), 0, "50 s held up in sight of the goal is no assist");
    }

    #[test]
    fn a_route_with_no_waypoints_heads_for_where_it_starts() {
        let mut r = RouteFollow::new([2.0, 0.0], Vec::new(), 1.5, |_: &UserPose, _: [f64; 2]| true);
        let h = r.heading_target_rad(&UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 }, 0.0);
        assert!(h.is_some_and(|h| h.abs() < 1e-9), "{h:?}");
    }

    #[test]
    fn experimenter_leads_a_stuck_user_until_the_goal_is_in_sight() {
        // goal at (5, 0) behind a wall at x = 2.5 for |y| < 2; the route goes round by y = 3
        let blocked = |p: &UserPose| p.y_m.abs() < 2.0 && p.x_m < 2.5;
        let route = RouteFollow::new(
            [0.0, 0.0],
            vec![[1.0, 3.0], [5.0, 3.0], [5.0, 0.0]],
            0.0,
            move |p: &UserPose, w: [f64; 2]| !(blocked(p) && w[0] > 2.5),
        );
        let mut g = ExperimenterAssist::new(GoalSound { x_m: 5.0, y_m: 0.0 }, route, move |p| !blocked(p), 10.0);
        let at = |x, y| UserPose { x_m: x, y_m: y, yaw_rad: 0.0, floor: 0 };
        // pressed against the wall, heading for the sound, for 10 s: no help yet
        assert!(g.heading_target_rad(&at(2.2, 0.0), 0.0).unwrap().abs() < 1e-9);
        assert!(g.heading_target_rad(&at(2.2, 0.0), 9.0).unwrap().abs() < 1e-9);
        assert_eq!(g.assists(), 0);
        // stuck past 10 s: led to the first waypoint of the way round
        let h = g.heading_target_rad(&at(2.2, 0.0), 10.5).unwrap();
        assert!(h > 1.0, "led towards (1, 3): {h}");
        assert_eq!(g.assists(), 1);
        // round the wall the goal is in sight: back to the sound
        let h = g.heading_target_rad(&at(3.0, 3.0), 14.0).unwrap();
        assert!((h - (-3f64).atan2(2.0)).abs() < 1e-9, "{h}");
        assert_eq!(g.assists(), 1);
    }

    fn at(x: f64, y: f64) -> UserPose {
        UserPose { x_m: x, y_m: y, yaw_rad: 0.0, floor: 0 }
    }

    #[test]
    fn route_follower_turns_a_lookahead_before_the_corner() {
        // (0, 0) east to (5, 0), then north to (5, 5); everything in sight
        let route = |lookahead_m| {
            RouteFollow::new([0.0, 0.0], vec![[5.0, 0.0], [5.0, 5.0]], lookahead_m, |_: &UserPose, _| true)
        };
        let mut g = route(1.5);
        // 2 m before the corner: straight on
        assert!(g.heading_target_rad(&at(1.0, 0.0), 0.0).unwrap().abs() < 1e-9);
        assert!(g.heading_target_rad(&at(3.0, 0.0), 1.0).unwrap().abs() < 1e-9);
        // 1 m before it: already turning, towards (5, 0.5)
        let h = g.heading_target_rad(&at(4.0, 0.0), 2.0).unwrap();
        assert!((h - 0.5f64.atan2(1.0)).abs() < 1e-9, "{h}");
        // on the second leg, 1.5 m up it
        let h = g.heading_target_rad(&at(5.0, 1.0), 3.0).unwrap();
        assert!((h - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{h}");
        // lookahead 0: the farthest waypoint in sight, the goal at once
        let h = route(0.0).heading_target_rad(&at(4.0, 0.0), 0.0).unwrap();
        assert!((h - 5f64.atan2(1.0)).abs() < 1e-9, "{h}");
    }

    #[test]
    fn route_follower_keeps_to_its_leg_where_a_later_leg_is_nearer() {
        // a hairpin: east along y = 0, back west along y = 1
        let mut g = RouteFollow::new([0.0, 0.0], vec![[5.0, 0.0], [5.0, 1.0], [0.0, 1.0]], 1.5, |_: &UserPose, _| true);
        // pushed 0.6 m to the left of the first leg: 0.4 m from the last leg, yet led on
        // along the first, back towards it
        let h = g.heading_target_rad(&at(1.0, 0.6), 0.0).unwrap();
        assert!((h - (-0.6f64).atan2(1.5)).abs() < 1e-9, "{h}");
        // round the hairpin the progress moves on, and never back
        g.heading_target_rad(&at(3.0, 0.0), 1.0);
        g.heading_target_rad(&at(4.5, 0.2), 2.0);
        g.heading_target_rad(&at(5.0, 0.8), 3.0);
        let h = g.heading_target_rad(&at(4.0, 0.6), 4.0).unwrap();
        assert!(wrap_pi(h - std::f64::consts::PI).abs() < 0.5, "heading west: {h}");
    }

    #[test]
    fn route_follower_rejoins_the_route_from_wherever_the_user_is_led_from() {
        // a straight route east; the user turns up 6 m along it before the guide has
        // heard of them (an experimenter taking over)
        let mut g = RouteFollow::new([0.0, 0.0], vec![[10.0, 0.0]], 1.5, |_: &UserPose, _| true);
        g.rejoin(&at(6.0, 0.5));
        let h = g.heading_target_rad(&at(6.0, 0.5), 0.0).unwrap();
        assert!((h - (-0.5f64).atan2(1.5)).abs() < 1e-9, "{h}");
        // back before the last progress: taken up from there, not pulled on
        g.rejoin(&at(2.0, -0.5));
        let h = g.heading_target_rad(&at(2.0, -0.5), 1.0).unwrap();
        assert!((h - 0.5f64.atan2(1.5)).abs() < 1e-9, "{h}");
    }

    #[test]
    fn route_follower_pushed_out_of_sight_of_the_route_heads_for_the_farthest_waypoint_in_sight() {
        // route east along y = 0; the user stands behind a wall (y > 1 sees only y > 1
        // and the final waypoint)
        let sight = |p: &UserPose, w: [f64; 2]| p.y_m <= 1.0 || w[1] > 1.0 || w == [8.0, 0.0];
        let mut g = RouteFollow::new([0.0, 0.0], vec![[4.0, 0.0], [8.0, 0.0]], 1.5, sight);
        let h = g.heading_target_rad(&at(2.0, 2.0), 0.0).unwrap();
        assert!((h - (-2f64).atan2(6.0)).abs() < 1e-9, "{h}");
    }

    #[test]
    fn route_guide_heads_for_the_farthest_waypoint_in_sight() {
        // a wall along x = 0.5 for y > 0.2 hides the second waypoint from the start
        let sight = |p: &UserPose, w: [f64; 2]| !(p.x_m < 0.5 && w[0] > 0.5 && w[1] > 0.2);
        let mut g = RouteWaypoints::new(vec![[1.0, 0.0], [1.0, 5.0]], sight);
        let at = |x, y| UserPose { x_m: x, y_m: y, yaw_rad: 0.0, floor: 0 };
        assert!(g.heading_target_rad(&at(0.0, 0.0), 0.0).unwrap().abs() < 1e-9);
        let h = g.heading_target_rad(&at(0.9, 0.0), 0.0).unwrap();
        assert!((h - std::f64::consts::FRAC_PI_2).abs() < 0.05, "{h}");
    }
}
