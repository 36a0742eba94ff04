//! A barometer on the cane board, for floor changes: the air pressure falls about 12 Pa
//! a metre near sea level, so a storey (3 m) is some 35 Pa, well above a good sensor's
//! noise once filtered. This module reads the pressure; the compute agent decides from
//! it when the user has gone up or down a floor.
//!
//! - [`Barometer`]: one reading a call, in pascals and degrees Celsius.
//! - [`bmp388::Bmp388`]: a Bosch BMP388 (or BMP390, same register map) on the kernel's
//!   i2c-dev bus, through the IMU's [`I2cLink`](crate::imu::I2cLink): checks `CHIP_ID`, soft-resets, reads
//!   the trimming coefficients, sets pressure ×8 / temperature ×1 oversampling, an IIR
//!   filter of coefficient 3 and 25 Hz in normal mode, waits for the first measurement,
//!   then compensates each reading with the datasheet's floating-point formulas.
//! - [`open`]: the chip a spec names (`bmp388:/dev/i2c-1[@0x76]`).
//! - [`WithBarometer`]: any [`FrameSource`] with the barometer read at each frame (the
//!   sensor agent's `--barometer`): the frame's pressure goes out on
//!   `sensor/<device>/pressure`.
//!
//! A reading outside [`PRESSURE_RANGE_PA`] or [`TEMPERATURE_RANGE_C`] (or not finite),
//! a chip reporting an error, or data registers still at their reset value is refused
//! with [`ImuError::Device`]: the caller counts it, and no wrong value goes out.
//!
//! **Untested with hardware**: no barometer was attached where this was written; the
//! tests check the bytes it writes and the values it makes of the bytes it reads.

pub mod bmp388;

use std::ops::RangeInclusive;
use std::path::Path;

use schemas::Pressure;

use crate::imu::{ImuError, LinuxI2c};
use crate::source::{FailedReads, FrameSource, SourceError, SourceFrame};

/// One barometer reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaroReading {
    /// Air pressure, pascals.
    pub pressure_pa: f64,
    /// The sensor's temperature, degrees Celsius (the board's, not the air's).
    pub temperature_c: f64,
}

/// A barometer read when the caller wants a reading.
pub trait Barometer: Send {
    /// Short description for logs (`bmp388:/dev/i2c-1@0x77`).
    fn describe(&self) -> String;
    /// The latest measurement, compensated; an implausible one is an error, never a value.
    fn read(&mut self) -> Result<BaroReading, ImuError>;
}

/// Pressures a reading may have, pascals: from above the highest inhabited places
/// (~30 kPa is some 9 km up) to beyond the highest sea-level pressure recorded.
pub const PRESSURE_RANGE_PA: RangeInclusive<f64> = 30_000.0..=110_000.0;

/// Temperatures a reading may have, degrees Celsius: the BMP388's operating range. Out
/// of it the pressure compensation, which depends on the temperature, is not to be
/// trusted either.
pub const TEMPERATURE_RANGE_C: RangeInclusive<f64> = -40.0..=85.0;

/// Any [`FrameSource`] with a barometer read at each frame: the frame carries its
/// pressure, stamped with the frame's capture time (the chip measures at 25 Hz; a read
/// gives its latest measurement). A failed read is counted and logged, and that frame
/// goes without.
pub struct WithBarometer {
    source: Box<dyn FrameSource>,
    barometer: Box<dyn Barometer>,
    failed_reads: FailedReads,
}

impl WithBarometer {
    /// `source`'s frames with `barometer`'s readings.
    pub fn new(source: Box<dyn FrameSource>, barometer: Box<dyn Barometer>) -> Self {
        Self { source, barometer, failed_reads: FailedReads::default() }
    }

    /// Reads that failed (their frames went without a pressure).
    pub fn failed_reads(&self) -> u64 {
        self.failed_reads.get()
    }
}

impl FrameSource for WithBarometer {
    fn describe(&self) -> String {
        format!("{} + {}", self.source.describe(), self.barometer.describe())
    }

    fn next_frame(&mut self, now_ns: u64) -> Result<Option<SourceFrame>, SourceError> {
        let Some(mut frame) = self.source.next_frame(now_ns)? else { return Ok(None) };
        match self.barometer.read() {
            Ok(r) => frame.pressure = Some(Pressure { stamp_ns: frame.stamp_ns, pressure_pa: r.pressure_pa as f32 }),
            Err(e) => self.failed_reads.count(&self.barometer.describe(), "pressure", &e),
        }
        Ok(Some(frame))
    }

    fn period_ns(&self) -> u64 {
        self.source.period_ns()
    }
}

/// Opens the barometer a spec names: `bmp388:/dev/i2c-N[@ADDRESS]` (address 0x77 by
/// default, 0x76 with the chip's SDO pin low). A BMP390 is opened under the same name.
pub fn open(spec: &str) -> Result<Box<dyn Barometer>, ImuError> {
    let (path, address) = parse_spec(spec)?;
    let link = LinuxI2c::open(Path::new(path), address)?;
    let barometer = bmp388::Bmp388::new(link, format!("bmp388:{path}@0x{address:02x}"))?;
    Ok(Box::new(barometer))
}

/// The bus and address a spec names (see [`open`]).
fn parse_spec(spec: &str) -> Result<(&str, u8), ImuError> {
    let usage = "bmp388:/dev/i2c-N[@0x76]";
    let rest = match spec.split_once(':') {
        Some(("bmp388", rest)) => rest,
        Some((chip, _)) => {
            return Err(ImuError::Spec(format!(
                "--barometer {spec:?}: no barometer {chip:?}; the supported one is bmp388 (a BMP388 or BMP390): \
                 use {usage}"
            )))
        }
        None => {
            return Err(ImuError::Spec(format!(
                "--barometer {spec:?}: name the chip and the bus; the supported chip is bmp388: use {usage}"
            )))
        }
    };
    let (path, address) = match rest.rsplit_once('@') {
        Some((p, a)) => {
            let digits = a.strip_prefix("0x").or_else(|| a.strip_prefix("0X"));
            let parsed = match digits {
                Some(hex) => u8::from_str_radix(hex, 16),
                None => a.parse::<u8>(),
            };
            match parsed {
                Ok(v) if v == bmp388::DEFAULT_ADDRESS || v == bmp388::OTHER_ADDRESS => (p, v),
                Ok(v) => {
                    return Err(ImuError::Spec(format!(
                        "--barometer {spec:?}: a BMP388 answers at 0x77 (SDO high) or 0x76 (SDO low), not 0x{v:02x}"
                    )))
                }
                Err(_) => {
                    return Err(ImuError::Spec(format!(
                        "--barometer {spec:?}: {a:?} is not an I2C address (0x77 or 0x76)"
                    )))
                }
            }
        }
        None => (rest, bmp388::DEFAULT_ADDRESS),
    };
    if path.is_empty() {
        return Err(ImuError::Spec(format!("--barometer {spec:?}: name the bus, e.g. bmp388:/dev/i2c-1")));
    }
    Ok((path, address))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_data::Camera;

    /// A barometer rising 1 Pa a read; every third read fails.
    struct Chip(u32);

    impl Barometer for Chip {
        fn describe(&self) -> String {
            "chip".into()
        }

        fn read(&mut self) -> Result<BaroReading, ImuError> {
            self.0 += 1;
            if self.0.is_multiple_of(3) {
                return Err(ImuError::Device("barometer: no answer".into()));
            }
            Ok(BaroReading { pressure_pa: 100_000.0 + f64::from(self.0), temperature_c: 21.0 })
        }
    }

    #[test]
    fn each_frame_carries_the_barometers_reading_at_its_capture_time_and_a_failed_read_none() {
        let mut s = WithBarometer::new(Box::new(Camera(0)), Box::new(Chip(0)));
        assert_eq!(s.describe(), "openni2:test + chip");
        assert_eq!(s.period_ns(), 33_333_333);
        let frames: Vec<SourceFrame> = (0..6).map(|_| s.next_frame(0).unwrap().unwrap()).collect();
        for (k, f) in frames.iter().enumerate() {
            if k % 3 == 2 {
                assert_eq!(f.pressure, None, "frame {k}: a failed read sends no pressure");
            } else {
                let p = f.pressure.expect("a pressure");
                assert_eq!(p.stamp_ns, f.stamp_ns);
                assert_eq!(p.pressure_pa, 100_000.0 + (k + 1) as f32);
            }
        }
        assert_eq!(s.failed_reads(), 2);
    }

    #[test]
    fn good_specs_give_the_bus_and_the_address() {
        for (spec, path, address) in [
            ("bmp388:/dev/i2c-1", "/dev/i2c-1", 0x77),
            ("bmp388:/dev/i2c-1@0x76", "/dev/i2c-1", 0x76),
            ("bmp388:/dev/i2c-0@0X77", "/dev/i2c-0", 0x77),
            ("bmp388:/dev/i2c-3@118", "/dev/i2c-3", 0x76),
        ] {
            assert_eq!(parse_spec(spec).unwrap(), (path, address), "{spec}");
        }
    }

    #[test]
    fn bad_specs_say_what_is_wrong_and_how() {
        for (spec, want) in [
            ("bmp280:/dev/i2c-1", "no barometer \"bmp280\"; the supported one is bmp388"),
            ("mpu6050:/dev/i2c-1@0x68", "the supported one is bmp388"),
            ("/dev/i2c-1", "the supported chip is bmp388"),
            ("", "the supported chip is bmp388"),
            ("bmp388:/dev/i2c-1@0x68", "0x77 (SDO high) or 0x76 (SDO low), not 0x68"),
            ("bmp388:/dev/i2c-1@0x100", "\"0x100\" is not an I2C address"),
            ("bmp388:/dev/i2c-1@zz", "\"zz\" is not an I2C address"),
            ("bmp388:/dev/i2c-1@", "\"\" is not an I2C address"),
            ("bmp388:", "name the bus"),
            ("bmp388:@0x76", "name the bus"),
        ] {
            let e = parse_spec(spec).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(e.starts_with(&format!("--barometer {spec:?}: ")) && e.contains(want), "{spec}: {e}");
            // the same refusal from open, before any bus is touched
            let e = open(spec).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(e.contains(want), "{spec}: {e}");
        }
    }

    #[test]
    fn a_missing_bus_is_named_with_the_likely_cause() {
        let e = open("bmp388:/nonexistent/i2c-9@0x76").err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.starts_with("cannot open /nonexistent/i2c-9 (is i2c-dev loaded"), "{e}");
    }
}
