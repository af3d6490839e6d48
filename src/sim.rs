//! The simulation thread: steps the backend frame by frame and hands snapshots to the recorder
//! over a bounded channel.

use std::sync::atomic::{AtomicBool, Ordering};

use crossbeam_channel::{Receiver, Sender, TrySendError};

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
/// Snapshots are pipelined one frame deep: frame N is collected after frame N + 1's steps have
/// been handed to the backend, so a GPU keeps stepping while the host reads N back. Whatever
/// stops the run (divergence, a device fault, cancellation), every good frame already taken is
/// delivered first.
pub fn simulate(
    backend: &mut dyn Backend,
    frames: u64,
    substeps: u32,
    tx: &Sender<Snapshot>,
    delivery: Delivery,
    cancel: &AtomicBool,
    recycled: Option<&Receiver<Snapshot>>,
) -> SimOutcome {
    let mut out = SimOutcome {
        frames_sent: 0,
        frames_dropped: 0,
        cancelled: false,
        failed: None,
        recorder_gone: false,
    };
    // Sends one snapshot; false when the recorder has gone.
    let deliver = |out: &mut SimOutcome, snap: Snapshot| -> bool {
        let sent = match delivery {
            Delivery::Lossless => tx.send(snap).is_ok(),
            Delivery::DropWhenBusy => match tx.try_send(snap) {
                Ok(()) => true,
                Err(TrySendError::Full(_)) => {
                    out.frames_dropped += 1;
                    return true;
                }
                Err(TrySendError::Disconnected(_)) => false,
            },
        };
        if sent {
            out.frames_sent += 1;
        } else {
            out.recorder_gone = true;
        }
        sent
    };
    let mut healthy = match backend.request_snapshot(0, StepStats::default()) {
        Ok(()) => true,
        Err(e) => {
            out.failed = Some(e);
            false
        }
    };
    let mut frame = 1;
    while healthy && frame <= frames {
        if cancel.load(Ordering::Relaxed) {
            out.cancelled = true;
            break;
        }
        // Snapshots the recorder has finished with: their buffers are refilled, not reallocated.
        if let Some(rx) = recycled {
            for s in rx.try_iter() {
                backend.recycle(s);
            }
        }
        let stepped = backend
            .advance(substeps)
            .and_then(|stats| backend.request_snapshot(frame, stats));
        if let Err(e) = stepped {
            out.failed = Some(e);
            break;
        }
        match backend.collect_snapshot() {
            Ok(Some(snap)) => healthy = deliver(&mut out, snap),
            Ok(None) => {}
            Err(e) => {
                out.failed = Some(e);
                healthy = false;
            }
        }
        frame += 1;
    }
    // Deliver what is still pending, unless the state already went bad or the recorder left.
    while healthy {
        match backend.collect_snapshot() {
            Ok(Some(snap)) => healthy = deliver(&mut out, snap),
            Ok(None) => break,
            Err(e) => {
                out.failed.get_or_insert(e);
                break;
            }
        }
    }
    out
}
