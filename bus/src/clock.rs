//! Wall-clock stamps. Capture stamps are ns since the Unix epoch so that ages can be
//! computed across machines of one LAN (NTP-synchronised) and by the Python monitor.

use std::time::{SystemTime, UNIX_EPOCH};

/// Now, in ns since the Unix epoch (0 if the clock is before 1970).
pub fn now_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_nanos() as u64).unwrap_or(0)
}

/// Age of a stamp in milliseconds (negative if the sender's clock is ahead).
pub fn age_ms(stamp_ns: u64, now_ns: u64) -> f64 {
    (now_ns as i128 - stamp_ns as i128) as f64 / 1e6
}
