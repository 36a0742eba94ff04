//! The page's clock against the bridge's: each `clock` round trip gives the offset to
//! within half its round-trip time, so the page's times (when it vibrated, when it
//! started speaking) can be told on the bridge's clock. The sample with the shortest
//! round trip of the last few is the one trusted.

use std::collections::VecDeque;

/// Round trips kept.
pub const SAMPLES: usize = 8;

/// Offset of the page's clock from the bridge's.
#[derive(Debug, Clone, Default)]
pub struct ClockOffset {
    /// (round trip ms, page minus bridge ms)
    samples: VecDeque<(f64, f64)>,
}

impl ClockOffset {
    /// A round trip: the bridge sent `sent_ms`, the page answered at its `page_ms`, the
    /// answer arrived at `received_ms` (bridge clock). Nonsense (an answer before its
    /// question, a page echoing a time the bridge never sent) is ignored.
    pub fn observe(&mut self, sent_ms: f64, page_ms: f64, received_ms: f64) {
        let rtt = received_ms - sent_ms;
        if !((0.0..10_000.0).contains(&rtt) && page_ms.is_finite()) {
            return;
        }
        self.samples.push_back((rtt, page_ms - (sent_ms + received_ms) / 2.0));
        while self.samples.len() > SAMPLES {
            self.samples.pop_front();
        }
    }

    /// Page minus bridge, ms, from the best round trip; `None` before any.
    pub fn offset_ms(&self) -> Option<f64> {
        self.samples.iter().min_by(|a, b| a.0.total_cmp(&b.0)).map(|s| s.1)
    }

    /// A page time (ms since the epoch on the page's clock) on the bridge's clock, ns.
    /// Before any round trip, or for a time the page cannot have meant (in the future
    /// of `now_ns`, or over a minute ago), the arrival time `now_ns` stands in.
    pub fn to_bridge_ns(&self, page_ms: f64, now_ns: u64) -> u64 {
        let Some(offset) = self.offset_ms() else { return now_ns };
        let ns = (page_ms - offset) * 1e6;
        if !ns.is_finite() || ns < 0.0 {
            return now_ns;
        }
        let ns = ns as u64;
        if ns > now_ns || now_ns - ns > 60_000_000_000 {
            now_ns
        } else {
            ns
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shortest_round_trip_sets_the_offset() {
        let mut c = ClockOffset::default();
        assert_eq!(c.offset_ms(), None);
        assert_eq!(c.to_bridge_ns(5.0, 1_000), 1_000, "no estimate: the arrival time");
        // page clock 250 ms ahead; a slow round trip (one way 80 ms, back 20 ms)...
        c.observe(1000.0, 1000.0 + 80.0 + 250.0, 1100.0);
        assert_eq!(c.offset_ms(), Some(280.0));
        // ...then a quick symmetric one, which wins
        c.observe(2000.0, 2000.0 + 5.0 + 250.0, 2010.0);
        assert_eq!(c.offset_ms(), Some(250.0));
        let now_ns = 3_000_000_000;
        assert_eq!(c.to_bridge_ns(2990.0 + 250.0, now_ns), 2_990_000_000);
        // a time in the future or nonsense falls back on the arrival time
        assert_eq!(c.to_bridge_ns(9999.0, now_ns), now_ns);
        assert_eq!(c.to_bridge_ns(f64::NAN, now_ns), now_ns);
        // answers before their question are ignored
        c.observe(5000.0, 1.0, 4000.0);
        assert_eq!(c.offset_ms(), Some(250.0));
    }
}
