//! The navigator: what the compute agent does with the user's commands (`cmd/destination`,
//! `where-am-i`, `repeat`, `cancel`, `floor`), the pose localization gives, and the
//! building's plan. It plans with [`planning::BuildingPlanner`], guides with a [`Guide`],
//! replans when the guide asks, and says what it does: every utterance is a
//! [`SpeechIntent`] at `Message` priority (never over a warning, safety rule 3).
//!
//! A destination given while the position is not known is kept and planned as soon as
//! localization tracks: no route, and no "turn left", is ever given on a guess.

use map::{Building, Label, SemanticLayer};
use planning::{BuildingPlanner, BuildingRoute, FloorPoint, UserProfile};
use schemas::{Command, Destination, Destinations, MapPoint, Priority, RouteState, RouteStatus, SpeechIntent};

use crate::guide::{
    word_ask_due, Barometer, Guide, Headings, UserPose, CONFIRM_PLACE, POSITION_FOUND, SEARCH_FAILED, STOP_UNCERTAIN,
    UNCERTAIN,
};
use crate::instruction::NEWS_TTL_MS;
use crate::perceived::{Perceived, PASS_M};
use crate::profile::GuidanceProfile;
use crate::utterance::distance_phrase;
use crate::where_am_i::{not_known, where_am_i, LastKnown};

/// How long an answer or an announcement of the navigator's own may wait for the
/// speaker, ms (as the guide's answers).
const ANSWER_TTL_MS: u32 = 5000;
/// With no way to the destination, it is planned again, unasked, once the position is
/// this far from where the last plan failed, metres (a position found again elsewhere,
/// a user who walked on); "repeat" plans again at once.
pub const NO_WAY_RETRY_M: f64 = 2.0;
/// After a way round what the camera found, the next is looked for no sooner than this,
/// ms: the user hears one new route and turns by it before the next (a cell that comes
/// and goes in the view would otherwise change the route at every frame).
pub const DETOUR_EVERY_MS: u64 = 4000;
/// A way round is said only when it leaves the route by at least this much, metres:
/// nearer, it is a sidestep round a bin or a post, which the cane and the obstacle cue
/// give better than "turn right, then go straight on" (told as turns, small sidesteps
/// sent users on a pavement off their way: docs/guidance.md).
pub const DETOUR_MIN_M: f64 = 1.0;
/// A way round longer than this many times what was left of the route, plus
/// [`DETOUR_MAX_EXTRA_M`], is not taken: round the far end of a block, or along a road
/// past a kerb a floor plan draws as a line, it is no way round a bin (the route is kept
/// and the cane and the cue find their way past).
pub const DETOUR_MAX_FACTOR: f64 = 1.5;
/// See [`DETOUR_MAX_FACTOR`], metres.
pub const DETOUR_MAX_EXTRA_M: f64 = 10.0;

/// What a command changed beyond speech.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Response {
    /// what to say, in order
    pub speech: Vec<SpeechIntent>,
    /// the user said they are on this floor: localization should move there
    pub floor_confirmed: Option<i32>,
    /// the user said the number of the door they are at: a landmark for localization
    /// (the agent answers once the filter has taken it, or refused it)
    pub door: Option<String>,
    /// the user said they are near this named place of the map (its name as the map
    /// has it, and where): a landmark for localization; answered as a door is
    pub place: Option<(String, FloorPoint)>,
}

/// One trip: where to, and how far it got.
#[derive(Clone, Debug)]
struct Trip {
    label: String,
    goal: FloorPoint,
    /// planned once the position is known
    guide: Option<Guide>,
    /// why there is no guide: waiting for the position, or no way there
    held: RouteStatus,
    /// with no way there: the floor and place it was planned from last
    no_way_from: Option<(i32, [f64; 2])>,
}

/// Commands, pose and plan in; speech and route state out. Pure: time is an argument.
#[derive(Clone, Debug)]
pub struct Navigator {
    planner: BuildingPlanner,
    semantic: SemanticLayer,
    profile: GuidanceProfile,
    trip: Option<Trip>,
    /// the navigator's own last utterance, for "repeat" without a route
    last_said: Option<SpeechIntent>,
    /// why the last plan failed, for the caller's log (the user hears the short form)
    problem: Option<String>,
    serial: u64,
    /// the poses' headings over the last second, handed to a new route's guide (was
    /// the user turning when it was planned?)
    headings: Headings,
    /// what the camera found that the plan does not have, on the planner
    perceived: Perceived,
    /// when the last way round was looked for, ms
    detour_tried_ms: Option<u64>,
    /// ways round laid, looked for without one found (or only a far longer one), and
    /// found but no farther from the route than a sidestep
    detours: (u64, u64, u64),
    /// since when the pose has not been confident, ms (none while it is)
    unplaced_since_ms: Option<u64>,
    /// with no way found, the user was asked to stop and turn on the spot (a trip with a
    /// route leaves that to its guide)
    stop_said: bool,
    /// when the localization's news last said the position was lost, ms
    lost_news_ms: Option<u64>,
    /// when the navigator itself asked the user to turn on the spot (a trip waiting for
    /// its first position, or the request to stop), ms; none once the place is known
    turn_asked_ms: Option<u64>,
    /// and, turning for the profile's `search_for_ms` without the place found, asked to
    /// stop turning and tell a door number or ask someone
    search_failed_said: bool,
    /// what a barometer says of the user's height ([`Guide::set_barometer`])
    barometer: Barometer,
    /// where guidance last took the place, and the odometry's distance walked since
    /// ([`Navigator::walked`])
    last_known: Option<LastKnown>,
    /// localization found a place by a search that waits for the user's word
    /// ([`Guide::set_awaiting_word`])
    awaiting_word: bool,
    /// when the user was last asked for it, ms (a trip with a route leaves that to its
    /// guide)
    word_asked_ms: Option<u64>,
}

impl Navigator {
    /// A navigator over `building`, planning with the user's `route` preferences and
    /// speaking with their `guidance` profile.
    pub fn new(building: &Building, route: UserProfile, guidance: GuidanceProfile) -> Self {
        let mut semantic = SemanticLayer::default();
        for floor in building.floors() {
            let s = &floor.semantic;
            semantic.labels.extend(s.labels.iter().cloned());
            semantic.doors.extend(s.doors.iter().cloned());
            semantic.corners.extend(s.corners.iter().cloned());
            semantic.areas.extend(s.areas.iter().cloned());
        }
        semantic.gateways = building.gateways().to_vec();
        Self {
            planner: BuildingPlanner::new(building, route),
            semantic,
            profile: guidance,
            trip: None,
            last_said: None,
            problem: None,
            serial: 0,
            headings: Headings::default(),
            perceived: Perceived::default(),
            detour_tried_ms: None,
            detours: (0, 0, 0),
            unplaced_since_ms: None,
            stop_said: false,
            lost_news_ms: None,
            turn_asked_ms: None,
            search_failed_said: false,
            barometer: Barometer::Unread,
            last_known: None,
            awaiting_word: false,
            word_asked_ms: None,
        }
    }

    /// Every place the user can ask for, by floor then name.
    pub fn destinations(&self) -> Destinations {
        let mut destinations: Vec<Destination> = self
            .semantic
            .labels
            .iter()
            .map(|l| Destination {
                label: l.name.clone(),
                at: MapPoint { x_m: l.x as f32, y_m: l.y as f32, floor: l.floor },
            })
            .collect();
        destinations.sort_by(|a, b| a.at.floor.cmp(&b.at.floor).then_with(|| a.label.cmp(&b.label)));
        Destinations { destinations }
    }

    /// The place called `asked` (case and surrounding blanks ignored), or what to say
    /// instead: that there is no such place, and the closest names.
    pub fn find(&self, asked: &str) -> Result<&Label, String> {
        let asked = asked.trim();
        if let Some(l) = self.semantic.label(asked) {
            return Ok(l);
        }
        let words = |s: &str| s.to_lowercase().split_whitespace().map(str::to_string).collect::<Vec<_>>();
        let asked_words = words(asked);
        let mut scored: Vec<(usize, &str)> = self
            .semantic
            .labels
            .iter()
            .map(|l| {
                let shared = words(&l.name).iter().filter(|w| asked_words.contains(w)).count();
                let prefix = usize::from(!asked.is_empty() && l.name.to_lowercase().starts_with(&asked.to_lowercase()));
                (shared + prefix, l.name.as_str())
            })
            .collect();
        scored.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(b.1)));
        let close: Vec<&str> = scored.iter().take(3).map(|(_, n)| *n).collect();
        Err(if close.is_empty() {
            format!("I do not know a place called {asked}: this map has no named places.")
        } else {
            format!("I do not know a place called {asked}. Places with a similar name: {}.", close.join(", "))
        })
    }

    /// Why the last plan failed, once: the planner's own words, for the log.
    pub fn take_problem(&mut self) -> Option<String> {
        self.problem.take()
    }

    /// The floor plan's planner (the guide rejoins on its graphs; obstacles go there).
    pub fn planner(&self) -> &BuildingPlanner {
        &self.planner
    }

    /// Handles one user command at `pose` (`confident: false` when localization does
    /// not track). `Mute` is the feedback agent's: nothing here.
    pub fn command(&mut self, command: &Command, pose: &UserPose, now_ms: u64) -> Response {
        self.headings.push(now_ms, pose.heading_rad);
        let mut out = Response::default();
        match command {
            Command::Destination { label } => match self.find(label) {
                Err(text) => out.speech.push(self.say(text, "destination/unknown")),
                Ok(place) => {
                    let (name, goal) = (place.name.clone(), FloorPoint { floor: place.floor, x: place.x, y: place.y });
                    self.trip = Some(Trip {
                        label: name.clone(),
                        goal,
                        guide: None,
                        held: RouteStatus::WaitingForPosition,
                        no_way_from: None,
                    });
                    if pose.confident {
                        if let Some(s) = self.plan_trip(pose, now_ms) {
                            out.speech.push(s);
                        }
                    } else if self.awaiting_word {
                        // a place a search found waits for the user's word: turning
                        // will not confirm it
                        let text = format!("Going to {name}. {CONFIRM_PLACE}");
                        out.speech.push(self.say(text, "destination/waiting"));
                        self.word_asked_ms = Some(now_ms);
                    } else {
                        let text = format!("Going to {name}. Turn slowly on the spot until I find your position.");
                        out.speech.push(self.say(text, "destination/waiting"));
                        (self.turn_asked_ms, self.search_failed_said) = (Some(now_ms), false);
                    }
                }
            },
            Command::WhereAmI => {
                let last = self.last_known;
                let speech = match self.trip.as_mut().and_then(|t| t.guide.as_mut()) {
                    Some(guide) => guide.where_am_i(pose, last.as_ref(), now_ms).speech(),
                    None if pose.confident => {
                        let text = where_am_i(&self.semantic, pose.floor, pose.x_m, pose.y_m, self.profile.near_door_m);
                        self.say(text, "where-am-i")
                    }
                    None if self.awaiting_word => self.say(CONFIRM_PLACE.into(), "where-am-i"),
                    None => {
                        let text = not_known(last.as_ref(), &self.semantic, &self.profile, pose.floor);
                        self.say(text, "where-am-i")
                    }
                };
                out.speech.push(speech);
            }
            Command::Repeat => {
                if self.trip.as_ref().is_some_and(|t| t.held == RouteStatus::Unreachable) && pose.confident {
                    // no way from where the position was: from where it is now, perhaps
                    // (a position found in the wrong place, found again)
                    if let Some(s) = self.plan_trip(pose, now_ms) {
                        out.speech.push(s);
                    }
                    return out;
                }
                let guided = self.trip.as_mut().and_then(|t| t.guide.as_mut()).filter(|g| g.last().is_some());
                let speech = match (guided, self.last_said.clone()) {
                    (Some(guide), _) => guide.repeat(pose, now_ms).speech(),
                    (None, Some(last)) => {
                        self.serial += 1;
                        SpeechIntent { dedup_key: format!("{}/repeat/{}", last.dedup_key, self.serial), ..last }
                    }
                    (None, None) => self.say("Nothing to repeat yet.".into(), "repeat"),
                };
                out.speech.push(speech);
            }
            Command::Cancel => {
                let text = match self.trip.take() {
                    Some(t) => format!("Guidance to {} stopped.", t.label),
                    None => "No guidance to stop.".to_string(),
                };
                out.speech.push(self.say(text, "cancel"));
            }
            Command::Floor { floor } => {
                out.floor_confirmed = Some(*floor);
                if let Some(guide) = self.trip.as_mut().and_then(|t| t.guide.as_mut()) {
                    // the guide starts the floor's leg and says its first instruction next step
                    if guide.floor_confirmed(*floor) {
                        return out;
                    }
                }
                out.speech.push(self.say(format!("Floor {floor}."), "floor"));
            }
            Command::Door { number } => out.door = Some(number.trim().to_string()),
            Command::Place { label } => match self.find(label) {
                Ok(l) => out.place = Some((l.name.clone(), FloorPoint { floor: l.floor, x: l.x, y: l.y })),
                Err(text) => out.speech.push(self.say(text, "place/unknown")),
            },
            Command::Mute { .. } => {}
        }
        out
    }

    /// [`Navigator::step`] after the caller said the localization's `news` of this step:
    /// "Position found." is said once when the guide (or the navigator) would say it
    /// too, having asked the user to stop and turn until then.
    ///
    /// The guide's "Position uncertain: no turn instructions ..." is not said while news
    /// that the position is lost may still be waiting for the speaker
    /// ([`NEWS_TTL_MS`]): the news says as much, and asks for a door number, and at
    /// `Text` priority the newer would replace it unsaid. The request to stop and turn
    /// on the spot is said all the same.
    pub fn step_after_news(&mut self, pose: &UserPose, news: Option<&str>, now_ms: u64) -> Option<SpeechIntent> {
        let found = news == Some(POSITION_FOUND);
        if news.is_some_and(|n| n != POSITION_FOUND) {
            self.lost_news_ms = Some(now_ms);
        }
        let lost_told = self.lost_news_ms.is_some_and(|t| now_ms.saturating_sub(t) < u64::from(NEWS_TTL_MS));
        self.step(pose, now_ms).filter(|s| !(found && s.text == POSITION_FOUND || lost_told && s.text == UNCERTAIN))
    }

    /// The user walked `m` metres (the odometry's step): counted since the place was
    /// last taken, for "where am I" while it is not known ("Last known: near door 214,
    /// 12 metres walked since."). Not a finite, non-negative distance: not counted.
    pub fn walked(&mut self, m: f64) {
        if let Some(last) = self.last_known.as_mut().filter(|_| m.is_finite() && m >= 0.0) {
            last.walked_m += m;
        }
    }

    /// What a barometer says, now, of the user's height ([`Guide::set_barometer`]):
    /// at their floor's, the guide can tell a user who walked away from the foot of
    /// stairs where they are; one that stopped sending after the guide said it would
    /// notice the floor has the user told to say it.
    pub fn set_barometer(&mut self, barometer: Barometer) {
        self.barometer = barometer;
    }

    /// Whether localization has found a place by a search that waits for the user's word
    /// ([`Guide::set_awaiting_word`]), as the caller last said: while the pose is not
    /// confident, the user is asked for a door number or a named place, not to turn on
    /// the spot.
    pub fn set_awaiting_word(&mut self, awaiting: bool) {
        self.awaiting_word = awaiting;
    }

    /// One step with the pose of now: plans a held destination once the position is
    /// known, then lets the guide speak; replans when it asks.
    pub fn step(&mut self, pose: &UserPose, now_ms: u64) -> Option<SpeechIntent> {
        self.headings.push(now_ms, pose.heading_rad);
        let placed = pose.placed();
        if placed {
            self.last_known = Some(LastKnown { floor: pose.floor, x_m: pose.x_m, y_m: pose.y_m, walked_m: 0.0 });
            (self.unplaced_since_ms, self.turn_asked_ms, self.search_failed_said) = (None, None, false);
            self.word_asked_ms = None;
        } else {
            self.unplaced_since_ms.get_or_insert(now_ms);
        }
        let trip = self.trip.as_ref()?;
        if trip.guide.is_none() {
            if placed && std::mem::take(&mut self.stop_said) {
                // asked to stop and turn on the spot (below): found; "repeat" plans again
                return Some(self.say(POSITION_FOUND.into(), "found"));
            }
            if self.awaiting_word && !placed {
                // a place a search found waits for the user's word: asked again each
                // `search_for_ms` (the localization asked first), never to turn
                if !word_ask_due(&mut self.word_asked_ms, now_ms, self.profile.search_for_ms) {
                    return None;
                }
                self.word_asked_ms = Some(now_ms);
                return Some(self.say(CONFIRM_PLACE.into(), "uncertain/confirm"));
            }
            self.word_asked_ms = None;
            let searched = self.turn_asked_ms.is_some_and(|t| now_ms.saturating_sub(t) >= self.profile.search_for_ms);
            if searched && !placed && !self.search_failed_said {
                // asked to turn on the spot, and turning did not find the place
                self.search_failed_said = true;
                return Some(self.say(SEARCH_FAILED.into(), "uncertain/search-failed"));
            }
            let long =
                self.unplaced_since_ms.is_some_and(|t| now_ms.saturating_sub(t) >= self.profile.stop_when_uncertain_ms);
            if trip.held == RouteStatus::Unreachable && long && !self.stop_said {
                // no way from where the position was, and it is lost since: the user, told
                // to walk on while it is looked for, is not left to walk on untold (a
                // trip waiting for its first position already asked them to turn)
                (self.stop_said, self.turn_asked_ms) = (true, Some(now_ms));
                return Some(self.say(STOP_UNCERTAIN.into(), "uncertain/stop"));
            }
            if trip.held == RouteStatus::WaitingForPosition && pose.confident {
                return self.plan_trip(pose, now_ms);
            }
            if trip.held == RouteStatus::Unreachable && pose.confident && moved_from(trip.no_way_from, pose) {
                // no way from where it was planned: from here, perhaps (a position found
                // again elsewhere, a user who walked on); said only when there is one
                let goal = trip.goal;
                let route = self.plan(FloorPoint { floor: pose.floor, x: pose.x_m, y: pose.y_m }, goal);
                let (floor, at) = (pose.floor, [pose.x_m, pose.y_m]);
                if let Some(t) = self.trip.as_mut() {
                    t.no_way_from = Some((floor, at));
                }
                self.start_guide(route.ok()?);
                return self.step(pose, now_ms);
            }
            return None;
        }
        let graph = self.planner.floor(pose.floor).map(|p| p.graph());
        let guide = self.trip.as_mut()?.guide.as_mut()?;
        guide.set_barometer(self.barometer);
        guide.set_awaiting_word(self.awaiting_word);
        let instruction = guide.step(pose, now_ms, graph)?;
        if instruction.needs_replan() {
            let goal = self.trip.as_ref()?.goal;
            let from = FloorPoint { floor: pose.floor, x: pose.x_m, y: pose.y_m };
            match self.plan(from, goal) {
                Ok(route) => {
                    if let Some(g) = self.trip.as_mut().and_then(|t| t.guide.as_mut()) {
                        g.set_route(route);
                    }
                }
                Err(e) => return Some(self.unreachable(&e.to_string(), pose)),
            }
        }
        Some(instruction.speech())
    }

    /// What the perception holds now, map frame of `pose.floor` (`camera`: where the
    /// camera is): what the plan does not have becomes an obstacle of the planner
    /// ([`Perceived`]); when one stands on the route ahead, a way round it is planned
    /// from `pose`, and the guide starts it ("Something stands in the way. A way round:
    /// ..."), at most once in [`DETOUR_EVERY_MS`]. No way round: the route is kept (the
    /// obstacle cue and the cane are for what stands on it) and the reason is left for
    /// the log ([`Navigator::take_problem`]). Nothing is taken while the position is not
    /// confident: a point is only where the position puts it.
    pub fn perceived(&mut self, pose: &UserPose, camera: [f64; 2], points: &[[f64; 2]], now_ms: u64) {
        let finite = pose.x_m.is_finite() && pose.y_m.is_finite() && camera[0].is_finite() && camera[1].is_finite();
        if !(pose.confident && finite) {
            return;
        }
        self.perceived.update(&mut self.planner, pose.floor, camera, points, now_ms);
        if self.detour_tried_ms.is_some_and(|t| now_ms < t.saturating_add(DETOUR_EVERY_MS)) {
            return;
        }
        let Some(trip) = self.trip.as_ref() else {
            return;
        };
        let goal = trip.goal;
        let Some((route, next)) = trip.guide.as_ref().and_then(Guide::way_left) else {
            return;
        };
        let Some(planner) = self.planner.floor(pose.floor).filter(|_| route.floor == pose.floor) else {
            return;
        };
        if !planner.blocks_ahead(route, [pose.x_m, pose.y_m], next, PASS_M) {
            return;
        }
        self.detour_tried_ms = Some(now_ms);
        let from = [pose.x_m, pose.y_m];
        let old: Vec<[f64; 2]> =
            std::iter::once(from).chain(route.waypoints[next.min(route.waypoints.len())..].iter().copied()).collect();
        match self.planner.plan(FloorPoint { floor: pose.floor, x: pose.x_m, y: pose.y_m }, goal) {
            Ok(round) => {
                // a way round that never leaves the old route by more than a sidestep is
                // the cane's and the cue's (a bin beside the pavement), not a new route
                let apart = round.legs.first().map_or(0.0, |l| farthest_from(&l.route.points, &old));
                if apart < DETOUR_MIN_M {
                    self.detours.2 += 1;
                    return;
                }
                let left_m: f64 = old.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sum();
                if round.walk_length_m > DETOUR_MAX_FACTOR * left_m + DETOUR_MAX_EXTRA_M {
                    self.detours.1 += 1;
                    self.problem = Some(format!(
                        "something stands on the route ahead; the way round is {:.0} m against {left_m:.0} m left: the route is kept",
                        round.walk_length_m
                    ));
                    return;
                }
                self.detours.0 += 1;
                if let Some(g) = self.trip.as_mut().and_then(|t| t.guide.as_mut()) {
                    g.set_detour(round);
                }
            }
            Err(e) => {
                self.detours.1 += 1;
                self.problem = Some(format!(
                    "something stands on the route ahead and there is no way round it ({e}): the route is kept"
                ));
            }
        }
    }

    /// Ways round what the camera found: laid, looked for without one found, and found
    /// but within [`DETOUR_MIN_M`] of the route (left to the cane and the cue).
    pub fn detours(&self) -> (u64, u64, u64) {
        self.detours
    }

    /// What the camera found that blocks the planner's graph now, in cells, and the
    /// points refused (not finite, out of range).
    pub fn perceived_obstacles(&self) -> (usize, u64) {
        (self.perceived.obstacles(), self.perceived.refused())
    }

    /// The feedback agent never finished saying `text` (`feedback/applied`: dropped or
    /// cut off): the guide gives it again when it was its last instruction
    /// ([`Guide::not_heard`]). True when it will.
    pub fn not_heard(&mut self, text: &str) -> bool {
        let Some(trip) = self.trip.as_mut() else {
            return false;
        };
        if let Some(guide) = trip.guide.as_mut() {
            return guide.not_heard(text);
        }
        // the navigator's own request to stop, or the position found after it: again
        let last = self.last_said.as_ref().is_some_and(|s| s.text == text);
        match text {
            STOP_UNCERTAIN if last && self.stop_said => self.stop_said = false,
            POSITION_FOUND if last && !self.stop_said => self.stop_said = true,
            SEARCH_FAILED if last && self.search_failed_said => self.search_failed_said = false,
            _ => return false,
        }
        true
    }

    /// Where guidance stands, for `route/state`.
    pub fn state(&self, pose: &UserPose) -> RouteState {
        state_of(self.trip.as_ref(), pose)
    }

    /// A route from `from` to the place called `to`, not followed (`query/route`).
    pub fn preview(&mut self, from: &UserPose, to: &str) -> Result<RouteState, String> {
        if !from.confident {
            return Err("the position is not known yet".into());
        }
        let place = self.find(to)?.clone();
        let goal = FloorPoint { floor: place.floor, x: place.x, y: place.y };
        let route = self
            .plan(FloorPoint { floor: from.floor, x: from.x_m, y: from.y_m }, goal)
            .map_err(|e| format!("no way to {}: {e}", place.name))?;
        let instruction = summary(&route, &self.profile);
        let guide = Guide::building(route, &place.name, self.semantic.clone(), self.profile);
        let trip = Trip { label: place.name, goal, guide: Some(guide), held: RouteStatus::Guiding, no_way_from: None };
        Ok(RouteState { status: RouteStatus::Preview, instruction, ..state_of(Some(&trip), from) })
    }

    /// Plans the trip from `pose`; what to say when that fails (the guide says the
    /// route's first instruction itself, next step).
    fn plan_trip(&mut self, pose: &UserPose, now_ms: u64) -> Option<SpeechIntent> {
        let trip = self.trip.as_ref()?;
        let goal = trip.goal;
        match self.plan(FloorPoint { floor: pose.floor, x: pose.x_m, y: pose.y_m }, goal) {
            Ok(route) => {
                self.start_guide(route);
                self.step(pose, now_ms)
            }
            Err(e) => Some(self.unreachable(&e.to_string(), pose)),
        }
    }

    /// The trip follows `route` from now on, with a new guide (told how the heading
    /// turned over the last second).
    fn start_guide(&mut self, route: BuildingRoute) {
        let Some(t) = self.trip.as_mut() else {
            return;
        };
        let mut guide = Guide::building(route, &t.label, self.semantic.clone(), self.profile);
        guide.headings = self.headings.clone();
        (t.guide, t.held) = (Some(guide), RouteStatus::Guiding);
    }

    /// A route from `from` to `to`; when what the camera found leaves none, the plan's
    /// own (what was found is given back: a user walled in by it, or snapped past it,
    /// is better guided on the plan than left without a route).
    fn plan(&mut self, from: FloorPoint, to: FloorPoint) -> Result<BuildingRoute, planning::PlanError> {
        match self.planner.plan(from, to) {
            Err(_) if self.perceived.obstacles() > 0 => {
                self.perceived.clear(&mut self.planner);
                self.planner.plan(from, to)
            }
            result => result,
        }
    }

    fn unreachable(&mut self, why: &str, pose: &UserPose) -> SpeechIntent {
        let label = match self.trip.as_mut() {
            Some(t) => {
                t.guide = None;
                t.held = RouteStatus::Unreachable;
                t.no_way_from = Some((pose.floor, [pose.x_m, pose.y_m]));
                t.label.clone()
            }
            None => String::new(),
        };
        self.problem = Some(format!("no way to {label}: {why}"));
        self.say(format!("I cannot find a way to {label} from here."), "destination/unreachable")
    }

    fn say(&mut self, text: String, key: &str) -> SpeechIntent {
        self.serial += 1;
        let s = SpeechIntent {
            text,
            priority: Priority::Message,
            interrupt: false,
            ttl_ms: ANSWER_TTL_MS,
            dedup_key: format!("navigator/{key}/{}", self.serial),
            notice: false,
        };
        self.last_said = Some(s.clone());
        s
    }
}

/// True when `pose` is [`NO_WAY_RETRY_M`] or more from where no way was found (or on
/// another floor).
fn moved_from(no_way_from: Option<(i32, [f64; 2])>, pose: &UserPose) -> bool {
    no_way_from
        .is_none_or(|(floor, [x, y])| floor != pose.floor || (pose.x_m - x).hypot(pose.y_m - y) >= NO_WAY_RETRY_M)
}

/// The farthest any of `points` is from the polyline `line`, metres.
fn farthest_from(points: &[[f64; 2]], line: &[[f64; 2]]) -> f64 {
    let near = |p: [f64; 2]| match line {
        [] => f64::INFINITY,
        [only] => (p[0] - only[0]).hypot(p[1] - only[1]),
        _ => line
            .windows(2)
            .map(|w| planning::smoothing::segment_point_distance(w[0], w[1], p))
            .fold(f64::INFINITY, f64::min),
    };
    points.iter().map(|&p| near(p)).fold(0.0, f64::max)
}

/// "25 metres, by the elevator to floor 1": a route in a few words.
fn summary(route: &BuildingRoute, profile: &GuidanceProfile) -> String {
    let mut text = distance_phrase(route.walk_length_m, profile);
    for leg in &route.legs {
        if let planning::LegEnd::Gateway { name, to_floor, .. } = &leg.end {
            text.push_str(&format!(", by the {name} to floor {to_floor}"));
        }
    }
    text
}

/// Where guidance along `trip` stands at `pose`.
fn state_of(trip: Option<&Trip>, pose: &UserPose) -> RouteState {
    let idle = RouteState {
        destination: String::new(),
        next_waypoint: None,
        distance_left_m: 0.0,
        instruction: String::new(),
        floor: pose.floor,
        status: RouteStatus::Idle,
        route: Vec::new(),
    };
    let Some(trip) = trip else {
        return idle;
    };
    let mut state = RouteState { destination: trip.label.clone(), status: trip.held, ..idle };
    let Some(guide) = &trip.guide else {
        return state;
    };
    state.instruction = guide.last().map(|i| i.text.clone()).unwrap_or_default();
    if guide.arrived() {
        state.status = RouteStatus::Arrived;
        state.floor = trip.goal.floor;
        return state;
    }
    let Some(ahead) = guide.ahead(pose) else {
        return state;
    };
    let point = |&(floor, [x, y]): &(i32, [f64; 2])| MapPoint { x_m: x as f32, y_m: y as f32, floor };
    state.route = ahead.points.iter().map(point).collect();
    state.next_waypoint = state.route.first().copied();
    state.floor = state.next_waypoint.map_or(pose.floor, |p| p.floor);
    state.distance_left_m = ahead.distance_m as f32;
    state.status = if ahead.at_gateway { RouteStatus::WaitingForFloor } else { RouteStatus::Guiding };
    state
}
