//! The body's turn rate from a body-worn IMU (a phone on a lanyard or in a chest
//! pocket, a belt clip): the gyro's rate about gravity, whatever way up the device is
//! worn. Perception uses it to take the costs along the heading the user is turning to
//! (`perception::turn_ahead`); it must not come from the cane, whose IMU carries the
//! sweep.
//!
//! Gravity is the accelerometer's reading low-passed over [`GRAVITY_TIME_CONSTANT_S`]
//! (the walking bounce averages out; a turn about the vertical leaves it where it is).
//! The rate given for a frame is the mean over the samples of the [`WINDOW_NS`] before
//! its capture, and none at all when the newest sample is older than [`MAX_AGE_NS`]:
//! then the costs look along the camera's heading only, as they do without the device.
//! A device whose clock is seconds off the LAN's (stamps far from their arrival) is
//! read by its newest samples and judged stale by when they arrived.

use std::collections::VecDeque;

use nalgebra::Vector3;
use schemas::ImuSample;

/// Time constant of the low-pass that finds gravity in the device frame, seconds.
pub const GRAVITY_TIME_CONSTANT_S: f32 = 1.0;
/// Samples averaged for one frame's rate: those this far before its capture, ns (a
/// frame's interval at 30 Hz, about 6 samples of a 100 Hz phone gyro).
pub const WINDOW_NS: u64 = 50_000_000;
/// Newest sample older than this at a frame's capture: the rate is unknown, ns.
pub const MAX_AGE_NS: u64 = 250_000_000;
/// Stamps this far from their arrival are on another clock than the LAN's, ns.
pub const OTHER_CLOCK_NS: u64 = 1_000_000_000;
/// Largest rate a body-worn gyro reads, rad/s (2000 degrees/s, the full scale of phone
/// gyros); beyond it the sample is garbage.
pub const MAX_GYRO_RAD_S: f32 = 35.0;
/// Largest specific force, m/s^2 (16 g, the accelerometers' full scale).
pub const MAX_ACCEL_M_S2: f32 = 157.0;
/// Specific force within this factor of 1 g updates the gravity estimate; a jolt does not.
const GRAVITY_BAND: (f32, f32) = (0.5 * 9.81, 1.5 * 9.81);
/// Samples kept: enough for [`MAX_AGE_NS`] at 1 kHz.
const MAX_KEPT: usize = 256;

/// A body IMU sample that cannot be a person's motion, or is out of time order.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BadBodySample {
    /// A rate or force that is not a number.
    #[error("sample at {stamp_ns} ns has a reading that is not a number")]
    NotFinite {
        /// Sample stamp, ns.
        stamp_ns: u64,
    },
    /// A rate beyond any body-worn gyro's range.
    #[error("gyro reads {rad_s} rad/s at {stamp_ns} ns, beyond a body-worn gyro's {MAX_GYRO_RAD_S} rad/s")]
    Gyro {
        /// Sample stamp, ns.
        stamp_ns: u64,
        /// Magnitude of the rate, rad/s.
        rad_s: f32,
    },
    /// A force beyond any accelerometer's range.
    #[error("accelerometer reads {m_s2} m/s^2 at {stamp_ns} ns, beyond {MAX_ACCEL_M_S2} m/s^2")]
    Accel {
        /// Sample stamp, ns.
        stamp_ns: u64,
        /// Magnitude of the force, m/s^2.
        m_s2: f32,
    },
    /// Not after the sample before it (repeated or reordered).
    #[error("sample stamped {stamp_ns} ns is not after the one before ({last_ns} ns)")]
    OutOfOrder {
        /// Sample stamp, ns.
        stamp_ns: u64,
        /// The previous accepted sample's stamp, ns.
        last_ns: u64,
    },
}

impl BadBodySample {
    /// Reject counter name.
    pub fn kind(&self) -> &'static str {
        match self {
            BadBodySample::NotFinite { .. } => "body_imu_not_finite",
            BadBodySample::Gyro { .. } => "body_imu_gyro_range",
            BadBodySample::Accel { .. } => "body_imu_accel_range",
            BadBodySample::OutOfOrder { .. } => "body_imu_out_of_order",
        }
    }
}

/// The body's turn rate about gravity from one body-worn IMU's samples.
#[derive(Debug, Clone, Default)]
pub struct BodyRate {
    /// Low-passed specific force in the device frame: points away from the floor.
    up: Option<Vector3<f32>>,
    /// Accepted samples' stamps and rates about `up` (positive left), oldest first.
    recent: VecDeque<(u64, f32)>,
    /// When the newest sample arrived, ns on this machine's clock.
    arrived_ns: u64,
}

impl BodyRate {
    /// Take one sample that arrived at `arrived_ns` (this machine's clock); a bad one
    /// is refused and changes nothing.
    pub fn add(&mut self, s: &ImuSample, arrived_ns: u64) -> Result<(), BadBodySample> {
        let stamp_ns = s.stamp_ns;
        let gyro = Vector3::from(s.gyro_rad_s);
        let accel = Vector3::from(s.accel_m_s2);
        if !(gyro.iter().chain(accel.iter()).all(|v| v.is_finite())) {
            return Err(BadBodySample::NotFinite { stamp_ns });
        }
        if gyro.norm() > MAX_GYRO_RAD_S {
            return Err(BadBodySample::Gyro { stamp_ns, rad_s: gyro.norm() });
        }
        if accel.norm() > MAX_ACCEL_M_S2 {
            return Err(BadBodySample::Accel { stamp_ns, m_s2: accel.norm() });
        }
        let last = self.recent.back().map(|&(t, _)| t);
        if let Some(last_ns) = last.filter(|&t| stamp_ns <= t) {
            return Err(BadBodySample::OutOfOrder { stamp_ns, last_ns });
        }
        let force = accel.norm();
        if (GRAVITY_BAND.0..=GRAVITY_BAND.1).contains(&force) {
            self.up = Some(match (self.up, last) {
                (Some(up), Some(last_ns)) => {
                    let dt = ((stamp_ns - last_ns) as f32 * 1e-9).min(GRAVITY_TIME_CONSTANT_S);
                    up + (accel - up) * (dt / (GRAVITY_TIME_CONSTANT_S + dt))
                }
                _ => accel,
            });
        }
        // Before gravity is known the sample still orders the stream, with no rate.
        let rate = self.up.and_then(|up| up.try_normalize(1e-3)).map_or(f32::NAN, |u| gyro.dot(&u));
        self.recent.push_back((stamp_ns, rate));
        self.arrived_ns = arrived_ns;
        if self.recent.len() > MAX_KEPT {
            self.recent.pop_front();
        }
        Ok(())
    }

    /// The turn rate about gravity at `capture_ns`, rad/s positive left: the mean over
    /// the samples of the [`WINDOW_NS`] up to it (samples after it, the frame having
    /// come late, are not used). `None` when the newest sample before it is older than
    /// [`MAX_AGE_NS`], or gravity is not known yet. A device on another clock is read
    /// by its newest samples, `None` once they arrived more than [`MAX_AGE_NS`] before
    /// `now_ns`.
    pub fn rate_at(&self, capture_ns: u64, now_ns: u64) -> Option<f32> {
        let &(newest, _) = self.recent.back()?;
        let end = if newest.abs_diff(self.arrived_ns) > OTHER_CLOCK_NS {
            if now_ns.saturating_sub(self.arrived_ns) > MAX_AGE_NS {
                return None;
            }
            newest
        } else {
            let (end, _) = *self.recent.iter().rev().find(|&&(t, _)| t <= capture_ns)?;
            if capture_ns - end > MAX_AGE_NS {
                return None;
            }
            end
        };
        let window = self.recent.iter().filter(|&&(t, _)| t <= end && t + WINDOW_NS >= end);
        let (sum, n) = window.fold((0.0f32, 0u32), |(sum, n), &(_, r)| (sum + r, n + 1));
        let mean = sum / n as f32;
        mean.is_finite().then_some(mean)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Rotation3;

    use super::*;

    const MS: u64 = 1_000_000;

    /// A phone worn tilted (rolled 20 degrees, pitched 65, turned 0.3 rad), its frame to
    /// the world's (z up): what it reads while the body turns at `rate` (positive left).
    fn worn(stamp_ns: u64, rate_rad_s: f32) -> ImuSample {
        let device_to_world = Rotation3::from_euler_angles(20f32.to_radians(), 65f32.to_radians(), 0.3);
        let to_device = device_to_world.inverse();
        let gyro = to_device * Vector3::new(0.0, 0.0, rate_rad_s);
        let accel = to_device * Vector3::new(0.0, 0.0, 9.81);
        ImuSample { stamp_ns, gyro_rad_s: gyro.into(), accel_m_s2: accel.into() }
    }

    /// Samples arriving the moment they are stamped.
    fn fed(samples: impl IntoIterator<Item = ImuSample>) -> BodyRate {
        let mut b = BodyRate::default();
        for s in samples {
            b.add(&s, s.stamp_ns).unwrap_or_else(|e| panic!("{e}"));
        }
        b
    }

    /// The rate for a frame captured at `t_ms`, handled at once.
    fn rate(b: &BodyRate, t_ms: u64) -> f32 {
        b.rate_at(t_ms * MS, t_ms * MS).unwrap_or(f32::NAN)
    }

    #[test]
    fn a_left_turn_reads_positive_however_the_device_is_worn() {
        let b = fed((0..100).map(|k| worn(k * 10 * MS, 1.0)));
        assert!((rate(&b, 990) - 1.0).abs() < 1e-4, "{}", rate(&b, 990));
        let b = fed((0..100).map(|k| worn(k * 10 * MS, -0.5)));
        assert!((rate(&b, 995) + 0.5).abs() < 1e-4, "{}", rate(&b, 995));
    }

    #[test]
    fn the_rate_is_the_mean_of_the_last_50_ms_before_the_capture() {
        // 0.2 rad/s, then 1.0 from 900 ms; samples after the capture are not used
        let b = fed((0..150).map(|k| worn(k * 10 * MS, if k < 90 { 0.2 } else { 1.0 })));
        assert!((rate(&b, 880) - 0.2).abs() < 1e-4, "{}", rate(&b, 880));
        // the 50 ms up to 925 hold 870, 880, 890 (0.2) and 900, 910, 920 (1.0)
        assert!((rate(&b, 925) - 0.6).abs() < 1e-4, "{}", rate(&b, 925));
        assert!((rate(&b, 1200) - 1.0).abs() < 1e-4, "{}", rate(&b, 1200));
    }

    #[test]
    fn a_stale_device_gives_no_rate_and_a_fresh_one_brings_it_back() {
        let mut b = fed((0..50).map(|k| worn(k * 10 * MS, 0.8)));
        let capture = 490 * MS + MAX_AGE_NS;
        assert!(b.rate_at(capture, capture).is_some());
        assert_eq!(b.rate_at(capture + MS, capture + MS), None);
        b.add(&worn(2_000 * MS, 0.8), 2_000 * MS).unwrap_or_else(|e| panic!("{e}"));
        assert!((rate(&b, 2_010) - 0.8).abs() < 1e-4, "{}", rate(&b, 2_010));
        assert_eq!(BodyRate::default().rate_at(0, 0), None, "nothing heard");
    }

    #[test]
    fn a_device_on_another_clock_is_read_by_its_newest_samples_while_they_come() {
        for offset_s in [5i64, -5] {
            // the phone's clock 5 s ahead of (behind) the LAN's
            let mut b = BodyRate::default();
            for k in 0..50u64 {
                let stamp = (1_000_000 * MS + k * 10 * MS).checked_add_signed(offset_s * 1_000_000_000);
                let s = worn(stamp.unwrap_or(0), -0.4);
                b.add(&s, 1_000_000 * MS + k * 10 * MS).unwrap_or_else(|e| panic!("{e}"));
            }
            let now = 1_000_000 * MS + 500 * MS;
            let r = b.rate_at(now - 20 * MS, now).unwrap_or(f32::NAN);
            assert!((r + 0.4).abs() < 1e-4, "{offset_s} s: {r}");
            // nothing more arrives: stale by the arrival of the last
            assert_eq!(b.rate_at(now + MAX_AGE_NS, now + MAX_AGE_NS), None, "{offset_s} s");
        }
    }

    #[test]
    fn gravity_is_found_through_the_walking_bounce() {
        // 2 m/s^2 of vertical bounce at 1.8 Hz and 1 m/s^2 fore and aft: the rate read
        // about the low-passed gravity is within 2 % of the turn after 3 s
        let to_device = Rotation3::from_euler_angles(0.0, 1.2f32, 0.0).inverse();
        let mut b = BodyRate::default();
        for k in 0..300u64 {
            let t = k as f32 * 0.01;
            let bounce = 2.0 * (std::f32::consts::TAU * 1.8 * t).sin();
            let surge = (std::f32::consts::TAU * 0.9 * t).cos();
            let accel = to_device * Vector3::new(surge, 0.0, 9.81 + bounce);
            let gyro = to_device * Vector3::new(0.0, 0.0, 0.7);
            let s = ImuSample { stamp_ns: k * 10 * MS, gyro_rad_s: gyro.into(), accel_m_s2: accel.into() };
            b.add(&s, s.stamp_ns).unwrap_or_else(|e| panic!("{e}"));
        }
        assert!((rate(&b, 2_990) - 0.7).abs() < 0.014, "{}", rate(&b, 2_990));
    }

    #[test]
    fn a_jolt_does_not_move_gravity() {
        let mut b = fed((0..100).map(|k| worn(k * 10 * MS, 0.0)));
        // a knock of 6 g sideways on one sample
        let mut knock = worn(1_000 * MS, 0.0);
        knock.accel_m_s2[0] += 60.0;
        b.add(&knock, 1_000 * MS).unwrap_or_else(|e| panic!("{e}"));
        for k in 101..110 {
            b.add(&worn(k * 10 * MS, 0.9), k * 10 * MS).unwrap_or_else(|e| panic!("{e}"));
        }
        assert!((rate(&b, 1_090) - 0.9).abs() < 1e-4, "{}", rate(&b, 1_090));
    }

    #[test]
    fn bad_samples_are_refused_by_kind_and_change_nothing() {
        let mut b = fed((0..20).map(|k| worn(k * 10 * MS, 0.5)));
        let mut nan = worn(200 * MS, 0.5);
        nan.gyro_rad_s[1] = f32::NAN;
        let mut spin = worn(200 * MS, 0.5);
        spin.gyro_rad_s = [40.0, 0.0, 0.0];
        let mut slam = worn(200 * MS, 0.5);
        slam.accel_m_s2 = [0.0, 0.0, 200.0];
        let repeat = worn(190 * MS, 3.0);
        let kinds: Vec<_> = [nan, spin, slam, repeat]
            .iter()
            .map(|s| b.add(s, 200 * MS).err().map_or("accepted", |e| e.kind()))
            .collect();
        assert_eq!(
            kinds,
            ["body_imu_not_finite", "body_imu_gyro_range", "body_imu_accel_range", "body_imu_out_of_order"]
        );
        assert!((rate(&b, 200) - 0.5).abs() < 1e-4, "{}", rate(&b, 200));
    }

    #[test]
    fn without_gravity_there_is_no_rate() {
        // free fall (or a zeroed accelerometer): no up, so no turn about it
        let s = |k: u64| ImuSample { stamp_ns: k * 10 * MS, gyro_rad_s: [0.0, 0.0, 1.0], accel_m_s2: [0.0; 3] };
        let b = fed((0..20).map(s));
        assert_eq!(b.rate_at(190 * MS, 190 * MS), None);
    }
}
