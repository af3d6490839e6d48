//! The wgpu compute backend: the same physics as `crate::cpu`, one kernel per CPU function of the
//! same name. Substeps are encoded into one submission; the host waits on the GPU only when a
//! snapshot is due, and a snapshot reads back only what the recorder logs (positions, strain and
//! a few per-workgroup energy sums).

mod context;
mod implicit;
mod kernels;
pub mod layout;

pub use context::{GpuContext, REQUIRE_ADAPTER_ENV, adapters, describe_error};
pub use kernels::programs;

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use wgpu::util::DeviceExt as _;

use crate::backend::{Backend, BackendError, RUNAWAY_SPEED_M_PER_S, find_divergence};
use crate::integrator::Integrator;
use crate::model::{Effects, Model, Shape};
use crate::state::{Divergence, Energies, Ledger, Snapshot, State, StepStats};
use kernels::{Layouts, Pipelines, groups_for};
use layout::{Collider, MassContact, Params, Pose, SolverStatus, Stage};

/// Stage slots per substep: t, t + h/2 (twice, for RK4's two midpoint stages), t + h.
const SLOTS_PER_STEP: u32 = 4;
/// Implicit Euler's per-mass vectors (SOLVER_VECTORS in shaders/common.wgsl).
const IMPLICIT_VECTORS: u64 = 7;

struct Buffers {
    x: wgpu::Buffer,
    v: wgpu::Buffer,
    ledger: wgpu::Buffer,
    counters: wgpu::Buffer,
    strain: wgpu::Buffer,
    partials: wgpu::Buffer,
    stage: wgpu::Buffer,
    /// Two, so that one frame's snapshot is read back while the next frame steps.
    staging: [wgpu::Buffer; 2],
}

struct BindGroups {
    /// Only when springs change during the run (plasticity, tearing).
    springs: Option<wgpu::BindGroup>,
    forces_model: wgpu::BindGroup,
    state_xv: wgpu::BindGroup,
    state_xtvt: wgpu::BindGroup,
    state_xvt: wgpu::BindGroup,
    integrate: wgpu::BindGroup,
    collide: wgpu::BindGroup,
    reduce: wgpu::BindGroup,
    stage: wgpu::BindGroup,
}

pub struct GpuBackend {
    ctx: GpuContext,
    model: Arc<Model>,
    integrator: Integrator,
    dt: f32,
    time_secs: f64,
    steps: u64,
    /// Energy folded out of the per-mass ledger at each snapshot, summed in f64.
    ledger: Ledger,
    verlet_primed: bool,
    pipelines: Pipelines,
    layouts: Layouts,
    buf: Buffers,
    bg: BindGroups,
    stage_stride: u64,
    stage_slots: u32,
    mass_groups: (u32, u32),
    spring_groups: (u32, u32),
    energy_groups: (u32, u32),
    /// Bytes of GPU memory held by the simulation's buffers.
    pub memory_bytes: u64,
    advance_started: Option<Instant>,
    /// Substeps advanced since the last snapshot was requested: a frame stepped in chunks
    /// numbers its steps on from here, so the first bad step is found within the whole frame.
    frame_steps: u32,
    /// Snapshots asked for and not yet collected, oldest first.
    pending: std::collections::VecDeque<Pending>,
    /// Snapshots returned by the recorder, their buffers reused.
    spare: Vec<Snapshot>,
    /// Implicit Euler only.
    solve: Option<ImplicitSolve>,
    /// Mass–mass contact only.
    mass_contact: Option<MassContactGrid>,
}

/// The GPU's hash grid as read back for tests: bucket b holds
/// `sorted[cell_start[b]..cell_start[b + 1]]` (as `crate::cpu::MassGrid`).
#[doc(hidden)]
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GridReadBack {
    pub cell_start: Vec<u32>,
    pub sorted: Vec<u32>,
}

/// Mass–mass contact's hash grid and the bind groups of its passes.
struct MassContactGrid {
    /// grid.wgsl: params, contact, counts, starts, block sums, mass buckets, sorted masses.
    grid: wgpu::BindGroup,
    /// collide_masses.wgsl: params, contact, mass, bodies, starts, sorted, deriv, partials.
    pairs: wgpu::BindGroup,
    cell_start: wgpu::Buffer,
    sorted: wgpu::Buffer,
    table_size: u32,
    block_count: u32,
    /// Workgroups over the table's buckets, and one per block of the prefix sum.
    table_groups: (u32, u32),
    block_groups: (u32, u32),
    memory_bytes: u64,
}

/// Implicit Euler's solver buffers (its vectors live in the per-mass scratch, `sums`).
struct ImplicitSolve {
    bind_group: wgpu::BindGroup,
    /// `SolverStatus`, then the per-workgroup partial sums.
    scratch: wgpu::Buffer,
    /// Where the host reads the status between chunks.
    status: wgpu::Buffer,
    /// CG iterations to encode before the first status read of a solve: the last solve's count.
    chunk: u32,
}

fn storage(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    extra: wgpu::BufferUsages,
) -> wgpu::Buffer {
    // wgpu rejects zero-sized bindings: give empty arrays one zeroed element.
    let zeros = [0u8; 64];
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: if contents.is_empty() {
            &zeros
        } else {
            contents
        },
        usage: wgpu::BufferUsages::STORAGE | extra,
    })
}

fn vec4s(v: &[Vec3]) -> Vec<[f32; 4]> {
    v.iter().map(|p| [p.x, p.y, p.z, 0.0]).collect()
}

fn entries<'a>(buffers: &[&'a wgpu::Buffer]) -> Vec<wgpu::BindGroupEntry<'a>> {
    buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect()
}

impl GpuBackend {
    pub fn new(
        model: Arc<Model>,
        integrator: Integrator,
        dt_secs: f64,
        adapter: Option<&str>,
    ) -> Result<Self, BackendError> {
        if integrator == Integrator::Implicit && model.effects.self_collision.is_some() {
            return Err(BackendError::Device(
                "implicit Euler does not support mass–mass contact ([effects.self_collision]): \
                 use semi-implicit, verlet or rk4"
                    .to_owned(),
            ));
        }
        let ctx = GpuContext::open(adapter).map_err(BackendError::Device)?;
        let n = model.mass_count();
        let ns = model.spring_count();
        let implicit = integrator == Integrator::Implicit;
        check_fits(&ctx, &model, integrator)?;
        let device = &ctx.device;
        let e = &model.effects;
        let ground = e.ground;
        let params = Params {
            mass_count: n as u32,
            spring_count: ns as u32,
            collider_count: e.colliders.len() as u32,
            runaway_speed: RUNAWAY_SPEED_M_PER_S,
            gravity: e.gravity_m_per_s2.unwrap_or(Vec3::ZERO).to_array(),
            drag_per_s: e.air_drag_per_s.unwrap_or(0.0),
            ground_height: ground.map_or(0.0, |g| g.height_m),
            ground_stiffness: ground.map_or(0.0, |g| g.contact.stiffness_n_per_m),
            ground_friction: ground.map_or(0.0, |g| g.contact.friction),
            ground_damping_ratio: ground.map_or(0.0, |g| g.contact.damping_ratio),
            ground_max_depth: ground.map_or(0.0, |g| g.max_depth_m),
            _pad: [0.0; 3],
        };
        let colliders: Vec<Collider> = e
            .colliders
            .iter()
            .map(|c| {
                let (kind, shape) = match c.shape {
                    Shape::Sphere { radius_m } => (layout::SPHERE, [radius_m, 0.0, 0.0, 0.0]),
                    Shape::Box { half_extents_m } => {
                        (layout::BOX, half_extents_m.extend(0.0).to_array())
                    }
                    Shape::Plane { normal } => (layout::PLANE, normal.extend(0.0).to_array()),
                };
                Collider {
                    kind,
                    stiffness: c.contact.stiffness_n_per_m,
                    friction: c.contact.friction,
                    damping_ratio: c.contact.damping_ratio,
                    shape,
                    max_depth: c.max_depth_m,
                    _pad: [0.0; 3],
                }
            })
            .collect();
        let mass: Vec<[f32; 2]> = model
            .mass_kg
            .iter()
            .zip(&model.inv_mass)
            .map(|(&m, &w)| [m, w])
            .collect();
        let copy = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let params_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let springs = storage(
            device,
            "springs",
            bytemuck::cast_slice(&model.springs),
            wgpu::BufferUsages::empty(),
        );
        let offsets = storage(
            device,
            "offsets",
            bytemuck::cast_slice(&model.adjacency.offsets),
            wgpu::BufferUsages::empty(),
        );
        let neighbors = storage(
            device,
            "neighbors",
            bytemuck::cast_slice(&model.adjacency.entries),
            wgpu::BufferUsages::empty(),
        );
        let colliders_buf = storage(
            device,
            "colliders",
            bytemuck::cast_slice(&colliders),
            wgpu::BufferUsages::empty(),
        );
        let mass_buf = storage(
            device,
            "mass",
            bytemuck::cast_slice(&mass),
            wgpu::BufferUsages::empty(),
        );
        let x = storage(
            device,
            "x",
            bytemuck::cast_slice(&vec4s(&model.initial.x)),
            copy,
        );
        let v = storage(
            device,
            "v",
            bytemuck::cast_slice(&vec4s(&model.initial.v)),
            copy,
        );
        let zeros = |label: &str, bytes: usize| storage(device, label, &vec![0u8; bytes], copy);
        let xt = zeros("xt", 16 * n);
        let vt = zeros("vt", 16 * n);
        let deriv = zeros("deriv", deriv_bytes(&model, integrator) as usize);
        // Plasticity and tearing: each spring's limits, and the energy it let go since the last
        // snapshot.
        let spring_state = model.effects.springs_change().then(|| {
            (
                storage(
                    device,
                    "spring limits",
                    bytemuck::cast_slice(&model.spring_limits(dt_secs)),
                    wgpu::BufferUsages::empty(),
                ),
                zeros("released", 4 * ns),
            )
        });
        let sums = zeros("sums", scratch_bytes(&model, integrator) as usize);
        let ledger = zeros("ledger", 16 * n);
        let counters = zeros("counters", 16);
        let strain = zeros("strain", 4 * ns);
        let max_dim = ctx.limits.max_compute_workgroups_per_dimension;
        let mass_groups = groups_for(n as u32, max_dim);
        let spring_groups = groups_for(ns as u32, max_dim);
        let energy_groups = groups_for(n.max(ns) as u32, max_dim);
        let partial_count = (energy_groups.0 * energy_groups.1) as usize;
        let partials = zeros("partials", 48 * partial_count);
        // Implicit Euler: the solver's status, then one partial sum per mass workgroup.
        let solver_scratch = implicit.then(|| {
            zeros(
                "solver",
                std::mem::size_of::<SolverStatus>() + 16 * (mass_groups.0 * mass_groups.1) as usize,
            )
        });
        let align = u64::from(ctx.limits.min_uniform_buffer_offset_alignment).max(1);
        // Each slot holds one Stage, at an offset the adapter accepts for a dynamic uniform.
        let stage_stride = (std::mem::size_of::<Stage>() as u64).div_ceil(align) * align;
        let stage_slots = 1;
        let stage = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stage"),
            size: stage_stride * u64::from(stage_slots),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let staging_size = (16 * n + 16 * n + 4 * ns.max(1) + 48 * partial_count + 16) as u64;
        let staging = [0, 1].map(|_| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("staging"),
                size: staging_size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        let layouts = Layouts::new(device);
        let pipelines = Pipelines::new(
            device,
            &layouts,
            &kernels::constants(&model, integrator),
            implicit,
            spring_state.is_some(),
            e.self_collision.is_some(),
        );
        let bg_of = |layout: &wgpu::BindGroupLayout, label: &str, bufs: &[&wgpu::Buffer]| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &entries(bufs),
            })
        };
        let stage_bg = Self::stage_bind_group(device, &layouts, &stage);
        let bg = BindGroups {
            springs: spring_state.as_ref().map(|(limits, released)| {
                bg_of(
                    &layouts.springs,
                    "springs",
                    &[&params_buf, &springs, limits, &x, released, &partials],
                )
            }),
            forces_model: bg_of(
                &layouts.forces_model,
                "forces model",
                &[
                    &params_buf,
                    &springs,
                    &offsets,
                    &neighbors,
                    &colliders_buf,
                    &mass_buf,
                    &deriv,
                ],
            ),
            state_xv: bg_of(&layouts.forces_state, "x v", &[&x, &v]),
            state_xtvt: bg_of(&layouts.forces_state, "xt vt", &[&xt, &vt]),
            state_xvt: bg_of(&layouts.forces_state, "x vt", &[&x, &vt]),
            integrate: bg_of(
                &layouts.integrate,
                "integrate",
                &[
                    &params_buf,
                    &x,
                    &v,
                    &xt,
                    &vt,
                    &deriv,
                    &sums,
                    &ledger,
                    &counters,
                ],
            ),
            collide: bg_of(
                &layouts.collide,
                "collide",
                &[
                    &params_buf,
                    &colliders_buf,
                    &mass_buf,
                    &x,
                    &v,
                    &ledger,
                    &counters,
                ],
            ),
            reduce: bg_of(
                &layouts.reduce,
                "reduce",
                &[
                    &params_buf,
                    &springs,
                    &colliders_buf,
                    &mass_buf,
                    &x,
                    &v,
                    &ledger,
                    &strain,
                    &partials,
                ],
            ),
            stage: stage_bg,
        };
        let solve = solver_scratch.map(|scratch| ImplicitSolve {
            bind_group: bg_of(
                &layouts.solve,
                "solve",
                &[
                    &params_buf,
                    &springs,
                    &offsets,
                    &neighbors,
                    &mass_buf,
                    &xt,
                    &deriv,
                    &sums,
                    &scratch,
                ],
            ),
            status: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("solver status"),
                size: std::mem::size_of::<SolverStatus>() as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            scratch,
            chunk: 16,
        });
        let mass_contact = e.self_collision.map(|c| {
            let table_size = crate::cpu::table_size(n);
            let block_count = table_size / crate::cpu::SCAN_BLOCK;
            let contact = MassContact {
                radius: c.radius_m,
                inv_cell: crate::cpu::inv_cell_per_m(c.radius_m),
                table_mask: table_size - 1,
                block_count,
                stiffness: c.contact.stiffness_n_per_m,
                friction: c.contact.friction,
                damping_ratio: c.contact.damping_ratio,
                within_bodies: u32::from(c.within_bodies),
            };
            let contact_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("mass contact"),
                contents: bytemuck::bytes_of(&contact),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let bodies = storage(
                device,
                "mass bodies",
                bytemuck::cast_slice(&model.mass_body),
                wgpu::BufferUsages::empty(),
            );
            let table = table_size as usize;
            let cell_count = zeros("cell count", 4 * table);
            let cell_start = zeros("cell start", 4 * (table + 1));
            let block_sums = zeros("block sums", 4 * block_count as usize);
            let mass_cell = zeros("mass cell", 4 * n);
            let sorted = zeros("sorted masses", 4 * n);
            let memory_bytes = [
                &contact_buf,
                &bodies,
                &cell_count,
                &cell_start,
                &block_sums,
                &mass_cell,
                &sorted,
            ]
            .iter()
            .map(|b| b.size())
            .sum();
            MassContactGrid {
                grid: bg_of(
                    &layouts.grid,
                    "grid",
                    &[
                        &params_buf,
                        &contact_buf,
                        &cell_count,
                        &cell_start,
                        &block_sums,
                        &mass_cell,
                        &sorted,
                    ],
                ),
                pairs: bg_of(
                    &layouts.collide_masses,
                    "collide masses",
                    &[
                        &params_buf,
                        &contact_buf,
                        &mass_buf,
                        &bodies,
                        &cell_start,
                        &sorted,
                        &deriv,
                        &partials,
                    ],
                ),
                cell_start,
                sorted,
                table_size,
                block_count,
                table_groups: groups_for(table_size, max_dim),
                block_groups: groups_for(block_count * kernels::WORKGROUP, max_dim),
                memory_bytes,
            }
        });
        let memory_bytes = [
            &params_buf,
            &springs,
            &offsets,
            &neighbors,
            &colliders_buf,
            &mass_buf,
            &x,
            &v,
            &xt,
            &vt,
            &deriv,
            &sums,
            &ledger,
            &counters,
            &strain,
            &partials,
            &staging[0],
            &staging[1],
        ]
        .iter()
        .map(|b| b.size())
        .sum::<u64>()
            + solve
                .as_ref()
                .map_or(0, |s| s.scratch.size() + s.status.size())
            + spring_state
                .as_ref()
                .map_or(0, |(l, r)| l.size() + r.size())
            + mass_contact.as_ref().map_or(0, |m| m.memory_bytes);
        let backend = Self {
            ctx,
            model,
            integrator,
            dt: dt_secs as f32,
            time_secs: 0.0,
            steps: 0,
            ledger: Ledger::default(),
            verlet_primed: false,
            pipelines,
            layouts,
            buf: Buffers {
                x,
                v,
                ledger,
                counters,
                strain,
                partials,
                stage,
                staging,
            },
            bg,
            stage_stride,
            stage_slots,
            mass_groups,
            spring_groups,
            energy_groups,
            memory_bytes,
            advance_started: None,
            frame_steps: 0,
            pending: std::collections::VecDeque::new(),
            spare: Vec::new(),
            solve,
            mass_contact,
        };
        backend.check_device()?;
        Ok(backend)
    }

    fn stage_bind_group(
        device: &wgpu::Device,
        layouts: &Layouts,
        stage: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("stage"),
            layout: &layouts.stage,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: stage,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<Stage>() as u64),
                }),
            }],
        })
    }

    /// Lose the device on purpose, as a driver reset would: for tests of what a run does then.
    #[doc(hidden)]
    pub fn lose_device(&self) {
        self.ctx.lose_device();
    }

    fn check_device(&self) -> Result<(), BackendError> {
        match self.ctx.take_error() {
            Some(e) => Err(BackendError::Device(format!(
                "the GPU reported an error on {}: {e}",
                self.ctx.describe()
            ))),
            None => Ok(()),
        }
    }

    fn encoder(&self, label: &'static str) -> wgpu::CommandEncoder {
        self.ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
    }

    /// Make room for `slots` stage slots (grows, never shrinks).
    fn reserve_stage_slots(&mut self, slots: u32) {
        if slots <= self.stage_slots {
            return;
        }
        let slots = slots.next_power_of_two();
        self.buf.stage = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stage"),
            size: self.stage_stride * u64::from(slots),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.bg.stage = Self::stage_bind_group(&self.ctx.device, &self.layouts, &self.buf.stage);
        self.stage_slots = slots;
    }

    fn write_slots(&self, first: u32, stages: &[Stage]) {
        let stride = self.stage_stride as usize;
        let mut bytes = vec![0u8; stride * stages.len()];
        for (k, s) in stages.iter().enumerate() {
            let b = bytemuck::bytes_of(s);
            bytes[k * stride..k * stride + b.len()].copy_from_slice(b);
        }
        self.ctx.queue.write_buffer(
            &self.buf.stage,
            u64::from(first) * self.stage_stride,
            &bytes,
        );
    }

    fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        pipeline: &wgpu::ComputePipeline,
        group0: &wgpu::BindGroup,
        state: Option<&wgpu::BindGroup>,
        slot: u32,
        groups: (u32, u32),
    ) {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group0, &[]);
        if let Some(s) = state {
            pass.set_bind_group(1, s, &[]);
        }
        pass.set_bind_group(
            2,
            &self.bg.stage,
            &[(u64::from(slot) * self.stage_stride) as u32],
        );
        pass.dispatch_workgroups(groups.0, groups.1, 1);
    }

    fn step_plan(&self, prime: bool) -> Vec<(Kernel, u32)> {
        step_plan(self.integrator, &self.model.effects, prime)
    }

    /// Workgroups a kernel dispatches: one thread per mass, per spring, per bucket of the hash
    /// grid, one workgroup per block of its prefix sum, or a single workgroup.
    fn groups(&self, k: Kernel) -> (u32, u32) {
        let grid = self.mass_contact.as_ref();
        match k {
            Kernel::UpdateSprings => self.spring_groups,
            Kernel::GridScanBlocks => grid.map_or((1, 1), |g| g.block_groups),
            Kernel::GridScanSums => (1, 1),
            Kernel::GridScanAdd | Kernel::GridSortCells => grid.map_or((1, 1), |g| g.table_groups),
            _ => self.mass_groups,
        }
    }

    fn state_group(&self, s: StateIn) -> &wgpu::BindGroup {
        match s {
            StateIn::XV => &self.bg.state_xv,
            StateIn::XtVt => &self.bg.state_xtvt,
            StateIn::XVt => &self.bg.state_xvt,
        }
    }

    /// A kernel's pipeline, bind group 0 and state bind group; `None` for mass–mass contact's
    /// kernels in a scene without it (its step plan never asks for them).
    fn kernel(
        &self,
        k: Kernel,
    ) -> Option<(
        &wgpu::ComputePipeline,
        &wgpu::BindGroup,
        Option<&wgpu::BindGroup>,
    )> {
        let (p, bg) = (&self.pipelines, &self.bg);
        let mc = || {
            self.pipelines
                .mass_contact
                .as_ref()
                .zip(self.mass_contact.as_ref())
        };
        Some(match k {
            Kernel::Forces(s) => (
                &p.compute_forces,
                &bg.forces_model,
                Some(self.state_group(s)),
            ),
            Kernel::GridCount(s) => {
                let (p, g) = mc()?;
                (&p.grid_count, &g.grid, Some(self.state_group(s)))
            }
            Kernel::GridScanBlocks => {
                let (p, g) = mc()?;
                (&p.grid_scan_blocks, &g.grid, None)
            }
            Kernel::GridScanSums => {
                let (p, g) = mc()?;
                (&p.grid_scan_sums, &g.grid, None)
            }
            Kernel::GridScanAdd => {
                let (p, g) = mc()?;
                (&p.grid_scan_add, &g.grid, None)
            }
            Kernel::GridScatter => {
                let (p, g) = mc()?;
                (&p.grid_scatter, &g.grid, None)
            }
            Kernel::GridSortCells => {
                let (p, g) = mc()?;
                (&p.grid_sort_cells, &g.grid, None)
            }
            Kernel::CollideMasses(s) => {
                let (p, g) = mc()?;
                (&p.collide_masses, &g.pairs, Some(self.state_group(s)))
            }
            Kernel::MassContactEnergy => {
                let (p, g) = mc()?;
                (&p.mass_contact_energy, &g.pairs, Some(&self.bg.state_xv))
            }
            Kernel::EulerUpdate => (&p.euler_update, &bg.integrate, None),
            Kernel::SemiImplicitUpdate => (&p.semi_implicit_update, &bg.integrate, None),
            Kernel::Rk2Stage => (&p.rk2_stage, &bg.integrate, None),
            Kernel::Rk2Final => (&p.rk2_final, &bg.integrate, None),
            Kernel::Rk4Begin => (&p.rk4_begin, &bg.integrate, None),
            Kernel::Rk4Mid => (&p.rk4_mid, &bg.integrate, None),
            Kernel::Rk4Final => (&p.rk4_final, &bg.integrate, None),
            Kernel::VerletDrift => (&p.verlet_drift, &bg.integrate, None),
            Kernel::VerletKick => (&p.verlet_kick, &bg.integrate, None),
            Kernel::ProjectContacts => (&p.project_contacts, &bg.collide, None),
            Kernel::UpdateSprings => {
                let (p, bg) = p.springs.as_ref().zip(bg.springs.as_ref())?;
                (&p.update_springs, bg, None)
            }
        })
    }

    /// Dispatch `k` at stage slot `slot`; a kernel this backend lacks is an internal error.
    fn dispatch_kernel(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        k: Kernel,
        slot: u32,
    ) -> Result<(), BackendError> {
        let (pipeline, g0, state) = self.kernel(k).ok_or_else(|| {
            BackendError::Device(format!(
                "internal: kernel {} asked for without its effect",
                k.name()
            ))
        })?;
        self.dispatch(pass, pipeline, g0, state, slot, self.groups(k));
        Ok(())
    }

    /// Encode `substeps` steps into one pass; slot `4k + j` holds stage j of step k.
    fn encode_steps(
        &mut self,
        pass: &mut wgpu::ComputePass<'_>,
        substeps: u32,
    ) -> Result<(), BackendError> {
        let warm = self.step_plan(false);
        for k in 0..substeps {
            let prime = !self.verlet_primed && self.integrator == Integrator::Verlet;
            let plan = if prime {
                self.step_plan(true)
            } else {
                warm.clone()
            };
            for (kernel, rel) in plan {
                self.dispatch_kernel(pass, kernel, SLOTS_PER_STEP * k + rel)?;
            }
            self.verlet_primed = true;
        }
        Ok(())
    }

    /// The hash grid of the positions in `state`: mass–mass contact's build passes.
    fn encode_grid(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        state: StateIn,
        slot: u32,
    ) -> Result<(), BackendError> {
        for k in grid_build(state) {
            self.dispatch_kernel(pass, k, slot)?;
        }
        Ok(())
    }

    /// For tests: build the hash grid on the GPU from the current positions and read it back.
    /// `None` without mass–mass contact.
    #[doc(hidden)]
    pub fn mass_grid(&mut self) -> Result<Option<GridReadBack>, BackendError> {
        self.reserve_stage_slots(1);
        let Some(g) = self.mass_contact.as_ref() else {
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
        let mut enc = self.encoder("grid");
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("grid"),
                timestamp_writes: None,
            });
            self.encode_grid(&mut pass, StateIn::XV, self.stage_slots - 1)?;
        }
        enc.copy_buffer_to_buffer(&g.cell_start, 0, &read, 0, starts);
        enc.copy_buffer_to_buffer(&g.sorted, 0, &read, starts, masses);
        let index = self.ctx.queue.submit([enc.finish()]);
        let slice = read.slice(..);
        self.map_and_wait(&slice, index)?;
        let out = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| BackendError::Device(format!("reading the grid failed: {e}")))?;
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

    /// Compulsory memory traffic of one step: every buffer a kernel touches, read (and written)
    /// once per dispatch, caches assumed to absorb the neighbours' repeated reads. Steps/s times
    /// this is the achieved bandwidth that BENCHMARKS.md compares with the card's peak.
    pub fn bytes_per_step(&self) -> u64 {
        let n = self.model.mass_count() as u64;
        let ns = self.model.spring_count() as u64;
        let colliders = self.model.effects.colliders.len() as u64 * 48;
        let (table, blocks) = self.mass_contact.as_ref().map_or((0, 0), |g| {
            (u64::from(g.table_size), u64::from(g.block_count))
        });
        self.step_plan(false)
            .iter()
            .map(|(k, _)| match k {
                // x in; each mass's bucket out; one atomic count per mass.
                Kernel::GridCount(_) => n * (16 + 4 + 4),
                // Counts in, starts out; block sums.
                Kernel::GridScanBlocks => table * 8 + blocks * 4,
                Kernel::GridScanSums => blocks * 8 + 4,
                Kernel::GridScanAdd => table * 8 + blocks * 4,
                // Bucket, count and start per mass; the sorted index out.
                Kernel::GridScatter => n * 16,
                // Starts; each bucket's masses read and written.
                Kernel::GridSortCells => table * 8 + n * 8,
                // x, v, mass, body per mass and per candidate (cached); starts; deriv in and out.
                Kernel::CollideMasses(_) => n * (16 + 16 + 8 + 4 + 4 + 2 * 32) + table * 4,
                Kernel::MassContactEnergy => n * (16 + 8 + 4 + 4) + table * 4,
                // x, v in; offsets; neighbours and springs; acceleration and rates out.
                Kernel::Forces(_) => n * (16 + 16 + 4 + 8 + 32) + ns * (2 * 8 + 20) + colliders,
                // x, v read and written; derivatives read; ledger read and written.
                Kernel::EulerUpdate | Kernel::SemiImplicitUpdate => n * (4 * 16 + 32 + 2 * 16 + 8),
                Kernel::Rk2Stage => n * (2 * 16 + 32 + 2 * 16 + 8),
                Kernel::Rk2Final => n * (5 * 16 + 32 + 2 * 16 + 8),
                Kernel::Rk4Begin => n * (2 * 16 + 32 + 2 * 16 + 3 * 16 + 8),
                Kernel::Rk4Mid => n * (3 * 16 + 32 + 2 * 16 + 2 * 3 * 16 + 8),
                Kernel::Rk4Final => n * (5 * 16 + 32 + 3 * 16 + 2 * 16 + 8),
                Kernel::VerletDrift => n * (3 * 16 + 32 + 16 + 2 * 16 + 8),
                Kernel::VerletKick => n * (2 * 16 + 32 + 2 * 16 + 2 * 16 + 8),
                Kernel::ProjectContacts => n * (4 * 16 + 8) + colliders,
                // Spring and limits read; two ends; rest length and released energy written.
                Kernel::UpdateSprings => ns * (20 + 16 + 2 * 16 + 4 + 2 * 4),
            })
            .sum()
    }

    /// Wait until everything submitted has run.
    fn wait_idle(&self) -> Result<(), BackendError> {
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| {
                BackendError::Device(format!("waiting for {} failed: {e}", self.ctx.describe()))
            })?;
        self.check_device()
    }

    /// GPU time of each kernel per step, averaged over `steps` steps, each dispatch timed in its
    /// own pass with timestamp queries. `None` when the adapter has no timestamp queries.
    pub fn profile_kernels(
        &mut self,
        steps: u32,
    ) -> Result<Option<Vec<(String, f64)>>, BackendError> {
        if !self.ctx.features.contains(wgpu::Features::TIMESTAMP_QUERY) || steps == 0 {
            return Ok(None);
        }
        self.reserve_stage_slots(SLOTS_PER_STEP * steps + 1);
        let stages = self.stage_times(steps);
        self.write_slots(0, &stages);
        let mut dispatches = Vec::new();
        for k in 0..steps {
            let prime = !self.verlet_primed && self.integrator == Integrator::Verlet;
            for (kernel, rel) in self.step_plan(prime) {
                dispatches.push((kernel, SLOTS_PER_STEP * k + rel));
            }
            self.verlet_primed = true;
        }
        let device = &self.ctx.device;
        let count = 2 * dispatches.len() as u32;
        let queries = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let bytes = 8 * u64::from(count);
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let read = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps read"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("profile"),
        });
        for (q, (kernel, slot)) in dispatches.iter().enumerate() {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(kernel.name()),
                timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                    query_set: &queries,
                    beginning_of_pass_write_index: Some(2 * q as u32),
                    end_of_pass_write_index: Some(2 * q as u32 + 1),
                }),
            });
            self.dispatch_kernel(&mut pass, *kernel, *slot)?;
        }
        enc.resolve_query_set(&queries, 0..count, &resolve, 0);
        enc.copy_buffer_to_buffer(&resolve, 0, &read, 0, bytes);
        self.ctx.queue.submit([enc.finish()]);
        self.time_secs = self.time_after(steps);
        self.steps += u64::from(steps);
        self.frame_steps += steps;
        let slice = read.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.wait_idle()?;
        let ns_per_tick = f64::from(self.ctx.queue.get_timestamp_period());
        let mut totals: Vec<(String, f64)> = Vec::new();
        {
            let data = slice
                .get_mapped_range()
                .map_err(|e| BackendError::Device(format!("reading timestamps failed: {e}")))?;
            let ticks: &[u64] = bytemuck::cast_slice(&data);
            for (q, (kernel, _)) in dispatches.iter().enumerate() {
                let ms = ticks[2 * q + 1].saturating_sub(ticks[2 * q]) as f64 * ns_per_tick * 1e-6;
                match totals.iter_mut().find(|(n, _)| n == kernel.name()) {
                    Some(t) => t.1 += ms,
                    None => totals.push((kernel.name().to_owned(), ms)),
                }
            }
        }
        read.unmap();
        for t in &mut totals {
            t.1 /= f64::from(steps);
        }
        Ok(Some(totals))
    }

    /// Stage slots for `steps` steps from the current time: t, t + h/2 (RK4 stage 2), t + h/2
    /// (stage 3), t + h, accumulating t by repeated addition exactly as the CPU backend does.
    fn stage_times(&self, steps: u32) -> Vec<Stage> {
        let h = f64::from(self.dt);
        let mut stages = Vec::with_capacity((SLOTS_PER_STEP * steps) as usize);
        let mut t = self.time_secs;
        for k in 0..steps {
            let at = |time: f64, weight: f32, next_scale: f32| Stage {
                weight,
                next_scale,
                step: self.frame_steps + k,
                ..self.stage_at(time)
            };
            stages.extend([
                at(t, 1.0, 0.5),
                at(t + 0.5 * h, 2.0, 0.5),
                at(t + 0.5 * h, 2.0, 1.0),
                at(t + h, 1.0, 1.0),
            ]);
            t += h;
        }
        stages
    }

    /// A stage slot at `time`: its dt and every collider's pose then.
    fn stage_at(&self, time: f64) -> Stage {
        let mut poses = [Pose::default(); layout::MAX_COLLIDERS];
        for (slot, c) in poses.iter_mut().zip(&self.model.effects.colliders) {
            let p = c.path.pose_at(time);
            *slot = Pose {
                position: p.position_m.extend(0.0).to_array(),
                velocity: p.velocity_m_per_s.extend(0.0).to_array(),
            };
        }
        Stage {
            time: time as f32,
            dt: self.dt,
            weight: 1.0,
            next_scale: 1.0,
            step: 0,
            _pad: [0; 3],
            poses,
        }
    }

    fn time_after(&self, steps: u32) -> f64 {
        let h = f64::from(self.dt);
        (0..steps).fold(self.time_secs, |t, _| t + h)
    }

    /// Run the reductions and copy what a snapshot needs (and `with_velocity`, the velocities) to a
    /// free staging buffer, without waiting: returns which buffer and the submission to wait for.
    fn submit_read_back(
        &mut self,
        with_velocity: bool,
    ) -> Result<(usize, wgpu::SubmissionIndex), BackendError> {
        let k = (0..2)
            .find(|k| self.pending.iter().all(|p| p.staging != *k))
            .ok_or_else(|| {
                BackendError::Device("internal: both snapshot buffers are in use".to_owned())
            })?;
        let n = self.model.mass_count() as u64;
        let ns = self.model.spring_count() as u64;
        let partial_count = u64::from(self.energy_groups.0 * self.energy_groups.1);
        // The reductions' stage slot: the current time, after the stepping slots.
        let slot = self.stage_slots - 1;
        self.write_slots(slot, &[self.stage_at(self.time_secs)]);
        let mut enc = self.encoder("snapshot");
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("reduce"),
                timestamp_writes: None,
            });
            if ns > 0 {
                self.dispatch(
                    &mut pass,
                    &self.pipelines.compute_strain,
                    &self.bg.reduce,
                    None,
                    slot,
                    self.spring_groups,
                );
            }
            self.dispatch(
                &mut pass,
                &self.pipelines.compute_energies,
                &self.bg.reduce,
                None,
                slot,
                self.energy_groups,
            );
            if let (Some(p), Some(bg)) = (&self.pipelines.springs, &self.bg.springs) {
                self.dispatch(
                    &mut pass,
                    &p.sum_spring_work,
                    bg,
                    None,
                    slot,
                    self.energy_groups,
                );
            }
            if self.mass_contact.is_some() {
                // The pair potential of the positions read back, on a grid built from them.
                self.encode_grid(&mut pass, StateIn::XV, slot)?;
                self.dispatch_kernel(&mut pass, Kernel::MassContactEnergy, slot)?;
            }
        }
        let (x_off, v_off) = (0u64, 16 * n);
        let strain_off = 32 * n;
        let partials_off = strain_off + 4 * ns.max(1);
        let counters_off = partials_off + 48 * partial_count;
        enc.copy_buffer_to_buffer(&self.buf.x, 0, &self.buf.staging[k], x_off, 16 * n);
        if with_velocity {
            enc.copy_buffer_to_buffer(&self.buf.v, 0, &self.buf.staging[k], v_off, 16 * n);
        }
        if ns > 0 {
            enc.copy_buffer_to_buffer(
                &self.buf.strain,
                0,
                &self.buf.staging[k],
                strain_off,
                4 * ns,
            );
        }
        enc.copy_buffer_to_buffer(
            &self.buf.partials,
            0,
            &self.buf.staging[k],
            partials_off,
            48 * partial_count,
        );
        enc.copy_buffer_to_buffer(
            &self.buf.counters,
            0,
            &self.buf.staging[k],
            counters_off,
            16,
        );
        enc.clear_buffer(&self.buf.ledger, 0, None);
        enc.clear_buffer(&self.buf.counters, 0, None);
        let index = self.ctx.queue.submit([enc.finish()]);
        Ok((k, index))
    }

    /// Map `slice` for reading once submission `index` has run, waiting for that submission only:
    /// work submitted after it keeps the GPU busy meanwhile.
    fn map_and_wait(
        &self,
        slice: &wgpu::BufferSlice<'_>,
        index: wgpu::SubmissionIndex,
    ) -> Result<(), BackendError> {
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        // A lost device fails the mapping; its own message says more than the mapping's.
        let lost = |e: String| match self.ctx.take_error() {
            Some(cause) => BackendError::Device(format!(
                "the GPU reported an error on {}: {cause}",
                self.ctx.describe()
            )),
            None => BackendError::Device(format!(
                "reading back from {} failed: {e}",
                self.ctx.describe()
            )),
        };
        self.ctx
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .map_err(|e| lost(e.to_string()))?;
        rx.recv()
            .map_err(|e| lost(e.to_string()))?
            .map_err(|e| lost(e.to_string()))?;
        self.check_device()
    }

    /// Wait for staging buffer `k` (submission `index`) and decode it; folds the ledger.
    fn finish_read_back(
        &mut self,
        k: usize,
        index: wgpu::SubmissionIndex,
        with_velocity: bool,
        (mut positions, mut strain): (Vec<Vec3>, Vec<f32>),
    ) -> Result<ReadBack, BackendError> {
        let n = self.model.mass_count() as u64;
        let ns = self.model.spring_count() as u64;
        let partial_count = u64::from(self.energy_groups.0 * self.energy_groups.1);
        let (x_off, v_off) = (0u64, 16 * n);
        let strain_off = 32 * n;
        let partials_off = strain_off + 4 * ns.max(1);
        let counters_off = partials_off + 48 * partial_count;
        let slice = self.buf.staging[k].slice(..);
        self.map_and_wait(&slice, index)?;
        let lost = |e: String| {
            BackendError::Device(format!(
                "reading back from {} failed: {e}",
                self.ctx.describe()
            ))
        };
        let out = {
            let data = slice.get_mapped_range().map_err(|e| lost(e.to_string()))?;
            let f32s = |off: u64, count: u64| -> &[f32] {
                bytemuck::cast_slice(&data[off as usize..(off + 4 * count) as usize])
            };
            let as_vec3 = |off: u64| {
                f32s(off, 4 * n)
                    .chunks_exact(4)
                    .map(|c| Vec3::new(c[0], c[1], c[2]))
                    .collect::<Vec<_>>()
            };
            let partials = f32s(partials_off, 12 * partial_count);
            let mut sum = [0.0f64; 8];
            let mut max_speed = 0.0f32;
            let mut bad = 0.0f32;
            let mut released = 0.0f64;
            for p in partials.chunks_exact(12) {
                for (s, q) in sum.iter_mut().zip(&p[..8]) {
                    *s += f64::from(*q);
                }
                max_speed = max_speed.max(p[8]);
                bad += p[9];
                released += f64::from(p[10]);
            }
            let counters: &[u32] =
                bytemuck::cast_slice(&data[counters_off as usize..counters_off as usize + 16]);
            ReadBack {
                positions: {
                    positions.clear();
                    positions.extend(
                        f32s(x_off, 4 * n)
                            .chunks_exact(4)
                            .map(|c| Vec3::new(c[0], c[1], c[2])),
                    );
                    positions
                },
                velocities: if with_velocity {
                    as_vec3(v_off)
                } else {
                    Vec::new()
                },
                strain: {
                    strain.clear();
                    strain.extend_from_slice(f32s(strain_off, ns));
                    if self.model.effects.tearing {
                        // compute_strain's mark of a broken spring (BROKEN_STRAIN in the WGSL).
                        for s in strain.iter_mut().filter(|s| **s == -f32::MAX) {
                            *s = f32::NAN;
                        }
                    }
                    strain
                },
                released,
                energy: [sum[0], sum[1], sum[2], sum[3]],
                ledger: [sum[4], sum[5], sum[6], sum[7]],
                max_speed,
                non_finite: bad > 0.0 || !max_speed.is_finite(),
                projections: counters[0],
                first_bad_step: (counters[1] != 0).then(|| u32::MAX - counters[1]),
            }
        };
        self.buf.staging[k].unmap();
        self.ledger.damping_j += out.ledger[0];
        self.ledger.drag_j += out.ledger[1];
        self.ledger.contact_j += out.ledger[2];
        self.ledger.collider_work_j += out.ledger[3];
        self.ledger.plastic_j += out.released;
        Ok(out)
    }

    /// Reductions, copy and wait in one: for tests, divergence reports and `state()`.
    fn read_back(&mut self, with_velocity: bool) -> Result<ReadBack, BackendError> {
        let (k, index) = self.submit_read_back(with_velocity)?;
        self.finish_read_back(k, index, with_velocity, (Vec::new(), Vec::new()))
    }

    /// The divergence of a collected frame, if its state went bad. The step is the first bad
    /// one, as the update kernels flagged it; the mass and spring are read off the state now.
    fn divergence(&mut self, rb: &ReadBack, frame: &Pending) -> Option<Box<Divergence>> {
        if rb.first_bad_step.is_none() && !rb.non_finite && rb.max_speed <= RUNAWAY_SPEED_M_PER_S {
            return None;
        }
        let state = self.state_now().ok()?;
        let mut d = find_divergence(&self.model, &state, self.integrator, f64::from(self.dt))?;
        if let Some(k) = rb.first_bad_step {
            let later = u64::from(frame.stats.substeps.saturating_sub(k + 1));
            d.step = frame.steps - later;
            d.time_secs = frame.time_secs - later as f64 * f64::from(self.dt);
        }
        Some(d)
    }

    fn state_now(&mut self) -> Result<State, BackendError> {
        let rb = self.read_back(true)?;
        Ok(State {
            x: rb.positions,
            v: rb.velocities,
            time_secs: self.time_secs,
            steps: self.steps,
            ledger: self.ledger,
        })
    }
}

/// Mass–mass contact's grid build from the positions of `state`, in order.
fn grid_build(state: StateIn) -> [Kernel; 6] {
    use Kernel::*;
    [
        GridCount(state),
        GridScanBlocks,
        GridScanSums,
        GridScanAdd,
        GridScatter,
        GridSortCells,
    ]
}

/// The dispatches of one step, with their stage slot relative to the step's first slot.
/// `prime`: Verlet's first step also evaluates a(x_0). Implicit Euler's solve is planned in
/// `implicit.rs`; only the post-step passes are here for it.
fn step_plan(integrator: Integrator, effects: &Effects, prime: bool) -> Vec<(Kernel, u32)> {
    use Kernel::*;
    let mut plan = match integrator {
        Integrator::Euler => vec![(Forces(StateIn::XV), 0), (EulerUpdate, 0)],
        Integrator::SemiImplicit => vec![(Forces(StateIn::XV), 0), (SemiImplicitUpdate, 0)],
        Integrator::Rk2 => vec![
            (Forces(StateIn::XV), 0),
            (Rk2Stage, 0),
            (Forces(StateIn::XtVt), 1),
            (Rk2Final, 0),
        ],
        Integrator::Rk4 => vec![
            (Forces(StateIn::XV), 0),
            (Rk4Begin, 0),
            (Forces(StateIn::XtVt), 1),
            (Rk4Mid, 1),
            (Forces(StateIn::XtVt), 2),
            (Rk4Mid, 2),
            (Forces(StateIn::XtVt), 3),
            (Rk4Final, 0),
        ],
        Integrator::Verlet => {
            let mut p = vec![(VerletDrift, 0), (Forces(StateIn::XVt), 3), (VerletKick, 0)];
            if prime {
                p.insert(0, (Forces(StateIn::XV), 0));
            }
            p
        }
        Integrator::Implicit => Vec::new(),
    };
    if effects.has_contact() && integrator != Integrator::Implicit {
        plan.push((ProjectContacts, 3));
    }
    if effects.self_collision.is_some() {
        plan = plan
            .into_iter()
            .flat_map(|(k, slot)| match k {
                Forces(s) => grid_build(s)
                    .into_iter()
                    .chain([Forces(s), CollideMasses(s)])
                    .map(|k| (k, slot))
                    .collect(),
                _ => vec![(k, slot)],
            })
            .collect();
    }
    if effects.springs_change() {
        plan.push((UpdateSprings, 3));
    }
    plan
}

/// For `hooke check`: the kernels one GPU step dispatches, in order, and the effects compiled into
/// them (absent effects are specialised away and cost nothing).
pub fn step_passes(model: &Model, integrator: Integrator) -> (Vec<String>, Vec<&'static str>) {
    let mut passes = if integrator == Integrator::Implicit {
        vec![implicit::step_passes()]
    } else {
        Vec::new()
    };
    passes.extend(
        step_plan(integrator, &model.effects, false)
            .into_iter()
            .map(|(k, _)| k.name().to_owned()),
    );
    let effects = kernels::effect_constants(model)
        .into_iter()
        .filter(|(_, on)| *on != 0.0)
        .map(|(name, _)| name)
        .collect();
    (passes, effects)
}

/// What a dispatch runs (names as in the WGSL).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kernel {
    Forces(StateIn),
    EulerUpdate,
    SemiImplicitUpdate,
    Rk2Stage,
    Rk2Final,
    Rk4Begin,
    Rk4Mid,
    Rk4Final,
    VerletDrift,
    VerletKick,
    ProjectContacts,
    UpdateSprings,
    GridCount(StateIn),
    GridScanBlocks,
    GridScanSums,
    GridScanAdd,
    GridScatter,
    GridSortCells,
    CollideMasses(StateIn),
    /// At snapshot time only.
    MassContactEnergy,
}

/// Which state a force evaluation reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum StateIn {
    XV,
    XtVt,
    XVt,
}

impl Kernel {
    fn name(self) -> &'static str {
        match self {
            Kernel::Forces(_) => "compute_forces",
            Kernel::EulerUpdate => "euler_update",
            Kernel::SemiImplicitUpdate => "semi_implicit_update",
            Kernel::Rk2Stage => "rk2_stage",
            Kernel::Rk2Final => "rk2_final",
            Kernel::Rk4Begin => "rk4_begin",
            Kernel::Rk4Mid => "rk4_mid",
            Kernel::Rk4Final => "rk4_final",
            Kernel::VerletDrift => "verlet_drift",
            Kernel::VerletKick => "verlet_kick",
            Kernel::ProjectContacts => "project_contacts",
            Kernel::UpdateSprings => "update_springs",
            Kernel::GridCount(_) => "grid_count",
            Kernel::GridScanBlocks => "grid_scan_blocks",
            Kernel::GridScanSums => "grid_scan_sums",
            Kernel::GridScanAdd => "grid_scan_add",
            Kernel::GridScatter => "grid_scatter",
            Kernel::GridSortCells => "grid_sort_cells",
            Kernel::CollideMasses(_) => "collide_masses",
            Kernel::MassContactEnergy => "mass_contact_energy",
        }
    }
}

/// A snapshot asked for and not yet collected.
struct Pending {
    staging: usize,
    index: wgpu::SubmissionIndex,
    frame: u64,
    stats: StepStats,
    time_secs: f64,
    steps: u64,
    started: Option<Instant>,
}

struct ReadBack {
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    strain: Vec<f32>,
    energy: [f64; 4],
    ledger: [f64; 4],
    /// Energy let go by plasticity and tearing since the last read-back.
    released: f64,
    max_speed: f32,
    non_finite: bool,
    projections: u32,
    /// Index, within the last submission of steps, of the first step whose state went bad.
    first_bad_step: Option<u32>,
}

/// For `hooke check`: the adapter a run would use, its relevant limits, and whether the scene fits.
pub fn adapter_report(
    name: Option<&str>,
    model: &Model,
    integrator: Integrator,
) -> Result<String, String> {
    let ctx = GpuContext::open(name)?;
    let l = &ctx.limits;
    let fits = match check_fits(&ctx, model, integrator) {
        Ok(()) => "the scene fits".to_owned(),
        Err(e) => e.to_string(),
    };
    Ok(format!(
        "adapter: {} (max storage buffer {} MiB, {} storage buffers per stage, {} workgroups per dimension, timestamps {}); {fits}",
        ctx.describe(),
        l.max_storage_buffer_binding_size.min(l.max_buffer_size) >> 20,
        l.max_storage_buffers_per_shader_stage,
        l.max_compute_workgroups_per_dimension,
        if ctx.features.contains(wgpu::Features::TIMESTAMP_QUERY) {
            "yes"
        } else {
            "no"
        },
    ))
}

/// Bytes of the per-mass scratch: RK4's and Verlet's stage sums, or implicit Euler's vectors.
fn scratch_bytes(model: &Model, integrator: Integrator) -> u64 {
    let per_mass = if integrator == Integrator::Implicit {
        16 * IMPLICIT_VECTORS
    } else {
        48
    };
    per_mass * model.mass_count() as u64
}

/// Bytes of compute_forces' output: acceleration and rates, and for implicit Euler with contacts
/// their linearisation.
fn deriv_bytes(model: &Model, integrator: Integrator) -> u64 {
    let per_mass = if integrator == Integrator::Implicit && model.effects.has_contact() {
        64
    } else {
        32
    };
    per_mass * model.mass_count() as u64
}

/// Refuse a scene beyond the adapter's limits with the numbers, instead of failing inside wgpu.
fn check_fits(ctx: &GpuContext, model: &Model, integrator: Integrator) -> Result<(), BackendError> {
    let n = model.mass_count() as u64;
    let ns = model.spring_count() as u64;
    let limit = ctx
        .limits
        .max_storage_buffer_binding_size
        .min(ctx.limits.max_buffer_size);
    let largest = [
        ("per-mass scratch", scratch_bytes(model, integrator)),
        ("per-mass derivatives", deriv_bytes(model, integrator)),
        ("springs", 20 * ns),
        ("adjacency", 16 * ns),
        (
            "mass-contact hash grid",
            model.effects.self_collision.map_or(0, |_| {
                4 * (u64::from(crate::cpu::table_size(n as usize)) + 1)
            }),
        ),
    ];
    for (what, bytes) in largest {
        if bytes > limit {
            return Err(BackendError::Device(format!(
                "the scene is too large for {}: its {what} buffer needs {bytes} bytes, the adapter allows {limit} bytes per storage buffer \
                 ({n} masses, {ns} springs). Use a smaller grid or --backend cpu",
                ctx.describe()
            )));
        }
    }
    // Scene files are held to this by validation; a model built by hand is checked here, since
    // each stage slot has room for only this many collider poses.
    let colliders = model.effects.colliders.len();
    if colliders > layout::MAX_COLLIDERS {
        return Err(BackendError::Device(format!(
            "the model has {colliders} colliders; the GPU backend passes at most {} (their poses \
             ride in each stage's uniform slot). Use fewer colliders or --backend cpu",
            layout::MAX_COLLIDERS
        )));
    }
    let needed = 8;
    if ctx.limits.max_storage_buffers_per_shader_stage < needed {
        return Err(BackendError::Device(format!(
            "{} allows {} storage buffers per shader stage; Hooke's kernels need {needed}. Use --backend cpu",
            ctx.describe(),
            ctx.limits.max_storage_buffers_per_shader_stage
        )));
    }
    Ok(())
}

impl Backend for GpuBackend {
    fn describe(&self) -> String {
        format!("gpu: {}", self.ctx.describe())
    }

    fn advance(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        self.advance_started.get_or_insert_with(Instant::now);
        if self.solve.is_some() {
            return self.advance_implicit(substeps);
        }
        // One extra slot, the last, for the snapshot's reductions.
        self.reserve_stage_slots(SLOTS_PER_STEP * substeps + 1);
        let stages = self.stage_times(substeps);
        let t = self.time_after(substeps);
        self.write_slots(0, &stages);
        let mut enc = self.encoder("steps");
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("steps"),
                timestamp_writes: None,
            });
            self.encode_steps(&mut pass, substeps)?;
        }
        self.ctx.queue.submit([enc.finish()]);
        self.time_secs = t;
        self.steps += u64::from(substeps);
        self.frame_steps += substeps;
        self.check_device()?;
        Ok(StepStats {
            substeps,
            dt_secs: f64::from(self.dt),
            step_ms: 0.0,
            projections: 0,
            ..StepStats::default()
        })
    }

    fn request_snapshot(&mut self, frame: u64, stats: StepStats) -> Result<(), BackendError> {
        let (staging, index) = self.submit_read_back(false)?;
        self.frame_steps = 0;
        self.pending.push_back(Pending {
            staging,
            index,
            frame,
            stats,
            time_secs: self.time_secs,
            steps: self.steps,
            started: self.advance_started.take(),
        });
        Ok(())
    }

    fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError> {
        let Some(p) = self.pending.pop_front() else {
            return Ok(None);
        };
        let mut spare = self.spare.pop();
        let buffers = spare.as_mut().map_or_else(Default::default, |s| {
            (
                std::mem::take(&mut s.positions),
                std::mem::take(&mut s.strain),
            )
        });
        let rb = self.finish_read_back(p.staging, p.index.clone(), false, buffers)?;
        if let Some(d) = self.divergence(&rb, &p) {
            return Err(BackendError::Diverged(d));
        }
        Ok(Some(Snapshot {
            frame: p.frame,
            time_secs: p.time_secs,
            steps: p.steps,
            energies: Energies {
                kinetic_j: rb.energy[0],
                elastic_j: rb.energy[1],
                gravity_j: rb.energy[2],
                contact_j: rb.energy[3],
                ledger: self.ledger,
            },
            positions: rb.positions,
            strain: rb.strain,
            stats: StepStats {
                step_ms: p.started.map_or(0.0, |t| t.elapsed().as_secs_f64() * 1e3),
                projections: rb.projections,
                ..p.stats
            },
            collider_positions: {
                let mut c = spare.map(|s| s.collider_positions).unwrap_or_default();
                c.clear();
                c.extend(
                    self.model
                        .effects
                        .colliders
                        .iter()
                        .map(|col| col.path.pose_at(p.time_secs).position_m),
                );
                c
            },
        }))
    }

    fn recycle(&mut self, snapshot: Snapshot) {
        if self.spare.len() < 8 {
            self.spare.push(snapshot);
        }
    }

    fn state(&mut self) -> Result<State, BackendError> {
        self.state_now()
    }

    fn finish(&mut self) -> Result<(), BackendError> {
        self.wait_idle()
    }

    fn memory_bytes(&self) -> Option<u64> {
        Some(self.memory_bytes)
    }
}
