//! Bosch BMP388 over I2C (datasheet BST-BMP388-DS001): the registers this driver writes
//! and reads, the trimming coefficients in the chip's NVM, and the datasheet's
//! floating-point compensation that turns the raw counts into pascals and degrees. A
//! BMP390 (`CHIP_ID` 0x60) has the same register map and formulas and is taken too.
//!
//! At [`SETUP`]'s settings (pressure ×8, temperature ×1) a measurement takes some 19 ms
//! (the datasheet's 234 µs + 392 µs + 8 × 2020 µs + 163 µs + 1 × 2020 µs), well within
//! the 40 ms of 25 Hz; the chip measures on its own in normal mode, and a read returns
//! the latest measurement (twice the same if read faster than 25 Hz).

use std::time::{Duration, Instant};

use super::{BaroReading, Barometer, PRESSURE_RANGE_PA, TEMPERATURE_RANGE_C};
use crate::imu::{I2cLink, ImuError};

/// The chip's address with its SDO pin high (most breakout boards pull it up).
pub const DEFAULT_ADDRESS: u8 = 0x77;
/// The chip's address with its SDO pin low.
pub const OTHER_ADDRESS: u8 = 0x76;

/// Identity: [`BMP388_ID`] or [`BMP390_ID`].
pub const CHIP_ID: u8 = 0x00;
/// What a BMP388 answers at [`CHIP_ID`].
pub const BMP388_ID: u8 = 0x50;
/// What a BMP390 answers at [`CHIP_ID`] (same registers, same formulas).
pub const BMP390_ID: u8 = 0x60;
/// Errors: bit 0 fatal, bit 1 a command failed, bit 2 a configuration refused (the chip
/// then stays asleep); bits 1 and 2 clear when read.
pub const ERR_REG: u8 = 0x02;
/// Status: bit 4 ready for a command, bit 5 pressure data ready, bit 6 temperature data
/// ready (bits 5 and 6 clear when the data are read).
pub const STATUS: u8 = 0x03;
/// First of the 6 data bytes: pressure, then temperature, each 24 bits little-endian.
pub const DATA_0: u8 = 0x04;
/// Power control: bit 0 pressure on, bit 1 temperature on, bits 5:4 the mode (3 = normal).
pub const PWR_CTRL: u8 = 0x1b;
/// Oversampling: bits 2:0 pressure, bits 5:3 temperature (0 = ×1, 1 = ×2, 2 = ×4, 3 = ×8, …).
pub const OSR: u8 = 0x1c;
/// Output data rate in normal mode: 200 Hz / 2^n for n in bits 4:0.
pub const ODR: u8 = 0x1d;
/// IIR filter coefficient in bits 3:1 (0 off, 1 → 1, 2 → 3, 3 → 7, …).
pub const CONFIG: u8 = 0x1f;
/// First of the trimming coefficients: `NVM_PAR_T1` … `NVM_PAR_P11`, 0x31 to 0x45.
pub const NVM_PAR_T1: u8 = 0x31;
/// How many bytes the trimming coefficients take.
pub const NVM_LEN: usize = 21;
/// Command register.
pub const CMD: u8 = 0x7e;
/// The command that resets the chip (all settings back to their defaults, asleep).
pub const SOFT_RESET: u8 = 0xb6;

/// [`ERR_REG`]: the chip needs a reset.
const FATAL_ERR: u8 = 0x01;
/// [`ERR_REG`]: a command failed.
const CMD_ERR: u8 = 0x02;
/// [`ERR_REG`]: the settings were refused (e.g. a data rate too fast for the oversampling).
const CONF_ERR: u8 = 0x04;
/// [`STATUS`]: a new pressure and a new temperature are ready.
const DRDY_BOTH: u8 = 0x60;

/// The writes that set the chip up after its reset, in order (register, value): pressure
/// ×8 and temperature ×1, 25 Hz (200 Hz / 8), the IIR filter's coefficient 3, then
/// normal mode with pressure and temperature on (last: the others are written asleep).
pub const SETUP: [(u8, u8); 4] = [(OSR, 0x03), (ODR, 0x03), (CONFIG, 0x02 << 1), (PWR_CTRL, 0x33)];

/// The wait after the soft reset: the datasheet's start-up time is 2 ms; 10 ms leaves margin.
pub const RESET_WAIT: Duration = Duration::from_millis(10);
/// How long the first measurement may take after normal mode starts (one takes ~19 ms).
pub const FIRST_MEASUREMENT_WITHIN: Duration = Duration::from_millis(200);
/// How often [`STATUS`] is read while waiting for the first measurement.
const POLL: Duration = Duration::from_millis(5);

/// The data registers' reset value, for pressure and temperature alike. A chip that was
/// reset (a power glitch) sleeps with these, which compensate to a plausible-looking
/// pressure: they are refused, never passed on.
pub const RESET_RAW: u32 = 0x80_0000;

/// The trimming coefficients as the datasheet's floating-point parameters (`PAR_T1` …
/// `PAR_P11`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    t1: f64,
    t2: f64,
    t3: f64,
    p1: f64,
    p2: f64,
    p3: f64,
    p4: f64,
    p5: f64,
    p6: f64,
    p7: f64,
    p8: f64,
    p9: f64,
    p10: f64,
    p11: f64,
}

impl Calibration {
    /// The parameters from the [`NVM_LEN`] bytes read from [`NVM_PAR_T1`] on: each
    /// coefficient (little-endian; T1, T2, P5, P6 unsigned 16-bit, P1, P2, P9 signed
    /// 16-bit, the rest signed 8-bit) scaled by its power of two, P1 and P2 offset by 2^14.
    pub fn from_nvm(b: &[u8; NVM_LEN]) -> Self {
        let u16_at = |i: usize| f64::from(u16::from_le_bytes([b[i], b[i + 1]]));
        let i16_at = |i: usize| f64::from(i16::from_le_bytes([b[i], b[i + 1]]));
        let i8_at = |i: usize| f64::from(i8::from_le_bytes([b[i]]));
        let two = |n: i32| 2f64.powi(n);
        Self {
            t1: u16_at(0) * two(8),
            t2: u16_at(2) * two(-30),
            t3: i8_at(4) * two(-48),
            p1: (i16_at(5) - two(14)) * two(-20),
            p2: (i16_at(7) - two(14)) * two(-29),
            p3: i8_at(9) * two(-32),
            p4: i8_at(10) * two(-37),
            p5: u16_at(11) * two(3),
            p6: u16_at(13) * two(-6),
            p7: i8_at(15) * two(-8),
            p8: i8_at(16) * two(-15),
            p9: i16_at(17) * two(-48),
            p10: i8_at(19) * two(-48),
            p11: i8_at(20) * two(-65),
        }
    }

    /// The temperature, °C, from the raw 24-bit temperature.
    pub fn temperature_c(&self, raw: u32) -> f64 {
        let d = f64::from(raw) - self.t1;
        d * self.t2 + d * d * self.t3
    }

    /// The pressure, Pa, from the raw 24-bit pressure and the compensated temperature.
    pub fn pressure_pa(&self, raw: u32, temperature_c: f64) -> f64 {
        let (t, p) = (temperature_c, f64::from(raw));
        let (t2, t3) = (t * t, t * t * t);
        let offset = self.p5 + self.p6 * t + self.p7 * t2 + self.p8 * t3;
        let sensitivity = p * (self.p1 + self.p2 * t + self.p3 * t2 + self.p4 * t3);
        let higher = p * p * (self.p9 + self.p10 * t) + p * p * p * self.p11;
        offset + sensitivity + higher
    }

    /// Temperature, then the pressure with it, from the raw words (not checked).
    pub fn compensate(&self, raw_pressure: u32, raw_temperature: u32) -> BaroReading {
        let temperature_c = self.temperature_c(raw_temperature);
        BaroReading { pressure_pa: self.pressure_pa(raw_pressure, temperature_c), temperature_c }
    }
}

/// A BMP388 (or BMP390) on `L`, measuring on its own at 25 Hz.
pub struct Bmp388<L: I2cLink> {
    link: L,
    name: String,
    chip_id: u8,
    calibration: Calibration,
}

impl<L: I2cLink> Bmp388<L> {
    /// Checks the chip's identity, resets it, reads its trimming coefficients, sets it up
    /// ([`SETUP`]) and waits for its first measurement. `name` prefixes every error.
    pub fn new(mut link: L, name: String) -> Result<Self, ImuError> {
        let [chip_id] = read_registers(&mut link, &name, CHIP_ID, "CHIP_ID (0x00)")?;
        if chip_id != BMP388_ID && chip_id != BMP390_ID {
            return Err(ImuError::Device(format!(
                "{name}: CHIP_ID is 0x{chip_id:02x}, a BMP388 says 0x50 (a BMP390 0x60): another chip at that address?"
            )));
        }
        link.write(&[CMD, SOFT_RESET]).map_err(|source| ImuError::Io {
            what: format!("{name}: cannot soft-reset the barometer (CMD 0x7e <- 0xb6)"),
            source,
        })?;
        std::thread::sleep(RESET_WAIT);
        let [err] = read_registers(&mut link, &name, ERR_REG, "ERR_REG (0x02)")?;
        check_errors(&name, err, "after its soft reset")?;
        let nvm = read_registers(&mut link, &name, NVM_PAR_T1, "trimming coefficients (0x31..0x45)")?;
        let calibration = Calibration::from_nvm(&nvm);
        for (register, value) in SETUP {
            link.write(&[register, value]).map_err(|source| ImuError::Io {
                what: format!("{name}: cannot write 0x{value:02x} to the barometer's register 0x{register:02x}"),
                source,
            })?;
        }
        // a refused setting shows in ERR_REG (and the chip stays asleep); until the first
        // measurement the data registers hold their reset value
        let started = Instant::now();
        loop {
            let [err, status] = read_registers(&mut link, &name, ERR_REG, "ERR_REG and STATUS (0x02, 0x03)")?;
            check_errors(&name, err, "on starting")?;
            if status & DRDY_BOTH == DRDY_BOTH {
                break;
            }
            if started.elapsed() >= FIRST_MEASUREMENT_WITHIN {
                return Err(ImuError::Device(format!(
                    "{name}: the barometer gave no measurement within {} ms of starting (STATUS 0x{status:02x})",
                    FIRST_MEASUREMENT_WITHIN.as_millis()
                )));
            }
            std::thread::sleep(POLL);
        }
        Ok(Self { link, name, chip_id, calibration })
    }

    /// What the chip answered at [`CHIP_ID`]: [`BMP388_ID`] or [`BMP390_ID`].
    pub fn chip_id(&self) -> u8 {
        self.chip_id
    }

    /// The parameters made of the chip's trimming coefficients.
    pub fn calibration(&self) -> &Calibration {
        &self.calibration
    }
}

/// `N` bytes from `register` on; `what` names them in the error.
fn read_registers<L: I2cLink, const N: usize>(
    link: &mut L,
    name: &str,
    register: u8,
    what: &str,
) -> Result<[u8; N], ImuError> {
    let mut bytes = [0u8; N];
    link.write_read(&[register], &mut bytes)
        .map_err(|source| ImuError::Io { what: format!("{name}: cannot read the barometer's {what}"), source })?;
    Ok(bytes)
}

/// An error for the bits of [`ERR_REG`] that are set, if any.
fn check_errors(name: &str, err: u8, when: &str) -> Result<(), ImuError> {
    let found: Vec<&str> = [
        (FATAL_ERR, "a fatal error"),
        (CMD_ERR, "a failed command"),
        (CONF_ERR, "a refused configuration (it stays asleep)"),
    ]
    .into_iter()
    .filter(|(bit, _)| err & bit != 0)
    .map(|(_, what)| what)
    .collect();
    if found.is_empty() {
        return Ok(());
    }
    Err(ImuError::Device(format!("{name}: the barometer reports {} {when} (ERR_REG 0x{err:02x})", found.join(" and "))))
}

impl<L: I2cLink> Barometer for Bmp388<L> {
    fn describe(&self) -> String {
        self.name.clone()
    }

    fn read(&mut self) -> Result<BaroReading, ImuError> {
        let [err] = read_registers(&mut self.link, &self.name, ERR_REG, "ERR_REG (0x02)")?;
        check_errors(&self.name, err, "while measuring")?;
        let d: [u8; 6] = read_registers(&mut self.link, &self.name, DATA_0, "data registers (0x04..0x09)")?;
        let raw_pressure = u32::from_le_bytes([d[0], d[1], d[2], 0]);
        let raw_temperature = u32::from_le_bytes([d[3], d[4], d[5], 0]);
        if raw_pressure == RESET_RAW && raw_temperature == RESET_RAW {
            return Err(ImuError::Device(format!(
                "{}: the barometer's data registers hold their reset value: it is not measuring (was it reset, \
                 a power glitch?)",
                self.name
            )));
        }
        let r = self.calibration.compensate(raw_pressure, raw_temperature);
        if !PRESSURE_RANGE_PA.contains(&r.pressure_pa) || !TEMPERATURE_RANGE_C.contains(&r.temperature_c) {
            return Err(ImuError::Device(format!(
                "{}: the barometer's reading, {:.0} Pa at {:.1} °C (raw 0x{raw_pressure:06x}, 0x{raw_temperature:06x}), \
                 is outside {}..{} Pa or {}..{} °C: refused",
                self.name,
                r.pressure_pa,
                r.temperature_c,
                PRESSURE_RANGE_PA.start(),
                PRESSURE_RANGE_PA.end(),
                TEMPERATURE_RANGE_C.start(),
                TEMPERATURE_RANGE_C.end(),
            )));
        }
        Ok(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// The trimming coefficients of the test chip, as integers in the NVM (realistic
    /// values: 25 °C near raw 8.46 M, 101.3 kPa near raw 7.08 M, -0.016 Pa a count).
    const T1: u16 = 27_500;
    const T2: u16 = 19_000;
    const T3: i8 = -8;
    const P1: i16 = 400;
    const P2: i16 = -2_600;
    const P3: i8 = 35;
    const P4: i8 = 1;
    const P5: u16 = 25_400;
    const P6: u16 = 31_000;
    const P7: i8 = -12;
    const P8: i8 = -9;
    const P9: i16 = 4_300;
    const P10: i8 = 7;
    const P11: i8 = -60;

    /// The coefficients laid out at their registers, 0x31 to 0x45, one by one.
    fn nvm() -> Vec<(u8, Vec<u8>)> {
        vec![
            (0x31, T1.to_le_bytes().to_vec()),
            (0x33, T2.to_le_bytes().to_vec()),
            (0x35, T3.to_le_bytes().to_vec()),
            (0x36, P1.to_le_bytes().to_vec()),
            (0x38, P2.to_le_bytes().to_vec()),
            (0x3a, P3.to_le_bytes().to_vec()),
            (0x3b, P4.to_le_bytes().to_vec()),
            (0x3c, P5.to_le_bytes().to_vec()),
            (0x3e, P6.to_le_bytes().to_vec()),
            (0x40, P7.to_le_bytes().to_vec()),
            (0x41, P8.to_le_bytes().to_vec()),
            (0x42, P9.to_le_bytes().to_vec()),
            (0x44, P10.to_le_bytes().to_vec()),
            (0x45, P11.to_le_bytes().to_vec()),
        ]
    }

    /// One transfer on the wire.
    #[derive(Debug, Clone, PartialEq, Eq)]
    enum Transfer {
        /// These bytes written.
        Write(Vec<u8>),
        /// This register's address written, then this many bytes read.
        Read(u8, usize),
    }

    /// The chip behind the wire.
    struct State {
        registers: Vec<u8>,
        log: Vec<Transfer>,
        /// What the chip measures while in normal mode: pressure, temperature (raw).
        measuring: (u32, u32),
        /// Transfers starting at this register fail.
        fail_at: Option<u8>,
        /// Normal mode is refused (ERR_REG's conf_err, and asleep).
        refuse_config: bool,
        /// Normal mode starts but no measurement ever completes.
        stall: bool,
    }

    impl State {
        /// Power-on values of everything but the identity and the NVM.
        fn power_on(&mut self) {
            for r in 0x02..0x31 {
                self.registers[r] = 0;
            }
            self.registers[usize::from(STATUS)] = 0x10; // ready for a command
            self.registers[usize::from(OSR)] = 0x02;
            self.set_data(RESET_RAW, RESET_RAW);
        }

        fn set_data(&mut self, pressure: u32, temperature: u32) {
            let (p, t) = (pressure.to_le_bytes(), temperature.to_le_bytes());
            self.registers[0x04..0x0a].copy_from_slice(&[p[0], p[1], p[2], t[0], t[1], t[2]]);
        }

        fn normal(&self) -> bool {
            self.registers[usize::from(PWR_CTRL)] == 0x33
        }
    }

    /// A BMP388 on a wire: records every transfer, answers reads from its registers,
    /// resets on 0xB6, measures in normal mode.
    #[derive(Clone)]
    struct Chip(Arc<Mutex<State>>);

    impl Chip {
        /// A BMP388 (CHIP_ID 0x50) with the test's coefficients, measuring 101.3 kPa at 25 °C.
        fn new() -> Self {
            let mut state = State {
                registers: vec![0; 128],
                log: Vec::new(),
                measuring: (7_081_512, 8_456_038),
                fail_at: None,
                refuse_config: false,
                stall: false,
            };
            state.registers[usize::from(CHIP_ID)] = BMP388_ID;
            for (register, bytes) in nvm() {
                let r = usize::from(register);
                state.registers[r..r + bytes.len()].copy_from_slice(&bytes);
            }
            state.power_on();
            Self(Arc::new(Mutex::new(state)))
        }

        fn with(self, f: impl FnOnce(&mut State)) -> Self {
            f(&mut self.0.lock().unwrap());
            self
        }

        fn log(&self) -> Vec<Transfer> {
            self.0.lock().unwrap().log.clone()
        }

        fn register(&self, r: u8) -> u8 {
            self.0.lock().unwrap().registers[usize::from(r)]
        }
    }

    impl I2cLink for Chip {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
            let mut s = self.0.lock().unwrap();
            s.log.push(Transfer::Write(bytes.to_vec()));
            if s.fail_at == Some(bytes[0]) {
                return Err(std::io::Error::from_raw_os_error(libc::EREMOTEIO));
            }
            assert_eq!(bytes.len(), 2, "one register at a time");
            match (bytes[0], bytes[1]) {
                (CMD, SOFT_RESET) => s.power_on(),
                (PWR_CTRL, 0x33) if s.refuse_config => {
                    s.registers[usize::from(ERR_REG)] |= CONF_ERR;
                    s.registers[usize::from(PWR_CTRL)] = 0x03;
                }
                (PWR_CTRL, 0x33) if !s.stall => {
                    s.registers[usize::from(PWR_CTRL)] = 0x33;
                    let (p, t) = s.measuring;
                    s.set_data(p, t);
                    s.registers[usize::from(STATUS)] |= DRDY_BOTH;
                }
                (r, v) => s.registers[usize::from(r)] = v,
            }
            Ok(())
        }

        fn write_read(&mut self, bytes: &[u8], into: &mut [u8]) -> std::io::Result<()> {
            let mut s = self.0.lock().unwrap();
            s.log.push(Transfer::Read(bytes[0], into.len()));
            if s.fail_at == Some(bytes[0]) {
                return Err(std::io::Error::from_raw_os_error(libc::EREMOTEIO));
            }
            let start = usize::from(bytes[0]);
            if start == usize::from(DATA_0) && s.normal() {
                let (p, t) = s.measuring;
                s.set_data(p, t);
            }
            into.copy_from_slice(&s.registers[start..start + into.len()]);
            if (start..start + into.len()).contains(&usize::from(ERR_REG)) {
                s.registers[usize::from(ERR_REG)] &= FATAL_ERR; // cmd_err, conf_err clear on read
            }
            Ok(())
        }
    }

    const NAME: &str = "bmp388:/dev/i2c-1@0x77";

    fn error(result: Result<impl Sized, ImuError>) -> String {
        result.err().map(|e| e.to_string()).unwrap_or_default()
    }

    #[test]
    fn setup_checks_the_chip_resets_it_reads_the_nvm_and_writes_these_bytes() {
        let chip = Chip::new();
        let started = Instant::now();
        let baro = Bmp388::new(chip.clone(), NAME.into()).unwrap();
        assert!(started.elapsed() >= RESET_WAIT, "the reset is waited for");
        assert_eq!(baro.chip_id(), 0x50);
        assert_eq!(baro.describe(), NAME);
        use Transfer::{Read, Write};
        assert_eq!(
            chip.log(),
            vec![
                Read(0x00, 1),
                Write(vec![0x7e, 0xb6]),
                Read(0x02, 1),
                Read(0x31, 21),
                Write(vec![0x1c, 0x03]),
                Write(vec![0x1d, 0x03]),
                Write(vec![0x1f, 0x04]),
                Write(vec![0x1b, 0x33]),
                Read(0x02, 2),
            ]
        );
        let written: Vec<u8> = chip
            .log()
            .into_iter()
            .filter_map(|t| match t {
                Write(bytes) => Some(bytes),
                Read(..) => None,
            })
            .flatten()
            .collect();
        assert_eq!(written, [0x7e, 0xb6, 0x1c, 0x03, 0x1d, 0x03, 0x1f, 0x04, 0x1b, 0x33]);
        // pressure x8 (bits 2:0 = 3), temperature x1 (bits 5:3 = 0); 200 Hz / 2^3; IIR
        // coefficient 3 (bits 3:1 = 2); pressure and temperature on, normal mode
        assert_eq!([OSR, ODR, CONFIG, PWR_CTRL].map(|r| chip.register(r)), [0x03, 0x03, 0x04, 0x33]);
    }

    #[test]
    fn a_bmp390_is_taken_and_another_chip_refused_untouched() {
        let bmp390 = Chip::new().with(|s| s.registers[0] = BMP390_ID);
        assert_eq!(Bmp388::new(bmp390, NAME.into()).unwrap().chip_id(), 0x60);
        // a BMP280 answers 0x58; an empty bus reads 0xff or 0x00
        for id in [0x58, 0xff, 0x00] {
            let other = Chip::new().with(|s| s.registers[0] = id);
            let e = error(Bmp388::new(other.clone(), NAME.into()));
            assert_eq!(
                e,
                format!(
                    "{NAME}: CHIP_ID is 0x{id:02x}, a BMP388 says 0x50 (a BMP390 0x60): another chip at that address?"
                )
            );
            assert_eq!(other.log(), vec![Transfer::Read(0x00, 1)], "nothing written to a chip that is not one");
        }
    }

    /// The datasheet's compensation written out again from the NVM integers (not the
    /// bytes) with the divisors as plain numbers: temperature, then pressure.
    fn datasheet(raw_pressure: f64, raw_temperature: f64) -> (f64, f64) {
        let par_t1 = f64::from(T1) / 0.003_906_25; // / 2^-8
        let par_t2 = f64::from(T2) / 1_073_741_824.0; // / 2^30
        let par_t3 = f64::from(T3) / 281_474_976_710_656.0; // / 2^48
        let par_p1 = (f64::from(P1) - 16_384.0) / 1_048_576.0; // (- 2^14) / 2^20
        let par_p2 = (f64::from(P2) - 16_384.0) / 536_870_912.0; // (- 2^14) / 2^29
        let par_p3 = f64::from(P3) / 4_294_967_296.0; // / 2^32
        let par_p4 = f64::from(P4) / 137_438_953_472.0; // / 2^37
        let par_p5 = f64::from(P5) / 0.125; // / 2^-3
        let par_p6 = f64::from(P6) / 64.0; // / 2^6
        let par_p7 = f64::from(P7) / 256.0; // / 2^8
        let par_p8 = f64::from(P8) / 32_768.0; // / 2^15
        let par_p9 = f64::from(P9) / 281_474_976_710_656.0; // / 2^48
        let par_p10 = f64::from(P10) / 281_474_976_710_656.0; // / 2^48
        let par_p11 = f64::from(P11) / 36_893_488_147_419_103_232.0; // / 2^65

        let partial_data1 = raw_temperature - par_t1;
        let partial_data2 = partial_data1 * par_t2;
        let t_lin = partial_data2 + (partial_data1 * partial_data1) * par_t3;

        let partial_out1 = par_p5 + par_p6 * t_lin + par_p7 * (t_lin * t_lin) + par_p8 * (t_lin * t_lin * t_lin);
        let partial_out2 =
            raw_pressure * (par_p1 + par_p2 * t_lin + par_p3 * (t_lin * t_lin) + par_p4 * (t_lin * t_lin * t_lin));
        let partial_data3 = (raw_pressure * raw_pressure) * (par_p9 + par_p10 * t_lin);
        let partial_data4 = partial_data3 + (raw_pressure * raw_pressure * raw_pressure) * par_p11;
        (partial_out1 + partial_out2 + partial_data4, t_lin)
    }

    #[test]
    fn the_trimming_bytes_become_the_datasheets_parameters() {
        let nvm: [u8; NVM_LEN] = [
            0x6c, 0x6b, 0x38, 0x4a, 0xf8, 0x90, 0x01, 0xd8, 0xf5, 0x23, 0x01, 0x38, 0x63, 0x18, 0x79, 0xf4, 0xf7, 0xcc,
            0x10, 0x07, 0xc4,
        ];
        let c = Calibration::from_nvm(&nvm);
        assert_eq!(c.t1, 7_040_000.0); // 27500 * 2^8
        assert_eq!(c.t2, 19_000.0 / 1_073_741_824.0);
        assert_eq!(c.t3, -8.0 / 281_474_976_710_656.0);
        assert_eq!(c.p1, (400.0 - 16_384.0) / 1_048_576.0);
        assert_eq!(c.p2, (-2_600.0 - 16_384.0) / 536_870_912.0);
        assert_eq!(c.p3, 35.0 / 4_294_967_296.0);
        assert_eq!(c.p4, 1.0 / 137_438_953_472.0);
        assert_eq!(c.p5, 203_200.0); // 25400 * 8
        assert_eq!(c.p6, 484.375); // 31000 / 64
        assert_eq!(c.p7, -12.0 / 256.0);
        assert_eq!(c.p8, -9.0 / 32_768.0);
        assert_eq!(c.p9, 4_300.0 / 281_474_976_710_656.0);
        assert_eq!(c.p10, 7.0 / 281_474_976_710_656.0);
        assert_eq!(c.p11, -60.0 / 36_893_488_147_419_103_232.0);
        // the same bytes as the chip's registers hold
        let chip = Chip::new();
        let baro = Bmp388::new(chip, NAME.into()).unwrap();
        assert_eq!(baro.calibration(), &c);
    }

    #[test]
    fn a_reading_is_compensated_as_the_datasheet_says() {
        // exact values from the same formulas in rational arithmetic (Python's Fraction)
        for (raw_p, raw_t, exact_pa, exact_c) in [
            (7_081_512, 8_456_038, 101_325.008_679_976_66, 24.999_984_784_658_295),
            (7_300_000, 7_900_000, 95_564.115_958_975_97, 15.196_790_172_922_192),
        ] {
            let chip = Chip::new().with(|s| s.measuring = (raw_p, raw_t));
            let mut baro = Bmp388::new(chip.clone(), NAME.into()).unwrap();
            let r = baro.read().unwrap();
            let n = chip.log().len();
            assert_eq!(chip.log()[n - 2..], [Transfer::Read(0x02, 1), Transfer::Read(0x04, 6)]);
            let (pa, c) = datasheet(f64::from(raw_p), f64::from(raw_t));
            assert!((r.pressure_pa - pa).abs() < 0.01, "{r:?} vs {pa} Pa");
            assert!((r.temperature_c - c).abs() < 1e-9, "{r:?} vs {c} °C");
            assert!((r.pressure_pa - exact_pa).abs() < 0.01, "{r:?} vs {exact_pa} Pa");
            assert!((r.temperature_c - exact_c).abs() < 1e-9, "{r:?} vs {exact_c} °C");
        }
        // and the first is a plausible day: 1013 hPa at 25 °C
        let mut baro = Bmp388::new(Chip::new(), NAME.into()).unwrap();
        let r = baro.read().unwrap();
        assert!((r.pressure_pa - 101_325.0).abs() < 1.0 && (r.temperature_c - 25.0).abs() < 0.01, "{r:?}");
        // a count less is some 0.016 Pa more (the sensor's resolution at x8)
        baro.link.0.lock().unwrap().measuring.0 -= 1;
        let step = baro.read().unwrap().pressure_pa - r.pressure_pa;
        assert!((0.015..0.017).contains(&step), "{step}");
    }

    #[test]
    fn implausible_readings_are_refused_and_the_next_good_one_taken() {
        let chip = Chip::new();
        let mut baro = Bmp388::new(chip.clone(), NAME.into()).unwrap();
        let measure = |p: u32, t: u32| chip.0.lock().unwrap().measuring = (p, t);
        // raw 0 is some 215 kPa, the top of the range a negative pressure, 12 M 21 kPa; raw
        // temperature 0 is -126 °C (the pressure with it a plausible 66 kPa: refused all the same)
        for (p, t, want) in [
            (0, 8_456_038, "215276 Pa at 25.0 °C (raw 0x000000, 0x810766)"),
            (0xff_ffff, 8_456_038, "-58417 Pa at 25.0 °C (raw 0xffffff, 0x810766)"),
            (12_000_000, 8_456_038, "21287 Pa at 25.0 °C (raw 0xb71b00, 0x810766)"),
            (7_081_512, 0, "66426 Pa at -126.0 °C (raw 0x6c0e28, 0x000000)"),
        ] {
            measure(p, t);
            let e = error(baro.read());
            assert!(e.starts_with(&format!("{NAME}: the barometer's reading, ")), "{e}");
            assert!(e.contains(want) && e.ends_with("is outside 30000..110000 Pa or -40..85 °C: refused"), "{e}");
        }
        measure(7_081_512, 8_456_038);
        assert!((baro.read().unwrap().pressure_pa - 101_325.0).abs() < 1.0);
    }

    #[test]
    fn a_chip_that_reset_or_reports_an_error_is_not_read() {
        let chip = Chip::new();
        let mut baro = Bmp388::new(chip.clone(), NAME.into()).unwrap();
        // a power glitch: the chip sleeps with its reset values, which alone would read ~80 kPa
        chip.0.lock().unwrap().power_on();
        let would = baro.calibration().compensate(RESET_RAW, RESET_RAW);
        assert!(PRESSURE_RANGE_PA.contains(&would.pressure_pa), "{would:?}");
        let e = error(baro.read());
        assert!(e.starts_with(&format!("{NAME}: the barometer's data registers hold their reset value")), "{e}");
        // a fatal error
        chip.0.lock().unwrap().registers[usize::from(ERR_REG)] = FATAL_ERR;
        assert_eq!(
            error(baro.read()),
            format!("{NAME}: the barometer reports a fatal error while measuring (ERR_REG 0x01)")
        );
    }

    #[test]
    fn settings_the_chip_refuses_or_a_chip_that_never_measures_fail_the_setup() {
        let refusing = Chip::new().with(|s| s.refuse_config = true);
        assert_eq!(
            error(Bmp388::new(refusing, NAME.into())),
            format!(
                "{NAME}: the barometer reports a refused configuration (it stays asleep) on starting (ERR_REG 0x04)"
            )
        );
        let stalled = Chip::new().with(|s| s.stall = true);
        let started = Instant::now();
        assert_eq!(
            error(Bmp388::new(stalled.clone(), NAME.into())),
            format!("{NAME}: the barometer gave no measurement within 200 ms of starting (STATUS 0x10)")
        );
        assert!(started.elapsed() >= FIRST_MEASUREMENT_WITHIN);
        assert!(stalled.log().len() > 10, "STATUS polled");
    }

    #[test]
    fn a_failed_transfer_says_what_was_being_done() {
        for (register, want) in [
            (CHIP_ID, "cannot read the barometer's CHIP_ID (0x00)"),
            (CMD, "cannot soft-reset the barometer (CMD 0x7e <- 0xb6)"),
            (NVM_PAR_T1, "cannot read the barometer's trimming coefficients (0x31..0x45)"),
            (CONFIG, "cannot write 0x04 to the barometer's register 0x1f"),
        ] {
            let dead = Chip::new().with(|s| s.fail_at = Some(register));
            let e = error(Bmp388::new(dead, NAME.into()));
            let os = std::io::Error::from_raw_os_error(libc::EREMOTEIO);
            assert_eq!(e, format!("{NAME}: {want}: {os}"));
        }
        let chip = Chip::new();
        let mut baro = Bmp388::new(chip.clone(), NAME.into()).unwrap();
        chip.0.lock().unwrap().fail_at = Some(DATA_0);
        let e = error(baro.read());
        assert!(e.starts_with(&format!("{NAME}: cannot read the barometer's data registers (0x04..0x09): ")), "{e}");
        // the bus back: readings again
        chip.0.lock().unwrap().fail_at = None;
        assert!(baro.read().is_ok());
    }

    #[test]
    fn it_works_as_a_boxed_barometer() {
        let mut baro: Box<dyn Barometer> = Box::new(Bmp388::new(Chip::new(), NAME.into()).unwrap());
        assert_eq!(baro.describe(), NAME);
        assert!(PRESSURE_RANGE_PA.contains(&baro.read().unwrap().pressure_pa));
    }
}
