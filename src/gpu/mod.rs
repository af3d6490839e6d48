//! The wgpu compute backend: the same physics as the CPU backend, each kernel named as the CPU
//! function computing the same thing (the table in `kernels.rs` says which, and why some have
//! none). The modules, lowest first:
//!
//! - `context`: the adapter and device, and what their errors mean; `limits`: whether a scene
//!   fits the adapter.
//! - `shaders`: the WGSL programs and their override constants; `kernels`: the kernel table;
//!   `layout`: the host copies of the WGSL structs.
//! - `pipelines`: bind group layouts and pipelines; `buffers`: the model's and state's buffers;
//!   `resources`: those and the effects' buffers, bound; `xpbd`: XPBD's colours and multipliers;
//!   `stages`: the stage slots and the run's clock.
//! - `links`: the fused steps' compact springs.
//! - `plan`: the dispatch sequences of a step, fused or a pass per stage; `encode`: recording a
//!   dispatch.
//! - `implicit`: implicit Euler's solve; `multigrid`: its CG's multigrid cycle on large systems;
//!   `readback`: what a snapshot reads back.
//! - `backend`: `GpuBackend`; `steps` records its steps (an `advance`), `profile` and `inspect`
//!   add to it (bench timings, test hooks).

mod backend;
#[doc(hidden)]
pub mod bindings;
mod buffers;
mod colours;
mod context;
mod dispatch;
mod encode;
mod implicit;
mod inspect;
pub mod kernels;
pub mod layout;
mod limits;
mod links;
mod loop_budget;
mod multigrid;
mod passes;
mod pipelines;
mod plan;
mod profile;
pub mod programs;
mod readback;
mod resources;
mod shaders;
mod stages;
mod stencils;
mod steps;
mod tuning;
mod vbd;
mod xpbd;

pub use backend::GpuBackend;
pub use context::{
    AdapterError, DeviceError, Fault, GpuContext, REQUIRE_ADAPTER_ENV, ReadBackCause, ReadBackOf,
    adapters, describe_error,
};
pub use dispatch::{
    FRAME_STATE_BYTES_PER_MASS, FrameState, one_group_step_masses, sweeps_in_one_group, vbd_lanes,
    vbd_one_group_masses, why_not_in_group,
};
pub use implicit::Budgets as ImplicitBudgets;
pub use implicit::{Path as ImplicitPath, SolverHome, path as implicit_path};
pub use inspect::GridReadBack;
pub use layout::NEIGHBOUR_SLOTS;
pub use limits::MULTIGRID_FACTOR_WORKGROUP_BYTES;
pub use limits::adapter_report;
pub use loop_budget::{LOOP_BUDGET_WGSL, LoopBudget, PROBE_ITERATIONS};
pub use passes::{adapter_step_passes, step_passes};
pub use plan::ONE_GROUP_BUILD_MASSES;
pub use plan::{DispatchCount, ExplicitPath, dispatches_per_step, explicit_path};
pub use shaders::{missing, program_groups, programs, unmet};
pub use stencils::stencil_cover;
pub use tuning::{KernelFamily, Tuning};
