//! Why a run does not take a GPU path it might, as values: each names the numbers that decided
//! it, and writes its sentence in `Display`, so that `check` prints them and tests compare the
//! fields, not the text.

use super::links::NoLinks;
use crate::integrator::Integrator;

/// Why a run's explicit steps take a pass per stage, not the fused steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unfused {
    /// The scheme has no fused step.
    NoFusedStep(Integrator),
    /// Plasticity or tearing changes the springs.
    SpringsChange,
    /// Mass–mass contact checks its neighbour lists between force evaluations.
    MassContact,
    /// The adapter binds fewer storage buffers a stage than the fused step does.
    StorageBuffers { allowed: u32, needed: u32 },
    /// The springs have no compact links.
    NoLinks(NoLinks),
}

impl std::fmt::Display for Unfused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unfused::NoFusedStep(i) => write!(f, "{} has no fused step", i.name()),
            Unfused::SpringsChange => f.write_str("plasticity or tearing changes the springs"),
            Unfused::MassContact => f.write_str(
                "mass–mass contact checks its neighbour lists between force evaluations",
            ),
            Unfused::StorageBuffers { allowed, needed } => write!(
                f,
                "the adapter allows {allowed} storage buffers per stage, the fused step needs \
                 {needed}"
            ),
            Unfused::NoLinks(why) => write!(f, "{why}"),
        }
    }
}

/// Why a fused run cannot step a whole submission in one workgroup.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotInGroup {
    /// The scheme takes more than one pass a step.
    Passes(Integrator),
    /// More masses than one workgroup steps on the adapter (`cpu`: a CPU adapter's, else a
    /// GPU's).
    Masses {
        masses: usize,
        most: usize,
        cpu: bool,
    },
}

impl std::fmt::Display for NotInGroup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NotInGroup::Passes(i) => write!(f, "{} takes more than one pass a step", i.name()),
            NotInGroup::Masses { masses, most, cpu } => {
                let adapter = if *cpu { "a CPU adapter" } else { "a GPU" };
                write!(
                    f,
                    "{masses} masses, more than one workgroup steps on {adapter} ({most})"
                )
            }
        }
    }
}

/// Why an adapter cannot run the multigrid cycle, whose CG then takes block Jacobi.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MultigridUnbound {
    /// The cycle binds more storage buffers a stage than the adapter allows.
    StorageBuffers { allowed: u32, needed: u32 },
    /// The one-workgroup step's cycle takes more workgroup memory than the adapter has.
    WorkgroupMemory { allowed: u32, needed: u32 },
}

impl std::fmt::Display for MultigridUnbound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MultigridUnbound::StorageBuffers { allowed, needed } => write!(
                f,
                "the cycle binds {needed} storage buffers a stage, the adapter {allowed}"
            ),
            MultigridUnbound::WorkgroupMemory { allowed, needed } => write!(
                f,
                "the one-workgroup step's cycle takes up to {needed} bytes of workgroup memory, \
                 the adapter {allowed}"
            ),
        }
    }
}

/// A run whose CG multigrid would precondition takes block Jacobi on this adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockJacobiInstead(pub MultigridUnbound);

impl std::fmt::Display for BlockJacobiInstead {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "its CG takes block Jacobi on this adapter, not multigrid as on the CPU ({}): the \
             backends agree to the solver's tolerance",
            self.0
        )
    }
}
