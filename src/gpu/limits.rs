//! Whether a scene fits the adapter: its largest buffers against the adapter's limits, checked
//! before anything is allocated, so that a scene too large is refused with the numbers instead
//! of failing inside wgpu.

use super::context::{AdapterError, GpuContext};
use super::layout::{MAX_COLLIDERS, SOLVER_VECTORS};
use super::verdicts::{BlockJacobiInstead, MultigridUnbound};
#[cfg(test)]
use crate::integrator::StepOptions;
use crate::integrator::{Integrator, Solve, Step};
use crate::model::Model;

/// Storage buffers the kernels bind per stage at most (collide_masses.wgsl).
const STORAGE_BUFFERS_NEEDED: u32 = 8;
/// The fused steps': RK4's middle stages bind ten in group 0 and four in the state flow
/// (fused.wgsl). An adapter with fewer takes the general passes.
pub const FUSED_STORAGE_BUFFERS_NEEDED: u32 = 14;
/// Implicit Euler's: implicit_step reads and writes everything a step touches (implicit.wgsl).
const IMPLICIT_STORAGE_BUFFERS_NEEDED: u32 = 15;
/// The multigrid cycle's kernels bind the solver's and two more (multigrid.wgsl); an adapter
/// with fewer preconditions the CG by block Jacobi.
pub const MULTIGRID_STORAGE_BUFFERS_NEEDED: u32 = 17;

/// The most masses implicit Euler's one-workgroup step takes (`sizing::implicit_path`): 32 per thread.
/// Beyond that, a dispatch per pass spreads the masses over the device.
pub const IN_GROUP_MAX_MASSES: usize = 2048;

/// Workgroup memory of the coarsest level's elimination (`dense_sh`, `pivot_row_sh` and
/// `pivot_col_sh` in multigrid.wgsl, f32).
pub const MULTIGRID_FACTOR_WORKGROUP_BYTES: u32 = {
    let n = 3 * crate::physics::hierarchy::COARSEST_NODES as u32;
    4 * (n * n + 2 * n)
};

/// The one-workgroup step's workgroup memory with the cycle, at its widest (512 threads): the
/// elimination and the sums (`implicit::plan`'s `sum_scratch_bytes`, which asserts the bound).
/// The per-pass path's `mg_factor` takes the elimination and 64 slots of sums: within WebGPU's
/// least limit (16 KiB), so it always fits.
pub const MULTIGRID_IN_GROUP_WORKGROUP_BYTES: u32 =
    MULTIGRID_FACTOR_WORKGROUP_BYTES + 16 * 512 + 560;
const _: () = assert!(MULTIGRID_FACTOR_WORKGROUP_BYTES + 16 * 64 + 560 <= 16 * 1024);

/// Why an adapter with `limits` cannot run the multigrid cycle on `model`'s implicit steps
/// (its CG then takes block Jacobi), or `None`: the one decision both `GpuBackend::new`
/// (`multigrid::Layout::for_run`) and `hooke check` take.
pub fn multigrid_unbound_by(model: &Model, limits: &wgpu::Limits) -> Option<MultigridUnbound> {
    let buffers = limits.max_storage_buffers_per_shader_stage;
    let bytes = limits.max_compute_workgroup_storage_size;
    if buffers < MULTIGRID_STORAGE_BUFFERS_NEEDED {
        Some(MultigridUnbound::StorageBuffers {
            allowed: buffers,
            needed: MULTIGRID_STORAGE_BUFFERS_NEEDED,
        })
    } else if model.mass_count() <= IN_GROUP_MAX_MASSES
        && bytes < MULTIGRID_IN_GROUP_WORKGROUP_BYTES
    {
        Some(MultigridUnbound::WorkgroupMemory {
            allowed: bytes,
            needed: MULTIGRID_IN_GROUP_WORKGROUP_BYTES,
        })
    } else {
        None
    }
}

/// Bytes of the per-mass scratch: RK4's and Verlet's stage sums, or implicit Euler's vectors.
pub fn scratch_bytes(model: &Model, integrator: Integrator) -> u64 {
    // VBD keeps each mass's velocity at the last step's start in [i] and its residual's workgroup
    // sums after those (RK4 and Verlet use three per mass);
    // After the solver's vectors: the best iterate's Δv and rates (BEST_DV, BEST_RATES), then
    // BDF2's last step start (HISTORY_X, HISTORY_V).
    let per_mass = match integrator.scheme().solve {
        Solve::Newton { history } => 16 * (SOLVER_VECTORS + 2 + if history { 2 } else { 0 }),
        Solve::Explicit(_) | Solve::Sweeps(_) => 48,
    };
    per_mass * model.mass_count() as u64
}

/// Bytes of compute_forces' output: acceleration and rates, and for implicit Euler and VBD with
/// contacts their linearisation.
pub fn deriv_bytes(model: &Model, integrator: Integrator) -> u64 {
    let per_mass = if integrator.scheme().assembles_blocks() && model.effects.has_contact() {
        64
    } else {
        32
    };
    per_mass * model.mass_count() as u64
}

/// Refuse a scene beyond the adapter's limits.
pub fn check_fits(
    ctx: &GpuContext,
    model: &Model,
    integrator: Integrator,
) -> Result<(), AdapterError> {
    let n = model.mass_count() as u64;
    let ns = model.spring_count() as u64;
    let limit = ctx
        .limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size);
    let largest = [
        ("per-mass scratch", scratch_bytes(model, integrator)),
        ("per-mass derivatives", deriv_bytes(model, integrator)),
        ("springs", 20 * ns),
        ("adjacency", 16 * ns),
        (
            "implicit spring terms",
            if integrator.newton() { 64 * ns } else { 0 },
        ),
        (
            "mass-contact hash grid",
            model.effects.self_collision.map_or(0, |_| {
                4 * (u64::from(crate::physics::table_size(n as usize)) + 1 + n)
            }),
        ),
        (
            "mass-contact neighbour lists",
            model
                .effects
                .self_collision
                .map_or(0, |_| super::layout::neighbour_bytes(n)),
        ),
    ];
    if let Some((what, bytes)) = largest.into_iter().find(|(_, bytes)| *bytes > limit) {
        return Err(AdapterError::BufferTooLarge {
            adapter: ctx.describe(),
            what,
            bytes,
            limit,
            masses: n,
            springs: ns,
        });
    }
    // Scene files are held to this by validation; a model built by hand is checked here, since
    // each stage slot has room for only this many collider poses.
    let colliders = model.effects.colliders.len();
    if colliders > MAX_COLLIDERS {
        return Err(AdapterError::TooManyColliders {
            colliders,
            max: MAX_COLLIDERS,
        });
    }
    let allowed = ctx.limits.max_storage_buffers_per_shader_stage;
    let needed = if integrator.newton() {
        IMPLICIT_STORAGE_BUFFERS_NEEDED
    } else {
        STORAGE_BUFFERS_NEEDED
    };
    if allowed < needed {
        return Err(AdapterError::TooFewStorageBuffers {
            adapter: ctx.describe(),
            allowed,
            needed,
        });
    }
    Ok(())
}

/// Why a run of `model` as `step` says, whose CG multigrid would precondition, takes block
/// Jacobi on the GPU instead, on an adapter with `limits` (`None` when it does not).
fn multigrid_unbound(
    model: &Model,
    step: Step,
    limits: &wgpu::Limits,
) -> Option<BlockJacobiInstead> {
    let wanted = step.integrator.newton()
        && crate::physics::preconditioner_of(model, step)
            == crate::physics::Preconditioner::Multigrid;
    wanted
        .then(|| multigrid_unbound_by(model, limits))
        .flatten()
        .map(BlockJacobiInstead)
}

/// For `hooke check`: the adapter a run would use, its relevant limits, and whether the scene fits.
pub fn adapter_report(
    name: Option<&str>,
    model: &Model,
    step: Step,
) -> Result<String, AdapterError> {
    let ctx = GpuContext::open(name)?;
    let l = &ctx.limits;
    let mut fits = match check_fits(&ctx, model, step.integrator) {
        Ok(()) => "the scene fits".to_owned(),
        Err(e) => e.to_string(),
    };
    if let Some(why) = multigrid_unbound(model, step, l) {
        fits.push_str(&format!("; {why}"));
    }
    let budget = super::loop_budget::LoopBudget::measure(&ctx);
    if !budget.runs_long_loops() {
        fits.push_str(&format!(
            "; {budget}: no step runs in one workgroup here, each takes a dispatch per pass, \
             step or colour"
        ));
    }
    Ok(format!(
        "adapter: {} (max storage buffer {} MiB, {} storage buffers per stage, {} workgroups per dimension, {} KiB of workgroup memory, timestamps {}); {fits}",
        ctx.describe(),
        l.max_storage_buffer_binding_size.min(l.max_buffer_size) >> 20,
        l.max_storage_buffers_per_shader_stage,
        l.max_compute_workgroups_per_dimension,
        l.max_compute_workgroup_storage_size >> 10,
        if ctx.features.contains(wgpu::Features::TIMESTAMP_QUERY) {
            "yes"
        } else {
            "no"
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The elimination's workgroup arrays in multigrid.wgsl are sized for the coarsest level's
    /// `COARSEST_NODES`, as `MULTIGRID_FACTOR_WORKGROUP_BYTES` counts them.
    #[test]
    fn the_elimination_arrays_hold_the_coarsest_level() {
        let n = 3 * crate::physics::hierarchy::COARSEST_NODES;
        let text = include_str!("../../shaders/multigrid.wgsl");
        assert!(text.contains(&format!("const COARSEST_UNKNOWNS: u32 = {n}u;")));
        assert!(text.contains(&format!("var<workgroup> dense_sh: array<f32, {}>;", n * n)));
        assert!(text.contains("var<workgroup> pivot_row_sh: array<f32, COARSEST_UNKNOWNS>;"));
        assert!(text.contains("var<workgroup> pivot_col_sh: array<f32, COARSEST_UNKNOWNS>;"));
    }

    /// `check` says when an adapter cannot run the multigrid cycle and the GPU's CG falls back
    /// to block Jacobi: only for an implicit system multigrid would precondition (a large one,
    /// or a small one asked to), and only below the cycle's buffers or, in the one-workgroup
    /// step, its workgroup memory.
    #[test]
    fn check_says_when_the_gpu_cannot_take_multigrid() {
        use crate::physics::Preconditioner;
        let at = |integrator| Step::new(integrator, 1.0 / 60.0);
        let adapter = |buffers, bytes| wgpu::Limits {
            max_storage_buffers_per_shader_stage: buffers,
            max_compute_workgroup_storage_size: bytes,
            ..wgpu::Limits::default()
        };
        let (needed, roomy) = (MULTIGRID_STORAGE_BUFFERS_NEEDED, 32 * 1024);
        let short = adapter(needed - 1, roomy);
        let crate::run::prepare::Planned { model, .. } =
            crate::run::prepare::planned("cloth-64").expect("the built-in cloth-64 is planned");
        let why = multigrid_unbound(&model, at(Integrator::Implicit), &short);
        let unbound = MultigridUnbound::StorageBuffers {
            allowed: needed - 1,
            needed,
        };
        assert_eq!(why, Some(BlockJacobiInstead(unbound)));
        assert!(multigrid_unbound(&model, at(Integrator::Bdf2), &short).is_some());
        assert!(
            multigrid_unbound(&model, at(Integrator::Implicit), &adapter(needed, roomy)).is_none()
        );
        assert!(multigrid_unbound(&model, at(Integrator::SemiImplicit), &short).is_none());
        // The per-pass path fits WebGPU's least workgroup memory.
        let least = adapter(needed, 16 * 1024);
        assert!(multigrid_unbound(&model, at(Integrator::Implicit), &least).is_none());
        let crate::run::prepare::Planned { model, .. } =
            crate::run::prepare::planned("jello").expect("the built-in jello is planned");
        assert!(multigrid_unbound(&model, at(Integrator::Implicit), &short).is_none());
        let asked = at(Integrator::Implicit).with_options(StepOptions {
            preconditioner: Some(Preconditioner::Multigrid),
            ..StepOptions::default()
        });
        assert!(multigrid_unbound(&model, asked, &short).is_some());
        assert!(multigrid_unbound(&model, asked, &adapter(needed, roomy)).is_none());
        let why = multigrid_unbound(&model, asked, &least);
        let unbound = MultigridUnbound::WorkgroupMemory {
            allowed: 16 * 1024,
            needed: MULTIGRID_IN_GROUP_WORKGROUP_BYTES,
        };
        assert_eq!(why, Some(BlockJacobiInstead(unbound)));
    }
}
