//! Implicit Euler on the GPU, the host's side of `shaders/implicit.wgsl`: the same Newton
//! iterations and conjugate-gradient solves as `crate::cpu`'s `implicit_step`, with the same
//! stopping rules. Each Newton iteration is encoded with a chunk of CG iterations (as many as the
//! last solve took) and the solver's status is read back after it; a solve that needs more gets
//! further chunks, each twice as long. Kernels of a solve that has stopped do nothing, so a chunk
//! longer than needed costs only empty dispatches.

use super::context::{DeviceError, GpuContext};
use super::encode::{Dispatcher, in_pass};
use super::layout::SolverStatus;
use super::plan::{Dispatch, implicit::*};
use super::resources::SolverBuffers;
use crate::backend::BackendError;
use crate::cpu::NEWTON_MAX_ITERATIONS;

/// The fewest CG iterations a chunk encodes.
pub const MIN_CHUNK: u32 = 8;

/// One implicit step's solve, on the device.
pub struct ImplicitStep<'a> {
    pub ctx: &'a GpuContext,
    pub kernels: Dispatcher<'a>,
    pub solver: &'a SolverBuffers,
    /// The passes every integrator runs after its step (plasticity, tearing).
    pub post: &'a [Dispatch],
}

impl ImplicitStep<'_> {
    /// One backward Euler step whose every dispatch reads stage slot `slot`: the step's end time
    /// (backward Euler evaluates forces there), its dt and its index (for the divergence check).
    /// `chunk`: CG iterations to encode before the first status read, the last solve's count;
    /// updated. Returns the solver's status at the step's end.
    pub fn run(&self, slot: u32, chunk: &mut u32) -> Result<SolverStatus, BackendError> {
        let label = "implicit step";
        let mut enc = self.ctx.encoder(label);
        in_pass(&mut enc, label, |pass| {
            self.kernels.dispatch_all(pass, &BEGIN, slot)
        })?;
        let mut status = SolverStatus::default();
        for _ in 0..NEWTON_MAX_ITERATIONS {
            let mut cg = *chunk;
            in_pass(&mut enc, label, |pass| {
                self.kernels.dispatch_all(pass, &NEWTON_BEGIN, slot)?;
                self.encode_cg(pass, cg, slot)
            })?;
            status = self.submit_and_read_status(enc)?;
            while status.cg_active != 0 {
                cg *= 2;
                enc = self.ctx.encoder(label);
                in_pass(&mut enc, label, |pass| self.encode_cg(pass, cg, slot))?;
                status = self.submit_and_read_status(enc)?;
            }
            *chunk = status.iterations.max(MIN_CHUNK);
            enc = self.ctx.encoder(label);
            if status.converged != 0 {
                break;
            }
        }
        in_pass(&mut enc, label, |pass| {
            self.kernels.dispatch_all(pass, &END, slot)?;
            // The post-step passes read this step's slot too.
            for d in self.post {
                self.kernels
                    .dispatch(pass, Dispatch { slot: 0, ..*d }, slot)?;
            }
            Ok(())
        })?;
        self.ctx.queue.submit([enc.finish()]);
        Ok(status)
    }

    /// `iterations` CG iterations, then the Newton update (which waits for the solve to stop).
    fn encode_cg(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        iterations: u32,
        slot: u32,
    ) -> Result<(), BackendError> {
        for _ in 0..iterations {
            self.kernels.dispatch_all(pass, &CG_ITERATION, slot)?;
        }
        self.kernels.dispatch_all(pass, &NEWTON_END, slot)
    }

    /// Submit `enc` with a copy of the solver's status, and wait for it.
    fn submit_and_read_status(
        &self,
        mut enc: wgpu::CommandEncoder,
    ) -> Result<SolverStatus, BackendError> {
        let size = std::mem::size_of::<SolverStatus>() as u64;
        let s = self.solver;
        enc.copy_buffer_to_buffer(&s.scratch, 0, &s.status, 0, size);
        let index = self.ctx.queue.submit([enc.finish()]);
        let slice = s.status.slice(..);
        self.ctx.map_and_wait(&slice, index)?;
        let status = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| DeviceError::ReadBack {
                    what: format!("the solver status from {}", self.ctx.describe()),
                    cause: e.to_string(),
                })?;
            bytemuck::pod_read_unaligned::<SolverStatus>(&data[..size as usize])
        };
        s.status.unmap();
        Ok(status)
    }
}
