//! The simulation's GPU buffers and the bind groups over them: the model's (read-only after
//! upload), the state's, and those of the effects a scene has (plasticity and tearing, mass–mass
//! contact, implicit Euler's solver).

use glam::Vec3;
use wgpu::util::DeviceExt as _;

use super::kernels::{Group, Sizes, Threads};
use super::layout::{self, Collider, MassContact, Params, SolverStatus};
use super::limits::{deriv_bytes, scratch_bytes};
use super::pipelines::Layouts;
use super::plan::StateIn;
use super::shaders::WORKGROUP;
use crate::backend::RUNAWAY_SPEED_M_PER_S;
use crate::integrator::Integrator;
use crate::model::{Model, Shape};

/// Creates buffers and counts their bytes.
struct Alloc<'a> {
    device: &'a wgpu::Device,
    bytes: u64,
}

const COPY: wgpu::BufferUsages = wgpu::BufferUsages::COPY_SRC.union(wgpu::BufferUsages::COPY_DST);

impl Alloc<'_> {
    fn count(&mut self, b: wgpu::Buffer) -> wgpu::Buffer {
        self.bytes += b.size();
        b
    }

    fn storage(&mut self, label: &str, contents: &[u8], extra: wgpu::BufferUsages) -> wgpu::Buffer {
        // wgpu rejects zero-sized bindings: give empty arrays one zeroed element.
        let zeros = [0u8; 64];
        let b = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: if contents.is_empty() {
                    &zeros
                } else {
                    contents
                },
                usage: wgpu::BufferUsages::STORAGE | extra,
            });
        self.count(b)
    }

    /// Read-only after upload.
    fn model(&mut self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        self.storage(label, contents, wgpu::BufferUsages::empty())
    }

    fn zeros(&mut self, label: &str, bytes: usize) -> wgpu::Buffer {
        self.storage(label, &vec![0u8; bytes], COPY)
    }

    fn uniform(&mut self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        let b = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::UNIFORM,
            });
        self.count(b)
    }

    /// Where the host maps what it reads back.
    fn read_back(&mut self, label: &str, size: u64) -> wgpu::Buffer {
        let b = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.count(b)
    }
}

/// Workgroup counts of each kind of dispatch.
#[derive(Debug, Clone, Copy)]
pub struct Workgroups {
    pub masses: (u32, u32),
    pub springs: (u32, u32),
    /// Over masses or springs, whichever are more: the energy sums' partials.
    pub energies: (u32, u32),
    /// Mass–mass contact only: over the hash grid's buckets, and one per block of its prefix sum.
    pub buckets: (u32, u32),
    pub scan_blocks: (u32, u32),
}

impl Workgroups {
    pub fn of(&self, t: Threads) -> (u32, u32) {
        match t {
            Threads::Masses => self.masses,
            Threads::Springs => self.springs,
            Threads::Energies => self.energies,
            Threads::Buckets => self.buckets,
            Threads::ScanBlocks => self.scan_blocks,
            Threads::OneGroup => (1, 1),
        }
    }

    /// Per-workgroup partial sums of the energy reductions.
    pub fn partial_count(&self) -> u64 {
        u64::from(self.energies.0 * self.energies.1)
    }
}

/// Workgroup counts for `threads` threads: a 2D grid when x would exceed the adapter's limit.
pub fn groups_for(threads: u32, max_per_dim: u32) -> (u32, u32) {
    let groups = threads.div_ceil(WORKGROUP).max(1);
    if groups <= max_per_dim {
        (groups, 1)
    } else {
        let y = groups.div_ceil(max_per_dim);
        (groups.div_ceil(y), y)
    }
}

/// Mass–mass contact's hash grid, as far as the host reads it.
pub struct GridBuffers {
    pub cell_start: wgpu::Buffer,
    pub sorted: wgpu::Buffer,
    pub table_size: u32,
    pub block_count: u32,
}

/// Implicit Euler's solver (its vectors live in the per-mass scratch, `sums`).
pub struct SolverBuffers {
    /// `SolverStatus`, then the per-workgroup partial sums.
    pub scratch: wgpu::Buffer,
    /// Where the host reads the status between chunks.
    pub status: wgpu::Buffer,
}

/// Every buffer a run binds, and the bind groups over them.
pub struct Resources {
    pub x: wgpu::Buffer,
    pub v: wgpu::Buffer,
    pub ledger: wgpu::Buffer,
    pub counters: wgpu::Buffer,
    pub strain: wgpu::Buffer,
    pub partials: wgpu::Buffer,
    /// Two, so that one frame's snapshot is read back while the next frame steps.
    pub staging: [wgpu::Buffer; 2],
    /// Bind group 0 of each kernel group; `None` for an effect the scene lacks.
    groups: Vec<Option<wgpu::BindGroup>>,
    /// Bind group 1, by [`StateIn`].
    states: [wgpu::BindGroup; 3],
    pub grid: Option<GridBuffers>,
    pub solver: Option<SolverBuffers>,
    pub workgroups: Workgroups,
    /// Bytes of GPU memory held by the buffers above (all but the stage slots').
    pub memory_bytes: u64,
}

/// The buffers bind groups are made of, by name.
struct Bufs {
    params: wgpu::Buffer,
    springs: wgpu::Buffer,
    offsets: wgpu::Buffer,
    neighbors: wgpu::Buffer,
    colliders: wgpu::Buffer,
    mass: wgpu::Buffer,
    x: wgpu::Buffer,
    v: wgpu::Buffer,
    xt: wgpu::Buffer,
    vt: wgpu::Buffer,
    deriv: wgpu::Buffer,
    sums: wgpu::Buffer,
    ledger: wgpu::Buffer,
    counters: wgpu::Buffer,
    strain: wgpu::Buffer,
    partials: wgpu::Buffer,
}

fn vec4s(v: &[Vec3]) -> Vec<[f32; 4]> {
    v.iter().map(|p| [p.x, p.y, p.z, 0.0]).collect()
}

fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    label: &str,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// Scene-wide constants.
fn params(model: &Model) -> Params {
    let e = &model.effects;
    let ground = e.ground;
    Params {
        mass_count: model.mass_count() as u32,
        spring_count: model.spring_count() as u32,
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
    }
}

fn colliders(model: &Model) -> Vec<Collider> {
    let collider = |c: &crate::model::Collider| {
        let (kind, shape) = match c.shape {
            Shape::Sphere { radius_m } => (layout::SPHERE, [radius_m, 0.0, 0.0, 0.0]),
            Shape::Box { half_extents_m } => (layout::BOX, half_extents_m.extend(0.0).to_array()),
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
    };
    model.effects.colliders.iter().map(collider).collect()
}

/// Bind group 0 of each kernel group, as they are made.
struct GroupSet<'a> {
    device: &'a wgpu::Device,
    layouts: &'a Layouts,
    groups: Vec<Option<wgpu::BindGroup>>,
}

impl GroupSet<'_> {
    /// Bind `buffers` in order as group `g`.
    fn set(&mut self, g: Group, buffers: &[&wgpu::Buffer]) {
        debug_assert_eq!(buffers.len(), g.slots().len(), "{g:?}");
        let label = format!("{g:?}");
        // A group no kernel of the run uses has no layout, and is never bound.
        self.groups[g as usize] = self
            .layouts
            .group(g)
            .map(|layout| bind_group(self.device, layout, &label, buffers));
    }

    /// The groups every run binds.
    fn common(&mut self, b: &Bufs) {
        use Group::*;
        self.set(
            ForcesModel,
            &[
                &b.params,
                &b.springs,
                &b.offsets,
                &b.neighbors,
                &b.colliders,
                &b.mass,
                &b.deriv,
            ],
        );
        self.set(
            Integrate,
            &[
                &b.params,
                &b.x,
                &b.v,
                &b.xt,
                &b.vt,
                &b.deriv,
                &b.sums,
                &b.ledger,
                &b.counters,
            ],
        );
        self.set(
            Collide,
            &[
                &b.params,
                &b.colliders,
                &b.mass,
                &b.x,
                &b.v,
                &b.ledger,
                &b.counters,
            ],
        );
        self.set(
            Reduce,
            &[
                &b.params,
                &b.springs,
                &b.colliders,
                &b.mass,
                &b.x,
                &b.v,
                &b.ledger,
                &b.strain,
                &b.partials,
            ],
        );
    }

    /// Plasticity and tearing: each spring's limits, and the energy it let go since the last
    /// snapshot.
    fn springs(&mut self, a: &mut Alloc<'_>, b: &Bufs, model: &Model, dt_secs: f64) {
        let limits = a.model(
            "spring limits",
            bytemuck::cast_slice(&model.spring_limits(dt_secs)),
        );
        let released = a.zeros("released", 4 * model.spring_count());
        self.set(
            Group::Springs,
            &[&b.params, &b.springs, &limits, &b.x, &released, &b.partials],
        );
    }
}

impl Resources {
    pub fn new(
        device: &wgpu::Device,
        limits: &wgpu::Limits,
        layouts: &Layouts,
        model: &Model,
        (integrator, dt_secs): (Integrator, f64),
    ) -> Self {
        let mut a = Alloc { device, bytes: 0 };
        let (n, ns) = (model.mass_count(), model.spring_count());
        let max_dim = limits.max_compute_workgroups_per_dimension;
        let mut workgroups = Workgroups {
            masses: groups_for(n as u32, max_dim),
            springs: groups_for(ns as u32, max_dim),
            energies: groups_for(n.max(ns) as u32, max_dim),
            buckets: (1, 1),
            scan_blocks: (1, 1),
        };
        let b = Bufs::new(&mut a, model, integrator, workgroups.partial_count());
        let mut groups = GroupSet {
            device,
            layouts,
            groups: Group::ALL.iter().map(|_| None).collect(),
        };
        groups.common(&b);
        if model.effects.springs_change() {
            groups.springs(&mut a, &b, model, dt_secs);
        }
        let solver = (integrator == Integrator::Implicit)
            .then(|| SolverBuffers::new(&mut a, (&b, model), &mut groups, workgroups.masses));
        let grid = model.effects.self_collision.map(|c| {
            let grid = GridBuffers::new(&mut a, model, &c, &b, &mut groups);
            workgroups.buckets = groups_for(grid.table_size, max_dim);
            workgroups.scan_blocks = groups_for(grid.block_count * WORKGROUP, max_dim);
            grid
        });
        let staging_size =
            (16 * n + 16 * n + 4 * ns.max(1)) as u64 + 48 * workgroups.partial_count() + 16;
        let staging = [0, 1].map(|_| a.read_back("staging", staging_size));
        let states = [(&b.x, &b.v), (&b.xt, &b.vt), (&b.x, &b.vt)]
            .map(|(x, v)| bind_group(device, &layouts.state, "state", &[x, v]));
        Self {
            x: b.x,
            v: b.v,
            ledger: b.ledger,
            counters: b.counters,
            strain: b.strain,
            partials: b.partials,
            staging,
            groups: groups.groups,
            states,
            grid,
            solver,
            workgroups,
            memory_bytes: a.bytes,
        }
    }

    /// Bind group 0 of kernel group `g`; `None` for an effect the scene lacks.
    pub fn group(&self, g: Group) -> Option<&wgpu::BindGroup> {
        self.groups[g as usize].as_ref()
    }

    /// Bind group 1 over `s`.
    pub fn state(&self, s: StateIn) -> &wgpu::BindGroup {
        &self.states[s as usize]
    }

    /// The sizes a step's memory traffic depends on.
    pub fn sizes(&self, model: &Model) -> Sizes {
        let (table, blocks) = self.grid.as_ref().map_or((0, 0), |g| {
            (u64::from(g.table_size), u64::from(g.block_count))
        });
        Sizes {
            n: model.mass_count() as u64,
            ns: model.spring_count() as u64,
            table,
            blocks,
            colliders: model.effects.colliders.len() as u64 * 48,
        }
    }
}

impl Bufs {
    fn new(a: &mut Alloc<'_>, model: &Model, integrator: Integrator, partial_count: u64) -> Self {
        let (n, ns) = (model.mass_count(), model.spring_count());
        let mass: Vec<[f32; 2]> = model
            .mass_kg
            .iter()
            .zip(&model.inv_mass)
            .map(|(&m, &w)| [m, w])
            .collect();
        Self {
            params: a.uniform("params", bytemuck::bytes_of(&params(model))),
            springs: a.model("springs", bytemuck::cast_slice(&model.springs)),
            offsets: a.model("offsets", bytemuck::cast_slice(&model.adjacency.offsets)),
            neighbors: a.model("neighbors", bytemuck::cast_slice(&model.adjacency.entries)),
            colliders: a.model("colliders", bytemuck::cast_slice(&colliders(model))),
            mass: a.model("mass", bytemuck::cast_slice(&mass)),
            x: a.storage("x", bytemuck::cast_slice(&vec4s(&model.initial.x)), COPY),
            v: a.storage("v", bytemuck::cast_slice(&vec4s(&model.initial.v)), COPY),
            xt: a.zeros("xt", 16 * n),
            vt: a.zeros("vt", 16 * n),
            deriv: a.zeros("deriv", deriv_bytes(model, integrator) as usize),
            sums: a.zeros("sums", scratch_bytes(model, integrator) as usize),
            ledger: a.zeros("ledger", 16 * n),
            counters: a.zeros("counters", 16),
            strain: a.zeros("strain", 4 * ns),
            partials: a.zeros("partials", 48 * partial_count as usize),
        }
    }
}

impl SolverBuffers {
    /// The solver's status, then one partial sum per mass workgroup.
    fn new(
        a: &mut Alloc<'_>,
        (b, model): (&Bufs, &Model),
        groups: &mut GroupSet<'_>,
        masses: (u32, u32),
    ) -> Self {
        let status_bytes = std::mem::size_of::<SolverStatus>();
        let scratch = a.zeros("solver", status_bytes + 16 * (masses.0 * masses.1) as usize);
        let status = a.read_back("solver status", status_bytes as u64);
        // Each CSR entry's spring terms at the Newton iterate (two vec4s), kept for the solve.
        let terms = a.zeros("spring terms", 32 * model.adjacency.entries.len().max(1));
        groups.set(
            Group::Solve,
            &[
                &b.params,
                &b.springs,
                &b.offsets,
                &b.neighbors,
                &b.colliders,
                &b.mass,
                &b.deriv,
                &b.x,
                &b.v,
                &b.xt,
                &b.vt,
                &b.sums,
                &b.ledger,
                &b.counters,
                &scratch,
                &terms,
            ],
        );
        Self { scratch, status }
    }
}

impl GridBuffers {
    /// The grid's buffers, and the bind groups of its build (grid.wgsl) and of the pairs
    /// (collide_masses.wgsl).
    fn new(
        a: &mut Alloc<'_>,
        model: &Model,
        c: &crate::model::MassContact,
        b: &Bufs,
        groups: &mut GroupSet<'_>,
    ) -> Self {
        let n = model.mass_count();
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
        let contact = a.uniform("mass contact", bytemuck::bytes_of(&contact));
        let bodies = a.model("mass bodies", bytemuck::cast_slice(&model.mass_body));
        let table = table_size as usize;
        let cell_count = a.zeros("cell count", 4 * table);
        let cell_start = a.zeros("cell start", 4 * (table + 1));
        let block_sums = a.zeros("block sums", 4 * block_count as usize);
        let mass_cell = a.zeros("mass cell", 4 * n);
        let sorted = a.zeros("sorted masses", 4 * n);
        groups.set(
            Group::Grid,
            &[
                &b.params,
                &contact,
                &cell_count,
                &cell_start,
                &block_sums,
                &mass_cell,
                &sorted,
            ],
        );
        groups.set(
            Group::CollideMasses,
            &[
                &b.params,
                &contact,
                &b.mass,
                &bodies,
                &cell_start,
                &sorted,
                &b.deriv,
                &b.partials,
            ],
        );
        Self {
            cell_start,
            sorted,
            table_size,
            block_count,
        }
    }
}
