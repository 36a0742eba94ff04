//! OpenNI2 depth camera source, by hand-written FFI to `OniCAPI.h` (OpenNI 2.2):
//! `oniInitialize`, `oniDeviceOpen`, `oniDeviceCreateStream`, set the video mode
//! (640x480, 30 Hz, 1 mm depth) and mirroring off, `oniStreamStart`, then per frame
//! `oniWaitForAnyStream` + `oniStreamReadFrame` + `oniFrameRelease`.
//!
//! Intrinsics come from the stream's field of view, as OpenNI's own depth-to-world
//! converter does it: `fx = width / (2 tan(hfov / 2))`, `cx = width / 2`.

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::time::{SystemTime, UNIX_EPOCH};

use schemas::Intrinsics;

use crate::source::{FrameSource, SourceError, SourceFrame};

/// The C API, as declared in `OniCAPI.h`, `OniCTypes.h` and `OniCEnums.h`.
#[allow(non_camel_case_types)]
mod ffi {
    use std::ffi::{c_char, c_int, c_void};

    pub type OniStatus = c_int;
    pub const ONI_STATUS_OK: OniStatus = 0;
    pub const ONI_STATUS_TIME_OUT: OniStatus = 102;
    /// `ONI_CREATE_API_VERSION(2, 2)`.
    pub const ONI_API_VERSION: c_int = 2 * 1000 + 2;
    pub const ONI_SENSOR_DEPTH: c_int = 3;
    pub const ONI_PIXEL_FORMAT_DEPTH_1_MM: c_int = 100;
    pub const ONI_PIXEL_FORMAT_DEPTH_100_UM: c_int = 101;
    pub const ONI_STREAM_PROPERTY_HORIZONTAL_FOV: c_int = 1;
    pub const ONI_STREAM_PROPERTY_VERTICAL_FOV: c_int = 2;
    pub const ONI_STREAM_PROPERTY_VIDEO_MODE: c_int = 3;
    pub const ONI_STREAM_PROPERTY_MIRRORING: c_int = 7;

    #[repr(C)]
    pub struct OniDevice {
        _private: [u8; 0],
    }
    #[repr(C)]
    pub struct OniStream {
        _private: [u8; 0],
    }
    pub type OniDeviceHandle = *mut OniDevice;
    pub type OniStreamHandle = *mut OniStream;

    #[repr(C)]
    #[derive(Debug, Clone, Copy)]
    pub struct OniVideoMode {
        pub pixel_format: c_int,
        pub resolution_x: c_int,
        pub resolution_y: c_int,
        pub fps: c_int,
    }

    #[repr(C)]
    pub struct OniFrame {
        pub data_size: c_int,
        pub data: *mut c_void,
        pub sensor_type: c_int,
        pub timestamp: u64,
        pub frame_index: c_int,
        pub width: c_int,
        pub height: c_int,
        pub video_mode: OniVideoMode,
        pub cropping_enabled: c_int,
        pub crop_origin_x: c_int,
        pub crop_origin_y: c_int,
        pub stride: c_int,
    }

    #[link(name = "OpenNI2")]
    extern "C" {
        pub fn oniInitialize(api_version: c_int) -> OniStatus;
        pub fn oniShutdown();
        pub fn oniGetExtendedError() -> *const c_char;
        pub fn oniDeviceOpen(uri: *const c_char, device: *mut OniDeviceHandle) -> OniStatus;
        pub fn oniDeviceClose(device: OniDeviceHandle) -> OniStatus;
        pub fn oniDeviceCreateStream(device: OniDeviceHandle, sensor: c_int, stream: *mut OniStreamHandle)
            -> OniStatus;
        pub fn oniStreamDestroy(stream: OniStreamHandle);
        pub fn oniStreamStart(stream: OniStreamHandle) -> OniStatus;
        pub fn oniStreamStop(stream: OniStreamHandle);
        pub fn oniStreamSetProperty(stream: OniStreamHandle, id: c_int, data: *const c_void, size: c_int) -> OniStatus;
        pub fn oniStreamGetProperty(
            stream: OniStreamHandle,
            id: c_int,
            data: *mut c_void,
            size: *mut c_int,
        ) -> OniStatus;
        pub fn oniWaitForAnyStream(
            streams: *mut OniStreamHandle,
            count: c_int,
            ready: *mut c_int,
            timeout_ms: c_int,
        ) -> OniStatus;
        pub fn oniStreamReadFrame(stream: OniStreamHandle, frame: *mut *mut OniFrame) -> OniStatus;
        pub fn oniFrameRelease(frame: *mut OniFrame);
    }
}

/// Why the camera could not be opened or stopped delivering.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("OpenNI2 {call} failed (status {status}): {detail}")]
pub struct CameraError {
    /// The C function that failed.
    pub call: &'static str,
    /// Its `OniStatus`.
    pub status: i32,
    /// `oniGetExtendedError()` at the time.
    pub detail: String,
}

fn check(call: &'static str, status: ffi::OniStatus) -> Result<(), CameraError> {
    if status == ffi::ONI_STATUS_OK {
        return Ok(());
    }
    // SAFETY: oniGetExtendedError returns a NUL-terminated string owned by OpenNI (or
    // null), valid until the next OpenNI call; it is copied out at once.
    let detail = unsafe {
        let p = ffi::oniGetExtendedError();
        if p.is_null() {
            String::new()
        } else {
            // OpenNI indents its messages with a tab
            CStr::from_ptr(p).to_string_lossy().trim().to_owned()
        }
    };
    Err(CameraError { call, status, detail })
}

/// What to ask the camera for.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenNi2Options {
    /// Device URI (`None`: the first device found).
    pub uri: Option<String>,
    /// Depth image width, pixels.
    pub width: u32,
    /// Depth image height, pixels.
    pub height: u32,
    /// Frame rate, Hz.
    pub fps: u32,
    /// `next_frame` gives up waiting after this long and reports a skipped frame, so
    /// the agent's stall detection keeps running when the camera goes quiet.
    pub wait_ms: u32,
}

impl Default for OpenNi2Options {
    /// The Xtion Pro Live's VGA depth mode at 30 Hz (Taylor 2017 used it at VGA).
    fn default() -> Self {
        OpenNi2Options { uri: None, width: 640, height: 480, fps: 30, wait_ms: 200 }
    }
}

/// Pinhole intrinsics of an image `width` x `height` with the given fields of view,
/// by OpenNI's own projection.
pub fn intrinsics_from_fov(width: u32, height: u32, hfov_rad: f32, vfov_rad: f32) -> Intrinsics {
    Intrinsics {
        fx: width as f32 / (2.0 * (hfov_rad / 2.0).tan()),
        fy: height as f32 / (2.0 * (vfov_rad / 2.0).tan()),
        cx: width as f32 / 2.0,
        cy: height as f32 / 2.0,
    }
}

/// A depth stream from an OpenNI2 device.
pub struct OpenNi2Camera {
    device: ffi::OniDeviceHandle,
    stream: ffi::OniStreamHandle,
    description: String,
    intrinsics: Intrinsics,
    depth_scale_m: f32,
    period_ns: u64,
    wait_ms: u32,
}

// SAFETY: OpenNI2 device and stream handles are not tied to the thread that created
// them; this type is only ever used by one thread at a time (`&mut self`).
unsafe impl Send for OpenNi2Camera {}

impl OpenNi2Camera {
    /// Initialises OpenNI2, opens the device and starts its depth stream.
    pub fn open(opts: &OpenNi2Options) -> Result<OpenNi2Camera, CameraError> {
        let uri = match &opts.uri {
            Some(u) => Some(CString::new(u.as_str()).map_err(|_| CameraError {
                call: "oniDeviceOpen",
                status: -1,
                detail: "device URI contains a NUL byte".into(),
            })?),
            None => None,
        };
        // SAFETY: plain C calls with valid pointers to locals; each handle is checked
        // before use, and every handle created is released on the error paths (and in
        // Drop once the value exists).
        unsafe {
            check("oniInitialize", ffi::oniInitialize(ffi::ONI_API_VERSION))?;
            let mut device: ffi::OniDeviceHandle = std::ptr::null_mut();
            let uri_ptr: *const c_char = uri.as_ref().map_or(std::ptr::null(), |u| u.as_ptr());
            if let Err(e) = check("oniDeviceOpen", ffi::oniDeviceOpen(uri_ptr, &mut device)) {
                ffi::oniShutdown();
                return Err(e);
            }
            let mut stream: ffi::OniStreamHandle = std::ptr::null_mut();
            if let Err(e) =
                check("oniDeviceCreateStream", ffi::oniDeviceCreateStream(device, ffi::ONI_SENSOR_DEPTH, &mut stream))
            {
                ffi::oniDeviceClose(device);
                ffi::oniShutdown();
                return Err(e);
            }
            let mut camera = OpenNi2Camera {
                device,
                stream,
                description: format!("openni2:{}", opts.uri.as_deref().unwrap_or("any")),
                intrinsics: intrinsics_from_fov(opts.width, opts.height, 58f32.to_radians(), 45f32.to_radians()),
                depth_scale_m: 0.001,
                period_ns: 0,
                wait_ms: opts.wait_ms,
            };
            camera.configure(opts)?;
            check("oniStreamStart", ffi::oniStreamStart(stream))?;
            Ok(camera)
        }
    }

    /// Video mode, mirroring off, and the fields of view for the intrinsics.
    unsafe fn configure(&mut self, opts: &OpenNi2Options) -> Result<(), CameraError> {
        let mode = ffi::OniVideoMode {
            pixel_format: ffi::ONI_PIXEL_FORMAT_DEPTH_1_MM,
            resolution_x: opts.width as c_int,
            resolution_y: opts.height as c_int,
            fps: opts.fps as c_int,
        };
        check(
            "oniStreamSetProperty(VIDEO_MODE)",
            ffi::oniStreamSetProperty(
                self.stream,
                ffi::ONI_STREAM_PROPERTY_VIDEO_MODE,
                (&mode as *const ffi::OniVideoMode).cast::<c_void>(),
                std::mem::size_of::<ffi::OniVideoMode>() as c_int,
            ),
        )?;
        // OpenNI mirrors by default on some drivers; the optical frame is unmirrored.
        let off: c_int = 0;
        check(
            "oniStreamSetProperty(MIRRORING)",
            ffi::oniStreamSetProperty(
                self.stream,
                ffi::ONI_STREAM_PROPERTY_MIRRORING,
                (&off as *const c_int).cast::<c_void>(),
                std::mem::size_of::<c_int>() as c_int,
            ),
        )?;
        let mut fov = [0f32; 2];
        for (v, id) in
            fov.iter_mut().zip([ffi::ONI_STREAM_PROPERTY_HORIZONTAL_FOV, ffi::ONI_STREAM_PROPERTY_VERTICAL_FOV])
        {
            let mut size = std::mem::size_of::<f32>() as c_int;
            check(
                "oniStreamGetProperty(FOV)",
                ffi::oniStreamGetProperty(self.stream, id, (v as *mut f32).cast::<c_void>(), &mut size),
            )?;
        }
        if fov.iter().all(|f| f.is_finite() && *f > 0.1 && *f < 3.0) {
            self.intrinsics = intrinsics_from_fov(opts.width, opts.height, fov[0], fov[1]);
        }
        self.period_ns = 1_000_000_000 / u64::from(opts.fps.max(1));
        Ok(())
    }
}

impl Drop for OpenNi2Camera {
    fn drop(&mut self) {
        // SAFETY: the handles were created by `open` and are released exactly once.
        unsafe {
            ffi::oniStreamStop(self.stream);
            ffi::oniStreamDestroy(self.stream);
            ffi::oniDeviceClose(self.device);
            ffi::oniShutdown();
        }
    }
}

impl FrameSource for OpenNi2Camera {
    fn describe(&self) -> String {
        self.description.clone()
    }

    fn next_frame(&mut self, _now_ns: u64) -> Result<Option<SourceFrame>, SourceError> {
        let mut streams = [self.stream];
        let mut ready: c_int = -1;
        // SAFETY: `streams` and `ready` outlive the call; the frame pointer is checked
        // for null, its data read only within `data_size` and the dimensions it states,
        // and released exactly once.
        unsafe {
            let status = ffi::oniWaitForAnyStream(streams.as_mut_ptr(), 1, &mut ready, self.wait_ms as c_int);
            if status == ffi::ONI_STATUS_TIME_OUT {
                return Err(SourceError::Skipped {
                    what: self.description.clone(),
                    reason: format!("no depth frame within {} ms", self.wait_ms),
                });
            }
            check("oniWaitForAnyStream", status).map_err(|e| SourceError::Fatal(e.to_string()))?;
            let mut frame: *mut ffi::OniFrame = std::ptr::null_mut();
            check("oniStreamReadFrame", ffi::oniStreamReadFrame(self.stream, &mut frame))
                .map_err(|e| SourceError::Fatal(e.to_string()))?;
            if frame.is_null() {
                return Err(SourceError::Fatal("oniStreamReadFrame returned no frame".into()));
            }
            let result = copy_depth(&*frame, self.intrinsics, self.depth_scale_m);
            ffi::oniFrameRelease(frame);
            result.map(Some)
        }
    }

    fn period_ns(&self) -> u64 {
        0
    }
}

/// Copies one OpenNI depth frame into a [`SourceFrame`], honouring the row stride.
fn copy_depth(frame: &ffi::OniFrame, intrinsics: Intrinsics, mm_scale: f32) -> Result<SourceFrame, SourceError> {
    let bad = |reason: String| SourceError::Skipped { what: format!("openni2 frame {}", frame.frame_index), reason };
    let (w, h) = (frame.width.max(0) as usize, frame.height.max(0) as usize);
    let stride = frame.stride.max(0) as usize;
    let depth_scale_m = match frame.video_mode.pixel_format {
        ffi::ONI_PIXEL_FORMAT_DEPTH_1_MM => mm_scale,
        ffi::ONI_PIXEL_FORMAT_DEPTH_100_UM => mm_scale / 10.0,
        other => return Err(bad(format!("pixel format {other} is not a depth format"))),
    };
    if w == 0
        || h == 0
        || stride < 2 * w
        || frame.data.is_null()
        || (frame.data_size.max(0) as usize) < stride * (h - 1) + 2 * w
    {
        return Err(bad(format!("{w}x{h} frame with stride {stride} and {} bytes", frame.data_size)));
    }
    // SAFETY: data is non-null and holds at least `stride * (h - 1) + 2w` bytes (checked).
    let bytes = unsafe { std::slice::from_raw_parts(frame.data.cast::<u8>(), frame.data_size as usize) };
    let mut depth = Vec::with_capacity(w * h);
    for row in 0..h {
        let line = &bytes[row * stride..row * stride + 2 * w];
        depth.extend(line.chunks_exact(2).map(|b| u16::from_ne_bytes([b[0], b[1]])));
    }
    let stamp_ns = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64);
    Ok(SourceFrame::depth_only(stamp_ns, (w as u32, h as u32), depth_scale_m, intrinsics, depth))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xtion_fov_gives_its_known_focal_length() {
        // 58 x 45 degrees at VGA: fx ~ 570 px, the Xtion's usual calibration.
        let k = intrinsics_from_fov(640, 480, 58f32.to_radians(), 45f32.to_radians());
        assert!((k.fx - 577.3).abs() < 1.0 && (k.fy - 579.4).abs() < 1.0, "{k:?}");
        assert_eq!((k.cx, k.cy), (320.0, 240.0));
    }

    #[test]
    fn strided_frame_is_copied_row_by_row() {
        let mut data: Vec<u16> = vec![1, 2, 99, 3, 4, 99];
        let frame = ffi::OniFrame {
            data_size: 12,
            data: data.as_mut_ptr().cast(),
            sensor_type: ffi::ONI_SENSOR_DEPTH,
            timestamp: 0,
            frame_index: 7,
            width: 2,
            height: 2,
            video_mode: ffi::OniVideoMode {
                pixel_format: ffi::ONI_PIXEL_FORMAT_DEPTH_1_MM,
                resolution_x: 2,
                resolution_y: 2,
                fps: 30,
            },
            cropping_enabled: 0,
            crop_origin_x: 0,
            crop_origin_y: 0,
            stride: 6,
        };
        let k = intrinsics_from_fov(2, 2, 1.0, 1.0);
        let f = copy_depth(&frame, k, 0.001).unwrap();
        assert_eq!(f.depth, [1, 2, 3, 4]);
        let short = ffi::OniFrame { data_size: 8, ..frame };
        assert!(matches!(copy_depth(&short, k, 0.001), Err(SourceError::Skipped { .. })));
    }

    /// No camera is attached where the tests run (CI, most desks): opening the first
    /// device fails at `oniDeviceOpen` with OpenNI's reason, and nothing crashes or hangs.
    /// With a camera plugged in this test fails and says so.
    #[test]
    fn openni2_without_a_camera_fails_at_device_open_saying_no_devices_found() {
        let err = match OpenNi2Camera::open(&OpenNi2Options::default()) {
            Err(e) => e,
            Ok(cam) => panic!("{} opened: this test expects no camera attached", cam.describe()),
        };
        assert_eq!(
            err.to_string(),
            "OpenNI2 oniDeviceOpen failed (status 1): DeviceOpen using default: no devices found"
        );
    }

    #[test]
    fn openni2_unknown_device_uri_fails_at_device_open_naming_it() {
        let opts = OpenNi2Options { uri: Some("no-such-camera".into()), ..OpenNi2Options::default() };
        let err = OpenNi2Camera::open(&opts).err().expect("no device has that URI");
        assert_eq!(
            err.to_string(),
            "OpenNI2 oniDeviceOpen failed (status 6): DeviceOpen: Couldn't open device 'no-such-camera'"
        );
    }

    #[test]
    fn openni2_device_uri_with_a_nul_byte_is_refused_before_opening() {
        let opts = OpenNi2Options { uri: Some("usb\0camera".into()), ..OpenNi2Options::default() };
        let err = OpenNi2Camera::open(&opts).err().expect("refused");
        assert_eq!(err.to_string(), "OpenNI2 oniDeviceOpen failed (status -1): device URI contains a NUL byte");
    }
}
