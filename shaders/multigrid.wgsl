// Aggregation multigrid for implicit Euler's conjugate gradients: the V-cycle of
// src/cpu/multigrid.rs over the coarse levels of src/physics/hierarchy.rs (shared by both
// backends). On the per-pass path a dispatch per level and pass: `level` names the dispatch's
// level (1 the first coarse one; the host binds a window per level). In the one-workgroup step
// (mg_implicit_step, at the end) a loop of the workgroup's threads per level and pass, through
// the same per-node functions (*_at). `mg_topology` holds each level's record and rows
// (src/gpu/multigrid.rs lays them out), `mg_values` each level's blocks and vectors.
//
// Per Newton iteration, after cg_begin: mg_linearise and mg_invert for each level, finest first
// (a level's blocks are sums of the finer level's: the Galerkin product Pᵀ A P without a
// subtraction), then mg_factor inverts the coarsest level's dense system in one workgroup.
// Per CG iteration, after cg_advance (which left r and B⁻¹r, the block-Jacobi z): mg_fine_down
// on the masses (the sweep from zero and the residual after it), mg_restrict down the levels
// (a level's b from the finer level's residual, and its own sweep from zero), mg_solve_coarsest,
// mg_prolong up the levels (the coarser correction, then a sweep), and mg_fine_up on the masses
// (the first level's correction, a sweep, and the partial sums (r·z, r·r) that cg_apply reads,
// as cg_advance's would be). Every kernel of a stopped solve returns at once.
// #import mass_force spring_records state_check system_blocks implicit_terms stage_pose solver_sums implicit_group

// A level's record: words at mg_topology[MG_RECORD_WORDS * level + field] (record 0 describes
// the whole hierarchy: MG_LEVELS, MG_Z0, MG_DENSE, MG_SOLVED). Rows are (rows + 1) word indices
// into mg_topology where each row's entries start; incident entries are pairs (edge, other end).
const MG_RECORD_WORDS: u32 = 16u;
const R_NODES: u32 = 0u;
const R_EDGES: u32 = 1u;
// Each finer node's node here (NONE for a pinned mass, on the first level).
const R_PARENT: u32 = 2u;
const R_MEMBERS: u32 = 3u;
// Each edge's finer edges (on the first level, a CSR entry of the spring at a free end, whose
// terms implicit_rhs_at stored), and each node's finer edges to pinned masses.
const R_EDGE_SOURCES: u32 = 4u;
const R_OWN_SOURCES: u32 = 5u;
const R_INCIDENT: u32 = 6u;
// Where the level's values start in mg_values (vec4s): own, edge and inverted diagonal blocks
// (two vec4s each, symmetric), x (the sweep down), b, y (the result up).
const R_OWN: u32 = 8u;
const R_EDGE: u32 = 9u;
const R_DIAG: u32 = 10u;
const R_X: u32 = 11u;
const R_B: u32 = 12u;
const R_Y: u32 = 13u;
const MG_LEVELS: u32 = 0u;
// Each mass's sweep from zero, ω B⁻¹ r (mg_restrict writes it, mg_fine_up reads it).
const MG_Z0: u32 = 1u;
// The coarsest level's inverse, row-major, after one vec4 whose x is 1 when it holds one.
const MG_DENSE: u32 = 2u;
// 1 when the coarsest level has at most COARSEST_NODES nodes and is solved directly.
const MG_SOLVED: u32 = 3u;
const NONE: u32 = 0xffffffffu;
const COARSEST_UNKNOWNS: u32 = 48u;

fn rec(k: u32, field: u32) -> u32 {
    return mg_topology[MG_RECORD_WORDS * k + field];
}

// Row r of the rows `field` of level k: where its entries start and end.
fn rows_of(k: u32, field: u32, r: u32) -> vec2<u32> {
    let at = rec(k, field) + r;
    return vec2<u32>(mg_topology[at], mg_topology[at + 1u]);
}

fn sym_at(at: u32) -> mat3x3<f32> {
    let d = mg_values[at];
    let o = mg_values[at + 1u];
    return symmetric_block(d.xyz, vec3<f32>(d.w, o.x, o.y));
}

fn set_sym(at: u32, m: mat3x3<f32>) {
    mg_values[at] = vec4<f32>(m[0][0], m[1][1], m[2][2], m[0][1]);
    mg_values[at + 1u] = vec4<f32>(m[0][2], m[1][2], 0.0, 0.0);
}

fn value_at(k: u32, field: u32, n: u32) -> vec3<f32> {
    return mg_values[rec(k, field) + n].xyz;
}

fn set_value(k: u32, field: u32, n: u32, value: vec3<f32>) {
    mg_values[rec(k, field) + n] = vec4<f32>(value, 0.0);
}

// ---- the blocks, per Newton iteration ----

// A CSR entry's spring block, from the terms implicit_rhs_at stored (add_spring_block's).
fn entry_block(e: u32) -> mat3x3<f32> {
    let t = term_at(2u * e);
    let a = term_at(2u * e + 1u).x;
    let across = mat3x3<f32>(vec3<f32>(a, 0.0, 0.0), vec3<f32>(0.0, a, 0.0), vec3<f32>(0.0, 0.0, a));
    return outer(t.xyz) * (t.w - a) + across;
}

// A free mass's own block: mass, drag and contacts, without its springs
// (src/cpu/implicit.rs's own_and_contacts).
fn mass_own_block(m: u32) -> mat3x3<f32> {
    var block = own_block(m);
    if (has_contact_terms()) {
        let n2 = 2u * params.mass_count;
        block += symmetric_block(deriv[n2 + 2u * m].xyz, deriv[n2 + 2u * m + 1u].xyz);
    }
    return block;
}

// The finer level's own block of node m and edge block of edge f, seen from level k.
fn finer_own(k: u32, m: u32) -> mat3x3<f32> {
    if (k == 1u) {
        return mass_own_block(m);
    }
    return sym_at(rec(k - 1u, R_OWN) + 2u * m);
}

fn finer_edge(k: u32, f: u32) -> mat3x3<f32> {
    if (k == 1u) {
        return entry_block(f);
    }
    return sym_at(rec(k - 1u, R_EDGE) + 2u * f);
}

fn solve_running() -> bool {
    return scratch.solver.cg_active != 0u;
}

// The node of the dispatch's level this thread works on, or NONE (past the level's nodes, or
// the solve has stopped).
fn level_node(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    let n = thread_index(gid, groups);
    if (!solve_running() || n >= rec(level.level, R_NODES)) {
        return NONE;
    }
    return n;
}

// Level k's blocks from the finer level's (aggregates.rs's Level::linearise): edge t the sum of
// its finer edges, node t the sum of its members' own blocks and its springs to pinned masses.
fn linearise_at(k: u32, t: u32) {
    if (t < rec(k, R_EDGES)) {
        let r = rows_of(k, R_EDGE_SOURCES, t);
        var block = mat3x3<f32>();
        for (var s = r.x; s < r.y; s++) {
            block += finer_edge(k, mg_topology[s]);
        }
        set_sym(rec(k, R_EDGE) + 2u * t, block);
    }
    if (t < rec(k, R_NODES)) {
        let members = rows_of(k, R_MEMBERS, t);
        var own = mat3x3<f32>();
        for (var s = members.x; s < members.y; s++) {
            own += finer_own(k, mg_topology[s]);
        }
        let sources = rows_of(k, R_OWN_SOURCES, t);
        for (var s = sources.x; s < sources.y; s++) {
            own += finer_edge(k, mg_topology[s]);
        }
        set_sym(rec(k, R_OWN) + 2u * t, own);
    }
}

// A thread an edge and a node of the dispatch's level.
@compute @workgroup_size(64)
fn mg_linearise(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    if (!solve_running()) {
        return;
    }
    linearise_at(level.level, thread_index(gid, groups));
}

// Level k's inverted diagonal block of node n: its own block and its edges'.
fn invert_at(k: u32, n: u32) {
    var diag = sym_at(rec(k, R_OWN) + 2u * n);
    let r = rows_of(k, R_INCIDENT, n);
    for (var s = r.x; s < r.y; s += 2u) {
        diag += sym_at(rec(k, R_EDGE) + 2u * mg_topology[s]);
    }
    set_sym(rec(k, R_DIAG) + 2u * n, invert_block(diag));
}

@compute @workgroup_size(64)
fn mg_invert(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let n = level_node(gid, groups);
    if (n != NONE) {
        invert_at(level.level, n);
    }
}

var<workgroup> dense_sh: array<f32, 2304>;
var<workgroup> pivot_row_sh: array<f32, COARSEST_UNKNOWNS>;
var<workgroup> pivot_col_sh: array<f32, COARSEST_UNKNOWNS>;

// The coarsest level k's dense system (3 unknowns a node), inverted in place by Gauss–Jordan
// elimination without pivoting (its pivots are positive: the system is symmetric positive
// definite), by one workgroup of `threads` threads. The CPU factors it by Cholesky in f64
// instead; a pivot that is not positive and finite here leaves the level to a sweep
// (solve_coarsest), as a factor that fails does there. Call from uniform control flow.
fn factor_coarsest(lid: u32, threads: u32, k: u32) {
    let nodes = rec(k, R_NODES);
    let n = 3u * nodes;
    // Row p of nodes p: its own block and its edges' on the diagonal, minus each edge's
    // towards its other end.
    for (var p = lid; p < nodes; p += threads) {
        for (var c = 0u; c < n; c++) {
            for (var a = 0u; a < 3u; a++) {
                dense_sh[(3u * p + a) * n + c] = 0.0;
            }
        }
        var diag = sym_at(rec(k, R_OWN) + 2u * p);
        let r = rows_of(k, R_INCIDENT, p);
        for (var s = r.x; s < r.y; s += 2u) {
            let edge = sym_at(rec(k, R_EDGE) + 2u * mg_topology[s]);
            diag += edge;
            let q = mg_topology[s + 1u];
            for (var a = 0u; a < 3u; a++) {
                for (var b = 0u; b < 3u; b++) {
                    dense_sh[(3u * p + a) * n + 3u * q + b] = -edge[b][a];
                }
            }
        }
        for (var a = 0u; a < 3u; a++) {
            for (var b = 0u; b < 3u; b++) {
                dense_sh[(3u * p + a) * n + 3u * p + b] = diag[b][a];
            }
        }
    }
    var failed = false;
    for (var p = 0u; p < n; p++) {
        workgroupBarrier();
        let pivot = dense_sh[p * n + p];
        failed = failed || !(pivot > 0.0 && pivot <= F32_MAX);
        for (var t = lid; t < n; t += threads) {
            pivot_col_sh[t] = dense_sh[t * n + p];
            pivot_row_sh[t] = select(dense_sh[p * n + t], 1.0, t == p) / pivot;
        }
        workgroupBarrier();
        for (var e = lid; e < n * n; e += threads) {
            let i = e / n;
            let j = e % n;
            if (i == p) {
                dense_sh[e] = pivot_row_sh[j];
            } else {
                dense_sh[e] = select(dense_sh[e], 0.0, j == p) - pivot_col_sh[i] * pivot_row_sh[j];
            }
        }
    }
    workgroupBarrier();
    let at = rec(0u, MG_DENSE);
    if (lid == 0u) {
        mg_values[at] = vec4<f32>(select(1.0, 0.0, failed), 0.0, 0.0, 0.0);
    }
    for (var e = lid; e < n * n; e += threads) {
        mg_values[at + 1u + e / 4u][e % 4u] = dense_sh[e];
    }
}

@compute @workgroup_size(64)
fn mg_factor(@builtin(local_invocation_index) lid: u32) {
    if (uniform_status(lid, false).cg_active == 0u || rec(0u, MG_SOLVED) == 0u) {
        return;
    }
    factor_coarsest(lid, WORKGROUP, level.level);
}

// ---- the cycle, per CG iteration ----

// The operand of the fine level's product at mass j: on the way down, the sweep from zero
// ω B⁻¹ r (B⁻¹ r is cg_advance's z); on the way up, that sweep with the first level's correction.
// A pinned mass's is 0 (its r is 0; it has no node).
fn fine_operand(j: u32, up: bool) -> vec3<f32> {
    if (!up) {
        return MG_SMOOTHING * vector_at(PRECONDITIONED, j).xyz;
    }
    var w = mg_values[rec(0u, MG_Z0) + j].xyz;
    let parent = mg_topology[rec(1u, R_PARENT) + j];
    if (parent != NONE) {
        w += value_at(1u, R_Y, parent);
    }
    return w;
}

// The system's product at mass i with fine_operand (apply_system_at's, pinned rows and columns
// filtered out).
fn fine_product(i: u32, up: bool) -> vec3<f32> {
    if (mass[i].y == 0.0) {
        return vec3<f32>(0.0);
    }
    let pi = fine_operand(i, up);
    var out = own_mass_term(i) * pi;
    let end = offsets[i + 1u];
    for (var e = offsets[i]; e < end; e++) {
        out = add_entry_times(out, e, pi - fine_operand(neighbors[e].other, up));
    }
    if (has_contact_terms()) {
        out += contact_times(i, pi);
    }
    return out;
}

// Level k's product at node n with x on the way down (y absent) or, on the way up, x plus the
// coarser level's result (`up`): its own block, and each edge's on the difference across it.
fn coarse_operand(k: u32, n: u32, up: bool) -> vec3<f32> {
    var x = value_at(k, R_X, n);
    if (up) {
        x += value_at(k + 1u, R_Y, mg_topology[rec(k + 1u, R_PARENT) + n]);
    }
    return x;
}

fn coarse_product(k: u32, n: u32, up: bool) -> vec3<f32> {
    let xn = coarse_operand(k, n, up);
    var out = sym_at(rec(k, R_OWN) + 2u * n) * xn;
    let r = rows_of(k, R_INCIDENT, n);
    for (var s = r.x; s < r.y; s += 2u) {
        let edge = sym_at(rec(k, R_EDGE) + 2u * mg_topology[s]);
        out += edge * (xn - coarse_operand(k, mg_topology[s + 1u], up));
    }
    return out;
}

// The fine level's sweep from zero at mass i, kept for mg_fine_up, and the residual after it,
// kept in the product's vector (free between a CG iteration's update and its next product). A
// pass over the masses of its own, so that no thread walks all of a node's members' springs.
fn fine_down_at(i: u32) {
    mg_values[rec(0u, MG_Z0) + i] = vec4<f32>(fine_operand(i, false), 0.0);
    set_vector(PRODUCT, i, vec4<f32>(vector_at(RESIDUAL, i).xyz - fine_product(i, false), 0.0));
}

// The finer level's residual after its sweep from zero, at its node m (level k's member).
fn finer_residual(k: u32, m: u32) -> vec3<f32> {
    if (k == 1u) {
        return vector_at(PRODUCT, m).xyz;
    }
    return value_at(k - 1u, R_B, m) - coarse_product(k - 1u, m, false);
}

// The cycle's start on the masses, over the solver's grid.
@compute @workgroup_size(SOLVER_THREADS)
fn mg_fine_down(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!solve_running()) {
        return;
    }
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        fine_down_at(i);
    }
}

// Level k's b at node n, the sum of its members' residuals (restrict), and its sweep from zero,
// ω D⁻¹ b.
fn restrict_at(k: u32, n: u32) {
    var b = vec3<f32>(0.0);
    let members = rows_of(k, R_MEMBERS, n);
    for (var s = members.x; s < members.y; s++) {
        b += finer_residual(k, mg_topology[s]);
    }
    set_value(k, R_B, n, b);
    set_value(k, R_X, n, MG_SMOOTHING * (sym_at(rec(k, R_DIAG) + 2u * n) * b));
}

@compute @workgroup_size(64)
fn mg_restrict(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let n = level_node(gid, groups);
    if (n != NONE) {
        restrict_at(level.level, n);
    }
}

// The coarsest level k's result: its inverse times b, or (too large to solve, or its inverse
// failed) its sweep from zero. A thread a node, of `threads`.
fn solve_coarsest(lid: u32, threads: u32, k: u32) {
    let nodes = rec(k, R_NODES);
    let n = 3u * nodes;
    let at = rec(0u, MG_DENSE);
    let direct = rec(0u, MG_SOLVED) != 0u && mg_values[at].x == 1.0;
    for (var p = lid; p < nodes; p += threads) {
        if (!direct) {
            set_value(k, R_Y, p, value_at(k, R_X, p));
            continue;
        }
        var y = vec3<f32>(0.0);
        for (var c = 0u; c < n; c++) {
            let bc = value_at(k, R_B, c / 3u)[c % 3u];
            for (var a = 0u; a < 3u; a++) {
                let e = (3u * p + a) * n + c;
                y[a] += mg_values[at + 1u + e / 4u][e % 4u] * bc;
            }
        }
        set_value(k, R_Y, p, y);
    }
}

@compute @workgroup_size(64)
fn mg_solve_coarsest(@builtin(local_invocation_index) lid: u32) {
    if (solve_running()) {
        solve_coarsest(lid, WORKGROUP, level.level);
    }
}

// Level k's result at node n on the way up: x plus the coarser correction, then a sweep on the
// residual.
fn prolong_at(k: u32, n: u32) {
    let x = coarse_operand(k, n, true);
    let r = value_at(k, R_B, n) - coarse_product(k, n, true);
    set_value(k, R_Y, n, x + MG_SMOOTHING * block_times(sym_at(rec(k, R_DIAG) + 2u * n), r));
}

@compute @workgroup_size(64)
fn mg_prolong(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let n = level_node(gid, groups);
    if (n != NONE) {
        prolong_at(level.level, n);
    }
}

// The cycle's end at mass i: z = the sweep from zero plus the first level's correction, then a
// sweep on the residual. Returns (r·z, r·r), as cg_update_at does.
fn fine_up_at(i: u32) -> vec4<f32> {
    let w = fine_operand(i, true);
    let r = vector_at(RESIDUAL, i).xyz;
    let z = w + MG_SMOOTHING * block_times(block_inverse_at(i), r - fine_product(i, true));
    set_vector(PRECONDITIONED, i, vec4<f32>(z, 0.0));
    return vec4<f32>(dot(r, z), dot(r, r), 0.0, 0.0);
}

// The cycle's end on the masses, with partials (r·z, r·r) for cg_apply over the solver's grid.
@compute @workgroup_size(SOLVER_THREADS)
fn mg_fine_up(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    if (uniform_status(lid, false).cg_active == 0u) {
        return;
    }
    var partial = vec4<f32>(0.0);
    for (var i = gid.x; i < params.mass_count; i += solver_groups() * SOLVER_THREADS) {
        partial += fine_up_at(i);
    }
    store_grid_partial(lid, wid.x, RHS_SUMS, partial, false);
}

// ---- the whole step in one workgroup (implicit_group.wgsl), its CG preconditioned by the cycle ----
// The same passes in the same order as on the per-pass path, each a loop of the workgroup's
// threads over a level's nodes, with a barrier where a dispatch would end.

// Between the cycle's passes: the levels live in storage, the masses' vectors perhaps in
// workgroup memory.
fn cycle_barrier() {
    storageBarrier();
    if (SOLVER_IN_WORKGROUP) {
        workgroupBarrier();
    }
}

// The levels' blocks at the Newton iterate (each level's, then the coarsest's inverse), the
// cycle's z on implicit_rhs_at's residual, and p = z. Returns r·z.
fn group_cg_start(lid: u32, rz: f32) -> f32 {
    let levels = rec(0u, MG_LEVELS);
    // Every mass's spring terms and contact blocks are written.
    cycle_barrier();
    for (var k = 1u; k <= levels; k++) {
        let threads = max(rec(k, R_NODES), rec(k, R_EDGES));
        for (var t = lid; t < threads; t += GROUP_THREADS) {
            linearise_at(k, t);
        }
        storageBarrier();
        for (var n = lid; n < rec(k, R_NODES); n += GROUP_THREADS) {
            invert_at(k, n);
        }
    }
    storageBarrier();
    if (rec(0u, MG_SOLVED) != 0u) {
        factor_coarsest(lid, GROUP_THREADS, levels);
    }
    let sums = group_cg_sums(lid, vec4<f32>(0.0));
    for (var i = lid; i < params.mass_count; i += GROUP_THREADS) {
        cg_direction_at(i, 0.0);
    }
    return sums.x;
}

// One V-cycle on the residual cg_update_at (or implicit_rhs_at) left: z for every mass. Returns
// the workgroup's (r·z, r·r).
fn group_cg_sums(lid: u32, partial: vec4<f32>) -> vec4<f32> {
    let levels = rec(0u, MG_LEVELS);
    // Every mass's r and block-Jacobi z are written.
    cycle_barrier();
    for (var i = lid; i < params.mass_count; i += GROUP_THREADS) {
        fine_down_at(i);
    }
    for (var k = 1u; k <= levels; k++) {
        cycle_barrier();
        for (var n = lid; n < rec(k, R_NODES); n += GROUP_THREADS) {
            restrict_at(k, n);
        }
    }
    storageBarrier();
    solve_coarsest(lid, GROUP_THREADS, levels);
    for (var k = levels; k > 1u; k--) {
        storageBarrier();
        for (var n = lid; n < rec(k - 1u, R_NODES); n += GROUP_THREADS) {
            prolong_at(k - 1u, n);
        }
    }
    storageBarrier();
    var sums = vec4<f32>(0.0);
    for (var i = lid; i < params.mass_count; i += GROUP_THREADS) {
        sums += fine_up_at(i);
    }
    return group_reduce(lid, sums, false);
}

@compute @workgroup_size(GROUP_THREADS)
fn mg_implicit_step(@builtin(local_invocation_index) lid: u32) {
    step_in_group(lid);
}
