//! Hooks for tests: the GPU's hash grid read back, and a device lost on purpose.

use super::backend::GpuBackend;
use super::context::ReadBackOf;
use super::dispatch::StateIn;
use super::encode::in_pass;
use super::plan::grid_build;
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
    /// Lose the device on purpose, as a driver reset would: for tests of what a run does then.
    #[doc(hidden)]
    pub fn lose_device(&self) {
        self.ctx.lose_device();
    }

    /// For tests: build the hash grid on the GPU from the current positions and read it back.
    /// `None` without mass–mass contact.
    #[doc(hidden)]
    pub fn mass_grid(&mut self) -> Result<Option<GridReadBack>, BackendError> {
        self.reserve_stage_slots(1);
        let Some(g) = self.resources.grid.as_ref() else {
            return Ok(None);
        };
        let starts = 4 * (u64::from(g.table_size) + 1);
        let masses = 4 * self.model.mass_count() as u64;
        let read = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("grid read"),
            size: starts + masses,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.ctx.encoder("grid");
        let slot = self.stages.last();
        in_pass(&mut enc, "grid", |pass| {
            self.kernels()
                .dispatch_all(pass, &grid_build(StateIn::XV, 0), slot)
        })?;
        enc.copy_buffer_to_buffer(&g.cell_start, 0, &read, 0, starts);
        enc.copy_buffer_to_buffer(&g.sorted, 0, &read, starts, masses);
        let index = self.ctx.queue.submit([enc.finish()]);
        let slice = read.slice(..);
        self.ctx.map_and_wait(&slice, index, ReadBackOf::Grid)?;
        let out = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| self.ctx.read_back_failed(ReadBackOf::Grid, e))?;
            let words: &[u32] = bytemuck::cast_slice(&data);
            let (a, b) = words.split_at(starts as usize / 4);
            GridReadBack {
                cell_start: a.to_vec(),
                sorted: b.to_vec(),
            }
        };
        read.unmap();
        Ok(Some(out))
    }
}
