//! The CPU reference backend: f32 like the GPU, multi-threaded with rayon, deterministic (every
//! mass is written by one task and every sum is taken over fixed chunks in a fixed order).

// Each module is named for the WGSL file its kernels' twins are in (`src/cpu/grid.rs` and
// `shaders/grid.wgsl`); `gpu::kernels` names the twin of every GPU kernel, and checks that it
// exists, so the modules are visible to the crate.
mod aggregates;
mod backend;
pub(crate) mod backward;
pub(crate) mod cg;
pub(crate) mod chunks;
pub(crate) mod collide;
pub(crate) mod collide_masses;
pub(crate) mod forces;
pub(crate) mod fused;
mod fused_chunk;
pub(crate) mod grid;
pub(crate) mod implicit;
mod implicit_work;
pub(crate) mod integrate;
mod lanes;
pub(crate) mod law;
pub(crate) mod multigrid;
mod multigrid_sweeps;
pub(crate) mod neighbours;
mod newton_rules;
pub(crate) mod reduce;
mod solver_sums;
pub(crate) mod springs;
mod stencil;
pub(crate) mod system_blocks;
pub(crate) mod vbd;
pub(crate) mod xpbd;

pub use backend::CpuBackend;
pub use chunks::PARALLEL_MIN_MASSES;
pub use collide::{Projected, project_contacts};
pub use collide_masses::{collide_masses, mass_contact_energy, pair_contact};
pub use forces::{Gather, compute_external_forces, compute_forces};
pub use fused::{FusedStep, Simd};
pub use grid::{MassGrid, grid_cell, grid_hash};
pub use implicit_work::SolveStats;
pub use law::{Real, contact_force, spring_force};
pub use neighbours::Neighbours;
pub use reduce::{compute_energies, compute_strain};
pub use springs::update_springs;
pub use xpbd::XpbdWork;
