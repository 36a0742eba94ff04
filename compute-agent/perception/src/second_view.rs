//! A second depth device, worn at the chest, joined to the cane camera's cue.
//!
//! The cane camera is pitched down from under the handle: it never sees above its own
//! height, so a lamp, a sign or a cabinet at head height stays out of its view however
//! near the user comes. A camera worn at the chest (about 1.3 m up, looking ahead) sees
//! them. Each device's frames go through their own [`crate::ComputeStep`] (their own
//! ground, memory and costs); the chest's last state is held here and joined to every
//! cane frame: a side either device warns of is warned (one left and one right: both),
//! and the nearer of the obstacles that warn sets the pulse. The cane camera stays the
//! one the system cannot do without: a chest state older than
//! [`SecondView::max_age_ns`], or one from a chest device that cannot see (its ground
//! degraded, its frames refused), is not joined, and [`Joined::Stale`] says so, so the
//! owner can tell the user the head-high view is gone.
//!
//! The predictive cue ([`crate::predictive`]) takes the chest's obstacle points too
//! (what overhangs from 1 m up, in view and remembered), put in the body's frame: they
//! join the cane camera's in its look-ahead as points only the body can touch
//! ([`SecondView::fresh_points`]). The chest's state is joined to the cue's all the
//! same: the look-ahead predicts where the user walks, and a user led elsewhere (by a
//! companion, by a sound) walks under a sign it took them to pass; a head-high touch
//! is an injury. Measured in docs/beyond-the-course.md ("The chest camera's
//! obstacles in the look-ahead").

use schemas::{GroundState, Hazard, Rumble};

use crate::Perception;

/// How old the chest's state may be when a cane frame is joined to it, ns: three frames
/// at 30 Hz and the link's jitter.
pub const DEFAULT_MAX_AGE_NS: u64 = 300_000_000;

/// What one chest frame said.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewState {
    /// Capture stamp of the chest frame, ns.
    pub capture_ns: u64,
    /// Its rumble state.
    pub rumble: Rumble,
    /// Its nearest obstacle, metres (`INFINITY`: none).
    pub nearest_m: f32,
    /// Bearing of that obstacle, degrees, positive left.
    pub nearest_bearing_deg: f32,
    /// The chest device saw nothing it could trust (ground degraded, or its frames
    /// refused): its state is not joined.
    pub blind: bool,
}

impl ViewState {
    /// The state a chest frame's hazard gives, captured at `capture_ns`.
    pub fn of(hazard: &Hazard, capture_ns: u64) -> Self {
        Self {
            capture_ns,
            rumble: hazard.rumble,
            nearest_m: hazard.nearest_m,
            nearest_bearing_deg: hazard.nearest_bearing_deg,
            blind: hazard.ground == GroundState::Degraded,
        }
    }
}

/// Whether a cane frame was joined to the chest's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Joined {
    /// The chest's state was fresh and seeing: the cue is both devices'.
    Joined,
    /// No fresh, seeing chest state: the cue is the cane camera's alone.
    Stale,
}

/// How far ahead of the body's centre a chest camera is worn, metres (on the sternum,
/// 12 cm in front of the body's axis): its points' offset into the body's frame.
pub const CHEST_AHEAD_OF_BODY_M: f32 = 0.12;

/// The chest device's last state and points, and the counts of frames joined and not.
#[derive(Debug, Clone, PartialEq)]
pub struct SecondView {
    max_age_ns: u64,
    ahead_of_body_m: f32,
    last: Option<ViewState>,
    /// The last state's obstacle points, body frame (x forward, y left, metres).
    points: Vec<[f32; 2]>,
    joined: u64,
    stale: u64,
}

impl Default for SecondView {
    fn default() -> Self {
        Self::new(DEFAULT_MAX_AGE_NS)
    }
}

impl SecondView {
    /// Nothing heard yet; states older than `max_age_ns` are not joined; the device
    /// worn [`CHEST_AHEAD_OF_BODY_M`] ahead of the body's centre.
    pub fn new(max_age_ns: u64) -> Self {
        Self { max_age_ns, ahead_of_body_m: CHEST_AHEAD_OF_BODY_M, last: None, points: Vec::new(), joined: 0, stale: 0 }
    }

    /// The same, for a device worn `metres` ahead of the body's centre.
    pub fn ahead_of_body(mut self, metres: f32) -> Self {
        self.ahead_of_body_m = metres;
        self
    }

    /// How old a chest state may be when joined, ns.
    pub fn max_age_ns(&self) -> u64 {
        self.max_age_ns
    }

    /// A chest frame's state and the obstacle points its step held, the device's own
    /// user frame (x forward from its place on the floor, y left, metres:
    /// [`crate::ComputeStep::obstacle_points`]; none for a refused frame). An older
    /// frame than the last heard is ignored: frames may arrive out of order.
    pub fn heard(&mut self, state: ViewState, points: &[[f32; 2]]) {
        if self.last.is_none_or(|l| state.capture_ns >= l.capture_ns) {
            self.last = Some(state);
            self.points.clear();
            let ahead = self.ahead_of_body_m;
            self.points.extend(points.iter().map(|p| [p[0] + ahead, p[1]]));
        }
    }

    /// Whether the chest's last state is recent enough for a cane frame captured at
    /// `capture_ns` but its camera cannot see (its ground degraded): not silent, blind.
    pub fn blind(&self, capture_ns: u64) -> bool {
        self.last.is_some_and(|l| l.blind && capture_ns.saturating_sub(l.capture_ns) <= self.max_age_ns)
    }

    /// The chest's state, when fresh for a cane frame captured at `capture_ns` and seeing.
    pub fn fresh(&self, capture_ns: u64) -> Option<ViewState> {
        self.last.filter(|l| !l.blind && capture_ns.saturating_sub(l.capture_ns) <= self.max_age_ns)
    }

    /// The chest's obstacle points in the body's frame, when its state is fresh for a
    /// cane frame captured at `capture_ns` and seeing; none otherwise.
    pub fn fresh_points(&self, capture_ns: u64) -> &[[f32; 2]] {
        match self.fresh(capture_ns) {
            Some(_) => &self.points,
            None => &[],
        }
    }

    /// Joins the chest's state to a cane frame's perception: its rumble becomes the
    /// union of both, and the nearer obstacle of those that warn sets `nearest_m` and
    /// its bearing (the pulse's rate).
    pub fn join(&mut self, capture_ns: u64, p: &mut Perception) -> Joined {
        let Some(chest) = self.fresh(capture_ns) else {
            self.stale += 1;
            return Joined::Stale;
        };
        self.joined += 1;
        if chest.rumble != Rumble::None && (p.rumble == Rumble::None || chest.nearest_m < p.nearest_m) {
            p.nearest_m = chest.nearest_m;
            p.nearest_bearing_deg = chest.nearest_bearing_deg;
        }
        p.rumble = union(p.rumble, chest.rumble);
        Joined::Joined
    }

    /// Cane frames joined to a fresh chest state so far, and frames that were not.
    pub fn counts(&self) -> (u64, u64) {
        (self.joined, self.stale)
    }
}

/// Every side either state warns of: left and right together are both.
pub fn union(a: Rumble, b: Rumble) -> Rumble {
    match (a, b) {
        (Rumble::None, x) | (x, Rumble::None) => x,
        (x, y) if x == y => x,
        _ => Rumble::Both,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(capture_ns: u64, rumble: Rumble, nearest_m: f32) -> ViewState {
        ViewState { capture_ns, rumble, nearest_m, nearest_bearing_deg: 20.0, blind: false }
    }

    fn cane(rumble: Rumble, nearest_m: f32) -> Perception {
        Perception { rumble, nearest_m, nearest_bearing_deg: -5.0, ground: GroundState::Found, ..Perception::empty() }
    }

    #[test]
    fn the_union_warns_every_side_either_device_warns_of() {
        use Rumble::*;
        let cases = [
            (None, None, None),
            (None, Left, Left),
            (Right, None, Right),
            (Left, Left, Left),
            (Left, Right, Both),
            (Right, Left, Both),
            (Both, None, Both),
            (None, Both, Both),
            (Left, Both, Both),
        ];
        for (a, b, want) in cases {
            assert_eq!(union(a, b), want, "{a:?} + {b:?}");
        }
    }

    #[test]
    fn a_fresh_chest_warning_is_joined_and_its_nearer_obstacle_sets_the_pulse() {
        let mut view = SecondView::default();
        view.heard(state(1_000_000_000, Rumble::Left, 1.1), &[]);
        // a clear cane frame 100 ms later: the chest's lamp warns, at its distance
        let mut p = cane(Rumble::None, f32::INFINITY);
        assert_eq!(view.join(1_100_000_000, &mut p), Joined::Joined);
        assert_eq!((p.rumble, p.nearest_m, p.nearest_bearing_deg), (Rumble::Left, 1.1, 20.0));
        // the cane warns right of a nearer bin: both sides, the bin's distance
        let mut p = cane(Rumble::Right, 0.6);
        view.join(1_100_000_000, &mut p);
        assert_eq!((p.rumble, p.nearest_m, p.nearest_bearing_deg), (Rumble::Both, 0.6, -5.0));
        // a chest that says clear changes nothing
        view.heard(state(1_200_000_000, Rumble::None, 0.4), &[]);
        let mut p = cane(Rumble::Right, 0.9);
        view.join(1_200_000_000, &mut p);
        assert_eq!((p.rumble, p.nearest_m), (Rumble::Right, 0.9));
        assert_eq!(view.counts(), (3, 0));
    }

    #[test]
    fn a_chest_state_too_old_or_blind_is_not_joined_and_says_so() {
        let mut view = SecondView::new(300_000_000);
        let mut p = cane(Rumble::None, f32::INFINITY);
        assert_eq!(view.join(1_000_000_000, &mut p), Joined::Stale, "nothing heard yet");
        view.heard(state(1_000_000_000, Rumble::Both, 0.8), &[]);
        assert_eq!(view.join(1_300_000_000, &mut p), Joined::Joined, "300 ms: still fresh");
        let mut p = cane(Rumble::None, f32::INFINITY);
        assert_eq!(view.join(1_300_000_001, &mut p), Joined::Stale);
        assert_eq!(p.rumble, Rumble::None, "a stale warning is not the cane's");
        // an older frame arriving late does not replace the newer one
        view.heard(state(900_000_000, Rumble::None, f32::INFINITY), &[]);
        assert_eq!(view.fresh(1_000_000_000).map(|s| s.rumble), Some(Rumble::Both));
        // a chest that cannot see is not joined, whatever it says
        view.heard(ViewState { blind: true, ..state(1_400_000_000, Rumble::Both, f32::NAN) }, &[]);
        let mut p = cane(Rumble::Left, 2.0);
        assert_eq!(view.join(1_400_000_000, &mut p), Joined::Stale);
        assert_eq!((p.rumble, p.nearest_m), (Rumble::Left, 2.0));
        assert_eq!(view.counts(), (1, 3));
        // and says why: blind while that state is recent, silent once it has aged
        assert!(view.blind(1_400_000_000) && view.blind(1_700_000_000));
        let mut seeing = SecondView::new(300_000_000);
        assert!(!seeing.blind(1_000_000_000), "nothing heard: silent");
        seeing.heard(state(1_000_000_000, Rumble::None, f32::INFINITY), &[]);
        assert!(!seeing.blind(1_000_000_000) && seeing.fresh(1_000_000_000).is_some());
        assert!(!view.blind(1_700_000_001), "aged: silent");
    }

    #[test]
    fn the_chest_points_are_kept_in_the_body_frame_while_its_state_is_fresh_and_seeing() {
        let mut view = SecondView::default().ahead_of_body(0.12);
        view.heard(state(1_000_000_000, Rumble::Left, 1.1), &[[1.0, 0.2], [1.1, -0.3]]);
        // in the body's frame: 12 cm further on
        assert_eq!(view.fresh_points(1_100_000_000), &[[1.12, 0.2], [1.22, -0.3]]);
        assert!(view.fresh_points(1_300_000_001).is_empty(), "stale");
        // an older frame arriving late does not replace the newer one's points
        view.heard(state(900_000_000, Rumble::None, f32::INFINITY), &[]);
        assert_eq!(view.fresh_points(1_100_000_000).len(), 2);
        // a refused or blind chest frame holds none
        view.heard(ViewState { blind: true, ..state(1_400_000_000, Rumble::None, f32::INFINITY) }, &[[1.0, 0.0]]);
        assert!(view.fresh_points(1_400_000_000).is_empty());
    }

    #[test]
    fn a_degraded_chest_hazard_is_blind() {
        let h = Hazard::nothing_ahead(3, GroundState::Degraded);
        assert!(ViewState::of(&h, 5).blind);
        let h = Hazard { rumble: Rumble::Right, nearest_m: 1.5, ..Hazard::nothing_ahead(4, GroundState::Lost) };
        let s = ViewState::of(&h, 6);
        assert_eq!((s.blind, s.rumble, s.nearest_m, s.capture_ns), (false, Rumble::Right, 1.5, 6));
    }
}
