//! What one call of `advance` records on the GPU: the stage slots of its steps, their
//! dispatches (explicit and sweeping integrators) or implicit Euler's solves, in submissions that
//! a stop can end between (`Dispatcher::encode_in_submissions`).

use super::backend::{GpuBackend, RECENT_FRAMES};
use super::dispatch::{Dispatch, SLOTS_PER_STEP};
use super::fused_plan::{ExplicitPath, fused_step_plan, primes};
use super::implicit::{ImplicitStep, Path};
use super::kernels::Kernel;
use super::plan::{ListBuild, step_plan};
use crate::backend::{BackendError, Internal};
use crate::integrator::Explicit;
use crate::physics::BackwardStep;

impl GpuBackend {
    /// Write the stage slots of the next `steps` steps (in one workgroup without colliders, the
    /// first step's: the kernel reads no other pose), and room for the snapshot's after them.
    pub(super) fn prepare_stages(&mut self, steps: u32) {
        self.reserve_stage_slots(SLOTS_PER_STEP * steps + 1);
        let still = self.model.effects.colliders.is_empty();
        let laid = match self.explicit_path {
            ExplicitPath::InGroup if still => 1,
            _ => steps,
        };
        let stages = self.clock.stages(&self.model, steps, laid);
        self.stages.write(&self.ctx.queue, 0, stages);
    }

    /// What `advance` records for the integrators without a solve on the device: the steps'
    /// dispatches (`advance` then moves the clock and checks the device).
    pub(super) fn advance_explicit(&mut self, substeps: u32) -> Result<(), BackendError> {
        self.prepare_stages(substeps);
        let plan = self.plan_steps(substeps);
        let enc = self.ctx.encoder("steps");
        let (mut enc, recorded) = self
            .kernels()
            .encode_in_submissions(&self.ctx, &self.stop, enc, "steps", &plan)?;
        self.last_recorded = (recorded, plan.len());
        self.copy_back(&mut enc, substeps);
        self.ctx.queue.submit([enc.finish()]);
        Ok(())
    }

    /// The dispatches of one step (`prime`: Verlet's first, which also evaluates a(x_0); `odd`:
    /// a fused Euler or semi-implicit step that reads B).
    pub(super) fn step_plan(&self, prime: bool, odd: bool) -> Vec<Dispatch> {
        match self.explicit_path {
            ExplicitPath::InGroup => return vec![Dispatch::at(Kernel::FusedFrame, 0)],
            ExplicitPath::Fused => return fused_step_plan(self.integrator, prime, odd),
            ExplicitPath::General => {}
        }
        step_plan(
            self.integrator,
            &self.model.effects,
            self.list_build(),
            prime,
            self.resources.sweeps(),
        )
    }

    /// How this run rebuilds mass–mass contact's neighbour lists.
    pub(super) fn list_build(&self) -> ListBuild {
        ListBuild::for_masses(self.model.mass_count())
    }

    /// Whether `steps` steps leave the state in B (fused Euler and semi-implicit Euler
    /// alternate): then [`GpuBackend::copy_back`] returns it to A, where everything else reads it.
    pub(super) fn ends_in_b(&self, steps: u32) -> bool {
        self.explicit_path == ExplicitPath::Fused
            && matches!(
                self.integrator.scheme().explicit(),
                Some(Explicit::OneUpdate { .. })
            )
            && steps % 2 == 1
    }

    /// After `steps` steps, record the copy of B's x and v to A if they ended there.
    pub(super) fn copy_back(&self, enc: &mut wgpu::CommandEncoder, steps: u32) {
        if self.ends_in_b(steps) {
            let r = &self.resources;
            enc.copy_buffer_to_buffer(&r.xt, 0, &r.x, 0, r.x.size());
            enc.copy_buffer_to_buffer(&r.vt, 0, &r.v, 0, r.v.size());
        }
    }

    /// The dispatches of the next `steps` steps, each slot counted from slot 0; Verlet's first
    /// step also evaluates a(x_0). In one workgroup, one dispatch runs them all.
    pub(super) fn plan_steps(&mut self, steps: u32) -> Vec<Dispatch> {
        if self.explicit_path == ExplicitPath::InGroup {
            // No steps, no dispatch: the kernel would run the count a stale slot holds.
            return match steps {
                0 => Vec::new(),
                _ => self.step_plan(false, false),
            };
        }
        let warm = [self.step_plan(false, false), self.step_plan(false, true)];
        let mut all = Vec::with_capacity(warm[0].len() * steps as usize);
        for k in 0..steps {
            let prime = !self.verlet_primed && primes(self.integrator);
            let plan = if prime {
                self.step_plan(true, false)
            } else {
                warm[k as usize % 2].clone()
            };
            all.extend(plan.into_iter().map(|d| Dispatch {
                slot: SLOTS_PER_STEP * k + d.slot,
                ..d
            }));
            self.verlet_primed = true;
        }
        all
    }

    /// What `advance` records for implicit Euler and BDF2: their solves, in one workgroup or a
    /// dispatch per pass (replayed with larger budgets where a frame outran them).
    pub(super) fn advance_implicit(&mut self, substeps: u32) -> Result<(), BackendError> {
        self.prepare_stages(substeps);
        let post = self.step_plan(false, false);
        let Some(solver) = self.resources.solver.as_ref() else {
            return Err(BackendError::Internal(Internal::NoImplicitSolver));
        };
        let step = ImplicitStep {
            ctx: &self.ctx,
            kernels: self.kernels(),
            stop: &self.stop,
            solver,
            post: &post,
            multigrid: self.resources.multigrid.as_ref().map(|mg| mg.passes()),
            restarts: BackwardStep::restarts_at_impacts(self.integrator, &self.model.effects),
        };
        // The solve's iterations and residual reach the snapshot, read back with the frame.
        if self.implicit_path == Some(Path::InGroup) {
            step.run_in_group(substeps)?;
        } else {
            let outcome = step.run_frame(substeps, self.budgets)?;
            if self.recent_frames.len() == RECENT_FRAMES {
                self.recent_frames.pop_front();
            }
            self.recent_frames.push_back(outcome.took);
            self.budgets = outcome.budgets.fitted(&self.recent_frames);
            self.replays += u64::from(outcome.replays);
        }
        Ok(())
    }
}
