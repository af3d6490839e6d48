//! The seam between the simulation thread and whatever steps the model: the [`Backend`] trait
//! that the CPU reference (`cpu/`) and the wgpu compute backend (`gpu/`) implement, the error
//! they stop with, and what every backend shares (the divergence check). Which backend a run
//! gets is chosen above both, in [`crate::run::select`]; everything above that is backend-agnostic.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::integrator::Integrator;
use crate::model::Model;
use crate::stability::divergence::{Divergence, Fault, StrainedSpring, Unconverged, Unphysical};
use crate::stability::{Modes, stable_step};
use crate::state::{Snapshot, State, StepStats};

/// Why a backend stopped.
#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    /// The state went bad; every frame before it was delivered.
    #[error(transparent)]
    Diverged(Box<Divergence>),
    /// The solver stopped short of its rule for too many frames in a row; every frame before
    /// the last was delivered.
    #[error(transparent)]
    Unconverged(Box<Unconverged>),
    /// The energy ledger went non-finite or ran away while the state stayed finite; every
    /// frame before the last was delivered.
    #[error(transparent)]
    Unphysical(Box<Unphysical>),
    /// The device failed or refused the run (lost, out of memory, no adapter, scene beyond its
    /// limits): the backend's own typed error, kept whole (the GPU's `gpu::AdapterError` or
    /// `gpu::DeviceError`, which this layer below the backends cannot name).
    #[error(transparent)]
    Device(Box<dyn std::error::Error + Send + Sync>),
    /// A broken invariant of Hooke's own, not a problem of the device or the scene.
    #[error("internal: {0}")]
    Internal(Internal),
}

/// A bug in Hooke that a backend caught before it did harm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Internal {
    #[error("a requested snapshot went missing")]
    SnapshotMissing,
    #[error("both snapshot buffers are in use")]
    SnapshotBuffersBusy,
    #[error("the fused step is missing")]
    FusedStepMissing,
    #[error("no implicit solver")]
    NoImplicitSolver,
    /// A step plan asked for a dispatch the run cannot make.
    #[error("kernel {kernel} {why}")]
    Dispatch {
        kernel: &'static str,
        why: Misplanned,
    },
    /// Implicit Euler's solve overran a budget that cannot be raised (`overran`: its flags).
    #[error("implicit Euler's solve flagged a budget already at its maximum ({overran:#x})")]
    BudgetAtMaximum { overran: u32 },
}

/// How a planned dispatch does not fit the run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Misplanned {
    #[error("asked for without its effect or its colour")]
    WithoutEffect,
    #[error("planned with a state flow the run lacks")]
    NoSuchFlow,
    #[error("planned with the wrong state")]
    WrongState,
}

/// The flags that ask a run to stop (Ctrl-C, a recorder that can take no more), as a backend
/// watches them inside a step: between the sweeps and the Newton and CG iterations of one step on
/// the CPU, between submissions on the GPU. A step cut short is unconverged, so whoever set a
/// flag drops the frame it belonged to (`sim::step_frame` does). None watched: never asked.
#[derive(Debug, Clone, Default)]
pub struct StopFlags(Vec<Arc<AtomicBool>>);

impl StopFlags {
    pub fn new(flags: impl IntoIterator<Item = Arc<AtomicBool>>) -> Self {
        Self(flags.into_iter().collect())
    }

    /// Whether any flag is set.
    pub fn asked(&self) -> bool {
        self.0.iter().any(|f| f.load(Ordering::Relaxed))
    }
}

pub trait Backend: Send {
    /// Human-readable name of the device, printed at the start of every run.
    fn describe(&self) -> String;
    /// Watch `flags` from now on: once one is set, the step in progress ends early (see
    /// [`StopFlags`]) and so does every later one, until the caller drops the backend.
    fn watch(&mut self, flags: StopFlags);
    /// Advance `substeps` steps of the backend's dt. Stops at the first step whose state is not
    /// finite or runs away, leaving the last good snapshot intact for the caller.
    fn advance(&mut self, substeps: u32) -> Result<StepStats, BackendError>;
    /// Start taking a snapshot of the current state (what the recorder logs). The caller may
    /// advance again before [`Backend::collect_snapshot`] returns it: the GPU steps the next frame
    /// while this one is read back.
    fn request_snapshot(&mut self, frame: u64, stats: StepStats) -> Result<(), BackendError>;
    /// The oldest requested snapshot, `None` when none is pending. A backend that sees the state
    /// only here (the GPU) reports divergence here, and never hands out a non-finite frame.
    fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError>;
    /// A snapshot of the current state, now (none may be pending).
    fn snapshot(&mut self, frame: u64, stats: StepStats) -> Result<Snapshot, BackendError> {
        self.request_snapshot(frame, stats)?;
        self.collect_snapshot()?
            .ok_or_else(|| BackendError::Internal(Internal::SnapshotMissing))
    }
    /// The full state (tests and benchmarks).
    fn state(&mut self) -> Result<State, BackendError>;
    /// Take back a snapshot the recorder is done with, so that its buffers are refilled instead
    /// of allocating new ones each frame.
    fn recycle(&mut self, _snapshot: Snapshot) {}
    /// Wait until all stepping asked for so far has run (benchmarks time up to here).
    fn finish(&mut self) -> Result<(), BackendError> {
        Ok(())
    }
    /// Device memory held by the simulation's buffers, where the backend has its own device.
    fn memory_bytes(&self) -> Option<u64> {
        None
    }
    /// Submissions of steps run again since the backend began, where it ever runs one again
    /// (implicit Euler on the GPU's per-pass path replays a frame that outran its budgets).
    fn replays(&self) -> Option<u64> {
        None
    }
    /// How many times the mass–mass contact's neighbour lists have been built since the run
    /// began (each a full build; between them a step only checks how far the masses moved);
    /// `None` without mass–mass contact.
    fn neighbour_builds(&mut self) -> Result<Option<u64>, BackendError> {
        Ok(None)
    }
}

/// A backend whose snapshots pass through `then` as they are collected, on the thread that
/// collects them (the simulation thread): `--realtime` holds each until its time, the recorder's
/// digest stage reduces its strains, the solver watch may stop the run. Everything else goes
/// straight to `inner`.
pub struct Then<F> {
    inner: Box<dyn Backend>,
    then: F,
}

impl<F: FnMut(&mut Snapshot) -> Result<(), BackendError> + Send> Then<F> {
    pub fn new(inner: Box<dyn Backend>, then: F) -> Self {
        Self { inner, then }
    }
}

impl<F: FnMut(&mut Snapshot) -> Result<(), BackendError> + Send> Backend for Then<F> {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn watch(&mut self, flags: StopFlags) {
        self.inner.watch(flags)
    }
    fn advance(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        self.inner.advance(substeps)
    }
    fn request_snapshot(&mut self, frame: u64, stats: StepStats) -> Result<(), BackendError> {
        self.inner.request_snapshot(frame, stats)
    }
    fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError> {
        let mut snap = self.inner.collect_snapshot()?;
        if let Some(s) = &mut snap {
            (self.then)(s)?;
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
    fn replays(&self) -> Option<u64> {
        self.inner.replays()
    }
    fn neighbour_builds(&mut self) -> Result<Option<u64>, BackendError> {
        self.inner.neighbour_builds()
    }
}

/// Advance `steps` steps in submissions of at most `batch` substeps (a GPU encodes each batch
/// into one submission; the CPU does not care).
pub fn advance_steps(be: &mut dyn Backend, steps: u64, batch: u32) -> Result<(), BackendError> {
    let mut left = steps;
    while left > 0 {
        let n = left.min(u64::from(batch.max(1))) as u32;
        be.advance(n)?;
        left -= u64::from(n);
    }
    Ok(())
}

/// Speed beyond which a state counts as runaway: nothing in a mass-spring scene moves at 10 km/s
/// unless the integration has gone unstable, and stopping there keeps the last frames readable.
pub const RUNAWAY_SPEED_M_PER_S: f32 = 1.0e4;
const _: () = assert!(RUNAWAY_SPEED_M_PER_S == crate::scene::MAX_START_SPEED_M_PER_S);

/// The first mass whose state is non-finite or runaway, described for the user: what went
/// wrong, its most strained spring, and the stability limit its step crossed there.
pub fn find_divergence(
    model: &Model,
    state: &State,
    integrator: Integrator,
    dt_secs: f64,
) -> Option<Box<Divergence>> {
    let bad = |i: usize| {
        let (x, v) = (state.x[i], state.v[i]);
        if !x.is_finite() || !v.is_finite() {
            Some(Fault::NonFinite)
        } else if v.length() > RUNAWAY_SPEED_M_PER_S {
            Some(Fault::Runaway {
                speed_m_per_s: v.length(),
            })
        } else {
            None
        }
    };
    let (i, fault) = (0..state.x.len()).find_map(|i| bad(i).map(|w| (i, w)))?;
    let body = model
        .body_of_mass(i as u32)
        .map(|(b, local)| (b.name.clone(), local));
    // The spring at this mass that is stretched or squeezed the most points at the culprit.
    let spring = model
        .adjacency
        .of(i)
        .iter()
        .map(|nb| {
            let s = &model.springs[nb.spring as usize];
            let strain = s.strain(&state.x);
            StrainedSpring {
                index: nb.spring,
                kind: model.spring_kind[nb.spring as usize],
                strain: if strain.is_finite() {
                    strain
                } else {
                    f32::INFINITY
                },
                stiffness_n_per_m: s.stiffness_n_per_m,
            }
        })
        .max_by(|a, b| a.strain.abs().total_cmp(&b.strain.abs()));
    Some(Box::new(Divergence {
        step: state.steps,
        time_secs: state.time_secs,
        mass: i as u32,
        fault,
        body,
        spring,
        dt_secs,
        integrator,
        scene: stable_step(&Modes::of(model), integrator),
        here: stable_step(&Modes::at_mass(model, i as u32), integrator),
    }))
}
