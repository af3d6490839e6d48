// Structs and helpers shared by every kernel. Keep the structs in sync with src/gpu/layout.rs (a test
// checks sizes).
// Each program is this file followed by one kernel file (src/gpu/shaders.rs compiles them).

// Effects present in the scene: absent ones are specialised away at pipeline creation.
override HAS_GRAVITY: bool = false;
override HAS_DRAG: bool = false;
override HAS_GROUND: bool = false;
// Collider shapes present (a scene with only spheres compiles no box or plane code).
override HAS_SPHERES: bool = false;
override HAS_BOXES: bool = false;
override HAS_PLANES: bool = false;
// Any of the three.
override HAS_COLLIDERS: bool = false;
override HAS_DAMPING: bool = false;
// Springs that change during a run: the post-step update_springs pass (shaders/springs.wgsl).
override HAS_PLASTICITY: bool = false;
override HAS_TEARING: bool = false;
// Implicit Euler: compute_forces also linearises the contacts, and the solver's stopping rules
// (set from src/physics/solver.rs, so both backends stop alike).
override IMPLICIT: bool = false;
// BDF2: each step blends its start from the last (implicit_blend_at).
override HISTORY: bool = false;
override NEWTON_WORK_SHARE: f32 = 1e-2;
override CG_MAX_ITERATIONS: u32 = 200u;
override NEWTON_TOLERANCE: f32 = 1e-4;
override NEWTON_MAX_ITERATIONS: u32 = 10u;
override NEWTON_RESIDUAL: f32 = 3e-2;
override NEWTON_FLOOR: f32 = 1e-2;
// The movable masses' weights' 2-norm in newtons (src/physics/solver.rs's weight_norm_n).
override WEIGHT_N: f32 = 0.0;
override NEWTON_STALL: f32 = 0.5;
override NEWTON_BACKTRACKS: u32 = 2u;
override NEWTON_OVERSHOOT: f32 = 1.1;
override CG_FORCING: f32 = 0.1;
// A step BDF2 restarts with implicit Euler solves to this share (src/physics/solver.rs).
override CG_FORCING_AT_RESTART: f32 = 1e-3;
// BDF2 restarts where its blend rule would move a mass back by more than this share of its
// shortest spring (src/physics/solver.rs).
override RESTART_PRESS_SHARE: f32 = 0.5;
// How many times its allowed depth a mass may sink in a step before its projection counts as
// deep (src/laws/contact_law.rs's DEEP_SHARE).
override DEEP_SHARE: f32 = 2.0;
// VBD's sweeps count as having solved a step below this residual (src/physics/solver.rs).
override VBD_RESIDUAL: f32 = 0.5;
// The damping of the multigrid cycle's block-Jacobi sweeps (src/physics/hierarchy.rs's SMOOTHING).
override MG_SMOOTHING: f32 = 0.6666667;
// Threads of implicit_step's one workgroup (src/gpu/implicit/plan.rs's group_threads), the
// threads of its sums' first level (sum_level there) and the slots of implicit.wgsl's sum_sh
// (the most threads any of its kernels has).
override GROUP_THREADS: u32 = 64u;
override SUM_LEVEL: u32 = 8u;
override SUM_SLOTS: u32 = 64u;
// Threads of each workgroup of implicit Euler's per-pass kernels (src/gpu/implicit/plan.rs's
// solver_threads): 64 on a GPU, physics::SUM_LANES on a CPU adapter, whose sums the CPU takes so.
override SOLVER_THREADS: u32 = 64u;
// Where the one-workgroup step keeps the solver's vectors and spring terms (implicit_terms.wgsl,
// src/gpu/implicit/plan.rs's SolverHome), and the workgroup arrays' lengths in vec4s (1 when unused).
override SOLVER_IN_WORKGROUP: bool = false;
override WORKGROUP_VECTORS: u32 = 1u;
override WORKGROUP_TERMS: u32 = 1u;
// Whether fused_frame keeps the state of its submission's steps in workgroup memory (mass_force's
// x_at, v_at; src/gpu/dispatch.rs's FrameState::masses_in_workgroup), its masses and the array's length
// in words (1 when unused).
override STATE_IN_WORKGROUP: bool = false;
override WORKGROUP_MASSES: u32 = 1u;
override WORKGROUP_STATE_WORDS: u32 = 1u;
// XPBD: compute_forces leaves the springs out (they are projected as constraints, xpbd.wgsl) but
// for their dashpots' power, which the ledger books.
override XPBD: bool = false;

// Implicit Euler with contacts: compute_forces writes their linearisation after the derivatives
// (deriv[2n + 2i], deriv[2n + 2i + 1]) and the solve adds it to its system (as deriv_bytes in
// src/gpu/limits.rs sizes it).
fn has_contact_terms() -> bool {
    return IMPLICIT && (HAS_GROUND || HAS_COLLIDERS);
}
// The fused steps (fused.wgsl): Euler's update or semi-implicit Euler's, and where a compact
// link's spring kind starts (the bits below are the other mass's index).
override SEMI_IMPLICIT: bool = false;
override KIND_SHIFT: u32 = 31u;
// Threads of fused_frame's one workgroup (src/gpu/dispatch.rs's frame_threads), and of
// vbd_sweeps' (vbd_threads there); the threads VBD shares a mass's springs among (vbd_lanes).
override FRAME_THREADS: u32 = 64u;
override VBD_THREADS: u32 = 64u;
override VBD_LANES: u32 = 1u;
// How far apart the stage slots lie, in words (src/gpu/stages.rs's StageSlots::stride_for):
// fused_frame reads every step's slot from them.
override STAGE_STRIDE_WORDS: u32 = 8u;
// Stage slots per step: t, t + h/2 (twice), t + h (src/gpu/dispatch.rs).
const SLOTS_PER_STEP: u32 = 4u;
// Grid bodies whose fused steps take their springs from a stencil (src/gpu/stencils.rs).
override HAS_STENCILS: bool = false;
// Mass–mass contact: the share of a pair's sliding its friction may stop in one step (set from
// src/physics/mass_contact.rs).
override PAIR_STICK_SHARE: f32 = 0.25;
// The squared distance within which a pair's contact may act, before the touch where it closes
// fast (src/physics/mass_contact.rs's pair_onset_sq_m2, of the scene's radius).
override PAIR_ONSET_SQ: f32 = 0.0;

const WORKGROUP: u32 = 64u;
// Hash-grid buckets per block of the prefix sum (grid.wgsl): four per invocation.
const SCAN_BLOCK: u32 = 4u * WORKGROUP;
// A spring shorter than this has no direction and exerts nothing (as src/cpu/law.rs).
const MIN_SPRING_LENGTH: f32 = 1.1754944e-32;

struct Params {
    mass_count: u32,
    spring_count: u32,
    collider_count: u32,
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

// Colliders per scene (MAX_COLLIDERS in src/scene/validate.rs).
const MAX_COLLIDERS: u32 = 16u;

// A collider's position and velocity at a stage's time (w unused).
struct Pose {
    position: vec4<f32>,
    velocity: vec4<f32>,
}

// One per dispatch that needs it, selected by a dynamic uniform offset. The host fills in every
// collider's pose at the stage's time (its scripted path, evaluated as the CPU does).
struct Stage {
    time: f32,
    dt: f32,
    // RK4: weight of this stage's derivative, and the step fraction of the next stage point.
    weight: f32,
    next_scale: f32,
    // Index of this step within its submission (the divergence check reports the first bad one).
    step: u32,
    // The submission's steps from this one on (fused_frame.wgsl runs them all in one dispatch).
    steps: u32,
    // The whole step, where dt is a backward scheme's solve's (the ledger's quadrature), and the
    // blend of the step's start (src/physics/solver.rs's BackwardStep).
    whole_dt: f32,
    history: f32,
    poses: array<Pose, MAX_COLLIDERS>,
}

struct Spring {
    a: u32,
    b: u32,
    rest: f32,
    stiffness: f32,
    damping: f32,
}

// XPBD: a spring's constants for the substep length h (XpbdSpring in src/cpu/xpbd.rs). And the
// colour a dispatch of xpbd_solve_spring or vbd_solve_mass solves (ColourRange in
// src/gpu/layout.rs).
struct XpbdSpring {
    alpha_tilde: f32,
    gamma: f32,
}

// The multigrid cycle's coarse level (multigrid.wgsl), 1 the first (src/gpu/layout.rs's MgLevel).
struct MgLevel {
    level: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct ColourRange {
    // The colour's springs (XPBD) or masses (VBD) are colour_order[start .. start + count].
    start: u32,
    count: u32,
    // 1 on a substep's first sweep: the multipliers start from zero.
    first: u32,
    _pad: u32,
}

// A broken spring has neither stiffness nor damping (as Spring::is_broken in src/model/springs.rs).
fn is_broken(s: Spring) -> bool {
    return s.stiffness == 0.0 && s.damping == 0.0;
}

// compute_strain's value for a broken spring (the host reads it as NaN: no strain).
const BROKEN_STRAIN: f32 = -3.4028235e38;
// The largest finite f32.
const F32_MAX: f32 = 3.4028235e38;

// Per spring, when some body has plasticity or tearing (as SpringLimits in src/model/springs.rs).
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

// The fused steps' spring kinds: each distinct (stiffness, damping) of a run's springs, as
// (stiffness, damping, 0, 0) (SpringKinds in src/gpu/layout.rs).
const MAX_SPRING_KINDS: u32 = 256u;
struct SpringKinds {
    kind: array<vec4<f32>, MAX_SPRING_KINDS>,
}

// The fused steps' grid stencils (StencilTable in src/gpu/layout.rs, built by
// src/gpu/stencils.rs): a grid body's masses take their springs from its slots, in the order of
// their CSR entries, instead of reading links.
const MAX_STENCIL_BODIES: u32 = 8u;
const MAX_STENCIL_SLOTS: u32 = 256u;
struct StencilBody {
    first_mass: u32,
    mass_end: u32,
    slot_start: u32,
    slot_end: u32,
    dims: vec4<u32>,
}
struct StencilSlot {
    // Cells to the other end (x, y, z) and the difference of the two masses' indices (w).
    step: vec4<i32>,
    rest: f32,
    stiffness: f32,
    damping: f32,
    _pad: f32,
}
struct StencilTable {
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    bodies: array<StencilBody, MAX_STENCIL_BODIES>,
    slots: array<StencilSlot, MAX_STENCIL_SLOTS>,
}

// What mass_force reads of mass i's spring e (spring_range(i) gives its e): the mass at its
// other end and its constants, from whichever layout the program binds (spring_records.wgsl or
// fused_mass.wgsl); NO_SPRING where a stencil's slot falls off the grid.
struct SpringEnd {
    other: u32,
    rest: f32,
    stiffness: f32,
    damping: f32,
}
const NO_SPRING: u32 = 0xFFFFFFFFu;

const SPHERE: u32 = 0u;
const BOX: u32 = 1u;
const PLANE: u32 = 2u;

// A collider's shape and contact; its pose is in the stage.
struct Collider {
    kind: u32,
    stiffness: f32,
    friction: f32,
    damping_ratio: f32,
    // Sphere: (radius, 0, 0); box: half extents; plane: unit normal.
    shape: vec4<f32>,
    max_depth: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

// Signed depth of x in collider c placed at `center` (negative outside) and the outward normal
// of the surface point nearest x, as (normal, depth); zero where there is no normal (a sphere's
// centre). Mirrors Shape::signed_depth in src/model/colliders.rs, operation for operation.
fn signed_depth(c: Collider, center: vec3<f32>, x: vec3<f32>) -> vec4<f32> {
    let r = x - center;
    if (HAS_SPHERES && c.kind == SPHERE) {
        let dist = length(r);
        if (dist > 0.0) {
            return vec4<f32>(r / dist, c.shape.x - dist);
        }
    } else if (HAS_BOXES && c.kind == BOX) {
        let q = abs(r) - c.shape.xyz;
        if (q.x > 0.0 || q.y > 0.0 || q.z > 0.0) {
            // Outside: the nearest surface point is on a face, an edge or a corner.
            let out = max(q, vec3<f32>(0.0));
            let away = select(out, -out, r < vec3<f32>(0.0));
            let dist = length(away);
            return vec4<f32>(away / dist, -dist);
        }
        var axis = vec3<f32>(0.0, 0.0, 1.0);
        var gap = q.z;
        if (q.x >= q.y && q.x >= q.z) {
            axis = vec3<f32>(1.0, 0.0, 0.0);
            gap = q.x;
        } else if (q.y >= q.z) {
            axis = vec3<f32>(0.0, 1.0, 0.0);
            gap = q.y;
        }
        var side = 1.0;
        if (dot(r, axis) < 0.0) {
            side = -1.0;
        }
        return vec4<f32>(axis * side, -gap);
    } else if (HAS_PLANES && c.kind == PLANE) {
        return vec4<f32>(c.shape.xyz, -dot(r, c.shape.xyz));
    }
    return vec4<f32>(0.0);
}

// Depth of x inside collider c and the outward normal, as (normal, depth), where signed_depth is
// positive; zero outside (Shape::penetration).
fn penetration(c: Collider, center: vec3<f32>, x: vec3<f32>) -> vec4<f32> {
    let s = signed_depth(c, center, x);
    if (s.w > 0.0) {
        return s;
    }
    return vec4<f32>(0.0);
}

// Mass–mass contact and its hash grid (grid.wgsl, collide_masses.wgsl).
struct MassContact {
    radius: f32,
    // 1 / cell size; cells are one reach (2 · radius + skin) wide.
    inv_cell: f32,
    // Buckets − 1 (a power of two), and buckets / SCAN_BLOCK.
    table_mask: u32,
    block_count: u32,
    stiffness: f32,
    friction: f32,
    // With the pair's reduced mass.
    damping_ratio: f32,
    // 1: masses of one body collide with each other too; 0: only masses of different bodies.
    within_bodies: u32,
    // The neighbour lists' reach (2 r + skin) squared, and the squared displacement since the
    // last build past which they are stale.
    reach_sq: f32,
    moved_sq: f32,
    // Slots of a mass's list, and the words before the first mass's record.
    list_slots: u32,
    list_head: u32,
}

// The cell holding p: as src/cpu/grid.rs (multiply by the inverse cell size, floor, convert).
fn grid_cell(p: vec3<f32>, inv_cell: f32) -> vec3<i32> {
    return vec3<i32>(floor(p * inv_cell));
}

// The bucket of cell c: large odd multipliers mix the coordinates (wrapping, as on the CPU).
fn grid_hash(c: vec3<i32>, mask: u32) -> u32 {
    return ((bitcast<u32>(c.x) * 73856093u) ^ (bitcast<u32>(c.y) * 19349663u) ^ (bitcast<u32>(c.z) * 83492791u)) & mask;
}

struct Contact {
    force: vec3<f32>,
    dissipated: f32,
}

// The normal force of a Kelvin–Voigt contact at signed depth `depth` for normal velocity vn:
// k·depth − c·vn while that pushes, zero otherwise (src/cpu/law.rs's contact_normal_force). The
// contact is on while its force pushes, so that the force has no jump at the touch.
fn contact_normal_force(stiffness: f32, damping_ratio: f32, depth: f32, vn: f32, m: f32) -> f32 {
    let damper = -2.0 * damping_ratio * sqrt(stiffness * m) * vn;
    return max(stiffness * depth + damper, 0.0);
}

// Whether a contact acts: it pushes, or the mass is inside (law.rs's contact_acts).
fn contact_acts(normal_force: f32, depth: f32) -> bool {
    return normal_force > 0.0 || depth > 0.0;
}

// Penalty contact along unit normal n at signed depth `depth` (src/cpu/law.rs): force and the
// power its damping and friction take out. Friction opposes the tangential velocity the step would
// end with under `load` (the mass's other forces) alone, stopping at most stick_share of it in a
// step, so that sticking holds against a load instead of creeping.
fn contact_force(stiffness: f32, friction: f32, damping_ratio: f32, depth: f32, n: vec3<f32>, v_rel: vec3<f32>, load: vec3<f32>, m: f32, dt: f32, stick_share: f32) -> Contact {
    let vn = dot(v_rel, n);
    let fn_total = contact_normal_force(stiffness, damping_ratio, depth, vn, m);
    // The spring holds energy only inside; the rest of the force is the damper's.
    let spring = stiffness * max(depth, 0.0);
    let damper_part = fn_total - spring;
    var out = Contact(n * fn_total, -damper_part * vn);
    if (friction > 0.0) {
        let vt = v_rel - vn * n;
        let load_t = load - n * dot(load, n);
        let wt = vt + load_t * (dt / m);
        let trial = length(wt);
        if (trial > 0.0) {
            let ft = min(friction * fn_total, stick_share * m * trial / dt);
            let scale = ft / trial;
            out.force -= wt * scale;
            out.dissipated += scale * dot(wt, vt);
        }
    }
    return out;
}

// Implicit Euler's per-mass vectors, each a block of mass_count vec4s in the per-mass scratch
// buffer (RK4's stage sums otherwise): Δv so far, the CG update δ, residual, preconditioned
// residual, search direction, A·p, and the inverted diagonal block (xx, yy, zz, xy; xz, yz).
const DV_TOTAL: u32 = 0u;
const DV: u32 = 1u;
const RESIDUAL: u32 = 2u;
const PRECONDITIONED: u32 = 3u;
const DIRECTION: u32 = 4u;
const PRODUCT: u32 = 5u;
const DIAGONAL: u32 = 6u;
const DIAGONAL_OFF: u32 = 7u;
const SOLVER_VECTORS: u32 = 8u;
// After the solver's vectors in the work buffer (never in workgroup memory: written once a
// Newton iteration, read once a step): Δv and the ledger rates at the iterate with the least
// residual Newton solved from, where a step short of its rule ends (implicit_final_at);
const BEST_DV: u32 = 8u;
const BEST_RATES: u32 = 9u;
// then BDF2's last step start, which outlives the step.
const HISTORY_X: u32 = 10u;
const HISTORY_V: u32 = 11u;

fn block(k: u32, i: u32) -> u32 {
    return k * params.mass_count + i;
}

// Linear thread index over a 2D grid of workgroups (large scenes exceed 65535 groups in x).
fn thread_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * WORKGROUP;
}
