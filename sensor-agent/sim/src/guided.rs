//! A walker that follows guidance, as a user following spoken directions would: it
//! walks towards the route's next waypoint *as the device describes it*, relative to
//! where the device believes the user stands and faces (`localization/pose`), so a
//! localization error moves the walk as it would move a real user. It turns slowly on
//! the spot while the device is still looking for its position, rides an elevator when
//! told to take it (and says which floor it reached, as the user would), and stops
//! when guidance says it has arrived or has nothing to say.
//!
//! Its pose is integrated in small steps as the run goes; the poses of the last
//! seconds are kept and read back with a smooth (Hermite) interpolation, so the
//! simulated IMUs' finite differences see continuous motion.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use schemas::{MapPoint, Pose, RouteStatus};

use super::scene::ElevatorSpec;
use super::walker::{wrap_pi, Ride, Trajectory};
use super::world::UserPose;

/// Integration step, seconds.
const STEP_S: f64 = 0.005;
/// History kept, seconds (the IMUs look back at most one frame interval).
const HISTORY_S: f64 = 2.0;
/// Walking speed, m/s.
const WALK_M_S: f64 = 1.0;
/// Forward acceleration, m/s^2 (as the scripted walker).
const WALK_ACCEL_M_S2: f64 = 2.0;
/// Angular acceleration, rad/s^2 (as the scripted walker).
const TURN_ACCEL_RAD_S2: f64 = 6.0;
/// The walker turns towards its aim at the angle off it over this, seconds.
const STEER_S: f64 = 0.3;
/// Share of the walking speed kept while the device is unsure where the user is.
const UNSURE_PACE: f64 = 0.5;
/// Turn rate walking or on the spot, rad/s.
const TURN_RAD_S: f64 = 1.5;
/// Turn rate while the device looks for the position, rad/s (about 30 degrees a second).
const SEARCH_TURN_RAD_S: f64 = 0.5;
/// Off the direction by more than this, the walker slows; by twice it, it stops and turns.
const ON_COURSE_RAD: f64 = 0.35;
/// An elevator this near can be taken, metres.
const ELEVATOR_REACH_M: f64 = 1.5;
/// A ride, doors to doors, seconds.
const RIDE_S: f64 = 5.0;
/// The walker stops this near where the directions point, metres.
const ARRIVED_M: f64 = 0.15;

/// What the walker hears from the device, shared with whoever reads the bus for it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Directions {
    /// Where guidance stands and where it points next (`route/state`).
    pub status: Option<RouteStatus>,
    /// The route's next waypoint.
    pub next: Option<MapPoint>,
    /// The floor the route continues on after a gateway (the route's first point off
    /// the current floor).
    pub next_floor: Option<i32>,
    /// Where the device believes the user is (`localization/pose`).
    pub estimate: Option<Pose>,
    /// The walker reached this floor by elevator and says so (taken by the reader, who
    /// sends `cmd/floor`).
    pub said_floor: Option<i32>,
}

/// The directions shared between the bus and the walker.
pub type DirectionsHandle = Arc<Mutex<Directions>>;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Doing {
    Walking,
    Riding {
        until_s: f64,
        to_floor: i32,
    },
    /// off the elevator, until the device speaks again
    Arrived,
}

#[derive(Debug, Clone, Copy)]
struct Sample {
    t_s: f64,
    pose: UserPose,
    speed_m_s: f64,
    yaw_rate_rad_s: f64,
}

/// The guided walker.
#[derive(Debug)]
pub struct GuidedWalker {
    directions: DirectionsHandle,
    elevators: Vec<ElevatorSpec>,
    history: VecDeque<Sample>,
    doing: Doing,
    /// the directions last acted on
    heard: Directions,
    /// where they point, in the world
    aim: Option<[f64; 2]>,
    /// the device said it is not sure where the user is: slower
    unsure: bool,
    /// elevator rides taken, for reports
    rides: u32,
    /// every ride taken: start and end, seconds, floors from and to
    ride_log: Vec<(f64, f64, i32, i32)>,
}

impl GuidedWalker {
    /// A walker at `start` listening to `directions`, in a world with these elevators.
    pub fn new(start: UserPose, directions: DirectionsHandle, elevators: Vec<ElevatorSpec>) -> Self {
        let mut history = VecDeque::new();
        history.push_back(Sample { t_s: 0.0, pose: start, speed_m_s: 0.0, yaw_rate_rad_s: 0.0 });
        Self {
            directions,
            elevators,
            history,
            doing: Doing::Walking,
            heard: Directions::default(),
            aim: None,
            unsure: false,
            rides: 0,
            ride_log: Vec::new(),
        }
    }

    /// Elevator rides taken so far.
    pub fn rides(&self) -> u32 {
        self.rides
    }

    /// Walks on until `t_s`.
    pub fn advance_to(&mut self, t_s: f64) {
        let directions = match self.directions.lock() {
            Ok(d) => d.clone(),
            Err(poisoned) => poisoned.into_inner().clone(),
        };
        if directions != self.heard {
            // new words: where they point from here, kept until the next ones; while the
            // device's guidance does not take its place, the user goes on carefully the
            // way they were told last
            let guided = directions.estimate.is_some_and(|e| e.guides);
            self.unsure = !guided;
            if self.doing == Doing::Arrived {
                self.doing = Doing::Walking;
                self.aim = None;
            }
            if let (Some(next), Some(est), true) = (directions.next, directions.estimate, guided) {
                self.aim = Some(aim(&self.last().pose, &est, &next));
            }
            self.heard = directions.clone();
        }
        let mut said = None;
        while self.last().t_s + STEP_S <= t_s {
            let s = self.step(&directions, &mut said);
            self.history.push_back(s);
            while self.history.len() > 2 && self.history[1].t_s < s.t_s - HISTORY_S {
                self.history.pop_front();
            }
        }
        if said.is_some() {
            let mut d = match self.directions.lock() {
                Ok(d) => d,
                Err(poisoned) => poisoned.into_inner(),
            };
            d.said_floor = said;
            // what was heard before the ride is about the floor left behind
            d.status = None;
            d.next = None;
        }
    }

    fn last(&self) -> Sample {
        self.history.back().copied().unwrap_or(Sample {
            t_s: 0.0,
            pose: UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 },
            speed_m_s: 0.0,
            yaw_rate_rad_s: 0.0,
        })
    }

    /// One integration step with the directions of now.
    fn step(&mut self, d: &Directions, said: &mut Option<i32>) -> Sample {
        let now = self.last();
        let t_s = now.t_s + STEP_S;
        let mut pose = now.pose;
        if self.doing == Doing::Arrived {
            return Sample { t_s, pose, speed_m_s: 0.0, yaw_rate_rad_s: 0.0 };
        }
        if let Doing::Riding { until_s, to_floor } = self.doing {
            if t_s >= until_s {
                pose.floor = to_floor;
                // what it heard was about the floor it left: it waits for new words
                self.doing = Doing::Arrived;
                self.rides += 1;
                *said = Some(to_floor);
            }
            return Sample { t_s, pose, speed_m_s: 0.0, yaw_rate_rad_s: 0.0 };
        }
        let (mut want_speed, mut want_rate) = (0.0, 0.0);
        match d.status {
            Some(RouteStatus::WaitingForPosition) => want_rate = SEARCH_TURN_RAD_S,
            Some(RouteStatus::WaitingForFloor) => {
                // at the gateway of the floor it stands on, told to take it elsewhere;
                // words about the floor it left (the route ahead starting there) are stale
                if let (Some(next), Some(to_floor)) = (d.next, d.next_floor) {
                    let here = next.floor == pose.floor && to_floor != pose.floor;
                    if here && self.elevator_near(&pose, to_floor) && now.speed_m_s < 0.05 {
                        self.doing = Doing::Riding { until_s: t_s + RIDE_S, to_floor };
                        self.ride_log.push((t_s, t_s + RIDE_S, pose.floor, to_floor));
                    }
                }
            }
            Some(RouteStatus::Guiding) => {
                if let Some(goal) = self.aim.filter(|_| d.next.is_some_and(|n| n.floor == pose.floor)) {
                    let (dx, dy) = (goal[0] - pose.x_m, goal[1] - pose.y_m);
                    if dx.hypot(dy) > ARRIVED_M {
                        let off = wrap_pi(dy.atan2(dx) - pose.yaw_rad);
                        want_rate = (off / STEER_S).clamp(-TURN_RAD_S, TURN_RAD_S);
                        let pace = if self.unsure { UNSURE_PACE } else { 1.0 };
                        want_speed = pace
                            * if off.abs() < ON_COURSE_RAD {
                                WALK_M_S
                            } else if off.abs() < 2.0 * ON_COURSE_RAD {
                                0.4 * WALK_M_S
                            } else {
                                0.0
                            };
                    }
                }
            }
            _ => {}
        }
        // speed and turn rate change within the body's accelerations, and the pose moves
        // by their means over the step: the motion the IMUs see is smooth
        let dv = (want_speed - now.speed_m_s).clamp(-WALK_ACCEL_M_S2 * STEP_S, WALK_ACCEL_M_S2 * STEP_S);
        let speed = now.speed_m_s + dv;
        let dw = (want_rate - now.yaw_rate_rad_s).clamp(-TURN_ACCEL_RAD_S2 * STEP_S, TURN_ACCEL_RAD_S2 * STEP_S);
        let rate = now.yaw_rate_rad_s + dw;
        let yaw0 = pose.yaw_rad;
        pose.yaw_rad = wrap_pi(yaw0 + 0.5 * (now.yaw_rate_rad_s + rate) * STEP_S);
        pose.x_m += 0.5 * (now.speed_m_s * yaw0.cos() + speed * pose.yaw_rad.cos()) * STEP_S;
        pose.y_m += 0.5 * (now.speed_m_s * yaw0.sin() + speed * pose.yaw_rad.sin()) * STEP_S;
        Sample { t_s, pose, speed_m_s: speed, yaw_rate_rad_s: rate }
    }

    fn elevator_near(&self, pose: &UserPose, to_floor: i32) -> bool {
        self.elevators.iter().any(|e| {
            e.floors.contains(&pose.floor)
                && e.floors.contains(&to_floor)
                && (e.at[0] - pose.x_m).hypot(e.at[1] - pose.y_m) <= ELEVATOR_REACH_M
        })
    }

    /// The kept samples around `t_s`.
    fn around(&self, t_s: f64) -> (Sample, Sample) {
        let h = &self.history;
        let first = h.front().copied().unwrap_or(self.last());
        if t_s <= first.t_s || h.len() < 2 {
            return (first, first);
        }
        let last = self.last();
        if t_s >= last.t_s {
            return (last, last);
        }
        // samples are evenly spaced from the first
        let k = (((t_s - first.t_s) / STEP_S).floor() as usize).min(h.len() - 2);
        (h[k], h[k + 1])
    }
}

/// Where the walker heads: the next waypoint as seen from the estimated pose (so far
/// ahead, so far to the left), carried over to where the walker really stands and
/// faces when it hears it (a user hears "ahead, slightly left", not map coordinates).
fn aim(truth: &UserPose, est: &Pose, next: &MapPoint) -> [f64; 2] {
    let (dx, dy) = (f64::from(next.x_m - est.x_m), f64::from(next.y_m - est.y_m));
    let (s, c) = f64::from(est.yaw_rad).sin_cos();
    let (ahead, left) = (c * dx + s * dy, -s * dx + c * dy);
    let (s, c) = truth.yaw_rad.sin_cos();
    [truth.x_m + c * ahead - s * left, truth.y_m + s * ahead + c * left]
}

impl Trajectory for GuidedWalker {
    fn ride_at(&self, t_s: f64) -> Option<Ride> {
        let &(from_s, to_s, from_floor, to_floor) =
            self.ride_log.iter().rev().find(|(from_s, to_s, _, _)| (*from_s..*to_s).contains(&t_s))?;
        Some(Ride { from_floor, to_floor, done: (t_s - from_s) / (to_s - from_s) })
    }

    fn pose_at(&self, t_s: f64) -> UserPose {
        let (a, b) = self.around(t_s);
        if b.t_s <= a.t_s {
            return a.pose;
        }
        let u = ((t_s - a.t_s) / (b.t_s - a.t_s)).clamp(0.0, 1.0);
        // cubic Hermite on position and heading with the samples' rates
        let dt = b.t_s - a.t_s;
        let (h00, h10, h01, h11) = (
            2.0 * u.powi(3) - 3.0 * u * u + 1.0,
            u.powi(3) - 2.0 * u * u + u,
            -2.0 * u.powi(3) + 3.0 * u * u,
            u.powi(3) - u * u,
        );
        let va = [a.speed_m_s * a.pose.yaw_rad.cos(), a.speed_m_s * a.pose.yaw_rad.sin()];
        let vb = [b.speed_m_s * b.pose.yaw_rad.cos(), b.speed_m_s * b.pose.yaw_rad.sin()];
        let x = h00 * a.pose.x_m + h10 * dt * va[0] + h01 * b.pose.x_m + h11 * dt * vb[0];
        let y = h00 * a.pose.y_m + h10 * dt * va[1] + h01 * b.pose.y_m + h11 * dt * vb[1];
        let dyaw = wrap_pi(b.pose.yaw_rad - a.pose.yaw_rad);
        let yaw = wrap_pi(a.pose.yaw_rad + h10 * dt * a.yaw_rate_rad_s + h01 * dyaw + h11 * dt * b.yaw_rate_rad_s);
        UserPose { x_m: x, y_m: y, yaw_rad: yaw, floor: if u < 1.0 { a.pose.floor } else { b.pose.floor } }
    }

    /// A central difference of the pose over 10 ms either side, as the scripted
    /// walker's: the bob and sway that scale with it change smoothly.
    fn speed_at(&self, t_s: f64) -> f64 {
        const H: f64 = 0.01;
        let (before, after) = (Trajectory::pose_at(self, t_s - H), Trajectory::pose_at(self, t_s + H));
        (after.x_m - before.x_m).hypot(after.y_m - before.y_m) / (2.0 * H)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use schemas::LocalizationStatus;

    fn walker(at: [f64; 2]) -> (GuidedWalker, DirectionsHandle) {
        let d: DirectionsHandle = Arc::new(Mutex::new(Directions::default()));
        let lift = ElevatorSpec { label: "lift".into(), at: [10.0, 0.0], floors: vec![0, 1] };
        let start = UserPose { x_m: at[0], y_m: at[1], yaw_rad: 0.0, floor: 0 };
        (GuidedWalker::new(start, d.clone(), vec![lift]), d)
    }

    fn tell(d: &DirectionsHandle, status: RouteStatus, next: [f32; 3], est: [f32; 3], next_floor: Option<i32>) {
        let mut g = d.lock().unwrap();
        g.status = Some(status);
        g.next = Some(MapPoint { x_m: next[0], y_m: next[1], floor: next[2] as i32 });
        g.next_floor = next_floor;
        g.estimate = Some(Pose {
            x_m: est[0],
            y_m: est[1],
            yaw_rad: est[2],
            floor: 0,
            covariance: [0.0; 9],
            status: LocalizationStatus::Tracking,
            guides: true,
        });
    }

    #[test]
    fn it_walks_where_the_directions_point_as_seen_from_the_estimate() {
        let (mut w, d) = walker([0.0, 0.0]);
        // the device believes the user 1 m further north than they are: "5 m ahead" is
        // heard as 5 m ahead of where the user really stands
        tell(&d, RouteStatus::Guiding, [5.0, 1.0, 0.0], [0.0, 1.0, 0.0], None);
        let mut speeds = Vec::new();
        for k in 1..=80 {
            w.advance_to(k as f64 * 0.1);
            speeds.push(w.speed_at(k as f64 * 0.1 - 0.05));
        }
        let p = w.pose_at(8.0);
        assert!((p.x_m - 5.0).abs() < 0.2 && p.y_m.abs() < 0.05, "{p:?}");
        // it reached the point and stands; the speed rose and eased within the
        // acceleration bound (no jumps for the IMUs to see)
        assert!(w.speed_at(8.0) < 0.05);
        let peak = speeds.iter().copied().fold(0.0, f64::max);
        assert!((0.95..=1.0 + 1e-9).contains(&peak), "{peak}");
        assert!(speeds.windows(2).all(|s| (s[1] - s[0]).abs() <= WALK_ACCEL_M_S2 * 0.1 + 1e-9), "{speeds:?}");
    }

    #[test]
    fn it_walks_by_a_place_guidance_takes_and_goes_on_carefully_by_one_it_does_not() {
        // the filter converges, and guidance takes its place (followed from a known one):
        // walked to as when tracking
        let (mut w, d) = walker([0.0, 0.0]);
        tell(&d, RouteStatus::Guiding, [0.0, 5.0, 0.0], [0.0, 0.0, 0.0], None);
        d.lock().unwrap().estimate.as_mut().unwrap().status = LocalizationStatus::Converging;
        w.advance_to(8.0);
        let p = w.pose_at(8.0);
        assert!(p.x_m.abs() < 0.2 && (p.y_m - 5.0).abs() < 0.2, "{p:?}");
        // the same words from a place guidance does not take: not turned to, the user
        // goes on the way they faced, at the unsure pace
        let (mut w, d) = walker([0.0, 0.0]);
        tell(&d, RouteStatus::Guiding, [0.0, 5.0, 0.0], [0.0, 0.0, 0.0], None);
        let mut estimate = d.lock().unwrap().estimate.unwrap();
        (estimate.status, estimate.guides) = (LocalizationStatus::Converging, false);
        d.lock().unwrap().estimate = Some(estimate);
        w.advance_to(8.0);
        let p = w.pose_at(8.0);
        assert!(p.y_m.abs() < 0.05, "{p:?}");
    }

    #[test]
    fn it_rides_the_elevator_when_told_and_says_the_floor_once() {
        let (mut w, d) = walker([9.5, 0.0]);
        tell(&d, RouteStatus::WaitingForFloor, [10.0, 0.0, 0.0], [9.5, 0.0, 0.0], Some(1));
        w.advance_to(4.0);
        assert_eq!(w.pose_at(4.0).floor, 0, "riding");
        let ride = w.ride_at(4.0).expect("in the lift");
        assert_eq!((ride.from_floor, ride.to_floor), (0, 1));
        assert!(ride.done > 0.7 && ride.done < 0.8, "the ride started at the first step: {ride:?}");
        w.advance_to(6.0);
        assert_eq!((w.pose_at(6.0).floor, w.rides()), (1, 1));
        assert_eq!(w.ride_at(6.0), None, "out of the lift");
        let said = d.lock().unwrap().said_floor.take();
        assert_eq!(said, Some(1));
        // what it heard before the ride was about floor 0: it waits, it does not ride back,
        // not even when those words come again (late, from before the device heard it)
        w.advance_to(10.0);
        tell(&d, RouteStatus::WaitingForFloor, [10.0, 0.0, 0.0], [9.5, 0.0, 0.0], Some(1));
        w.advance_to(20.0);
        assert_eq!((w.pose_at(20.0).floor, w.rides()), (1, 1));
        assert!((w.pose_at(20.0).x_m - 9.5).abs() < 1e-9);
    }

    #[test]
    fn it_turns_on_the_spot_while_the_device_looks_for_the_position_and_stands_when_nothing_is_said() {
        let (mut w, d) = walker([0.0, 0.0]);
        d.lock().unwrap().status = Some(RouteStatus::WaitingForPosition);
        w.advance_to(2.0);
        let p = w.pose_at(2.0);
        // 2 s at the search rate, less the ramp up to it
        assert!((p.yaw_rad - 2.0 * SEARCH_TURN_RAD_S).abs() < 0.05 && p.x_m == 0.0, "{p:?}");
        d.lock().unwrap().status = Some(RouteStatus::Arrived);
        w.advance_to(4.0);
        // it eases out of the turn and stands
        let (p2, p4) = (w.pose_at(2.0), w.pose_at(4.0));
        assert!((p4.yaw_rad - p2.yaw_rad).abs() < 0.05 && p4.x_m == 0.0, "{p2:?} {p4:?}");
        assert_eq!(w.pose_at(4.0), w.pose_at(3.5));
    }
}
