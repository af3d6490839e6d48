// Implicit Euler (src/cpu/implicit.rs's implicit_step): Δv starts at zero; for each Newton iterate
// (x, v) = (x₀ + h (v₀ + Δv), v₀ + Δv), forces_on (mass_force.wgsl) evaluates f and linearises the
// contacts, and
//   (M − h D − h² K) δ = h f(x, v) − M Δv
// is solved by matrix-free conjugate gradients with a Jacobi preconditioner; the step ends at the
// last iterate. The arithmetic per mass is written once (the *_at functions in
// implicit_terms.wgsl, compiled before this file); two ways run it:
// - implicit_step: one workgroup loops over the whole step in one dispatch, every sum reduced in
//   workgroup memory, every stopping rule decided on the device. For small systems
//   (src/gpu/implicit.rs says which): no host wait, one dispatch per step.
// - larger systems: one dispatch per pass over the masses (implicit_begin … newton_end), each dot
//   product summed per workgroup, then over the workgroups in a fixed order by one workgroup (the
//   *_begin/_alpha/_beta/_end kernels); a kernel whose solve has stopped does nothing, and the
//   host reads the status between chunks of CG iterations.
// Both keep the frame's largest CG count and residual per step in counters[2] and [3], which the
// snapshot reads back once per frame. Sums run in a fixed order, so a run is repeatable.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> springs: array<Spring>;
@group(0) @binding(2) var<storage, read> offsets: array<u32>;
@group(0) @binding(3) var<storage, read> neighbors: array<Neighbor>;
@group(0) @binding(4) var<storage, read> colliders: array<Collider>;
@group(0) @binding(5) var<storage, read> mass: array<vec2<f32>>;
// forces_on's output at the iterate: [2i] acceleration, [2i + 1] ledger rates, [2n + 2i],
// [2n + 2i + 1] contacts.
@group(0) @binding(6) var<storage, read_write> deriv: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> x: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> v: array<vec4<f32>>;
// The Newton iterate (the state forces_on reads).
@group(0) @binding(9) var<storage, read_write> x_in: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> v_in: array<vec4<f32>>;
// The solver's per-mass vectors (block() in common.wgsl).
@group(0) @binding(11) var<storage, read_write> work: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> ledger: array<vec4<f32>>;
// [1] the divergence flag (check_state); [2] the most CG iterations of a step since the last
// snapshot; [3] the largest residual (an f32's bits: positive floats order as their bits).
@group(0) @binding(13) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(14) var<storage, read_write> scratch: Scratch;
// Each CSR entry's spring terms at the iterate (spring_terms), stored by implicit_rhs_at for the
// solve's products: [2e] (n, h²k + h c), [2e + 1] (h²k·max(0, 1 − L/l), …).
@group(0) @binding(15) var<storage, read_write> terms: array<vec4<f32>>;
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
    // |h f − M Δv| at the last Newton iterate (newton_stalled).
    last_residual: f32,
}

struct Scratch {
    solver: Solver,
    // One partial sum per workgroup of the last per-mass pass.
    partials: array<vec4<f32>>,
}

var<workgroup> sum_sh: array<vec4<f32>, 64>;
var<workgroup> flag_sh: u32;
var<workgroup> part_sh: array<vec4<f32>, 8>;
var<workgroup> total_sh: vec4<f32>;
// The one-workgroup step's solver vectors and spring terms, when they fit (SOLVER_IN_WORKGROUP).
var<workgroup> vectors_sh: array<vec4<f32>, WORKGROUP_VECTORS>;
var<workgroup> terms_sh: array<vec4<f32>, WORKGROUP_TERMS>;

// ---- workgroup sums ----

// The sum (or max, per component) of `value` over a workgroup of `threads` threads, the same for
// every thread (a uniform value, so loops and branches on it may hold barriers). Two levels: 8
// threads add strided eighths, then one adds those, always in the same order. Call from uniform
// control flow.
fn reduce_over(lid: u32, value: vec4<f32>, take_max: bool, threads: u32) -> vec4<f32> {
    sum_sh[lid] = value;
    workgroupBarrier();
    if (lid < 8u) {
        var acc = vec4<f32>(0.0);
        for (var k = lid; k < threads; k += 8u) {
            acc = combine(acc, sum_sh[k], take_max);
        }
        part_sh[lid] = acc;
    }
    workgroupBarrier();
    if (lid == 0u) {
        var total = vec4<f32>(0.0);
        for (var k = 0u; k < min(threads, 8u); k++) {
            total = combine(total, part_sh[k], take_max);
        }
        total_sh = total;
    }
    return workgroupUniformLoad(&total_sh);
}

// Sums start from 0, and so do maxima (of lengths and other non-negative figures).
fn combine(acc: vec4<f32>, value: vec4<f32>, take_max: bool) -> vec4<f32> {
    return select(acc + value, max(acc, value), take_max);
}

fn workgroup_reduce(lid: u32, value: vec4<f32>, take_max: bool) -> vec4<f32> {
    return reduce_over(lid, value, take_max, WORKGROUP);
}

// A per-mass pass's partial for its workgroup, reduced over the workgroup and stored by its first
// thread. Call from uniform control flow.
fn store_partial(lid: u32, wid: vec3<u32>, groups: vec3<u32>, value: vec4<f32>, take_max: bool) {
    let total = workgroup_reduce(lid, value, take_max);
    if (lid == 0u) {
        scratch.partials[wid.x + wid.y * groups.x] = total;
    }
}

// Sum (or max) of the per-workgroup partials, by the single workgroup of a reduction kernel.
fn total_of_partials(lid: u32, take_max: bool) -> vec4<f32> {
    let count = arrayLength(&scratch.partials);
    var acc = vec4<f32>(0.0);
    for (var g = lid; g < count; g += WORKGROUP) {
        acc = combine(acc, scratch.partials[g], take_max);
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

// Between a pass that writes the solver's vectors and one that reads them across a spring, in
// whichever memory holds them.
fn vectors_barrier() {
    if (SOLVER_IN_WORKGROUP) {
        workgroupBarrier();
    } else {
        storageBarrier();
    }
}

// The one-workgroup step's sums.
fn group_reduce(lid: u32, value: vec4<f32>, take_max: bool) -> vec4<f32> {
    return reduce_over(lid, value, take_max, GROUP_THREADS);
}

// ---- one workgroup, the whole step ----

// The conjugate-gradient solve from implicit_rhs's start (r·z = `rz`, |b| = `b_norm`) to
// |r| ≤ CG_TOLERANCE · `scale`, each thread on the masses lid, lid + GROUP_THREADS, …. Returns the
// iterations and the final relative residual (as src/cpu/implicit.rs's solve).
fn solve_in_group(lid: u32, rz_start: f32, b_norm: f32, scale: f32) -> vec2<f32> {
    let n = params.mass_count;
    if (b_norm == 0.0 || scale == 0.0) {
        return vec2<f32>(0.0);
    }
    var rz = rz_start;
    var residual = b_norm / scale;
    var iterations = 0u;
    while (cg_goes_on(residual, iterations)) {
        iterations += 1u;
        // Every thread's p is written before any is read across a spring.
        vectors_barrier();
        var pap = vec4<f32>(0.0);
        for (var i = lid; i < n; i += GROUP_THREADS) {
            pap += apply_system_at(i);
        }
        let curvature = group_reduce(lid, pap, false).x;
        if (!usable_curvature(curvature)) {
            break;
        }
        let alpha = rz / curvature;
        var rr = vec4<f32>(0.0);
        for (var i = lid; i < n; i += GROUP_THREADS) {
            rr += cg_update_at(i, alpha);
        }
        let sums = group_reduce(lid, rr, false);
        let beta = sums.x / rz;
        rz = sums.x;
        residual = sqrt(sums.y) / scale;
        for (var i = lid; i < n; i += GROUP_THREADS) {
            cg_direction_at(i, beta);
        }
    }
    return vec2<f32>(f32(iterations), residual);
}

// One backward Euler step of the whole system by one workgroup (src/cpu/implicit.rs's
// implicit_step): Newton iterations, each a CG solve, to the same stopping rules. Threads own the
// masses lid, lid + GROUP_THREADS, …; a storage barrier separates a pass that writes what another
// thread's next pass reads across a spring.
@compute @workgroup_size(GROUP_THREADS)
fn implicit_step(@builtin(local_invocation_index) lid: u32) {
    let n = params.mass_count;
    for (var i = lid; i < n; i += GROUP_THREADS) {
        implicit_begin_at(i);
    }
    var scale = 0.0;
    var last_residual = F32_MAX;
    var iterations = 0u;
    var max_residual = 0.0;
    for (var newton = 0u; newton < NEWTON_MAX_ITERATIONS; newton++) {
        for (var i = lid; i < n; i += GROUP_THREADS) {
            implicit_iterate_at(i);
        }
        storageBarrier();
        var start = vec4<f32>(0.0);
        for (var i = lid; i < n; i += GROUP_THREADS) {
            forces_on(i);
            start += implicit_rhs_at(i);
        }
        let t = group_reduce(lid, start, false);
        let b_norm = sqrt(t.y);
        if (scale == 0.0) {
            scale = b_norm;
        }
        if (newton_stalled(b_norm, last_residual, scale)) {
            break;
        }
        last_residual = b_norm;
        let solved = solve_in_group(lid, t.x, b_norm, scale);
        iterations += u32(solved.x);
        max_residual = max(max_residual, solved.y);
        var norms = vec4<f32>(0.0);
        for (var i = lid; i < n; i += GROUP_THREADS) {
            norms = max(norms, newton_update_at(i));
        }
        let m = group_reduce(lid, norms, true);
        if (newton_converged(m.x, m.y)) {
            break;
        }
    }
    for (var i = lid; i < n; i += GROUP_THREADS) {
        implicit_final_at(i);
    }
    if (lid == 0u) {
        book_solve(iterations, max_residual);
    }
}

// ---- a dispatch per pass (larger systems) ----

@compute @workgroup_size(64)
fn implicit_begin(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i < params.mass_count) {
        implicit_begin_at(i);
    }
}

@compute @workgroup_size(64)
fn implicit_iterate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i < params.mass_count) {
        implicit_iterate_at(i);
    }
}

@compute @workgroup_size(64)
fn implicit_final(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i < params.mass_count) {
        implicit_final_at(i);
    }
}

// The start of a step's first solve: no residual scale yet, nothing done.
@compute @workgroup_size(1)
fn solver_begin() {
    scratch.solver = Solver(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u, 0u, 0u, 0u, 0u, 0u, F32_MAX);
}

// Partials: (r·z, b·b).
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
        partial = implicit_rhs_at(i);
    }
    store_partial(lid, wid, groups, partial, false);
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
    if (newton_stalled(b_norm, sv.last_residual, sv.scale)) {
        // Newton has converged as far as f32 forces go: the step ends at this iterate.
        sv.cg_active = 0u;
        sv.newton_pending = 0u;
        sv.converged = 1u;
        scratch.solver = sv;
        return;
    }
    sv.last_residual = b_norm;
    sv.rz = t.x;
    sv.iterations = 0u;
    sv.newton_pending = 1u;
    if (b_norm == 0.0 || sv.scale == 0.0) {
        sv.residual = 0.0;
        sv.cg_active = 0u;
    } else {
        sv.residual = b_norm / sv.scale;
        sv.cg_active = select(0u, 1u, cg_goes_on(sv.residual, 0u));
    }
    scratch.solver = sv;
}

// Partials: (p·Ap).
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
        partial = apply_system_at(i);
    }
    store_partial(lid, wid, groups, partial, false);
}

// α = r·z / p·Ap, or the solve stops where it is.
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
    if (usable_curvature(t.x)) {
        sv.alpha = sv.rz / t.x;
    } else {
        sv.cg_active = 0u;
    }
    scratch.solver = sv;
}

// Partials: (r·z, r·r).
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
    var partial = vec4<f32>(0.0);
    if (i < params.mass_count) {
        partial = cg_update_at(i, scratch.solver.alpha);
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
    sv.cg_active = select(0u, 1u, cg_goes_on(sv.residual, sv.iterations));
    scratch.solver = sv;
}

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
        cg_direction_at(i, scratch.solver.beta);
    }
}

// Once the solve has stopped. Partials: (max |δ|, max |Δv|).
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
        partial = newton_update_at(i);
    }
    store_partial(lid, wid, groups, partial, true);
}

// Whether Newton has converged; the step's solve figures are booked for the snapshot.
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
    sv.converged = select(0u, 1u, newton_converged(t.x, t.y));
    scratch.solver = sv;
    book_solve(sv.total_iterations, sv.max_residual);
}
