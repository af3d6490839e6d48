//! How a comparison's copies are laid out and coloured, and what the recording tallies of
//! each entry for the line `hooke run` prints at its end.

use super::framing::extent;
use crate::model::Model;

/// Which colouring a non-reference copy shows when the recording opens; the other is logged
/// too, hidden, one click away in the viewer's blueprint panel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum ColourBy {
    /// Distance to the reference at the same simulated time.
    #[default]
    Gap,
    /// Strain, as a single run colours it.
    Strain,
}

/// How the copies are placed and coloured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompareLayout {
    /// On top of each other, the non-reference copies translucent; else side by side.
    pub overlay: bool,
    /// The gap at which a copy is fully red.
    pub gap_range_m: f32,
    pub colour_by: ColourBy,
}

impl CompareLayout {
    /// A twentieth of the scene's size (the diagonal of its starting extent): the gap at which
    /// a copy reads as having gone its own way.
    pub fn default_gap_range(model: &Model) -> f32 {
        let (lo, hi) = extent(&model.initial.x);
        ((hi - lo).length() / 20.0).max(1e-3)
    }
}

/// How one entry went, as far as the recording saw it: for the line `hooke run` prints at the end.
#[derive(Debug, Clone, Default)]
pub struct EntryTally {
    /// Its name in entity paths, unique among the entries.
    pub name: String,
    /// As the user wrote it (`implicit@1/60`).
    pub label: String,
    /// Wall milliseconds its backend spent stepping, all frames together.
    pub step_ms: f64,
    /// Simulated seconds it reached.
    pub sim_secs: f64,
    /// RMS distance to the reference at its last frame with both.
    pub last_gap_rms_m: Option<f64>,
    /// Energy balance (total plus what left) at frame 0 and at its last frame; the scale its
    /// drift is judged against (the larger of |total| and kinetic at frame 0).
    pub balance_j: Option<(f64, f64)>,
    pub energy_scale_j: f64,
}

impl EntryTally {
    /// The balance's change over the run, in percent of the energy at its start.
    pub fn drift_pct(&self) -> Option<f64> {
        self.balance_j
            .map(|(a, b)| 100.0 * (b - a) / self.energy_scale_j.max(1e-12))
    }
}
