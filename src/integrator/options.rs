//! What an integrator is given beyond its name and step: its sweeps and its preconditioner,
//! with their defaults.

use serde::{Deserialize, Serialize};

/// From this many masses on, where the system is also stiff against the step
/// (`MULTIGRID_MIN_STIFFNESS`), both backends precondition implicit Euler's conjugate gradients
/// by aggregation multigrid (`cpu/multigrid.rs`, `gpu/multigrid.rs`) unless the run names a
/// preconditioner. Below it the cycle saves no time on the CPU: on the eleven scenes of 100 to
/// 1 444 masses at 1/60 s, two cores, it took fewer CG iterations but ran no faster than block
/// Jacobi on the whole (BENCHMARKS.md, "Multigrid in the one-workgroup step, and a
/// preconditioner to choose"). Whether it pays in the GPU's one-workgroup step is for a GPU to
/// measure (`bench/device/gpu_rows.sh mg`).
pub const MULTIGRID_MIN_MASSES: usize = 4096;

/// The system's stiffness against the step (`physics::stiffness_against_step`: the largest
/// (h² Σk + h Σc) / m over the masses) from which multigrid pays. Below it block Jacobi's CG
/// takes few iterations, each a fraction of a cycle's cost. On two cores the crossing lay in the
/// thousands on cloth-256 and below a few hundred on the 64 × 64 peer cloth: no one figure
/// serves both, and 300 loses least on either (BENCHMARKS.md, "The CPU's loops on the pool, and
/// the preconditioner by stiffness against the step").
pub const MULTIGRID_MIN_STIFFNESS: f64 = 300.0;

/// What preconditions implicit Euler's and BDF2's conjugate gradients. Names match
/// `--preconditioner` and the scene's `solver.preconditioner`; without either, both backends
/// take [`Preconditioner::for_system`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Preconditioner {
    /// Each mass's 3 × 3 diagonal block of the system, inverted (both backends).
    #[default]
    BlockJacobi,
    /// A V-cycle of aggregation multigrid over coarser copies of the system
    /// (`physics::hierarchy`): the CPU's `cpu/multigrid.rs`, the GPU's `gpu/multigrid.rs`.
    Multigrid,
}

impl Preconditioner {
    /// Both backends' choice for a system of `mass_count` masses, `stiffness` stiff against
    /// its step (`physics::stiffness_against_step`), when the run names none.
    pub fn for_system(mass_count: usize, stiffness: f64) -> Self {
        if mass_count >= MULTIGRID_MIN_MASSES && stiffness >= MULTIGRID_MIN_STIFFNESS {
            Preconditioner::Multigrid
        } else {
            Preconditioner::BlockJacobi
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Preconditioner::BlockJacobi => "3×3 block Jacobi",
            Preconditioner::Multigrid => "aggregation multigrid",
        }
    }
}

/// What an integrator needs beyond its name and step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepOptions {
    /// XPBD's constraint iterations per substep (≥ 1; the others ignore it).
    pub xpbd_iterations: u32,
    /// VBD's sweeps over the masses per step (≥ 1; the others ignore it).
    pub vbd_iterations: u32,
    /// What preconditions implicit Euler's and BDF2's CG on both backends; `None`: each system
    /// as its size and stiffness say (`Preconditioner::for_system`).
    pub preconditioner: Option<Preconditioner>,
}

impl Default for StepOptions {
    fn default() -> Self {
        Self {
            xpbd_iterations: DEFAULT_XPBD_ITERATIONS,
            vbd_iterations: DEFAULT_VBD_ITERATIONS,
            preconditioner: None,
        }
    }
}

impl StepOptions {
    /// The preconditioner of a system of `mass_count` masses, `stiffness` stiff against its
    /// step: the one asked for, else the system's (`Preconditioner::for_system`). (One without
    /// coarse levels takes block Jacobi whatever is asked: `hooke check` says so.) A model's
    /// run asks `physics::preconditioner_of`, which measures the stiffness.
    pub fn preconditioner_for(&self, mass_count: usize, stiffness: f64) -> Preconditioner {
        self.preconditioner
            .unwrap_or_else(|| Preconditioner::for_system(mass_count, stiffness))
    }
}

/// "Small Steps": one iteration per substep, and more substeps where accuracy is wanted.
pub const DEFAULT_XPBD_ITERATIONS: u32 = 1;

/// VBD's sweeps per step: NVIDIA Newton's cloth examples run 10.
pub const DEFAULT_VBD_ITERATIONS: u32 = 10;
