//! `hooke run --compare` as a library call: a prepared comparison (see
//! [`crate::run::prepare::prepare_comparison`]) stepped in lockstep on the simulation thread and
//! recorded on the recorder thread into one recording, each entry under its own name
//! ([`crate::record::CompareRecorder`]). An entry that stops (a divergence, a device fault)
//! stops alone; what it recorded stays.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use crossbeam_channel::Sender;

use crate::backend::{Backend, BackendError};
use crate::error::{Error, Result};
use crate::record::{CompareLayout, CompareRecorder, EntryName, EntryTally};
use crate::run::pacing::{Pacer, paced};
use crate::run::prepare::PreparedComparison;
use crate::run::progress::Progress;
use crate::run::sim::{self, ComparedFrame};
use crate::run::solver_watch::{SolverWatch, watching};
use crate::run::{RunOptions, Threads, end_recording};
use crate::scene::compare_entry::CompareEntry;

/// How one entry's run went.
#[derive(Debug)]
pub struct EntryOutcome {
    pub entry: CompareEntry,
    pub tally: EntryTally,
    /// The frame it stopped at and why, for an entry that did not reach the end.
    pub stopped: Option<(u64, BackendError)>,
}

impl EntryOutcome {
    /// One line for the end of a run: wall seconds per simulated second, the final RMS gap to
    /// the reference and the energy drift, or where it stopped.
    pub fn line(&self, reference: bool) -> String {
        let t = &self.tally;
        let cost = if t.sim_secs > 0.0 {
            format!(
                "{:.3} wall-s per simulated s",
                1e-3 * t.step_ms / t.sim_secs
            )
        } else {
            "no simulated time".to_owned()
        };
        let gap = match (reference, t.last_gap_rms_m) {
            (true, _) => "the reference".to_owned(),
            (false, Some(g)) => format!("final RMS gap {g:.3e} m"),
            (false, None) => "no gap (the reference stopped first)".to_owned(),
        };
        let drift = t.drift_pct().map_or_else(
            || "no energy".to_owned(),
            |d| format!("energy drift {d:+.3}%"),
        );
        let end = match &self.stopped {
            Some((frame, _)) => format!("; stopped at frame {frame}"),
            None => String::new(),
        };
        format!("{:<24} {cost}, {gap}, {drift}{end}", t.label)
    }
}

#[derive(Debug)]
pub struct ComparisonSummary {
    pub backend: String,
    pub entries: Vec<EntryOutcome>,
    pub frames_recorded: u64,
    pub frames_dropped: u64,
    pub wall_secs: f64,
    pub cancelled: bool,
}

/// Run a comparison into `rec`: every entry's frames, side by side (or overlaid, as `layout`
/// says), until the last frame, a stop, or every entry has stopped.
pub fn run_comparison(
    prepared: PreparedComparison,
    rec: rerun::RecordingStream,
    opts: &RunOptions,
    layout: CompareLayout,
    cancel: Arc<AtomicBool>,
) -> Result<ComparisonSummary> {
    let PreparedComparison {
        loaded,
        model,
        entries,
    } = prepared;
    let Some(first) = entries.first() else {
        return Ok(ComparisonSummary {
            backend: String::new(),
            entries: Vec::new(),
            frames_recorded: 0,
            frames_dropped: 0,
            wall_secs: 0.0,
            cancelled: false,
        });
    };
    let backend_name = first.backend.describe();
    let (frames, frame_rate_hz) = (first.settings.frames, first.settings.frame_rate_hz);
    let names: Vec<EntryName> = entries
        .iter()
        .map(|e| EntryName {
            path: e.name.clone(),
            label: e.label.clone(),
        })
        .collect();
    let settings: Vec<_> = entries.iter().map(|e| e.settings.clone()).collect();
    let substeps: Vec<u32> = settings.iter().map(|s| s.substeps).collect();
    let which: Vec<CompareEntry> = entries.iter().map(|e| e.entry.clone()).collect();
    let watches: Vec<SolverWatch> = entries
        .iter()
        .map(|e| SolverWatch::new(&model, &e.settings))
        .collect();
    let mut recorder = CompareRecorder::new(rec.clone(), model, opts.record, &names, layout);
    recorder
        .log_static(&loaded.scene.name, &loaded.text, &settings, &backend_name)
        .map_err(|e| Error::Rerun(e.into()))?;
    let mut backends: Vec<Box<dyn Backend>> = entries
        .into_iter()
        .zip(watches)
        .map(|(e, watch)| -> Box<dyn Backend> {
            // Each entry's solver is watched on its own: one stuck entry stops alone.
            let watched = watching(e.backend, watch);
            if opts.realtime {
                paced(watched, Pacer::start(frame_rate_hz))
            } else {
                watched
            }
        })
        .collect();

    let start = std::time::Instant::now();
    let mut progress = Progress::new(opts.progress, frames + 1, &loaded.scene.name);
    let simulate = |tx: &Sender<ComparedFrame>, stop: sim::Stop<'_>| {
        sim::simulate_all(&mut backends, frames, &substeps, tx, opts.delivery, stop)
    };
    let mut stopped: Vec<Option<(u64, BackendError)>> = names.iter().map(|_| None).collect();
    let log = |f: ComparedFrame, progress: &mut Progress| {
        for (i, e) in f.stopped {
            // Said in full once, at the end; here only that it happened.
            let what = match &e {
                BackendError::Diverged(_) => "diverged",
                BackendError::Unconverged(_) => "did not converge",
                BackendError::Unphysical(_) => "broke its energy ledger",
                BackendError::Device(_) => "its device failed",
                BackendError::Internal(_) => "hit an internal error",
            };
            progress.suspend(|| {
                eprintln!(
                    "entry {} {what} at frame {}: its frames before are recorded, and the other entries go on",
                    names[i].label, f.frame
                )
            });
            stopped[i] = Some((f.frame, e));
        }
        for (name, snap) in names.iter().zip(&f.snapshots) {
            for note in snap.iter().flat_map(|s| &s.notes) {
                progress.suspend(|| eprintln!("entry {}: {note}", name.label));
            }
        }
        let snaps: Vec<_> = f.snapshots.iter().map(Option::as_ref).collect();
        recorder.log_frame(&snaps)?;
        Ok(f.frame)
    };
    let threads = Threads {
        opts,
        cancel: &cancel,
        frame_rate_hz,
    };
    let (outcome, recorded, recorder_error) =
        threads.simulate_and_record(simulate, log, &mut progress);
    progress.finish();
    let outcome = end_recording(&rec, opts, outcome, recorder_error)?;
    let entries = which
        .into_iter()
        .zip(recorder.tallies())
        .zip(stopped)
        .map(|((entry, tally), stopped)| EntryOutcome {
            entry,
            tally,
            stopped,
        })
        .collect();
    Ok(ComparisonSummary {
        backend: backend_name,
        entries,
        frames_recorded: recorded,
        frames_dropped: outcome.frames_dropped,
        wall_secs: start.elapsed().as_secs_f64(),
        cancelled: outcome.cancelled,
    })
}
