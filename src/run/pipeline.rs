//! `hooke run` as a library call: given a prepared scene (see [`crate::run::prepare`]), start the
//! simulation thread and the recorder thread, join them, and say how it went.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crossbeam_channel::Sender;

use crate::backend::{Backend, StopFlags};
use crate::error::{Error, Result};
use crate::record::rrd_file::RrdFile;
use crate::record::viewer::{LinkState, ViewerLink};
use crate::record::{RecordError, RecordOptions, Recorder, digesting};
use crate::run::pacing::{LongFrames, Pacer, RecorderPace, SimPace, paced};
use crate::run::prepare::Prepared;
use crate::run::progress::{Progress, ProgressMode};
use crate::run::sim::{self, Delivery};
use crate::run::solver_watch::{SolverWatch, watching};
use crate::state::Snapshot;

/// Snapshots in flight between the threads: enough to smooth out a slow log call, small enough
/// that a large scene's snapshots do not pile up in memory.
pub const CHANNEL_CAPACITY: usize = 4;

/// How often the recorder looks up from waiting for a frame (to say that frames are long).
const LISTEN: std::time::Duration = std::time::Duration::from_millis(250);

#[derive(Debug, Clone)]
pub struct RunOptions {
    pub delivery: Delivery,
    /// A bar on a terminal, lines in a log, or nothing.
    pub progress: ProgressMode,
    /// `--realtime`: never run ahead of the wall clock.
    pub realtime: bool,
    /// What the recording holds (`--springs`, `--masses`).
    pub record: RecordOptions,
    /// The live viewer to watch, when streaming to one.
    pub viewer: Option<ViewerWatch>,
    /// The `.rrd` file being written, if any: watched for a failed write, ended after the run.
    pub file: Option<RrdFile>,
}

impl RunOptions {
    /// How the layout framed on the whole run takes effect at its end
    /// (`record::Takes::at_run_end`).
    pub fn end_framing_takes(&self) -> crate::record::Takes {
        crate::record::Takes::at_run_end(self.viewer.as_ref().map(|v| v.file.is_some()))
    }

    /// A run that nobody watches: every frame recorded (into `file`, when given, else where the
    /// recording stream goes), no progress shown, as fast as it goes, the default recording.
    pub fn unattended(file: Option<RrdFile>) -> Self {
        Self {
            delivery: Delivery::Lossless,
            progress: ProgressMode::Off,
            realtime: false,
            record: RecordOptions::default(),
            viewer: None,
            file,
        }
    }
}

/// A live viewer, and where the run goes on if it goes away.
#[derive(Debug, Clone)]
pub struct ViewerWatch {
    pub link: ViewerLink,
    /// The file recorded beside the viewer: the run finishes into it. Without one, the run stops.
    pub file: Option<std::path::PathBuf>,
}

#[derive(Debug)]
pub struct RunSummary {
    pub backend: String,
    pub frames_recorded: u64,
    pub frames_dropped: u64,
    pub sim_time_secs: f64,
    pub wall_secs: f64,
    pub cancelled: bool,
    /// What the run's watch said on the way (a solver short of its rule, energy from nowhere),
    /// each as printed.
    pub notes: Vec<String>,
}

/// Run a scene into `rec`. On divergence every good frame is recorded and flushed before the
/// error is returned.
pub fn run(
    prepared: Prepared,
    rec: rerun::RecordingStream,
    opts: &RunOptions,
    cancel: Arc<AtomicBool>,
) -> Result<RunSummary> {
    let Prepared {
        loaded,
        settings,
        model,
        backend: be,
    } = prepared;
    let settings = &settings;
    let backend_name = be.describe();
    let watch = SolverWatch::new(&model, settings);
    let mut recorder = Recorder::new(rec.clone(), model, opts.record);
    recorder
        .log_static(&loaded.scene.name, &loaded.text, settings, &backend_name)
        .map_err(|e| Error::Rerun(e.into()))?;

    let start = std::time::Instant::now();
    let mut progress = Progress::new(opts.progress, settings.frames + 1, &loaded.scene.name);
    // Each snapshot's reductions over every spring are made on the simulation thread, before
    // --realtime holds it (so that its release is not delayed by them).
    let be = digesting(be, recorder.digester());
    // A solver stuck short of its rule stops the run; what the watch notes rides on the frame.
    let be = watching(be, watch);
    let be: Box<dyn Backend> = if opts.realtime {
        paced(be, Pacer::start(settings.frame_rate_hz))
    } else {
        be
    };
    // The recorder hands logged snapshots back so that their buffers are reused.
    let (back_tx, back_rx) = crossbeam_channel::bounded(CHANNEL_CAPACITY + 2);
    let (frames, substeps) = (settings.frames, settings.substeps);
    let simulate = move |tx: &Sender<Snapshot>, stop: sim::Stop<'_>| {
        let mut be = be;
        sim::simulate(
            be.as_mut(),
            frames,
            substeps,
            tx,
            opts.delivery,
            stop,
            Some(&back_rx),
        )
    };
    let mut notes = Vec::new();
    let log = |snap: Snapshot, progress: &mut Progress| {
        for note in &snap.notes {
            progress.suspend(|| eprintln!("{note}"));
            notes.push(note.to_string());
        }
        recorder.log_snapshot(&snap)?;
        let frame = snap.frame;
        // Back to the simulation for reuse; if its queue is full, just drop it.
        let _ = back_tx.try_send(snap);
        Ok(frame)
    };
    let threads = Threads {
        opts,
        cancel: &cancel,
        frame_rate_hz: settings.frame_rate_hz,
    };
    let (outcome, recorded, mut recorder_error) =
        threads.simulate_and_record(simulate, log, &mut progress);
    progress.finish();
    if recorder_error.is_none() {
        recorder_error = recorder
            .frame_what_was_seen(opts.end_framing_takes())
            .err()
            .map(|e| Error::Rerun(e.into()));
    }
    let outcome = end_recording(&rec, opts, outcome, recorder_error)?;
    if let Some(e) = outcome.failed {
        return Err(Error::Backend(e));
    }
    Ok(RunSummary {
        backend: backend_name,
        frames_recorded: recorded,
        frames_dropped: outcome.frames_dropped,
        sim_time_secs: settings.frames.min(outcome.frames_sent.saturating_sub(1)) as f64
            / settings.frame_rate_hz,
        wall_secs: start.elapsed().as_secs_f64(),
        cancelled: outcome.cancelled,
        notes,
    })
}

/// The end of a recording, whatever ended the run: what was logged reaches the sink before the
/// run reports, and the file is ended. A recorder's error (a full disk, a viewer gone with no
/// file beside it) or a thread's panic is the run's error; otherwise the simulation's outcome.
pub(crate) fn end_recording(
    rec: &rerun::RecordingStream,
    opts: &RunOptions,
    outcome: Result<sim::SimOutcome>,
    recorder_error: Option<Error>,
) -> Result<sim::SimOutcome> {
    if let Some(gone @ Error::ViewerGone { .. }) = recorder_error {
        // Nothing more can reach that viewer; do not wait for it.
        let _ = rec.flush_with_timeout(std::time::Duration::from_millis(200));
        return Err(gone);
    }
    let flushed = rec.flush_blocking();
    if let Some(file) = &opts.file {
        // A failed write explains a failed flush better than the flush does.
        file.finish().map_err(Error::WriteRecording)?;
    }
    flushed.map_err(Error::FlushRun)?;
    let outcome = outcome?;
    if let Some(e) = recorder_error {
        return Err(e);
    }
    Ok(outcome)
}

/// What the two threads of a run share: its options, its stop, and its frame rate.
pub(crate) struct Threads<'a> {
    pub opts: &'a RunOptions,
    pub cancel: &'a Arc<AtomicBool>,
    pub frame_rate_hz: f64,
}

impl Threads<'_> {
    /// The simulation thread running `simulate` and the recorder thread handing each frame it
    /// sends to `log` (which returns the frame's number), joined: how the simulation ended, the
    /// frames recorded, and why the recorder stopped early, if it did.
    pub(crate) fn simulate_and_record<F: Send>(
        &self,
        simulate: impl FnOnce(&Sender<F>, sim::Stop<'_>) -> sim::SimOutcome + Send,
        log: impl FnMut(F, &mut Progress) -> std::result::Result<u64, RecordError> + Send,
        progress: &mut Progress,
    ) -> (Result<sim::SimOutcome>, u64, Option<Error>) {
        let (tx, rx) = crossbeam_channel::bounded(CHANNEL_CAPACITY);
        // Set by the recorder when it can take no more: the simulation stops within a chunk.
        let halt = Arc::new(AtomicBool::new(false));
        let flags = StopFlags::new([self.cancel.clone(), halt.clone()]);
        let pace = SimPace::default();
        std::thread::scope(|scope| {
            let sim = std::thread::Builder::new()
                .name("hooke-sim".into())
                .spawn_scoped(scope, {
                    let cancel = self.cancel.clone();
                    let (halt, pace, flags) = (&halt, &pace, &flags);
                    move || {
                        let stop = sim::Stop {
                            interrupt: &cancel,
                            halt: Some(halt),
                            pace: Some(pace),
                            within_steps: Some(flags),
                        };
                        simulate(&tx, stop)
                    }
                });
            let rec_thread = std::thread::Builder::new()
                .name("hooke-record".into())
                .spawn_scoped(scope, || {
                    let recording = Recording {
                        progress,
                        opts: self.opts,
                        halt: &halt,
                        frame_rate_hz: self.frame_rate_hz,
                        pace: &pace,
                    };
                    recording.record(rx, log)
                });
            match (sim, rec_thread) {
                (Ok(s), Ok(r)) => {
                    let outcome = s
                        .join()
                        .map_err(|p| Error::panicked(p.as_ref(), Error::SimulationPanicked));
                    let rec_out = r
                        .join()
                        .map_err(|p| Error::panicked(p.as_ref(), Error::RecorderPanicked));
                    match (outcome, rec_out) {
                        (Ok(o), Ok((n, err))) => (Ok(o), n, err),
                        (Err(e), _) | (_, Err(e)) => (Err(e), 0, None),
                    }
                }
                (Err(e), _) | (_, Err(e)) => (Err(Error::SpawnThread(e)), 0, None),
            }
        })
    }
}

/// The recorder thread's side of a run.
struct Recording<'a> {
    progress: &'a mut Progress,
    opts: &'a RunOptions,
    /// Set when the recorder can take no more.
    halt: &'a AtomicBool,
    frame_rate_hz: f64,
    /// How fast the simulation makes frames by itself.
    pace: &'a SimPace,
}

impl Recording<'_> {
    /// Log every frame `rx` brings: the frames recorded, and why recording stopped early, if it
    /// did. The receiver is owned here, so that returning early drops it: the simulation then
    /// stops at its next frame instead of stepping on with nobody to record.
    fn record<F>(
        self,
        rx: crossbeam_channel::Receiver<F>,
        mut log: impl FnMut(F, &mut Progress) -> std::result::Result<u64, RecordError>,
    ) -> (u64, Option<Error>) {
        let Recording {
            progress,
            opts,
            halt,
            frame_rate_hz,
            pace,
        } = self;
        let mut recorded = 0u64;
        let mut recorder_pace = RecorderPace::default();
        let mut viewer_lost = false;
        let mut long_frames = LongFrames::default();
        let stop_simulation = |e: Error| {
            halt.store(true, Ordering::SeqCst);
            // Returning drops the receiver as well, which a waiting simulation sees.
            Some(e)
        };
        loop {
            // Waiting long for a frame is when to say that frames are long.
            let f = match rx.recv_timeout(LISTEN) {
                Ok(f) => f,
                Err(crossbeam_channel::RecvTimeoutError::Timeout) => {
                    let left = progress.frames_total().saturating_sub(recorded);
                    if let Some(say) = long_frames.waiting(pace, left) {
                        progress.suspend(|| eprintln!("note: {say}"));
                    }
                    continue;
                }
                Err(crossbeam_channel::RecvTimeoutError::Disconnected) => break,
            };
            long_frames.frame();
            let started = std::time::Instant::now();
            let frame = match log(f, progress) {
                Ok(frame) => frame,
                Err(e) => return (recorded, stop_simulation(Error::RecorderGone(e))),
            };
            if let Some(say) = recorder_pace.recorded(started.elapsed(), pace) {
                progress.suspend(|| eprintln!("{say}"));
            }
            // The flag first: the writer's lock may be held by a long write.
            let failed = opts.file.as_ref().filter(|f| f.failed());
            if let Some(failure) = failed.and_then(RrdFile::failure) {
                return (recorded, stop_simulation(Error::WriteRecording(failure)));
            }
            recorded += 1;
            progress.frame(recorded, frame as f64 / frame_rate_hz);
            // A lost viewer is said once; then the run finishes into the file, or stops.
            if let Some(w) = opts.viewer.as_ref().filter(|_| !viewer_lost)
                && let LinkState::Gone(why) = w.link.state()
            {
                viewer_lost = true;
                let Some(file) = &w.file else {
                    let gone = Error::ViewerGone {
                        url: w.link.url().to_owned(),
                        frame,
                        why,
                    };
                    return (recorded, Some(gone));
                };
                progress.suspend(|| {
                    eprintln!(
                        "the viewer at {} went away at frame {frame} ({why}); recording the rest of the run to {} only",
                        w.link.url(),
                        file.display()
                    )
                });
            }
        }
        (recorded, None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::BackendError;
    use crate::scene::settings::Overrides;
    use crate::state::{State, StepStats};

    /// A backend with a bug: it panics on its first step.
    struct PanicsWhenStepped;

    impl Backend for PanicsWhenStepped {
        fn describe(&self) -> String {
            "a backend that panics".to_owned()
        }
        fn watch(&mut self, _flags: StopFlags) {}
        fn advance(&mut self, _substeps: u32) -> Result<StepStats, BackendError> {
            let doing = "stepping";
            panic!("the test backend panicked while {doing}");
        }
        fn request_snapshot(&mut self, _frame: u64, _stats: StepStats) -> Result<(), BackendError> {
            Ok(())
        }
        fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError> {
            Ok(None)
        }
        fn state(&mut self) -> Result<State, BackendError> {
            Err(BackendError::Internal(
                crate::backend::Internal::SnapshotMissing,
            ))
        }
    }

    #[test]
    fn a_panicking_simulation_thread_is_reported_as_one_with_its_message() {
        let request = crate::run::prepare::Request {
            overrides: Overrides {
                frames: Some(2),
                substeps: Some(3),
                ..Overrides::default()
            },
            ..crate::run::prepare::Request::named("hair", crate::run::select::Device::cpu())
        };
        let planned =
            crate::run::prepare::plan(&request, &mut |_| {}).expect("the hair scene plans");
        let (rec, _storage) = rerun::RecordingStreamBuilder::new("hooke-test")
            .memory()
            .expect("an in-memory recording");
        let opts = RunOptions::unattended(None);
        let cancel = Arc::new(AtomicBool::new(false));
        let prepared = Prepared {
            loaded: planned.loaded,
            settings: planned.settings,
            model: planned.model,
            backend: Box::new(PanicsWhenStepped),
        };
        let result = run(prepared, rec, &opts, cancel);
        let Err(e) = result else {
            panic!("a run whose backend panics must fail");
        };
        assert!(
            matches!(&e, Error::SimulationPanicked(Some(m)) if m == "the test backend panicked while stepping"),
            "{e:?}"
        );
        assert_eq!(
            e.to_string(),
            "the simulation thread panicked: the test backend panicked while stepping"
        );
    }
}
