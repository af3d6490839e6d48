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

/// Threads of the one-workgroup step (`GROUP_THREADS` in WGSL) for `mass_count` masses. On a
/// CPU adapter (lavapipe) a workgroup's threads run as SIMD lanes, 8 to a 256-bit register, and
/// each further group of 8 is a coroutine switched at every barrier: 8 threads, one register, ran
/// hair's step 2x faster there than 64 (4 and 16 were slower). A GPU runs the workgroup on one
/// SM, where each CG iteration is a chain of passes over the masses with sums between them: a
/// thread per mass, in whole warps, two at least and 512 at most. On an H100 the jello (1 000
/// masses) stepped at 1/60 s 125, 201, 358, 493 and 402 times a second with 64, 128, 256, 512
/// and 1 024 threads (BENCHMARKS.md): 1 024 leave each thread 64 registers.
pub fn group_threads(device: wgpu::DeviceType, mass_count: usize) -> u32 {
    match device {
        wgpu::DeviceType::Cpu => crate::physics::SUM_LANES,
        _ => (mass_count.div_ceil(32).clamp(2, 16) * 32) as u32,
    }
}

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
/// (hair's steps 12% faster, BENCHMARKS.md).
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
    pub fn of(model: &Model, path: Path, (threads, workgroup_bytes): (u32, u32)) -> Self {
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

/// The path for `model`: one workgroup for a small system, contacts or not. (Contact scenes
/// took the per-pass path until 2026-11-23: on Mesa 22's lavapipe the one-workgroup step left
/// the CPU's solution on jello-sphere. On Mesa 25, with sums in two levels, it agrees with
/// the CPU as the per-pass path does, `tests/gpu_implicit.rs`, and runs jello 1.35x faster.)
pub fn path(model: &Model) -> Path {
    if model.mass_count() <= IN_GROUP_MAX_MASSES {
        Path::InGroup
    } else {
        Path::Passes
    }
}

/// The most workgroups of the per-pass kernels' grid on a GPU, which needs enough threads in
/// flight to hide memory latency, and reads the partials that every workgroup of a pass sums
/// from its cache.
const SOLVER_GROUPS_GPU: u32 = 1024;

/// Workgroups of the per-pass kernels' grid (`solver_groups()` in WGSL). On a GPU, one per 64
/// masses, at most SOLVER_GROUPS_GPU. On a CPU adapter (lavapipe), `physics::sum_groups`: one
/// per 2 048 masses, at most 64, each of `physics::SUM_LANES` threads, as the CPU backend takes
/// its sums (`cpu/solver_sums.rs`), so that the two agree bit for bit; a CPU runs few
/// workgroups at once, and each load of a partial costs it a descriptor read and a bounds check.
pub fn solver_groups(masses: usize, device: wgpu::DeviceType) -> u32 {
    if device == wgpu::DeviceType::Cpu {
        return crate::physics::sum_groups(masses) as u32;
    }
    let wanted = masses
        .div_ceil(super::super::shaders::WORKGROUP as usize)
        .max(1);
    u32::try_from(wanted).map_or(SOLVER_GROUPS_GPU, |w| w.min(SOLVER_GROUPS_GPU))
}

/// Threads of each workgroup of the per-pass kernels' grid (`SOLVER_THREADS` in WGSL): 64 on a
/// GPU, `physics::SUM_LANES` on a CPU adapter (see `solver_groups`).
pub fn solver_threads(device: wgpu::DeviceType) -> u32 {
    match device {
        wgpu::DeviceType::Cpu => crate::physics::SUM_LANES,
        _ => super::super::shaders::WORKGROUP,
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
/// preconditioned by a multigrid cycle over `levels` coarse levels (0: block Jacobi).
pub fn passes(path: Path, levels: u32) -> String {
    let names = |ds: &[Dispatch]| {
        ds.iter()
            .map(|d| d.kernel.name())
            .collect::<Vec<_>>()
            .join(" → ")
    };
    match path {
        Path::InGroup if levels > 0 => format!(
            "{} (one workgroup, the whole step: [Newton: iterate → forces → levels × {levels} → \
             [CG: product → update → [cycle: fine down → restrict × {levels} → coarsest{} → fine up]]])",
            names(&IN_GROUP_MULTIGRID),
            if levels > 1 {
                format!(" → prolong × {}", levels - 1)
            } else {
                String::new()
            }
        ),
        Path::InGroup => format!(
            "{} (one workgroup, the whole step: [Newton: iterate → forces → [CG]])",
            names(&IN_GROUP)
        ),
        Path::Passes if levels > 0 => {
            let [begin @ .., apply] = NEWTON_BEGIN;
            let [advance, _] = CG_ITERATION;
            let cycle = format!("[cycle: {}]", super::super::multigrid::cycle_text(levels));
            format!(
                "{} → [Newton: {} → [levels: {} → {}] × {levels} → {} → {cycle} → {} → [CG: {} → {cycle} → {}] → {}] → {}",
                names(&BEGIN),
                names(&begin),
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
            names(&BEGIN),
            names(&NEWTON_BEGIN),
            names(&CG_ITERATION),
            names(&NEWTON_END),
            names(&END)
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::DeviceType::{Cpu, DiscreteGpu};

    /// A GPU's workgroup has a thread per mass in whole warps, two warps at least and 512 at
    /// most; a CPU adapter's is one SIMD register.
    #[test]
    fn the_one_workgroup_step_is_sized_to_the_adapter() {
        assert_eq!(group_threads(Cpu, 1000), 8);
        assert_eq!(group_threads(DiscreteGpu, 10), 64);
        assert_eq!(group_threads(DiscreteGpu, 100), 128);
        assert_eq!(group_threads(DiscreteGpu, 500), 512);
        assert_eq!(group_threads(DiscreteGpu, 2048), 512);
    }
}
