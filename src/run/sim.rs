//! The simulation thread: steps the backend frame by frame and hands snapshots to the recorder
//! over a bounded channel. A frame too long to wait for is stepped in chunks, so that a stop
//! (Ctrl-C, or a recorder that can take no more) takes effect within about [`CHUNK_SECS`]
//! whatever the frame's length.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender, TrySendError};

use crate::backend::{Backend, BackendError, StopFlags};
use crate::run::pacing::SimPace;
use crate::state::{Snapshot, StepStats};

/// Wall time one chunk of substeps aims at: a stop waits for at most the chunk in progress
/// (a single step that takes longer is not split).
pub const CHUNK_SECS: f64 = 0.05;

/// Most substeps in one chunk: bounds what a GPU submission encodes (its stage slots).
pub const MAX_CHUNK_SUBSTEPS: u32 = 4096;

/// What ends stepping before the last frame, checked before every frame and between chunks.
#[derive(Debug, Clone, Copy)]
pub struct Stop<'a> {
    /// The user asked (Ctrl-C, SIGTERM): the run ends as interrupted.
    pub interrupt: &'a AtomicBool,
    /// The recorder can take no more (a full disk, say): the run ends with its error.
    pub halt: Option<&'a AtomicBool>,
    /// Where the simulation notes how long it takes to make each frame by itself.
    pub pace: Option<&'a SimPace>,
    /// The same flags, for the backends to watch inside a step (a step may be long: VBD's
    /// sweeps, Newton's iterations); without them a stop waits for the step in progress.
    pub within_steps: Option<&'a StopFlags>,
}

impl Stop<'_> {
    /// Hand the flags to `backend`, where there are any.
    fn watched_by(&self, backend: &mut dyn Backend) {
        if let Some(flags) = self.within_steps {
            backend.watch(flags.clone());
        }
    }

    fn requested(&self) -> bool {
        self.interrupt.load(Ordering::Relaxed)
            || self.halt.is_some_and(|h| h.load(Ordering::Relaxed))
    }
}

impl<'a> From<&'a AtomicBool> for Stop<'a> {
    fn from(interrupt: &'a AtomicBool) -> Self {
        Self {
            interrupt,
            halt: None,
            pace: None,
            within_steps: None,
        }
    }
}

/// Chooses how many substeps go to the backend at once, from the time the last ones took.
/// A frame that fits in [`CHUNK_SECS`] goes whole, as one submission: a GPU then reads the last
/// frame back while it steps this one. A longer frame goes in chunks of about `CHUNK_SECS`,
/// each waited for, so that at most one chunk is ever queued when a stop comes. The results do
/// not depend on the split: every backend steps the same substeps in the same order.
#[derive(Debug, Default)]
pub struct Chunker {
    /// Wall seconds per substep, as last measured; unknown before the first chunk.
    secs_per_substep: Option<f64>,
    last_chunk: u32,
}

impl Chunker {
    /// Whether a frame of `substeps` goes to the backend whole.
    pub fn whole(&self, substeps: u32) -> bool {
        self.secs_per_substep
            .is_some_and(|c| c * f64::from(substeps) <= CHUNK_SECS)
            && substeps <= MAX_CHUNK_SUBSTEPS
    }

    /// The next chunk, at most `remaining`: one substep while the cost is unknown, then what
    /// fits in `CHUNK_SECS`, growing at most fourfold per chunk so that a first measurement
    /// inflated by fixed costs is corrected step by step.
    pub fn next(&mut self, remaining: u32) -> u32 {
        let n = match self.secs_per_substep {
            None => 1,
            Some(c) => {
                let fits = (CHUNK_SECS / c.max(1e-12)).clamp(1.0, f64::from(MAX_CHUNK_SUBSTEPS));
                (fits as u32).min(self.last_chunk.saturating_mul(4).max(1))
            }
        };
        self.last_chunk = n.min(remaining).max(1);
        self.last_chunk
    }

    /// `substeps` took `elapsed` of wall time.
    pub fn observe(&mut self, substeps: u32, elapsed: Duration) {
        if substeps > 0 {
            self.secs_per_substep = Some(elapsed.as_secs_f64() / f64::from(substeps));
            self.last_chunk = self.last_chunk.max(substeps);
        }
    }
}

/// Step one frame of `substeps`, in chunks where it is long. `Ok(None)`: a stop came first, and
/// the frame in progress is abandoned (never snapshotted).
fn step_frame(
    backend: &mut dyn Backend,
    substeps: u32,
    chunker: &mut Chunker,
    stop: Stop<'_>,
) -> Result<Option<StepStats>, BackendError> {
    // A step the stop cut short is unconverged: its frame is dropped, whatever it returned.
    let unless_stopped = |stepped: Result<StepStats, BackendError>| match stepped {
        _ if stop.requested() => Ok(None),
        other => other.map(Some),
    };
    if chunker.whole(substeps) {
        return unless_stopped(backend.advance(substeps));
    }
    let mut stats: Option<StepStats> = None;
    let mut done = 0;
    while done < substeps {
        if stop.requested() {
            return Ok(None);
        }
        let n = chunker.next(substeps - done);
        let start = Instant::now();
        let Some(s) = unless_stopped(backend.advance(n).and_then(|s| {
            // Wait for it: the chunk's real cost is known, and nothing more is queued.
            backend.finish().map(|()| s)
        }))?
        else {
            return Ok(None);
        };
        chunker.observe(n, start.elapsed());
        if let Some(p) = stop.pace {
            p.stepped(substeps, start.elapsed() / n);
        }
        stats = Some(stats.map_or(s, |acc| acc.merged(&s)));
        done += n;
    }
    Ok(stats)
}

/// What happens when the recorder falls behind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delivery {
    /// The simulation waits: every snapshot is recorded (files).
    Lossless,
    /// The snapshot is dropped for display and counted; the simulation never stalls (live views).
    DropWhenBusy,
}

/// How a simulation ended.
#[derive(Debug, Default)]
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
pub fn simulate<'a>(
    backend: &mut dyn Backend,
    frames: u64,
    substeps: u32,
    tx: &Sender<Snapshot>,
    delivery: Delivery,
    stop: impl Into<Stop<'a>>,
    recycled: Option<&Receiver<Snapshot>>,
) -> SimOutcome {
    let stop: Stop<'a> = stop.into();
    stop.watched_by(backend);
    let mut out = SimOutcome::default();
    let deliver = |out: &mut SimOutcome, snap: Snapshot| deliver(tx, delivery, out, snap);
    let mut healthy = backend
        .request_snapshot(0, StepStats::default())
        .map_err(|e| out.failed = Some(e))
        .is_ok();
    let mut chunker = Chunker::default();
    let mut frame = 1;
    while healthy && frame <= frames {
        if stop.requested() {
            break;
        }
        // Snapshots the recorder has finished with: their buffers are refilled, not reallocated.
        if let Some(rx) = recycled {
            for s in rx.try_iter() {
                backend.recycle(s);
            }
        }
        let whole = chunker.whole(substeps);
        if !whole {
            // A long frame: the last one goes to the recorder now, not once this one is done.
            match backend.collect_snapshot() {
                Ok(Some(snap)) => healthy = deliver(&mut out, snap),
                Ok(None) => {}
                Err(e) => {
                    out.failed = Some(e);
                    healthy = false;
                }
            }
            if !healthy {
                break;
            }
        }
        let start = Instant::now();
        let stepped = step_frame(backend, substeps, &mut chunker, stop).and_then(|stats| {
            stats
                .map(|stats| backend.request_snapshot(frame, stats))
                .transpose()
        });
        match stepped {
            Ok(Some(())) => {}
            // Stopped mid-frame: the frames before it are still delivered below.
            Ok(None) => break,
            Err(e) => {
                out.failed = Some(e);
                break;
            }
        }
        // After a long frame its own snapshot stays pending, one frame deep as ever: the next
        // frame's steps are queued before it is read back.
        let collected = match whole {
            true => backend.collect_snapshot(),
            false => Ok(None),
        };
        if let Some(p) = stop.pace {
            p.made(start.elapsed());
        }
        if whole {
            // A whole frame's cost, the wait for the last frame's read-back included: on a GPU
            // that wait is where the stepping time shows.
            chunker.observe(substeps, start.elapsed());
        }
        match collected {
            Ok(Some(snap)) => healthy = deliver(&mut out, snap),
            Ok(None) => {}
            Err(e) => {
                out.failed = Some(e);
                healthy = false;
            }
        }
        frame += 1;
    }
    out.cancelled = stop.interrupt.load(Ordering::Relaxed) && frame <= frames;
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

/// Send one frame as `delivery` says; false when the recorder has gone.
fn deliver<F>(tx: &Sender<F>, delivery: Delivery, out: &mut SimOutcome, snap: F) -> bool {
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
}

/// One frame of a comparison: each entry's snapshot (`None` for an entry that has stopped), and
/// the entries that stopped at this frame, with why.
#[derive(Debug)]
pub struct ComparedFrame {
    pub frame: u64,
    pub snapshots: Vec<Option<Snapshot>>,
    pub stopped: Vec<(usize, BackendError)>,
}

/// [`simulate`] for the entries of a comparison, in lockstep: each frame steps every entry still
/// running (`substeps[i]` steps of its own dt), all at once, each on a thread of its own, and
/// sends their snapshots together. An entry whose state goes bad or whose device fails stops
/// alone: its last good frame stays, and the others go on. A stop ends them all; the frame in
/// progress is abandoned.
pub fn simulate_all<'a>(
    backends: &mut [Box<dyn Backend>],
    frames: u64,
    substeps: &[u32],
    tx: &Sender<ComparedFrame>,
    delivery: Delivery,
    stop: impl Into<Stop<'a>>,
) -> SimOutcome {
    let stop: Stop<'a> = stop.into();
    for b in backends.iter_mut() {
        stop.watched_by(b.as_mut());
    }
    let n = backends.len();
    let mut out = SimOutcome::default();
    let mut live = vec![true; n];
    let mut first = ComparedFrame {
        frame: 0,
        snapshots: Vec::with_capacity(n),
        stopped: Vec::new(),
    };
    for (i, b) in backends.iter_mut().enumerate() {
        match b.snapshot(0, StepStats::default()) {
            Ok(s) => first.snapshots.push(Some(s)),
            Err(e) => {
                live[i] = false;
                first.snapshots.push(None);
                first.stopped.push((i, e));
            }
        }
    }
    if !deliver(tx, delivery, &mut out, first) {
        return out;
    }
    let mut chunkers: Vec<Chunker> = (0..n).map(|_| Chunker::default()).collect();
    let mut frame = 1;
    while frame <= frames && live.contains(&true) {
        if stop.requested() {
            break;
        }
        // The entries step at once, each on a thread of its own: a backend steps the same
        // substeps in the same order whatever else runs, and the CPU backend's pool, or the
        // GPUs, take work from all of them.
        let stepped: Vec<(usize, Stepped)> = std::thread::scope(|scope| {
            let running: Vec<_> = backends
                .iter_mut()
                .zip(chunkers.iter_mut())
                .enumerate()
                .filter(|(i, _)| live[*i])
                .map(|(i, (be, chunker))| {
                    let n = substeps[i];
                    (
                        i,
                        scope.spawn(move || step_entry(be.as_mut(), n, chunker, frame, stop)),
                    )
                })
                .collect();
            running
                .into_iter()
                .map(|(i, h)| {
                    let s = h.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
                    (i, s)
                })
                .collect()
        });
        let mut this = ComparedFrame {
            frame,
            snapshots: (0..n).map(|_| None).collect(),
            stopped: Vec::new(),
        };
        let mut interrupted = false;
        for (i, s) in stepped {
            match s {
                Stepped::Frame(snap) => this.snapshots[i] = Some(*snap),
                // Stopped mid-frame: this frame is abandoned, the ones before it delivered.
                Stepped::Interrupted => interrupted = true,
                Stepped::Failed(e) => {
                    live[i] = false;
                    this.stopped.push((i, e));
                }
            }
        }
        if interrupted || !deliver(tx, delivery, &mut out, this) {
            break;
        }
        frame += 1;
    }
    out.cancelled = stop.interrupt.load(Ordering::Relaxed) && frame <= frames;
    out
}

/// How one entry's frame went.
enum Stepped {
    Frame(Box<Snapshot>),
    /// A stop came mid-frame.
    Interrupted,
    Failed(BackendError),
}

/// One entry's frame `frame`: its substeps, then its snapshot.
fn step_entry(
    be: &mut dyn Backend,
    substeps: u32,
    chunker: &mut Chunker,
    frame: u64,
    stop: Stop<'_>,
) -> Stepped {
    let whole = chunker.whole(substeps);
    let start = Instant::now();
    let stepped = step_frame(be, substeps, chunker, stop)
        .and_then(|stats| stats.map(|st| be.request_snapshot(frame, st)).transpose());
    match stepped {
        Ok(Some(())) => {}
        Ok(None) => return Stepped::Interrupted,
        Err(e) => return Stepped::Failed(e),
    }
    let collected = be.collect_snapshot();
    if whole {
        chunker.observe(substeps, start.elapsed());
    }
    match collected {
        Ok(Some(snap)) => Stepped::Frame(Box::new(snap)),
        // A backend hands back every snapshot it was asked for.
        Ok(None) => Stepped::Failed(BackendError::Internal(
            crate::backend::Internal::SnapshotMissing,
        )),
        Err(e) => Stepped::Failed(e),
    }
}
