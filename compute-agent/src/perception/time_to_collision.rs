//! Beyond the thesis: time to collision with what is ahead, from the frame-to-frame
//! change of the nearest forward distance in the path. Distance alone warns late for a
//! person walking towards the user; the closing speed includes the user's own walking,
//! which is what a collision depends on.

use super::config::TtcConfig;

/// Longest gap between frames over which a range change is still a speed, ns.
const MAX_GAP_NS: u64 = 1_000_000_000;

/// Closing-speed tracker.
#[derive(Debug, Default)]
pub struct ClosingSpeed {
    previous: Option<(u64, f32)>,
    speed_m_s: Option<f32>,
}

impl ClosingSpeed {
    /// Feeds the nearest forward distance in the path (`None`: path empty) at `stamp_ns`;
    /// returns the time to collision when something is approaching.
    pub fn update(&mut self, stamp_ns: u64, nearest_forward_m: Option<f32>, cfg: &TtcConfig) -> Option<f32> {
        let now = nearest_forward_m.filter(|x| x.is_finite());
        let prev = self.previous.replace((stamp_ns, now.unwrap_or(f32::NAN)));
        let (Some(x), Some((t0, x0))) = (now, prev) else {
            self.speed_m_s = None;
            return None;
        };
        let gap = stamp_ns.saturating_sub(t0);
        if gap == 0 || gap > MAX_GAP_NS || !x0.is_finite() || (x - x0).abs() > cfg.max_step_m {
            self.speed_m_s = None;
            return None;
        }
        let measured = (x0 - x) / (gap as f32 * 1e-9);
        let speed = match self.speed_m_s {
            Some(s) => s + cfg.smoothing * (measured - s),
            None => measured,
        };
        self.speed_m_s = Some(speed);
        (speed >= cfg.min_closing_speed_m_s).then(|| x / speed)
    }
}

/// The point with the nearest forward distance inside a path of `width_m`.
pub fn nearest_in_path(points: impl Iterator<Item = [f32; 2]>, width_m: f32) -> Option<[f32; 2]> {
    points.filter(|[x, y]| *x > 0.0 && y.abs() <= width_m * 0.5).min_by(|a, b| a[0].total_cmp(&b[0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAME_NS: u64 = 33_333_333;

    #[test]
    fn person_approaching_at_1_5_m_s_from_3_m_gives_2_s() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        let mut ttc = None;
        for k in 0..10u64 {
            let x = 3.0 + 0.05 * 9.0 - 0.05 * k as f32; // 1.5 m/s at 30 Hz, ending at 3.0 m
            ttc = c.update(k * FRAME_NS, Some(x), &cfg);
        }
        let ttc = ttc.expect("approaching");
        assert!((ttc - 2.0).abs() < 0.05, "{ttc}");
    }

    #[test]
    fn still_or_receding_obstacles_have_no_ttc() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        for k in 0..10u64 {
            assert_eq!(c.update(k * FRAME_NS, Some(2.0 + 0.01 * k as f32), &cfg), None);
        }
    }

    #[test]
    fn a_new_nearer_obstacle_is_not_a_speed() {
        let cfg = TtcConfig::default();
        let mut c = ClosingSpeed::default();
        c.update(0, Some(3.0), &cfg);
        assert_eq!(c.update(FRAME_NS, Some(1.0), &cfg), None);
    }
}
