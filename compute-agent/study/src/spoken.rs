//! `--guide spoken`: the user walks by the guidance agent's words.
//!
//! The device's side ([`SpokenDevice`]) is the compute agent's navigator
//! ([`guidance::Navigator`]) on the world's floor plan as `wearnav map` exports it,
//! told the destination by the user at the start and fed the place the device believes
//! (the particle filter's, or the truth with `--pose truth`); what it says goes through
//! the feedback step's speech queue as the feedback agent's would (priorities, TTLs,
//! cut-offs, a voice at the agent's default rate). The user ([`SpokenGuide`]) hears an
//! utterance when its last word is spoken, acts on it [`UNDERSTAND_S`] later, and knows
//! only its words ([`meaning`]): "turn left" turns by about 90 degrees from where the
//! user faces, "go straight on" holds the heading, "off the route: the route is 3 metres
//! away, to your left" turns towards it; "in 6 metres, turn right" (and "in 6 metres,
//! turn right, then turn left") waits for the "now".
//! Once told "you have arrived", the user finds the place by its sound (the goal's,
//! as in every other guide: Taylor's music, a door one can touch).

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

use guidance::{GuidanceProfile, Navigator, UserPose};
use map::Building;
use planning::UserProfile;
use schemas::{Command, RouteState, SpeechIntent};

use crate::virtual_user::{GoalSound, Guide};

/// From the last word of an utterance to the user acting on it, seconds (our choice:
/// a short instruction understood while walking; the simple reaction to a spoken
/// word is about a third of this).
pub const UNDERSTAND_S: f64 = 0.5;
/// "Turn slowly on the spot": this fast, radians a second (30 degrees a second, left).
pub const SEARCH_TURN_RAD_S: f64 = 0.5;
/// The voice's rate, words a minute (the feedback agent's default `rate_wpm`).
pub const SPEECH_WPM: u32 = 175;

/// What the user heard, and when they act on it (seconds into the walk).
#[derive(Debug, Clone, PartialEq)]
pub struct Heard {
    /// the user acts on it from here
    pub at_s: f64,
    /// the words
    pub text: String,
}

/// Between the walk and the user's guide: the utterances heard and not yet acted on
/// (the walk hears them from the feedback step), and what the user asked the device.
#[derive(Debug, Clone, Default)]
pub struct Talk {
    /// heard, in order
    pub heard: VecDeque<Heard>,
    /// asked, for the device (`cmd/*`)
    pub asked: Vec<Command>,
    /// the voice is speaking now (the user does not talk over it)
    pub speaking: bool,
}

/// The [`Talk`] shared by the walk and the user.
pub type Ear = Rc<RefCell<Talk>>;

/// A user who stands with no way to go asks "repeat" this long after the last words
/// heard, seconds, when the voice is silent (and again as long after each answer; our
/// choice).
pub const ASK_AFTER_S: f64 = 4.0;

/// What a sentence of the guide asks of the walker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Meaning {
    /// turn by this many degrees to the right (negative: left) from where the user
    /// faces, then walk on that way
    Turn(f64),
    /// the place is here: find it
    Arrived,
    /// turn slowly on the spot until told the position is found (the filter earns its
    /// tracking from motion)
    Search,
    /// "Position found.": a user turning on the spot stops and waits
    Wait,
    /// "I cannot find your position by turning. Please stop turning, and tell me the
    /// number of a door you are at, or ask someone nearby where you are and tell me the
    /// place.": the user stops turning and stands; neither a door sign within reach nor
    /// a passer-by is simulated, so they stand and wait for the device to speak, asking
    /// nothing
    NoPlace,
    /// nothing to do now (an announcement, the position's news, a replan)
    Nothing,
}

/// Degrees to the right the words of `turn_phrase` or `bearing_phrase` mean, as a
/// walker takes them: the middle of each category of the profile (`turn left`: 90,
/// `slightly`: 40, `sharply`: 145), a clock hour 30 degrees each.
fn words_right_deg(words: &str, p: &GuidanceProfile) -> Option<f64> {
    let mid = |a: f64, b: f64| (a + b) / 2.0;
    let sided = |deg: f64, w: &str| {
        if w.contains("left") {
            Some(-deg)
        } else if w.contains("right") {
            Some(deg)
        } else {
            None
        }
    };
    if let Some(i) = words.find(" o'clock") {
        let hour: f64 = words[..i].rsplit(' ').next()?.parse().ok()?;
        let deg = (hour % 12.0) * 30.0;
        return Some(if deg > 180.0 { deg - 360.0 } else { deg });
    }
    if words.contains("turn around") || words.trim() == "behind you" {
        return Some(180.0);
    }
    if words.contains("straight on") || words.trim() == "ahead" {
        return Some(0.0);
    }
    if words.contains("slightly") {
        return sided(mid(p.straight_max_deg, p.slight_max_deg), words);
    }
    if words.contains("sharply") || words.contains("behind you to the") {
        return sided(mid(p.normal_max_deg, p.sharp_max_deg), words);
    }
    sided(mid(p.slight_max_deg, p.normal_max_deg), words)
}

/// What the guide's sentence `text` asks of the user (the guide's wording in
/// `guidance::guide`, with the profile's categories for the angles).
pub fn meaning(text: &str, p: &GuidanceProfile) -> Meaning {
    let t = text.to_lowercase();
    if t.contains("you have arrived") {
        return Meaning::Arrived;
    }
    if t.contains("turn slowly on the spot") {
        return Meaning::Search;
    }
    if t.starts_with("position found") {
        return Meaning::Wait;
    }
    if t.contains("please stop turning") {
        return Meaning::NoPlace;
    }
    // "Off the route: turn back; the route is 3 metres away, behind you to the left."
    if let Some(rest) = t.strip_prefix("off the route:") {
        return match rest.split_once(" away, ") {
            Some((_, bearing)) => {
                words_right_deg(bearing.trim_end_matches('.'), p).map_or(Meaning::Nothing, Meaning::Turn)
            }
            None => Meaning::Nothing, // "finding a new route": the new route's start follows
        };
    }
    // "Turn right now." / "Route to X: 12 metres. Turn left, then go straight on." /
    // "Back on the route. Go straight on."; never "In 6 metres, turn right." (wait for
    // the "now"), nor an elevator, the position's news or an answer
    let last = t.rsplit(". ").next().unwrap_or(&t).trim();
    let now = last.ends_with(" now.") || last.ends_with("go straight on.");
    if !now || last.starts_with("in ") {
        return Meaning::Nothing;
    }
    let words = last.split(", then").next().unwrap_or(last);
    words_right_deg(words, p).map_or(Meaning::Nothing, Meaning::Turn)
}

/// The user of `--guide spoken`: heads where the words heard last sent them.
#[derive(Debug, Clone)]
pub struct SpokenGuide {
    ear: Ear,
    profile: GuidanceProfile,
    heading_rad: Option<f64>,
    searching: bool,
    arrived: bool,
    place: GoalSound,
    /// when the user last heard (or asked) something, seconds
    last_words_s: f64,
    /// told that turning did not find the place ([`Meaning::NoPlace`]), and nothing
    /// asked of them since
    no_place: bool,
}

impl SpokenGuide {
    /// A user who hears what `ear` collects and, told they arrived, finds `place`.
    pub fn new(ear: Ear, profile: GuidanceProfile, place: GoalSound) -> Self {
        Self {
            ear,
            profile,
            heading_rad: None,
            searching: false,
            arrived: false,
            place,
            last_words_s: 0.0,
            no_place: false,
        }
    }
}

impl Guide for SpokenGuide {
    fn heading_target_rad(&mut self, pose: &sim::UserPose, t_s: f64) -> Option<f64> {
        loop {
            let next = {
                let mut ear = self.ear.borrow_mut();
                if ear.heard.front().is_some_and(|h| h.at_s <= t_s) {
                    ear.heard.pop_front()
                } else {
                    None
                }
            };
            let Some(heard) = next else { break };
            self.last_words_s = heard.at_s;
            let said = meaning(&heard.text, &self.profile);
            match said {
                Meaning::Turn(right_deg) => {
                    self.heading_rad = Some(pose.yaw_rad - right_deg.to_radians());
                    self.searching = false;
                }
                Meaning::Arrived => self.arrived = true,
                Meaning::Search => (self.heading_rad, self.searching) = (None, true),
                // found while turning on the spot: stand and wait for the way (found
                // again while walking: walk on as before)
                Meaning::Wait if self.searching => (self.heading_rad, self.searching) = (None, false),
                Meaning::Wait => {}
                Meaning::NoPlace => (self.heading_rad, self.searching) = (None, false),
                Meaning::Nothing => {}
            }
            // told what to do without the place, the user asks nothing until the device
            // has something else to say that asks something of them
            self.no_place = match said {
                Meaning::NoPlace => true,
                Meaning::Nothing => self.no_place,
                _ => false,
            };
        }
        if self.arrived {
            return self.place.heading_target_rad(pose, t_s);
        }
        if self.searching {
            // turning on the spot ([`Guide::spin_rad_s`]), heading nowhere
            return None;
        }
        if self.heading_rad.is_none() && !self.no_place && t_s - self.last_words_s >= ASK_AFTER_S {
            // standing with no way to go, and nothing said for a while: "repeat" (not
            // after being told what to do without the place: it would say that again)
            let mut ear = self.ear.borrow_mut();
            if ear.heard.is_empty() && !ear.speaking {
                ear.asked.push(Command::Repeat);
                self.last_words_s = t_s;
            }
        }
        self.heading_rad
    }

    fn spin_rad_s(&self) -> Option<f64> {
        (self.searching && !self.arrived).then_some(SEARCH_TURN_RAD_S)
    }

    fn boxed_clone(&self) -> Box<dyn Guide + '_> {
        // a copy that hears what was heard so far, not what the walk hears later
        let ear = Rc::new(RefCell::new(self.ear.borrow().clone()));
        Box::new(Self { ear, ..self.clone() })
    }
}

/// The guidance profile of spoken walks: the default, without the notice tap before
/// each instruction (the hands hold the obstacle rumble; a tap there would be felt as
/// an obstacle).
pub fn profile() -> GuidanceProfile {
    GuidanceProfile { vibrate_before: false, ..GuidanceProfile::default() }
}

/// The device's side of a spoken walk: the navigator, told the destination once.
#[derive(Debug, Clone)]
pub struct SpokenDevice {
    navigator: Navigator,
    destination: String,
    asked: bool,
    serial: u64,
}

impl SpokenDevice {
    /// The navigator on `building`, to go to the place called `destination`.
    pub fn new(building: &Building, destination: &str) -> anyhow::Result<Self> {
        let route = UserProfile { prefer_elevator: true, ..UserProfile::default() };
        let navigator = Navigator::new(building, route, profile());
        let destination = navigator.find(destination).map_err(anyhow::Error::msg)?.name.clone();
        Ok(Self { navigator, destination, asked: false, serial: 0 })
    }

    /// One frame at the believed `pose`: what the device says now into `out` (the
    /// destination's answer on the first, the localization's `news`, the guide's
    /// instruction).
    pub fn step(&mut self, pose: &UserPose, news: Option<&str>, now_ms: u64, out: &mut Vec<SpeechIntent>) {
        if let Some(news) = news {
            self.serial += 1;
            out.push(guidance::instruction::localization_news(news, self.serial));
        }
        if !self.asked {
            self.asked = true;
            let asked = Command::Destination { label: self.destination.clone() };
            out.extend(self.navigator.command(&asked, pose, now_ms).speech);
        }
        out.extend(self.navigator.step_after_news(pose, news, now_ms));
    }

    /// Whether the device's filter tracks a place a search found that waits for the
    /// user's word (`Navigator::set_awaiting_word`).
    pub fn set_awaiting_word(&mut self, awaiting: bool) {
        self.navigator.set_awaiting_word(awaiting);
    }

    /// A command from the user (`cmd/*`) at the believed `pose`; the answer into `out`.
    pub fn command(&mut self, command: &Command, pose: &UserPose, now_ms: u64, out: &mut Vec<SpeechIntent>) {
        out.extend(self.navigator.command(command, pose, now_ms).speech);
    }

    /// The voice never finished `text` (dropped or cut off): the guide says it again
    /// when it was its last instruction (`guidance::Guide::not_heard`).
    pub fn not_heard(&mut self, text: &str) -> bool {
        self.navigator.not_heard(text)
    }

    /// What the perception holds now, map frame (`camera`: where the camera is), at the
    /// believed `pose`: ways round what stands on the route
    /// (`guidance::Navigator::perceived`).
    pub fn perceived(&mut self, pose: &UserPose, camera: [f64; 2], points: &[[f64; 2]], now_ms: u64) {
        self.navigator.perceived(pose, camera, points, now_ms);
    }

    /// Ways round what the camera found: laid, looked for without one found, and
    /// found but within a sidestep of the route.
    pub fn detours(&self) -> (u64, u64, u64) {
        self.navigator.detours()
    }

    /// Where guidance stands at `pose` (`route/state`).
    pub fn state(&self, pose: &UserPose) -> RouteState {
        self.navigator.state(pose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use guidance::utterance::{bearing_phrase, turn_phrase, wrap_deg};
    use guidance::{DirectionStyle, Turn};

    #[test]
    fn the_words_of_every_turn_and_bearing_mean_a_turn_within_the_category_they_name() {
        for directions in [DirectionStyle::Words, DirectionStyle::Clock] {
            let p = GuidanceProfile { directions, ..profile() };
            for right in (-179..=180).step_by(7).map(f64::from) {
                let turn = Turn::of(right, &p);
                let phrase = turn_phrase(turn, right, &p);
                // as the guide says them: a start, a "now", an off-route prompt
                let start = format!(
                    "Route to room 4: 12 metres. {}, then go straight on.",
                    guidance::utterance::capitalised(&phrase)
                );
                let start =
                    if turn == Turn::Straight { "Route to room 4: 12 metres. Go straight on.".into() } else { start };
                let now = format!("{} now.", guidance::utterance::capitalised(&phrase));
                let off = format!("Off the route: the route is 3 metres away, {}.", bearing_phrase(right, &p));
                for text in [start, now, off] {
                    let Meaning::Turn(got) = meaning(&text, &p) else { panic!("{text:?}: no turn") };
                    // the walker's angle names the same category (a clock hour: within 15 degrees)
                    let err = wrap_deg(got - right).abs();
                    if directions == DirectionStyle::Clock && turn != Turn::Straight && turn != Turn::Around {
                        assert!(err <= 15.0 + 1e-9, "{text:?}: {got} for {right}");
                    } else if turn == Turn::Around
                        || (text.starts_with("Off") && wrap_deg(right).abs() >= p.sharp_max_deg)
                    {
                        assert_eq!(got, 180.0, "{text:?}");
                    } else {
                        assert_eq!(Turn::of(got, &p), turn, "{text:?}: {got} for {right}");
                    }
                }
            }
        }
    }

    #[test]
    fn announcements_news_and_answers_ask_nothing_and_arrival_is_arrival() {
        let p = profile();
        for text in [
            "In 6 metres, turn right.",
            "In 6 metres, turn right, then turn left.",
            "Then turn left.",
            "Going to music. Finding your position first: I will tell you when I have it.",
            "In 12 metres, turn sharply left.",
            "Position uncertain: no turn instructions until I know where you are again.",
            "Position lost: walk on slowly while I look for it, or tell me the number of a door you are at.",
            "Off the route: finding a new route.",
            "Elevator ahead; take it to floor 2; tell me when you are there.",
            "You are at the elevator. Take it to floor 1, then tell me when you are there.",
            "Elevator ahead; take it to floor 2; I will notice the floor when you get there.",
            "You are at the stairs. Take them to floor 1. I will notice the floor when you get there; you can also tell me.",
            localization::SEARCHED_NEWS,
            "I am still not sure where you are: tell me the number of a door you are at, or the name of a place you are near.",
            "Going to music. I am still not sure where you are: tell me the number of a door you are at, or the name of a place you are near.",
            "Passing door 214, on your left.",
            "Passing door 3, at 3 o'clock.",
        ] {
            assert_eq!(meaning(text, &p), Meaning::Nothing, "{text:?}");
        }
        assert_eq!(meaning("You have arrived at music.", &p), Meaning::Arrived);
        let search = "Going to music. Turn slowly on the spot until I find your position.";
        assert_eq!(meaning(search, &p), Meaning::Search);
        let stop = "Position still uncertain: please stop, and turn slowly on the spot until I find your position.";
        assert_eq!(meaning(stop, &p), Meaning::Search);
        assert_eq!(meaning("Position found.", &p), Meaning::Wait);
        assert_eq!(meaning("Back on the route. Turn left, then go straight on.", &p), Meaning::Turn(-90.0));
        assert_eq!(
            meaning("Off the route: turn back; the route is 2 metres away, behind you.", &p),
            Meaning::Turn(180.0)
        );
    }

    #[test]
    fn told_to_turn_on_the_spot_the_user_turns_slowly_until_the_position_is_found() {
        let ear: Ear = Rc::default();
        let mut guide = SpokenGuide::new(ear.clone(), profile(), GoalSound { x_m: 10.0, y_m: 0.0 });
        let at = sim::UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 };
        let said = "Going to music. Turn slowly on the spot until I find your position.";
        ear.borrow_mut().heard.push_back(Heard { at_s: 1.0, text: said.into() });
        ear.borrow_mut().heard.push_back(Heard { at_s: 5.0, text: "Position found.".into() });
        assert_eq!(guide.heading_target_rad(&at, 1.0), None);
        assert_eq!(guide.spin_rad_s(), Some(SEARCH_TURN_RAD_S), "30 degrees a second, heading nowhere");
        assert_eq!(guide.heading_target_rad(&at, 5.0), None);
        assert_eq!(guide.spin_rad_s(), None, "found: the user stands and waits for the way");
    }

    #[test]
    fn told_that_turning_did_not_find_the_position_the_user_stops_turning_and_stands() {
        let ear: Ear = Rc::default();
        let mut guide = SpokenGuide::new(ear.clone(), profile(), GoalSound { x_m: 10.0, y_m: 0.0 });
        let at = sim::UserPose { x_m: 0.0, y_m: 0.0, yaw_rad: 0.0, floor: 0 };
        let failed = "I cannot find your position by turning. Please stop turning, and tell me the number of a door you are at, or ask someone nearby where you are and tell me the place.";
        assert_eq!(meaning(failed, &profile()), Meaning::NoPlace);
        let said = [
            (1.0, "Turn left now."),
            (3.0, "Position still uncertain: please stop, and turn slowly on the spot until I find your position."),
            (30.0, failed),
        ];
        for (at_s, text) in said {
            ear.borrow_mut().heard.push_back(Heard { at_s, text: text.into() });
        }
        assert!(guide.heading_target_rad(&at, 1.0).is_some());
        assert_eq!(guide.heading_target_rad(&at, 3.0), None);
        assert_eq!(guide.spin_rad_s(), Some(SEARCH_TURN_RAD_S));
        assert_eq!(guide.heading_target_rad(&at, 30.0), None, "stands");
        assert_eq!(guide.spin_rad_s(), None, "no longer turning");
        // and asks nothing: "repeat" would say the same again
        assert_eq!(guide.heading_target_rad(&at, 30.0 + 3.0 * ASK_AFTER_S), None);
        assert!(ear.borrow().asked.is_empty(), "{:?}", ear.borrow().asked);
        // the position found: standing with no way yet, the user asks again
        ear.borrow_mut().heard.push_back(Heard { at_s: 50.0, text: "Position found.".into() });
        assert_eq!(guide.heading_target_rad(&at, 50.0), None);
        assert_eq!(guide.heading_target_rad(&at, 50.0 + ASK_AFTER_S), None);
        assert_eq!(ear.borrow().asked, [Command::Repeat]);
    }

    #[test]
    fn the_user_turns_from_where_they_face_when_the_words_are_understood_and_holds_that_heading() {
        let ear: Ear = Rc::default();
        let mut guide = SpokenGuide::new(ear.clone(), profile(), GoalSound { x_m: 10.0, y_m: 0.0 });
        let at = |yaw_rad: f64| sim::UserPose { x_m: 0.0, y_m: 0.0, yaw_rad, floor: 0 };
        assert_eq!(guide.heading_target_rad(&at(0.3), 0.0), None, "nothing heard: nowhere to go");
        assert_eq!(guide.spin_rad_s(), None);
        assert_eq!(guide.heading_target_rad(&at(0.3), 1.0), None);
        assert!(ear.borrow().asked.is_empty(), "not asked before {ASK_AFTER_S} s");
        ear.borrow_mut()
            .heard
            .push_back(Heard { at_s: 2.0, text: "Route to music: 10 metres. Turn left, then go straight on.".into() });
        assert_eq!(guide.heading_target_rad(&at(0.3), 1.9), None, "not understood yet");
        // (nothing heard for 4 s would ask "repeat"; the words are coming)
        assert!(ear.borrow().asked.is_empty());
        let h = guide.heading_target_rad(&at(0.3), 2.0).unwrap();
        assert!((h - (0.3 + std::f64::consts::FRAC_PI_2)).abs() < 1e-9, "{h}");
        // facing elsewhere later (turned away from an obstacle): the heading told stays
        assert_eq!(guide.heading_target_rad(&at(-1.0), 5.0), Some(h));
        ear.borrow_mut().heard.push_back(Heard { at_s: 6.0, text: "You have arrived at music.".into() });
        let to_place =
            guide.heading_target_rad(&sim::UserPose { x_m: 10.0, y_m: -1.0, yaw_rad: 0.0, floor: 0 }, 6.0).unwrap();
        assert!((to_place - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "then to the place's sound: {to_place}");
    }

    /// The speech queue the user hears through, with the guide's and the localization's
    /// own intents: a turn "now" is not left waiting behind talk of the place.
    #[test]
    fn a_turn_now_cuts_off_what_only_tells_where_things_stand_and_not_the_request_to_stop() {
        use feedback_agent::speech_queue::{QueueConfig, SpeechAction, SpeechQueue};
        use guidance::instruction::{localization_news, ttl_ms, Instruction, InstructionKind};
        const MS: u64 = 1_000_000;
        let say = |kind: InstructionKind, text: &str| {
            Instruction {
                ttl_ms: ttl_ms(&kind),
                kind,
                text: text.into(),
                dedup_key: text.into(),
                vibrate_first: false,
                issued_ms: 0,
            }
            .speech()
        };
        let now = say(
            InstructionKind::TurnNow { leg: 0, waypoint: 1, turn: Turn::Normal(guidance::utterance::Side::Left) },
            "Turn left now.",
        );
        let uncertain = "Position uncertain: no turn instructions until I know where you are again.";
        let lost = "Position lost: walk on slowly while I look for it, or tell me the number of a door you are at.";
        let stop = "Position still uncertain: please stop, and turn slowly on the spot until I find your position.";
        for (first, cut) in [
            (say(InstructionKind::PositionUncertain, uncertain), true),
            (localization_news(lost, 1), true),
            (say(InstructionKind::PassingDoor { number: "214".into() }, "Passing door 214, on your left."), true),
            (say(InstructionKind::StopAndTurn, stop), false),
            (localization_news("Position found.", 2), false),
        ] {
            let mut queue = SpeechQueue::new(QueueConfig::default());
            let mut out = Vec::new();
            queue.offer(&first, 0, 0, &mut out).unwrap();
            assert!(matches!(&out[..], [SpeechAction::Start(u)] if u.text == first.text), "{out:?}");
            // a second into it, about 3 s of it left: the turn is due at the corner
            out.clear();
            queue.offer(&now, 1000 * MS, 1000 * MS, &mut out).unwrap();
            if cut {
                assert!(
                    matches!(&out[..], [SpeechAction::Cut(c), SpeechAction::Start(s)]
                        if c.text == first.text && s.text == now.text),
                    "{:?}: {out:?}",
                    first.text
                );
            } else {
                // waits, and is dropped when its 1.5 s pass before the request ends
                assert!(out.is_empty(), "{:?}: {out:?}", first.text);
                queue.expire(2600 * MS, &mut out);
                assert!(
                    matches!(&out[..], [SpeechAction::Drop { utterance, reason: "stale" }] if utterance.text == now.text),
                    "{:?}: {out:?}",
                    first.text
                );
            }
        }
    }
}
