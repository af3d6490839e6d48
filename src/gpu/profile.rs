//! Profiling for `hooke bench`: each kernel's GPU time, from timestamp queries, and the
//! compulsory memory traffic of a step, from the kernel table.

use super::backend::GpuBackend;
use super::context::ReadBackOf;
use crate::backend::BackendError;

impl GpuBackend {
    /// Compulsory memory traffic of one step: every buffer a kernel touches, read (and written)
    /// once per dispatch, caches assumed to absorb the neighbours' repeated reads. Steps/s times
    /// this is the achieved bandwidth that BENCHMARKS.md compares with the card's peak.
    pub fn bytes_per_step(&self) -> u64 {
        let sizes = self.resources.sizes(&self.model);
        self.step_plan(false, false)
            .iter()
            .map(|d| d.kernel.bytes(&sizes).unwrap_or(0))
            .sum()
    }

    /// GPU time of each kernel per step, averaged over `steps` steps (fewer when their
    /// dispatches' two timestamps each would pass a query set's limit), each dispatch timed in
    /// its own pass with timestamp queries. `None` when the adapter has no timestamp queries, or
    /// when one step alone has more dispatches than a query set can time (VBD's or XPBD's
    /// sweeps over many colours).
    pub fn profile_kernels(
        &mut self,
        steps: u32,
    ) -> Result<Option<Vec<(String, f64)>>, BackendError> {
        if !self.ctx.features.contains(wgpu::Features::TIMESTAMP_QUERY) || steps == 0 {
            return Ok(None);
        }
        let per_step = 2 * self.step_plan(false, false).len() as u32;
        let fit = wgpu::QUERY_SET_MAX_QUERIES / per_step.max(1);
        if fit == 0 {
            return Ok(None);
        }
        let steps = steps.min(fit);
        self.prepare_stages(steps);
        let dispatches = self.plan_steps(steps);
        let count = 2 * dispatches.len() as u32;
        let timer = Timestamps::new(&self.ctx.device, count);
        let mut enc = self.ctx.encoder("profile");
        for (q, d) in dispatches.iter().enumerate() {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(d.kernel.name()),
                timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                    query_set: &timer.queries,
                    beginning_of_pass_write_index: Some(2 * q as u32),
                    end_of_pass_write_index: Some(2 * q as u32 + 1),
                }),
            });
            self.kernels().dispatch(&mut pass, *d, 0)?;
        }
        self.copy_back(&mut enc, steps);
        timer.resolve(&mut enc, count);
        self.ctx.queue.submit([enc.finish()]);
        self.clock.advance(steps);
        let slice = timer.read.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.ctx.wait_idle()?;
        let ns_per_tick = f64::from(self.ctx.queue.get_timestamp_period());
        let mut totals: Vec<(String, f64)> = Vec::new();
        {
            let data = slice
                .get_mapped_range()
                .map_err(|e| self.ctx.read_back_failed(ReadBackOf::Timestamps, e))?;
            let ticks: &[u64] = bytemuck::cast_slice(&data);
            for (q, d) in dispatches.iter().enumerate() {
                let ms = ticks[2 * q + 1].saturating_sub(ticks[2 * q]) as f64 * ns_per_tick * 1e-6;
                match totals.iter_mut().find(|(n, _)| n == d.kernel.name()) {
                    Some(t) => t.1 += ms,
                    None => totals.push((d.kernel.name().to_owned(), ms)),
                }
            }
        }
        timer.read.unmap();
        for t in &mut totals {
            t.1 /= f64::from(steps);
        }
        Ok(Some(totals))
    }
}

/// A query set of `count` timestamps and the buffers they are resolved into and read from.
struct Timestamps {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: wgpu::Buffer,
}

impl Timestamps {
    fn new(device: &wgpu::Device, count: u32) -> Self {
        let bytes = 8 * u64::from(count);
        let buffer = |label: &str, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage,
                mapped_at_creation: false,
            })
        };
        Self {
            queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("kernel timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolve: buffer(
                "timestamps",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            read: buffer(
                "timestamps read",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
        }
    }

    fn resolve(&self, enc: &mut wgpu::CommandEncoder, count: u32) {
        enc.resolve_query_set(&self.queries, 0..count, &self.resolve, 0);
        enc.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, 8 * u64::from(count));
    }
}
