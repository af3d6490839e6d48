//! The scalar series a recording holds: each one's entity path, name, plot and colour, and when a
//! run has it. The blueprint, the legend and the per-frame logging all read this one table.

use super::palette::{
    BLUE, BROWN, CYAN, DARK_RED, GREEN, GREY, ORANGE, PINK, RED, Rgb, SALMON, VIOLET, WHITE, YELLOW,
};

/// Which plot of the default layout a series is drawn in: one per unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plot {
    /// Joules.
    Energy,
    /// Dimensionless strain (ratios).
    Strain,
    /// Wall milliseconds per frame.
    Millis,
    /// Counts per frame.
    Count,
    /// In the recording, in no plot of the default layout (a relative residual: the user adds
    /// a plot, with a log scale, when they want it; the substeps, the same every frame).
    Unplotted,
}

impl Plot {
    /// The plots of the default layout, in the order the legend names them.
    pub const SHOWN: [Plot; 4] = [Plot::Energy, Plot::Strain, Plot::Millis, Plot::Count];

    /// The plot's title in the layout and the legend.
    pub fn title(self) -> &'static str {
        match self {
            Plot::Energy => "energy (J)",
            Plot::Strain => "strain",
            Plot::Millis => "time per frame (ms)",
            Plot::Count => "counts per frame",
            Plot::Unplotted => "",
        }
    }
}

/// One scalar series: its entity path, its name (shown when its line is hovered), its plot,
/// its colour and that colour's name for the legend, and when the recording has it.
pub struct Series {
    pub path: &'static str,
    pub name: &'static str,
    pub plot: Plot,
    pub color: Rgb,
    pub when: When,
}

/// When a run has a series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum When {
    Always,
    /// Springs yield or tear.
    SpringsChange,
    Tearing,
    Implicit,
    /// A solver with an acceptance rule: implicit Euler, BDF2 or VBD.
    Solver,
}

/// Every scalar series, in the order they are logged each frame.
#[rustfmt::skip]
pub const SERIES: [Series; 17] = [
    s("energy/kinetic", "kinetic", Plot::Energy, ORANGE, When::Always),
    s("energy/elastic", "elastic", Plot::Energy, GREEN, When::Always),
    s("energy/gravity", "gravity", Plot::Energy, BLUE, When::Always),
    s("energy/contact", "contact", Plot::Energy, VIOLET, When::Always),
    s("energy/dissipated", "dissipated", Plot::Energy, RED, When::Always),
    s("energy/dissipated_damping", "· damping", Plot::Energy, SALMON, When::Always),
    s("energy/dissipated_drag", "· drag", Plot::Energy, PINK, When::Always),
    s("energy/dissipated_contact", "· friction", Plot::Energy, BROWN, When::Always),
    s("energy/dissipated_plastic", "· plastic", Plot::Energy, DARK_RED, When::SpringsChange),
    s("energy/collider_work", "collider work", Plot::Energy, CYAN, When::Always),
    s("energy/total", "total", Plot::Energy, WHITE, When::Always),
    s("energy/balance", "balance", Plot::Energy, YELLOW, When::Always),
    s("stats/max_strain", "max |strain|", Plot::Strain, YELLOW, When::Always),
    s("stats/step_ms", "stepping", Plot::Millis, BLUE, When::Always),
    s("stats/record_ms", "recording", Plot::Millis, ORANGE, When::Always),
    // The same every frame of a run (the scene document names it): as a line, it lay along the
    // counts plot's top edge and hid the counts that change.
    s("stats/substeps", "substeps", Plot::Unplotted, WHITE, When::Always),
    s("stats/projections", "projections", Plot::Count, GREEN, When::Always),
];

/// Series beyond [`SERIES`] that only some runs have.
#[rustfmt::skip]
pub const MORE_SERIES: [Series; 6] = [
    s("stats/broken_springs", "broken springs", Plot::Count, RED, When::Tearing),
    s("stats/cg_iterations", "CG iterations", Plot::Count, CYAN, When::Implicit),
    s("stats/cg_residual", "CG residual", Plot::Unplotted, GREY, When::Implicit),
    s("stats/newton_iterations", "Newton iterations", Plot::Count, VIOLET, When::Implicit),
    s("stats/step_residual", "step residual", Plot::Unplotted, GREY, When::Solver),
    s("stats/unmet_steps", "steps short of the rule", Plot::Count, RED, When::Solver),
];

const fn s(path: &'static str, name: &'static str, plot: Plot, color: Rgb, when: When) -> Series {
    Series {
        path,
        name,
        plot,
        color,
        when,
    }
}

/// Every series: [`SERIES`], then [`MORE_SERIES`].
pub fn all_series() -> impl Iterator<Item = &'static Series> {
    SERIES.iter().chain(&MORE_SERIES)
}
