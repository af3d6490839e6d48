//! What a run took and hooks for tests: its loop budget, paths and kernel family, its adapter;
//! the GPU's hash grid and its count of neighbour-list builds read back, and a
//! device lost on purpose.

use super::backend::GpuBackend;
use super::context::ReadBackOf;
use super::dispatch::StateIn;
use super::encode::in_pass;
use super::implicit::Path;
use super::loop_budget::LoopBudget;
use super::plan::neighbour_update;
use super::tuning::KernelFamily;
use crate::backend::BackendError;

/// The GPU's hash grid as read back for tests: bucket b holds
/// `sorted[cell_start[b]..cell_start[b + 1]]` (as the CPU backend's `MassGrid`).
#[doc(hidden)]
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GridReadBack {
    pub cell_start: Vec<u32>,
    pub sorted: Vec<u32>,
}

impl GpuBackend {
    /// What the adapter's loops allowed this run: on a driver that cuts loops short, no step
    /// runs in one workgroup (`Tuning::within`).
    pub fn loop_budget(&self) -> LoopBudget {
        self.loop_budget
    }

    /// The dispatches the last `advance` of an explicit or sweeping integrator recorded, and
    /// those it planned: fewer where a stop cut its steps short (`Backend::watch`).
    pub fn last_recorded(&self) -> (usize, usize) {
        self.last_recorded
    }

    /// The path implicit Euler's or BDF2's steps take (`None` for the other integrators).
    pub fn implicit_path(&self) -> Option<Path> {
        self.implicit_path
    }

    /// The adapter the run steps on, as wgpu names it (its driver and version included).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.ctx.info
    }

    /// The kernels this run steps with, for the conformance probe.
    pub fn kernel_family(&self) -> KernelFamily {
        KernelFamily {
            integrator: self.integrator,
            implicit: self.implicit_path,
            explicit: self.explicit_path(),
            sweeps_in_group: self.sweeps_in_group(),
            multigrid: self.multigrid_levels() > 0,
        }
    }

    /// Lose the device on purpose, as a driver reset would: for tests of what a run does then.
    #[doc(hidden)]
    pub fn lose_device(&self) {
        self.ctx.lose_device();
    }

    /// For tests: make the neighbour lists valid for the current positions on the GPU (their
    /// first build, on a fresh backend) and read back the hash grid they were built with. `None`
    /// without mass–mass contact.
    #[doc(hidden)]
    pub fn mass_grid(&mut self) -> Result<Option<GridReadBack>, BackendError> {
        self.reserve_stage_slots(1);
        let Some(g) = self.resources.grid.as_ref() else {
            return Ok(None);
        };
        let starts = 4 * (u64::from(g.table_size) + 1);
        let masses = 4 * self.model.mass_count() as u64;
        let slot = self.stages.last();
        let build = self.list_build();
        let mut enc = self.ctx.encoder("grid");
        in_pass(&mut enc, "grid", |pass| {
            self.kernels()
                .dispatch_all(pass, &neighbour_update(build, StateIn::XV, 0), slot)
        })?;
        let words = self.read_words(enc, &g.grid_index, starts + masses)?;
        let (a, b) = words.split_at(starts as usize / 4);
        Ok(Some(GridReadBack {
            cell_start: a.to_vec(),
            sorted: b.to_vec(),
        }))
    }

    /// How many times the GPU has built its neighbour lists (tests, and `Backend::
    /// neighbour_builds` for the benchmarks). `None` without mass–mass contact.
    #[doc(hidden)]
    pub fn neighbour_builds(&mut self) -> Result<Option<u32>, BackendError> {
        let Some(g) = self.resources.grid.as_ref() else {
            return Ok(None);
        };
        let enc = self.ctx.encoder("neighbour builds");
        let words = self.read_words(enc, &g.neighbours, 8)?;
        Ok(Some(words[1]))
    }

    /// The first `bytes` of `buffer` after the commands of `enc`.
    fn read_words(
        &self,
        mut enc: wgpu::CommandEncoder,
        buffer: &wgpu::Buffer,
        bytes: u64,
    ) -> Result<Vec<u32>, BackendError> {
        let read = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("inspect read"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        enc.copy_buffer_to_buffer(buffer, 0, &read, 0, bytes);
        let index = self.ctx.queue.submit([enc.finish()]);
        let slice = read.slice(..);
        self.ctx.map_and_wait(&slice, index, ReadBackOf::Grid)?;
        let out = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| self.ctx.read_back_failed(ReadBackOf::Grid, e))?;
            bytemuck::cast_slice::<u8, u32>(&data).to_vec()
        };
        read.unmap();
        Ok(out)
    }
}
