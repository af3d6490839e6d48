//! The raw-wgpu variants: the snapshot read-back's calls alone, with no Hooke code between them,
//! one submission and wait per iteration.

use std::sync::Arc;

use hooke::gpu::GpuContext;

const SHADER: &str = r"
struct U { a: vec4<f32> }
@group(0) @binding(0) var<uniform> u: U;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x < arrayLength(&out) { out[id.x] = u.a + vec4<f32>(f32(id.x)); }
}
";

/// Bytes of the storage and read-back buffers.
const SIZE: u64 = 64 * 1024;

/// The raw wgpu objects the read-back uses, one of each, made once.
pub struct Raw {
    ctx: GpuContext,
    storage: wgpu::Buffer,
    read: wgpu::Buffer,
    uniform: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    dynamic_pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    dynamic_group: wgpu::BindGroup,
}

impl Raw {
    pub fn new() -> Self {
        let ctx = GpuContext::open(None).expect("opening a GPU adapter");
        let device = &ctx.device;
        let buffer = |label, size, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let storage = buffer("storage", SIZE, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        let read = buffer("read", SIZE, U::MAP_READ | U::COPY_DST);
        let uniform = buffer("uniform", 4 * 256, U::UNIFORM | U::COPY_DST);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("probe"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let make = |dynamic: bool| {
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("probe"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: dynamic,
                            min_binding_size: wgpu::BufferSize::new(16),
                        },
                        count: None,
                    },
                    wgpu::BindGroupLayoutEntry {
                        binding: 1,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Storage { read_only: false },
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                ],
            });
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("probe"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &uniform,
                            offset: 0,
                            size: wgpu::BufferSize::new(16),
                        }),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: storage.as_entire_binding(),
                    },
                ],
            });
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("probe"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("probe"),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
            (pipeline, group)
        };
        let (pipeline, group) = make(false);
        let (dynamic_pipeline, dynamic_group) = make(true);
        Self {
            ctx,
            storage,
            read,
            uniform,
            pipeline,
            dynamic_pipeline,
            group,
            dynamic_group,
        }
    }

    fn submit(&self, enc: wgpu::CommandEncoder) -> wgpu::SubmissionIndex {
        self.ctx.queue.submit([enc.finish()])
    }

    fn encoder(&self) -> wgpu::CommandEncoder {
        self.ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("probe"),
            })
    }

    fn wait(&self, index: Option<wgpu::SubmissionIndex>) {
        let poll = match index {
            Some(i) => wgpu::PollType::Wait {
                submission_index: Some(i),
                timeout: None,
            },
            None => wgpu::PollType::wait_indefinitely(),
        };
        self.ctx.device.poll(poll).expect("device.poll");
    }

    fn copy_and_submit(&self) -> wgpu::SubmissionIndex {
        let mut enc = self.encoder();
        enc.copy_buffer_to_buffer(&self.storage, 0, &self.read, 0, SIZE);
        self.submit(enc)
    }

    /// Read the mapped buffer and unmap it; `view`: through get_mapped_range.
    fn read_and_unmap(&self, view: bool) -> f32 {
        let mut sum = 0.0;
        if view {
            let data = self
                .read
                .slice(..)
                .get_mapped_range()
                .expect("get_mapped_range");
            let f: &[f32] = bytemuck::cast_slice(&data);
            sum = f[0] + f[f.len() - 1];
        }
        self.read.unmap();
        sum
    }

    fn dispatch(&self, dynamic: bool, k: u64) -> wgpu::SubmissionIndex {
        let mut enc = self.encoder();
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("probe"),
                timestamp_writes: None,
            });
            if dynamic {
                pass.set_pipeline(&self.dynamic_pipeline);
                pass.set_bind_group(0, &self.dynamic_group, &[256 * (k % 4) as u32]);
            } else {
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &self.group, &[]);
            }
            pass.dispatch_workgroups((SIZE / 16 / 64) as u32, 1, 1);
        }
        self.submit(enc)
    }

    /// One iteration of `variant`.
    pub fn run(&self, variant: &str, k: u64) -> f32 {
        match variant {
            "empty" => self.wait(Some(self.submit(self.encoder()))),
            "empty-any" => {
                self.submit(self.encoder());
                self.wait(None);
            }
            "write" => {
                self.ctx
                    .queue
                    .write_buffer(&self.uniform, 0, &[k as u8; 256]);
                self.wait(Some(self.submit(self.encoder())));
            }
            "copy" => self.wait(Some(self.copy_and_submit())),
            "map" | "map-any" | "map-noview" => {
                let index = self.copy_and_submit();
                self.read.slice(..).map_async(wgpu::MapMode::Read, |_| {});
                self.wait((variant != "map-any").then_some(index));
                return self.read_and_unmap(variant != "map-noview");
            }
            "map-chan" => {
                let index = self.copy_and_submit();
                let (tx, rx) = std::sync::mpsc::channel();
                self.read
                    .slice(..)
                    .map_async(wgpu::MapMode::Read, move |r| {
                        let _ = tx.send(r);
                    });
                self.wait(Some(index));
                rx.recv().expect("map callback").expect("mapping");
                return self.read_and_unmap(true);
            }
            "map-nosubmit" => {
                self.read.slice(..).map_async(wgpu::MapMode::Read, |_| {});
                self.wait(None);
                return self.read_and_unmap(true);
            }
            "map-poll" => {
                let done = Arc::new(std::sync::atomic::AtomicBool::new(false));
                let flag = done.clone();
                self.read
                    .slice(..)
                    .map_async(wgpu::MapMode::Read, move |_| {
                        flag.store(true, std::sync::atomic::Ordering::Release);
                    });
                while !done.load(std::sync::atomic::Ordering::Acquire) {
                    self.ctx
                        .device
                        .poll(wgpu::PollType::Poll)
                        .expect("device.poll");
                }
                return self.read_and_unmap(true);
            }
            "dispatch" => self.wait(Some(self.dispatch(true, k))),
            "dispatch-static" => self.wait(Some(self.dispatch(false, k))),
            "clear" => {
                let mut enc = self.encoder();
                enc.clear_buffer(&self.storage, 0, None);
                self.wait(Some(self.submit(enc)));
            }
            other => panic!("unknown variant {other}"),
        }
        0.0
    }
}
