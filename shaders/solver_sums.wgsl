// solver_sums: what implicit Euler's kernels share with the multigrid cycle's (implicit.wgsl,
// multigrid.wgsl): the solver's status and frame record, the sums over a workgroup, and the
// per-pass kernels' partial sums over their grid of workgroups, each summed by every workgroup
// that needs it in the same fixed order.
// A library: `#uses` names the bindings it reads, which its program must bind.
// #uses scratch

// Keep in sync with src/gpu/layout.rs's SolverStatus.
struct Solver {
    // r·z of the current iteration, and the β that cg_apply took for it (cg_advance's p).
    rz: f32,
    beta: f32,
    // The momentum change the last iterate evaluated is judged against (newton_scale).
    scale: f32,
    // |r| / |b| of the current solve.
    residual: f32,
    // Largest final residual over the step's solves.
    max_residual: f32,
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
    // `best` relative to its own scale: what a step that ends there is booked with.
    best_share: f32,
    // |h f − M Δv| at the last Newton iterate solved from (newton_stalled, newton_overshot), the
    // |b| of the current solve's start, which its residual is relative to.
    last_residual: f32,
    // Halvings of the last update so far (newton_overshot); 2 in newton_pending while one is
    // to be applied.
    halvings: u32,
    // |h f − M Δv| at the last iterate evaluated (solved from, or halved).
    evaluated: f32,
    // The least |h f − M Δv| of the iterates solved from after the first (BEST_DV keeps its
    // Δv), where a step whose iterations run out wandering ends (newton_wandered). With it the
    // status is 64 bytes: the partials after the two statuses and the frame record start
    // 16-aligned.
    best: f32,
}

// What the per-pass kernels learn of a frame, read back once by the host (src/gpu/layout.rs's
// FrameSolve). cg_most is indexed by Newton iteration (NEWTON_MAX_ITERATIONS ≤ 16).
struct FrameSolve {
    // The Newton iterations a step may take in this frame's encoding (the host writes it).
    newton_budget: u32,
    // NEWTON_OVERRAN, and bit j for a solve of Newton iteration j that ran out of its budget.
    overran: u32,
    // The most Newton iterations a step began, and CG iterations a solve of Newton iteration j
    // took.
    newton_most: u32,
    // 1 while the step under way is BDF2 restarted with implicit Euler (restarting()).
    restart: u32,
    cg_most: array<u32, 16>,
}

struct Scratch {
    // The status cg_apply reads, and the one it writes (cg_advance reads it and writes the first).
    solver: Solver,
    applied: Solver,
    frame: FrameSolve,
    // The per-pass kernels' partial sums, two per workgroup of their grid.
    partials: array<vec4<f32>>,
}

var<workgroup> sum_sh: array<vec4<f32>, SUM_SLOTS>;
var<workgroup> flag_sh: u32;
var<workgroup> part_sh: array<vec4<f32>, 32>;
var<workgroup> total_sh: vec4<f32>;

// ---- workgroup sums ----

// The sum (or max, per component) of `value` over a workgroup of `threads` threads, the same for
// every thread (a uniform value, so loops and branches on it may hold barriers). Two levels:
// `level` threads (at most 32) add strided shares, then one adds those, always in the same
// order. Call from uniform control flow.
fn reduce_over(lid: u32, value: vec4<f32>, take_max: bool, threads: u32, level: u32) -> vec4<f32> {
    sum_sh[lid] = value;
    workgroupBarrier();
    if (lid < level) {
        var acc = vec4<f32>(0.0);
        for (var k = lid; k < threads; k += level) {
            acc = combine(acc, sum_sh[k], take_max);
        }
        part_sh[lid] = acc;
    }
    workgroupBarrier();
    if (lid == 0u) {
        var total = vec4<f32>(0.0);
        for (var k = 0u; k < min(threads, level); k++) {
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

// The sum over a per-pass kernel's workgroup (SOLVER_THREADS threads, at most 64).
fn workgroup_reduce(lid: u32, value: vec4<f32>, take_max: bool) -> vec4<f32> {
    return reduce_over(lid, value, take_max, SOLVER_THREADS, 8u);
}

// `flag` as read by the workgroup's first thread, the same for every thread (a uniform value for
// the barriers that follow).
fn uniform_flag(lid: u32, flag: bool) -> bool {
    if (lid == 0u) {
        flag_sh = select(0u, 1u, flag);
    }
    return workgroupUniformLoad(&flag_sh) != 0u;
}

// The grid's workgroups: half the partials (set by the host, src/gpu/implicit/plan.rs's solver_groups).
fn solver_groups() -> u32 {
    return arrayLength(&scratch.partials) / 2u;
}

const RHS_SUMS: u32 = 0u;
const OTHER_SUMS: u32 = 1u;

// A grid kernel's partial for its workgroup, into sums `which`. Call from uniform control flow.
fn store_grid_partial(lid: u32, wid: u32, which: u32, value: vec4<f32>, take_max: bool) {
    let total = workgroup_reduce(lid, value, take_max);
    if (lid == 0u) {
        scratch.partials[which * solver_groups() + wid] = total;
    }
}

// The sum (or max) of sums `which` over the grid's workgroups, the same for every thread of every
// workgroup: each thread adds a strided share of them, and the shares are summed in order
// (src/cpu/solver_sums.rs's group_reduce takes it so).
fn grid_total(lid: u32, which: u32, take_max: bool) -> vec4<f32> {
    let groups = solver_groups();
    var acc = vec4<f32>(0.0);
    for (var g = lid; g < groups; g += SOLVER_THREADS) {
        acc = combine(acc, scratch.partials[which * groups + g], take_max);
    }
    return workgroup_reduce(lid, acc, take_max);
}

var<workgroup> solver_sh: Solver;

// The status as the workgroup's first thread reads it, the same for every thread (a uniform
// value). `applied`: scratch.applied (cg_apply's), else scratch.solver.
fn uniform_status(lid: u32, applied: bool) -> Solver {
    if (lid == 0u) {
        if (applied) {
            solver_sh = scratch.applied;
        } else {
            solver_sh = scratch.solver;
        }
    }
    return workgroupUniformLoad(&solver_sh);
}

// Whether this is the grid's first thread, the one that writes the status.
fn status_writer(lid: u32, wid: u32) -> bool {
    return lid == 0u && wid == 0u;
}

