//! The explicit schemes' fused steps: whether a run takes them (and why not), on which path, and
//! the dispatches of one fused step.

use super::dispatch::{Dispatch, Flow, StateIn};
use super::kernels::Kernel;
use super::sizing::why_not_in_group;
use super::verdicts::Unfused;
use crate::integrator::Integrator;
use crate::model::Model;

/// How a run's explicit steps are dispatched: fused (`fused.wgsl`: each step's per-mass passes
/// folded into its force gathers, the state ping-ponging between A and B), fused with every step
/// of a submission in one dispatch of one workgroup (`fused_frame.wgsl`: small scenes), or a
/// pass per stage. Each path is open to the runs of the one after it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExplicitPath {
    InGroup,
    Fused,
    General,
}

/// Why a run cannot take the fused steps, or `None` when it can (given compact links for its
/// springs, `links.rs`). `storage_buffers`: what the adapter allows per shader stage.
fn why_unfused(model: &Model, integrator: Integrator, storage_buffers: u32) -> Option<Unfused> {
    let e = &model.effects;
    let needed = super::limits::FUSED_STORAGE_BUFFERS_NEEDED;
    Some(if fused_step_plan(integrator, false, false).is_empty() {
        Unfused::NoFusedStep(integrator)
    } else if e.springs_change() {
        Unfused::SpringsChange
    } else if e.self_collision.is_some() {
        Unfused::MassContact
    } else if storage_buffers < needed {
        Unfused::StorageBuffers {
            allowed: storage_buffers,
            needed,
        }
    } else {
        return None;
    })
}

/// Whether a run's steps keep a third state, C (RK4's fused stages ping-pong B and C).
pub fn keeps_stage_c(integrator: Integrator) -> bool {
    match integrator {
        Integrator::Rk4 => true,
        Integrator::Euler
        | Integrator::SemiImplicit
        | Integrator::Rk2
        | Integrator::Verlet
        | Integrator::Implicit
        | Integrator::Xpbd
        | Integrator::Vbd
        | Integrator::Bdf2 => false,
    }
}

/// Whether a run's first step also evaluates a(x₀), which the later ones keep from the step
/// before (Verlet).
pub fn primes(integrator: Integrator) -> bool {
    match integrator {
        Integrator::Verlet => true,
        Integrator::Euler
        | Integrator::SemiImplicit
        | Integrator::Rk2
        | Integrator::Rk4
        | Integrator::Implicit
        | Integrator::Xpbd
        | Integrator::Vbd
        | Integrator::Bdf2 => false,
    }
}

/// A fused run's dispatches of one step, none for a scheme with no fused step. Euler and
/// semi-implicit Euler alternate A → B and B → A (`odd`: the step reads B); the others return
/// to A within the step. `prime`: Verlet's first step, which also evaluates a(x₀) (with the
/// general kernel, into deriv).
pub fn fused_step_plan(integrator: Integrator, prime: bool, odd: bool) -> Vec<Dispatch> {
    use Flow::*;
    use Kernel::*;
    let flowing = Dispatch::flowing;
    match integrator {
        Integrator::Euler | Integrator::SemiImplicit => {
            vec![flowing(FusedStep, if odd { BA } else { AB }, 0)]
        }
        Integrator::Verlet => {
            let mut p = vec![
                flowing(FusedVerletDrift, AB, 0),
                flowing(FusedVerletKick, BA, 3),
            ];
            if prime {
                p.insert(0, Dispatch::reading(ComputeForces, StateIn::XV, 0));
            }
            p
        }
        Integrator::Rk4 => vec![
            flowing(FusedRk4Begin, AB, 0),
            flowing(FusedRk4Mid, BC, 1),
            flowing(FusedRk4Mid, CB, 2),
            flowing(FusedRk4Final, BA, 3),
        ],
        Integrator::Rk2
        | Integrator::Implicit
        | Integrator::Xpbd
        | Integrator::Vbd
        | Integrator::Bdf2 => Vec::new(),
    }
}

/// The path a run's explicit steps take on a `device` allowing `storage_buffers` storage
/// buffers per stage, and why when it is not the fused one (in one workgroup or not).
pub fn explicit_path(
    model: &Model,
    integrator: Integrator,
    (storage_buffers, device): (u32, wgpu::DeviceType),
) -> (ExplicitPath, Option<Unfused>) {
    match fused_links(model, integrator, storage_buffers) {
        Ok(_) if why_not_in_group(model, integrator, device).is_none() => {
            (ExplicitPath::InGroup, None)
        }
        Ok(_) => (ExplicitPath::Fused, None),
        Err(why) => (ExplicitPath::General, Some(why)),
    }
}

/// The compact links a fused run steps with, or why the run takes the general passes: the one
/// decision `explicit_path` reports and the backend acts on.
pub fn fused_links(
    model: &Model,
    integrator: Integrator,
    storage_buffers: u32,
) -> Result<super::links::Links, Unfused> {
    match why_unfused(model, integrator, storage_buffers) {
        Some(why) => Err(why),
        None => super::links::Links::build(model).map_err(Unfused::NoLinks),
    }
}

/// The schemes with a fused step, for the tests of the plans.
#[cfg(test)]
pub(super) const FUSED: [Integrator; 4] = [
    Integrator::Euler,
    Integrator::SemiImplicit,
    Integrator::Verlet,
    Integrator::Rk4,
];

#[cfg(test)]
mod tests {
    use super::*;

    /// The fused steps keep their bounds (at most 2 dispatches per step, RK4 5), each
    /// dispatch reads the state the one before wrote, and a step starts from A and returns to it
    /// (Euler and semi-implicit Euler every second step).
    #[test]
    fn fused_steps_chain_their_states_within_the_dispatch_bounds() {
        let ends = |f: Flow| match f {
            Flow::AB => ('A', 'B'),
            Flow::BA => ('B', 'A'),
            Flow::BC => ('B', 'C'),
            Flow::CB => ('C', 'B'),
        };
        for integrator in FUSED {
            let bound = if integrator == Integrator::Rk4 { 5 } else { 2 };
            let mut at = 'A';
            for odd in [false, true] {
                let plan = fused_step_plan(integrator, false, odd);
                assert!(!plan.is_empty() && plan.len() <= bound, "{integrator}");
                for d in &plan {
                    let (from, to) = ends(d.flow.expect("a fused kernel"));
                    assert_eq!(from, at, "{integrator} {}", d.kernel.name());
                    at = to;
                }
                let single = matches!(integrator, Integrator::Euler | Integrator::SemiImplicit);
                assert_eq!(at, if single && !odd { 'B' } else { 'A' }, "{integrator}");
            }
        }
    }
}
