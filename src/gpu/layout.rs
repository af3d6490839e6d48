//! Host-side copies of the structs in `shaders/common.wgsl`. Same field order, sizes and padding;
//! `tests/shaders.rs` checks each against naga's layout of the WGSL.

use bytemuck::{Pod, Zeroable};

pub use crate::model::{Neighbor, Spring, SpringLimits};

/// Scene-wide constants (`Params` in WGSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct Params {
    pub mass_count: u32,
    pub spring_count: u32,
    pub collider_count: u32,
    pub runaway_speed: f32,
    pub gravity: [f32; 3],
    pub drag_per_s: f32,
    pub ground_height: f32,
    pub ground_stiffness: f32,
    pub ground_friction: f32,
    pub ground_damping_ratio: f32,
    pub ground_max_depth: f32,
    pub _pad: [f32; 3],
}

/// Colliders' poses a stage slot holds (`MAX_COLLIDERS` in WGSL).
pub const MAX_COLLIDERS: usize = crate::scene::MAX_COLLIDERS;

/// Per-dispatch values (`Stage` in WGSL), one slot per stage of each substep: the stage's time,
/// and every collider's pose at that time, computed on the host as the CPU backend computes it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct Stage {
    pub time: f32,
    pub dt: f32,
    pub weight: f32,
    pub next_scale: f32,
    pub step: u32,
    /// The submission's steps from this one on (`fused_frame.wgsl` runs them in one dispatch).
    pub steps: u32,
    /// The whole step, where `dt` is a backward scheme's solve's (the ledger's quadrature).
    pub whole_dt: f32,
    /// A backward scheme's blend of the step's start (`physics::BackwardStep::history`).
    pub history: f32,
    pub poses: [Pose; MAX_COLLIDERS],
}

/// A collider's position and velocity (`Pose` in WGSL; w unused).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct Pose {
    pub position: [f32; 4],
    pub velocity: [f32; 4],
}

/// `Collider::kind` values (`SPHERE`, `BOX`, `PLANE` in WGSL).
pub const SPHERE: u32 = 0;
pub const BOX: u32 = 1;
pub const PLANE: u32 = 2;

/// A collider's shape and contact (`Collider` in WGSL); its pose is in the stage slot.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct Collider {
    pub kind: u32,
    pub stiffness: f32,
    pub friction: f32,
    pub damping_ratio: f32,
    /// Sphere: (radius, 0, 0); box: half extents; plane: unit normal.
    pub shape: [f32; 4],
    pub max_depth: f32,
    pub _pad: [f32; 3],
}

/// Mass–mass contact, its neighbour lists and their hash grid (`MassContact` in WGSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct MassContact {
    pub radius: f32,
    pub inv_cell: f32,
    pub table_mask: u32,
    pub block_count: u32,
    pub stiffness: f32,
    pub friction: f32,
    pub damping_ratio: f32,
    pub within_bodies: u32,
    pub reach_sq: f32,
    pub moved_sq: f32,
    pub list_slots: u32,
    pub list_head: u32,
}

/// Slots of a mass's neighbour list on the GPU. A mass with more masses in reach walks the grid
/// instead, which yields the same pairs in the same order, only slower. With a skin of one
/// radius a sheet's mass has 4–12 in reach and a mass packed among spheres of its size at
/// most about 47: 28 holds the first case with room and leaves dense piles to the walk.
pub const NEIGHBOUR_SLOTS: u32 = 28;

/// Words of the neighbour buffer before the first mass's record: the stale flag, the count of
/// builds, two unused.
pub const NEIGHBOUR_HEAD: u32 = 4;

/// Bytes of the neighbour buffer for `mass_count` masses: the head, then per mass its list's
/// length, its position at the build and the slots.
pub fn neighbour_bytes(mass_count: u64) -> u64 {
    4 * (u64::from(NEIGHBOUR_HEAD) + mass_count * u64::from(4 + NEIGHBOUR_SLOTS))
}

/// Implicit Euler's solver state on the per-pass path (`Solver` in shaders/implicit.wgsl); the
/// solver's scratch holds two, the status `cg_apply` reads and the one it writes.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct SolverStatus {
    pub rz: f32,
    pub beta: f32,
    /// The momentum change the last iterate evaluated is judged against (`newton_scale`).
    pub scale: f32,
    pub residual: f32,
    pub max_residual: f32,
    pub iterations: u32,
    pub total_iterations: u32,
    pub cg_active: u32,
    pub newton: u32,
    pub newton_pending: u32,
    pub converged: u32,
    /// `best` relative to its own `scale`: what a step that ends there is booked with.
    pub best_share: f32,
    /// |h f − M Δv| at the last iterate solved from: the |b| of the current solve's start.
    pub last_residual: f32,
    /// Halvings of the last Newton update so far (`physics::NEWTON_BACKTRACKS`).
    pub halvings: u32,
    /// |h f − M Δv| at the last iterate evaluated (solved from, or halved).
    pub evaluated: f32,
    /// The least |h f − M Δv| of the iterates solved from after the first, where a step whose
    /// Newton iterations run out wandering ends (`BEST_DV` in WGSL keeps its Δv). With it the
    /// status is 64 bytes, so that the partials after two statuses and a `FrameSolve` start
    /// 16-aligned.
    pub best: f32,
}

/// Room in [`FrameSolve::cg_most`]: one per Newton iteration a step may take.
pub const MAX_NEWTON_SLOTS: usize = 16;
const _: () = assert!(crate::physics::NEWTON_MAX_ITERATIONS as usize <= MAX_NEWTON_SLOTS);

/// What implicit Euler's per-pass kernels learn of a frame (`FrameSolve` in
/// shaders/implicit.wgsl), after the two statuses in the solver's scratch: the host writes the
/// Newton budget and zeros before a frame and reads the rest back once after it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct FrameSolve {
    /// The Newton iterations the frame's encoding gives each step.
    pub newton_budget: u32,
    /// [`FrameSolve::NEWTON_OVERRAN`], and bit j for a solve of Newton iteration j still running
    /// when its CG budget ran out: the frame halted there and must be replayed.
    pub overran: u32,
    /// The most Newton iterations any step began.
    pub newton_most: u32,
    /// 1 while the step under way is a BDF2 step restarted with implicit Euler (the kernels set
    /// it at each step's start; `cpu::backward::blend_presses`).
    pub restart: u32,
    /// The most CG iterations of any solve of Newton iteration j.
    pub cg_most: [u32; MAX_NEWTON_SLOTS],
}

impl FrameSolve {
    /// A step used its whole Newton budget without converging.
    pub const NEWTON_OVERRAN: u32 = 1 << 31;
    /// Where it sits in the solver's scratch: after the two statuses.
    pub const OFFSET: u64 = 2 * std::mem::size_of::<SolverStatus>() as u64;
    pub const SIZE: u64 = std::mem::size_of::<FrameSolve>() as u64;
}

// The solver's per-workgroup partials (vec4s) follow the two statuses and the frame record: WGSL
// starts them at the next multiple of 16, and the host sizes the scratch as if they follow at once.
const _: () = assert!((FrameSolve::OFFSET + FrameSolve::SIZE).is_multiple_of(16));

pub use crate::physics::XpbdSpring;

/// The colour one dispatch of `xpbd_solve_spring` or `vbd_solve_mass` solves (`ColourRange` in
/// WGSL): its springs or masses are `colour_order[start..start + count]`; `first` on a (sub)step's
/// first sweep.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct ColourRange {
    pub start: u32,
    pub count: u32,
    pub first: u32,
    pub _pad: u32,
}

/// Which coarse level a multigrid kernel works on (`MgLevel` in WGSL): one window per level.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct MgLevel {
    pub level: u32,
    pub _pad: [u32; 3],
}

/// Spring kinds the fused steps' table holds (`MAX_SPRING_KINDS` in WGSL).
pub const MAX_SPRING_KINDS: usize = 256;

/// Implicit Euler's per-mass vectors (`SOLVER_VECTORS` in shaders/common.wgsl).
pub const SOLVER_VECTORS: u64 = 8;

/// The fused steps' spring kinds (`SpringKinds` in WGSL): (stiffness, damping, 0, 0) each.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct SpringKinds {
    pub kind: [[f32; 4]; MAX_SPRING_KINDS],
}

impl Default for SpringKinds {
    fn default() -> Self {
        Self::zeroed()
    }
}

/// Grid bodies whose springs the fused steps take from a stencil, and the stencils' slots in all
/// (`StencilTable` in WGSL).
pub const MAX_STENCIL_BODIES: usize = 8;
pub const MAX_STENCIL_SLOTS: usize = 256;

/// A grid body stepped by its stencil (`StencilBody` in WGSL): masses `first_mass..mass_end`,
/// numbered i fastest over `dims`, whose springs are slots `slot_start..slot_end`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct StencilBody {
    pub first_mass: u32,
    pub mass_end: u32,
    pub slot_start: u32,
    pub slot_end: u32,
    pub dims: [u32; 4],
}

/// One spring of a stencil as its mass sees it (`StencilSlot` in WGSL): the other end `step`
/// cells away (x, y, z, and w the difference of their indices) and the spring's constants.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Pod, Zeroable)]
pub struct StencilSlot {
    pub step: [i32; 4],
    pub rest: f32,
    pub stiffness: f32,
    pub damping: f32,
    pub _pad: f32,
}

/// The fused steps' grid stencils (`StencilTable` in WGSL), a uniform.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct StencilTable {
    pub count: u32,
    pub _pad: [u32; 3],
    pub bodies: [StencilBody; MAX_STENCIL_BODIES],
    pub slots: [StencilSlot; MAX_STENCIL_SLOTS],
}

impl Default for StencilTable {
    fn default() -> Self {
        Self::zeroed()
    }
}

/// The WGSL structs and the size of their host copies, for the layout test.
pub const SHARED_STRUCTS: [(&str, usize); 17] = [
    ("MgLevel", std::mem::size_of::<MgLevel>()),
    ("SpringKinds", std::mem::size_of::<SpringKinds>()),
    ("StencilBody", std::mem::size_of::<StencilBody>()),
    ("StencilSlot", std::mem::size_of::<StencilSlot>()),
    ("StencilTable", std::mem::size_of::<StencilTable>()),
    ("XpbdSpring", std::mem::size_of::<XpbdSpring>()),
    ("ColourRange", std::mem::size_of::<ColourRange>()),
    ("SpringLimits", std::mem::size_of::<SpringLimits>()),
    ("MassContact", std::mem::size_of::<MassContact>()),
    ("Solver", std::mem::size_of::<SolverStatus>()),
    ("FrameSolve", std::mem::size_of::<FrameSolve>()),
    ("Params", std::mem::size_of::<Params>()),
    ("Stage", std::mem::size_of::<Stage>()),
    ("Collider", std::mem::size_of::<Collider>()),
    ("Spring", std::mem::size_of::<Spring>()),
    ("Neighbor", std::mem::size_of::<Neighbor>()),
    ("vec4<f32>", 16),
];

/// The counters' bytes (`counters` in the kernels' bindings): projections, the first bad step,
/// then what the implicit steps book (readback.rs's `SolveRecord`: two counts, the CG residual,
/// two more counts and the step residual, residuals as f32 bits), and the deep projections.
pub const COUNTERS_BYTES: u64 = 32;
