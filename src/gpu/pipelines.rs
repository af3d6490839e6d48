//! Bind group layouts and compute pipelines, made from the kernel table: a pipeline for every
//! kernel the run needs, each WGSL file compiled once, only if one of its kernels is needed.

use super::bindings::{Group, Slot};
use super::kernels::{Kernel, Needs, Path};
use super::programs::Program;
use super::shaders::source;

/// Bind group 0 of every kernel group the run needs (implicit Euler's binds more storage buffers
/// than other runs may have); 1, the state a force evaluation reads (x and v), or for a fused
/// step the state it reads and the one it writes; 2, the stage slot (a dynamic uniform offset);
/// 3, a fused step's end slot (the same buffer). Each as `bindings.rs` declares it.
pub struct Layouts {
    groups: Vec<Option<wgpu::BindGroupLayout>>,
    pub state: wgpu::BindGroupLayout,
    pub flow: wgpu::BindGroupLayout,
    pub stage: wgpu::BindGroupLayout,
    /// Every stage slot as words (group 3 of a kernel of many steps).
    pub stage_words: wgpu::BindGroupLayout,
}

/// The layout of `g`, as the table (`bindings.rs`) declares it.
fn layout(device: &wgpu::Device, g: Group) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = g
        .bindings()
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let ty = match b.slot {
                Slot::Uniform => wgpu::BufferBindingType::Uniform,
                Slot::Read | Slot::ReadWrite => wgpu::BufferBindingType::Storage {
                    read_only: b.slot == Slot::Read,
                },
            };
            wgpu::BindGroupLayoutEntry {
                binding: i as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty,
                    has_dynamic_offset: b.dynamic,
                    min_binding_size: None,
                },
                count: None,
            }
        })
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("{g:?}")),
        entries: &entries,
    })
}

impl Layouts {
    pub fn new(device: &wgpu::Device, needed: Needed) -> Self {
        Self {
            groups: Group::ALL
                .iter()
                .map(|&g| {
                    let used = Kernel::ALL
                        .iter()
                        .any(|k| k.spec().group == g && needed.has(k.spec().needs));
                    used.then(|| layout(device, g))
                })
                .collect(),
            state: layout(device, Group::State),
            flow: layout(device, Group::Flow),
            // A fused step's end slot (group 3) has the stage slot's layout.
            stage: layout(device, Group::StageSlot),
            stage_words: layout(device, Group::StageWords),
        }
    }

    /// The stage groups' layouts.
    pub fn stages(&self) -> super::stages::StageLayouts<'_> {
        super::stages::StageLayouts {
            slot: &self.stage,
            words: &self.stage_words,
        }
    }

    /// `None` for a group no kernel of the run uses.
    pub fn group(&self, g: Group) -> Option<&wgpu::BindGroupLayout> {
        self.groups[g as usize].as_ref()
    }
}

/// What a run needs compiled.
#[derive(Debug, Clone, Copy)]
pub struct Needed {
    /// Implicit Euler, and how its step runs.
    pub implicit: Option<Path>,
    /// Its CG preconditioned by multigrid (on either path).
    pub multigrid: bool,
    /// BDF2 restarting across impacts (`physics::BackwardStep::restarts_at_impacts`).
    pub restarts: bool,
    pub springs_change: bool,
    pub mass_contact: bool,
    pub xpbd: bool,
    pub vbd: bool,
    /// The fused explicit steps, a dispatch per step.
    pub fused: bool,
    /// The fused Euler or semi-implicit steps, a submission's in one workgroup.
    pub fused_in_group: bool,
}

impl Needed {
    pub fn has(self, needs: Needs) -> bool {
        match needs {
            Needs::Always => true,
            Needs::ImplicitPasses => self.implicit == Some(Path::Passes),
            Needs::ImplicitRestarts => self.restarts && self.implicit == Some(Path::Passes),
            Needs::ImplicitInGroup => self.implicit == Some(Path::InGroup) && !self.multigrid,
            Needs::ImplicitMultigrid => self.multigrid && self.implicit == Some(Path::Passes),
            Needs::ImplicitInGroupMultigrid => {
                self.multigrid && self.implicit == Some(Path::InGroup)
            }
            Needs::SpringsChange => self.springs_change,
            Needs::MassContact => self.mass_contact,
            Needs::Xpbd => self.xpbd,
            Needs::Vbd => self.vbd,
            Needs::Fused => self.fused,
            Needs::FusedInGroup => self.fused_in_group,
        }
    }
}

/// A pipeline per kernel the run needs.
pub struct Pipelines {
    by_kernel: Vec<Option<wgpu::ComputePipeline>>,
}

impl Pipelines {
    pub fn new(
        device: &wgpu::Device,
        layouts: &Layouts,
        constants: &[(&str, f64)],
        needed: Needed,
    ) -> Self {
        let wanted = |k: &Kernel| needed.has(k.spec().needs);
        let modules: Vec<Option<wgpu::ShaderModule>> = Program::ALL
            .iter()
            .map(|&p| {
                let used = Kernel::ALL
                    .iter()
                    .any(|k| k.spec().program == p && wanted(k));
                used.then(|| {
                    device.create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some(p.file()),
                        source: wgpu::ShaderSource::Wgsl(source(p).into()),
                    })
                })
            })
            .collect();
        let by_kernel = Kernel::ALL
            .iter()
            .map(|k| {
                let module = modules[k.spec().program as usize].as_ref();
                module
                    .filter(|_| wanted(k))
                    .and_then(|m| pipeline(device, layouts, constants, *k, m))
            })
            .collect();
        Self { by_kernel }
    }

    /// `None` for a kernel this run does not need.
    pub fn get(&self, k: Kernel) -> Option<&wgpu::ComputePipeline> {
        self.by_kernel[k as usize].as_ref()
    }
}

fn pipeline(
    device: &wgpu::Device,
    layouts: &Layouts,
    constants: &[(&str, f64)],
    k: Kernel,
    module: &wgpu::ShaderModule,
) -> Option<wgpu::ComputePipeline> {
    let spec = k.spec();
    let group0 = Some(layouts.group(spec.group)?);
    let stage = Some(&layouts.stage);
    let flow: [Option<&wgpu::BindGroupLayout>; 4] = [group0, Some(&layouts.flow), stage, stage];
    let other = [group0, spec.reads_state.then_some(&layouts.state), stage];
    let slots = [group0, None, stage, Some(&layouts.stage_words)];
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(spec.entry),
        bind_group_layouts: match (spec.flows, spec.all_slots) {
            (true, _) => &flow[..],
            (false, true) => &slots[..],
            (false, false) => &other[..],
        },
        immediate_size: 0,
    });
    Some(
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(spec.entry),
            layout: Some(&layout),
            module,
            entry_point: Some(spec.entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        }),
    )
}
