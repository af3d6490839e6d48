//! The physics both backends compute from, owned by neither: XPBD's spring colouring and
//! constants, VBD's mass colouring, implicit Euler's stopping rules and its multigrid's coarse
//! levels (`hierarchy`), the hash grid's sizing and the mass–mass contact's constants. `cpu/` and `gpu/` import these; `gpu/` imports nothing from `cpu/`
//! (`tests/layers.rs`). The force laws that have a WGSL twin stay with the CPU backend
//! (`cpu/law.rs`), named as their kernels.

mod colouring;
mod grid;
pub mod hierarchy;
mod mass_contact;
mod solver;
mod xpbd;

pub use colouring::{Colouring, MassColouring, colour_masses, colour_springs, vbd_colouring};
pub use grid::{SCAN_BLOCK, inv_cell_per_m, table_size};
pub use mass_contact::{
    NEIGHBOUR_SKIN_SHARE, PAIR_STICK_SHARE, neighbour_moved_limit_m, neighbour_reach_m,
    pair_onset_sq_m2,
};
pub use solver::{
    BackwardStep, CG_FORCING, CG_FORCING_AT_RESTART, CG_MAX_ITERATIONS, MULTIGRID_MIN_MASSES,
    MULTIGRID_MIN_STIFFNESS, NEWTON_BACKTRACKS, NEWTON_FLOOR, NEWTON_MAX_ITERATIONS,
    NEWTON_OVERSHOOT, NEWTON_RESIDUAL, NEWTON_RESIDUAL_STEP_SECS, NEWTON_STALL, NEWTON_TOLERANCE,
    NEWTON_WORK_SHARE, Preconditioner, RESTART_PRESS_SHARE, SUM_GROUP_MASSES, SUM_GROUPS_MOST,
    SUM_LANES, VBD_RESIDUAL, newton_floor, newton_residual, preconditioner_of,
    stiffness_against_step, sum_groups, weight_norm_n,
};
pub use xpbd::{XpbdSpring, xpbd_constants};
