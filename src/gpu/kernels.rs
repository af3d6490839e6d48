//! Shader modules, bind group layouts and compute pipelines. Each WGSL file is compiled after
//! `common.wgsl`; the effects a scene lacks are specialised away through `override` constants.

use crate::integrator::Integrator;
use crate::model::{Model, Shape};

pub const COMMON: &str = include_str!("../../shaders/common.wgsl");
pub const FORCES: &str = include_str!("../../shaders/forces.wgsl");
pub const INTEGRATE: &str = include_str!("../../shaders/integrate.wgsl");
pub const COLLIDE: &str = include_str!("../../shaders/collide.wgsl");
pub const REDUCE: &str = include_str!("../../shaders/reduce.wgsl");
pub const IMPLICIT: &str = include_str!("../../shaders/implicit.wgsl");
pub const SPRINGS: &str = include_str!("../../shaders/springs.wgsl");
pub const GRID: &str = include_str!("../../shaders/grid.wgsl");
pub const COLLIDE_MASSES: &str = include_str!("../../shaders/collide_masses.wgsl");

/// Every shader program as compiled: (file name, common + file).
pub fn programs() -> [(&'static str, String); 8] {
    [
        ("forces.wgsl", format!("{COMMON}\n{FORCES}")),
        ("integrate.wgsl", format!("{COMMON}\n{INTEGRATE}")),
        ("collide.wgsl", format!("{COMMON}\n{COLLIDE}")),
        ("reduce.wgsl", format!("{COMMON}\n{REDUCE}")),
        ("implicit.wgsl", format!("{COMMON}\n{IMPLICIT}")),
        ("springs.wgsl", format!("{COMMON}\n{SPRINGS}")),
        ("grid.wgsl", format!("{COMMON}\n{GRID}")),
        ("collide_masses.wgsl", format!("{COMMON}\n{COLLIDE_MASSES}")),
    ]
}

pub const WORKGROUP: u32 = 64;

// The hash grid's table is whole blocks of the GPU's prefix sum: four buckets per invocation
// (`SCAN_BLOCK` in shaders/common.wgsl).
const _: () = assert!(crate::cpu::SCAN_BLOCK == 4 * WORKGROUP);

/// Binding kinds, in binding order.
#[derive(Clone, Copy)]
pub enum Slot {
    Uniform,
    UniformDynamic,
    Read,
    ReadWrite,
}

pub fn layout(device: &wgpu::Device, label: &str, slots: &[Slot]) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = slots
        .iter()
        .enumerate()
        .map(|(i, s)| wgpu::BindGroupLayoutEntry {
            binding: i as u32,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: match s {
                Slot::Uniform | Slot::UniformDynamic => wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: matches!(s, Slot::UniformDynamic),
                    min_binding_size: None,
                },
                Slot::Read | Slot::ReadWrite => wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage {
                        read_only: matches!(s, Slot::Read),
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
            },
            count: None,
        })
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

/// Every override constant of a pipeline: the effects, and the implicit solver's switch and
/// stopping rules (the CPU's, so both backends stop alike).
pub fn constants(model: &Model, integrator: Integrator) -> Vec<(&'static str, f64)> {
    use crate::cpu::{CG_MAX_ITERATIONS, CG_TOLERANCE, NEWTON_TOLERANCE};
    let mut c = effect_constants(model);
    c.extend([
        (
            "IMPLICIT",
            if integrator == Integrator::Implicit {
                1.0
            } else {
                0.0
            },
        ),
        ("CG_TOLERANCE", CG_TOLERANCE),
        ("PAIR_STICK_SHARE", f64::from(crate::cpu::PAIR_STICK_SHARE)),
        ("CG_MAX_ITERATIONS", f64::from(CG_MAX_ITERATIONS)),
        ("NEWTON_TOLERANCE", NEWTON_TOLERANCE),
    ]);
    c
}

/// The override constants that switch effects on, from the model.
pub fn effect_constants(model: &Model) -> Vec<(&'static str, f64)> {
    let e = &model.effects;
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    vec![
        ("HAS_GRAVITY", flag(e.gravity_m_per_s2.is_some())),
        ("HAS_DRAG", flag(e.air_drag_per_s.is_some())),
        ("HAS_GROUND", flag(e.ground.is_some())),
        (
            "HAS_SPHERES",
            flag(e.has_shape(|s| matches!(s, Shape::Sphere { .. }))),
        ),
        (
            "HAS_BOXES",
            flag(e.has_shape(|s| matches!(s, Shape::Box { .. }))),
        ),
        (
            "HAS_PLANES",
            flag(e.has_shape(|s| matches!(s, Shape::Plane { .. }))),
        ),
        ("HAS_COLLIDERS", flag(!e.colliders.is_empty())),
        (
            "HAS_DAMPING",
            flag(model.springs.iter().any(|s| s.damping_n_s_per_m != 0.0)),
        ),
        ("HAS_PLASTICITY", flag(e.plasticity)),
        ("HAS_TEARING", flag(e.tearing)),
    ]
}

pub struct Layouts {
    pub forces_model: wgpu::BindGroupLayout,
    pub forces_state: wgpu::BindGroupLayout,
    pub stage: wgpu::BindGroupLayout,
    pub integrate: wgpu::BindGroupLayout,
    pub collide: wgpu::BindGroupLayout,
    pub reduce: wgpu::BindGroupLayout,
    pub solve: wgpu::BindGroupLayout,
    pub springs: wgpu::BindGroupLayout,
    pub grid: wgpu::BindGroupLayout,
    pub collide_masses: wgpu::BindGroupLayout,
}

impl Layouts {
    pub fn new(device: &wgpu::Device) -> Self {
        use Slot::*;
        Self {
            forces_model: layout(
                device,
                "forces model",
                &[Uniform, Read, Read, Read, Read, Read, ReadWrite],
            ),
            forces_state: layout(device, "forces state", &[Read, Read]),
            stage: layout(device, "stage", &[UniformDynamic]),
            integrate: layout(
                device,
                "integrate",
                &[
                    Uniform, ReadWrite, ReadWrite, ReadWrite, ReadWrite, Read, ReadWrite,
                    ReadWrite, ReadWrite,
                ],
            ),
            collide: layout(
                device,
                "collide",
                &[
                    Uniform, Read, Read, ReadWrite, ReadWrite, ReadWrite, ReadWrite,
                ],
            ),
            reduce: layout(
                device,
                "reduce",
                &[
                    Uniform, Read, Read, Read, Read, Read, Read, ReadWrite, ReadWrite,
                ],
            ),
            // params, springs, offsets, neighbours, mass, xt, deriv, work, scratch.
            solve: layout(
                device,
                "solve",
                &[
                    Uniform, Read, Read, Read, Read, Read, Read, ReadWrite, ReadWrite,
                ],
            ),
            // params, springs, limits, x, released, partials.
            springs: layout(
                device,
                "springs",
                &[Uniform, ReadWrite, Read, Read, ReadWrite, ReadWrite],
            ),
            // params, contact, cell counts, cell starts, block sums, mass buckets, sorted masses.
            grid: layout(
                device,
                "grid",
                &[
                    Uniform, Uniform, ReadWrite, ReadWrite, ReadWrite, ReadWrite, ReadWrite,
                ],
            ),
            // params, contact, mass, mass bodies, cell starts, sorted masses, deriv, partials:
            // with the state's x and v, the 8 storage buffers a stage may bind.
            collide_masses: layout(
                device,
                "collide masses",
                &[
                    Uniform, Uniform, Read, Read, Read, Read, ReadWrite, ReadWrite,
                ],
            ),
        }
    }
}

pub struct Pipelines {
    pub compute_forces: wgpu::ComputePipeline,
    pub euler_update: wgpu::ComputePipeline,
    pub semi_implicit_update: wgpu::ComputePipeline,
    pub rk2_stage: wgpu::ComputePipeline,
    pub rk2_final: wgpu::ComputePipeline,
    pub rk4_begin: wgpu::ComputePipeline,
    pub rk4_mid: wgpu::ComputePipeline,
    pub rk4_final: wgpu::ComputePipeline,
    pub verlet_drift: wgpu::ComputePipeline,
    pub verlet_kick: wgpu::ComputePipeline,
    pub project_contacts: wgpu::ComputePipeline,
    pub compute_strain: wgpu::ComputePipeline,
    pub compute_energies: wgpu::ComputePipeline,
    /// Only for the implicit integrator.
    pub implicit: Option<ImplicitPipelines>,
    /// Only when springs change during the run (plasticity, tearing).
    pub springs: Option<SpringPipelines>,
    /// Only with mass–mass contact.
    pub mass_contact: Option<MassContactPipelines>,
}

pub struct SpringPipelines {
    pub update_springs: wgpu::ComputePipeline,
    pub sum_spring_work: wgpu::ComputePipeline,
}

/// Mass–mass contact's kernels: the hash grid's build (grid.wgsl) and the pairs
/// (collide_masses.wgsl).
pub struct MassContactPipelines {
    pub grid_count: wgpu::ComputePipeline,
    pub grid_scan_blocks: wgpu::ComputePipeline,
    pub grid_scan_sums: wgpu::ComputePipeline,
    pub grid_scan_add: wgpu::ComputePipeline,
    pub grid_scatter: wgpu::ComputePipeline,
    pub grid_sort_cells: wgpu::ComputePipeline,
    pub collide_masses: wgpu::ComputePipeline,
    pub mass_contact_energy: wgpu::ComputePipeline,
}

/// Implicit Euler's kernels: the state-side ones in integrate.wgsl, the solve in implicit.wgsl.
pub struct ImplicitPipelines {
    pub implicit_begin: wgpu::ComputePipeline,
    pub implicit_iterate: wgpu::ComputePipeline,
    pub implicit_final: wgpu::ComputePipeline,
    pub solver_begin: wgpu::ComputePipeline,
    pub implicit_rhs: wgpu::ComputePipeline,
    pub cg_begin: wgpu::ComputePipeline,
    pub apply_system: wgpu::ComputePipeline,
    pub cg_alpha: wgpu::ComputePipeline,
    pub cg_update: wgpu::ComputePipeline,
    pub cg_beta: wgpu::ComputePipeline,
    pub cg_direction: wgpu::ComputePipeline,
    pub newton_update: wgpu::ComputePipeline,
    pub newton_end: wgpu::ComputePipeline,
}

impl Pipelines {
    pub fn new(
        device: &wgpu::Device,
        l: &Layouts,
        constants: &[(&str, f64)],
        implicit: bool,
        springs_change: bool,
        mass_contact: bool,
    ) -> Self {
        let module = |(name, src): (&str, String)| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            })
        };
        let [
            forces,
            integrate,
            collide,
            reduce,
            solve,
            springs,
            grid,
            pairs,
        ] = programs();
        let (forces, integrate) = (module(forces), module(integrate));
        let (collide, reduce) = (module(collide), module(reduce));
        // Implicit Euler's solve compiles only for that integrator, mass–mass contact only for
        // scenes that have it.
        let solve = implicit.then(|| module(solve));
        let springs = springs_change.then(|| module(springs));
        let mass_contact_modules = mass_contact.then(|| (module(grid), module(pairs)));
        let pipeline_layout = |label: &str, groups: &[Option<&wgpu::BindGroupLayout>]| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: groups,
                immediate_size: 0,
            })
        };
        let forces_layout = pipeline_layout(
            "forces",
            &[Some(&l.forces_model), Some(&l.forces_state), Some(&l.stage)],
        );
        let integrate_layout =
            pipeline_layout("integrate", &[Some(&l.integrate), None, Some(&l.stage)]);
        let collide_layout = pipeline_layout("collide", &[Some(&l.collide), None, Some(&l.stage)]);
        let reduce_layout = pipeline_layout("reduce", &[Some(&l.reduce), None, Some(&l.stage)]);
        let make = |layout: &wgpu::PipelineLayout, module: &wgpu::ShaderModule, entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            })
        };
        Self {
            compute_forces: make(&forces_layout, &forces, "compute_forces"),
            euler_update: make(&integrate_layout, &integrate, "euler_update"),
            semi_implicit_update: make(&integrate_layout, &integrate, "semi_implicit_update"),
            rk2_stage: make(&integrate_layout, &integrate, "rk2_stage"),
            rk2_final: make(&integrate_layout, &integrate, "rk2_final"),
            rk4_begin: make(&integrate_layout, &integrate, "rk4_begin"),
            rk4_mid: make(&integrate_layout, &integrate, "rk4_mid"),
            rk4_final: make(&integrate_layout, &integrate, "rk4_final"),
            verlet_drift: make(&integrate_layout, &integrate, "verlet_drift"),
            verlet_kick: make(&integrate_layout, &integrate, "verlet_kick"),
            project_contacts: make(&collide_layout, &collide, "project_contacts"),
            compute_strain: make(&reduce_layout, &reduce, "compute_strain"),
            compute_energies: make(&reduce_layout, &reduce, "compute_energies"),
            implicit: solve.map(|solve| {
                let solve_layout =
                    pipeline_layout("solve", &[Some(&l.solve), None, Some(&l.stage)]);
                ImplicitPipelines {
                    implicit_begin: make(&integrate_layout, &integrate, "implicit_begin"),
                    implicit_iterate: make(&integrate_layout, &integrate, "implicit_iterate"),
                    implicit_final: make(&integrate_layout, &integrate, "implicit_final"),
                    solver_begin: make(&solve_layout, &solve, "solver_begin"),
                    implicit_rhs: make(&solve_layout, &solve, "implicit_rhs"),
                    cg_begin: make(&solve_layout, &solve, "cg_begin"),
                    apply_system: make(&solve_layout, &solve, "apply_system"),
                    cg_alpha: make(&solve_layout, &solve, "cg_alpha"),
                    cg_update: make(&solve_layout, &solve, "cg_update"),
                    cg_beta: make(&solve_layout, &solve, "cg_beta"),
                    cg_direction: make(&solve_layout, &solve, "cg_direction"),
                    newton_update: make(&solve_layout, &solve, "newton_update"),
                    newton_end: make(&solve_layout, &solve, "newton_end"),
                }
            }),
            springs: springs.map(|springs| {
                let layout = pipeline_layout("springs", &[Some(&l.springs), None, Some(&l.stage)]);
                SpringPipelines {
                    update_springs: make(&layout, &springs, "update_springs"),
                    sum_spring_work: make(&layout, &springs, "sum_spring_work"),
                }
            }),
            mass_contact: mass_contact_modules.map(|(grid, pairs)| {
                let with_x = pipeline_layout(
                    "grid",
                    &[Some(&l.grid), Some(&l.forces_state), Some(&l.stage)],
                );
                let table = pipeline_layout("grid table", &[Some(&l.grid), None, Some(&l.stage)]);
                let pairs_layout = pipeline_layout(
                    "collide masses",
                    &[
                        Some(&l.collide_masses),
                        Some(&l.forces_state),
                        Some(&l.stage),
                    ],
                );
                MassContactPipelines {
                    grid_count: make(&with_x, &grid, "grid_count"),
                    grid_scan_blocks: make(&table, &grid, "grid_scan_blocks"),
                    grid_scan_sums: make(&table, &grid, "grid_scan_sums"),
                    grid_scan_add: make(&table, &grid, "grid_scan_add"),
                    grid_scatter: make(&table, &grid, "grid_scatter"),
                    grid_sort_cells: make(&table, &grid, "grid_sort_cells"),
                    collide_masses: make(&pairs_layout, &pairs, "collide_masses"),
                    mass_contact_energy: make(&pairs_layout, &pairs, "mass_contact_energy"),
                }
            }),
        }
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
