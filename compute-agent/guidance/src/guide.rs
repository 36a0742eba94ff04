//! The guide: from the route and the user's pose, at most one instruction per step.
//!
//! Progress along a leg is the nearest of the current segment and the next two (never
//! backwards, except when the user rejoins the route behind), so a route that doubles
//! back does not make the guide jump ahead. The checks run in this order each step,
//! and the first that has something to say wins:
//!
//! 1. localization not confident: say so once, then nothing (no turns on a guess);
//!    still not confident after `stop_when_uncertain_ms`: ask the user to stop and turn
//!    slowly on the spot until the position is found;
//! 2. the floor: the gateway's destination floor starts the next leg, any other floor
//!    asks for a replan;
//! 3. off the route (hysteresis `off_route_m` / `on_route_m`): where to rejoin
//!    ([`planning::Route::rejoin`], ISANA's O(1) recovery) or a replan request;
//! 4. the start of a leg, or coming back to the route: length and which way to face;
//! 5. arrival (exempt from spacing) or "you are at the elevator";
//! 6. the next turn: "turn right now" within `turn_now_m`, "in 6 metres, turn right" within
//!    `announce_turn_m` (skipped when "now" would follow sooner than the spacing); a turn
//!    whose own announcement would be skipped after the "now" of the one before is
//!    announced with that one ("In 6 metres, turn right, then turn left."); where that
//!    one's announcement was left out, its "now" is followed at once by the next
//!    ("Turn right now." "Then turn left.": the "now" stays short);
//! 7. a gateway ahead;
//! 8. a named area of the map the user has just entered ("Entering the stair hall."),
//!    then a numbered door the user comes level with ("Passing door 214, on your
//!    left."), where nothing of 5-7 is near enough ahead for it to be held back by them.
//!
//! Everything spontaneous waits for `min_spacing_ms` after the previous one (arrival
//! excepted); an instruction that has to wait is tried again next step, with the
//! distances of then. A door or an area asks nothing of the user: nothing waits for it.

use std::collections::VecDeque;

use map::{GatewayKind, SemanticLayer};
use planning::{BuildingRoute, Leg, LegEnd, NavGraph, Rejoin, Route};

use crate::instruction::{ttl_ms, Instruction, InstructionKind};
use crate::profile::{DirectionStyle, GuidanceProfile};
use crate::utterance::{bearing_phrase, capitalised, distance_phrase, gateway_words, turn_phrase, wrap_deg, Turn};
use crate::where_am_i::{not_known, where_am_i, with_article, LastKnown};

/// "Then turn left." follows the "now" before it within this, or is not said, ms.
const THEN_WITHIN_MS: u64 = 1000;

/// How much of the heading's history is kept to tell a turning user, ms.
const HEADINGS_KEPT_MS: u64 = 1000;
/// Level with the route's end (within the arrival radius along it), a user this near
/// the end has arrived, metres: issue 31's "within 1 m of the place". A user who passes
/// the goal a stride to its side never comes within the arrival radius.
pub const ARRIVAL_BESIDE_M: f64 = 1.0;
/// A user told they are at the elevator who walks this far from it is told where it is,
/// metres (our choice: out of the lift and its doorway, well past the arrival radius).
pub const GATEWAY_LEFT_M: f64 = 3.0;

/// Said once when the pose stops being confident.
pub(crate) const UNCERTAIN: &str = "Position uncertain: no turn instructions until I know where you are again.";
/// Said once when it has not been confident for the profile's `stop_when_uncertain_ms`.
pub(crate) const STOP_UNCERTAIN: &str =
    "Position still uncertain: please stop, and turn slowly on the spot until I find your position.";
/// Said when the user has turned on the spot for the profile's `search_for_ms` and the
/// position is still not known: turning will not find it here.
pub(crate) const SEARCH_FAILED: &str = "I cannot find your position by turning. Please stop turning, and tell me the number of a door you are at, or ask someone nearby where you are and tell me the place.";
/// Said while localization has found a place by a search that only the user's word can
/// confirm (a door number, a named place: turning will not), every profile's
/// `search_for_ms` after the localization's own question
/// (`localization::tracker::SEARCHED_NEWS`) ([`Guide::set_awaiting_word`]).
pub(crate) const CONFIRM_PLACE: &str =
    "I am still not sure where you are: tell me the number of a door you are at, or the name of a place you are near.";
/// Whether the user waiting to confirm a searched place is to be asked for their word
/// again now: `every_ms` after `asked` (the first call, when the localization's own
/// question was said, starts the count). The caller sets `asked` once it asked.
pub(crate) fn word_ask_due(asked: &mut Option<u64>, now_ms: u64, every_ms: u64) -> bool {
    now_ms.saturating_sub(*asked.get_or_insert(now_ms)) >= every_ms
}

/// Said when the position is known again after the user was asked to stop and turn:
/// the words of the localization's news for it, said once when both come in one step
/// ([`crate::Navigator::step_after_news`]).
pub(crate) const POSITION_FOUND: &str = "Position found.";

/// A door is passed from when it is this far ahead along the way to when it is this
/// far behind, metres (the user's place moves 0.1 m a step at walking pace).
const PASSING_AHEAD_M: f64 = 1.0;
const PASSING_BEHIND_M: f64 = 0.5;
/// A door nearer the way than this is on it (a door the route goes through), not beside
/// it, metres.
pub(crate) const PASSING_MIN_M: f64 = 0.4;
/// An area entered is said from when the user is this far past where they entered it
/// (a step across its edge and back is no entering) to this far, metres (our choice;
/// later, "entering" would be said well inside it).
const ENTERED_FROM_M: f64 = 1.0;
const ENTERED_UNTIL_M: f64 = 5.0;

/// The headings of the last second of poses (ms, radians).
#[derive(Clone, Debug, Default)]
pub(crate) struct Headings(VecDeque<(u64, f64)>);

impl Headings {
    /// The heading at `now_ms` (a non-finite one is no heading; a clock that went back
    /// starts the history again).
    pub(crate) fn push(&mut self, now_ms: u64, heading_rad: f64) {
        if !heading_rad.is_finite() {
            return;
        }
        if self.0.back().is_some_and(|&(t, _)| t > now_ms) {
            self.0.clear();
        }
        self.0.push_back((now_ms, heading_rad));
        while self.0.front().is_some_and(|&(t, _)| t.saturating_add(HEADINGS_KEPT_MS) < now_ms) {
            self.0.pop_front();
        }
    }

    /// False while the heading is known to turn: from the oldest kept to the newest it
    /// turned faster than `max_deg_s`. With one heading or none, nothing is known: true.
    pub(crate) fn still(&self, max_deg_s: f64) -> bool {
        let (Some(&(t0, h0)), Some(&(t1, h1))) = (self.0.front(), self.0.back()) else {
            return true;
        };
        if t1 <= t0 {
            return true;
        }
        let dt_s = (t1 - t0) as f64 / 1000.0;
        wrap_deg((h1 - h0).to_degrees()).abs() / dt_s <= max_deg_s
    }
}

/// What a barometer says of the user's height, as the caller last read it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Barometer {
    /// none is read: there is none, or it stopped sending
    #[default]
    Unread,
    /// its height holds still at the floor the user is on (they stand on the level)
    AtFloor,
    /// it is read, but the height is not the floor's: moving (stairs, a lift, a ramp)
    /// or between floors
    OffFloor,
}

/// Where the user is, as localization says.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UserPose {
    /// map frame of `floor`, metres
    pub x_m: f64,
    /// map frame of `floor`, metres
    pub y_m: f64,
    /// the direction the user faces, map frame, radians counter-clockwise from +x
    pub heading_rad: f64,
    /// floor level
    pub floor: i32,
    /// localization trusts this pose (converged, small covariance); a pose with a
    /// non-finite coordinate or heading is taken as not confident
    pub confident: bool,
}

impl UserPose {
    /// Guidance may take this place: localization trusts it and every number of it is
    /// finite.
    pub fn placed(&self) -> bool {
        self.confident && self.x_m.is_finite() && self.y_m.is_finite() && self.heading_rad.is_finite()
    }
}

/// Where the user is along the current leg.
#[derive(Clone, Copy, Debug)]
struct Progress {
    /// segment index (waypoint `segment` to `segment + 1`)
    segment: usize,
    /// distance from the user to that segment, metres
    lateral_m: f64,
    /// along the route from the user's projection to the segment's end waypoint
    to_next_m: f64,
    /// along the route from the projection to the leg's end
    remaining_m: f64,
}

/// What is left of a route ([`Guide::ahead`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Ahead {
    /// (floor, map point) in walking order: the next waypoint first, the goal last
    pub points: Vec<(i32, [f64; 2])>,
    /// along the route from the user to the goal, metres (gateway rides count 0)
    pub distance_m: f64,
    /// the user was told they are at the gateway and to confirm the floor
    pub at_gateway: bool,
}

/// Turns route and pose into instructions. Pure: time is the `now_ms` argument.
#[derive(Clone, Debug)]
pub struct Guide {
    profile: GuidanceProfile,
    destination: String,
    semantic: SemanticLayer,
    legs: Vec<Leg>,
    /// bumped by every new route, so dedup keys of an old route never silence the new one
    generation: u64,
    leg: usize,
    /// the waypoint ahead on the current leg
    target: usize,
    started_leg: Option<usize>,
    announced: Option<(usize, usize)>,
    said_now: Option<(usize, usize)>,
    /// the turn announced with the one before it ("…, then turn left.", or "Then turn
    /// left." after its "now"): not announced again
    then_said: Option<(usize, usize)>,
    gateway_ahead_said: Option<usize>,
    at_gateway_said: Option<usize>,
    /// after that, the user walked away from the elevator and was told where it is
    gateway_left_said: bool,
    /// what a barometer says of the user's height ([`Guide::set_barometer`])
    barometer: Barometer,
    /// the words at the gateway of this leg said the barometer would notice the floor
    /// reached: said otherwise if it stops sending before then
    floor_noticed_said: Option<usize>,
    /// localization found a place by a search that waits for the user's word
    /// ([`Guide::set_awaiting_word`])
    awaiting_word: bool,
    /// when the user was last asked for it (the localization's question, then
    /// [`CONFIRM_PLACE`]), ms; none while not awaiting
    word_asked_ms: Option<u64>,
    arrived: bool,
    off_route: bool,
    /// came back to the route after a deviation: say which way to face
    back_on_route: bool,
    deviation_said_ms: Option<u64>,
    uncertain_said: bool,
    /// since when the pose has not been confident, ms (none while it is)
    uncertain_since_ms: Option<u64>,
    /// the user was asked to stop and turn on the spot until the position is found
    stop_said: bool,
    /// when they were asked (while `stop_said`), ms
    stop_said_ms: u64,
    /// and, still not found after the profile's `search_for_ms`, asked to stop turning
    /// and tell a door number or ask someone ([`SEARCH_FAILED`])
    search_failed_said: bool,
    last_spontaneous_ms: Option<u64>,
    last: Option<Instruction>,
    serial: u64,
    /// the pose's heading over the last second: is the user turning?
    pub(crate) headings: Headings,
    /// the last instruction was not heard: the next one gets a key of its own (the
    /// feedback agent remembers the key of what it started, even if it was cut)
    again: bool,
    /// the route is a way round something the camera found on the last one: its start
    /// says so
    detour: bool,
    /// the doors said passing on this trip (each once, whatever the route)
    doors_said: Vec<String>,
    /// where the user was when the last door was said
    last_door_at: Option<[f64; 2]>,
    /// the floor and the areas the user was last in, innermost first
    areas_here: Option<(i32, Vec<String>)>,
    /// an area just entered, not yet said, and where the user entered it
    area_entered: Option<(String, [f64; 2])>,
    /// the areas said entering on this trip, by floor (each once)
    areas_said: Vec<(i32, String)>,
    /// when the last door or area was said: they keep the spacing between each other
    /// (and after the route's words) without holding back the route's words
    last_passing_ms: Option<u64>,
}

impl Guide {
    /// A guide along `legs` (walking order) to `destination` ("room 214"; empty when it
    /// has no name). `semantic` answers "where am I" (any floors; filtered by the pose's).
    pub fn new(legs: Vec<Leg>, destination: &str, semantic: SemanticLayer, profile: GuidanceProfile) -> Self {
        let mut g = Self {
            profile,
            destination: destination.trim().to_string(),
            semantic,
            legs: Vec::new(),
            generation: 0,
            leg: 0,
            target: 1,
            started_leg: None,
            announced: None,
            said_now: None,
            then_said: None,
            gateway_ahead_said: None,
            at_gateway_said: None,
            gateway_left_said: false,
            barometer: Barometer::Unread,
            floor_noticed_said: None,
            awaiting_word: false,
            word_asked_ms: None,
            arrived: false,
            off_route: false,
            back_on_route: false,
            deviation_said_ms: None,
            uncertain_said: false,
            uncertain_since_ms: None,
            stop_said: false,
            stop_said_ms: 0,
            search_failed_said: false,
            last_spontaneous_ms: None,
            last: None,
            serial: 0,
            headings: Headings::default(),
            again: false,
            detour: false,
            doors_said: Vec::new(),
            last_door_at: None,
            areas_here: None,
            area_entered: None,
            areas_said: Vec::new(),
            last_passing_ms: None,
        };
        g.set_legs(legs);
        g
    }

    /// A guide along a route on one floor.
    pub fn single_floor(route: Route, destination: &str, semantic: SemanticLayer, profile: GuidanceProfile) -> Self {
        Self::new(vec![Leg { route, end: LegEnd::Goal }], destination, semantic, profile)
    }

    /// A guide along a route across floors.
    pub fn building(
        route: BuildingRoute,
        destination: &str,
        semantic: SemanticLayer,
        profile: GuidanceProfile,
    ) -> Self {
        Self::new(route.legs, destination, semantic, profile)
    }

    /// Replaces the route (after a replan): guidance starts again on its first leg; the
    /// spacing clock and the last instruction (for "repeat") are kept.
    pub fn set_route(&mut self, route: BuildingRoute) {
        self.set_legs(route.legs);
    }

    /// Replaces the route with a way round something found standing on it
    /// ([`crate::Navigator::perceived`]): as [`Guide::set_route`], and the new route's
    /// start says why it changed ("Something stands in the way. A way round: ...").
    pub fn set_detour(&mut self, route: BuildingRoute) {
        self.set_legs(route.legs);
        self.detour = true;
    }

    /// The current leg's route and the index of the waypoint ahead on it; `None` once
    /// arrived.
    pub fn way_left(&self) -> Option<(&Route, usize)> {
        (!self.arrived).then(|| self.legs.get(self.leg).map(|l| (&l.route, self.target))).flatten()
    }

    fn set_legs(&mut self, legs: Vec<Leg>) {
        self.detour = false;
        self.legs = legs;
        self.generation += 1;
        self.leg = 0;
        self.started_leg = None;
        self.announced = None;
        self.said_now = None;
        self.then_said = None;
        self.gateway_ahead_said = None;
        self.at_gateway_said = None;
        self.gateway_left_said = false;
        self.floor_noticed_said = None;
        self.arrived = false;
        self.off_route = false;
        self.back_on_route = false;
        self.deviation_said_ms = None;
        self.target = self.first_target();
    }

    /// The profile in use.
    pub fn profile(&self) -> &GuidanceProfile {
        &self.profile
    }

    /// True once "you have arrived" was said.
    pub fn arrived(&self) -> bool {
        self.arrived
    }

    /// Index of the leg being walked.
    pub fn leg(&self) -> usize {
        self.leg
    }

    /// The floor the current leg is on, if there is a route.
    pub fn floor(&self) -> Option<i32> {
        self.legs.get(self.leg).map(|l| l.route.floor)
    }

    /// The last instruction given (spontaneous or asked for; repeats excluded).
    pub fn last(&self) -> Option<&Instruction> {
        self.last.as_ref()
    }

    /// The feedback agent never finished saying `text` (dropped as stale, cut off by a
    /// warning). When it is the last instruction, it is given again, with the words of
    /// then, as soon as the step would give it: the route's start (or back on the
    /// route), an off-route prompt, a turn still ahead (a "now" only while the turn is
    /// within reach), a gateway ahead (while it is) and "you are at the elevator" (while
    /// the user is), where the elevator is (while the user is still away from it), the
    /// arrival, the request to stop and turn on the spot, the search that failed and the
    /// position found after them. True when it was.
    pub fn not_heard(&mut self, text: &str) -> bool {
        let Some(last) = self.last.as_ref().filter(|i| i.text == text) else {
            return false;
        };
        match last.kind {
            InstructionKind::Start { leg } if self.started_leg == Some(leg) => self.started_leg = None,
            InstructionKind::OffRoute { .. } | InstructionKind::Replan => self.deviation_said_ms = None,
            InstructionKind::TurnAhead { leg, waypoint, .. } if self.announced == Some((leg, waypoint)) => {
                self.announced = None;
                self.then_said = None;
            }
            InstructionKind::TurnNow { leg, waypoint, .. } if self.said_now == Some((leg, waypoint)) => {
                self.said_now = None;
                self.announced = None;
            }
            InstructionKind::GatewayAhead { leg } if self.gateway_ahead_said == Some(leg) => {
                self.gateway_ahead_said = None;
            }
            // a user at the lift who did not hear which floor waits there for nothing
            InstructionKind::AtGateway { leg } if self.at_gateway_said == Some(leg) => self.at_gateway_said = None,
            // a user who did not hear that the floor will not be noticed waits for it
            InstructionKind::FloorNotNoticed { leg } if leg == self.leg && self.at_gateway_said == Some(leg) => {
                self.floor_noticed_said = Some(leg);
            }
            // still away from the elevator: where it is, said again
            InstructionKind::AwayFromGateway { leg } if leg == self.leg && self.gateway_left_said => {
                self.gateway_left_said = false;
            }
            InstructionKind::Arrived => self.arrived = false,
            InstructionKind::StopAndTurn => self.stop_said = false,
            // still turning on the spot, the search's time up: said again
            InstructionKind::SearchFailed => self.search_failed_said = false,
            // still turning on the spot: said again while the position is known
            InstructionKind::PositionFound => self.stop_said = true,
            _ => return false,
        }
        // not heard: no spacing to keep after it
        self.last_spontaneous_ms = None;
        self.again = true;
        true
    }

    /// The route still ahead of `pose`: from the user's place on the current leg (its
    /// start when the pose is on another floor) through every later leg, and the distance
    /// along it. `None` without a route or once arrived.
    pub fn ahead(&self, pose: &UserPose) -> Option<Ahead> {
        if self.arrived || self.legs.is_empty() {
            return None;
        }
        let leg = &self.legs[self.leg];
        let w = &leg.route.waypoints;
        let here = pose.floor == leg.route.floor && pose.x_m.is_finite() && pose.y_m.is_finite();
        let (first, mut distance_m) = if here && w.len() >= 2 {
            let pr = self.progress(pose);
            (pr.segment + 1, pr.remaining_m)
        } else {
            (0, leg.route.length_m)
        };
        let mut points: Vec<(i32, [f64; 2])> = w[first.min(w.len())..].iter().map(|&p| (leg.route.floor, p)).collect();
        for later in &self.legs[self.leg + 1..] {
            points.extend(later.route.waypoints.iter().map(|&p| (later.route.floor, p)));
            distance_m += later.route.length_m;
        }
        let at_gateway = self.at_gateway_said == Some(self.leg);
        Some(Ahead { points, distance_m, at_gateway })
    }

    /// The user said they reached `floor` (ISANA: the map switches when the user
    /// confirms the floor). Starts the next leg when the current one ends at a gateway
    /// to that floor; false otherwise.
    pub fn floor_confirmed(&mut self, floor: i32) -> bool {
        match self.legs.get(self.leg).map(|l| &l.end) {
            Some(LegEnd::Gateway { to_floor, .. }) if *to_floor == floor && self.leg + 1 < self.legs.len() => {
                self.enter_leg(self.leg + 1);
                true
            }
            _ => false,
        }
    }

    /// One step: the user's pose at `now_ms`; `graph` is the navigation graph of the
    /// pose's floor, for rejoining (without it, leaving the route asks for a replan).
    pub fn step(&mut self, pose: &UserPose, now_ms: u64, graph: Option<&NavGraph>) -> Option<Instruction> {
        if self.arrived || self.legs.is_empty() {
            return None;
        }
        self.headings.push(now_ms, pose.heading_rad);
        // a pose with a non-finite number is no pose: treated as not confident
        if !pose.placed() {
            let since_ms = *self.uncertain_since_ms.get_or_insert(now_ms);
            if !self.uncertain_said {
                let i =
                    self.issue(InstructionKind::PositionUncertain, UNCERTAIN.into(), "uncertain", now_ms, Pace::Spaced);
                self.uncertain_said = i.is_some();
                return i;
            }
            if self.awaiting_word {
                // a place a search found waits for the user's word: turning will not
                // confirm it. The localization asked at once; asked again each
                // `search_for_ms`
                if !word_ask_due(&mut self.word_asked_ms, now_ms, self.profile.search_for_ms) {
                    return None;
                }
                let i = self.issue(
                    InstructionKind::ConfirmPlace,
                    CONFIRM_PLACE.into(),
                    "uncertain/confirm",
                    now_ms,
                    Pace::Spaced,
                );
                if i.is_some() {
                    self.word_asked_ms = Some(now_ms);
                }
                return i;
            }
            self.word_asked_ms = None;
            if self.stop_said {
                if self.search_failed_said || now_ms.saturating_sub(self.stop_said_ms) < self.profile.search_for_ms {
                    return None;
                }
                // turned long enough and not found: turning will not find it here
                let i = self.issue(
                    InstructionKind::SearchFailed,
                    SEARCH_FAILED.into(),
                    "uncertain/search-failed",
                    now_ms,
                    Pace::Spaced,
                );
                self.search_failed_said = i.is_some();
                return i;
            }
            if now_ms.saturating_sub(since_ms) < self.profile.stop_when_uncertain_ms {
                return None;
            }
            let i =
                self.issue(InstructionKind::StopAndTurn, STOP_UNCERTAIN.into(), "uncertain/stop", now_ms, Pace::Spaced);
            self.stop_said = i.is_some();
            self.stop_said_ms = now_ms;
            return i;
        }
        (self.uncertain_said, self.uncertain_since_ms, self.search_failed_said) = (false, None, false);
        self.word_asked_ms = None;
        if std::mem::take(&mut self.stop_said) {
            // the user stands turning on the spot until told: said at once, and the way
            // to face follows once they stand still
            self.back_on_route = true;
            return self.issue(InstructionKind::PositionFound, POSITION_FOUND.into(), "found", now_ms, Pace::Exempt);
        }
        if pose.floor != self.legs[self.leg].route.floor {
            if let LegEnd::Gateway { to_floor, .. } = self.legs[self.leg].end {
                if to_floor == pose.floor && self.leg + 1 < self.legs.len() {
                    self.enter_leg(self.leg + 1);
                }
            }
            if pose.floor != self.legs[self.leg].route.floor {
                return self.replan(pose, now_ms);
            }
        }
        if self.at_gateway_said == Some(self.leg) {
            if let Some(i) = self.floor_not_noticed(now_ms) {
                return Some(i);
            }
            // waiting at the gateway for the floor to change; a user who walked away from
            // the gateway and came back is told again what to do there
            if !(self.gateway_left_said && self.at_leg_end(pose)) {
                return self.left_gateway(pose, now_ms);
            }
            (self.at_gateway_said, self.gateway_left_said) = (None, false);
        }
        self.follow_areas(pose);
        let pr = self.progress(pose);
        if self.off_route {
            if pr.lateral_m <= self.profile.on_route_m {
                self.off_route = false;
                self.back_on_route = self.deviation_said_ms.is_some();
                self.deviation_said_ms = None;
            }
        } else if pr.lateral_m > self.profile.off_route_m {
            self.off_route = true;
        }
        if self.off_route {
            return self.deviation(pose, now_ms, graph);
        }
        self.target = self.target.max(pr.segment + 1);
        if self.started_leg != Some(self.leg) || self.back_on_route {
            return self.start(pose, &pr, now_ms);
        }
        // both along the route and as the crow flies, so a goal behind a wall or a route that
        // loops back past its goal does not end guidance early
        // ... or level with the end and beside it, within issue 31's metre: a user who
        // walks past the goal a stride to its side has arrived too (else, never within
        // the radius, they walk on until told they are off the route)
        let at_end = pr.remaining_m <= self.profile.arrival_radius_m && self.at_leg_end(pose);
        let leg_end = self.legs[self.leg].end.clone();
        match (&leg_end, at_end) {
            (LegEnd::Goal, true) if self.leg + 1 >= self.legs.len() => {
                let text = match self.destination.as_str() {
                    "" => "You have arrived.".to_string(),
                    d => format!("You have arrived at {d}."),
                };
                let i = self.issue(InstructionKind::Arrived, text, "arrived", now_ms, Pace::Exempt);
                self.arrived = i.is_some();
                return i;
            }
            (LegEnd::Gateway { kind, to_floor, .. }, true) => {
                let (name, it) = gateway_words(*kind);
                let text = format!("You are at the {name}. Take {it} to floor {to_floor}{}", self.floor_told(false));
                let key = format!("leg{}/at-gateway", self.leg);
                let noticed = self.height_held();
                let i = self.issue(InstructionKind::AtGateway { leg: self.leg }, text, &key, now_ms, Pace::Spaced);
                if i.is_some() {
                    self.at_gateway_said = Some(self.leg);
                    self.floor_noticed_said = noticed.then_some(self.leg);
                }
                return i;
            }
            _ => {}
        }
        if let Some(i) = self.then_after_now(now_ms) {
            return Some(i);
        }
        if let Some(i) = self.turn(&pr, now_ms) {
            return Some(i);
        }
        if let LegEnd::Gateway { kind, to_floor, .. } = leg_end {
            if pr.remaining_m <= self.profile.announce_turn_m && self.gateway_ahead_said != Some(self.leg) {
                let (name, it) = gateway_words(kind);
                let text =
                    format!("{} ahead; take {it} to floor {to_floor}{}", capitalised(name), self.floor_told(true));
                let key = format!("leg{}/gateway-ahead", self.leg);
                let i = self.issue(InstructionKind::GatewayAhead { leg: self.leg }, text, &key, now_ms, Pace::Spaced);
                if i.is_some() {
                    self.gateway_ahead_said = Some(self.leg);
                }
                return i;
            }
        }
        if let Some(i) = self.entering_area(pose, &pr, now_ms) {
            return Some(i);
        }
        self.passing_door(pose, &pr, now_ms)
    }

    /// The answer to "where am I": the areas around the pose and the nearest door (not
    /// confident: that it is not known and where the user was `last` placed, or the
    /// question for the user's word).
    pub fn where_am_i(&mut self, pose: &UserPose, last: Option<&LastKnown>, now_ms: u64) -> Instruction {
        let text = if pose.confident && pose.x_m.is_finite() && pose.y_m.is_finite() {
            where_am_i(&self.semantic, pose.floor, pose.x_m, pose.y_m, self.profile.near_door_m)
        } else if self.awaiting_word {
            CONFIRM_PLACE.to_string()
        } else {
            not_known(last, &self.semantic, &self.profile, pose.floor)
        };
        self.answer(InstructionKind::WhereAmI, text, "where-am-i", now_ms, true)
    }

    /// The answer to "repeat": the last instruction again, except that a turn is said
    /// with the distance of now (or, once passed, which way to face and how far to go
    /// straight on), never a stale "turn right now", and the route's start says the
    /// way to face from where the user faces now, as does a "position uncertain" once
    /// the position is known again.
    pub fn repeat(&mut self, pose: &UserPose, now_ms: u64) -> Instruction {
        let Some(last) = self.last.clone() else {
            return self.answer(
                InstructionKind::NothingToRepeat,
                "Nothing to repeat yet.".into(),
                "repeat",
                now_ms,
                false,
            );
        };
        if let InstructionKind::TurnAhead { leg, waypoint, .. } | InstructionKind::TurnNow { leg, waypoint, .. } =
            last.kind
        {
            if !pose.confident {
                let (kind, text) = match (self.awaiting_word, self.search_failed_said, self.stop_said) {
                    (true, _, _) => (InstructionKind::ConfirmPlace, CONFIRM_PLACE),
                    (false, true, _) => (InstructionKind::SearchFailed, SEARCH_FAILED),
                    (false, false, true) => (InstructionKind::StopAndTurn, STOP_UNCERTAIN),
                    (false, false, false) => (InstructionKind::PositionUncertain, UNCERTAIN),
                };
                return self.answer(kind, text.into(), "repeat", now_ms, false);
            }
            if leg == self.leg && waypoint == self.target && pose.floor == self.legs[leg].route.floor {
                let pr = self.progress(pose);
                let (kind, text, _) = self.turn_words(pr.to_next_m, waypoint);
                return self.answer(kind, text, "repeat", now_ms, false);
            }
            let pr = self.progress(pose);
            let text = self.face_words(pose, &pr);
            return self.answer(InstructionKind::Continue, text, "repeat", now_ms, false);
        }
        // the way to face is said again from where the user faces now (they may have
        // turned since, or never heard it)
        let here = pose.confident && self.legs.get(self.leg).is_some_and(|l| l.route.floor == pose.floor);
        match (&last.kind, here) {
            (InstructionKind::Start { .. }, true) => {
                let pr = self.progress(pose);
                let text = self.start_words(pose, &pr, false);
                return self.answer(last.kind.clone(), text, "repeat", now_ms, false);
            }
            // the position is known again since: not a stale "uncertain", the way on
            (
                InstructionKind::PositionUncertain
                | InstructionKind::StopAndTurn
                | InstructionKind::SearchFailed
                | InstructionKind::ConfirmPlace
                | InstructionKind::PositionFound,
                true,
            ) if !self.off_route => {
                let pr = self.progress(pose);
                let text = self.face_words(pose, &pr);
                return self.answer(InstructionKind::Continue, text, "repeat", now_ms, false);
            }
            _ => {}
        }
        self.serial += 1;
        Instruction {
            dedup_key: format!("{}/repeat/{}", last.dedup_key, self.serial),
            vibrate_first: false,
            issued_ms: now_ms,
            ..last
        }
    }

    fn enter_leg(&mut self, leg: usize) {
        self.leg = leg;
        self.gateway_left_said = false;
        self.target = self.first_target();
        self.off_route = false;
        self.deviation_said_ms = None;
    }

    /// Metres from `pose` to the current leg's end as the crow flies (0 on a leg
    /// without waypoints).
    fn to_leg_end_m(&self, pose: &UserPose) -> f64 {
        let here = [pose.x_m, pose.y_m];
        dist(here, self.waypoints().last().copied().unwrap_or(here))
    }

    /// Within the arrival radius of the current leg's end (or, beside it, within
    /// [`ARRIVAL_BESIDE_M`]), as the crow flies.
    fn at_leg_end(&self, pose: &UserPose) -> bool {
        self.to_leg_end_m(pose) <= self.profile.arrival_radius_m.max(ARRIVAL_BESIDE_M)
    }

    /// Whether localization has found a place by a search that waits for the user's
    /// word (`Tracking`, `searched`: `localization::Estimate::searched`), as the caller
    /// last said. While the pose is not confident, the user is then not asked to stop
    /// and turn on the spot (turning will not confirm the place) but asked again for a
    /// door number or a named place ("I am still not sure where you are: ...") each
    /// `search_for_ms`.
    pub fn set_awaiting_word(&mut self, awaiting: bool) {
        self.awaiting_word = awaiting;
    }

    /// What a barometer says of the user's height, as the caller last read it: at
    /// their floor's height (on the level), a user who walked away from the foot of
    /// stairs or a ramp has not taken them, and the words at a gateway say the floor
    /// reached will be noticed; a barometer that stops sending ([`Barometer::Unread`])
    /// after those words were said has the user told to say the floor themselves.
    pub fn set_barometer(&mut self, barometer: Barometer) {
        self.barometer = barometer;
    }

    fn height_held(&self) -> bool {
        self.barometer == Barometer::AtFloor
    }

    /// How the words at a gateway (`ahead` of it, or at it) end: who tells the floor.
    /// With a barometer holding the floor's height the agent notices the floor itself
    /// (the user may still say it); without, the user says it.
    fn floor_told(&self, ahead: bool) -> &'static str {
        match (self.height_held(), ahead) {
            (true, true) => "; I will notice the floor when you get there.",
            (true, false) => ". I will notice the floor when you get there; you can also tell me.",
            (false, true) => "; tell me when you are there.",
            (false, false) => ", then tell me when you are there.",
        }
    }

    /// Told at the gateway that the floor reached will be noticed, the barometer stopped
    /// sending: the user is to say it ("I can no longer measure the height: ..."), once
    /// (again if a warning cut it off). A barometer read again afterwards still notices
    /// the floor.
    fn floor_not_noticed(&mut self, now_ms: u64) -> Option<Instruction> {
        if self.floor_noticed_said != Some(self.leg) || self.barometer != Barometer::Unread {
            return None;
        }
        let LegEnd::Gateway { to_floor, .. } = self.legs[self.leg].end else {
            return None;
        };
        let text = format!("I can no longer measure the height, so I will not notice the floor: tell me when you are on floor {to_floor}.");
        self.serial += 1;
        let key = format!("leg{}/floor-not-noticed/{}", self.leg, self.serial);
        let i = self.issue(InstructionKind::FloorNotNoticed { leg: self.leg }, text, &key, now_ms, Pace::Spaced);
        if i.is_some() {
            self.floor_noticed_said = None;
        }
        i
    }

    /// Told they are at the gateway, the user walked [`GATEWAY_LEFT_M`] or more from it:
    /// where it is, once until they come back (said while they stand or walk, not while
    /// they turn). For stairs or a ramp only while a barometer says the user stands at
    /// their floor's height ([`Self::set_barometer`]): a user who takes them walks
    /// away from their foot too.
    fn left_gateway(&mut self, pose: &UserPose, now_ms: u64) -> Option<Instruction> {
        let LegEnd::Gateway { kind, .. } = self.legs[self.leg].end else {
            return None;
        };
        if kind != GatewayKind::Elevator && !self.height_held() {
            return None;
        }
        let away_m = self.to_leg_end_m(pose);
        if self.gateway_left_said || away_m < GATEWAY_LEFT_M || !self.still() {
            return None;
        }
        let end = *self.waypoints().last()?;
        let (name, _) = gateway_words(kind);
        let is = if kind == GatewayKind::Stairs { "are" } else { "is" };
        let text = format!(
            "The {name} {is} {} away, {}.",
            distance_phrase(away_m, &self.profile),
            bearing_phrase(relative_right_deg(pose, end), &self.profile)
        );
        self.serial += 1;
        let key = format!("leg{}/left-gateway/{}", self.leg, self.serial);
        let i = self.issue(InstructionKind::AwayFromGateway { leg: self.leg }, text, &key, now_ms, Pace::Spaced);
        self.gateway_left_said = i.is_some();
        i
    }

    fn first_target(&self) -> usize {
        let n = self.legs.get(self.leg).map_or(0, |l| l.route.waypoints.len());
        1.min(n.saturating_sub(1))
    }

    fn route(&self) -> &Route {
        &self.legs[self.leg].route
    }

    fn waypoints(&self) -> &[[f64; 2]] {
        &self.legs[self.leg].route.waypoints
    }

    /// The nearest of the current segment and the next two (ties to the later one).
    fn progress(&self, pose: &UserPose) -> Progress {
        let w = self.waypoints();
        let p = [pose.x_m, pose.y_m];
        if w.len() < 2 {
            let d = w.first().map_or(0.0, |&q| dist(p, q));
            return Progress { segment: 0, lateral_m: d, to_next_m: d, remaining_m: d };
        }
        let first = self.target.saturating_sub(1).min(w.len() - 2);
        let last = (first + 2).min(w.len() - 2);
        let mut best = (f64::INFINITY, first, w[first]);
        for s in first..=last {
            let (d, q) = closest_on_segment(p, w[s], w[s + 1]);
            if d <= best.0 + 1e-9 {
                best = (d, s, q);
            }
        }
        let (lateral_m, segment, q) = best;
        let to_next_m = dist(q, w[segment + 1]);
        Progress {
            segment,
            lateral_m,
            to_next_m,
            remaining_m: to_next_m + self.route().remaining_from_waypoint_m(segment + 1),
        }
    }

    /// Degrees to the right the route bends at waypoint `w` (0 at the ends).
    fn bend_right_deg(&self, w: usize) -> f64 {
        let p = self.waypoints();
        if w == 0 || w + 1 >= p.len() {
            return 0.0;
        }
        let a_in = (p[w][1] - p[w - 1][1]).atan2(p[w][0] - p[w - 1][0]);
        let a_out = (p[w + 1][1] - p[w][1]).atan2(p[w + 1][0] - p[w][0]);
        wrap_deg(-(a_out - a_in).to_degrees())
    }

    /// Metres along the route to the next waypoint that is not straight on, or the leg's end.
    fn straight_on_m(&self, pr: &Progress) -> f64 {
        let n = self.waypoints().len();
        let mut d = pr.to_next_m;
        let mut w = pr.segment + 1;
        while w + 1 < n && Turn::of(self.bend_right_deg(w), &self.profile) == Turn::Straight {
            d += dist(self.waypoints()[w], self.waypoints()[w + 1]);
            w += 1;
        }
        d
    }

    /// "Turn right now." within `turn_now_m` of the turn, else "In 6 metres, turn right."
    /// (with the turn after it, when [`Guide::turn_after`] says so: "In 6 metres, turn
    /// right, then turn left.", and that turn's waypoint).
    fn turn_words(&self, to_turn_m: f64, w: usize) -> (InstructionKind, String, Option<usize>) {
        let right = self.bend_right_deg(w);
        let turn = Turn::of(right, &self.profile);
        let phrase = turn_phrase(turn, right, &self.profile);
        if to_turn_m <= self.profile.turn_now_m {
            let text = format!("{} now.", capitalised(&phrase));
            (InstructionKind::TurnNow { leg: self.leg, waypoint: w, turn }, text, None)
        } else {
            let (then, words) = self.turn_after(w).unzip();
            let text =
                format!("In {}, {phrase}{}.", distance_phrase(to_turn_m, &self.profile), words.unwrap_or_default());
            (InstructionKind::TurnAhead { leg: self.leg, waypoint: w, turn }, text, then)
        }
    }

    /// The next turn after waypoint `w` (straight-on waypoints passed over, none past
    /// the leg's end) and its words (", then turn left"), when its own announcement would
    /// be left out: a user told "now" `turn_now_m` before `w` is, once the spacing after
    /// it has passed at walking pace, within the announcement's floor (`turn_now_m` plus
    /// the spacing's walk) of it; that is, the two are at most twice the spacing's walk
    /// apart (6 m by default). Said with the announcement of `w`, it is heard in time;
    /// its own "now" says when. The words are few (no distance): the announcement must
    /// end before the "now" that follows it, as soon as the spacing allows, is due, and
    /// the "now"s stay short, so that nothing holds back the turn they ask for.
    fn turn_after(&self, w: usize) -> Option<(usize, String)> {
        let (p, wp) = (&self.profile, self.waypoints());
        let mut gap_m = 0.0;
        let mut v = w;
        loop {
            if v + 2 >= wp.len() {
                return None;
            }
            gap_m += dist(wp[v], wp[v + 1]);
            v += 1;
            if Turn::of(self.bend_right_deg(v), p) != Turn::Straight {
                break;
            }
        }
        if gap_m > 2.0 * p.spacing_walk_m() {
            return None;
        }
        let right = self.bend_right_deg(v);
        Some((v, format!(", then {}", turn_phrase(Turn::of(right, p), right, p))))
    }

    fn turn(&mut self, pr: &Progress, now_ms: u64) -> Option<Instruction> {
        let w = self.target;
        if w + 1 >= self.waypoints().len() || pr.segment + 1 != w {
            return None;
        }
        if Turn::of(self.bend_right_deg(w), &self.profile) == Turn::Straight {
            return None;
        }
        let p = &self.profile;
        let d = pr.to_next_m;
        let key_of = |kind: &str| format!("leg{}/turn{w}/{kind}", self.leg);
        if d <= p.turn_now_m {
            if self.said_now == Some((self.leg, w)) {
                return None;
            }
            let (kind, text, _) = self.turn_words(d, w);
            let i = self.issue(kind, text, &key_of("now"), now_ms, Pace::Spaced);
            if i.is_some() {
                self.said_now = Some((self.leg, w));
                self.announced = Some((self.leg, w));
            }
            return i;
        }
        // an announcement that "now" would follow within the spacing is left out, as is
        // one of a turn said with the announcement before it
        let floor_m = p.turn_now_m + p.spacing_walk_m();
        if d <= p.announce_turn_m && d > floor_m && !self.told(w) {
            let (kind, text, then) = self.turn_words(d, w);
            let i = self.issue(kind, text, &key_of("ahead"), now_ms, Pace::Spaced);
            if i.is_some() {
                self.announced = Some((self.leg, w));
                if let Some(then) = then {
                    self.then_said = Some((self.leg, then));
                }
            }
            return i;
        }
        None
    }

    /// Whether the turn at waypoint `w` of this leg has been announced, alone or with
    /// the turn before it.
    fn told(&self, w: usize) -> bool {
        [self.announced, self.then_said].contains(&Some((self.leg, w)))
    }

    /// "Then turn left.": the turn after a "now" whose announcement was left out
    /// ([`Guide::turn_after`]: its own announcement would be left out too, and nothing
    /// told it), in the step after that "now", so that it follows it in the voice. The
    /// "now" itself stays short: what is cut off or dropped of this loses nothing the
    /// user must act on now (its own "now" follows at the turn). Not kept to the
    /// spacing, nor does it count for it (the next "now" keeps its place), no notice tap
    /// (the voice is already speaking), and not what "repeat" says; only while the last
    /// instruction is that "now", said within a second, or not at all (a "now" not
    /// heard is said again first).
    fn then_after_now(&mut self, now_ms: u64) -> Option<Instruction> {
        let Some(InstructionKind::TurnNow { leg, waypoint: w, .. }) = self.last.as_ref().map(|i| &i.kind) else {
            return None;
        };
        let (leg, w) = (*leg, *w);
        let recent = self.last_spontaneous_ms.is_some_and(|t| now_ms <= t + THEN_WITHIN_MS);
        if leg != self.leg || self.said_now != Some((leg, w)) || !recent {
            return None;
        }
        let (v, _) = self.turn_after(w).filter(|&(v, _)| !self.told(v))?;
        let right = self.bend_right_deg(v);
        let turn = Turn::of(right, &self.profile);
        let text = format!("Then {}.", turn_phrase(turn, right, &self.profile));
        let kind = InstructionKind::TurnThen { leg, waypoint: v, turn };
        self.then_said = Some((leg, v));
        Some(Instruction::untapped(kind, text, format!("guidance/r{}/leg{leg}/turn{v}/then", self.generation), now_ms))
    }

    /// A direction relative to where the user faces, said while they turn, is wrong by
    /// the time it is heard: held while the heading turns faster than the profile's
    /// `still_max_deg_s`.
    fn still(&self) -> bool {
        self.headings.still(self.profile.still_max_deg_s)
    }

    /// Which areas of the map the user is in: an innermost area that was not among
    /// those of the last step was just entered (leaving a room for the corridor that
    /// holds it enters nothing). Where the user first is on a floor enters nothing.
    fn follow_areas(&mut self, pose: &UserPose) {
        let areas = self.semantic.areas_at(pose.floor, pose.x_m, pose.y_m);
        let names = || areas.iter().map(|a| a.name.as_str());
        // most steps stay where they were: nothing to keep anew
        if self.areas_here.as_ref().is_some_and(|(f, b)| *f == pose.floor && b.iter().map(String::as_str).eq(names())) {
            return;
        }
        let chain: Vec<String> = names().map(str::to_string).collect();
        match &self.areas_here {
            Some((floor, before)) if *floor == pose.floor => {
                if let Some(inner) = chain.first().filter(|a| !before.contains(a)) {
                    self.area_entered = Some((inner.clone(), [pose.x_m, pose.y_m]));
                } else if self.area_entered.as_ref().is_some_and(|(name, _)| !chain.contains(name)) {
                    self.area_entered = None;
                }
            }
            _ => self.area_entered = None,
        }
        self.areas_here = Some((pose.floor, chain));
    }

    /// "Entering the stair hall.": said 1-5 m past where the user entered a named area,
    /// once a trip per area, under the rules of a door in passing (spacing after others
    /// without counting for it, only where no turn, gateway or goal is near ahead).
    fn entering_area(&mut self, pose: &UserPose, pr: &Progress, now_ms: u64) -> Option<Instruction> {
        let p = self.profile;
        let (name, at) = self.area_entered.clone()?;
        let floor = pose.floor;
        let past_m = dist(at, [pose.x_m, pose.y_m]);
        if !p.passing_areas || past_m > ENTERED_UNTIL_M || self.areas_said.contains(&(floor, name.clone())) {
            self.area_entered = None;
            return None;
        }
        let clear_m = p.announce_turn_m + p.spacing_walk_m();
        if past_m < ENTERED_FROM_M || !self.spaced_for_passing(now_ms) || self.straight_on_m(pr) <= clear_m {
            return None;
        }
        let text = format!("Entering {}.", with_article(&name));
        let key = format!("guidance/r{}/area/{floor}/{name}", self.generation);
        let i = Instruction::untapped(InstructionKind::EnteringArea { name: name.clone() }, text, key, now_ms);
        self.areas_said.push((floor, name));
        self.area_entered = None;
        self.last_passing_ms = Some(now_ms);
        Some(i)
    }

    /// A door or an area may be said now: the spacing has passed since the route's
    /// last words and since the last door or area.
    fn spaced_for_passing(&self, now_ms: u64) -> bool {
        let spacing = self.profile.min_spacing_ms;
        [self.last_spontaneous_ms, self.last_passing_ms].iter().flatten().all(|&t| now_ms >= t.saturating_add(spacing))
    }

    /// "Passing door 214, on your left.": the first numbered door beside the segment
    /// being walked that the user, facing along it, comes level with, not said before on
    /// this trip, at least `passing_door_every_m` from where the last was said; only
    /// where the next turn, gateway or goal is further ahead than its announcement and
    /// the spacing after it, so that a door never holds back what the route asks for.
    /// It keeps the spacing after the route's words and after the last door or area,
    /// but does not count for the route's, is said without the notice tap (it asks
    /// nothing) and is not what "repeat" says.
    fn passing_door(&mut self, pose: &UserPose, pr: &Progress, now_ms: u64) -> Option<Instruction> {
        let p = self.profile;
        if !p.passing_doors || !self.spaced_for_passing(now_ms) {
            return None;
        }
        let clear_m = p.announce_turn_m + p.spacing_walk_m();
        let here = [pose.x_m, pose.y_m];
        if self.straight_on_m(pr) <= clear_m
            || self.last_door_at.is_some_and(|at| dist(at, here) < p.passing_door_every_m)
        {
            return None;
        }
        let (a, b) = (self.waypoints()[pr.segment], self.waypoints()[pr.segment + 1]);
        let len = dist(a, b);
        if len <= 0.0 {
            return None;
        }
        let way = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        // the side is the way's: said only to a user who faces along it (within 45°)
        if pose.heading_rad.cos() * way[0] + pose.heading_rad.sin() * way[1] < std::f64::consts::FRAC_1_SQRT_2 {
            return None;
        }
        let floor = self.route().floor;
        let (number, left) = self.semantic.doors.iter().filter(|d| d.floor == floor).find_map(|d| {
            let (dx, dy) = (d.x - here[0], d.y - here[1]);
            let along = dx * way[0] + dy * way[1];
            // positive: to the left of the way
            let left_m = way[0] * dy - way[1] * dx;
            // in a wall along the way, not one across it (a door at a corridor's end)
            let in_side_wall = (d.normal[0] * way[0] + d.normal[1] * way[1]).abs() < 0.5;
            let beside = (PASSING_MIN_M..=p.passing_door_m).contains(&left_m.abs());
            let level = (-PASSING_BEHIND_M..=PASSING_AHEAD_M).contains(&along);
            (level && beside && in_side_wall && !self.doors_said.contains(&d.number))
                .then(|| (d.number.clone(), left_m > 0.0))
        })?;
        let side = match (p.directions, left) {
            (DirectionStyle::Clock, true) => "at 9 o'clock",
            (DirectionStyle::Clock, false) => "at 3 o'clock",
            (DirectionStyle::Words, true) => "on your left",
            (DirectionStyle::Words, false) => "on your right",
        };
        let kind = InstructionKind::PassingDoor { number: number.clone() };
        let (text, key) =
            (format!("Passing door {number}, {side}."), format!("guidance/r{}/door/{number}", self.generation));
        let i = Instruction::untapped(kind, text, key, now_ms);
        self.doors_said.push(number);
        self.last_door_at = Some(here);
        self.last_passing_ms = Some(now_ms);
        Some(i)
    }

    fn start(&mut self, pose: &UserPose, pr: &Progress, now_ms: u64) -> Option<Instruction> {
        if !self.still() {
            return None;
        }
        let back = self.back_on_route && self.started_leg == Some(self.leg);
        let text = self.start_words(pose, pr, back);
        self.serial += 1;
        let key = match (back, self.detour) {
            (true, _) => format!("leg{}/back/{}", self.leg, self.serial),
            (false, true) => format!("leg{}/detour/{}", self.leg, self.serial),
            (false, false) => format!("leg{}/start", self.leg),
        };
        let i = self.issue(InstructionKind::Start { leg: self.leg }, text, &key, now_ms, Pace::Spaced);
        if i.is_some() {
            self.started_leg = Some(self.leg);
            self.back_on_route = false;
            self.detour = false;
        }
        i
    }

    /// "Route to room 4: 25 metres. Turn left, then go straight on." from `pose`
    /// ("Back on the route. ..." when `back`).
    fn start_words(&self, pose: &UserPose, pr: &Progress, back: bool) -> String {
        let total: f64 = pr.remaining_m + self.legs[self.leg + 1..].iter().map(|l| l.route.length_m).sum::<f64>();
        let total = distance_phrase(total, &self.profile);
        let head = match (self.leg, self.destination.as_str()) {
            _ if back => "Back on the route.".to_string(),
            (0, _) if self.detour => format!("Something stands in the way. A way round: {total}."),
            (0, "") => format!("Route: {total}."),
            (0, d) => format!("Route to {d}: {total}."),
            (_, "") => format!("Floor {}: {total} to go.", self.route().floor),
            (_, d) => format!("Floor {}: {total} to {d}.", self.route().floor),
        };
        let ahead = self.waypoints().get(self.target).copied().unwrap_or([pose.x_m, pose.y_m]);
        let right = relative_right_deg(pose, ahead);
        let turn = Turn::of(right, &self.profile);
        let how = match turn {
            Turn::Straight => "Go straight on.".to_string(),
            t => format!("{}, then go straight on.", capitalised(&turn_phrase(t, right, &self.profile))),
        };
        format!("{head} {how}")
    }

    /// "Go straight on for 8 metres." facing the waypoint ahead, else "Turn left, then
    /// go straight on for 8 metres.": the way to face from `pose`, and how far it goes.
    fn face_words(&self, pose: &UserPose, pr: &Progress) -> String {
        let ahead = self.straight_on_m(pr);
        let far = distance_phrase(ahead, &self.profile);
        let to = self.waypoints().get(self.target).copied().unwrap_or([pose.x_m, pose.y_m]);
        let right = relative_right_deg(pose, to);
        match Turn::of(right, &self.profile) {
            Turn::Straight => format!("Go straight on for {far}."),
            t => format!("{}, then go straight on for {far}.", capitalised(&turn_phrase(t, right, &self.profile))),
        }
    }

    fn deviation(&mut self, pose: &UserPose, now_ms: u64, graph: Option<&NavGraph>) -> Option<Instruction> {
        if self.deviation_said_ms.is_some_and(|t| now_ms < t.saturating_add(self.profile.deviation_repeat_ms)) {
            return None;
        }
        let rejoin = graph.and_then(|g| self.route().rejoin(g, pose.x_m, pose.y_m, self.profile.rejoin_radius_m));
        let Some(r) = rejoin else {
            return self.replan(pose, now_ms);
        };
        if !self.still() {
            return None;
        }
        let node = self.route().points[r.node];
        let right = relative_right_deg(pose, node);
        let behind = wrap_deg(right).abs() >= self.profile.normal_max_deg;
        let text = format!(
            "Off the route: {}the route is {} away, {}.",
            if behind { "turn back; " } else { "" },
            distance_phrase(r.distance_m, &self.profile),
            bearing_phrase(right, &self.profile)
        );
        self.serial += 1;
        let key = format!("off-route/{}", self.serial);
        let i = self.issue(InstructionKind::OffRoute { rejoin: r }, text, &key, now_ms, Pace::Spaced)?;
        self.deviation_said_ms = Some(now_ms);
        self.rejoin_at(r);
        Some(i)
    }

    /// Progress restarts from where the user rejoins: turns from there on are said again.
    fn rejoin_at(&mut self, r: Rejoin) {
        let n = self.waypoints().len();
        let mut t = r.next_waypoint.clamp(1, n.saturating_sub(1).max(1));
        if self.route().waypoint_nodes.get(t) == Some(&r.node) && t + 1 < n {
            t += 1;
        }
        self.target = t;
        let leg = self.leg;
        let forget = |m: &mut Option<(usize, usize)>| {
            if m.is_some_and(|(l, w)| l == leg && w >= t) {
                *m = None;
            }
        };
        forget(&mut self.announced);
        forget(&mut self.said_now);
        forget(&mut self.then_said);
    }

    fn replan(&mut self, pose: &UserPose, now_ms: u64) -> Option<Instruction> {
        if self.deviation_said_ms.is_some_and(|t| now_ms < t.saturating_add(self.profile.deviation_repeat_ms)) {
            return None;
        }
        let text = if pose.floor != self.route().floor {
            format!("You are on floor {}, which this route does not take: finding a new route.", pose.floor)
        } else {
            "Off the route: finding a new route.".to_string()
        };
        self.serial += 1;
        let key = format!("replan/{}", self.serial);
        let i = self.issue(InstructionKind::Replan, text, &key, now_ms, Pace::Spaced)?;
        self.deviation_said_ms = Some(now_ms);
        Some(i)
    }

    /// Issues a spontaneous instruction unless the spacing forbids it now.
    fn issue(
        &mut self,
        kind: InstructionKind,
        text: String,
        key: &str,
        now_ms: u64,
        pace: Pace,
    ) -> Option<Instruction> {
        if pace == Pace::Spaced
            && self.last_spontaneous_ms.is_some_and(|t| now_ms < t.saturating_add(self.profile.min_spacing_ms))
        {
            return None;
        }
        let dedup_key = if std::mem::take(&mut self.again) {
            self.serial += 1;
            format!("guidance/r{}/{key}/again/{}", self.generation, self.serial)
        } else {
            format!("guidance/r{}/{key}", self.generation)
        };
        let i = Instruction {
            ttl_ms: ttl_ms(&kind),
            kind,
            text,
            dedup_key,
            vibrate_first: self.profile.vibrate_before,
            issued_ms: now_ms,
        };
        self.last_spontaneous_ms = Some(now_ms);
        self.last = Some(i.clone());
        Some(i)
    }

    /// An answer the user asked for: never held back by the spacing, and it does not
    /// delay the next spontaneous instruction; no vibration (the user is listening).
    fn answer(&mut self, kind: InstructionKind, text: String, key: &str, now_ms: u64, remember: bool) -> Instruction {
        self.serial += 1;
        let i = Instruction::untapped(kind, text, format!("guidance/{key}/{}", self.serial), now_ms);
        if remember {
            self.last = Some(i.clone());
        }
        i
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Pace {
    /// waits for `min_spacing_ms` after the previous spontaneous instruction
    Spaced,
    /// said at once (arrival)
    Exempt,
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Distance from `p` to the segment `a`-`b` and the closest point on it.
fn closest_on_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> (f64, [f64; 2]) {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let q = [a[0] + t * dx, a[1] + t * dy];
    (dist(p, q), q)
}

/// Degrees to the right of the user's heading at which `target` lies.
fn relative_right_deg(pose: &UserPose, target: [f64; 2]) -> f64 {
    let bearing = (target[1] - pose.y_m).atan2(target[0] - pose.x_m);
    wrap_deg(-(bearing - pose.heading_rad).to_degrees())
}
