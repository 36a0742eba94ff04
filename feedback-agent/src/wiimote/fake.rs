//! A fake HID bus for tests and benchmarks: remotes can be attached, detached and made
//! to fail mid-write; every report written is recorded with its wall-clock stamp, and
//! queued input reports are played back on read.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};

use super::link::{HidBus, HidLink, LinkError, RemoteId};

/// One report written to a fake remote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// Remote path.
    pub path: String,
    /// Exact bytes.
    pub bytes: Vec<u8>,
    /// When it was written, ns since the epoch.
    pub at_ns: u64,
}

#[derive(Debug, Default)]
struct FakeRemote {
    id: Option<RemoteId>,
    attached: bool,
    /// Incremented on every detach so links opened before it fail.
    generation: u64,
    inputs: VecDeque<Vec<u8>>,
}

#[derive(Debug, Default)]
struct State {
    remotes: Vec<FakeRemote>,
    written: Vec<Written>,
}

/// Shared handle: clone it into the backend and keep one to drive and inspect.
#[derive(Debug, Clone, Default)]
pub struct FakeHid {
    state: Arc<Mutex<State>>,
}

impl FakeHid {
    /// A bus with no remotes.
    pub fn new() -> Self {
        Self::default()
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Attach (or re-attach) a remote at `path` with `serial` (a node freed by one remote
    /// can come back with another).
    pub fn attach(&self, path: &str, serial: &str) {
        let mut s = self.lock();
        let id = RemoteId { path: path.into(), serial: serial.into() };
        match s.remotes.iter_mut().find(|r| r.id.as_ref().is_some_and(|i| i.path == path)) {
            Some(r) => {
                r.attached = true;
                r.id = Some(id);
            }
            None => s.remotes.push(FakeRemote { id: Some(id), attached: true, ..Default::default() }),
        }
    }

    /// Detach the remote at `path`: its open links fail from now on.
    pub fn detach(&self, path: &str) {
        let mut s = self.lock();
        if let Some(r) = s.remotes.iter_mut().find(|r| r.id.as_ref().is_some_and(|i| i.path == path)) {
            r.attached = false;
            r.generation += 1;
            r.inputs.clear();
        }
    }

    /// Queue an input report for the remote at `path`.
    pub fn push_input(&self, path: &str, bytes: &[u8]) {
        let mut s = self.lock();
        if let Some(r) = s.remotes.iter_mut().find(|r| r.id.as_ref().is_some_and(|i| i.path == path)) {
            r.inputs.push_back(bytes.to_vec());
        }
    }

    /// Everything written so far.
    pub fn written(&self) -> Vec<Written> {
        self.lock().written.clone()
    }

    /// Bytes written to `path`, in order.
    pub fn written_to(&self, path: &str) -> Vec<Vec<u8>> {
        self.lock().written.iter().filter(|w| w.path == path).map(|w| w.bytes.clone()).collect()
    }

    /// Forget what was written.
    pub fn clear_written(&self) {
        self.lock().written.clear();
    }
}

struct FakeLink {
    hid: FakeHid,
    path: String,
    generation: u64,
}

impl FakeLink {
    fn check(&self, s: &State) -> Result<usize, LinkError> {
        s.remotes
            .iter()
            .position(|r| {
                r.attached && r.generation == self.generation && r.id.as_ref().is_some_and(|i| i.path == self.path)
            })
            .ok_or_else(|| LinkError(format!("{}: device disconnected", self.path)))
    }
}

impl HidLink for FakeLink {
    fn write(&mut self, report: &[u8]) -> Result<(), LinkError> {
        let hid = self.hid.clone();
        let mut s = hid.lock();
        self.check(&s)?;
        s.written.push(Written { path: self.path.clone(), bytes: report.to_vec(), at_ns: bus::now_ns() });
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8]) -> Result<usize, LinkError> {
        let hid = self.hid.clone();
        let mut s = hid.lock();
        let k = self.check(&s)?;
        match s.remotes[k].inputs.pop_front() {
            Some(bytes) => {
                let n = bytes.len().min(buf.len());
                buf[..n].copy_from_slice(&bytes[..n]);
                Ok(n)
            }
            None => Ok(0),
        }
    }
}

impl HidBus for FakeHid {
    fn remotes(&mut self) -> Result<Vec<RemoteId>, LinkError> {
        let s = self.lock();
        let mut ids: Vec<RemoteId> = s.remotes.iter().filter(|r| r.attached).filter_map(|r| r.id.clone()).collect();
        ids.sort();
        Ok(ids)
    }

    fn open(&mut self, id: &RemoteId) -> Result<Box<dyn HidLink>, LinkError> {
        let s = self.lock();
        let r = s
            .remotes
            .iter()
            .find(|r| r.attached && r.id.as_ref() == Some(id))
            .ok_or_else(|| LinkError(format!("{}: no such device", id.path)))?;
        Ok(Box::new(FakeLink { hid: self.clone(), path: id.path.clone(), generation: r.generation }))
    }
}
