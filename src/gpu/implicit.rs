//! Implicit Euler on the GPU, the host's side of `shaders/implicit.wgsl`: the same Newton
//! iterations and conjugate-gradient solves as `crate::cpu`'s `implicit_step`, with the same
//! stopping rules, taken one of two ways (`plan::implicit::path`):
//! - a small system's step is one dispatch of `implicit_step`, one workgroup deciding every
//!   stopping rule on the device: a frame's steps go in one submission and nothing waits;
//! - a larger one's Newton iteration is encoded with a chunk of CG iterations (as many as the last
//!   solve took) and the solver's status is read back after it; a solve that needs more gets
//!   further chunks, each twice as long. Kernels of a solve that has stopped do nothing, so a
//!   chunk longer than needed costs only empty dispatches.
//!
//! Either way each step books its CG iterations and residual on the device, and the frame's
//! snapshot reads them back (`readback.rs`).

use super::context::{DeviceError, GpuContext};
use super::encode::{Dispatcher, in_pass};
use super::layout::SolverStatus;
use super::plan::{Dispatch, SLOTS_PER_STEP, implicit::*};
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
    /// `steps` steps of a small system, one dispatch each (with the post-step passes), in one
    /// submission; nothing waits. Step k reads stage slot 4k + 3, its end.
    pub fn run_in_group(&self, steps: u32) -> Result<(), BackendError> {
        let label = "implicit steps";
        let mut enc = self.ctx.encoder(label);
        in_pass(&mut enc, label, |pass| {
            (0..steps).try_for_each(|k| {
                let slot = SLOTS_PER_STEP * k + 3;
                self.kernels.dispatch_all(pass, &IN_GROUP, slot)?;
                self.post_step(pass, slot)
            })
        })?;
        self.ctx.queue.submit([enc.finish()]);
        Ok(())
    }

    /// The passes every integrator runs after its step; they read the step's slot too.
    fn post_step(&self, pass: &mut wgpu::ComputePass<'_>, slot: u32) -> Result<(), BackendError> {
        self.post.iter().try_for_each(|d| {
            self.kernels
                .dispatch(pass, Dispatch { slot: 0, ..*d }, slot)
        })
    }

    /// One backward Euler step whose every dispatch reads stage slot `slot`: the step's end time
    /// (backward Euler evaluates forces there), its dt and its index (for the divergence check).
    /// `chunk`: CG iterations to encode before the first status read, the last solve's count;
    /// updated.
    pub fn run(&self, slot: u32, chunk: &mut u32) -> Result<(), BackendError> {
        let label = "implicit step";
        let mut enc = self.ctx.encoder(label);
        in_pass(&mut enc, label, |pass| {
            self.kernels.dispatch_all(pass, &BEGIN, slot)
        })?;
        for _ in 0..NEWTON_MAX_ITERATIONS {
            let mut cg = *chunk;
            in_pass(&mut enc, label, |pass| {
                self.kernels.dispatch_all(pass, &NEWTON_BEGIN, slot)?;
                self.encode_cg(pass, cg, slot)
            })?;
            let mut status = self.submit_and_read_status(enc)?;
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
            self.post_step(pass, slot)
        })?;
        self.ctx.queue.submit([enc.finish()]);
        Ok(())
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
