//! What `hooke bench accuracy` measured: one row per integrator and step, and each integrator's
//! largest stable step beside the estimate.

use crate::integrator::Integrator;

#[derive(Debug, Clone)]
pub struct Row {
    pub integrator: Integrator,
    pub dt_secs: f64,
    pub steps: u64,
    /// RMS and largest distance from the reference at the end (NaN when unstable).
    pub rms_error_m: f64,
    pub max_error_m: f64,
    /// Change of (mechanical + dissipated − collider work) over the run.
    pub energy_drift_j: f64,
    /// How the run ended: stable, diverged, or not run at all (refused, failed) and why.
    pub outcome: Outcome,
    /// Energy lost beyond what the ledger counts, as a percentage of the initial mechanical
    /// energy (0 when the balance held or grew).
    pub dissipated_pct: f64,
    pub wall_secs_per_sim_sec: f64,
    /// Where the run happened.
    pub backend: String,
    /// A step added at the integrator's estimated stable step (`hooke check`'s, rounded down to
    /// whole steps), beside the ladder every integrator shares: the cheapest stable answers lie
    /// near it.
    pub at_estimate: bool,
}

/// How a row's run ended. A row that was refused or failed has no error, like a diverged one,
/// but the table says which it was and why, so that a refusal never reads as instability.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Did not diverge: stayed finite and below the runaway speed, and gained less than 10% of
    /// the initial mechanical energy. A run that loses energy the ledger does not count (the
    /// numerical damping of implicit Euler) is stable; `dissipated_pct` says how much it lost.
    Stable,
    Diverged,
    /// The run was not made: the scene or the step is one the integrator refuses.
    Refused(String),
    /// The run could not be made or measured (no adapter, no error against the reference).
    Failed(String),
}

impl Outcome {
    pub fn is_stable(&self) -> bool {
        matches!(self, Outcome::Stable)
    }

    /// As the tables' "stable" column says it.
    pub fn label(&self) -> String {
        match self {
            Outcome::Stable => "yes".to_owned(),
            Outcome::Diverged => "diverged".to_owned(),
            Outcome::Refused(why) => format!("refused: {why}"),
            Outcome::Failed(why) => format!("failed: {why}"),
        }
    }

    /// As the CSV's `status` column says it.
    pub fn status(&self) -> &'static str {
        match self {
            Outcome::Stable => "stable",
            Outcome::Diverged => "diverged",
            Outcome::Refused(_) => "refused",
            Outcome::Failed(_) => "failed",
        }
    }
}

#[derive(Debug, Clone)]
pub struct StableDt {
    pub integrator: Integrator,
    pub estimate: Option<f64>,
    pub found: Found,
    /// The steps searched, smallest and largest.
    pub searched: (f64, f64),
}

/// What the search for the largest stable dt found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Found {
    /// Stable at this dt, unstable at the next one tried.
    Largest(f64),
    /// Stable at the largest dt tried: the true limit is at least this.
    AtLeast(f64),
    /// Unstable even at the smallest dt tried.
    Unstable,
}

impl Found {
    /// The largest dt known to be stable.
    pub fn dt(&self) -> Option<f64> {
        match *self {
            Found::Largest(dt) | Found::AtLeast(dt) => Some(dt),
            Found::Unstable => None,
        }
    }
}

#[derive(Debug, Clone)]
pub struct Accuracy {
    pub scene: String,
    pub duration_secs: f64,
    pub reference_dt_secs: f64,
    /// One step per frame, when the ladder reached it (the fast end).
    pub frame_dt_secs: Option<f64>,
    pub rows: Vec<Row>,
    pub stable: Vec<StableDt>,
    /// How each row's wall time was taken: the median of this many timed runs.
    pub repeats: super::timing::Repeats,
    /// Whether the runs were timed one at a time (their times clean), not beside each other.
    pub timed_alone: bool,
}
