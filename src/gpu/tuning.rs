//! The choices a GPU run makes for itself: which path its steps take, where a small scene's
//! state lives between steps, how many threads a one-workgroup solve has, whether VBD sweeps its
//! colours in one workgroup. `GpuBackend::new` takes the defaults; the tests and the benchmark
//! examples fix one choice at a time to compare the paths on one scene.

use super::context::GpuContext;
use super::fused_plan::ExplicitPath;
use super::implicit::{Path, SolverHome};
use super::links::Links;
use super::loop_budget::LoopBudget;
use super::resources::Resources;
use super::shaders::{Specialisation, constants};
use super::sizing::{self, FrameState, frame_threads, vbd_in_one_group, vbd_lanes, vbd_threads};
use super::stages::StageSlots;
use crate::integrator::{Integrator, Over, Solve, Step};
use crate::model::Model;
use crate::physics::Preconditioner;

#[doc(hidden)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tuning {
    /// Implicit Euler's steps, whatever the system's size (by default `sizing::implicit_path`).
    pub implicit: Path,
    /// The explicit steps, where the run allows it, else the next path open to it (`InGroup`,
    /// then `Fused`, then `General`).
    pub explicit: ExplicitPath,
    /// Where `fused_frame` keeps a submission's state, where it fits.
    pub frame_state: FrameState,
    /// Threads of implicit Euler's one-workgroup step (by default `sizing::group_threads`).
    pub solver_threads: Option<u32>,
    /// VBD's sweeps in one workgroup (`Some(true)`, whatever the scene's size), a dispatch per
    /// colour and sweep (`Some(false)`), or as the scene's size says on the adapter
    /// (`None`: `vbd_in_one_group`).
    pub vbd_in_group: Option<bool>,
    /// XPBD's sweeps in one workgroup where the scene is small enough (`None`:
    /// `xpbd_in_one_group`), or a dispatch per colour and sweep (`Some(false)`).
    pub xpbd_in_group: Option<bool>,
    /// The threads VBD shares a mass's springs among (by default `vbd_lanes`).
    pub vbd_lanes: Option<u32>,
    /// What preconditions implicit Euler's CG, on either path (by default
    /// `physics::preconditioner_of` the run, as on the CPU).
    pub preconditioner: Preconditioner,
}

impl Tuning {
    /// What a run of `model` as `step` chooses for itself.
    pub fn for_run(model: &Model, step: Step) -> Self {
        Self {
            implicit: sizing::implicit_path(model),
            explicit: ExplicitPath::InGroup,
            frame_state: FrameState::Workgroup,
            solver_threads: None,
            vbd_in_group: None,
            xpbd_in_group: None,
            vbd_lanes: None,
            preconditioner: crate::physics::preconditioner_of(model, step),
        }
    }

    /// `self` on an adapter whose loops run as `budget` says: where the driver cuts a shader
    /// invocation's loops short, no step runs in one workgroup (each such kernel loops over a
    /// whole step, frame or sweep), whatever `self` asked for. Implicit Euler and BDF2 take a
    /// dispatch per pass, the explicit steps a dispatch per step, XPBD's and VBD's sweeps a
    /// dispatch per colour: each of their loops runs over a mass's springs or a thread's share
    /// of the masses. `GpuBackend::kernel_family` says which the run took.
    pub fn within(self, budget: LoopBudget) -> Self {
        if budget.runs_long_loops() {
            return self;
        }
        Self {
            implicit: Path::Passes,
            explicit: match self.explicit {
                ExplicitPath::InGroup => ExplicitPath::Fused,
                other => other,
            },
            vbd_in_group: Some(false),
            xpbd_in_group: Some(false),
            ..self
        }
    }
}

/// A run as [`specialise`] sizes it: the model, its step, its explicit path and its implicit
/// one (if it is implicit Euler's or BDF2's).
#[derive(Debug, Clone, Copy)]
pub(super) struct RunPaths<'a> {
    pub model: &'a Model,
    pub step: Step,
    pub explicit: ExplicitPath,
    pub implicit: Option<Path>,
}

/// The override constants a run's pipelines are compiled with (`shaders::constants`), each
/// one-workgroup kernel sized to the adapter in `ctx` as `tuning` says, and whether `fused_frame`
/// keeps its state in workgroup memory. `links`: the fused steps' links, if it has them.
/// VBD's sweeps leave one workgroup here when `tuning` says so.
pub(super) fn specialise(
    ctx: &GpuContext,
    run: RunPaths<'_>,
    tuning: &Tuning,
    links: Option<&Links>,
    resources: &mut Resources,
) -> (Vec<(&'static str, f64)>, bool) {
    let RunPaths {
        model,
        step,
        explicit,
        implicit,
    } = run;
    let device = ctx.info.device_type;
    let limits = &ctx.limits;
    let kind_shift = links.map_or(31, |l| l.kind_shift);
    let stencils = links.is_some_and(|l| l.stencils.table.count > 0);
    // The one-workgroup step's threads; a run without it keeps the per-pass kernels' 64 slots of
    // sums (implicit.wgsl's sum_sh, in every kernel of the file: more would cost each workgroup
    // of the per-pass path occupancy, cloth-256 a third of its speed on an H100).
    let group_threads = match implicit {
        Some(Path::InGroup) => tuning
            .solver_threads
            .unwrap_or_else(|| sizing::group_threads(device, model.mass_count())),
        _ => super::sizing::WORKGROUP,
    };
    let (stage_stride, _) = StageSlots::stride_for(
        limits.min_uniform_buffer_offset_alignment,
        model.effects.colliders.len(),
    );
    let widest_group = limits
        .max_compute_invocations_per_workgroup
        .min(limits.max_compute_workgroup_size_x);
    let frame_threads = frame_threads(device, model.mass_count(), widest_group);
    // VBD's sweeps: in one workgroup or a dispatch per colour, sized to a mass's lanes.
    let lanes = tuning.vbd_lanes.unwrap_or_else(|| vbd_lanes(device));
    let mut vbd_threads_wanted = lanes;
    if let Some(colours) = resources.colours.as_mut()
        && step.integrator.scheme().sweeps().map(|s| s.over) == Some(Over::Springs)
        && let Some(one_group) = tuning.xpbd_in_group
    {
        colours.sweeps.one_group &= one_group;
    }
    if let Some(colours) = resources.colours.as_mut()
        && step.integrator.scheme().sweeps().map(|s| s.over) == Some(Over::Masses)
    {
        colours.sweeps.one_group = tuning.vbd_in_group.unwrap_or_else(|| {
            vbd_in_one_group(model.mass_count(), colours.sweeps.iterations, device)
        });
        colours.spread(lanes);
        vbd_threads_wanted = vbd_threads(device, colours.widest, lanes, widest_group);
    }
    // The one-workgroup steps' state in workgroup memory where it fits.
    let frame_state_masses = tuning
        .frame_state
        .masses_in_workgroup(
            model.mass_count(),
            limits.max_compute_workgroup_storage_size,
        )
        .filter(|_| explicit == ExplicitPath::InGroup);
    let home = match implicit {
        Some(path) => {
            // The cycle's coarsest inverse takes its share first (mg_implicit_step).
            let cycle = match resources.multigrid {
                Some(_) => super::limits::MULTIGRID_FACTOR_WORKGROUP_BYTES,
                None => 0,
            };
            let bytes = limits.max_compute_workgroup_storage_size;
            SolverHome::of(model, path, group_threads, bytes.saturating_sub(cycle))
        }
        None => SolverHome::Buffers,
    };
    let constants = constants(
        model,
        &Specialisation {
            integrator: step.integrator,
            dt_secs: step.dt_secs,
            kind_shift,
            stencils,
            group_threads,
            solver_threads: sizing::solver_threads(device),
            in_workgroup: home.workgroup_arrays(),
            frame_threads,
            vbd_threads: vbd_threads_wanted,
            vbd_lanes: lanes,
            stage_stride_words: (stage_stride / 4) as u32,
            frame_state: frame_state_masses,
        },
    );
    (constants, frame_state_masses.is_some())
}

/// The kernels a GPU run steps with, as far as they decide what it computes: its integrator and
/// the path each of its steps takes. The conformance probe (`crate::conformance`) keeps one
/// verdict per family and adapter, and steps its small scenes on the same family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct KernelFamily {
    pub integrator: Integrator,
    /// Implicit Euler's and BDF2's path (`None` for the others).
    pub implicit: Option<Path>,
    pub explicit: ExplicitPath,
    /// XPBD's or VBD's sweeps in one workgroup.
    pub sweeps_in_group: bool,
    /// Implicit Euler's CG preconditioned by the multigrid cycle.
    pub multigrid: bool,
}

impl KernelFamily {
    /// A run of `model` as `step` on this family (the paths the adapter allows may still differ;
    /// `GpuBackend::kernel_family` says which it took).
    pub fn tuning(self, model: &Model, step: Step) -> Tuning {
        Tuning {
            implicit: self.implicit.unwrap_or(Path::Passes),
            explicit: self.explicit,
            vbd_in_group: Some(self.sweeps_in_group),
            xpbd_in_group: Some(self.sweeps_in_group),
            preconditioner: match self.multigrid {
                true => Preconditioner::Multigrid,
                false => Preconditioner::BlockJacobi,
            },
            ..Tuning::for_run(model, step)
        }
    }

    /// A name that stays the same from build to build, for the probe's cache.
    pub fn key(self) -> String {
        format!(
            "{}/{:?}/{:?}/{}/{}",
            self.integrator.name(),
            self.implicit,
            self.explicit,
            if self.sweeps_in_group {
                "sweeps-in-group"
            } else {
                "sweeps-per-colour"
            },
            if self.multigrid {
                "multigrid"
            } else {
                "block-jacobi"
            },
        )
    }
}

impl std::fmt::Display for KernelFamily {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.integrator.name())?;
        match self.integrator.scheme().solve {
            Solve::Newton { .. } => {
                let path = match self.implicit {
                    Some(Path::InGroup) => "in one workgroup",
                    _ => "a dispatch per pass",
                };
                let pre = if self.multigrid {
                    "multigrid"
                } else {
                    "block Jacobi"
                };
                write!(f, " ({path}, {pre})")
            }
            Solve::Sweeps(_) => match self.sweeps_in_group {
                true => f.write_str(" (sweeps in one workgroup)"),
                false => f.write_str(" (a dispatch per colour)"),
            },
            Solve::Explicit(_) => match self.explicit {
                ExplicitPath::InGroup => f.write_str(" (a submission's steps in one workgroup)"),
                ExplicitPath::Fused => f.write_str(" (fused, a dispatch per step)"),
                ExplicitPath::General => f.write_str(" (a pass per stage)"),
            },
        }
    }
}
