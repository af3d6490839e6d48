//! The step plans: which kernels a step dispatches, in order, on which state and at which stage
//! slot. Implicit Euler's solve has a plan of its own, repeated as its iterations need.

use super::dispatch::{ColourPass, Dispatch, StateIn, Sweeps};
use super::fused_plan::{ExplicitPath, fused_step_plan};
use super::implicit;
use super::kernels::Kernel;
use super::multigrid;
use crate::integrator::{Integrator, Over, Step};
use crate::model::{Effects, Model};

/// Every sweep over every colour of `sweeps` at stage slot `slot`: one dispatch of `in_group`
/// when they take one workgroup, else a dispatch of `per_colour` per colour and sweep.
fn sweeps_plan(
    (per_colour, in_group): (Kernel, Kernel),
    sweeps: Sweeps,
    slot: u32,
) -> Vec<Dispatch> {
    if sweeps.one_group {
        return vec![Dispatch::at(in_group, slot)];
    }
    colour_sweeps(per_colour, sweeps, slot).collect()
}

/// `kernel` over every colour of `sweeps`, once per sweep, at stage slot `slot`.
fn colour_sweeps(kernel: Kernel, sweeps: Sweeps, slot: u32) -> impl Iterator<Item = Dispatch> {
    (0..sweeps.iterations).flat_map(move |it| {
        (0..sweeps.colours).map(move |colour| {
            let pass = ColourPass {
                colour,
                first: it == 0,
            };
            Dispatch::colour(kernel, pass, slot)
        })
    })
}

/// How a run rebuilds mass–mass contact's neighbour lists: a pass per phase (count, prefix sum,
/// scatter, sort, lists), or all of them in one workgroup for a scene small enough that the
/// launches of six more dispatches, paid at every force evaluation, would cost more than a
/// rebuild in one workgroup, paid at one evaluation in ten or so.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ListBuild {
    Passes,
    OneGroup,
}

/// The most masses a run builds its lists for in one workgroup.
pub const ONE_GROUP_BUILD_MASSES: usize = 4096;

impl ListBuild {
    pub fn for_masses(mass_count: usize) -> Self {
        if mass_count <= ONE_GROUP_BUILD_MASSES {
            ListBuild::OneGroup
        } else {
            ListBuild::Passes
        }
    }
}

/// Mass–mass contact's neighbour lists made valid for the positions of `state`, in order: the
/// check, then the grid and the lists, rebuilt only when the check found them stale (in one
/// workgroup, one dispatch does it all).
pub fn neighbour_update(build: ListBuild, state: StateIn, slot: u32) -> Vec<Dispatch> {
    use Kernel::*;
    if build == ListBuild::OneGroup {
        return vec![Dispatch::reading(NeighboursBuild, state, slot)];
    }
    vec![
        Dispatch::reading(NeighboursCheck, state, slot),
        Dispatch::reading(GridCount, state, slot),
        Dispatch::at(GridScanBlocks, slot),
        Dispatch::at(GridScanSums, slot),
        Dispatch::at(GridScanAdd, slot),
        Dispatch::at(GridScatter, slot),
        Dispatch::at(GridSortCells, slot),
        Dispatch::reading(NeighbourLists, state, slot),
    ]
}

/// The dispatches of one step. `build`: how mass–mass contact rebuilds its lists (unused
/// without it); `prime`: Verlet's first step also evaluates a(x_0); `sweeps`: XPBD's or VBD's
/// (unused by the other integrators). Implicit Euler's solve is planned below; only the
/// post-step passes are here for it.
pub fn step_plan(
    integrator: Integrator,
    effects: &Effects,
    build: ListBuild,
    prime: bool,
    sweeps: Sweeps,
) -> Vec<Dispatch> {
    use Kernel::*;
    use StateIn::*;
    let forces = |state, slot| Dispatch::reading(ComputeForces, state, slot);
    let at = Dispatch::at;
    let mut plan = match integrator {
        Integrator::Euler => vec![forces(XV, 0), at(EulerUpdate, 0)],
        Integrator::SemiImplicit => vec![forces(XV, 0), at(SemiImplicitUpdate, 0)],
        Integrator::Rk2 => vec![
            forces(XV, 0),
            at(Rk2Stage, 0),
            forces(XtVt, 1),
            at(Rk2Final, 0),
        ],
        Integrator::Rk4 => vec![
            forces(XV, 0),
            at(Rk4Begin, 0),
            forces(XtVt, 1),
            at(Rk4Mid, 1),
            forces(XtVt, 2),
            at(Rk4Mid, 2),
            forces(XtVt, 3),
            at(Rk4Final, 0),
        ],
        Integrator::Verlet => {
            let mut p = vec![at(VerletDrift, 0), forces(XVt, 3), at(VerletKick, 0)];
            if prime {
                p.insert(0, forces(XV, 0));
            }
            p
        }
        // compute_forces is compiled with XPBD: every force but the springs'.
        Integrator::Xpbd => [forces(XV, 0), at(XpbdPredict, 0)]
            .into_iter()
            .chain(sweeps_plan((XpbdSolveSpring, XpbdSweeps), sweeps, 0))
            .chain([at(XpbdUpdateVelocity, 0)])
            .collect(),
        // Implicit's solve is planned apart.
        Integrator::Implicit | Integrator::Bdf2 => Vec::new(),
        // The guess; the block solves at the step's end (where backward Euler takes its forces
        // and collider poses); the forces there for the ledger and the residual; the new state;
        // the step's residual.
        Integrator::Vbd => [at(VbdPredict, 0)]
            .into_iter()
            .chain(sweeps_plan((VbdSolveMass, VbdSweeps), sweeps, 3))
            .chain([forces(XtVt, 3), at(VbdFinal, 3), at(VbdResidual, 3)])
            .collect(),
    };
    // A scheme that assembles the contacts' blocks solves them; the others project.
    if effects.has_contact() && !integrator.scheme().assembles_blocks() {
        plan.push(at(ProjectContacts, 3));
    }
    if effects.self_collision.is_some() {
        plan = plan
            .into_iter()
            .flat_map(|d| with_mass_contact(d, build))
            .collect();
    }
    if effects.springs_change() {
        plan.push(at(UpdateSprings, 3));
    }
    plan
}

/// A force evaluation with mass–mass contact: the neighbour lists made valid for its positions,
/// the forces, then the pairs' added to them.
fn with_mass_contact(d: Dispatch, build: ListBuild) -> Vec<Dispatch> {
    match (d.kernel, d.state) {
        (Kernel::ComputeForces, Some(state)) => neighbour_update(build, state, d.slot)
            .into_iter()
            .chain([d, Dispatch::reading(Kernel::CollideMasses, state, d.slot)])
            .collect(),
        _ => vec![d],
    }
}

/// How many dispatches one GPU step records: `fixed`, plus (implicit Euler a dispatch per pass)
/// so many per Newton iteration and per CG iteration that the step takes (the frame's budgets
/// also encode a few that find their step or solve stopped and return at once,
/// `implicit.rs`). A fused Euler or semi-implicit
/// run whose submission has an odd number of steps also copies the state back once (not a
/// dispatch).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DispatchCount {
    /// Whether the steps are the fused ones (`fused.wgsl`).
    pub fused: bool,
    /// Whether every step of a submission is one dispatch (`fused_frame.wgsl`): `fixed` is then
    /// per submission.
    pub in_group: bool,
    pub fixed: u32,
    pub per_newton_iteration: u32,
    pub per_cg_iteration: u32,
}

/// The colour sweeps a step of `integrator` runs: XPBD's over the springs' colours, VBD's over
/// the masses'; none for the others.
pub fn sweeps_of(
    model: &Model,
    integrator: Integrator,
    options: crate::integrator::StepOptions,
    one_group: bool,
) -> Sweeps {
    let Some(of) = integrator.scheme().sweeps() else {
        return Sweeps::default();
    };
    let colours = match of.over {
        Over::Springs => crate::physics::colour_springs(&model.springs, &model.inv_mass).colours(),
        Over::Masses => crate::physics::vbd_colouring(model).colours(),
    };
    Sweeps {
        colours: colours as u32,
        iterations: of.count(&options),
        one_group,
    }
}

/// The dispatches of `model`'s steps after the first (not Verlet's priming one) on `path`.
pub(super) fn steady_step_plan(
    model: &Model,
    integrator: Integrator,
    path: ExplicitPath,
    sweeps: Sweeps,
) -> Vec<Dispatch> {
    match path {
        ExplicitPath::InGroup => vec![Dispatch::at(Kernel::FusedFrame, 0)],
        ExplicitPath::Fused => fused_step_plan(integrator, false, false),
        ExplicitPath::General => step_plan(
            integrator,
            &model.effects,
            ListBuild::for_masses(model.mass_count()),
            false,
            sweeps,
        ),
    }
}

/// The paths a run's steps take, as `GpuBackend::step_paths` gives them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepPaths {
    pub explicit: ExplicitPath,
    /// Implicit Euler's path (by the system's size where `None`).
    pub implicit: Option<implicit::Path>,
    /// XPBD's or VBD's sweeps in one workgroup.
    pub sweeps_in_group: bool,
    /// Coarse levels of implicit Euler's multigrid cycle (0: block Jacobi).
    pub multigrid_levels: u32,
}

/// For `bench throughput`: the dispatches of a step after the first (Verlet's first also
/// evaluates a(x₀)), as the plans above record them on the run's `paths`.
pub fn dispatches_per_step(model: &Model, step: Step, paths: StepPaths) -> DispatchCount {
    use implicit::*;
    let StepPaths {
        explicit,
        implicit,
        sweeps_in_group,
        multigrid_levels,
    } = paths;
    let Step {
        integrator,
        options,
        ..
    } = step;
    let count = |n: usize| n as u32;
    let sweeps = sweeps_of(model, integrator, options, sweeps_in_group);
    let steps = count(steady_step_plan(model, integrator, explicit, sweeps).len());
    // The multigrid cycle's passes: a Newton iteration's levels and a cycle before each cg_apply.
    let (linearise, cycle) = match multigrid_levels {
        0 => (0, 0),
        l => (multigrid::linearise(l).len(), multigrid::cycle(l).len()),
    };
    match (
        integrator.newton(),
        implicit.unwrap_or_else(|| super::sizing::implicit_path(model)),
    ) {
        (true, Path::InGroup) => DispatchCount {
            fixed: count(IN_GROUP.len()) + steps,
            ..DispatchCount::default()
        },
        (true, Path::Passes) => DispatchCount {
            fixed: count(
                begin(crate::physics::BackwardStep::restarts_at_impacts(
                    integrator,
                    &model.effects,
                ))
                .len()
                    + END.len(),
            ) + steps,
            per_newton_iteration: count(NEWTON_BEGIN.len() + NEWTON_END.len() + linearise + cycle),
            per_cg_iteration: count(CG_ITERATION.len() + cycle),
            ..DispatchCount::default()
        },
        _ => DispatchCount {
            fused: explicit != ExplicitPath::General,
            in_group: explicit == ExplicitPath::InGroup,
            fixed: steps,
            ..DispatchCount::default()
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::dispatch::SLOTS_PER_STEP;
    use crate::gpu::fused_plan::FUSED;
    use crate::model::{ContactModel, MassContact};

    /// The grid stencil brings a fused semi-implicit step at cloth-256 under 18 B of compulsory
    /// traffic per spring update (x and v read and written, each mass's mass and ledger; nothing
    /// per spring; with links it was 34 B); the general passes move four times
    /// that.
    #[test]
    fn a_fused_cloth_256_step_moves_at_most_18_bytes_per_spring() {
        let scene = crate::scene::BUILT_IN
            .iter()
            .find(|b| b.name == "cloth-256")
            .map(|b| b.toml)
            .expect("built-in");
        let scene = crate::scene::from_toml(scene, crate::scene::SceneOrigin::Text).expect("valid");
        let model = crate::model::build(&scene);
        let sizes = crate::gpu::kernels::Sizes::of(&model, (0, 0));
        let per_spring = |plan: Vec<Dispatch>| {
            let bytes: u64 = plan.iter().filter_map(|d| d.kernel.bytes(&sizes)).sum();
            bytes as f64 / sizes.ns as f64
        };
        let integrator = Integrator::SemiImplicit;
        let fused = per_spring(fused_step_plan(integrator, false, false));
        let general = per_spring(step_plan(
            integrator,
            &model.effects,
            ListBuild::Passes,
            false,
            Sweeps::default(),
        ));
        assert!(fused <= 18.0, "{fused:.1} B per spring update");
        assert!(
            general > 3.5 * fused,
            "general {general:.1} B, fused {fused:.1} B"
        );
    }

    /// Implicit Euler's per-pass path keeps its bound: at most 2 dispatches per CG
    /// iteration, and no kernel of a CG iteration runs on one workgroup alone (each sums the
    /// partials it needs itself).
    #[test]
    fn a_cg_iteration_is_at_most_two_dispatches_over_the_grid() {
        use crate::gpu::kernels::Threads;
        assert!(implicit::CG_ITERATION.len() <= 2);
        for d in implicit::CG_ITERATION {
            assert_eq!(
                d.kernel.spec().threads,
                Threads::SolverGrid,
                "{}",
                d.kernel.name()
            );
        }
        // The solver's grid: on a GPU one workgroup per 64 masses up to its cap; on a CPU
        // adapter one per 2 048 up to 64, as the CPU backend sums.
        use wgpu::DeviceType::{Cpu, DiscreteGpu};
        assert_eq!(crate::gpu::sizing::solver_groups(4096, Cpu), 2);
        assert_eq!(crate::gpu::sizing::solver_groups(100, Cpu), 1);
        assert_eq!(crate::gpu::sizing::solver_groups(1 << 20, Cpu), 64);
        assert_eq!(
            crate::gpu::sizing::solver_groups(1 << 20, DiscreteGpu),
            1024
        );
        assert_eq!(crate::gpu::sizing::solver_groups(0, DiscreteGpu), 1);
    }

    /// XPBD's substep: the kick, every colour once per sweep with the multipliers reset on the
    /// first sweep only, then the new state; no colour is skipped or repeated within a sweep.
    #[test]
    fn an_xpbd_step_sweeps_every_colour_once_per_iteration() {
        let sweeps = Sweeps {
            colours: 4,
            iterations: 3,
            one_group: false,
        };
        let plan = step_plan(
            Integrator::Xpbd,
            &Effects::default(),
            ListBuild::Passes,
            false,
            sweeps,
        );
        let names: Vec<&str> = plan.iter().map(|d| d.kernel.name()).collect();
        assert_eq!(names[..2], ["compute_forces", "xpbd_predict"]);
        assert_eq!(names.last(), Some(&"xpbd_update_velocity"));
        let passes: Vec<ColourPass> = plan.iter().filter_map(|d| d.colour).collect();
        assert_eq!(passes.len(), 12);
        for (k, p) in passes.iter().enumerate() {
            assert_eq!(p.colour, k as u32 % 4);
            assert_eq!(p.first, k < 4);
        }
    }

    /// Every plan binds a state exactly for the kernels that read one (the dispatcher would
    /// refuse it at run time otherwise), and stays within its step's stage slots.
    #[test]
    fn every_plan_reads_a_state_exactly_where_its_kernels_do() {
        let pairs = MassContact {
            radius_m: 0.01,
            contact: ContactModel {
                stiffness_n_per_m: 1.0,
                friction: 0.0,
                damping_ratio: 0.0,
            },
            within_bodies: true,
        };
        let mut plans = vec![
            implicit::IN_GROUP.to_vec(),
            implicit::begin(true).to_vec(),
            implicit::NEWTON_BEGIN.to_vec(),
            implicit::CG_ITERATION.to_vec(),
            implicit::NEWTON_END.to_vec(),
            implicit::END.to_vec(),
        ];
        for integrator in Integrator::ALL {
            for (self_collision, tearing) in [(None, false), (Some(pairs), true)] {
                let effects = Effects {
                    self_collision,
                    tearing,
                    ..Effects::default()
                };
                let sweeps = Sweeps {
                    colours: 3,
                    iterations: 2,
                    one_group: integrator == Integrator::Xpbd && tearing,
                };
                for build in [ListBuild::Passes, ListBuild::OneGroup] {
                    plans.push(step_plan(integrator, &effects, build, true, sweeps));
                    plans.push(step_plan(integrator, &effects, build, false, sweeps));
                }
            }
        }
        for build in [ListBuild::Passes, ListBuild::OneGroup] {
            plans.push(neighbour_update(build, StateIn::XV, 0));
        }
        for integrator in FUSED {
            for (prime, odd) in [(false, false), (true, false), (false, true)] {
                plans.push(fused_step_plan(integrator, prime, odd));
            }
        }
        for d in plans.iter().flatten() {
            let spec = d.kernel.spec();
            assert_eq!(spec.reads_state, d.state.is_some(), "{}", spec.entry);
            assert_eq!(spec.flows, d.flow.is_some(), "{}", spec.entry);
            // Exactly the per-colour kernel names a colour.
            assert_eq!(
                spec.threads == crate::gpu::kernels::Threads::Colour,
                d.colour.is_some(),
                "{}",
                spec.entry
            );
            assert!(d.slot < SLOTS_PER_STEP, "{}", spec.entry);
        }
    }
}
