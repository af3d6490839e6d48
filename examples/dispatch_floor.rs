//! What one compute dispatch costs on this adapter, apart from any work: a submission of N
//! dispatches of a kernel that does (almost) nothing, timed from submit to the device's finish,
//! per dispatch. Four ways, to tell the launch from what wgpu puts between launches:
//!
//! - `empty`: a kernel that binds nothing, all in one compute pass (no barrier is needed);
//! - `touch`: each dispatch adds 1 to every word of one read-write storage buffer, one pass (each
//!   dispatch depends on the one before: wgpu puts a barrier between them, as between our steps);
//! - `touch, dynamic offset`: the same with a uniform bound at a dynamic offset that moves each
//!   dispatch (how our steps read their stage slot);
//! - `touch, a pass each`: the same, each dispatch in its own compute pass.
//!
//! On an H200 a fused step of a 4 096-mass cloth takes about 7 µs and a 100-mass one about 6 µs
//! (BENCHMARKS.md), against Warp's 2.8 µs per CUDA-graph kernel: this says how much of that is
//! the dispatch itself.
//!
//! `cargo run --release --example dispatch_floor -- [DISPATCHES] [WORDS]` (defaults 1 000, 4 096)

use std::time::Instant;

use hooke::gpu::GpuContext;

const SHADER: &str = r#"
@group(0) @binding(0) var<storage, read_write> words: array<u32>;
@group(0) @binding(1) var<uniform> slot: vec4<u32>;

@compute @workgroup_size(64)
fn empty() {}

@compute @workgroup_size(64)
fn touch(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x < arrayLength(&words)) {
        words[gid.x] = words[gid.x] + 1u;
    }
}

@compute @workgroup_size(64)
fn touch_slot(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x < arrayLength(&words)) {
        words[gid.x] = words[gid.x] + slot.x;
    }
}
"#;

/// Slots of the dynamic-offset uniform, 256 B apart (every adapter's alignment at most).
const SLOT_STRIDE: u64 = 256;
const SLOTS: u64 = 64;

#[derive(Clone, Copy, PartialEq)]
enum Way {
    Empty,
    Touch,
    TouchSlot,
    TouchPassEach,
}

impl Way {
    fn name(self) -> &'static str {
        match self {
            Way::Empty => "empty, one pass",
            Way::Touch => "touch, one pass",
            Way::TouchSlot => "touch, dynamic offset, one pass",
            Way::TouchPassEach => "touch, a pass each",
        }
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dispatches: u32 = args.first().map_or(Ok(1000), |s| s.parse())?;
    let words: u32 = args.get(1).map_or(Ok(4096), |s| s.parse())?;
    let ctx = GpuContext::open(None)?;
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("dispatch_floor"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("words"),
        size: u64::from(words.max(1)) * 4,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let slots = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("slots"),
        size: SLOT_STRIDE * SLOTS,
        usage: wgpu::BufferUsages::UNIFORM,
        mapped_at_creation: false,
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("dispatch_floor"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: false },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(16),
                },
                count: None,
            },
        ],
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("dispatch_floor"),
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: buffer.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &slots,
                    offset: 0,
                    size: wgpu::BufferSize::new(16),
                }),
            },
        ],
    });
    let pipeline_layout = |layouts: &[Option<&wgpu::BindGroupLayout>]| {
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("dispatch_floor"),
            bind_group_layouts: layouts,
            immediate_size: 0,
        })
    };
    let pipeline = |entry: &str, layout: &wgpu::PipelineLayout| {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    };
    let bare = pipeline_layout(&[]);
    let bound = pipeline_layout(&[Some(&layout)]);
    let empty = pipeline("empty", &bare);
    let touch = pipeline("touch", &bound);
    let touch_slot = pipeline("touch_slot", &bound);
    let groups = words.div_ceil(64).max(1);

    let submit = |way: Way| {
        let mut enc = device.create_command_encoder(&Default::default());
        let mut pass = None;
        for d in 0..dispatches {
            if way == Way::TouchPassEach || pass.is_none() {
                drop(pass.take());
                pass = Some(
                    enc.begin_compute_pass(&Default::default())
                        .forget_lifetime(),
                );
            }
            let Some(p) = pass.as_mut() else { continue };
            match way {
                Way::Empty => {
                    p.set_pipeline(&empty);
                    p.dispatch_workgroups(1, 1, 1);
                }
                Way::Touch | Way::TouchPassEach => {
                    p.set_pipeline(&touch);
                    p.set_bind_group(0, &group, &[0]);
                    p.dispatch_workgroups(groups, 1, 1);
                }
                Way::TouchSlot => {
                    p.set_pipeline(&touch_slot);
                    let offset = (u64::from(d) % SLOTS) * SLOT_STRIDE;
                    p.set_bind_group(0, &group, &[offset as u32]);
                    p.dispatch_workgroups(groups, 1, 1);
                }
            }
        }
        drop(pass);
        ctx.queue.submit([enc.finish()]);
        ctx.wait_idle()
    };

    println!(
        "{} dispatches a submission, {words} words ({groups} workgroups of 64) on {}",
        dispatches,
        ctx.describe()
    );
    for way in [Way::Empty, Way::Touch, Way::TouchSlot, Way::TouchPassEach] {
        submit(way)?;
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let start = Instant::now();
            submit(way)?;
            best = best.min(start.elapsed().as_secs_f64());
        }
        println!(
            "  {:<34} {:>8.2} µs a dispatch (best of 5)",
            way.name(),
            best * 1e6 / f64::from(dispatches.max(1))
        );
    }
    Ok(())
}
