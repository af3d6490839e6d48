//! Timing a run: `bench accuracy`'s and every sweep's points step here, each run on a fresh
//! backend, the median of their wall times kept.

use std::sync::Arc;
use std::time::Instant;

use crate::backend::{self, BackendError, StopFlags};
use crate::integrator::Step;
use crate::model::Model;
use crate::run::select::Device;
use crate::state::{Snapshot, State};

/// What [`timed_runs`] leaves: the last run's end, and every run's wall time, in order.
pub struct Timed {
    /// The end as the recorder would see it (energies) and in full (positions, velocities).
    pub end: Snapshot,
    pub state: State,
    /// The energy balance at the start (J): its change is energy from nowhere.
    pub start_balance_j: f64,
    pub wall_secs: Vec<f64>,
    /// The backend as it describes itself.
    pub backend: String,
}

impl Timed {
    /// The median of the wall times.
    pub fn median_secs(&self) -> f64 {
        let mut t = self.wall_secs.clone();
        t.sort_by(f64::total_cmp);
        t.get(t.len() / 2).copied().unwrap_or(f64::NAN)
    }
}

/// How many timed runs make a point's time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Repeats {
    /// At most this many (at least one is always made).
    pub most: u32,
    /// More than one only where the first took less than this (s): short runs are the noisy
    /// ones, and a long one timed again costs more than its noise.
    pub while_first_under_secs: Option<f64>,
}

impl Repeats {
    pub fn exactly(n: u32) -> Self {
        Self {
            most: n,
            while_first_under_secs: None,
        }
    }

    fn want_another(&self, wall_secs: &[f64]) -> bool {
        let short = match (self.while_first_under_secs, wall_secs.first()) {
            (Some(under), Some(&first)) => first < under,
            _ => true,
        };
        short && wall_secs.len() < self.most.max(1) as usize
    }
}

/// Run `model` for `steps` steps of `step`, as many times as `repeats` says, each on a fresh
/// backend watching `stop` and timed (the wait for the device included). Each backend is
/// deterministic, so the runs end alike; only the clock differs between them. `bench accuracy`'s
/// and every sweep's points time their runs here.
pub fn timed_runs(
    model: &Arc<Model>,
    device: &Device,
    step: Step,
    steps: u64,
    repeats: Repeats,
    stop: &StopFlags,
) -> std::result::Result<Timed, BackendError> {
    let mut wall_secs = Vec::new();
    loop {
        let mut be = device.create(model.clone(), step)?;
        be.watch(stop.clone());
        let backend = be.describe();
        let start_balance_j = be.snapshot(0, Default::default())?.energies.balance_j();
        let start = Instant::now();
        backend::advance_steps(be.as_mut(), steps, 1000)?;
        be.finish()?;
        wall_secs.push(start.elapsed().as_secs_f64());
        if repeats.want_another(&wall_secs) {
            continue;
        }
        return Ok(Timed {
            end: be.snapshot(1, Default::default())?,
            state: be.state()?,
            start_balance_j,
            wall_secs,
            backend,
        });
    }
}
