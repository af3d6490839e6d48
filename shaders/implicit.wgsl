// Implicit Euler (src/cpu/implicit.rs's implicit_step): Δv starts at zero; for each
// Newton iterate (x, v) = (x₀ + h (v₀ + Δv), v₀ + Δv), forces_on (mass_force.wgsl) evaluates f and
// linearises the contacts, and
//   (M − h D − h² K) δ = h f(x, v) − M Δv
// is solved by matrix-free conjugate gradients with a 3 × 3 block-Jacobi preconditioner, to a
// share of the Newton residual (inexact Newton); the step ends at the last iterate. The
// arithmetic per mass is written once (the *_at functions in implicit_terms.wgsl, compiled
// before this file); two ways run it:
// - implicit_step: one workgroup loops over the whole step in one dispatch, every sum reduced in
//   workgroup memory, every stopping rule decided on the device (implicit_group.wgsl's
//   step_in_group, below with block Jacobi's z; multigrid.wgsl's mg_implicit_step runs it with
//   the cycle's). For small systems (src/gpu/implicit/plan.rs says which): no host wait, one
//   dispatch per step.
// - larger systems: one dispatch per pass over the masses (implicit_begin … newton_end), two per
//   CG iteration, each dot product summed per workgroup and then, by every workgroup that needs
//   it, over the workgroups in a fixed order; a kernel whose solve or step has stopped does
//   nothing, and the host reads the frame's outcome once (the section below says how).
// Both keep the frame's largest CG count and residual per step in counters[2] and [3], and how each
// step's Newton went in [4] to [6] (implicit_terms.wgsl's book_step), which the
// snapshot reads back once per frame. Sums run in a fixed order, so a run is repeatable.

// Bindings: `Solve` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import mass_force spring_records state_check system_blocks implicit_terms stage_pose solver_sums implicit_group

// ---- one workgroup, the whole step (implicit_group.wgsl), preconditioned by block Jacobi ----

// implicit_rhs_at's z is the solve's first.
fn group_cg_start(lid: u32, rz: f32) -> f32 {
    return rz;
}

// cg_update_at's z is the iteration's.
fn group_cg_sums(lid: u32, partial: vec4<f32>) -> vec4<f32> {
    return group_reduce(lid, partial, false);
}

@compute @workgroup_size(GROUP_THREADS)
fn implicit_step(@builtin(local_invocation_index) lid: u32) {
    step_in_group(lid);
}

// ---- a dispatch per pass (larger systems) ----
// The kernels below run on a fixed grid of workgroups (SOLVER_GROUPS: as many as the masses need,
// at most a cap the host picks for the device), each thread striding over the masses, so every
// workgroup can sum all of the last pass's partials itself, in the same fixed order: a dot
// product's total needs no dispatch of its own. A CG iteration is two dispatches:
//   cg_advance: α from the p·Ap partials; p = z + βp, δ += αp, r −= αAp, z = B⁻¹r; partials
//               (r·z, r·r);
//   cg_apply:   β and the stopping rule from those partials; Ap with the next p taken on the fly
//               (z + βp at each neighbour: p itself is only written by the next cg_advance);
//               partials (p·Ap).
// The solver's status is double-buffered so that no dispatch writes what it reads: cg_apply reads
// scratch.solver and writes scratch.applied, cg_advance the reverse; a stopped solve's kernels
// only copy it across. The partials are too: [0, G) hold (r·z, r·r) sums (forces_and_rhs,
// cg_advance), [G, 2G) the others (cg_apply, newton_update).
// The host encodes a frame's steps with budgets (Newton iterations per step, CG iterations per
// Newton iteration); kernels past a finished solve or step find it stopped and return. A solve or
// step the budget cut short is flagged in scratch.frame and halts the frame, which the host reads
// once and replays from its start with larger budgets (src/gpu/implicit/solve.rs).

// Whether the step's Newton iterations go on (not converged, stalled or halted).
fn newton_running(lid: u32) -> bool {
    return uniform_flag(lid, scratch.solver.converged == 0u);
}

// Whether BDF2's blend, kept out of the colliders, would press any mass's springs hard
// (blend_presses_at), where the step restarts with implicit Euler. Partials: (1 where one does, …), taken as a max.
@compute @workgroup_size(SOLVER_THREADS)
fn restart_check(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    if (!(HISTORY && (HAS_GROUND || HAS_COLLIDERS))) {
        return;
    }
    var presses = 0.0;
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        if (blend_presses_at(i)) {
            presses = 1.0;
        }
    }
    store_grid_partial(lid, wid.x, OTHER_SUMS, vec4<f32>(presses, 0.0, 0.0, 0.0), true);
}

// The step's start; with contact, BDF2 restarts where restart_check found a mass whose blend
// would press its springs, which workgroup 0 keeps in scratch.frame.restart for the step's later passes.
@compute @workgroup_size(SOLVER_THREADS)
fn implicit_begin(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    var restart = false;
    if (HISTORY && (HAS_GROUND || HAS_COLLIDERS)) {
        restart = grid_total(lid, OTHER_SUMS, true).x > 0.0;
        if (wid.x == 0u && lid == 0u) {
            scratch.frame.restart = select(0u, 1u, restart);
        }
    }
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        implicit_begin_at(i, restart);
    }
}

@compute @workgroup_size(SOLVER_THREADS)
fn implicit_iterate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    if (!newton_running(lid)) {
        return;
    }
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        implicit_iterate_at(i);
    }
}

// A step whose Newton iterations ran out wandering (not converged, and not halted for a
// replay) ends at its best iterate.
@compute @workgroup_size(SOLVER_THREADS)
fn implicit_final(@builtin(global_invocation_id) gid: vec3<u32>) {
    let sv = scratch.solver;
    let at_best = sv.converged == 0u && newton_wandered(sv.evaluated, sv.best);
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        implicit_final_at(i, at_best);
    }
}

// The start of a step: no residual scale yet, nothing done; a halted frame's later steps do
// nothing.
@compute @workgroup_size(1)
fn solver_begin() {
    scratch.solver = Solver(0.0, 0.0, 0.0, 0.0, 0.0, 0u, 0u, 0u, 0u, 0u, 0u, 0.0, F32_MAX, 0u, 0.0, F32_MAX);
    if (scratch.frame.overran != 0u) {
        scratch.solver.converged = 1u;
    }
}

// The forces at the iterate and Newton's right-hand side from them, per mass. Partials: (r·z, b·b).
@compute @workgroup_size(SOLVER_THREADS)
fn forces_and_rhs(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    if (!newton_running(lid)) {
        return;
    }
    var partial = vec4<f32>(0.0);
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        forces_on(i);
        partial += implicit_rhs_at(i);
    }
    store_grid_partial(lid, wid.x, RHS_SUMS, partial, false);
}

// After forces_and_rhs: r·z, the residual scale (the iterate's own, newton_scale), and whether to
// iterate.
@compute @workgroup_size(SOLVER_THREADS)
fn cg_begin(@builtin(local_invocation_index) lid: u32) {
    if (!newton_running(lid)) {
        return;
    }
    let t = grid_total(lid, RHS_SUMS, false);
    if (lid != 0u) {
        return;
    }
    var sv = scratch.solver;
    // This step has used sv.newton + 1 of its budget's Newton iterations.
    scratch.frame.newton_most = max(scratch.frame.newton_most, sv.newton + 1u);
    let b_norm = sqrt(t.y);
    sv.scale = newton_scale(sqrt(t.z));
    let share = relative(b_norm, sv.scale);
    if ((newton_done(b_norm, sv.scale) || newton_stalled(b_norm, sv.last_residual, sv.scale)) && newton_may_end(t.w)) {
        // The step's equations hold well enough: the step ends at this iterate.
        sv.cg_active = 0u;
        sv.newton_pending = 0u;
        sv.converged = 1u;
        scratch.solver = sv;
        book_step(sv.newton, share, true);
        return;
    }
    if (newton_overshot(b_norm, sv.last_residual, sv.halvings)) {
        // No solve: newton_update halves the last update instead (NEWTON_HALVING).
        sv.halvings += 1u;
        sv.evaluated = b_norm;
        sv.iterations = 0u;
        sv.cg_active = 0u;
        sv.newton_pending = NEWTON_HALVING;
        scratch.solver = sv;
        return;
    }
    sv.halvings = 0u;
    sv.last_residual = b_norm;
    sv.evaluated = b_norm;
    if (sv.newton > 0u && b_norm <= sv.best) {
        // newton_update keeps this iterate (sv.best == sv.last_residual).
        sv.best = b_norm;
        sv.best_share = share;
    }
    sv.rz = t.x;
    sv.iterations = 0u;
    sv.newton_pending = 1u;
    if (b_norm == 0.0) {
        sv.residual = 0.0;
        sv.cg_active = 0u;
    } else {
        sv.residual = 1.0;
        sv.cg_active = select(0u, 1u, cg_goes_on(sv.residual, 0u));
    }
    scratch.solver = sv;
}

// The first half of a CG iteration (the first of a solve, after cg_begin, with β = 0 and p = z):
// r·z and |r| from the last pass's partials, whether the solve goes on, β, and Ap for the new
// p = z + βp. Partials: (p·Ap).
@compute @workgroup_size(SOLVER_THREADS)
fn cg_apply(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    var sv = uniform_status(lid, false);
    let writer = status_writer(lid, wid.x);
    if (sv.cg_active == 0u) {
        if (writer) {
            scratch.applied = sv;
        }
        return;
    }
    let t = grid_total(lid, RHS_SUMS, false);
    let first = sv.iterations == 0u;
    sv.residual = sqrt(t.y) / sv.last_residual;
    if (!cg_goes_on(sv.residual, sv.iterations)) {
        sv.cg_active = 0u;
        if (writer) {
            scratch.applied = sv;
        }
        return;
    }
    sv.beta = select(t.x / sv.rz, 0.0, first);
    sv.rz = t.x;
    var partial = vec4<f32>(0.0);
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        if (first) {
            solve_begin_at(i);
        }
        partial += apply_system_at(i, sv.beta, true);
    }
    store_grid_partial(lid, wid.x, OTHER_SUMS, partial, false);
    if (writer) {
        scratch.applied = sv;
    }
}

// The second half of a CG iteration: α = r·z / p·Ap, or the solve stops where it is; then each
// mass's p = z + βp, δ += αp, r −= αAp, z = B⁻¹r. Partials: (r·z, r·r).
@compute @workgroup_size(SOLVER_THREADS)
fn cg_advance(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    var sv = uniform_status(lid, true);
    let writer = status_writer(lid, wid.x);
    if (sv.cg_active == 0u) {
        if (writer) {
            scratch.solver = sv;
        }
        return;
    }
    let t = grid_total(lid, OTHER_SUMS, false);
    sv.iterations += 1u;
    sv.total_iterations += 1u;
    if (!usable_curvature(t.x)) {
        sv.cg_active = 0u;
        if (writer) {
            scratch.solver = sv;
        }
        return;
    }
    let alpha = sv.rz / t.x;
    var partial = vec4<f32>(0.0);
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        cg_direction_at(i, sv.beta);
        partial += cg_update_at(i, alpha);
    }
    store_grid_partial(lid, wid.x, RHS_SUMS, partial, false);
    if (writer) {
        scratch.solver = sv;
    }
}

// newton_pending while a halving of the last update, not a solve's, is to be applied.
const NEWTON_HALVING: u32 = 2u;

// Once the solve has stopped (after cg_apply: scratch.applied): Δv += δ, or the halving cg_begin
// chose. A solve that stopped before its first iteration leaves δ = 0 (cg_apply zeroes it on
// its first). Partials: (max |δ|, max |Δv|).
@compute @workgroup_size(SOLVER_THREADS)
fn newton_update(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let sv = uniform_status(lid, true);
    if (sv.cg_active != 0u || sv.newton_pending == 0u) {
        return;
    }
    var partial = vec4<f32>(0.0);
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        if (sv.newton_pending == NEWTON_HALVING) {
            newton_halve_at(i);
        } else {
            if (sv.best == sv.last_residual) {
                keep_best_at(i);
            }
            if (sv.iterations == 0u) {
                solve_begin_at(i);
            }
            partial = max(partial, newton_update_at(i));
        }
    }
    store_grid_partial(lid, wid.x, OTHER_SUMS, partial, true);
}

// Bit of scratch.frame.overran for a step that used its whole Newton budget unconverged; bit j
// below it for a solve of Newton iteration j still running at the end of its CG budget.
const NEWTON_OVERRAN: u32 = 0x80000000u;

// The relative residual a step out of Newton iterations is booked with: the best iterate's where
// it wandered and ends there (implicit_final), else its last evaluated iterate's.
fn ended_at(sv: Solver) -> f32 {
    return select(relative(sv.evaluated, sv.scale), sv.best_share, newton_wandered(sv.evaluated, sv.best));
}

// Whether Newton has converged; the step's solve figures are booked for the snapshot and the
// frame's budgets. A solve still running here has run out of its budget: the frame halts.
@compute @workgroup_size(SOLVER_THREADS)
fn newton_end(@builtin(local_invocation_index) lid: u32) {
    let applied = uniform_status(lid, true);
    if (applied.newton_pending == 0u) {
        return;
    }
    if (applied.cg_active != 0u) {
        // The rest of the step's encoding does nothing, nor do the frame's later steps.
        if (lid == 0u) {
            scratch.frame.overran |= 1u << applied.newton;
            scratch.solver.cg_active = 0u;
            scratch.solver.newton_pending = 0u;
            scratch.solver.converged = 1u;
        }
        return;
    }
    let t = grid_total(lid, OTHER_SUMS, true);
    if (lid != 0u) {
        return;
    }
    var sv = applied;
    let halving = sv.newton_pending == NEWTON_HALVING;
    sv.newton_pending = 0u;
    if (halving) {
        // A halving counts as an iteration; whether Newton converged is judged after solves.
        sv.newton += 1u;
        if (sv.newton >= NEWTON_MAX_ITERATIONS) {
            book_step(sv.newton, ended_at(sv), false);
        }
    } else {
        scratch.frame.cg_most[sv.newton] = max(scratch.frame.cg_most[sv.newton], sv.iterations);
        sv.newton += 1u;
        sv.max_residual = max(sv.max_residual, sv.residual);
        sv.converged = select(0u, 1u, newton_converged(t.x, t.y));
        // The step ends here: its update was too small to matter (sv.last_residual: the last
        // iterate's, before this update), or its iterations ran out short of the rule.
        if (sv.converged != 0u) {
            book_step(sv.newton, relative(sv.last_residual, sv.scale), true);
        } else if (sv.newton >= NEWTON_MAX_ITERATIONS) {
            book_step(sv.newton, ended_at(sv), false);
        }
    }
    if (sv.converged == 0u && sv.newton >= scratch.frame.newton_budget && sv.newton < NEWTON_MAX_ITERATIONS) {
        scratch.frame.overran |= NEWTON_OVERRAN;
        sv.converged = 1u;
    }
    scratch.solver = sv;
    book_solve(sv.total_iterations, sv.max_residual);
}
