// The integrators' update kernels, one per stage of each scheme. Mirrors src/cpu/integrate.rs;
// every stage's derivative comes from compute_forces (forces.wgsl) on the state named there.

// Bindings: `Integrate` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import state_check

fn acc(i: u32) -> vec3<f32> {
    return deriv[2u * i].xyz;
}

fn rate(i: u32) -> vec4<f32> {
    return deriv[2u * i + 1u];
}

@compute @workgroup_size(64)
fn euler_update(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    let vi = v[i].xyz;
    x[i] = vec4<f32>(x[i].xyz + dt * vi, 0.0);
    v[i] = vec4<f32>(vi + dt * acc(i), 0.0);
    ledger[i] += dt * rate(i);
    check_state(x[i].xyz, v[i].xyz);
}

@compute @workgroup_size(64)
fn semi_implicit_update(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    let vn = v[i].xyz + dt * acc(i);
    v[i] = vec4<f32>(vn, 0.0);
    x[i] = vec4<f32>(x[i].xyz + dt * vn, 0.0);
    ledger[i] += dt * rate(i);
    check_state(x[i].xyz, vn);
}

@compute @workgroup_size(64)
fn rk2_stage(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    xt[i] = vec4<f32>(x[i].xyz + 0.5 * dt * v[i].xyz, 0.0);
    vt[i] = vec4<f32>(v[i].xyz + 0.5 * dt * acc(i), 0.0);
}

@compute @workgroup_size(64)
fn rk2_final(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    x[i] = vec4<f32>(x[i].xyz + dt * vt[i].xyz, 0.0);
    v[i] = vec4<f32>(v[i].xyz + dt * acc(i), 0.0);
    ledger[i] += dt * rate(i);
    check_state(x[i].xyz, v[i].xyz);
}

@compute @workgroup_size(64)
fn rk4_begin(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    let xi = x[i].xyz;
    let vi = v[i].xyz;
    let ai = acc(i);
    sums[3u * i] = vec4<f32>(vi, 0.0);
    sums[3u * i + 1u] = vec4<f32>(ai, 0.0);
    sums[3u * i + 2u] = rate(i);
    xt[i] = vec4<f32>(xi + 0.5 * dt * vi, 0.0);
    vt[i] = vec4<f32>(vi + 0.5 * dt * ai, 0.0);
}

// Stages 2 and 3: accumulate this stage with `stage.weight`, then form the next stage point at
// `stage.next_scale` of the step.
@compute @workgroup_size(64)
fn rk4_mid(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    let w = stage.weight;
    let vti = vt[i].xyz;
    let ai = acc(i);
    sums[3u * i] += vec4<f32>(w * vti, 0.0);
    sums[3u * i + 1u] += vec4<f32>(w * ai, 0.0);
    sums[3u * i + 2u] += w * rate(i);
    xt[i] = vec4<f32>(x[i].xyz + stage.next_scale * dt * vti, 0.0);
    vt[i] = vec4<f32>(v[i].xyz + stage.next_scale * dt * ai, 0.0);
}

@compute @workgroup_size(64)
fn rk4_final(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let h6 = stage.dt / 6.0;
    x[i] = vec4<f32>(x[i].xyz + h6 * (sums[3u * i].xyz + vt[i].xyz), 0.0);
    v[i] = vec4<f32>(v[i].xyz + h6 * (sums[3u * i + 1u].xyz + acc(i)), 0.0);
    ledger[i] += h6 * (sums[3u * i + 2u] + rate(i));
    check_state(x[i].xyz, v[i].xyz);
}

// Velocity Verlet as kick-drift-kick, first half: half a kick with a(x_n) (kept from the previous
// step), the drift, a predicted velocity for the velocity-dependent forces, and the half-kicked
// velocity and a(x_n)'s rates kept for the second half. Every update is p + s·q, as on the CPU.
@compute @workgroup_size(64)
fn verlet_drift(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    let vi = v[i].xyz;
    let ai = acc(i);
    let half_kick = vi + (0.5 * dt) * ai;
    x[i] = vec4<f32>(x[i].xyz + dt * half_kick, 0.0);
    vt[i] = vec4<f32>(vi + dt * ai, 0.0);
    sums[3u * i] = vec4<f32>(half_kick, 0.0);
    sums[3u * i + 2u] = rate(i);
}

// Second half, after compute_forces at (x_{n+1}, predicted v).
@compute @workgroup_size(64)
fn verlet_kick(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    v[i] = vec4<f32>(sums[3u * i].xyz + (0.5 * dt) * acc(i), 0.0);
    ledger[i] += (0.5 * dt) * (sums[3u * i + 2u] + rate(i));
    check_state(x[i].xyz, v[i].xyz);
}

// XPBD (src/cpu/xpbd.rs), around the springs' projection in xpbd.wgsl: the kick of every force
// that is not a spring (compute_forces compiled with XPBD) and the predicted displacement, kept
// in xt; then, after the sweeps, the velocity the masses moved with and their new positions.
@compute @workgroup_size(64)
fn xpbd_predict(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    let vn = v[i].xyz + dt * acc(i);
    v[i] = vec4<f32>(vn, 0.0);
    xt[i] = vec4<f32>(dt * vn, 0.0);
    ledger[i] += dt * rate(i);
}

@compute @workgroup_size(64)
fn xpbd_update_velocity(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let d = xt[i].xyz;
    let vn = d / stage.dt;
    v[i] = vec4<f32>(vn, 0.0);
    x[i] = vec4<f32>(x[i].xyz + d, 0.0);
    check_state(x[i].xyz, vn);
}

// VBD (src/cpu/vbd.rs), around the block solves in vbd.wgsl: the first guess, in xt and vt (the
// iterate vbd_solve_mass refines); then, after the sweeps and compute_forces at the iterate, the
// new state and the ledger's rates there. `sums` keeps each mass's velocity at the start of the
// last step (zero before the first), which the guess's acceleration is taken from.
@compute @workgroup_size(64)
fn vbd_predict(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let h = stage.dt;
    var g = vec3<f32>(0.0);
    if (HAS_GRAVITY) {
        g = params.gravity;
    }
    let g_len = length(g);
    var down = vec3<f32>(0.0);
    if (g_len > 0.0) {
        down = g / g_len;
    }
    let v0 = v[i].xyz;
    let fell = clamp(dot(v0 - sums[i].xyz, down) / h, 0.0, g_len);
    let vk = v0 + h * fell * down;
    vt[i] = vec4<f32>(vk, 0.0);
    xt[i] = vec4<f32>(x[i].xyz + h * vk, 0.0);
}

// VBD's step residual (src/cpu/vbd.rs's vbd_residual): each workgroup of vbd_final adds its
// movable masses' |h f − m Δv|² and |h f|² in thread order into sums[n + g] (g its workgroup;
// sums holds 3n vec4s, src/gpu/limits.rs's scratch_bytes), then vbd_residual adds those in
// order and books the step (implicit_terms.wgsl's book_step does for Newton's steps).
var<workgroup> unmet_sh: array<vec2<f32>, WORKGROUP>;

// Mass i's (|h f − m Δv|², |h f|²) over the step that took its velocity from v0 to vn (zero for
// a pinned mass), h f from compute_forces at the step's end.
fn vbd_unmet(i: u32, v0: vec3<f32>, vn: vec3<f32>) -> vec2<f32> {
    let m = mass[i];
    if (m.y == 0.0) {
        return vec2<f32>(0.0);
    }
    let hf = stage.dt * m.x * acc(i);
    let r = hf - m.x * (vn - v0);
    return vec2<f32>(dot(r, r), dot(hf, hf));
}

@compute @workgroup_size(64)
fn vbd_final(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = thread_index(gid, groups);
    var unmet = vec2<f32>(0.0);
    if (i < params.mass_count) {
        let v0 = v[i].xyz;
        sums[i] = v[i];
        let vn = vt[i].xyz;
        v[i] = vec4<f32>(vn, 0.0);
        x[i] = xt[i];
        ledger[i] += stage.dt * rate(i);
        check_state(x[i].xyz, vn);
        unmet = vbd_unmet(i, v0, vn);
    }
    unmet_sh[lid] = unmet;
    workgroupBarrier();
    let g = wid.x + wid.y * groups.x;
    if (lid == 0u && g * WORKGROUP < params.mass_count) {
        var total = vec2<f32>(0.0);
        for (var k = 0u; k < WORKGROUP; k++) {
            total += unmet_sh[k];
        }
        sums[params.mass_count + g] = vec4<f32>(total, 0.0, 0.0);
    }
}

// One workgroup: vbd_final's workgroup sums added (each thread a strided share, then the first
// thread those, always in the same order), the step's residual, and the step booked: the largest
// residual in counters[6], a step above VBD_RESIDUAL counted in counters[5].
@compute @workgroup_size(64)
fn vbd_residual(@builtin(local_invocation_index) lid: u32) {
    let n = params.mass_count;
    let partials = (n + WORKGROUP - 1u) / WORKGROUP;
    var share = vec2<f32>(0.0);
    for (var g = lid; g < partials; g += WORKGROUP) {
        share += sums[n + g].xy;
    }
    unmet_sh[lid] = share;
    workgroupBarrier();
    if (lid == 0u) {
        var total = vec2<f32>(0.0);
        for (var k = 0u; k < WORKGROUP; k++) {
            total += unmet_sh[k];
        }
        var residual = 0.0;
        if (total.y > 0.0) {
            residual = sqrt(total.x / total.y);
        }
        atomicMax(&counters[6], bitcast<u32>(max(residual, 0.0)));
        if (!(residual <= VBD_RESIDUAL)) {
            atomicAdd(&counters[5], 1u);
        }
    }
}
