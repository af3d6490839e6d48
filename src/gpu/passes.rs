//! What `hooke check` shows of a GPU step: its passes in order, why a run does not take the fused
//! path, and the effects compiled into the kernels, from the plans in `plan.rs`.

use super::backend::GpuBackend;
use super::dispatch::{Sweeps, sweeps_in_one_group};
use super::implicit;
use super::plan::{explicit_path, steady_step_plan};
use super::shaders::effect_constants;
use crate::integrator::{Integrator, Step};
use crate::model::Model;
use crate::physics::Preconditioner;
use crate::physics::hierarchy::Hierarchy;

/// For `hooke check`: the kernels one GPU step dispatches, in order, on an adapter with enough
/// storage buffers for the fused steps (and why a run does not take them), and the effects
/// compiled into them (absent effects are specialised away and cost nothing).
pub fn step_passes(model: &Model, step: Step) -> (Vec<String>, Option<String>, Vec<&'static str>) {
    let integrator = step.integrator;
    let mut passes = if integrator.newton() {
        let path = implicit::path(model);
        let levels = match crate::physics::preconditioner_of(model, step) {
            Preconditioner::Multigrid => Hierarchy::new(model).map_or(0, |h| h.levels.len() as u32),
            Preconditioner::BlockJacobi => 0,
        };
        vec![implicit::passes(path, levels)]
    } else {
        Vec::new()
    };
    let gpu = wgpu::DeviceType::DiscreteGpu;
    let (path, why) = explicit_path(model, integrator, (u32::MAX, gpu));
    // XPBD's sweeps are listed once, in brackets: their count is the run's.
    let one_sweep = Sweeps {
        colours: 1,
        iterations: 1,
        one_group: sweeps_in_one_group(model, (integrator, step.options), gpu),
    };
    let plan = steady_step_plan(model, integrator, path, one_sweep);
    passes.extend(plan.into_iter().map(|d| match d.colour {
        Some(_) => format!("[iterations × colours: {}]", d.kernel.name()),
        None => d.kernel.name().to_owned(),
    }));
    let why = match integrator {
        Integrator::Implicit | Integrator::Bdf2 | Integrator::Xpbd | Integrator::Vbd => None,
        _ => why,
    };
    let effects = effect_constants(model)
        .into_iter()
        .filter(|(_, on)| *on != 0.0)
        .map(|(name, _)| name)
        .collect();
    (passes, why, effects)
}

/// The kernels one step of `gpu`'s run dispatches on its adapter, in order: `step_passes`'
/// list for the paths the adapter gave it (a driver that caps loops takes no step in one
/// workgroup, so its steps may differ from a discrete GPU's).
pub fn adapter_step_passes(gpu: &GpuBackend, model: &Model, integrator: Integrator) -> Vec<String> {
    let mut passes = match gpu.implicit_path() {
        Some(path) => vec![implicit::passes(path, gpu.multigrid_levels())],
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
