//! Real depth cameras as [`FrameSource`](crate::source::FrameSource)s, behind cargo
//! features so the default build needs no camera library.
//!
//! - `openni2` ([`openni2`]): PrimeSense-family structured-light cameras (the Asus
//!   Xtion Pro Live of Taylor 2017, Kinect v1 through its OpenNI2 driver) via the
//!   OpenNI2 C API. Build with `apt-get install libopenni2-dev` and
//!   `cargo build -p sensor-agent --features openni2`.
//!
//! **Untested with hardware**: no camera was attached where this was written. It
//! compiles and links against Debian's OpenNI2 2.2, and without a device it reports
//! the missing device as an error; the first run with a real Xtion should check the
//! depth orientation (mirroring off), the 1 mm unit and the FOV-derived intrinsics
//! against a wall at a tape-measured distance.

pub mod openni2;
