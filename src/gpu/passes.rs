//! What `hooke check` shows of a GPU step: its passes in order, why a run does not take the fused
//! path, and the effects compiled into the kernels, from the plans in `plan.rs`.

use super::backend::GpuBackend;
use super::dispatch::Sweeps;
use super::fused_plan::explicit_path;
use super::implicit;
use super::kernels::Kernel;
use super::plan::steady_step_plan;
use super::shaders::effect_constants;
use super::sizing::{
    FRAME_STATE_BYTES_PER_MASS, implicit_path, one_group_step_masses, sweeps_in_one_group,
    vbd_lanes, why_not_in_group,
};
use super::stencils::stencil_cover;
use super::verdicts::{NotInGroup, Unfused};
use crate::integrator::{Integrator, Over, Step};
use crate::model::Model;
use crate::physics::Preconditioner;
use crate::physics::hierarchy::Hierarchy;

/// One GPU step of a run as `hooke check` shows it: what a discrete GPU would dispatch, and why
/// the run takes the paths it does. `check` asks for it and prints it (`Display`); every figure
/// and reason is the GPU backend's own.
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport {
    /// Its kernels in order (XPBD's and VBD's sweeps once, in brackets: their count is the
    /// run's), on an adapter with enough storage buffers for the fused steps.
    pub passes: Vec<String>,
    /// Why its explicit steps do not take the fused path.
    pub unfused: Option<Unfused>,
    /// A submission's steps in one workgroup (`fused_frame`): up to how many masses.
    pub in_group: Option<InGroup>,
    /// Why fused one-update steps take a dispatch each, not one a submission.
    pub not_in_group: Option<NotInGroup>,
    /// How many masses of a fused run find their springs from their grid cell.
    pub stencils: Option<StencilCover>,
    /// XPBD's or VBD's sweeps.
    pub sweeps: Option<SweepReport>,
    /// The effects compiled into its kernels (absent effects are specialised away and cost
    /// nothing).
    pub effects: Vec<&'static str>,
}

/// Up to how many masses a submission's steps run in one workgroup, and what each keeps in
/// workgroup memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InGroup {
    pub gpu_masses: usize,
    pub cpu_adapter_masses: usize,
    pub state_bytes_per_mass: u32,
}

/// A fused run's grid stencils: `masses` of `of` masses, in `bodies` grid bodies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StencilCover {
    pub bodies: usize,
    pub masses: usize,
    pub of: usize,
}

/// XPBD's or VBD's sweeps: their colours and count, their kernel, and whether a step (XPBD's
/// substep) sweeps them in one dispatch of one workgroup.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SweepReport {
    pub over: Over,
    pub colours: usize,
    pub sweeps: u32,
    /// What one count of sweeps serves: "step" or "substep".
    pub per: &'static str,
    pub kernel: &'static str,
    /// Threads that share a mass's springs on a GPU (VBD's).
    pub gpu_lanes: u32,
    pub in_group_on_gpu: bool,
    pub in_group_on_cpu_adapter: bool,
}

/// For `hooke check`: one step of `step`'s run of `model` on a discrete GPU.
pub fn step_report(model: &Model, step: Step) -> StepReport {
    use wgpu::DeviceType::{Cpu, DiscreteGpu};
    let integrator = step.integrator;
    let mut passes = if integrator.newton() {
        let path = implicit_path(model);
        let levels = match crate::physics::preconditioner_of(model, step) {
            Preconditioner::Multigrid => Hierarchy::new(model).map_or(0, |h| h.levels.len() as u32),
            Preconditioner::BlockJacobi => 0,
        };
        let restarts =
            crate::physics::BackwardStep::restarts_at_impacts(integrator, &model.effects);
        vec![implicit::passes(path, levels, restarts)]
    } else {
        Vec::new()
    };
    let (path, why) = explicit_path(model, integrator, (u32::MAX, DiscreteGpu));
    let in_group = |device| sweeps_in_one_group(model, step, device);
    let one_sweep = Sweeps {
        colours: 1,
        iterations: 1,
        one_group: in_group(DiscreteGpu),
    };
    let plan = steady_step_plan(model, integrator, path, one_sweep);
    passes.extend(plan.into_iter().map(|d| match d.colour {
        Some(_) => format!("[iterations × colours: {}]", d.kernel.name()),
        None => d.kernel.name().to_owned(),
    }));
    // Only an explicit scheme has an explicit path to explain.
    let unfused = integrator.scheme().explicit().and(why);
    let fused = unfused.is_none() && passes.iter().any(|p| p.starts_with("fused_"));
    let frame = passes.iter().any(|p| p == "fused_frame");
    let one_update = matches!(
        integrator.scheme().explicit(),
        Some(crate::integrator::Explicit::OneUpdate { .. })
    );
    let sweeps = integrator.scheme().sweeps().map(|of| {
        let colours = match of.over {
            Over::Springs => {
                crate::physics::colour_springs(&model.springs, &model.inv_mass).colours()
            }
            Over::Masses => crate::physics::vbd_colouring(model).colours(),
        };
        SweepReport {
            over: of.over,
            colours,
            sweeps: of.count(&step.options),
            per: of.per,
            kernel: match of.over {
                Over::Springs => Kernel::XpbdSolveSpring.name(),
                Over::Masses => Kernel::VbdSolveMass.name(),
            },
            gpu_lanes: vbd_lanes(DiscreteGpu),
            in_group_on_gpu: in_group(DiscreteGpu),
            in_group_on_cpu_adapter: in_group(Cpu),
        }
    });
    StepReport {
        in_group: frame.then(|| InGroup {
            gpu_masses: one_group_step_masses(DiscreteGpu),
            cpu_adapter_masses: one_group_step_masses(Cpu),
            state_bytes_per_mass: FRAME_STATE_BYTES_PER_MASS,
        }),
        not_in_group: (fused && one_update && !frame)
            .then(|| why_not_in_group(model, integrator, DiscreteGpu))
            .flatten(),
        stencils: fused.then(|| {
            let (bodies, masses) = stencil_cover(model);
            StencilCover {
                bodies,
                masses,
                of: model.mass_count(),
            }
        }),
        effects: effect_constants(model)
            .into_iter()
            .filter(|(_, on)| *on != 0.0)
            .map(|(name, _)| name)
            .collect(),
        passes,
        unfused,
        sweeps,
    }
}

impl std::fmt::Display for StepReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "  GPU step passes: {}", self.passes.join(" → "))?;
        if let Some(g) = &self.in_group {
            writeln!(
                f,
                "  fused_frame: every step of a submission in one dispatch of one workgroup (up \
                 to {} masses on a GPU, {} on a CPU adapter; larger scenes take fused_step), the \
                 state in workgroup memory between steps where {} B a mass fits the adapter's \
                 (its line below), else in the state buffers",
                g.gpu_masses, g.cpu_adapter_masses, g.state_bytes_per_mass
            )?;
        }
        if let Some(why) = &self.unfused {
            writeln!(f, "  not the fused step: {why}")?;
        }
        if let Some(why) = &self.not_in_group {
            writeln!(f, "  a dispatch per step, not one a submission: {why}")?;
        }
        if let Some(c) = &self.stencils {
            writeln!(
                f,
                "  grid stencils: {} of {} masses ({} grid {}) find their springs from their grid \
                 cell, the others read a link per spring",
                c.masses,
                c.of,
                c.bodies,
                if c.bodies == 1 { "body" } else { "bodies" }
            )?;
        }
        if let Some(w) = &self.sweeps {
            let (per, kernel) = (w.per, w.kernel);
            let dispatches = w.colours as u32 * w.sweeps;
            let (head, lanes) = match w.over {
                Over::Springs => (
                    format!(
                        "XPBD: {} spring colours × {} iteration(s)",
                        w.colours, w.sweeps
                    ),
                    String::new(),
                ),
                Over::Masses => (
                    format!("VBD: {} mass colours × {} sweep(s)", w.colours, w.sweeps),
                    format!(
                        "; each mass's springs shared among {} threads on a GPU",
                        w.gpu_lanes
                    ),
                ),
            };
            let how = match (w.in_group_on_gpu, w.in_group_on_cpu_adapter) {
                (true, true) => format!("all in one dispatch of one workgroup per {per}"),
                (true, false) => format!(
                    "all in one dispatch of one workgroup per {per} on a GPU; {dispatches} \
                     {kernel} dispatches per {per} on a CPU adapter, which runs a workgroup on \
                     one core"
                ),
                (false, _) => format!("{dispatches} {kernel} dispatches per {per}"),
            };
            writeln!(f, "  {head}: {how}{lanes}")?;
        }
        write!(
            f,
            "  compiled-in effects: {}",
            if self.effects.is_empty() {
                "none".to_owned()
            } else {
                self.effects.join(", ")
            }
        )
    }
}

/// The kernels one step of `gpu`'s run dispatches on its adapter, in order: `step_report`'s
/// list for the paths the adapter gave it (a driver that caps loops takes no step in one
/// workgroup, so its steps may differ from a discrete GPU's).
pub fn adapter_step_passes(gpu: &GpuBackend, model: &Model, integrator: Integrator) -> Vec<String> {
    let mut passes = match gpu.implicit_path() {
        Some(path) => vec![implicit::passes(
            path,
            gpu.multigrid_levels(),
            crate::physics::BackwardStep::restarts_at_impacts(integrator, &model.effects),
        )],
        None => Vec::new(),
    };
    let one_sweep = Sweeps {
        colours: 1,
        iterations: 1,
        one_group: gpu.sweeps_in_group(),
    };
    let plan = steady_step_plan(model, integrator, gpu.explicit_path(), one_sweep);
    passes.extend(plan.into_iter().map(|d| match d.colour {
        Some(_) => format!("[iterations × colours: {}]", d.kernel.name()),
        None => d.kernel.name().to_owned(),
    }));
    passes
}
