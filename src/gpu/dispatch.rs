//! What one dispatch of a step plan is: a kernel, the state it reads or the states it flows
//! between, its stage slot and, for XPBD's projection and VBD's block solve, its colour. The plans (`plan.rs`,
//! `implicit/plan.rs`) are lists of these; `encode.rs` records them.

use super::kernels::Kernel;
use crate::integrator::Integrator;

/// Stage slots per substep: t, t + h/2 (twice, for RK4's two midpoint stages), t + h.
pub const SLOTS_PER_STEP: u32 = 4;

/// Which state a kernel reads through bind group 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StateIn {
    XV,
    XtVt,
    XVt,
}

/// The state a fused kernel reads and the one it writes (bind group 1): A is the run's x and v,
/// B its xt and vt, C the second stage point RK4's middle stages alternate with B.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    AB,
    BA,
    BC,
    CB,
}

/// One sweep over one colour: of springs (XPBD's projection) or of masses (VBD's block solve).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ColourPass {
    pub colour: u32,
    /// The substep's first sweep, which starts XPBD's multipliers from zero (VBD: unused).
    pub first: bool,
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
    (integrator, options): (Integrator, crate::integrator::StepOptions),
    device: wgpu::DeviceType,
) -> bool {
    match integrator {
        Integrator::Xpbd => xpbd_in_one_group(model.spring_count(), options.xpbd_iterations),
        Integrator::Vbd => vbd_in_one_group(model.mass_count(), options.vbd_iterations, device),
        _ => false,
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
pub fn vbd_threads(device: wgpu::DeviceType, (widest, lanes): (u32, u32), most: u32) -> u32 {
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
/// workgroup (`fused_frame.wgsl`, `plan::ExplicitPath::InGroup`) on a `device`: below it, a
/// dispatch per step costs more in launches than one workgroup loses in parallelism. A CPU
/// adapter (lavapipe) runs a workgroup on one core, so it gives up its other cores: on two, the
/// hair (100 masses) steps 2.5–4× as fast in one workgroup, a 22 × 22 cloth (484) about as fast,
/// the jello (1,000) and the cloth (1,024) 0.6–1.0× (BENCHMARKS.md). A GPU runs it on one SM of
/// many, and pays about 9 µs a launch. On an H200 (BENCHMARKS.md), against a dispatch per step:
/// with the state in the state buffers the hair's steps ran 1.5–2× as fast in one workgroup, the
/// jello's 1.26×, the cloth's (1,024 masses) 0.78×; with the state in workgroup memory, 1.9–2.5×,
/// 1.35× and 0.87–0.91×, a 32 × 32 cloth at 16 steps a submission 1.1×. So a GPU takes it up to
/// 1,024 masses, whose state fits in 48 KiB of workgroup memory, as NVIDIA GPUs allow
/// (`FrameState::masses_in_workgroup`).
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
) -> Option<String> {
    let most = one_group_step_masses(device);
    let why = if !matches!(integrator, Integrator::Euler | Integrator::SemiImplicit) {
        format!("{} takes more than one pass a step", integrator.name())
    } else if model.mass_count() > most {
        let adapter = match device {
            wgpu::DeviceType::Cpu => "a CPU adapter",
            _ => "a GPU",
        };
        format!(
            "{} masses, more than one workgroup steps on {adapter} ({most})",
            model.mass_count()
        )
    } else {
        return None;
    };
    Some(why)
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

/// XPBD's sweeps of a substep (the springs' colours) or VBD's of a step (the masses'), and the
/// sweeps over all of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Sweeps {
    pub colours: u32,
    pub iterations: u32,
    /// Every sweep over every colour in one dispatch of one workgroup (XPBD on a small scene:
    /// [`xpbd_in_one_group`]) instead of a dispatch per colour and sweep.
    pub one_group: bool,
}

/// One dispatch: a kernel, the state it reads (for the kernels that read one) or the states it
/// reads and writes (the fused kernels), its stage slot relative to its step's first, and for
/// XPBD's projection the colour it solves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dispatch {
    pub kernel: Kernel,
    pub state: Option<StateIn>,
    pub flow: Option<Flow>,
    pub slot: u32,
    pub colour: Option<ColourPass>,
    /// The multigrid cycle's coarse level (1 the first; 0 for every other kernel).
    pub level: u32,
}

impl Dispatch {
    /// A kernel that reads no state.
    pub const fn at(kernel: Kernel, slot: u32) -> Self {
        Self {
            kernel,
            state: None,
            flow: None,
            slot,
            colour: None,
            level: 0,
        }
    }

    /// A kernel that reads `state`.
    pub const fn reading(kernel: Kernel, state: StateIn, slot: u32) -> Self {
        Self {
            state: Some(state),
            ..Self::at(kernel, slot)
        }
    }

    /// A fused kernel, reading and writing the states of `flow`.
    pub const fn flowing(kernel: Kernel, flow: Flow, slot: u32) -> Self {
        Self {
            flow: Some(flow),
            ..Self::at(kernel, slot)
        }
    }

    /// A kernel over one colour (XPBD's projection, VBD's block solve).
    pub const fn colour(kernel: Kernel, pass: ColourPass, slot: u32) -> Self {
        Self {
            colour: Some(pass),
            ..Self::at(kernel, slot)
        }
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
        assert_eq!(vbd_threads(DiscreteGpu, (34, 8), 1024), 288);
        assert_eq!(vbd_threads(DiscreteGpu, (125, 8), 1024), 512);
        assert_eq!(vbd_threads(DiscreteGpu, (125, 8), 256), 256);
        assert_eq!(vbd_threads(Cpu, (125, vbd_lanes(Cpu)), 1024), 8);
        assert_eq!(vbd_threads(Cpu, (125, 16), 1024), 16);
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
}
