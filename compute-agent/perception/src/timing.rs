//! Stage timing. The pipeline only calls `start`/`stop`; whoever owns the clock (the
//! agent, the benchmark, `wearnav perceive`) passes an [`InstantTimer`], tests pass
//! [`NoTimer`].

use std::time::{Duration, Instant};

/// Times the pipeline's stages.
pub trait StageTimer {
    /// A stage begins.
    fn start(&mut self, stage: &'static str);
    /// The stage begun last ends.
    fn stop(&mut self);
}

/// A timer that records nothing (tests, replays).
#[derive(Debug, Default, Clone, Copy)]
pub struct NoTimer;

impl StageTimer for NoTimer {
    fn start(&mut self, _stage: &'static str) {}
    fn stop(&mut self) {}
}

/// Wall-clock stage timer: durations of the stages since the last [`InstantTimer::clear`].
#[derive(Debug, Default, Clone)]
pub struct InstantTimer {
    running: Option<(&'static str, Instant)>,
    /// Stage name and duration, in the order they ran.
    pub stages: Vec<(&'static str, Duration)>,
}

impl InstantTimer {
    /// Forgets the recorded stages (keeps the buffer).
    pub fn clear(&mut self) {
        self.running = None;
        self.stages.clear();
    }
}

impl StageTimer for InstantTimer {
    fn start(&mut self, stage: &'static str) {
        self.running = Some((stage, Instant::now()));
    }
    fn stop(&mut self) {
        if let Some((stage, t0)) = self.running.take() {
            self.stages.push((stage, t0.elapsed()));
        }
    }
}

/// Per-stage and total durations over many runs, reduced to medians.
#[derive(Debug, Default, Clone)]
pub struct StageMedians {
    stages: Vec<(&'static str, Vec<f64>)>,
    totals_ms: Vec<f64>,
}

impl StageMedians {
    /// Adds one run: its stages and its total.
    pub fn add(&mut self, stages: &[(&'static str, Duration)], total: Duration) {
        for &(name, d) in stages {
            let ms = d.as_secs_f64() * 1e3;
            match self.stages.iter_mut().find(|(n, _)| *n == name) {
                Some((_, v)) => v.push(ms),
                None => self.stages.push((name, vec![ms])),
            }
        }
        self.totals_ms.push(total.as_secs_f64() * 1e3);
    }

    /// Median total, milliseconds (NaN before any run).
    pub fn total_ms(&self) -> f64 {
        median(&self.totals_ms)
    }

    /// Median of each stage, milliseconds, in first-run order.
    pub fn stages_ms(&self) -> Vec<(&'static str, f64)> {
        self.stages.iter().map(|(n, v)| (*n, median(v))).collect()
    }
}

fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_are_per_stage_and_total() {
        let mut m = StageMedians::default();
        for ms in [3u64, 1, 2] {
            let d = Duration::from_millis(ms);
            m.add(&[("a", d), ("b", d * 2)], d * 3);
        }
        assert_eq!(m.stages_ms(), vec![("a", 2.0), ("b", 4.0)]);
        assert_eq!(m.total_ms(), 6.0);
    }
}
