// implicit_group: implicit Euler's whole step in one workgroup (small systems; src/cpu/implicit.rs's
// implicit_step), the body of implicit.wgsl's implicit_step (3 × 3 block Jacobi) and of
// multigrid.wgsl's mg_implicit_step (the V-cycle). Each thread owns the masses lid,
// lid + GROUP_THREADS, …; every sum is reduced in workgroup memory and every stopping rule
// decided on the device, so a step is one dispatch with no host wait.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define: how the CG's z is made from r, given the block-Jacobi z
// that implicit_rhs_at and cg_update_at leave (each called from uniform control flow):
// - group_cg_start(lid, rz): once per Newton iteration, after implicit_rhs_at (which set
//   p = z); returns the solve's first r·z, `rz` being block Jacobi's;
// - group_cg_sums(lid, partial): after each iteration's cg_update_at, whose per-thread
//   (r·z, r·r) is `partial`; returns the workgroup's (r·z, r·r).
// #uses params scratch
// #calls group_cg_start group_cg_sums

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
    return reduce_over(lid, value, take_max, GROUP_THREADS, SUM_LEVEL);
}

// The conjugate-gradient solve from implicit_rhs's start (block Jacobi's r·z = `rz_start`,
// |b| = `b_norm`) until cg_goes_on says. Returns the iterations and the final relative residual
// (as src/cpu/implicit.rs's solve).
fn solve_in_group(lid: u32, rz_start: f32, b_norm: f32) -> vec2<f32> {
    let n = params.mass_count;
    for (var i = lid; i < n; i += GROUP_THREADS) {
        solve_begin_at(i);
    }
    if (b_norm == 0.0) {
        return vec2<f32>(0.0);
    }
    var rz = group_cg_start(lid, rz_start);
    var residual = 1.0;
    var iterations = 0u;
    while (cg_goes_on(residual, iterations)) {
        iterations += 1u;
        // Every thread's p is written before any is read across a spring.
        vectors_barrier();
        var pap = vec4<f32>(0.0);
        for (var i = lid; i < n; i += GROUP_THREADS) {
            pap += apply_system_at(i, 0.0, false);
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
        let sums = group_cg_sums(lid, rr);
        let beta = sums.x / rz;
        rz = sums.x;
        residual = sqrt(sums.y) / b_norm;
        for (var i = lid; i < n; i += GROUP_THREADS) {
            cg_direction_at(i, beta);
        }
    }
    return vec2<f32>(f32(iterations), residual);
}

// Whether BDF2 restarts this step (blend_presses_at for any mass), kept in scratch.frame.restart
// for restarting(), which every thread reads after the barrier.
fn restart_in_group(lid: u32) -> bool {
    if (!(HISTORY && (HAS_GROUND || HAS_COLLIDERS))) {
        return false;
    }
    var presses = 0.0;
    for (var i = lid; i < params.mass_count; i += GROUP_THREADS) {
        if (blend_presses_at(i)) {
            presses = 1.0;
        }
    }
    let restart = group_reduce(lid, vec4<f32>(presses, 0.0, 0.0, 0.0), true).x > 0.0;
    if (lid == 0u) {
        scratch.frame.restart = select(0u, 1u, restart);
    }
    storageBarrier();
    return restart;
}

// One backward step of the whole system: Newton iterations, each a CG solve, to the CPU's
// stopping rules. A storage barrier separates a pass that writes what another thread's next
// pass reads across a spring.
fn step_in_group(lid: u32) {
    let n = params.mass_count;
    let restart = restart_in_group(lid);
    for (var i = lid; i < n; i += GROUP_THREADS) {
        implicit_begin_at(i, restart);
    }
    var last_residual = F32_MAX;
    var iterations = 0u;
    var max_residual = 0.0;
    var newtons = 0u;
    var met = false;
    var step_residual = 0.0;
    var halvings = 0u;
    var best = F32_MAX;
    var best_share = 0.0;
    var last_evaluated = F32_MAX;
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
        let scale = newton_scale(sqrt(t.z));
        step_residual = relative(b_norm, scale);
        last_evaluated = b_norm;
        if ((newton_done(b_norm, scale) || newton_stalled(b_norm, last_residual, scale)) && newton_may_end(t.w)) {
            met = true;
            break;
        }
        if (newton_overshot(b_norm, last_residual, halvings)) {
            // Each thread halves its own masses' update, which only it reads next.
            halvings += 1u;
            newtons += 1u;
            for (var i = lid; i < n; i += GROUP_THREADS) {
                newton_halve_at(i);
            }
            continue;
        }
        halvings = 0u;
        last_residual = b_norm;
        if (newton > 0u && b_norm <= best) {
            // Each thread keeps its own masses', which only it wrote and reads.
            best = b_norm;
            best_share = step_residual;
            for (var i = lid; i < n; i += GROUP_THREADS) {
                keep_best_at(i);
            }
        }
        newtons += 1u;
        let solved = solve_in_group(lid, t.x, b_norm);
        iterations += u32(solved.x);
        max_residual = max(max_residual, solved.y);
        var norms = vec4<f32>(0.0);
        for (var i = lid; i < n; i += GROUP_THREADS) {
            norms = max(norms, newton_update_at(i));
        }
        let m = group_reduce(lid, norms, true);
        if (newton_converged(m.x, m.y)) {
            met = true;
            break;
        }
    }
    let at_best = !met && newton_wandered(last_evaluated, best);
    if (at_best) {
        step_residual = best_share;
    }
    for (var i = lid; i < n; i += GROUP_THREADS) {
        implicit_final_at(i, at_best);
    }
    if (lid == 0u) {
        book_solve(iterations, max_residual);
        book_step(newtons, step_residual, met);
    }
}
