//! Where a sweep stands: each point done (and how), running, or missing, whichever executor ran
//! it; and the tally an executor keeps as points end.

use std::path::Path;

use super::plan::{Layout, Plan};
use super::result::{self, Status};
use super::slurm;

/// Where one point stands.
#[derive(Debug, Clone, PartialEq)]
pub enum PointState {
    Done(Status),
    /// Running (or waiting to) under Slurm, as `squeue` says: its state there.
    InSlurm(String),
    /// Running on this machine (a `hooke sweep point` process holds it).
    Running,
    Missing,
}

/// Each point's state, in order.
pub fn states(dir: &Path, plan: &Plan) -> Vec<PointState> {
    let layout = Layout::new(dir);
    let queued = slurm::queued(&layout);
    (0..plan.points.len())
        .map(|i| {
            if let Some(r) = result::read(&layout.result(i)) {
                return PointState::Done(r.status);
            }
            if let Some(state) = queued.get(&i) {
                return PointState::InSlurm(state.clone());
            }
            if running_here(&layout, i) {
                return PointState::Running;
            }
            PointState::Missing
        })
        .collect()
}

/// Whether a live process on this machine holds point `index` (its `running` file names it).
fn running_here(layout: &Layout, index: usize) -> bool {
    let Ok(text) = std::fs::read_to_string(layout.point(index).join("running")) else {
        return false;
    };
    let mut words = text.split_whitespace();
    let (Some(pid), Some(host)) = (words.next(), words.next()) else {
        return false;
    };
    host == result::host() && Path::new("/proc").join(pid).exists()
}

/// The points a resume runs: those without a result, or with a failed one, that nothing runs now.
pub fn to_run(states: &[PointState]) -> Vec<usize> {
    states
        .iter()
        .enumerate()
        .filter(|(_, s)| matches!(s, PointState::Missing | PointState::Done(Status::Failed)))
        .map(|(i, _)| i)
        .collect()
}
