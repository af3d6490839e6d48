//! An implicit step's passes. A small system's whole step is one dispatch of `implicit_step` (one
//! workgroup, no host wait). A larger one runs, in order: BEGIN, then per Newton iteration
//! NEWTON_BEGIN, CG_ITERATION repeated, NEWTON_END; then END, each a dispatch over the solver's
//! grid of workgroups (`solver_groups`) or one workgroup. Every dispatch of a step reads the same
//! slot.

use super::super::dispatch::Dispatch;
use super::super::kernels::Kernel::{self, *};
use super::super::kernels::Path;
use super::super::layout::SOLVER_VECTORS;
use crate::model::Model;

use super::super::limits::{
    IN_GROUP_MAX_MASSES, MULTIGRID_FACTOR_WORKGROUP_BYTES, MULTIGRID_IN_GROUP_WORKGROUP_BYTES,
};

/// Workgroup memory the one-workgroup step's sums take with `threads` threads (`sum_sh`, at
/// least the per-pass kernels' 64 slots, `part_sh`, `total_sh`, `flag_sh` in
/// shaders/implicit.wgsl) and mass_force's unused word of `state_sh`, rounded up.
const fn sum_scratch_bytes(threads: u32) -> u64 {
    let slots = if threads > 64 { threads } else { 64 };
    16 * slots as u64 + 32 * 16 + 16 + 16 + 16
}

// The cycle's bound on the one-workgroup step's workgroup memory holds at its widest.
const _: () = assert!(
    sum_scratch_bytes(512) + MULTIGRID_FACTOR_WORKGROUP_BYTES as u64
        <= MULTIGRID_IN_GROUP_WORKGROUP_BYTES as u64
);

/// Where the one-workgroup step keeps the solver's per-mass vectors and each CSR entry's
/// spring terms (`SOLVER_IN_WORKGROUP` in WGSL): in workgroup memory when both fit beside the
/// sums in `workgroup_bytes` (the adapter's limit), else in the `work` and `terms` buffers.
/// The passes read them many times a step; on lavapipe a storage-buffer load costs a
/// descriptor read, a bounds check and a branch per lane, a workgroup-memory load neither
/// (BENCHMARKS.md, "GPU backend on lavapipe", its table of what each change gained).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverHome {
    Buffers,
    /// The arrays' lengths in vec4s.
    Workgroup {
        vectors: u32,
        terms: u32,
    },
}

impl SolverHome {
    /// For `model` on `path`, with `threads` in the one-workgroup step.
    pub fn of(model: &Model, path: Path, threads: u32, workgroup_bytes: u32) -> Self {
        let vectors = SOLVER_VECTORS * model.mass_count() as u64;
        let terms = 2 * model.adjacency.entries.len() as u64;
        let bytes = 16 * (vectors + terms) + sum_scratch_bytes(threads);
        match (path, u32::try_from(vectors), u32::try_from(terms)) {
            (Path::InGroup, Ok(vectors), Ok(terms))
                if bytes <= u64::from(workgroup_bytes) && terms > 0 =>
            {
                SolverHome::Workgroup { vectors, terms }
            }
            _ => SolverHome::Buffers,
        }
    }

    /// The workgroup arrays' lengths (vectors, terms) for `shaders::constants`, if any.
    pub fn workgroup_arrays(self) -> Option<[u32; 2]> {
        match self {
            SolverHome::Workgroup { vectors, terms } => Some([vectors, terms]),
            SolverHome::Buffers => None,
        }
    }
}

// A system the one-workgroup step takes is one group of the per-pass grid on a CPU adapter, so
// both paths sum alike there.
const _: () = assert!(IN_GROUP_MAX_MASSES <= crate::physics::SUM_GROUP_MASSES);

const fn at(k: Kernel) -> Dispatch {
    Dispatch::at(k, 0)
}

pub const IN_GROUP: [Dispatch; 1] = [at(ImplicitStep)];
/// The whole step with the multigrid cycle: it binds the first level's group, whose record
/// 0 describes all the levels.
pub const IN_GROUP_MULTIGRID: [Dispatch; 1] = [Dispatch {
    level: 1,
    ..at(MgImplicitStep)
}];
pub const BEGIN: [Dispatch; 2] = [at(ImplicitBegin), at(SolverBegin)];
/// BEGIN after BDF2's restart test, where it may restart across impacts
/// (`physics::BackwardStep::restarts_at_impacts`).
pub const BEGIN_RESTARTING: [Dispatch; 3] = [at(RestartCheck), at(ImplicitBegin), at(SolverBegin)];

/// A step's first passes: BEGIN, after the restart test where `restarts`.
pub fn begin(restarts: bool) -> &'static [Dispatch] {
    if restarts { &BEGIN_RESTARTING } else { &BEGIN }
}
/// The Newton iterate, its forces and right-hand side, and the first half of the solve's first
/// CG iteration (`cg_apply` with p = z).
pub const NEWTON_BEGIN: [Dispatch; 4] = [
    at(ImplicitIterate),
    at(ForcesAndRhs),
    at(CgBegin),
    at(CgApply),
];
/// The rest of a CG iteration and the first half of the next: each half sums the partials
/// the other left, so a dot product costs no dispatch of its own.
pub const CG_ITERATION: [Dispatch; 2] = [at(CgAdvance), at(CgApply)];
pub const NEWTON_END: [Dispatch; 2] = [at(NewtonUpdate), at(NewtonEnd)];
pub const END: [Dispatch; 1] = [at(ImplicitFinal)];

/// For `hooke check`: the passes of one implicit step, the repeated parts in brackets, its CG
/// preconditioned by a multigrid cycle over `levels` coarse levels (0: block Jacobi), with BDF2's
/// restart test where it `restarts`.
pub fn passes(path: Path, levels: u32, restarts: bool) -> String {
    let names = |ds: &[Dispatch]| {
        ds.iter()
            .map(|d| d.kernel.name())
            .collect::<Vec<_>>()
            .join(" → ")
    };
    let restart = if restarts { "restart test → " } else { "" };
    match path {
        Path::InGroup if levels > 0 => format!(
            "{} (one workgroup, the whole step: {restart}[Newton: iterate → forces → levels × {levels} → \
             [CG: product → update → [cycle: fine down → restrict × {levels} → coarsest{} → fine up]]])",
            names(&IN_GROUP_MULTIGRID),
            if levels > 1 {
                format!(" → prolong × {}", levels - 1)
            } else {
                String::new()
            }
        ),
        Path::InGroup => format!(
            "{} (one workgroup, the whole step: {restart}[Newton: iterate → forces → [CG]])",
            names(&IN_GROUP)
        ),
        Path::Passes if levels > 0 => {
            let [newton_begin @ .., apply] = NEWTON_BEGIN;
            let [advance, _] = CG_ITERATION;
            let cycle = format!("[cycle: {}]", super::super::multigrid::cycle_text(levels));
            format!(
                "{} → [Newton: {} → [levels: {} → {}] × {levels} → {} → {cycle} → {} → [CG: {} → {cycle} → {}] → {}] → {}",
                names(begin(restarts)),
                names(&newton_begin),
                MgLinearise.name(),
                MgInvert.name(),
                MgFactor.name(),
                apply.kernel.name(),
                advance.kernel.name(),
                apply.kernel.name(),
                names(&NEWTON_END),
                names(&END)
            )
        }
        Path::Passes => format!(
            "{} → [Newton: {} → [CG: {}] → {}] → {}",
            names(begin(restarts)),
            names(&NEWTON_BEGIN),
            names(&CG_ITERATION),
            names(&NEWTON_END),
            names(&END)
        ),
    }
}
