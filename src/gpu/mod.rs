//! The wgpu compute backend: the same physics as the CPU backend, each kernel named as the CPU
//! function computing the same thing (the table in `kernels.rs` says which, and why some have
//! none). The modules, lowest first:
//!
//! - `context`: the adapter and device, and what their errors mean; `limits`: whether a scene
//!   fits the adapter; `loop_budget`: how long the driver lets an invocation loop.
//! - `programs` and `shaders`: the WGSL programs and their override constants; `kernel_table`
//!   and `kernels`: the kernel table; `bindings`: every bind group, declared once; `layout`: the
//!   host copies of the WGSL structs.
//! - `pipelines`: bind group layouts and pipelines; `buffers`: the model's and state's buffers;
//!   `resources` and `group_set`: those and the effects' buffers, bound; `colours`, `xpbd` and
//!   `vbd`: the colour sweeps' groups; `stages`: the stage slots and the run's clock.
//! - `links` and `stencils`: the fused steps' compact springs and grid stencils.
//! - `dispatch`: what a dispatch is; `sizing`: how many threads and workgroups each takes, and
//!   which run in one workgroup; `plan` and `fused_plan`: the
//!   dispatch sequences of a step, fused or a pass per stage; `tuning`: the paths a run takes;
//!   `encode`: recording dispatches in submissions.
//! - `implicit`: implicit Euler's solve; `multigrid`: its CG's multigrid cycle on large systems;
//!   `readback`: what a snapshot reads back.
//! - `backend`: `GpuBackend`; `steps` records its steps (an `advance`), `snapshots` its
//!   read-backs, `profile` and `inspect` add to it (bench timings, test hooks).
//! - `passes` and `verdicts`: what `hooke check` shows of a step, and why a run does not take a
//!   path, as values.

mod backend;
#[doc(hidden)]
pub mod bindings;
mod buffers;
mod colours;
mod context;
mod dispatch;
mod encode;
mod fused_plan;
mod group_set;
mod implicit;
mod inspect;
pub(crate) mod kernel_table;
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
mod sizing;
mod snapshots;
mod stages;
mod stencils;
mod steps;
mod tuning;
mod vbd;
mod verdicts;
mod xpbd;

pub use backend::GpuBackend;
pub use context::{
    AdapterError, DeviceError, Fault, GpuContext, REQUIRE_ADAPTER_ENV, ReadBackCause, ReadBackOf,
    adapters, describe_error,
};
pub use fused_plan::{ExplicitPath, explicit_path};
pub use implicit::Budgets as ImplicitBudgets;
pub use implicit::{Path as ImplicitPath, SolverHome};
pub use inspect::GridReadBack;
pub use layout::NEIGHBOUR_SLOTS;
pub use limits::adapter_report;
pub use limits::{FUSED_STORAGE_BUFFERS_NEEDED, MULTIGRID_FACTOR_WORKGROUP_BYTES};
pub use loop_budget::{LOOP_BUDGET_WGSL, LoopBudget, PROBE_ITERATIONS};
pub use passes::{
    InGroup, StencilCover, StepReport, SweepReport, adapter_step_passes, step_report,
};
pub use plan::ONE_GROUP_BUILD_MASSES;
pub use plan::{DispatchCount, StepPaths, dispatches_per_step};
pub use shaders::{missing, program_groups, programs, unmet};
pub use sizing::{
    FRAME_STATE_BYTES_PER_MASS, FrameState, implicit_path, one_group_step_masses,
    sweeps_in_one_group, vbd_lanes, vbd_one_group_masses, why_not_in_group,
};
pub use stencils::stencil_cover;
pub use tuning::{KernelFamily, Tuning};
pub use verdicts::{BlockJacobiInstead, MultigridUnbound, NotInGroup, Unfused};
