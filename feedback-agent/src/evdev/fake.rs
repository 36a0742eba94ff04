//! Fake input nodes for tests: every ioctl (request number and the exact `ff_effect`
//! bytes) and every write is recorded per path; nodes can be unplugged and plugged
//! back, and the "kernel" hands out effect ids as the real one does (lowest free).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use super::ff::{FfEffect, FF_EFFECT_BYTES};
use super::{FfNode, FfOpener};

/// One system call made on a fake node.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Call {
    /// `ioctl(fd, request, &effect)`: the request and the effect bytes as passed in.
    Upload {
        /// ioctl request number.
        request: u64,
        /// The 48 bytes of `struct ff_effect` the kernel would read.
        effect: [u8; FF_EFFECT_BYTES],
    },
    /// `ioctl(fd, request, id)`.
    Remove {
        /// ioctl request number.
        request: u64,
        /// Effect id.
        id: i32,
    },
    /// `write(fd, bytes)`.
    Write(Vec<u8>),
}

#[derive(Debug, Default)]
struct State {
    /// Plugged nodes and their generation (bumped on unplug so open files fail).
    nodes: Vec<(PathBuf, u64, bool)>,
    /// Nodes that are input devices without force feedback (EVIOCSFF fails EINVAL).
    no_ff: Vec<PathBuf>,
    calls: Vec<(PathBuf, Call)>,
    next_id: i16,
}

/// Shared handle: clone it into the backend and keep one to drive and inspect.
#[derive(Debug, Clone, Default)]
pub struct FakeFf {
    state: Arc<Mutex<State>>,
}

impl FakeFf {
    /// No nodes.
    pub fn new() -> Self {
        Self::default()
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Plug (or plug back) a node at `path`.
    pub fn plug(&self, path: &str) {
        let mut s = self.lock();
        match s.nodes.iter_mut().find(|(p, _, _)| p == Path::new(path)) {
            Some(n) => n.2 = true,
            None => s.nodes.push((path.into(), 0, true)),
        }
    }

    /// Plug a node that has no force feedback (a keyboard, say).
    pub fn plug_without_ff(&self, path: &str) {
        self.plug(path);
        self.lock().no_ff.push(path.into());
    }

    /// Unplug the node at `path`: its open files fail from now on.
    pub fn unplug(&self, path: &str) {
        let mut s = self.lock();
        if let Some(n) = s.nodes.iter_mut().find(|(p, _, _)| p == Path::new(path)) {
            n.1 += 1;
            n.2 = false;
        }
    }

    /// Calls made on `path`, in order.
    pub fn calls_to(&self, path: &str) -> Vec<Call> {
        self.lock().calls.iter().filter(|(p, _)| p == Path::new(path)).map(|(_, c)| c.clone()).collect()
    }

    /// Forget the calls recorded so far.
    pub fn clear_calls(&self) {
        self.lock().calls.clear();
    }
}

struct FakeNode {
    ff: FakeFf,
    path: PathBuf,
    generation: u64,
}

impl FakeNode {
    fn record(&self, call: Call) -> std::io::Result<MutexGuard<'_, State>> {
        let mut s = self.ff.lock();
        let alive = s.nodes.iter().any(|(p, g, plugged)| *p == self.path && *g == self.generation && *plugged);
        if !alive {
            return Err(std::io::Error::from_raw_os_error(libc::ENODEV));
        }
        s.calls.push((self.path.clone(), call));
        Ok(s)
    }
}

impl FfNode for FakeNode {
    fn upload_effect(&mut self, request: u64, effect: &mut FfEffect) -> std::io::Result<()> {
        let mut s = self.record(Call::Upload { request, effect: *effect.as_bytes() })?;
        if s.no_ff.contains(&self.path) {
            return Err(std::io::Error::from_raw_os_error(libc::EINVAL));
        }
        if effect.id < 0 {
            effect.id = s.next_id;
            s.next_id += 1;
        }
        Ok(())
    }

    fn remove_effect(&mut self, request: u64, id: i32) -> std::io::Result<()> {
        self.record(Call::Remove { request, id }).map(|_| ())
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.record(Call::Write(bytes.to_vec())).map(|_| ())
    }
}

impl FfOpener for FakeFf {
    fn open(&mut self, path: &Path) -> std::io::Result<Box<dyn FfNode>> {
        let s = self.lock();
        match s.nodes.iter().find(|(p, _, plugged)| p == path && *plugged) {
            Some((_, generation, _)) => {
                Ok(Box::new(FakeNode { ff: self.clone(), path: path.into(), generation: *generation }))
            }
            None => Err(std::io::Error::from_raw_os_error(libc::ENOENT)),
        }
    }
}
