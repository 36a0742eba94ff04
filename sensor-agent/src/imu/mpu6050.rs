//! InvenSense MPU-6050 over I2C (register map revision 4.2): the registers this driver
//! writes and reads, and how it turns the raw counts into SI units.

use schemas::ImuSample;

use super::{I2cLink, Imu, ImuError, G};

/// The chip's address with its AD0 pin low (0x69 with it high).
pub const DEFAULT_ADDRESS: u8 = 0x68;

/// Sample-rate divider: 1 kHz / (1 + 9) = 100 Hz with the low-pass on.
pub const SMPLRT_DIV: u8 = 0x19;
/// Digital low-pass filter: 3 = 44 Hz accelerometer, 42 Hz gyro.
pub const CONFIG: u8 = 0x1a;
/// Gyro full scale: bits 4:3 = 1, ±500 °/s.
pub const GYRO_CONFIG: u8 = 0x1b;
/// Accelerometer full scale: bits 4:3 = 0, ±2 g.
pub const ACCEL_CONFIG: u8 = 0x1c;
/// First of the 14 data bytes: accel x, y, z, temperature, gyro x, y, z (big-endian).
pub const ACCEL_XOUT_H: u8 = 0x3b;
/// Power management: 0x01 wakes the chip and clocks it from the x gyro's PLL.
pub const PWR_MGMT_1: u8 = 0x6b;
/// Identity: the upper six bits of the address, 0x68.
pub const WHO_AM_I: u8 = 0x75;

/// Counts per degree per second at ±500 °/s.
const GYRO_COUNTS_PER_DEG_S: f32 = 65.5;
/// Counts per g at ±2 g.
const ACCEL_COUNTS_PER_G: f32 = 16_384.0;

/// The writes that set the chip up, in order (register, value).
pub const SETUP: [(u8, u8); 5] =
    [(PWR_MGMT_1, 0x01), (SMPLRT_DIV, 9), (CONFIG, 0x03), (GYRO_CONFIG, 0x08), (ACCEL_CONFIG, 0x00)];

/// An MPU-6050 on `L`.
pub struct Mpu6050<L: I2cLink> {
    link: L,
    name: String,
}

impl<L: I2cLink> Mpu6050<L> {
    /// Checks the chip's identity and sets it up ([`SETUP`]).
    pub fn new(mut link: L, name: String) -> Result<Self, ImuError> {
        let io = |what: &str, name: &str| {
            let what = format!("{name}: {what}");
            move |source| ImuError::Io { what, source }
        };
        let mut id = [0u8];
        link.write_read(&[WHO_AM_I], &mut id).map_err(io("cannot read WHO_AM_I", &name))?;
        if id[0] & 0x7e != 0x68 {
            return Err(ImuError::Device(format!(
                "{name}: WHO_AM_I is 0x{:02x}, an MPU-6050 says 0x68: another chip at that address?",
                id[0]
            )));
        }
        for (register, value) in SETUP {
            link.write(&[register, value]).map_err(io(&format!("cannot write register 0x{register:02x}"), &name))?;
        }
        Ok(Self { link, name })
    }
}

/// The sample 14 data bytes from [`ACCEL_XOUT_H`] on give, in the board's axes.
pub fn decode(bytes: &[u8; 14], stamp_ns: u64) -> ImuSample {
    let word = |i: usize| f32::from(i16::from_be_bytes([bytes[2 * i], bytes[2 * i + 1]]));
    let accel = [0, 1, 2].map(|i| word(i) / ACCEL_COUNTS_PER_G * G);
    // word 3 is the temperature
    let gyro = [4, 5, 6].map(|i| (word(i) / GYRO_COUNTS_PER_DEG_S).to_radians());
    ImuSample { stamp_ns, gyro_rad_s: gyro, accel_m_s2: accel }
}

impl<L: I2cLink> Imu for Mpu6050<L> {
    fn describe(&self) -> String {
        self.name.clone()
    }

    fn read(&mut self, stamp_ns: u64) -> Result<ImuSample, ImuError> {
        let mut bytes = [0u8; 14];
        self.link.write_read(&[ACCEL_XOUT_H], &mut bytes).map_err(|source| ImuError::Io {
            what: format!("{}: cannot read the data registers", self.name),
            source,
        })?;
        Ok(decode(&bytes, stamp_ns))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// A chip on a wire: records every transfer, answers reads from its registers.
    #[derive(Clone, Default)]
    struct Wire {
        log: Arc<Mutex<Vec<Vec<u8>>>>,
        registers: Arc<Mutex<Vec<u8>>>,
        fail_reads: bool,
    }

    impl I2cLink for Wire {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
            self.log.lock().unwrap().push(bytes.to_vec());
            Ok(())
        }

        fn write_read(&mut self, bytes: &[u8], into: &mut [u8]) -> std::io::Result<()> {
            self.log.lock().unwrap().push(bytes.to_vec());
            if self.fail_reads {
                return Err(std::io::Error::from_raw_os_error(libc::EREMOTEIO));
            }
            let start = usize::from(bytes[0]);
            let registers = self.registers.lock().unwrap();
            into.copy_from_slice(&registers[start..start + into.len()]);
            Ok(())
        }
    }

    /// 128 registers, all 0.
    fn blank() -> Wire {
        Wire { registers: Arc::new(Mutex::new(vec![0; 128])), ..Wire::default() }
    }

    fn chip() -> Wire {
        let wire = blank();
        wire.registers.lock().unwrap()[usize::from(WHO_AM_I)] = 0x68;
        wire
    }

    #[test]
    fn setup_writes_these_bytes_after_checking_the_chip() {
        let wire = chip();
        Mpu6050::new(wire.clone(), "test".into()).unwrap();
        let log = wire.log.lock().unwrap().clone();
        let expected: Vec<Vec<u8>> =
            vec![vec![0x75], vec![0x6b, 0x01], vec![0x19, 0x09], vec![0x1a, 0x03], vec![0x1b, 0x08], vec![0x1c, 0x00]];
        assert_eq!(log, expected);
    }

    #[test]
    fn another_chip_or_a_dead_bus_is_refused_with_what_was_found() {
        let wire = blank();
        wire.registers.lock().unwrap()[usize::from(WHO_AM_I)] = 0x70;
        let e = Mpu6050::new(wire.clone(), "mpu6050:/dev/i2c-1@0x68".into()).err().unwrap().to_string();
        assert!(e.contains("WHO_AM_I is 0x70"), "{e}");
        assert_eq!(wire.log.lock().unwrap().len(), 1, "nothing written to a chip that is not one");
        let dead = Wire { fail_reads: true, ..chip() };
        let e = Mpu6050::new(dead, "mpu6050:/dev/i2c-1@0x68".into()).err().unwrap().to_string();
        assert!(e.starts_with("mpu6050:/dev/i2c-1@0x68: cannot read WHO_AM_I"), "{e}");
    }

    #[test]
    fn a_sample_is_read_from_0x3b_and_made_si() {
        let wire = chip();
        {
            // accel y -0.5 g = -8192 counts, z +1 g = 16384; gyro x 4290 counts = 65.5 deg/s, z -32750 = -500 deg/s
            let mut r = wire.registers.lock().unwrap();
            let words: [i16; 7] = [0, -8192, 16384, 1234, 4290, 0, -32750];
            for (i, w) in words.iter().enumerate() {
                let b = w.to_be_bytes();
                r[0x3b + 2 * i] = b[0];
                r[0x3b + 2 * i + 1] = b[1];
            }
        }
        let mut imu = Mpu6050::new(wire.clone(), "test".into()).unwrap();
        let s = imu.read(42).unwrap();
        assert_eq!(wire.log.lock().unwrap().last().unwrap(), &vec![0x3b]);
        assert_eq!(s.stamp_ns, 42);
        assert_eq!(s.accel_m_s2, [0.0, -0.5 * G, G]);
        assert!((s.gyro_rad_s[0].to_degrees() - 4290.0 / 65.5).abs() < 1e-3, "{:?}", s.gyro_rad_s);
        assert_eq!(s.gyro_rad_s[1], 0.0);
        assert!((s.gyro_rad_s[2].to_degrees() + 500.0).abs() < 1e-3, "{:?}", s.gyro_rad_s);
    }
}
