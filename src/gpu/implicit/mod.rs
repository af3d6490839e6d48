//! Implicit Euler on the GPU: `plan.rs` (a step's dispatches, and where the one workgroup keeps
//! the solver's vectors; its path and threads are `sizing.rs`'s) and `solve.rs` (the host's side of
//! the Newton/CG solve: budgets, replays, the frame's solve record).

mod plan;
mod solve;

pub use super::kernels::Path;
pub use plan::{CG_ITERATION, END, IN_GROUP, NEWTON_BEGIN, NEWTON_END, SolverHome, begin, passes};
pub use solve::{Budgets, ImplicitStep};
