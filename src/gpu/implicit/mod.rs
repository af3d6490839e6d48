//! Implicit Euler on the GPU: `plan.rs` (which path a step takes, its dispatches, the one
//! workgroup's threads and where it keeps the solver's vectors) and `solve.rs` (the host's side of
//! the Newton/CG solve: budgets, replays, the frame's solve record).

mod plan;
mod solve;

pub use super::kernels::Path;
pub use plan::{
    BEGIN, CG_ITERATION, END, IN_GROUP, NEWTON_BEGIN, NEWTON_END, SolverHome, group_threads,
    passes, path, solver_groups, solver_threads,
};
pub use solve::{Budgets, ImplicitStep};
