// Implicit Euler's linear solves: for each Newton iterate (x, v), solve
//   (M − h D − h² K) δ = h f(x, v) − M Δv
// by matrix-free conjugate gradients with a Jacobi preconditioner. Mirrors src/cpu/implicit.rs;
// the state-side kernels (implicit_begin, implicit_iterate, implicit_final) are in
// integrate.wgsl, and compute_forces evaluates f and linearises the contacts at the iterate.
//
// The host encodes a few CG iterations at a time and reads the solver's status between: every
// kernel here does nothing once its solve has stopped, so a chunk longer than needed costs only
// empty dispatches. Dot products are summed per workgroup, then over the workgroups in a fixed
// order by one workgroup, so a run is repeatable.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> springs: array<Spring>;
@group(0) @binding(2) var<storage, read> offsets: array<u32>;
@group(0) @binding(3) var<storage, read> neighbors: array<Neighbor>;
@group(0) @binding(4) var<storage, read> mass: array<vec2<f32>>;
// The Newton iterate's positions.
@group(0) @binding(5) var<storage, read> xt: array<vec4<f32>>;
// From compute_forces at the iterate: [2i] acceleration, [2n + 2i], [2n + 2i + 1] contacts.
@group(0) @binding(6) var<storage, read> deriv: array<vec4<f32>>;
// The solver's per-mass vectors (block() in common.wgsl).
@group(0) @binding(7) var<storage, read_write> work: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> scratch: Scratch;
@group(2) @binding(0) var<uniform> stage: Stage;

// Keep in sync with src/gpu/layout.rs's SolverStatus (the host reads it between chunks).
struct Solver {
    // r·z, and p·Ap of the current iteration.
    rz: f32,
    pap: f32,
    alpha: f32,
    beta: f32,
    // |h f| of the step's first Newton iterate: residuals are relative to it.
    scale: f32,
    // |r| / scale of the current solve.
    residual: f32,
    // Largest final residual over the step's solves.
    max_residual: f32,
    // Newton: the last update's and Δv's largest per-mass length.
    step_norm: f32,
    size_norm: f32,
    // CG iterations of the current solve, and of the whole step.
    iterations: u32,
    total_iterations: u32,
    // 1 while the current solve runs.
    cg_active: u32,
    // Newton iterations done this step; 1 while an iteration's update is still to be applied;
    // 1 once Newton has converged.
    newton: u32,
    newton_pending: u32,
    converged: u32,
    _pad: u32,
}

struct Scratch {
    solver: Solver,
    // One partial sum per workgroup of the last per-mass pass.
    partials: array<vec4<f32>>,
}

var<workgroup> sum_sh: array<vec4<f32>, 64>;
var<workgroup> flag_sh: u32;

// The workgroup's sum (or max, per component) of `value`; every thread gets it. Call from uniform
// control flow.
fn workgroup_reduce(lid: u32, value: vec4<f32>, take_max: bool) -> vec4<f32> {
    sum_sh[lid] = value;
    workgroupBarrier();
    for (var s = WORKGROUP / 2u; s > 0u; s >>= 1u) {
        if (lid < s) {
            if (take_max) {
                sum_sh[lid] = max(sum_sh[lid], sum_sh[lid + s]);
            } else {
                sum_sh[lid] += sum_sh[lid + s];
            }
        }
        workgroupBarrier();
    }
    let total = sum_sh[0];
    workgroupBarrier();
    return total;
}

// A per-mass pass's partial for its workgroup, reduced over the workgroup and stored by its first
// thread. Call from uniform control flow.
fn store_partial(lid: u32, wid: vec3<u32>, groups: vec3<u32>, value: vec4<f32>, take_max: bool) {
    let total = workgroup_reduce(lid, value, take_max);
    if (lid == 0u) {
        scratch.partials[group_index(wid, groups)] = total;
    }
}

fn group_index(wid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return wid.x + wid.y * groups.x;
}

// Sum (or max) of the per-workgroup partials, by the single workgroup of a reduction kernel.
fn total_of_partials(lid: u32, take_max: bool) -> vec4<f32> {
    let count = arrayLength(&scratch.partials);
    var acc = vec4<f32>(0.0);
    for (var g = lid; g < count; g += WORKGROUP) {
        if (take_max) {
            acc = max(acc, scratch.partials[g]);
        } else {
            acc += scratch.partials[g];
        }
    }
    return workgroup_reduce(lid, acc, take_max);
}

// `flag` as read by the workgroup's first thread, the same for every thread (a uniform value for
// the barriers that follow).
fn uniform_flag(lid: u32, flag: bool) -> bool {
    if (lid == 0u) {
        flag_sh = select(0u, 1u, flag);
    }
    return workgroupUniformLoad(&flag_sh) != 0u;
}

// Whether the current solve runs.
fn solve_running(lid: u32) -> bool {
    return uniform_flag(lid, scratch.solver.cg_active != 0u);
}

// Whether the Newton update waits: the solve has stopped and its update is not yet applied.
fn newton_update_due(lid: u32) -> bool {
    return uniform_flag(lid, scratch.solver.cg_active == 0u && scratch.solver.newton_pending != 0u);
}

struct SpringTerms {
    n: vec3<f32>,
    // h²k along n, h²k·max(0, 1 − L/l) across it, h c along it.
    stiff_along: f32,
    stiff_across: f32,
    damp_along: f32,
}

// One spring's share of the system at the iterate, seen from mass i (src/cpu/implicit.rs's
// linearise; the sign of n does not matter, the terms are in n nᵀ).
fn spring_terms(i: u32, nb: Neighbor) -> SpringTerms {
    let s = springs[nb.spring];
    let d = xt[i].xyz - xt[nb.other].xyz;
    let len = length(d);
    var t = SpringTerms(vec3<f32>(0.0), 0.0, 0.0, 0.0);
    if (len > MIN_SPRING_LENGTH) {
        let h = stage.dt;
        let k = h * h * s.stiffness;
        t.n = d * (1.0 / len);
        t.stiff_along = k;
        t.stiff_across = k * max(1.0 - s.rest / len, 0.0);
        if (HAS_DAMPING) {
            t.damp_along = h * s.damping;
        }
    }
    return t;
}

fn contact_times(i: u32, p: vec3<f32>) -> vec3<f32> {
    let n2 = 2u * params.mass_count;
    let d = deriv[n2 + 2u * i].xyz;
    let o = deriv[n2 + 2u * i + 1u].xyz;
    return vec3<f32>(
        d.x * p.x + o.x * p.y + o.y * p.z,
        o.x * p.x + d.y * p.y + o.z * p.z,
        o.y * p.x + o.z * p.y + d.z * p.z,
    );
}

fn own_mass_term(i: u32) -> f32 {
    var drag = 0.0;
    if (HAS_DRAG) {
        drag = params.drag_per_s;
    }
    return mass[i].x * (1.0 + stage.dt * drag);
}

// Newton's right-hand side h f − M Δv, the Jacobi diagonal, and the solve's start from δ = 0:
// r = b, z = r / diag, p = z. Partials: (r·z, b·b).
@compute @workgroup_size(64)
fn implicit_rhs(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let i = thread_index(gid, groups);
    var partial = vec4<f32>(0.0);
    if (i < params.mass_count) {
        var b = vec3<f32>(0.0);
        var diag = vec3<f32>(1.0);
        if (mass[i].y != 0.0) {
            let m = mass[i].x;
            b = stage.dt * m * deriv[2u * i].xyz - m * work[block(DV_TOTAL, i)].xyz;
            diag = vec3<f32>(own_mass_term(i));
            if (has_contact_terms()) {
                diag += deriv[2u * params.mass_count + 2u * i].xyz;
            }
            let end = offsets[i + 1u];
            for (var e = offsets[i]; e < end; e++) {
                let t = spring_terms(i, neighbors[e]);
                diag += (t.stiff_along + t.damp_along) * t.n * t.n + t.stiff_across * (vec3<f32>(1.0) - t.n * t.n);
            }
        }
        let z = b / diag;
        work[block(DV, i)] = vec4<f32>(0.0);
        work[block(RESIDUAL, i)] = vec4<f32>(b, 0.0);
        work[block(PRECONDITIONED, i)] = vec4<f32>(z, 0.0);
        work[block(DIRECTION, i)] = vec4<f32>(z, 0.0);
        work[block(DIAGONAL, i)] = vec4<f32>(diag, 0.0);
        partial = vec4<f32>(dot(b, z), dot(b, b), 0.0, 0.0);
    }
    store_partial(lid, wid, groups, partial, false);
}

// The start of a step's first solve: no residual scale yet, nothing done.
@compute @workgroup_size(1)
fn solver_begin() {
    scratch.solver = Solver(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
}

// After implicit_rhs: r·z, the residual scale (the first iterate's |b|), and whether to iterate.
@compute @workgroup_size(64)
fn cg_begin(@builtin(local_invocation_index) lid: u32) {
    let t = total_of_partials(lid, false);
    if (lid != 0u) {
        return;
    }
    var sv = scratch.solver;
    let b_norm = sqrt(t.y);
    if (sv.scale == 0.0) {
        sv.scale = b_norm;
    }
    sv.rz = t.x;
    sv.iterations = 0u;
    sv.newton_pending = 1u;
    if (b_norm == 0.0 || sv.scale == 0.0) {
        sv.residual = 0.0;
        sv.cg_active = 0u;
    } else {
        sv.residual = b_norm / sv.scale;
        sv.cg_active = select(0u, 1u, sv.residual > CG_TOLERANCE && CG_MAX_ITERATIONS > 0u);
    }
    scratch.solver = sv;
}

// Ap = (M − h D − h² K) p, pinned rows and columns filtered out (src/cpu/implicit.rs's
// apply_system). Partials: (p·Ap).
@compute @workgroup_size(64)
fn apply_system(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    if (!solve_running(lid)) {
        return;
    }
    let i = thread_index(gid, groups);
    var partial = vec4<f32>(0.0);
    if (i < params.mass_count) {
        var out = vec3<f32>(0.0);
        let pi = work[block(DIRECTION, i)].xyz;
        if (mass[i].y != 0.0) {
            out = own_mass_term(i) * pi;
            let end = offsets[i + 1u];
            for (var e = offsets[i]; e < end; e++) {
                let nb = neighbors[e];
                let t = spring_terms(i, nb);
                var pj = vec3<f32>(0.0);
                if (mass[nb.other].y != 0.0) {
                    pj = work[block(DIRECTION, nb.other)].xyz;
                }
                let dp = pi - pj;
                let dn = dot(t.n, dp);
                out += (t.stiff_along + t.damp_along) * dn * t.n + t.stiff_across * (dp - dn * t.n);
            }
            if (has_contact_terms()) {
                out += contact_times(i, pi);
            }
        }
        work[block(PRODUCT, i)] = vec4<f32>(out, 0.0);
        partial = vec4<f32>(dot(pi, out), 0.0, 0.0, 0.0);
    }
    store_partial(lid, wid, groups, partial, false);
}

// α = r·z / p·Ap; a solve whose p·Ap is not positive and finite stops where it is.
@compute @workgroup_size(64)
fn cg_alpha(@builtin(local_invocation_index) lid: u32) {
    if (!solve_running(lid)) {
        return;
    }
    let t = total_of_partials(lid, false);
    if (lid != 0u) {
        return;
    }
    var sv = scratch.solver;
    sv.iterations += 1u;
    sv.total_iterations += 1u;
    sv.pap = t.x;
    if (!(t.x > 0.0) || t.x > 3.4028235e38) {
        sv.cg_active = 0u;
    } else {
        sv.alpha = sv.rz / t.x;
    }
    scratch.solver = sv;
}

// δ += α p, r −= α Ap, z = r / diag. Partials: (r·z, r·r).
@compute @workgroup_size(64)
fn cg_update(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    if (!solve_running(lid)) {
        return;
    }
    let i = thread_index(gid, groups);
    let alpha = scratch.solver.alpha;
    var partial = vec4<f32>(0.0);
    if (i < params.mass_count) {
        work[block(DV, i)] += alpha * work[block(DIRECTION, i)];
        let r = work[block(RESIDUAL, i)].xyz - alpha * work[block(PRODUCT, i)].xyz;
        let z = r / work[block(DIAGONAL, i)].xyz;
        work[block(RESIDUAL, i)] = vec4<f32>(r, 0.0);
        work[block(PRECONDITIONED, i)] = vec4<f32>(z, 0.0);
        partial = vec4<f32>(dot(r, z), dot(r, r), 0.0, 0.0);
    }
    store_partial(lid, wid, groups, partial, false);
}

// β = r·z (new) / r·z (old), and whether the solve goes on.
@compute @workgroup_size(64)
fn cg_beta(@builtin(local_invocation_index) lid: u32) {
    if (!solve_running(lid)) {
        return;
    }
    let t = total_of_partials(lid, false);
    if (lid != 0u) {
        return;
    }
    var sv = scratch.solver;
    sv.beta = t.x / sv.rz;
    sv.rz = t.x;
    sv.residual = sqrt(t.y) / sv.scale;
    sv.cg_active = select(0u, 1u, sv.residual > CG_TOLERANCE && sv.iterations < CG_MAX_ITERATIONS);
    scratch.solver = sv;
}

// p = z + β p.
@compute @workgroup_size(64)
fn cg_direction(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    if (!solve_running(lid)) {
        return;
    }
    let i = thread_index(gid, groups);
    if (i < params.mass_count) {
        let beta = scratch.solver.beta;
        work[block(DIRECTION, i)] = work[block(PRECONDITIONED, i)] + beta * work[block(DIRECTION, i)];
    }
}

// Once the solve has stopped: Δv += δ. Partials: (max |δ|, max |Δv|).
@compute @workgroup_size(64)
fn newton_update(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    if (!newton_update_due(lid)) {
        return;
    }
    let i = thread_index(gid, groups);
    var partial = vec4<f32>(0.0);
    if (i < params.mass_count) {
        let dv = work[block(DV, i)].xyz;
        let total = work[block(DV_TOTAL, i)].xyz + dv;
        work[block(DV_TOTAL, i)] = vec4<f32>(total, 0.0);
        partial = vec4<f32>(length(dv), length(total), 0.0, 0.0);
    }
    store_partial(lid, wid, groups, partial, true);
}

// Newton stops when its update is small against Δv (or Δv is below 1e-7 m/s).
@compute @workgroup_size(64)
fn newton_end(@builtin(local_invocation_index) lid: u32) {
    if (!newton_update_due(lid)) {
        return;
    }
    let t = total_of_partials(lid, true);
    if (lid != 0u) {
        return;
    }
    var sv = scratch.solver;
    sv.newton += 1u;
    sv.newton_pending = 0u;
    sv.max_residual = max(sv.max_residual, sv.residual);
    sv.step_norm = t.x;
    sv.size_norm = t.y;
    sv.converged = select(0u, 1u, t.x <= NEWTON_TOLERANCE * t.y || t.x < 1e-7);
    scratch.solver = sv;
}
