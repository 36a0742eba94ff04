//! A real IMU on the cane, beside a camera that has none (the Xtion's OpenNI2 frames
//! carry no gravity, so the compute agent looks for lower ground along the path only
//! and tells the user "No tilt sensor"). An InvenSense MPU-6050 (the common 6-axis
//! board, I2C) gives the frames gravity and the cane's turn rate:
//!
//! - [`I2cLink`]: the narrow trait the driver talks through; [`LinuxI2c`] is the
//!   kernel's `/dev/i2c-N` (i2c-dev: `ioctl(I2C_SLAVE)`, then plain reads and writes).
//! - [`mpu6050::Mpu6050`]: wakes the chip, sets 100 Hz sampling, a 44 Hz low-pass, ±2 g
//!   and ±500 °/s, checks `WHO_AM_I`, and reads one sample (14 bytes) per call.
//! - [`AxisMap`]: the board's axes in the camera's optical frame (x right, y down,
//!   z forward), as mounted.
//! - [`GravityFilter`]: gravity from the accelerometer while the cane is still enough
//!   (the specific force within 15 % of g), low-passed; none after a second without
//!   such a sample, so a frame never carries a stale or swinging "down".
//! - [`WithImu`]: any [`FrameSource`] with an IMU read at each frame: the frame gets
//!   the sample and the gravity. A failed read is counted and logged, and that frame
//!   goes without (the compute agent then treats it as a frame without IMU).
//!
//! **Untested with hardware**: no IMU was attached where this was written; the tests
//! check the bytes it writes and the values it makes of the bytes it reads.

pub mod mpu6050;

use std::fs::File;
use std::io::{Read, Write};
use std::os::fd::AsRawFd;
use std::path::Path;

use schemas::ImuSample;

use crate::source::{FailedReads, FrameSource, SourceError, SourceFrame};

/// Standard gravity, m/s².
pub const G: f32 = 9.806_65;

/// Why the IMU could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ImuError {
    /// The bus could not be opened or a transfer failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The system's error.
        source: std::io::Error,
    },
    /// The chip answered, but not as an MPU-6050 does.
    #[error("{0}")]
    Device(String),
    /// A spec (`--imu`, `--imu-axes`) could not be read.
    #[error("{0}")]
    Spec(String),
}

/// One device on an I2C bus (its address chosen when opened).
pub trait I2cLink: Send {
    /// Writes `bytes` in one transfer.
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()>;
    /// Writes `bytes`, then reads `into.len()` bytes.
    fn write_read(&mut self, bytes: &[u8], into: &mut [u8]) -> std::io::Result<()>;
}

/// The kernel's i2c-dev interface (`/dev/i2c-N`; `modprobe i2c-dev`).
pub struct LinuxI2c {
    file: File,
}

/// `I2C_SLAVE` from `linux/i2c-dev.h`: the address the following reads and writes go to.
const I2C_SLAVE: libc::c_ulong = 0x0703;

impl LinuxI2c {
    /// Opens `path` for the 7-bit `address`.
    pub fn open(path: &Path, address: u8) -> Result<Self, ImuError> {
        let io = |what: String| move |source| ImuError::Io { what, source };
        let file = File::options()
            .read(true)
            .write(true)
            .open(path)
            .map_err(io(format!("cannot open {} (is i2c-dev loaded, and may this user use it?)", path.display())))?;
        // SAFETY: a valid open descriptor and an integer argument, as i2c-dev expects.
        let r = unsafe { libc::ioctl(file.as_raw_fd(), I2C_SLAVE as _, libc::c_ulong::from(address)) };
        if r < 0 {
            return Err(io(format!("cannot address 0x{address:02x} on {}", path.display()))(
                std::io::Error::last_os_error(),
            ));
        }
        Ok(Self { file })
    }
}

impl I2cLink for LinuxI2c {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.file.write_all(bytes)
    }

    fn write_read(&mut self, bytes: &[u8], into: &mut [u8]) -> std::io::Result<()> {
        self.file.write_all(bytes)?;
        self.file.read_exact(into)
    }
}

/// An IMU read once a frame.
pub trait Imu: Send {
    /// Short description for logs (`mpu6050:/dev/i2c-1@0x68`).
    fn describe(&self) -> String;
    /// One sample, stamped `stamp_ns`, in the board's own axes.
    fn read(&mut self, stamp_ns: u64) -> Result<ImuSample, ImuError>;
}

/// The board's axes in the camera's optical frame: camera axis `i` is board axis
/// `axis[i]` times `sign[i]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisMap {
    axis: [usize; 3],
    sign: [i8; 3],
}

impl Default for AxisMap {
    /// The board mounted with its axes along the camera's (x right, y down, z forward).
    fn default() -> Self {
        Self { axis: [0, 1, 2], sign: [1, 1, 1] }
    }
}

impl AxisMap {
    /// Reads `X,Y,Z` where each names the board axis (with its sign) that points along
    /// the camera's x (right), y (down) and z (forward): `-y,-z,x` is a board lying
    /// flat behind the camera with its x forward and z up. Each axis once.
    pub fn parse(s: &str) -> Result<Self, ImuError> {
        let bad = || {
            ImuError::Spec(format!(
                "--imu-axes {s:?}: give three of x, y, z, each once, each signed or not (e.g. -y,-z,x)"
            ))
        };
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        if parts.len() != 3 {
            return Err(bad());
        }
        let mut map = Self { axis: [0; 3], sign: [1; 3] };
        for (i, p) in parts.iter().enumerate() {
            let (sign, name) = match p.strip_prefix('-') {
                Some(rest) => (-1, rest),
                None => (1, p.strip_prefix('+').unwrap_or(p)),
            };
            map.axis[i] = match name {
                "x" => 0,
                "y" => 1,
                "z" => 2,
                _ => return Err(bad()),
            };
            map.sign[i] = sign;
        }
        let mut seen = map.axis;
        seen.sort_unstable();
        if seen != [0, 1, 2] {
            return Err(bad());
        }
        Ok(map)
    }

    /// A board-frame vector in the camera frame.
    pub fn apply(&self, v: [f32; 3]) -> [f32; 3] {
        [0, 1, 2].map(|i| f32::from(self.sign[i]) * v[self.axis[i]])
    }
}

/// Gravity from the accelerometer, while the cane is still enough to say where down is.
#[derive(Debug, Clone, Default)]
pub struct GravityFilter {
    /// Low-passed specific force (camera frame) and the stamp of its last still sample.
    state: Option<([f32; 3], u64)>,
}

impl GravityFilter {
    /// The low-pass's time constant, seconds.
    pub const TIME_CONSTANT_S: f32 = 0.3;
    /// A sample counts when its specific force is within this share of g.
    pub const STILL_WITHIN: f32 = 0.15;
    /// Without a still sample for this long, no gravity, nanoseconds.
    pub const STALE_NS: u64 = 1_000_000_000;

    /// Takes a sample (camera frame) and returns gravity now (unit, towards the floor),
    /// if known.
    pub fn add(&mut self, sample: &ImuSample) -> Option<[f32; 3]> {
        let a = sample.accel_m_s2;
        let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let still = norm.is_finite() && (norm - G).abs() <= Self::STILL_WITHIN * G;
        if still {
            self.state = Some(match self.state {
                Some((f, t)) if sample.stamp_ns > t => {
                    let dt = (sample.stamp_ns - t) as f32 * 1e-9;
                    let k = 1.0 - (-dt / Self::TIME_CONSTANT_S).exp();
                    ([0, 1, 2].map(|i| f[i] + k * (a[i] - f[i])), sample.stamp_ns)
                }
                _ => (a, sample.stamp_ns),
            });
        }
        self.gravity(sample.stamp_ns)
    }

    /// Gravity at `now_ns` from the samples so far.
    pub fn gravity(&self, now_ns: u64) -> Option<[f32; 3]> {
        let (f, t) = self.state?;
        if now_ns.saturating_sub(t) > Self::STALE_NS {
            return None;
        }
        let n = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        // at rest the specific force points up: gravity is the other way
        (n > 0.0).then(|| f.map(|x| -x / n))
    }
}

/// A frame source whose frames get an IMU sample and gravity at each frame.
pub struct WithImu {
    source: Box<dyn FrameSource>,
    imu: Box<dyn Imu>,
    axes: AxisMap,
    gravity: GravityFilter,
    failed_reads: FailedReads,
}

impl WithImu {
    /// `source`'s frames with `imu`, mounted as `axes` says.
    pub fn new(source: Box<dyn FrameSource>, imu: Box<dyn Imu>, axes: AxisMap) -> Self {
        Self { source, imu, axes, gravity: GravityFilter::default(), failed_reads: FailedReads::default() }
    }

    /// Reads that failed (their frames went without IMU).
    pub fn failed_reads(&self) -> u64 {
        self.failed_reads.get()
    }
}

impl FrameSource for WithImu {
    fn describe(&self) -> String {
        format!("{} + {}", self.source.describe(), self.imu.describe())
    }

    fn next_frame(&mut self, now_ns: u64) -> Result<Option<SourceFrame>, SourceError> {
        let Some(mut frame) = self.source.next_frame(now_ns)? else { return Ok(None) };
        match self.imu.read(frame.stamp_ns) {
            Ok(s) => {
                let sample = ImuSample {
                    stamp_ns: s.stamp_ns,
                    gyro_rad_s: self.axes.apply(s.gyro_rad_s),
                    accel_m_s2: self.axes.apply(s.accel_m_s2),
                };
                frame.gravity_camera = self.gravity.add(&sample);
                frame.imu.push(sample);
            }
            Err(e) => {
                self.failed_reads.count(&self.imu.describe(), "IMU", &e);
                frame.gravity_camera = self.gravity.gravity(frame.stamp_ns);
            }
        }
        Ok(Some(frame))
    }

    fn period_ns(&self) -> u64 {
        self.source.period_ns()
    }
}

/// Opens the IMU a spec names: `mpu6050:/dev/i2c-N[@ADDRESS]` (address 0x68 by default,
/// 0x69 with its AD0 pin high).
pub fn open(spec: &str) -> Result<Box<dyn Imu>, ImuError> {
    let Some(rest) = spec.strip_prefix("mpu6050:") else {
        return Err(ImuError::Spec(format!("--imu {spec:?}: use mpu6050:/dev/i2c-N[@0x68]")));
    };
    let (path, address) = match rest.rsplit_once('@') {
        Some((p, a)) => {
            let digits = a.strip_prefix("0x").or_else(|| a.strip_prefix("0X"));
            let parsed = match digits {
                Some(hex) => u8::from_str_radix(hex, 16),
                None => a.parse::<u8>(),
            };
            match parsed {
                Ok(v) if v < 0x80 => (p, v),
                _ => return Err(ImuError::Spec(format!("--imu {spec:?}: {a:?} is not a 7-bit I2C address"))),
            }
        }
        None => (rest, mpu6050::DEFAULT_ADDRESS),
    };
    if path.is_empty() {
        return Err(ImuError::Spec(format!("--imu {spec:?}: name the bus, e.g. mpu6050:/dev/i2c-1")));
    }
    let link = LinuxI2c::open(Path::new(path), address)?;
    let imu = mpu6050::Mpu6050::new(link, format!("mpu6050:{path}@0x{address:02x}"))?;
    Ok(Box::new(imu))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_data::Camera;

    fn still(stamp_ns: u64, accel: [f32; 3]) -> ImuSample {
        ImuSample { stamp_ns, gyro_rad_s: [0.0; 3], accel_m_s2: accel }
    }

    #[test]
    fn axes_are_read_with_their_signs_and_each_once() {
        let m = AxisMap::parse("-y, -z, x").unwrap();
        // a board flat behind the camera, x forward, z up: at rest it reads +g on z
        assert_eq!(m.apply([0.0, 0.0, G]), [0.0, -G, 0.0]);
        assert_eq!(m.apply([1.0, 2.0, 3.0]), [-2.0, -3.0, 1.0]);
        assert_eq!(AxisMap::parse("x,y,z").unwrap(), AxisMap::default());
        assert_eq!(AxisMap::parse("+x,y,-z").unwrap().apply([1.0, 1.0, 1.0]), [1.0, 1.0, -1.0]);
        for bad in ["x,x,z", "x,y", "x,y,w", "x,y,z,x", ""] {
            assert!(AxisMap::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn gravity_is_down_while_still_and_gone_a_second_after_the_cane_swings() {
        let mut f = GravityFilter::default();
        // a camera pitched 30 degrees down: up is -y turned towards -z
        let (s, c) = 30f32.to_radians().sin_cos();
        let up = [0.0, -c * G, -s * G];
        let g = f.add(&still(0, up)).unwrap();
        assert!((g[1] - c).abs() < 1e-6 && (g[2] - s).abs() < 1e-6, "{g:?}");
        // a swing (1.5 g) is not taken, and the last gravity holds for a second
        let g = f.add(&still(500_000_000, [0.0, -1.5 * G, 0.0])).unwrap();
        assert!((g[1] - c).abs() < 1e-6, "{g:?}");
        assert_eq!(f.add(&still(1_100_000_000, [0.0, -1.5 * G, 0.0])), None);
        // still again, level now: the low-pass moves to it within a second
        let mut t = 1_100_000_000;
        for _ in 0..30 {
            t += 33_333_333;
            f.add(&still(t, [0.0, -G, 0.0]));
        }
        let g = f.gravity(t).unwrap();
        assert!((g[1] - 1.0).abs() < 0.01, "{g:?}");
        assert_eq!(f.add(&still(t + 1, [f32::NAN, 0.0, 0.0])).map(|g| g[1] > 0.99), Some(true));
    }

    /// A board lying flat, x forward, z up, turning left at 0.5 rad/s; every third
    /// read fails.
    struct Board(u32);

    impl Imu for Board {
        fn describe(&self) -> String {
            "board".into()
        }

        fn read(&mut self, stamp_ns: u64) -> Result<ImuSample, ImuError> {
            self.0 += 1;
            if self.0.is_multiple_of(3) {
                return Err(ImuError::Device("no answer".into()));
            }
            Ok(ImuSample { stamp_ns, gyro_rad_s: [0.0, 0.0, 0.5], accel_m_s2: [0.0, 0.0, G] })
        }
    }

    #[test]
    fn a_camera_without_imu_sends_the_boards_sample_and_gravity_in_its_own_axes() {
        let mut s = WithImu::new(Box::new(Camera(0)), Box::new(Board(0)), AxisMap::parse("-y,-z,x").unwrap());
        assert_eq!(s.describe(), "openni2:test + board");
        assert_eq!(s.period_ns(), 33_333_333);
        let frames: Vec<SourceFrame> = (0..6).map(|_| s.next_frame(0).unwrap().unwrap()).collect();
        for (k, f) in frames.iter().enumerate() {
            // level camera: down is +y; the board's turn about its z (up) is the
            // camera's turn about -y
            assert_eq!(f.gravity_camera, Some([0.0, 1.0, 0.0]), "frame {k}");
            if k % 3 == 2 {
                assert!(f.imu.is_empty(), "frame {k}: a failed read sends no sample");
            } else {
                assert_eq!(f.imu.len(), 1);
                assert_eq!(f.imu[0].stamp_ns, f.stamp_ns);
                assert_eq!(f.imu[0].gyro_rad_s, [0.0, -0.5, 0.0]);
                assert_eq!(f.imu[0].accel_m_s2, [0.0, -G, 0.0]);
            }
        }
        assert_eq!(s.failed_reads(), 2);
    }

    #[test]
    fn specs_name_the_bus_and_address_or_say_how() {
        for (spec, want) in [
            ("bmi160:/dev/i2c-1", "use mpu6050:/dev/i2c-N"),
            ("mpu6050:", "name the bus"),
            ("mpu6050:/dev/i2c-1@0x80", "not a 7-bit I2C address"),
            ("mpu6050:/dev/i2c-1@zz", "not a 7-bit I2C address"),
            ("mpu6050:/nonexistent/i2c-9@0x69", "cannot open /nonexistent/i2c-9 (is i2c-dev loaded"),
        ] {
            let e = open(spec).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(e.contains(want), "{spec}: {e}");
        }
    }
}
