//! One thing the guide says, and how it goes to the feedback agent: a [`SpeechIntent`]
//! at [`Priority::Message`], or [`Priority::Text`] for what only tells where things
//! stand ([`priority`]); never `Important` (obstacle warnings pre-empt guidance;
//! guidance never talks over a warning, ARCHITECTURE.md safety rule 3).

use planning::Rejoin;
use schemas::{Priority, SpeechIntent};

use crate::guide::POSITION_FOUND;
use crate::utterance::Turn;

/// What an instruction is about.
#[derive(Clone, Debug, PartialEq)]
pub enum InstructionKind {
    /// the route begins (or a new floor's leg begins): length and first heading
    Start {
        /// leg index
        leg: usize,
    },
    /// a turn ahead, announced at the profile's distance
    TurnAhead {
        /// leg index
        leg: usize,
        /// waypoint index of the turn on that leg
        waypoint: usize,
        /// its category
        turn: Turn,
    },
    /// the turn is here
    TurnNow {
        /// leg index
        leg: usize,
        /// waypoint index of the turn on that leg
        waypoint: usize,
        /// its category
        turn: Turn,
    },
    /// the turn after a "now" whose announcement was left out, said right after it
    /// ("Then turn left."): else it is heard only as its own "now"
    TurnThen {
        /// leg index
        leg: usize,
        /// waypoint index of the turn after, on that leg
        waypoint: usize,
        /// its category
        turn: Turn,
    },
    /// an elevator, stairs or ramp ahead, to be taken to another floor
    GatewayAhead {
        /// leg index
        leg: usize,
    },
    /// at the gateway: take it, then confirm the floor
    AtGateway {
        /// leg index
        leg: usize,
    },
    /// told they are at the elevator, the user walked away from it: where it is
    AwayFromGateway {
        /// leg index
        leg: usize,
    },
    /// told at the gateway that the floor reached would be noticed, the barometer
    /// stopped sending: the user is to say the floor
    FloorNotNoticed {
        /// leg index
        leg: usize,
    },
    /// within the arrival radius of the goal; guidance ends
    Arrived,
    /// off the route, and the route is near: where to rejoin it
    OffRoute {
        /// where the route is joined again
        rejoin: Rejoin,
    },
    /// off the route with no route near (or on a floor the route does not use): the
    /// caller should replan from the user's position and call [`crate::Guide::set_route`]
    Replan,
    /// localization is not confident: no turn instructions until it is
    PositionUncertain,
    /// still not confident after the profile's `stop_when_uncertain_ms`: the user is
    /// asked to stop and turn slowly on the spot
    StopAndTurn,
    /// turned on the spot for the profile's `search_for_ms` and still not confident:
    /// the user is asked to stop turning and to tell a door number or ask someone
    SearchFailed,
    /// localization found a place by a search that only the user's word confirms:
    /// asked for a door number or a named place (again each `search_for_ms`)
    ConfirmPlace,
    /// the position is known again after the user was asked to stop and turn on the
    /// spot: they stop turning, and the way to face follows
    PositionFound,
    /// the user comes level with a numbered door beside the route: a landmark to
    /// check, asking nothing
    PassingDoor {
        /// the number on its sign
        number: String,
    },
    /// the user has just entered a named area of the map on the way: where they are,
    /// asking nothing
    EnteringArea {
        /// the area's name
        name: String,
    },
    /// the answer to "where am I"
    WhereAmI,
    /// "go straight on for 8 metres": the answer to "repeat" once a repeated turn has
    /// been passed
    Continue,
    /// the user asked for a repeat and there was nothing to repeat
    NothingToRepeat,
}

/// One utterance from the guide.
#[derive(Clone, Debug, PartialEq)]
pub struct Instruction {
    /// what it is about
    pub kind: InstructionKind,
    /// the words
    pub text: String,
    /// utterances with the same key are not said twice within the feedback agent's
    /// dedup window; a repeat gets a key of its own
    pub dedup_key: String,
    /// drop it if it cannot start within this long of `issued_ms`
    pub ttl_ms: u32,
    /// ask for a short vibration before it (the profile's device has one; only for
    /// instructions the user did not ask for). The feedback agent renders it as a
    /// pattern of its own, never as an obstacle rumble.
    pub vibrate_first: bool,
    /// when the guide issued it, the caller's clock, ms
    pub issued_ms: u64,
}

impl Instruction {
    /// One without the notice tap (the user is already listening, or it asks nothing),
    /// waiting for the speaker at most its kind's [`ttl_ms`].
    pub(crate) fn untapped(kind: InstructionKind, text: String, dedup_key: String, issued_ms: u64) -> Self {
        Self { ttl_ms: ttl_ms(&kind), kind, text, dedup_key, vibrate_first: false, issued_ms }
    }

    /// The speech intent for the feedback agent: the kind's [`priority`], no
    /// interrupt, a notice tap first when the profile asks for one
    /// ([`Instruction::vibrate_first`]).
    pub fn speech(&self) -> SpeechIntent {
        SpeechIntent {
            text: self.text.clone(),
            priority: priority(&self.kind),
            interrupt: false,
            ttl_ms: self.ttl_ms,
            dedup_key: self.dedup_key.clone(),
            notice: self.vibrate_first,
        }
    }

    /// True when the caller should plan a new route from the user's position.
    pub fn needs_replan(&self) -> bool {
        self.kind == InstructionKind::Replan
    }
}

/// The speech priority of an instruction: `Text` for what asks nothing of the user
/// now (a door in passing, an area entered, "position uncertain", the "then" after a
/// "now", whose own "now" follows), so a turn, a prompt or an answer (`Message`) cuts
/// it off and goes first, and a newer one replaces one still waiting; `Message` for
/// everything else, the request to stop and turn on the spot (and to stop turning when
/// that did not find the place) included. Measured in docs/guidance.md ("What only tells where
/// things stand gives way"): the turns "now" the speech queue had dropped behind it.
pub fn priority(kind: &InstructionKind) -> Priority {
    match kind {
        InstructionKind::PassingDoor { .. }
        | InstructionKind::EnteringArea { .. }
        | InstructionKind::PositionUncertain
        | InstructionKind::TurnThen { .. } => Priority::Text,
        _ => Priority::Message,
    }
}

/// How long the localization's news may wait for the speaker, ms.
pub const NEWS_TTL_MS: u32 = 5000;

/// The localization's news (`localization::Tracker::news`) as the user hears it:
/// "Position found." at `Message` priority (a user turning on the spot waits for it),
/// "Position lost: ..." at `Text`, as "position uncertain" ([`priority`]); said within
/// 5 s or not at all, each with a dedup key of its own (`serial`).
pub fn localization_news(news: &str, serial: u64) -> SpeechIntent {
    SpeechIntent {
        text: news.to_string(),
        priority: if news == POSITION_FOUND { Priority::Message } else { Priority::Text },
        interrupt: false,
        ttl_ms: NEWS_TTL_MS,
        dedup_key: format!("localization/{serial}"),
        notice: false,
    }
}

/// How long each kind may wait for the speaker, ms (our choice: a "now" said later
/// than 1.5 s is said past the corner at walking pace, a door past the door; an area
/// entered is said 1-5 m into it, 2 s more is still near its edge; the "then" after a
/// "now" must end (1 s of words) before the next "now" can be due, the spacing after
/// the first; an announcement is good for about half its 6 m; answers and arrival for
/// 5 s).
pub fn ttl_ms(kind: &InstructionKind) -> u32 {
    match kind {
        InstructionKind::TurnNow { .. } | InstructionKind::PassingDoor { .. } => 1500,
        InstructionKind::TurnThen { .. } | InstructionKind::EnteringArea { .. } => 2000,
        InstructionKind::TurnAhead { .. } | InstructionKind::OffRoute { .. } | InstructionKind::Continue => 3000,
        _ => 5000,
    }
}
