//! Link pacing: depth frames go on the wire only while the link carries them fresh,
//! fewer and coarser when it is slow.
//!
//! Sent at the camera's rate over a slow link (a crowded Wi-Fi, 2 Mbit/s), frames queue
//! in the socket and in Zenoh's queue and reach the compute agent too old to perceive:
//! the user gets no hazard at all. The compute agent answers every frame it perceives
//! with a hazard that carries that frame's capture stamp (and every frame it refuses,
//! from the third in a row, with the blind hazard: a refused frame got through), so
//! the sensor agent sees, on its own clock (no clock skew in it), which frames got
//! through. Two things follow:
//!
//! - At most `window` frames go unanswered on the way (six: 200 ms of frames at 30 Hz,
//!   room for a link's delay both ways and its jitter; a frame that waits behind more
//!   would be stale on arrival). A frame unanswered after `give_up` (a second: stale by
//!   then, or lost) frees its place. Not sooner: an unanswered frame may still be in the
//!   link's queue, and freeing its place early would let the queue grow by a window
//!   every time (measured: 357 stale frames reached the compute agent in 12 s at
//!   2 Mbit/s with 250 ms).
//! - A ladder of levels, each a codec, a size and a share of the frames: the configured
//!   codec at full size and every frame; then the frame halved to every second pixel of
//!   every second row (a quarter of the bytes, and exactly the pixels the perception
//!   samples of a full one, so it perceives the same); then bounded steps of 10 mm,
//!   every second frame, 25 mm at every third and every sixth. When, in a second, more than a third of the frames
//!   due were held back by the window or went unanswered, the pacer steps up a level
//!   (two when more than two thirds were);
//!   after `roomy_s` seconds with none held back or lost it steps down (3 s for the
//!   next when that one fitted: a link that widened gets its fine frames back soon). The second
//!   after a change is not judged (the old level's frames still drain); a step down
//!   that congests the link within that wait doubles it (up to five minutes), so a link
//!   that fits only a coarser level does not flap. A stall of a few frames (200 ms) is
//!   not a slow link and changes nothing.
//!
//! With no compute agent alive nothing answers: every frame due goes, at the current
//! level (a recorder or a monitor still gets the camera's rate when nothing is slow).

use std::collections::VecDeque;

use crate::run::WireCodec;

/// The longest wait before trying a finer level again, seconds: a try that does not
/// fit costs about a second of stale frames (an offline warning), so on a link that
/// stays slow it comes every five minutes at most.
const MAX_ROOMY_S: u32 = 300;

/// Seconds with room before the next step down after one that fitted.
const FOLLOW_UP_S: u32 = 3;

/// One rung of the ladder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Level {
    /// How frames are packed.
    pub codec: WireCodec,
    /// Halved: every second pixel of every second row, the intrinsics halved.
    pub half: bool,
    /// One frame in this many is due (1: every frame).
    pub every: u32,
}

/// How the pacer behaves.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PacingConfig {
    /// Frames on the way, unanswered, at most.
    pub window: usize,
    /// A frame unanswered for this long (ns) counts as lost and frees its place.
    pub give_up_ns: u64,
    /// Levels from the configured codec at every frame (level 0) to the sparsest.
    pub ladder: Vec<Level>,
    /// Seconds without a held or lost frame before stepping down a level (first try).
    pub roomy_s: u32,
}

impl PacingConfig {
    /// Six frames in flight, lost after a second, 10 s before a first try at a finer
    /// level (a try that does not fit costs a moment of stale frames), and the ladder from `codec`: bounded
    /// steps of 10 and 25 mm where coarser than `codec`, then fewer frames.
    pub fn for_codec(codec: WireCodec) -> Self {
        let finest_mm = match codec {
            WireCodec::Raw | WireCodec::Lossless => 0,
            WireCodec::BoundedMm(mm) => mm,
        };
        let coarse = |mm: u16| if mm > finest_mm { WireCodec::BoundedMm(mm) } else { codec };
        let mut ladder = vec![Level { codec, half: false, every: 1 }];
        for (codec, every) in [(codec, 1), (coarse(10), 1), (coarse(10), 2), (coarse(25), 3), (coarse(25), 6)] {
            let level = Level { codec, half: true, every };
            if ladder.last() != Some(&level) {
                ladder.push(level);
            }
        }
        Self { window: 6, give_up_ns: 1_000_000_000, ladder, roomy_s: 10 }
    }
}

/// A change of level, to log and show in health.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LevelChange {
    /// Level before.
    pub from: Level,
    /// Level now.
    pub to: Level,
    /// Frames due in the second that decided it.
    pub due: u32,
    /// Of them, held back by the window.
    pub held: u32,
    /// Frames given up unanswered in that second.
    pub lost: u32,
}

/// The pacing state: frames on the way, the level and this second's counts.
#[derive(Debug, Clone)]
pub struct Pacer {
    config: PacingConfig,
    /// Capture stamps of the frames sent and not yet answered, oldest first.
    in_flight: VecDeque<u64>,
    consumer: bool,
    level: usize,
    /// Frames offered since start (the level's `every` picks among them).
    offered: u64,
    second_start_ns: Option<u64>,
    due: u32,
    held: u32,
    lost: u32,
    roomy: u32,
    roomy_needed: u32,
    /// The finest level a try did not fit at: only stepping down to it (or finer)
    /// waits `roomy_needed`.
    failed_at: Option<usize>,
    /// When the last step down happened (a congestion soon after doubles the wait).
    stepped_down_ns: Option<u64>,
    /// The second after a change is not judged: frames of the old level still drain.
    settling: bool,
    held_total: u64,
    lost_total: u64,
    skipped_total: u64,
    last_round_trip_ns: Option<u64>,
}

impl Pacer {
    /// A pacer at level 0 with no consumer known yet.
    pub fn new(config: PacingConfig) -> Self {
        let roomy_needed = config.roomy_s.max(1);
        Self {
            config,
            in_flight: VecDeque::new(),
            consumer: false,
            level: 0,
            offered: 0,
            second_start_ns: None,
            due: 0,
            held: 0,
            lost: 0,
            roomy: 0,
            roomy_needed,
            failed_at: None,
            stepped_down_ns: None,
            settling: false,
            held_total: 0,
            lost_total: 0,
            skipped_total: 0,
            last_round_trip_ns: None,
        }
    }

    /// The compute agent appeared (`true`) or went away: without it nothing answers,
    /// so every frame due goes.
    pub fn set_consumer(&mut self, alive: bool) {
        self.consumer = alive;
        if !alive {
            self.in_flight.clear();
        }
    }

    /// A frame captured at `capture_ns` is ready at `now_ns`: the level to send it
    /// at, or `None` to leave it (not due at this level, or the link still busy with
    /// earlier ones).
    pub fn admit(&mut self, capture_ns: u64, now_ns: u64) -> Option<Level> {
        while self.in_flight.front().is_some_and(|&c| now_ns.saturating_sub(c) > self.config.give_up_ns) {
            self.in_flight.pop_front();
            self.lost += 1;
            self.lost_total += 1;
        }
        let level = self.current();
        self.offered += 1;
        if !(self.offered - 1).is_multiple_of(u64::from(level.every.max(1))) {
            self.skipped_total += 1;
            return None;
        }
        self.due += 1;
        if !self.consumer {
            return Some(level);
        }
        if self.in_flight.len() >= self.config.window {
            self.held += 1;
            self.held_total += 1;
            return None;
        }
        self.in_flight.push_back(capture_ns);
        Some(level)
    }

    /// A hazard answered the frame captured at `capture_ns` (this agent's stamp) at
    /// `now_ns`: it and every frame sent before it are off the link.
    pub fn answered(&mut self, capture_ns: u64, now_ns: u64) {
        let mut found = false;
        while self.in_flight.front().is_some_and(|&c| c <= capture_ns) {
            found |= self.in_flight.pop_front() == Some(capture_ns);
        }
        if found {
            self.last_round_trip_ns = Some(now_ns.saturating_sub(capture_ns));
        }
    }

    /// Close the second if one has passed since it began: a level change to report,
    /// if the second's counts called for one.
    pub fn tick(&mut self, now_ns: u64) -> Option<LevelChange> {
        let start = *self.second_start_ns.get_or_insert(now_ns);
        if now_ns.saturating_sub(start) < 1_000_000_000 {
            return None;
        }
        let (due, held, lost) = (self.due, self.held, self.lost);
        self.second_start_ns = Some(now_ns);
        (self.due, self.held, self.lost) = (0, 0, 0);
        if !self.consumer {
            self.roomy = 0;
            return None;
        }
        if std::mem::take(&mut self.settling) {
            return None;
        }
        let from = self.current();
        // a lasting shortage, not a stall: a 200 ms stall costs 6 frames of 30
        let congested = (held + lost) * 3 > due;
        if congested {
            self.roomy = 0;
            let since_down = self.stepped_down_ns.map(|t| now_ns.saturating_sub(t));
            if since_down.is_some_and(|d| d <= u64::from(self.roomy_needed) * 1_000_000_000) {
                // the level below did not fit after all: wait longer before trying again
                self.roomy_needed = (self.roomy_needed * 2).min(MAX_ROOMY_S);
                self.failed_at = Some(self.level);
            }
            self.stepped_down_ns = None;
            if self.level + 1 < self.config.ladder.len() {
                // two levels at once when most frames did not get through
                let severe = (held + lost) * 3 > due * 2;
                self.level = (self.level + if severe { 2 } else { 1 }).min(self.config.ladder.len() - 1);
                self.settling = true;
                return Some(LevelChange { from, to: self.current(), due, held, lost });
            }
            return None;
        }
        if held == 0 && lost == 0 {
            self.roomy += 1;
            // after a step down that fits, the next comes sooner: the link has room
            // only a level as fine as one that did not fit waits the long wait
            let target = self.level.saturating_sub(1);
            let needed = match self.failed_at {
                Some(failed) if target <= failed => self.roomy_needed,
                Some(_) => FOLLOW_UP_S,
                None if self.stepped_down_ns.is_some() => FOLLOW_UP_S,
                None => self.roomy_needed,
            };
            if self.level > 0 && self.roomy >= needed {
                self.level -= 1;
                self.roomy = 0;
                self.stepped_down_ns = Some(now_ns);
                self.settling = true;
                return Some(LevelChange { from, to: self.current(), due, held, lost });
            }
        } else {
            self.roomy = 0;
        }
        None
    }

    /// Steps up the ladder from the configured codec at every frame (0).
    pub fn level(&self) -> usize {
        self.level
    }

    /// The level frames are sent at now.
    pub fn current(&self) -> Level {
        self.config.ladder[self.level.min(self.config.ladder.len() - 1)]
    }

    /// Frames held back by the window since start.
    pub fn held_total(&self) -> u64 {
        self.held_total
    }

    /// Frames left out by the level's share since start.
    pub fn skipped_total(&self) -> u64 {
        self.skipped_total
    }

    /// Frames sent and never answered since start.
    pub fn lost_total(&self) -> u64 {
        self.lost_total
    }

    /// Capture -> answer of the newest answered frame, ns.
    pub fn last_round_trip_ns(&self) -> Option<u64> {
        self.last_round_trip_ns
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;
    const T0: u64 = 1_700_000_000_000_000_000;
    const PERIOD: u64 = 33 * MS;
    const LOSSLESS: Level = Level { codec: WireCodec::Lossless, half: false, every: 1 };

    fn pacer() -> Pacer {
        let mut p = Pacer::new(PacingConfig::for_codec(WireCodec::Lossless));
        p.set_consumer(true);
        p
    }

    /// A link between the camera and the compute agent.
    struct Link {
        /// One way, each way.
        delay_ms: u64,
        /// +- this much on each frame's way there (a fixed pseudo-random sequence).
        jitter_ms: u64,
        /// Time on the wire of one frame, by level (the link's rate).
        serial_ms: fn(Level) -> u64,
        /// A stall of `.1` ms every `.0` ms: nothing crosses meanwhile.
        stall: Option<(u64, u64)>,
    }

    /// What went over the link.
    #[derive(Debug, Default)]
    struct Outcome {
        sent: u32,
        /// Frames perceived (fresh on arrival: 150 ms at most, like the compute agent).
        perceived: u32,
        /// Capture -> arrival of each perceived frame, ms.
        ages_ms: Vec<u64>,
        changes: Vec<LevelChange>,
    }

    /// Frames at 30 Hz for `seconds` over `link`.
    fn run(p: &mut Pacer, from: u64, seconds: u64, link: &Link) -> Outcome {
        let mut out = Outcome::default();
        let mut wire_free_at = from;
        // (capture, when its answer reaches the camera)
        let mut answers: VecDeque<(u64, u64)> = VecDeque::new();
        for k in 0..seconds * 1000 / 33 {
            let now = from + k * PERIOD;
            while answers.front().is_some_and(|&(_, at)| at <= now) {
                let (capture, at) = answers.pop_front().unwrap();
                p.answered(capture, at);
            }
            if let Some(level) = p.admit(now, now) {
                out.sent += 1;
                let mut start = wire_free_at.max(now);
                if let Some((every, length)) = link.stall {
                    let into = (start - from) / MS % every;
                    if into < length {
                        start += (length - into) * MS;
                    }
                }
                wire_free_at = start + (link.serial_ms)(level) * MS;
                let jitter = (k * 7919 % (2 * link.jitter_ms + 1)) as i64 - link.jitter_ms as i64;
                let arrival = (wire_free_at + link.delay_ms * MS).saturating_add_signed(jitter * MS as i64);
                let age_ms = (arrival - now) / MS;
                if age_ms <= 150 {
                    out.perceived += 1;
                    out.ages_ms.push(age_ms);
                    let at = arrival + (2 + link.delay_ms) * MS;
                    let i = answers.partition_point(|&(_, a)| a <= at);
                    answers.insert(i, (now, at));
                }
            }
            out.changes.extend(p.tick(now));
        }
        out
    }

    const FAST: Link = Link { delay_ms: 2, jitter_ms: 0, serial_ms: |_| 1, stall: None };
    /// The network-namespace test's proxy: 50 +- 20 ms, a 200 ms stall every 2.5 s.
    const PROXY: Link = Link { delay_ms: 50, jitter_ms: 20, serial_ms: |_| 3, stall: Some((2500, 200)) };
    /// 1.5 Mbit/s (what TCP got of the network-namespace test's 2 Mbit/s cap) behind
    /// the same delay, with the simulator's frames: 65 kB lossless (350 ms on the
    /// wire), 17 kB halved (90 ms), 13 kB halved at 10 mm (70 ms), 9 kB at 25 mm (48).
    const SLOW: Link = Link {
        delay_ms: 50,
        jitter_ms: 0,
        serial_ms: |l| match (l.half, l.codec) {
            (false, _) => 350,
            (true, WireCodec::BoundedMm(25)) => 48,
            (true, WireCodec::BoundedMm(10)) => 70,
            (true, _) => 90,
        },
        stall: None,
    };

    #[test]
    fn a_fast_link_sends_every_frame_losslessly() {
        let mut p = pacer();
        let out = run(&mut p, T0, 10, &FAST);
        assert_eq!((out.sent, out.perceived), (303, 303));
        assert!(out.changes.is_empty(), "{:?}", out.changes);
        assert_eq!(p.current(), LOSSLESS);
        assert_eq!(p.last_round_trip_ns(), Some(7 * MS));
        assert_eq!(p.held_total() + p.skipped_total() + p.lost_total(), 0);
    }

    #[test]
    fn delay_jitter_and_short_stalls_keep_every_frame_and_the_codec() {
        let mut p = pacer();
        let out = run(&mut p, T0, 30, &PROXY);
        assert!(out.changes.is_empty(), "{:?}", out.changes);
        assert_eq!(out.sent, 909 - p.held_total() as u32);
        // only the frames a stall holds up are missed
        assert!(out.perceived >= 909 * 9 / 10, "{} of 909 perceived", out.perceived);
    }

    #[test]
    fn a_slow_link_gets_fewer_coarser_frames_that_arrive_fresh() {
        let mut p = pacer();
        let settling = run(&mut p, T0, 8, &SLOW);
        let first = settling.changes.first().map(|c| (c.from, c.to));
        // nothing got through at full size: two levels at once, halved and 10 mm
        assert_eq!(first, Some((LOSSLESS, Level { codec: WireCodec::BoundedMm(10), half: true, every: 1 })));
        let out = run(&mut p, T0 + 8_000 * MS, 30, &SLOW);
        // halved 25 mm frames at every third fit (48 ms a frame, 10 a second); the
        // level below (10 mm, every second frame) is tried after 10, 20, 40 s ..., never
        // lossless; the climb may overshoot to every sixth frame for 10 s
        assert!(out.changes.iter().all(|c| c.to.codec != WireCodec::Lossless), "{:?}", out.changes);
        let tries: Vec<u64> = out.changes.iter().filter(|c| c.to.every == 2).map(|c| c.lost.into()).collect();
        assert!(tries.len() <= 2, "flapping: {:?}", out.changes);
        assert!(out.perceived >= 30 * 6, "{} frames perceived in 30 s: {:?}", out.perceived, out.changes);
        let slowest = out.ages_ms.iter().max().unwrap();
        assert!(*slowest <= 150, "a frame {slowest} ms old");
        // and then seldom: the wait doubles with each failed try, to five minutes
        let out = run(&mut p, T0 + 38_000 * MS, 600, &SLOW);
        let tries = out.changes.iter().filter(|c| c.to.every == 2).count();
        assert!(tries <= 5, "{tries} tries in 10 min: {:?}", out.changes);
        assert!(p.roomy_needed >= 160, "{} s", p.roomy_needed);
        assert!(out.perceived >= 600 * 9, "{} frames perceived in 10 min", out.perceived);
    }

    #[test]
    fn a_link_that_widens_again_gets_every_lossless_frame_back_and_a_failed_try_waits_longer() {
        let mut p = pacer();
        run(&mut p, T0, 8, &SLOW);
        assert!(p.level() >= 2, "{:?}", p.current());
        let out = run(&mut p, T0 + 8_000 * MS, 11 + 4 * 5 + 1, &FAST);
        assert_eq!(p.current(), LOSSLESS, "{:?}", out.changes);
        assert!(out.changes.iter().all(|c| c.held == 0 && c.lost == 0), "{:?}", out.changes);
        // where only 25 mm at every third frame fits, each failed try down doubles
        // the wait before the next
        let mut p = pacer();
        run(&mut p, T0, 60, &SLOW);
        assert!(p.roomy_needed >= 24, "wait after failed tries: {} s", p.roomy_needed);
    }

    #[test]
    fn without_a_compute_agent_every_frame_due_goes() {
        let mut p = Pacer::new(PacingConfig::for_codec(WireCodec::Lossless));
        for k in 0..100 {
            assert_eq!(p.admit(T0 + k * PERIOD, T0 + k * PERIOD), Some(LOSSLESS));
            assert_eq!(p.tick(T0 + k * PERIOD), None);
        }
        assert_eq!(p.held_total(), 0);
    }

    #[test]
    fn an_answer_frees_its_frame_and_every_earlier_one_and_lost_frames_free_theirs() {
        let mut p = pacer();
        for k in 0..6 {
            assert!(p.admit(T0 + k * PERIOD, T0 + k * PERIOD).is_some());
        }
        assert_eq!(p.admit(T0 + 6 * PERIOD, T0 + 6 * PERIOD), None, "window full");
        // the answer to the second frame frees the first two
        p.answered(T0 + PERIOD, T0 + 7 * PERIOD);
        assert_eq!(p.last_round_trip_ns(), Some(6 * PERIOD));
        assert!(p.admit(T0 + 7 * PERIOD, T0 + 7 * PERIOD).is_some());
        assert!(p.admit(T0 + 8 * PERIOD, T0 + 8 * PERIOD).is_some());
        assert_eq!(p.admit(T0 + 9 * PERIOD, T0 + 9 * PERIOD), None);
        // an answer to a frame never sent (another camera's) frees only earlier ones
        p.answered(T0 + PERIOD + 1, T0 + 9 * PERIOD);
        assert_eq!(p.admit(T0 + 9 * PERIOD + 1, T0 + 9 * PERIOD + 1), None);
        // a second after the newest, every unanswered one is lost
        let later = T0 + 8 * PERIOD + 1001 * MS;
        assert!(p.admit(later, later).is_some());
        assert_eq!((p.lost_total(), p.held_total()), (6, 3));
        // the compute agent gone: nothing is on the way any more
        p.set_consumer(false);
        assert!(p.admit(later + 1, later + 1).is_some());
    }

    #[test]
    fn the_ladder_coarsens_only_past_the_configured_codec_then_thins() {
        let every = |c: WireCodec| -> Vec<(WireCodec, bool, u32)> {
            PacingConfig::for_codec(c).ladder.iter().map(|l| (l.codec, l.half, l.every)).collect()
        };
        let (b10, b25, raw) = (WireCodec::BoundedMm(10), WireCodec::BoundedMm(25), WireCodec::Raw);
        let half = [(b10, true, 1), (b10, true, 2), (b25, true, 3), (b25, true, 6)];
        assert_eq!(every(raw)[..2], [(raw, false, 1), (raw, true, 1)]);
        assert_eq!(every(raw)[2..], half);
        assert_eq!(every(b10)[..1], [(b10, false, 1)]);
        assert_eq!(every(b10)[1..], half);
        let b50 = WireCodec::BoundedMm(50);
        assert_eq!(every(b50), [(b50, false, 1), (b50, true, 1), (b50, true, 2), (b50, true, 3), (b50, true, 6)]);
        // a level's share: one frame in `every`
        let level = Level { codec: b25, half: true, every: 3 };
        let mut p = Pacer::new(PacingConfig { ladder: vec![level], ..PacingConfig::for_codec(b25) });
        let sent: Vec<bool> = (0..7).map(|k| p.admit(T0 + k * PERIOD, T0 + k * PERIOD).is_some()).collect();
        assert_eq!(sent, [true, false, false, true, false, false, true]);
        assert_eq!(p.skipped_total(), 4);
    }
}
