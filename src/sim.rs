//! The simulation thread: steps the backend frame by frame and hands snapshots to the recorder
//! over a bounded channel.

use std::sync::atomic::{AtomicBool, Ordering};

use crossbeam_channel::{Sender, TrySendError};

use crate::backend::{Backend, BackendError};
use crate::state::{Snapshot, StepStats};

/// What happens when the recorder falls behind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delivery {
    /// The simulation waits: every snapshot is recorded (files).
    Lossless,
    /// The snapshot is dropped for display and counted; the simulation never stalls (live views).
    DropWhenBusy,
}

/// How a simulation ended.
#[derive(Debug)]
pub struct SimOutcome {
    /// Snapshots handed to the recorder (frame 0, the initial state, included).
    pub frames_sent: u64,
    /// Snapshots dropped because a live viewer could not keep up.
    pub frames_dropped: u64,
    pub cancelled: bool,
    /// Set when the state went bad or the device failed; every frame before it was sent.
    pub failed: Option<BackendError>,
    pub recorder_gone: bool,
}

/// Step `frames` frames of `substeps` steps each, sending the initial state and every frame.
pub fn simulate(
    backend: &mut dyn Backend,
    frames: u64,
    substeps: u32,
    tx: &Sender<Snapshot>,
    delivery: Delivery,
    cancel: &AtomicBool,
) -> SimOutcome {
    let mut out = SimOutcome {
        frames_sent: 0,
        frames_dropped: 0,
        cancelled: false,
        failed: None,
        recorder_gone: false,
    };
    let mut stats = StepStats::default();
    for frame in 0..=frames {
        if frame > 0 {
            if cancel.load(Ordering::Relaxed) {
                out.cancelled = true;
                break;
            }
            match backend.advance(substeps) {
                Ok(s) => stats = s,
                Err(e) => {
                    out.failed = Some(e);
                    break;
                }
            }
        }
        let snap = match backend.snapshot(frame, stats) {
            Ok(s) => s,
            Err(e) => {
                out.failed = Some(e);
                break;
            }
        };
        let sent = match delivery {
            Delivery::Lossless => tx.send(snap).map_err(|_| ()),
            Delivery::DropWhenBusy => match tx.try_send(snap) {
                Ok(()) => Ok(()),
                Err(TrySendError::Full(_)) => {
                    out.frames_dropped += 1;
                    continue;
                }
                Err(TrySendError::Disconnected(_)) => Err(()),
            },
        };
        if sent.is_err() {
            out.recorder_gone = true;
            break;
        }
        out.frames_sent += 1;
    }
    out
}
