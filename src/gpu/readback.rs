//! What a snapshot reads back, and how: the reductions, the copy into a staging buffer, and its
//! decoding once mapped. A snapshot holds only what the recorder logs (positions, strain and a
//! few per-workgroup energy sums), and the velocities when the whole state is asked for.

use std::time::Instant;

use glam::Vec3;

use super::dispatch::{Dispatch, StateIn};
use super::encode::Dispatcher;
use super::kernels::Kernel;
use super::layout::COUNTERS_BYTES;
use super::plan::{ListBuild, neighbour_update};
use super::resources::Resources;
use crate::backend::BackendError;
use crate::state::StepStats;

/// A snapshot asked for and not yet collected.
pub struct Pending {
    pub staging: usize,
    pub index: wgpu::SubmissionIndex,
    pub frame: u64,
    pub stats: StepStats,
    pub time_secs: f64,
    pub steps: u64,
    pub started: Option<Instant>,
}

/// A snapshot as decoded.
pub struct ReadBack {
    pub positions: Vec<Vec3>,
    pub velocities: Vec<Vec3>,
    pub strain: Vec<f32>,
    pub energy: [f64; 4],
    pub ledger: [f64; 4],
    /// Energy let go by plasticity and tearing since the last read-back.
    pub released: f64,
    pub max_speed: f32,
    pub non_finite: bool,
    pub projections: u32,
    /// Of those, the deep ones (counters[7]: contact_projection.wgsl's `deep`).
    pub deep_projections: u32,
    /// Index, within the last submission of steps, of the first step whose state went bad.
    pub first_bad_step: Option<u32>,
    /// Implicit Euler and BDF2: what their steps since the last read-back booked.
    pub solve: SolveRecord,
}

/// What the implicit steps since the last read-back booked in the counters (implicit_terms.wgsl's
/// book_solve and book_step): the most CG iterations of a step and the largest CG residual, the
/// most Newton iterations, the steps that ended short of Newton's rule, and the largest residual
/// |h f − M Δv| / |h f| a step ended with.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SolveRecord {
    pub cg_iterations: u32,
    pub cg_residual: f32,
    pub newton_iterations: u32,
    pub unmet_steps: u32,
    pub step_residual: f32,
}

impl SolveRecord {
    /// How the booked steps met Newton's rule.
    pub fn rule(&self) -> crate::state::RuleOutcome {
        crate::state::RuleOutcome {
            step_residual: f64::from(self.step_residual),
            unmet_steps: self.unmet_steps,
        }
    }
}

/// Where each part of a snapshot lies in a staging buffer, in bytes.
#[derive(Debug, Clone, Copy)]
pub struct StagingLayout {
    n: u64,
    ns: u64,
    partial_count: u64,
}

impl StagingLayout {
    pub fn new(n: usize, ns: usize, partial_count: u64) -> Self {
        Self {
            n: n as u64,
            ns: ns as u64,
            partial_count,
        }
    }
    const X: u64 = 0;
    fn v(&self) -> u64 {
        16 * self.n
    }
    fn strain(&self) -> u64 {
        32 * self.n
    }
    fn partials(&self) -> u64 {
        self.strain() + 4 * self.ns.max(1)
    }
    fn counters(&self) -> u64 {
        self.partials() + 48 * self.partial_count
    }
}

/// Which reductions a snapshot takes besides the energies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reductions {
    /// Each spring's strain (a model with springs).
    pub strain: bool,
    /// The energy springs let go (plasticity, tearing).
    pub released: bool,
    /// Mass–mass contact's pair potential, on a grid built as this says.
    pub pairs: Option<ListBuild>,
}

/// The reductions of a snapshot at stage slot `slot`: strain, energies, the energy springs let
/// go, and the pair potential of the positions read back, on a grid built from them.
pub fn encode_reductions(
    kernels: &Dispatcher<'_>,
    pass: &mut wgpu::ComputePass<'_>,
    slot: u32,
    which: Reductions,
) -> Result<(), BackendError> {
    let mut plan = Vec::new();
    if which.strain {
        plan.push(Dispatch::at(Kernel::ComputeStrain, 0));
    }
    plan.push(Dispatch::at(Kernel::ComputeEnergies, 0));
    if which.released {
        plan.push(Dispatch::at(Kernel::SumSpringWork, 0));
    }
    if let Some(build) = which.pairs {
        plan.extend(neighbour_update(build, StateIn::XV, 0));
        plan.push(Dispatch::reading(Kernel::MassContactEnergy, StateIn::XV, 0));
    }
    kernels.dispatch_all(pass, &plan, slot)
}

/// Copy a snapshot into staging buffer `k` and clear what the next frame sums afresh.
pub fn copy_to_staging(
    enc: &mut wgpu::CommandEncoder,
    r: &Resources,
    at: StagingLayout,
    k: usize,
    with_velocity: bool,
) {
    let staging = &r.staging[k];
    enc.copy_buffer_to_buffer(&r.x, 0, staging, StagingLayout::X, 16 * at.n);
    if with_velocity {
        enc.copy_buffer_to_buffer(&r.v, 0, staging, at.v(), 16 * at.n);
    }
    if at.ns > 0 {
        enc.copy_buffer_to_buffer(&r.strain, 0, staging, at.strain(), 4 * at.ns);
    }
    enc.copy_buffer_to_buffer(
        &r.partials,
        0,
        staging,
        at.partials(),
        48 * at.partial_count,
    );
    enc.copy_buffer_to_buffer(&r.counters, 0, staging, at.counters(), COUNTERS_BYTES);
    enc.clear_buffer(&r.ledger, 0, None);
    enc.clear_buffer(&r.counters, 0, None);
}

/// The per-workgroup partials, summed in workgroup order: 8 energy and ledger sums in f64, the
/// largest speed, the count of non-finite values and the energy springs let go.
fn sum_partials(partials: &[f32]) -> ([f64; 8], f32, f32, f64) {
    let mut sum = [0.0f64; 8];
    let mut max_speed = 0.0f32;
    let mut bad = 0.0f32;
    let mut released = 0.0f64;
    for p in partials.chunks_exact(12) {
        for (s, q) in sum.iter_mut().zip(&p[..8]) {
            *s += f64::from(*q);
        }
        max_speed = max_speed.max(p[8]);
        bad += p[9];
        released += f64::from(p[10]);
    }
    (sum, max_speed, bad, released)
}

/// What a snapshot's staging buffer holds beyond positions and strain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decode {
    /// The velocities were copied too.
    pub with_velocity: bool,
    /// Springs may be broken: their strain reads as NaN.
    pub tearing: bool,
}

/// Decode a mapped staging buffer; `positions` and `strain` are refilled. `tearing`: broken
/// springs are marked (compute_strain's BROKEN_STRAIN) and read as NaN.
pub fn decode(
    data: &[u8],
    at: StagingLayout,
    read: Decode,
    (mut positions, mut strain): (Vec<Vec3>, Vec<f32>),
) -> ReadBack {
    let Decode {
        with_velocity,
        tearing,
    } = read;
    let f32s = |off: u64, count: u64| -> &[f32] {
        bytemuck::cast_slice(&data[off as usize..(off + 4 * count) as usize])
    };
    let vec3s = |off: u64| {
        f32s(off, 4 * at.n)
            .chunks_exact(4)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
    };
    let (sum, max_speed, bad, released) = sum_partials(f32s(at.partials(), 12 * at.partial_count));
    let counters_off = at.counters() as usize;
    let counters: &[u32] =
        bytemuck::cast_slice(&data[counters_off..counters_off + COUNTERS_BYTES as usize]);
    positions.clear();
    positions.extend(vec3s(StagingLayout::X));
    strain.clear();
    strain.extend_from_slice(f32s(at.strain(), at.ns));
    if tearing {
        for s in strain.iter_mut().filter(|s| **s == -f32::MAX) {
            *s = f32::NAN;
        }
    }
    ReadBack {
        positions,
        velocities: if with_velocity {
            vec3s(at.v()).collect()
        } else {
            Vec::new()
        },
        strain,
        released,
        energy: [sum[0], sum[1], sum[2], sum[3]],
        ledger: [sum[4], sum[5], sum[6], sum[7]],
        max_speed,
        non_finite: bad > 0.0 || !max_speed.is_finite(),
        projections: counters[0],
        deep_projections: counters[7],
        first_bad_step: (counters[1] != 0).then(|| u32::MAX - counters[1]),
        solve: SolveRecord {
            cg_iterations: counters[2],
            cg_residual: f32::from_bits(counters[3]),
            newton_iterations: counters[4],
            unmet_steps: counters[5],
            step_residual: f32::from_bits(counters[6]),
        },
    }
}
