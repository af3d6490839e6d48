//! A point's `result.json`: what it was, how it ended, what it cost and where it got to. Written
//! last and atomically, so that a point is done exactly when the file exists.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::plan::Param;

/// How a point ended. A diverged or refused point is a result of the sweep, not a failure of
/// it; a failed one (the run could not be made: no adapter, a full disk) is run again by
/// `resume`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    Ok,
    Diverged,
    Refused,
    Failed,
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Status::Ok => "ok",
            Status::Diverged => "diverged",
            Status::Refused => "refused",
            Status::Failed => "failed",
        })
    }
}

/// What else ran beside a point while it was timed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Load {
    /// Nothing of the sweep's: its time is clean.
    Alone,
    /// Other points at the same time: its time is not clean, and the report says so.
    Shared,
}

/// The energies at the end (J), and how far the balance moved from the start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EndEnergies {
    pub kinetic_j: f64,
    pub elastic_j: f64,
    pub gravity_j: f64,
    pub contact_j: f64,
    /// What the ledger says the energy should be; its change is energy from nowhere (or lost
    /// to no known sink).
    pub balance_j: f64,
    pub balance_change_j: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointResult {
    pub index: usize,
    pub label: String,
    pub params: Vec<Param>,
    pub status: Status,
    /// Why a point diverged, was refused or failed.
    pub message: Option<String>,
    /// What the run said about how its values were applied (a rounded step, a step above the
    /// estimate) and what its watch said on the way (a solver short of its rule, energy from
    /// nowhere).
    pub notes: Vec<String>,
    /// The device it ran on, as the run describes it.
    pub backend: Option<String>,
    pub integrator: Option<String>,
    pub dt_secs: Option<f64>,
    pub substeps: Option<u32>,
    pub frames: Option<u64>,
    pub steps: Option<u64>,
    pub masses: Option<usize>,
    /// `check`'s estimate of the integrator's stable step on this scene (`None`: any step).
    pub stable_dt_secs: Option<f64>,
    /// The median of the timed runs' wall times (stepping only, no recording).
    pub wall_secs: Option<f64>,
    pub wall_secs_each: Vec<f64>,
    pub load: Load,
    pub steps_per_sec: Option<f64>,
    pub energies: Option<EndEnergies>,
    /// RMS over the masses of the distance to the reference's end, where the sweep has one.
    pub error_rms_m: Option<f64>,
    /// The largest distance of a mass from the reference's end.
    #[serde(default)]
    pub error_max_m: Option<f64>,
    /// A hash of the end state's positions and velocities (`State::digest`, hex): the same on
    /// every run of a deterministic backend.
    pub digest: Option<String>,
    /// The recording, relative to the sweep's folder.
    pub recording: Option<String>,
    pub host: String,
}

impl PointResult {
    /// The first sentence of why the point diverged, was refused or failed (the rest, its
    /// advice, stays in result.json), if it says why.
    pub fn first_sentence(&self) -> Option<&str> {
        let m = self.message.as_deref()?;
        Some(m.split_once(". ").map_or(m, |(first, _)| first))
    }
}

/// The result in `path`, if the point is done.
pub fn read(path: &Path) -> Option<PointResult> {
    let text = std::fs::read_to_string(path).ok()?;
    serde_json::from_str(&text).ok()
}

/// This machine's name, as a result and a point's `running` file record it.
pub fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_owned())
        .or_else(|_| std::env::var("HOSTNAME"))
        .unwrap_or_else(|_| "unknown".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_message_is_cut_at_its_first_sentence() {
        let mut r: PointResult = serde_json::from_value(serde_json::json!({
            "index": 0, "label": "x", "params": [], "status": "diverged", "notes": [],
            "wall_secs_each": [], "load": "alone", "host": "here",
        }))
        .expect("a result without a message");
        assert_eq!(r.first_sentence(), None);
        r.message = Some("diverged at frame 3 (mass 7). Try a smaller step.".to_owned());
        assert_eq!(r.first_sentence(), Some("diverged at frame 3 (mass 7)"));
        r.message = Some("no adapter".to_owned());
        assert_eq!(r.first_sentence(), Some("no adapter"));
    }
}
