//! Implicit Euler on the GPU, the host's side of `shaders/implicit.wgsl`: the same Newton
//! iterations and conjugate-gradient solves as `crate::cpu`'s `implicit_step`, with the same
//! stopping rules. Each Newton iteration is encoded with a chunk of CG iterations (as many as the
//! last solve took) and the solver's status is read back after it; a solve that needs more gets
//! further chunks, each twice as long. Kernels of a solve that has stopped do nothing, so a chunk
//! longer than needed costs only empty dispatches.

use super::layout::SolverStatus;
use super::{GpuBackend, SLOTS_PER_STEP};
use crate::backend::BackendError;
use crate::cpu::NEWTON_MAX_ITERATIONS;
use crate::state::StepStats;

/// The fewest CG iterations a chunk encodes.
const MIN_CHUNK: u32 = 8;

impl GpuBackend {
    pub(super) fn advance_implicit(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        self.reserve_stage_slots(SLOTS_PER_STEP * substeps + 1);
        let stages = self.stage_times(substeps);
        self.write_slots(0, &stages);
        let (mut iterations, mut residual) = (0u32, 0.0f64);
        for k in 0..substeps {
            // Every dispatch of step k reads slot 4k + 3: the step's end time (backward Euler
            // evaluates forces there), its dt and its index (for the divergence check).
            let status = self.implicit_step(SLOTS_PER_STEP * k + 3)?;
            iterations = iterations.max(status.total_iterations);
            residual = residual.max(f64::from(status.max_residual));
        }
        self.time_secs = self.time_after(substeps);
        self.steps += u64::from(substeps);
        self.frame_steps += substeps;
        self.check_device()?;
        Ok(StepStats {
            substeps,
            dt_secs: f64::from(self.dt),
            solver_iterations: iterations,
            solver_residual: residual,
            ..StepStats::default()
        })
    }

    /// One backward Euler step; returns the solver's status at its end.
    fn implicit_step(&mut self, slot: u32) -> Result<SolverStatus, BackendError> {
        let mut enc = self.encoder("implicit step");
        self.encode(&mut enc, |b, pass| b.dispatch_all(pass, &BEGIN, slot))?;
        let mut status = SolverStatus::default();
        for _ in 0..NEWTON_MAX_ITERATIONS {
            let mut chunk = self.solve.as_ref().map_or(MIN_CHUNK, |s| s.chunk);
            self.encode(&mut enc, |b, pass| {
                b.dispatch_all(pass, &NEWTON_BEGIN, slot)?;
                b.encode_cg(pass, chunk, slot)
            })?;
            status = self.submit_and_read_status(enc)?;
            while status.cg_active != 0 {
                chunk *= 2;
                enc = self.encoder("implicit step");
                self.encode(&mut enc, |b, pass| b.encode_cg(pass, chunk, slot))?;
                status = self.submit_and_read_status(enc)?;
            }
            if let Some(s) = self.solve.as_mut() {
                s.chunk = status.iterations.max(MIN_CHUNK);
            }
            enc = self.encoder("implicit step");
            if status.converged != 0 {
                break;
            }
        }
        self.encode(&mut enc, |b, pass| {
            b.dispatch_all(pass, &END, slot)?;
            // The post-step passes every integrator shares (plasticity, tearing).
            for (kernel, _) in b.step_plan(false) {
                b.dispatch_kernel(pass, kernel, slot)?;
            }
            Ok(())
        })?;
        self.ctx.queue.submit([enc.finish()]);
        Ok(status)
    }

    /// Record `body` in one compute pass of `enc`.
    fn encode(
        &self,
        enc: &mut wgpu::CommandEncoder,
        body: impl FnOnce(&Self, &mut wgpu::ComputePass<'_>) -> Result<(), BackendError>,
    ) -> Result<(), BackendError> {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("implicit step"),
            timestamp_writes: None,
        });
        body(self, &mut pass)
    }

    /// `iterations` CG iterations, then the Newton update (which waits for the solve to stop).
    fn encode_cg(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        iterations: u32,
        slot: u32,
    ) -> Result<(), BackendError> {
        for _ in 0..iterations {
            self.dispatch_all(pass, &CG_ITERATION, slot)?;
        }
        self.dispatch_all(pass, &NEWTON_END, slot)
    }

    fn dispatch_all(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        kernels: &[Named],
        slot: u32,
    ) -> Result<(), BackendError> {
        kernels
            .iter()
            .try_for_each(|&k| self.dispatch_named(pass, k, slot))
    }

    fn dispatch_named(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        kernel: Named,
        slot: u32,
    ) -> Result<(), BackendError> {
        let (Some(p), Some(solve)) = (self.pipelines.implicit.as_ref(), self.solve.as_ref()) else {
            return Err(BackendError::Device(
                "internal: implicit kernels asked for without the implicit integrator".to_owned(),
            ));
        };
        let (bg, s) = (&self.bg, &solve.bind_group);
        let one = (1, 1);
        let (pipeline, group0, state, groups) = match kernel {
            Named::ImplicitBegin => (&p.implicit_begin, &bg.integrate, None, self.mass_groups),
            Named::ImplicitIterate => (&p.implicit_iterate, &bg.integrate, None, self.mass_groups),
            Named::ImplicitFinal => (&p.implicit_final, &bg.integrate, None, self.mass_groups),
            Named::ComputeForces => (
                &self.pipelines.compute_forces,
                &bg.forces_model,
                Some(&bg.state_xtvt),
                self.mass_groups,
            ),
            Named::SolverBegin => (&p.solver_begin, s, None, one),
            Named::ImplicitRhs => (&p.implicit_rhs, s, None, self.mass_groups),
            Named::CgBegin => (&p.cg_begin, s, None, one),
            Named::ApplySystem => (&p.apply_system, s, None, self.mass_groups),
            Named::CgAlpha => (&p.cg_alpha, s, None, one),
            Named::CgUpdate => (&p.cg_update, s, None, self.mass_groups),
            Named::CgBeta => (&p.cg_beta, s, None, one),
            Named::CgDirection => (&p.cg_direction, s, None, self.mass_groups),
            Named::NewtonUpdate => (&p.newton_update, s, None, self.mass_groups),
            Named::NewtonEnd => (&p.newton_end, s, None, one),
        };
        self.dispatch(pass, pipeline, group0, state, slot, groups);
        Ok(())
    }

    /// Submit `enc` with a copy of the solver's status, and wait for it.
    fn submit_and_read_status(
        &self,
        mut enc: wgpu::CommandEncoder,
    ) -> Result<SolverStatus, BackendError> {
        let Some(solve) = self.solve.as_ref() else {
            return Err(BackendError::Device(
                "internal: no implicit solver".to_owned(),
            ));
        };
        let size = std::mem::size_of::<SolverStatus>() as u64;
        enc.copy_buffer_to_buffer(&solve.scratch, 0, &solve.status, 0, size);
        let index = self.ctx.queue.submit([enc.finish()]);
        let slice = solve.status.slice(..);
        self.map_and_wait(&slice, index)?;
        let status = {
            let data = slice.get_mapped_range().map_err(|e| {
                BackendError::Device(format!(
                    "reading the solver status from {} failed: {e}",
                    self.ctx.describe()
                ))
            })?;
            bytemuck::pod_read_unaligned::<SolverStatus>(&data[..size as usize])
        };
        solve.status.unmap();
        Ok(status)
    }
}

/// The dispatches of an implicit step (names as in the WGSL).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Named {
    ImplicitBegin,
    SolverBegin,
    ImplicitIterate,
    ComputeForces,
    ImplicitRhs,
    CgBegin,
    ApplySystem,
    CgAlpha,
    CgUpdate,
    CgBeta,
    CgDirection,
    NewtonUpdate,
    NewtonEnd,
    ImplicitFinal,
}

impl Named {
    fn name(self) -> &'static str {
        match self {
            Named::ImplicitBegin => "implicit_begin",
            Named::SolverBegin => "solver_begin",
            Named::ImplicitIterate => "implicit_iterate",
            Named::ComputeForces => "compute_forces",
            Named::ImplicitRhs => "implicit_rhs",
            Named::CgBegin => "cg_begin",
            Named::ApplySystem => "apply_system",
            Named::CgAlpha => "cg_alpha",
            Named::CgUpdate => "cg_update",
            Named::CgBeta => "cg_beta",
            Named::CgDirection => "cg_direction",
            Named::NewtonUpdate => "newton_update",
            Named::NewtonEnd => "newton_end",
            Named::ImplicitFinal => "implicit_final",
        }
    }
}

/// A step's passes, in order: BEGIN, then per Newton iteration NEWTON_BEGIN, CG_ITERATION
/// repeated, NEWTON_END; then END.
const BEGIN: [Named; 2] = [Named::ImplicitBegin, Named::SolverBegin];
const NEWTON_BEGIN: [Named; 4] = [
    Named::ImplicitIterate,
    Named::ComputeForces,
    Named::ImplicitRhs,
    Named::CgBegin,
];
const CG_ITERATION: [Named; 5] = [
    Named::ApplySystem,
    Named::CgAlpha,
    Named::CgUpdate,
    Named::CgBeta,
    Named::CgDirection,
];
const NEWTON_END: [Named; 2] = [Named::NewtonUpdate, Named::NewtonEnd];
const END: [Named; 1] = [Named::ImplicitFinal];

/// For `hooke check`: the passes of one implicit step, the repeated parts in brackets.
pub fn step_passes() -> String {
    let names = |ks: &[Named]| ks.iter().map(|k| k.name()).collect::<Vec<_>>().join(" → ");
    format!(
        "{} → [Newton: {} → [CG: {}] → {}] → {}",
        names(&BEGIN),
        names(&NEWTON_BEGIN),
        names(&CG_ITERATION),
        names(&NEWTON_END),
        names(&END)
    )
}
