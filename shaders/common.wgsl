// Structs shared by every kernel. Keep in sync with src/gpu/layout.rs (a test checks sizes).
// Each kernel module is this file followed by one of forces/integrate/collide/reduce.wgsl.

// Effects present in the scene: absent ones are specialised away at pipeline creation.
override HAS_GRAVITY: bool = false;
override HAS_DRAG: bool = false;
override HAS_GROUND: bool = false;
override HAS_SPHERES: bool = false;
override HAS_DAMPING: bool = false;
// Springs that change during a run: the post-step update_springs pass (shaders/springs.wgsl).
override HAS_PLASTICITY: bool = false;
override HAS_TEARING: bool = false;
// Implicit Euler: compute_forces also linearises the contacts, and the solver's stopping rules
// (set from src/cpu/implicit.rs, so both backends stop alike).
override IMPLICIT: bool = false;
override CG_TOLERANCE: f32 = 1e-4;
override CG_MAX_ITERATIONS: u32 = 200u;
override NEWTON_TOLERANCE: f32 = 1e-4;

const WORKGROUP: u32 = 64u;
// A spring shorter than this has no direction and exerts nothing (as src/cpu/forces.rs).
const MIN_SPRING_LENGTH: f32 = 1.1754944e-32;

struct Params {
    mass_count: u32,
    spring_count: u32,
    sphere_count: u32,
    runaway_speed: f32,
    gravity: vec3<f32>,
    drag_per_s: f32,
    ground_height: f32,
    ground_stiffness: f32,
    ground_friction: f32,
    ground_damping_ratio: f32,
    ground_max_depth: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// One per dispatch that needs it, selected by a dynamic uniform offset.
struct Stage {
    time: f32,
    dt: f32,
    // RK4: weight of this stage's derivative, and the step fraction of the next stage point.
    weight: f32,
    next_scale: f32,
    // Index of this step within its submission (the divergence check reports the first bad one).
    step: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Spring {
    a: u32,
    b: u32,
    rest: f32,
    stiffness: f32,
    damping: f32,
}

// A broken spring has neither stiffness nor damping (as Spring::is_broken in src/model.rs).
fn is_broken(s: Spring) -> bool {
    return s.stiffness == 0.0 && s.damping == 0.0;
}

// compute_strain's value for a broken spring (the host reads it as NaN: no strain).
const BROKEN_STRAIN: f32 = -3.4028235e38;

// Per spring, when some body has plasticity or tearing (as SpringLimits in src/model.rs).
struct SpringLimits {
    yield_strain: f32,
    relax: f32,
    break_strain: f32,
    creep_per_s: f32,
}

struct Neighbor {
    spring: u32,
    other: u32,
}

struct Sphere {
    center: vec3<f32>,
    radius: f32,
    velocity: vec3<f32>,
    stiffness: f32,
    friction: f32,
    damping_ratio: f32,
    max_depth: f32,
    _pad: f32,
}

// Implicit Euler's per-mass vectors, each a block of mass_count vec4s in the per-mass scratch
// buffer (RK4's stage sums otherwise): Δv so far, the CG update δ, residual, preconditioned
// residual, search direction, A·p, and the system's diagonal.
const DV_TOTAL: u32 = 0u;
const DV: u32 = 1u;
const RESIDUAL: u32 = 2u;
const PRECONDITIONED: u32 = 3u;
const DIRECTION: u32 = 4u;
const PRODUCT: u32 = 5u;
const DIAGONAL: u32 = 6u;
const SOLVER_VECTORS: u32 = 7u;

fn block(k: u32, i: u32) -> u32 {
    return k * params.mass_count + i;
}

// Linear thread index over a 2D grid of workgroups (large scenes exceed 65535 groups in x).
fn thread_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * WORKGROUP;
}
