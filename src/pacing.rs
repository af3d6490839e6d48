//! `--realtime`: a live view that never runs ahead of the wall clock.
//!
//! [`Paced`] wraps a backend and holds each snapshot until its time has come: frame k is handed
//! out no earlier than k / frame_rate seconds of wall time after the first. A run that cannot keep
//! up simply runs late; nothing is skipped to catch up.

use std::time::{Duration, Instant};

use crate::backend::{Backend, BackendError};
use crate::state::{Snapshot, State, StepStats};

/// The wall-clock schedule of frames.
#[derive(Debug, Clone, Copy)]
pub struct Pacer {
    start: Instant,
    frame_rate_hz: f64,
}

impl Pacer {
    /// Frame 0 is due now.
    pub fn start(frame_rate_hz: f64) -> Self {
        Self {
            start: Instant::now(),
            frame_rate_hz,
        }
    }

    /// When frame `frame` is due, from the start.
    pub fn due(&self, frame: u64) -> Duration {
        Duration::from_secs_f64(frame as f64 / self.frame_rate_hz)
    }

    /// Sleep until frame `frame` is due (at once if it is already).
    pub fn wait_for(&self, frame: u64) {
        let due = self.start + self.due(frame);
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
    }

    pub fn started(&self) -> Instant {
        self.start
    }
}

/// A backend whose snapshots are released on the wall clock's schedule. Stepping is not held
/// back: the next frame is stepped while this one waits (one frame ahead at most, since the
/// simulation thread waits on each snapshot).
pub struct Paced {
    inner: Box<dyn Backend>,
    pacer: Pacer,
}

impl Paced {
    pub fn new(inner: Box<dyn Backend>, pacer: Pacer) -> Self {
        Self { inner, pacer }
    }
}

impl Backend for Paced {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn advance(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        self.inner.advance(substeps)
    }
    fn request_snapshot(&mut self, frame: u64, stats: StepStats) -> Result<(), BackendError> {
        self.inner.request_snapshot(frame, stats)
    }
    fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError> {
        let snap = self.inner.collect_snapshot()?;
        if let Some(s) = &snap {
            self.pacer.wait_for(s.frame);
        }
        Ok(snap)
    }
    fn state(&mut self) -> Result<State, BackendError> {
        self.inner.state()
    }
    fn recycle(&mut self, snapshot: Snapshot) {
        self.inner.recycle(snapshot)
    }
    fn finish(&mut self) -> Result<(), BackendError> {
        self.inner.finish()
    }
    fn memory_bytes(&self) -> Option<u64> {
        self.inner.memory_bytes()
    }
}
