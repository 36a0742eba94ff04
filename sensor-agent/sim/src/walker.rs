//! A scripted walker: from its start pose it turns in place towards each waypoint and
//! walks to it, with smooth starts and stops (bounded acceleration, so the simulated
//! IMU sees plausible forces), then stands still or backs up along the path.

use super::scene::{AtEnd, WalkerSpec};
use super::world::UserPose;

/// Forward acceleration of a walker starting or stopping, m/s^2 (about 0.5 s to 1 m/s).
const WALK_ACCEL_M_S2: f64 = 2.0;
/// Angular acceleration when turning in place, rad/s^2.
const TURN_ACCEL_RAD_S2: f64 = 6.0;

/// Distance covered after `t` seconds of a trapezoidal profile over `total` with peak
/// rate `rate` and acceleration `accel` (the rate never exceeds what stops in time).
fn trapezoid(t: f64, total: f64, rate: f64, accel: f64) -> f64 {
    let peak = rate.min((total * accel).sqrt());
    let ramp_t = peak / accel;
    let ramp_d = 0.5 * accel * ramp_t * ramp_t;
    let cruise_t = (total - 2.0 * ramp_d) / peak;
    let duration = 2.0 * ramp_t + cruise_t;
    let t = t.clamp(0.0, duration);
    if t < ramp_t {
        0.5 * accel * t * t
    } else if t < ramp_t + cruise_t {
        ramp_d + peak * (t - ramp_t)
    } else {
        let left = duration - t;
        total - 0.5 * accel * left * left
    }
}

fn trapezoid_duration(total: f64, rate: f64, accel: f64) -> f64 {
    if total <= 0.0 {
        return 0.0;
    }
    let peak = rate.min((total * accel).sqrt());
    peak / accel + total / peak
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Leg {
    Turn { at: [f64; 2], from_rad: f64, by_rad: f64 },
    Move { from: [f64; 2], to: [f64; 2], yaw_rad: f64 },
}

/// Time step of the finite difference that gives the walker's speed, seconds.
const SPEED_STEP_S: f64 = 0.01;

/// A walk as the simulator reads it: the user's pose and walking speed at a time,
/// seconds from the run's first frame.
pub trait Trajectory {
    /// The user's pose at `t_s`.
    fn pose_at(&self, t_s: f64) -> UserPose;
    /// Walking speed at `t_s`, m/s.
    fn speed_at(&self, t_s: f64) -> f64;
    /// In a lift at `t_s`: from which floor to which, and how much of the ride is done
    /// (0 to 1). Walkers that ride no lift are never in one.
    fn ride_at(&self, _t_s: f64) -> Option<Ride> {
        None
    }
}

/// A lift ride under way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ride {
    /// the floor left
    pub from_floor: i32,
    /// the floor ridden to
    pub to_floor: i32,
    /// the share of the ride done, 0 to 1
    pub done: f64,
}

impl Trajectory for ScriptedWalker {
    fn pose_at(&self, t_s: f64) -> UserPose {
        ScriptedWalker::pose_at(self, t_s)
    }

    fn speed_at(&self, t_s: f64) -> f64 {
        ScriptedWalker::speed_at(self, t_s)
    }
}

/// A walker following a fixed script; its pose is a pure function of time.
#[derive(Debug, Clone, PartialEq)]
pub struct ScriptedWalker {
    floor: i32,
    legs: Vec<(Leg, f64)>,
    speed_m_s: f64,
    turn_rate_rad_s: f64,
    at_end: AtEnd,
    rest: UserPose,
    out_s: f64,
}

impl ScriptedWalker {
    /// A walker starting at `start` that follows `spec`.
    pub fn new(start: UserPose, spec: &WalkerSpec) -> Self {
        let mut legs = Vec::new();
        let mut here = [start.x_m, start.y_m];
        let mut heading = start.yaw_rad;
        for &to in &spec.waypoints {
            let (dx, dy) = (to[0] - here[0], to[1] - here[1]);
            if dx.hypot(dy) < 1e-6 {
                continue;
            }
            let want = dy.atan2(dx);
            let by = wrap_pi(want - heading);
            if by.abs() > 1e-9 {
                legs.push(Leg::Turn { at: here, from_rad: heading, by_rad: by });
            }
            legs.push(Leg::Move { from: here, to, yaw_rad: want });
            here = to;
            heading = want;
        }
        let mut walker = ScriptedWalker {
            floor: start.floor,
            legs: Vec::new(),
            speed_m_s: spec.speed_m_s,
            turn_rate_rad_s: spec.turn_rate_deg_s.to_radians(),
            at_end: spec.at_end,
            rest: UserPose { x_m: here[0], y_m: here[1], yaw_rad: heading, floor: start.floor },
            out_s: 0.0,
        };
        walker.legs = legs.into_iter().map(|l| (l, walker.duration_of(&l))).collect();
        walker.out_s = walker.legs.iter().map(|(_, d)| d).sum();
        if walker.legs.is_empty() {
            walker.rest = start;
        }
        walker
    }

    /// A walker that stands at `start` forever.
    pub fn standing(start: UserPose) -> Self {
        Self::new(
            start,
            &WalkerSpec { waypoints: Vec::new(), speed_m_s: 1.0, turn_rate_deg_s: 90.0, at_end: AtEnd::Stop },
        )
    }

    fn duration_of(&self, leg: &Leg) -> f64 {
        match leg {
            Leg::Turn { by_rad, .. } => trapezoid_duration(by_rad.abs(), self.turn_rate_rad_s, TURN_ACCEL_RAD_S2),
            Leg::Move { from, to, .. } => {
                trapezoid_duration((to[0] - from[0]).hypot(to[1] - from[1]), self.speed_m_s, WALK_ACCEL_M_S2)
            }
        }
    }

    /// Time to walk the script once, seconds.
    pub fn script_duration_s(&self) -> f64 {
        self.out_s
    }

    /// Walking speed at `t_s`, m/s: a central difference of the pose over
    /// 10 ms either side.
    pub fn speed_at(&self, t_s: f64) -> f64 {
        let (before, after) = (self.pose_at(t_s - SPEED_STEP_S), self.pose_at(t_s + SPEED_STEP_S));
        (after.x_m - before.x_m).hypot(after.y_m - before.y_m) / (2.0 * SPEED_STEP_S)
    }

    /// The user's pose at `t_s` seconds after the start.
    pub fn pose_at(&self, t_s: f64) -> UserPose {
        if self.legs.is_empty() {
            return self.rest;
        }
        let t = t_s.max(0.0);
        match self.at_end {
            AtEnd::Stop if t >= self.out_s => self.rest,
            AtEnd::Stop => self.pose_on_legs(t),
            AtEnd::BackUp => {
                let lap = t.rem_euclid(2.0 * self.out_s);
                if lap < self.out_s {
                    self.pose_on_legs(lap)
                } else {
                    self.pose_on_legs(2.0 * self.out_s - lap)
                }
            }
        }
    }

    /// Pose `t` seconds into the outward script. Backing up replays it in reverse:
    /// the same positions and headings, so the walker faces the way it came.
    fn pose_on_legs(&self, t: f64) -> UserPose {
        let mut left = t;
        for (leg, duration) in &self.legs {
            if left <= *duration {
                return self.pose_in_leg(leg, left);
            }
            left -= duration;
        }
        self.rest
    }

    fn pose_in_leg(&self, leg: &Leg, t: f64) -> UserPose {
        match *leg {
            Leg::Turn { at, from_rad, by_rad } => {
                let turned = trapezoid(t, by_rad.abs(), self.turn_rate_rad_s, TURN_ACCEL_RAD_S2);
                UserPose {
                    x_m: at[0],
                    y_m: at[1],
                    yaw_rad: wrap_pi(from_rad + by_rad.signum() * turned),
                    floor: self.floor,
                }
            }
            Leg::Move { from, to, yaw_rad } => {
                let length = (to[0] - from[0]).hypot(to[1] - from[1]);
                let f = trapezoid(t, length, self.speed_m_s, WALK_ACCEL_M_S2) / length;
                UserPose {
                    x_m: from[0] + f * (to[0] - from[0]),
                    y_m: from[1] + f * (to[1] - from[1]),
                    yaw_rad,
                    floor: self.floor,
                }
            }
        }
    }
}

/// Angle wrapped to (-pi, pi].
pub fn wrap_pi(a: f64) -> f64 {
    let w = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if w <= -std::f64::consts::PI {
        w + std::f64::consts::TAU
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start() -> UserPose {
        UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 }
    }

    #[test]
    fn walker_reaches_each_waypoint_turning_in_place_between() {
        let spec = WalkerSpec {
            waypoints: vec![[3.0, 0.0], [3.0, 2.0]],
            speed_m_s: 1.0,
            turn_rate_deg_s: 90.0,
            at_end: AtEnd::Stop,
        };
        let w = ScriptedWalker::new(start(), &spec);
        // 3 m at 1 m/s with 0.5 s ramps: 3.5 s; a 90-degree turn at 90 deg/s: about 1.26 s.
        let first = trapezoid_duration(3.0, 1.0, WALK_ACCEL_M_S2);
        assert!((first - 3.5).abs() < 1e-9);
        let p = w.pose_at(first);
        assert!((p.x_m - 3.0).abs() < 1e-9 && p.y_m.abs() < 1e-9);
        let end = w.pose_at(w.script_duration_s() + 10.0);
        assert!((end.x_m - 3.0).abs() < 1e-9 && (end.y_m - 2.0).abs() < 1e-9);
        assert!((end.yaw_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        // Mid-walk speed is the cruise speed.
        let a = w.pose_at(1.5);
        let b = w.pose_at(1.6);
        assert!(((b.x_m - a.x_m) / 0.1 - 1.0).abs() < 1e-9);
    }

    #[test]
    fn backing_up_returns_to_start_facing_forward_and_repeats() {
        let spec =
            WalkerSpec { waypoints: vec![[3.0, 0.0]], speed_m_s: 1.0, turn_rate_deg_s: 90.0, at_end: AtEnd::BackUp };
        let w = ScriptedWalker::new(start(), &spec);
        let d = w.script_duration_s();
        let back = w.pose_at(2.0 * d);
        assert!(back.x_m.abs() < 1e-9);
        let halfway_back = w.pose_at(1.5 * d);
        assert!((halfway_back.x_m - 1.5).abs() < 1e-9);
        assert_eq!(halfway_back.yaw_rad, 0.0);
        assert!((w.pose_at(2.5 * d).x_m - 1.5).abs() < 1e-9);
    }
}
