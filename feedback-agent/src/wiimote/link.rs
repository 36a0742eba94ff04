//! The HID device behind a narrow trait: the real one is hidapi on hidraw; tests use
//! [`super::fake::FakeHid`], which records exact bytes and plays back input reports.

use std::ffi::CString;

use hidapi::HidApi;

use super::protocol::{PRODUCT_RVL_CNT_01, PRODUCT_RVL_CNT_01_TR, VENDOR_NINTENDO};

/// A HID failure: the remote went away, or the OS refused access.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct LinkError(pub String);

/// Identity of one attached remote.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct RemoteId {
    /// OS path (`/dev/hidraw3`).
    pub path: String,
    /// Serial number as the HID layer reports it (the Bluetooth address on Linux), or "".
    pub serial: String,
}

/// One open remote.
pub trait HidLink: Send {
    /// Write one output report (report id first).
    fn write(&mut self, report: &[u8]) -> Result<(), LinkError>;

    /// Read one waiting input report into `buf` without blocking; `Ok(0)` when none.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, LinkError>;
}

/// Finds and opens remotes.
pub trait HidBus: Send {
    /// The remotes attached now, in a stable order.
    fn remotes(&mut self) -> Result<Vec<RemoteId>, LinkError>;

    /// Open one.
    fn open(&mut self, id: &RemoteId) -> Result<Box<dyn HidLink>, LinkError>;
}

/// hidapi's Linux-native backend (hidraw + udev, no C library).
#[derive(Default)]
pub struct HidapiBus {
    api: Option<HidApi>,
}

impl HidapiBus {
    /// A bus that initialises hidapi on first use (and retries if that fails).
    pub fn new() -> Self {
        Self::default()
    }
}

fn err(context: &str, e: impl std::fmt::Display) -> LinkError {
    LinkError(format!("{context}: {e}"))
}

impl HidBus for HidapiBus {
    fn remotes(&mut self) -> Result<Vec<RemoteId>, LinkError> {
        if self.api.is_none() {
            self.api = Some(HidApi::new().map_err(|e| err("cannot initialise hidapi", e))?);
        }
        let Some(api) = self.api.as_mut() else {
            return Ok(Vec::new());
        };
        api.reset_devices().map_err(|e| err("hidapi", e))?;
        for product in [PRODUCT_RVL_CNT_01, PRODUCT_RVL_CNT_01_TR] {
            api.add_devices(VENDOR_NINTENDO, product).map_err(|e| err("cannot enumerate HID devices", e))?;
        }
        let mut ids: Vec<RemoteId> = api
            .device_list()
            .map(|d| RemoteId {
                path: d.path().to_string_lossy().into_owned(),
                serial: d.serial_number().unwrap_or("").to_string(),
            })
            .collect();
        ids.sort();
        ids.dedup_by(|a, b| a.path == b.path);
        Ok(ids)
    }

    fn open(&mut self, id: &RemoteId) -> Result<Box<dyn HidLink>, LinkError> {
        let api = self.api.as_ref().ok_or_else(|| LinkError("hidapi not initialised".into()))?;
        let path = CString::new(id.path.as_str()).map_err(|e| err("bad HID path", e))?;
        let device = api.open_path(&path).map_err(|e| err(&format!("cannot open {}", id.path), e))?;
        Ok(Box::new(HidapiLink { device }))
    }
}

struct HidapiLink {
    device: hidapi::HidDevice,
}

impl HidLink for HidapiLink {
    fn write(&mut self, report: &[u8]) -> Result<(), LinkError> {
        self.device.write(report).map(|_| ()).map_err(|e| err("HID write failed", e))
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<usize, LinkError> {
        self.device.read_timeout(buf, 0).map_err(|e| err("HID read failed", e))
    }
}
