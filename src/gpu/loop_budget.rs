//! How many loop iterations the adapter lets one shader invocation run.
//!
//! A conforming driver runs a loop until its own condition ends it. Mesa's llvmpipe (lavapipe)
//! before 23.x does not: gallivm gives every shader function one counter, set to 65 535 at its
//! entry and decremented at the back edge of *every* loop in it, nested ones included, and a
//! loop stops when the counter reaches zero, whatever its own condition says
//! (`LP_MAX_TGSI_LOOP_ITERATIONS`, a guard inherited from its TGSI days). Debian 12's own
//! `mesa-vulkan-drivers` 22.3.6 has it; Mesa 25 (bookworm-backports) does not. A kernel that
//! runs a whole step in one workgroup loops hundreds of times per Newton or CG iteration or per
//! sweep, so on such a driver its later iterations silently do nothing: the implicit cloth
//! froze in mid-air, VBD stopped sweeping after 163 sweeps (docs/drivers.md).
//!
//! `LOOP_BUDGET_WGSL` is the smallest kernel that shows it: one invocation counts to a number
//! read from a buffer. `LoopBudget::measure` runs it once when a device opens, and the run
//! keeps every dispatch's loops well inside what it finds (`LoopBudget::runs_long_loops`).

use super::context::GpuContext;

/// Iterations the probe asks for: four times the cap it looks for, and few enough that a
/// conforming driver counts them in well under a millisecond.
pub const PROBE_ITERATIONS: u32 = 1 << 18;

/// One invocation counts `words[0]` loop iterations and writes the count to `words[1]`. The
/// bound is read from a buffer so that no compiler can unroll the loop away (the cap counts
/// back edges, and an unrolled loop has none).
pub const LOOP_BUDGET_WGSL: &str = "
@group(0) @binding(0) var<storage, read_write> words: array<u32, 2>;

@compute @workgroup_size(1)
fn loop_budget() {
    let n = words[0];
    var count = 0u;
    for (var i = 0u; i < n; i++) {
        count += 1u;
    }
    words[1] = count;
}
";

/// What the probe found on an adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoopBudget {
    /// Every loop ran to its own end.
    Unbounded,
    /// The driver stopped the probe's loops after `iterations` of `PROBE_ITERATIONS`.
    Capped { iterations: u32 },
}

impl LoopBudget {
    /// Whether the one-workgroup kernels may run here: each loops far more often than any
    /// driver's cap over a step, a frame or a solve, so on a capped adapter every step takes
    /// the kernels of a dispatch per pass (or per colour, or per step) instead, whose loops run
    /// over one mass's springs or a thread's share of the masses.
    pub fn runs_long_loops(self) -> bool {
        self == LoopBudget::Unbounded
    }

    /// The probe's own figure from `counted` iterations of `PROBE_ITERATIONS`.
    pub fn from_count(counted: u32) -> Self {
        if counted >= PROBE_ITERATIONS {
            LoopBudget::Unbounded
        } else {
            LoopBudget::Capped {
                iterations: counted,
            }
        }
    }

    /// Run the probe on `ctx`'s device. A probe that cannot run (a lost device) counts as a
    /// cap of nothing: the run then takes the paths of short loops, which every adapter runs.
    pub fn measure(ctx: &GpuContext) -> Self {
        match count_on(ctx) {
            Some(counted) => Self::from_count(counted),
            None => LoopBudget::Capped { iterations: 0 },
        }
    }
}

impl std::fmt::Display for LoopBudget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoopBudget::Unbounded => write!(f, "loops run to their end ({PROBE_ITERATIONS} tried)"),
            LoopBudget::Capped { iterations } => write!(
                f,
                "the driver ends a shader invocation's loops after {iterations} iterations in all \
                 (Mesa's llvmpipe before 23.x; update Mesa for the one-workgroup steps)"
            ),
        }
    }
}

/// The probe's count on `ctx`, or `None` where the device failed it.
fn count_on(ctx: &GpuContext) -> Option<u32> {
    use wgpu::util::DeviceExt;
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("loop_budget"),
        source: wgpu::ShaderSource::Wgsl(LOOP_BUDGET_WGSL.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("loop_budget"),
        layout: None,
        module: &module,
        entry_point: Some("loop_budget"),
        compilation_options: Default::default(),
        cache: None,
    });
    let words = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("loop_budget"),
        contents: bytemuck::cast_slice(&[PROBE_ITERATIONS, 0u32]),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("loop_budget read"),
        size: 8,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("loop_budget"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: words.as_entire_binding(),
        }],
    });
    let mut enc = ctx.encoder("loop_budget");
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    enc.copy_buffer_to_buffer(&words, 0, &read, 0, 8);
    let index = ctx.queue.submit([enc.finish()]);
    let slice = read.slice(..);
    ctx.map_and_wait(&slice, index, super::context::ReadBackOf::Probe)
        .ok()?;
    let counted = {
        let view = slice.get_mapped_range().ok()?;
        bytemuck::cast_slice::<u8, u32>(&view).get(1).copied()
    };
    read.unmap();
    counted
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_count_short_of_the_probe_is_a_cap() {
        assert_eq!(
            LoopBudget::from_count(PROBE_ITERATIONS),
            LoopBudget::Unbounded
        );
        let capped = LoopBudget::from_count(65_535);
        assert_eq!(capped, LoopBudget::Capped { iterations: 65_535 });
        assert!(!capped.runs_long_loops());
        assert!(LoopBudget::Unbounded.runs_long_loops());
    }
}
