// Implicit Euler's arithmetic, written once for both ways implicit.wgsl runs a step: the stopping
// rules of src/cpu/implicit.rs, and each pass over the masses as a function of one mass (the *_at
// functions, named for the CPU functions they mirror). It runs in implicit.wgsl.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params springs offsets neighbors mass deriv x v ledger counters x_in v_in work terms stage colliders scratch
// #calls check_state collider_pose

// ---- where the solver's vectors live ----

// The one-workgroup step's solver vectors and spring terms, when they fit (SOLVER_IN_WORKGROUP).
var<workgroup> vectors_sh: array<vec4<f32>, WORKGROUP_VECTORS>;
var<workgroup> terms_sh: array<vec4<f32>, WORKGROUP_TERMS>;

// The solver's per-mass vector `k` (block() in common.wgsl) and each CSR entry's spring terms are
// read many times a step. The one-workgroup step keeps them in workgroup memory when they fit
// (SOLVER_IN_WORKGROUP, src/gpu/implicit/plan.rs's SolverHome); otherwise, and always in the
// per-pass kernels, they live in the `work` and `terms` buffers.

fn vector_at(k: u32, i: u32) -> vec4<f32> {
    if (SOLVER_IN_WORKGROUP) {
        return vectors_sh[block(k, i)];
    }
    return work[block(k, i)];
}

fn set_vector(k: u32, i: u32, value: vec4<f32>) {
    if (SOLVER_IN_WORKGROUP) {
        vectors_sh[block(k, i)] = value;
    } else {
        work[block(k, i)] = value;
    }
}

fn term_at(slot: u32) -> vec4<f32> {
    if (SOLVER_IN_WORKGROUP) {
        return terms_sh[slot];
    }
    return terms[slot];
}

fn set_term(slot: u32, value: vec4<f32>) {
    if (SOLVER_IN_WORKGROUP) {
        terms_sh[slot] = value;
    } else {
        terms[slot] = value;
    }
}

// ---- the step: BDF2's, or implicit Euler's where BDF2 restarts ----

// Whether this step is a BDF2 step restarted with implicit Euler across an impact (decided at
// its start from blend_presses_at over every mass: restart_check, step_in_group).
fn restarting() -> bool {
    return HISTORY && (HAS_GROUND || HAS_COLLIDERS) && scratch.frame.restart != 0u;
}

// The step the solve takes (h in x = x̂ + h v): the stage's, or the whole step in a restart
// (src/physics/solver.rs's BackwardStep::restarted). mass_force.wgsl and system_blocks.wgsl
// call it.
fn solve_dt() -> f32 {
    return select(stage.dt, stage.whole_dt, restarting());
}

// ---- the stopping rules, as src/cpu/newton_rules.rs's and src/cpu/cg.rs's ----

// The step's forcing: CG_FORCING, or CG_FORCING_AT_RESTART in a restart (src/cpu/cg.rs's
// cg_forcing).
fn cg_forcing() -> f32 {
    return select(CG_FORCING, CG_FORCING_AT_RESTART, restarting());
}

// Whether CG goes on at `residual` (|r| relative to the Newton residual |b| it started from)
// after `iterations` iterations: until the step's forcing of |b| (inexact Newton) or its cap.
fn cg_goes_on(residual: f32, iterations: u32) -> bool {
    return residual > cg_forcing() && iterations < CG_MAX_ITERATIONS;
}

// A solve whose p·Ap is not positive and finite stops where it is.
fn usable_curvature(pap: f32) -> bool {
    return pap > 0.0 && pap <= F32_MAX;
}

// Newton stops when its update is small against Δv (or Δv is below 1e-7 m/s).
fn newton_converged(step_norm: f32, size_norm: f32) -> bool {
    return step_norm <= NEWTON_TOLERANCE * size_norm || step_norm < 1e-7;
}

// The momentum change an iterate's residual is judged against: |h f| at that iterate, and at
// least the step's impulse of the weight WEIGHT_N (src/cpu/newton_rules.rs's newton_scale).
fn newton_scale(hf: f32) -> f32 {
    return max(hf, solve_dt() * WEIGHT_N);
}

// Newton's residual is small enough to end the step at this iterate: at most NEWTON_RESIDUAL (the
// host sets it for the run's step: src/physics/solver.rs's newton_residual) of the iterate's
// momentum change `scale` (newton_scale).
fn newton_done(residual: f32, scale: f32) -> bool {
    return residual <= NEWTON_RESIDUAL * scale;
}

// Newton's residual has stalled at the floor of f32 forces (src/cpu/newton_rules.rs's newton_stalled):
// below NEWTON_FLOOR of |h f| (physics::newton_floor of the step), and not halved since the last
// iterate's.
fn newton_stalled(residual: f32, last: f32, scale: f32) -> bool {
    return residual <= NEWTON_FLOOR * scale && residual > NEWTON_STALL * last;
}

// Whether the step may end at this iterate (newton_done or newton_stalled) given the residual's
// summed work `work` (implicit_rhs_at's w): BDF2's must be at most 0 (physics::NEWTON_WORK_SHARE).
fn newton_may_end(work: f32) -> bool {
    return !HISTORY || work <= 0.0;
}

// A finished step's CG iterations and residual, kept for the frame's snapshot.
fn book_solve(iterations: u32, residual: f32) {
    atomicMax(&counters[2], iterations);
    atomicMax(&counters[3], bitcast<u32>(residual));
}

// `residual` as a share of the step's momentum change `scale`, 0 where nothing moves
// (src/cpu/newton_rules.rs's relative).
fn relative(residual: f32, scale: f32) -> f32 {
    return select(0.0, residual / scale, scale > 0.0);
}

// How a finished step's Newton went, kept for the frame's snapshot: its iterations, its residual
// |h f − M Δv| / |h f| at its last iterate evaluated, and whether it met its rule (the
// tolerance, the floor of f32 forces or an update too small to matter) or ran out of iterations
// (counted; a replayed frame restores the counters with the state).
fn book_step(newton: u32, step_residual: f32, met: bool) {
    atomicMax(&counters[4], newton);
    if (!met) {
        atomicAdd(&counters[5], 1u);
    }
    atomicMax(&counters[6], bitcast<u32>(max(step_residual, 0.0)));
}

// ---- the system, per mass ----

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

// ---- the passes, per mass: src/cpu/implicit.rs's functions of the same names ----

fn implicit_begin_at(i: u32, restart: bool) {
    set_vector(DV_TOTAL, i, vec4<f32>(0.0));
    if (HISTORY) {
        implicit_blend_at(i, restart);
    }
}

// BDF2's start (src/cpu/backward.rs's implicit_blend): x̂ = x + history (x − x₋₁), the same for
// v, keeping x and v as the next step's history. Its first step's history is 0, and a
// `restart` starts from x and v themselves: x₋₁ is unused. A blend that would start a mass
// deeper in the ground or a collider than it is starts it at its own depth and velocity
// (blend_along_surface).
fn implicit_blend_at(i: u32, restart: bool) {
    let b = select(stage.history, 0.0, restart);
    let xo = x[i].xyz;
    let vo = v[i].xyz;
    if (b != 0.0) {
        let xl = work[block(HISTORY_X, i)].xyz;
        let vl = work[block(HISTORY_V, i)].xyz;
        var start = Blend(xo + b * (xo - xl), vo + b * (vo - vl));
        if (HAS_GROUND || HAS_COLLIDERS) {
            start = blend_along_surface(start, deepest_penetration(start.x), deepest_penetration(xo).w, vo);
        }
        x[i] = vec4<f32>(start.x, 0.0);
        v[i] = vec4<f32>(start.v, 0.0);
    }
    work[block(HISTORY_X, i)] = vec4<f32>(xo, 0.0);
    work[block(HISTORY_V, i)] = vec4<f32>(vo, 0.0);
}

struct Blend {
    x: vec3<f32>,
    v: vec3<f32>,
}

// BDF2's blended start of a mass whose blend's deepest contact is (normal, depth) `deepest`, the
// mass itself `now` deep moving at v_now: unchanged unless the blend starts it deeper than it is;
// then moved back out along the normal to the mass's depth, at the mass's own velocity
// (backward.rs's blend_along_surface).
fn blend_along_surface(b: Blend, deepest: vec4<f32>, now: f32, v_now: vec3<f32>) -> Blend {
    if (deepest.w <= now) {
        return b;
    }
    let n = deepest.xyz;
    return Blend(b.x + (deepest.w - now) * n, v_now);
}

// Whether blend_along_surface would move mass i back by more than RESTART_PRESS_SHARE of its
// shortest spring, where the step restarts with implicit Euler (backward.rs's blend_presses).
// Not on a step with no history to blend.
fn blend_presses_at(i: u32) -> bool {
    let b = stage.history;
    if (b == 0.0) {
        return false;
    }
    let xo = x[i].xyz;
    let xl = work[block(HISTORY_X, i)].xyz;
    let depth = deepest_penetration(xo + b * (xo - xl)).w;
    let now = deepest_penetration(xo).w;
    return depth - now > RESTART_PRESS_SHARE * shortest_spring(i);
}

// The rest length of mass i's shortest unbroken spring, F32_MAX where it has none
// (backward.rs's shortest_spring).
fn shortest_spring(i: u32) -> f32 {
    var shortest = F32_MAX;
    let end = offsets[i + 1u];
    for (var e = offsets[i]; e < end; e++) {
        let s = springs[neighbors[e].spring];
        if (!is_broken(s)) {
            shortest = min(shortest, s.rest);
        }
    }
    return shortest;
}

// The deepest p is in the ground or a collider at the stage's poses, 0 outside them all, and
// that contact's outward normal, as (normal, depth) (backward.rs's deepest_penetration).
fn deepest_penetration(p: vec3<f32>) -> vec4<f32> {
    var deepest = vec4<f32>(0.0);
    if (HAS_GROUND) {
        let depth = params.ground_height - p.y;
        if (depth > 0.0) {
            deepest = vec4<f32>(0.0, 1.0, 0.0, depth);
        }
    }
    if (HAS_COLLIDERS) {
        for (var k = 0u; k < params.collider_count; k++) {
            let c = penetration(colliders[k], collider_pose(k).position.xyz, p);
            if (c.w > deepest.w) {
                deepest = c;
            }
        }
    }
    return deepest;
}

fn implicit_iterate_at(i: u32) {
    let vk = v[i].xyz + vector_at(DV_TOTAL, i).xyz;
    v_in[i] = vec4<f32>(vk, 0.0);
    x_in[i] = vec4<f32>(x[i].xyz + solve_dt() * vk, 0.0);
}

// The iterate just solved from has the least residual so far: keep its Δv and its forces'
// ledger rates (src/cpu/implicit.rs's implicit_step keeps them as best_dv and its power).
fn keep_best_at(i: u32) {
    work[block(BEST_DV, i)] = vector_at(DV_TOTAL, i);
    work[block(BEST_RATES, i)] = deriv[2u * i + 1u];
}

// The ledger takes the rates of the last iterate's forces (backward quadrature, as on the CPU);
// a step short of its rule that wandered (`at_best`) ends at the best iterate it solved from,
// with its rates.
fn implicit_final_at(i: u32, at_best: bool) {
    var dv = vector_at(DV_TOTAL, i).xyz;
    var rates = deriv[2u * i + 1u];
    if (at_best) {
        dv = work[block(BEST_DV, i)].xyz;
        rates = work[block(BEST_RATES, i)];
    }
    let vn = v[i].xyz + dv;
    v[i] = vec4<f32>(vn, 0.0);
    x[i] = vec4<f32>(x[i].xyz + solve_dt() * vn, 0.0);
    ledger[i] += stage.whole_dt * rates;
    check_state(x[i].xyz, vn);
}

// The preconditioner's inverted block of mass i, stored symmetric in two vectors.
fn block_inverse_at(i: u32) -> mat3x3<f32> {
    let d = vector_at(DIAGONAL, i);
    let o = vector_at(DIAGONAL_OFF, i);
    return mat3x3<f32>(
        vec3<f32>(d.x, d.w, o.x),
        vec3<f32>(d.w, d.y, o.y),
        vec3<f32>(o.x, o.y, d.z),
    );
}

// Newton's right-hand side h f − M Δv, the inverted diagonal block of the block-Jacobi
// preconditioner, and the solve's start from δ = 0: r = b, z = B⁻¹ r, p = z. Returns
// (r·z, b·b, |h f|², BDF2's residual work: src/cpu/backward.rs's residual_work).
// (Summed in f32 as the CPU sums them, src/cpu/solver_sums.rs.)
fn implicit_rhs_at(i: u32) -> vec4<f32> {
    var b = vec3<f32>(0.0);
    var hf = vec3<f32>(0.0);
    var inv = mat3x3<f32>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
    if (mass[i].y != 0.0) {
        let m = mass[i].x;
        hf = solve_dt() * m * deriv[2u * i].xyz;
        b = hf - m * vector_at(DV_TOTAL, i).xyz;
        var block = own_block(i);
        if (has_contact_terms()) {
            let n2 = 2u * params.mass_count;
            block += symmetric_block(deriv[n2 + 2u * i].xyz, deriv[n2 + 2u * i + 1u].xyz);
        }
        let end = offsets[i + 1u];
        for (var e = offsets[i]; e < end; e++) {
            let t = spring_terms(i, neighbors[e]);
            let along = t.stiff_along + t.damp_along;
            set_term(2u * e, vec4<f32>(t.n, along));
            set_term(2u * e + 1u, vec4<f32>(t.stiff_across, 0.0, 0.0, 0.0));
            block = add_spring_block(block, t);
        }
        inv = invert_block(block);
    }
    let z = block_times(inv, b);
    // δ (DV) keeps the last update until the solve starts (newton_halve_at may halve it).
    set_vector(RESIDUAL, i, vec4<f32>(b, 0.0));
    set_vector(PRECONDITIONED, i, vec4<f32>(z, 0.0));
    set_vector(DIRECTION, i, vec4<f32>(z, 0.0));
    set_vector(DIAGONAL, i, vec4<f32>(inv[0][0], inv[1][1], inv[2][2], inv[0][1]));
    set_vector(DIAGONAL_OFF, i, vec4<f32>(inv[0][2], inv[1][2], 0.0, 0.0));
    var work = 0.0;
    if (HISTORY && mass[i].y != 0.0) {
        let vk = v_in[i].xyz;
        work = -dot(vk, b) - NEWTON_WORK_SHARE * 0.5 * mass[i].x * dot(vk, vk);
    }
    return vec4<f32>(dot(b, z), dot(b, b), dot(hf, hf), work);
}

// The search direction at mass j: p, or (`pending`: the per-pass cg_apply, before cg_advance
// stores it) the next one, z + βp, as cg_direction_at computes it.
fn direction_at(j: u32, beta: f32, pending: bool) -> vec3<f32> {
    if (pending) {
        return (vector_at(PRECONDITIONED, j) + beta * vector_at(DIRECTION, j)).xyz;
    }
    return vector_at(DIRECTION, j).xyz;
}

// `out` plus CSR entry e's spring block times dp, the difference of the operand across it, from
// the terms implicit_rhs_at stored (multigrid.wgsl's products take it too), its two parts added
// to `out` in turn (src/cpu/system_blocks.rs's SpringTerms::add_times): lavapipe's compiler
// adds `out + (a + b)` as `(out + a) + b`, so the sum is written in that order on both backends.
fn add_entry_times(out: vec3<f32>, e: u32, dp: vec3<f32>) -> vec3<f32> {
    let t = term_at(2u * e);
    let stiff_across = term_at(2u * e + 1u).x;
    let dn = dot(t.xyz, dp);
    return out + t.w * dn * t.xyz + stiff_across * (dp - dn * t.xyz);
}

// Ap = (M − h D − h² K) p, pinned rows and columns filtered out, p as direction_at gives it.
// Returns (p·Ap).
fn apply_system_at(i: u32, beta: f32, pending: bool) -> vec4<f32> {
    var out = vec3<f32>(0.0);
    let pi = direction_at(i, beta, pending);
    if (mass[i].y != 0.0) {
        out = own_mass_term(i) * pi;
        let end = offsets[i + 1u];
        for (var e = offsets[i]; e < end; e++) {
            // The terms implicit_rhs_at stored. A pinned neighbour's p is always 0 (its b is 0 and
            // its row is filtered), so its column drops out without reading its mass.
            out = add_entry_times(out, e, pi - direction_at(neighbors[e].other, beta, pending));
        }
        if (has_contact_terms()) {
            out += contact_times(i, pi);
        }
    }
    set_vector(PRODUCT, i, vec4<f32>(out, 0.0));
    return vec4<f32>(dot(pi, out), 0.0, 0.0, 0.0);
}

// δ += α p, r −= α Ap, z = B⁻¹ r. Returns (r·z, r·r).
fn cg_update_at(i: u32, alpha: f32) -> vec4<f32> {
    set_vector(DV, i, vector_at(DV, i) + alpha * vector_at(DIRECTION, i));
    let r = vector_at(RESIDUAL, i).xyz - alpha * vector_at(PRODUCT, i).xyz;
    let z = block_times(block_inverse_at(i), r);
    set_vector(RESIDUAL, i, vec4<f32>(r, 0.0));
    set_vector(PRECONDITIONED, i, vec4<f32>(z, 0.0));
    return vec4<f32>(dot(r, z), dot(r, r), 0.0, 0.0);
}

// p = z + β p.
fn cg_direction_at(i: u32, beta: f32) {
    set_vector(DIRECTION, i, vec4<f32>(direction_at(i, beta, true), 0.0));
}

// Δv += δ. Returns (|δ|, |Δv|), to be maxed.
// Whether the last update left Newton's residual above NEWTON_OVERSHOOT times the one it started
// from (`last`), with fewer than NEWTON_BACKTRACKS halvings of it so far
// (src/cpu/newton_rules.rs's newton_overshot).
fn newton_overshot(residual: f32, last: f32, halvings: u32) -> bool {
    return residual > NEWTON_OVERSHOOT * last && halvings < NEWTON_BACKTRACKS;
}

// Whether a step whose Newton iterations ran out wandered: the last iterate it evaluated
// (residual `last`) more than NEWTON_OVERSHOOT times worse than the best it solved from (`best`,
// F32_MAX while none), so that it ends at the best (src/cpu/newton_rules.rs's newton_wandered).
fn newton_wandered(last: f32, best: f32) -> bool {
    return best < F32_MAX && last > NEWTON_OVERSHOOT * best;
}

// The last update halved: δ ← δ / 2, Δv ← Δv − δ (src/cpu/implicit.rs's newton_halve).
fn newton_halve_at(i: u32) {
    let dv = 0.5 * vector_at(DV, i).xyz;
    set_vector(DV, i, vec4<f32>(dv, 0.0));
    set_vector(DV_TOTAL, i, vec4<f32>(vector_at(DV_TOTAL, i).xyz - dv, 0.0));
}

// A solve starts from δ = 0.
fn solve_begin_at(i: u32) {
    set_vector(DV, i, vec4<f32>(0.0));
}

fn newton_update_at(i: u32) -> vec4<f32> {
    let dv = vector_at(DV, i).xyz;
    let total = vector_at(DV_TOTAL, i).xyz + dv;
    set_vector(DV_TOTAL, i, vec4<f32>(total, 0.0));
    return vec4<f32>(length(dv), length(total), 0.0, 0.0);
}
