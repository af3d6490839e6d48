//! How many threads and workgroups a run's dispatches take, and which run in one workgroup: the
//! GPU's sizing policy, in one room. Each choice is by the adapter's kind (a CPU adapter, such
//! as lavapipe, runs a workgroup on one core as SIMD lanes; a GPU runs it on one SM of many)
//! and the scene's size; `tuning.rs` applies them to a run, and the tests and benchmarks may
//! fix them otherwise (`Tuning`).

use super::kernels::Path;
use super::limits::IN_GROUP_MAX_MASSES;
use super::verdicts::NotInGroup;
use crate::integrator::{Integrator, Over};
use crate::model::Model;

/// Threads of a workgroup of the kernels that take a thread per mass, spring or item (the
/// `@workgroup_size` of most of the WGSL).
pub const WORKGROUP: u32 = 64;

/// Workgroup counts for `threads` threads: a 2D grid when x would exceed the adapter's limit.
pub fn groups_for(threads: u32, max_per_dim: u32) -> (u32, u32) {
    let groups = threads.div_ceil(WORKGROUP).max(1);
    if groups <= max_per_dim {
        (groups, 1)
    } else {
        let y = groups.div_ceil(max_per_dim);
        (groups.div_ceil(y), y)
    }
}

/// The most springs XPBD sweeps in one workgroup: below it, the launches of a dispatch per colour
/// and sweep cost more than the sweeps' work on one workgroup.
pub const XPBD_ONE_GROUP_SPRINGS: usize = 16_384;

/// The most sweeps one dispatch of `xpbd_sweeps` or `vbd_sweeps` runs: a dispatch cannot be
/// stopped, and a stop waits for the submission in progress (`encode_in_submissions`). More
/// sweeps than this take a dispatch per colour and sweep, whose result is the same bit for bit
/// (the kernels' headers say why); 1 024 sweeps of the 4 × 4 × 4 jello's 16 colours in one
/// workgroup take about 0.1 s on lavapipe.
pub const MOST_SWEEPS_IN_ONE_DISPATCH: u32 = 1024;

/// Whether a run with `spring_count` springs sweeps XPBD's colours `iterations` times in one
/// dispatch (`xpbd_sweeps.wgsl`).
pub fn xpbd_in_one_group(spring_count: usize, iterations: u32) -> bool {
    spring_count <= XPBD_ONE_GROUP_SPRINGS && iterations <= MOST_SWEEPS_IN_ONE_DISPATCH
}

/// Threads of the first level of implicit Euler's one-workgroup sums (`SUM_LEVEL`,
/// shaders/implicit.wgsl): the fewest, a power of two from 8 to 32, whose square covers
/// `threads`, so that neither level's adds are a long chain (64 threads: 8 of 8; 1 024: 32 of
/// 32).
pub fn sum_level(threads: u32) -> u32 {
    let mut level = 8;
    while level < 32 && level * level < threads {
        level *= 2;
    }
    level
}

/// The most masses VBD sweeps in one workgroup (`vbd_sweeps.wgsl`) on a `device`, instead of a
/// dispatch per colour and sweep. On an H100 at one step per frame, with 8 lanes a mass
/// (BENCHMARKS.md), one workgroup swept the hair (100 masses, every colour in one round of its
/// 512 threads) 1.7x as fast, the jello (1 000) 0.93x, the cloth (1 024) 0.62x and the peer cloth
/// at N = 64 (4 096) 0.19x: a colour of more masses than a round holds is better spread over the
/// card. A CPU adapter (lavapipe) runs a workgroup on one core: on two, one workgroup swept the
/// hair 2.1x as fast, the jello and the cloth 0.94x.
pub fn vbd_one_group_masses(device: wgpu::DeviceType) -> usize {
    match device {
        wgpu::DeviceType::Cpu => 512,
        _ => 256,
    }
}

/// Whether a VBD run with `mass_count` masses sweeps its colours `iterations` times in one
/// dispatch on `device`.
pub fn vbd_in_one_group(mass_count: usize, iterations: u32, device: wgpu::DeviceType) -> bool {
    mass_count <= vbd_one_group_masses(device) && iterations <= MOST_SWEEPS_IN_ONE_DISPATCH
}

/// Whether a run's colour sweeps (XPBD's springs, VBD's masses) take one workgroup on `device`.
pub fn sweeps_in_one_group(
    model: &crate::model::Model,
    step: crate::integrator::Step,
    device: wgpu::DeviceType,
) -> bool {
    match step.integrator.scheme().sweeps() {
        Some(s) => match s.over {
            Over::Springs => xpbd_in_one_group(model.spring_count(), s.count(&step.options)),
            Over::Masses => vbd_in_one_group(model.mass_count(), s.count(&step.options), device),
        },
        None => false,
    }
}

/// Threads VBD's block solves share a mass's springs among (`VBD_LANES`, vbd_mass.wgsl) on a
/// `device`: on a GPU 8, so that a colour of a hundred masses keeps an SM's schedulers busy and
/// each thread walks a few springs, not all; on a CPU adapter (lavapipe), whose workgroup runs on
/// one core a SIMD vector at a time, one.
pub fn vbd_lanes(device: wgpu::DeviceType) -> u32 {
    match device {
        wgpu::DeviceType::Cpu => 1,
        _ => 8,
    }
}

/// Threads of `vbd_sweeps`' workgroup whose widest colour has `widest` masses of `lanes` threads
/// each, on a `device` allowing `most` invocations in a workgroup's x: a CPU adapter (lavapipe)
/// one SIMD vector, as `frame_threads`, or one mass's lanes if more; a GPU the lanes of every mass
/// of the widest colour, a warp's worth at least and 512 at most (each thread's share takes 64
/// bytes of workgroup memory). A whole number of masses either way.
pub fn vbd_threads(device: wgpu::DeviceType, widest: u32, lanes: u32, most: u32) -> u32 {
    let lanes = lanes.max(1);
    let threads = match device {
        wgpu::DeviceType::Cpu => 8.max(lanes),
        _ => {
            let wanted = widest.saturating_mul(lanes);
            (32 * wanted.div_ceil(32).max(1)).min(512).min(most)
        }
    };
    (threads / lanes).max(1) * lanes
}

/// The most masses whose Euler or semi-implicit steps run a submission in one dispatch of one
/// workgroup (`fused_frame.wgsl`, `fused_plan::ExplicitPath::InGroup`) on a `device`: below it, a
/// dispatch per step costs more in launches than one workgroup loses in parallelism. A CPU
/// adapter (lavapipe) runs a workgroup on one core, so it gives up its other cores: on two, a
/// hundred masses gain, five hundred break even, a thousand lose. A GPU runs it on one SM of
/// many and pays a few µs a launch: on an H200 one workgroup still gains at a thousand masses
/// with the state in workgroup memory, which 1,024 masses fill as NVIDIA GPUs allow (48 KiB,
/// `FrameState::masses_in_workgroup`). The figures: BENCHMARKS.md, "A submission in one
/// workgroup on small scenes".
pub fn one_group_step_masses(device: wgpu::DeviceType) -> usize {
    match device {
        wgpu::DeviceType::Cpu => 512,
        _ => 1024,
    }
}

/// Where `fused_frame` keeps a submission's state between its steps: in workgroup memory where
/// it fits (the default), or always in the state buffers (the tests compare the two).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameState {
    Workgroup,
    Buffers,
}

impl FrameState {
    /// The masses whose state `fused_frame` keeps in workgroup memory of `workgroup_bytes` (the
    /// adapter's limit), if it does: all `mass_count` where they fit and `self` allows it, else
    /// none (the state buffers). Each step's gathers are a chain of dependent loads of other
    /// masses' state: from a buffer that the step before wrote they cost an SM hundreds of cycles
    /// each (L2), from workgroup memory tens. The arithmetic is the same either way.
    pub fn masses_in_workgroup(self, mass_count: usize, workgroup_bytes: u32) -> Option<u32> {
        let bytes = (mass_count as u64) * u64::from(FRAME_STATE_BYTES_PER_MASS);
        let fits = mass_count > 0 && bytes <= u64::from(workgroup_bytes);
        (self == FrameState::Workgroup && fits).then_some(mass_count as u32)
    }
}

/// Workgroup memory `fused_frame` keeps a mass's state in: x and v, three f32 each, in two halves
/// (the step's and the next's).
pub const FRAME_STATE_BYTES_PER_MASS: u32 = 2 * 6 * 4;

/// Why a fused run on a `device` cannot step a whole submission in one workgroup, or `None`
/// when it can.
pub fn why_not_in_group(
    model: &crate::model::Model,
    integrator: Integrator,
    device: wgpu::DeviceType,
) -> Option<NotInGroup> {
    let most = one_group_step_masses(device);
    let one_update = matches!(
        integrator.scheme().explicit(),
        Some(crate::integrator::Explicit::OneUpdate { .. })
    );
    Some(if !one_update {
        NotInGroup::Passes(integrator)
    } else if model.mass_count() > most {
        NotInGroup::Masses {
            masses: model.mass_count(),
            most,
            cpu: device == wgpu::DeviceType::Cpu,
        }
    } else {
        return None;
    })
}

/// Threads of `fused_frame`'s workgroup for `mass_count` masses on a `device` allowing `most`
/// invocations in a workgroup's x. A CPU adapter (lavapipe) runs a workgroup on one core, a SIMD
/// vector of invocations at a time, and switches between vectors at every barrier: a vector's
/// worth is its fastest. A GPU keeps an SM's warps busy with up to a thread per mass.
pub fn frame_threads(device: wgpu::DeviceType, mass_count: usize, most: u32) -> u32 {
    match device {
        wgpu::DeviceType::Cpu => 8,
        _ => {
            let warps = (mass_count as u32).div_ceil(32).max(1);
            (32 * warps).min(1024).min(most).max(1)
        }
    }
}

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

/// The path for `model`: one workgroup for a small system, contacts or not. (Contact scenes
/// took the per-pass path until 2026-11-23: on Mesa 22's lavapipe the one-workgroup step left
/// the CPU's solution on jello-sphere. On Mesa 25, with sums in two levels, it agrees with
/// the CPU as the per-pass path does, `tests/gpu_implicit.rs`, and runs jello 1.35x faster.)
pub fn implicit_path(model: &Model) -> Path {
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
    let wanted = masses.div_ceil(WORKGROUP as usize).max(1);
    u32::try_from(wanted).map_or(SOLVER_GROUPS_GPU, |w| w.min(SOLVER_GROUPS_GPU))
}

/// Threads of each workgroup of the per-pass kernels' grid (`SOLVER_THREADS` in WGSL): 64 on a
/// GPU, `physics::SUM_LANES` on a CPU adapter (see `solver_groups`).
pub fn solver_threads(device: wgpu::DeviceType) -> u32 {
    match device {
        wgpu::DeviceType::Cpu => crate::physics::SUM_LANES,
        _ => WORKGROUP,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::DeviceType::{Cpu, DiscreteGpu};

    /// A GPU's workgroup has a warp per 32 masses, within 1 024 and the adapter's width; a CPU
    /// adapter's is one SIMD vector; a CPU adapter takes fewer masses in one workgroup.
    #[test]
    fn one_workgroup_is_sized_to_the_adapter() {
        // Implicit Euler's sums: both levels short.
        let levels = [8, 64, 65, 256, 257, 1024].map(sum_level);
        assert_eq!(levels, [8, 8, 16, 16, 32, 32]);
        // VBD's sweeps: whole masses of 8 lanes on a GPU, up to 512 threads; one SIMD vector of
        // one-lane masses on a CPU adapter.
        assert_eq!(vbd_lanes(DiscreteGpu), 8);
        assert_eq!(vbd_threads(DiscreteGpu, 34, 8, 1024), 288);
        assert_eq!(vbd_threads(DiscreteGpu, 125, 8, 1024), 512);
        assert_eq!(vbd_threads(DiscreteGpu, 125, 8, 256), 256);
        assert_eq!(vbd_threads(Cpu, 125, vbd_lanes(Cpu), 1024), 8);
        assert_eq!(vbd_threads(Cpu, 125, 16, 1024), 16);
        assert_eq!(frame_threads(DiscreteGpu, 100, 1024), 128);
        assert_eq!(frame_threads(DiscreteGpu, 1000, 1024), 1024);
        assert_eq!(frame_threads(DiscreteGpu, 2048, 1024), 1024);
        assert_eq!(frame_threads(DiscreteGpu, 2048, 256), 256);
        assert_eq!(frame_threads(DiscreteGpu, 0, 1024), 32);
        assert_eq!(frame_threads(Cpu, 2048, 1024), 8);
        assert!(one_group_step_masses(Cpu) < one_group_step_masses(DiscreteGpu));
    }

    /// The state stays in workgroup memory exactly where 48 B a mass fits: a GPU's whole
    /// one-workgroup range in NVIDIA's 48 KiB, 682 masses in lavapipe's 32 KiB; never when the
    /// caller keeps it in the buffers, nor for no masses.
    #[test]
    fn the_state_stays_in_workgroup_memory_where_it_fits() {
        use FrameState::{Buffers, Workgroup};
        let gpu = one_group_step_masses(DiscreteGpu);
        assert_eq!(
            Workgroup.masses_in_workgroup(gpu, 48 * 1024),
            Some(gpu as u32)
        );
        assert_eq!(Workgroup.masses_in_workgroup(gpu + 1, 48 * 1024), None);
        assert_eq!(Workgroup.masses_in_workgroup(682, 32 * 1024), Some(682));
        assert_eq!(Workgroup.masses_in_workgroup(683, 32 * 1024), None);
        assert_eq!(Buffers.masses_in_workgroup(100, 48 * 1024), None);
        assert_eq!(Workgroup.masses_in_workgroup(0, 48 * 1024), None);
    }

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
