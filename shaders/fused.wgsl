// The fused explicit steps: each thread gathers its mass's force (mass_force.wgsl) at the state
// it reads (x_in, v_in), updates the mass, books its ledger, checks it (state_check.wgsl) and, at
// a step's end, projects it out of the ground and colliders (contact_projection.wgsl), writing the
// new state to x_out, v_out: the neighbours still read the old one, so the state ping-pongs
// between two buffers and no pass but this one touches it. Euler and semi-implicit Euler take one
// dispatch per step (fused_step), Verlet two (drift, kick), RK4 four (one per stage).
//
// A grid body's springs come from its stencil, the others' as compact links (fused_mass.wgsl).
// They serve runs whose springs never change (no plasticity or tearing) and without mass–mass
// contact; src/gpu/plan.rs decides.
//
// Each kernel computes exactly what the general path's passes compute (compute_forces, the update
// kernels of integrate.wgsl, project_contacts), operation for operation and in the same order, so
// the two paths agree bit for bit (tests/gpu_fused.rs).

// Bindings: `Fused` and `FusedMid` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import mass_force state_check contact_projection fused_mass stage_pose stage_step

fn end_pose(k: u32) -> Pose {
    return stage_end.poses[k];
}

// Euler or semi-implicit Euler (SEMI_IMPLICIT), the whole step: compute_forces, euler_update or
// semi_implicit_update, project_contacts.
@compute @workgroup_size(64)
fn fused_step(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    put_step(i, euler_step_of(i, stage.step));
}

// Verlet's first half (verlet_drift): reads the step's start, writes the drifted positions and
// the predicted velocities the kick's forces are evaluated at.
@compute @workgroup_size(64)
fn fused_verlet_drift(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    let vi = v_in[i].xyz;
    let ai = deriv[2u * i].xyz;
    let half_kick = vi + (0.5 * dt) * ai;
    x_out[i] = vec4<f32>(x_in[i].xyz + dt * half_kick, 0.0);
    v_out[i] = vec4<f32>(vi + dt * ai, 0.0);
    sums[3u * i] = vec4<f32>(half_kick, 0.0);
    sums[3u * i + 2u] = deriv[2u * i + 1u];
}

// Verlet's second half: compute_forces at the drifted state, verlet_kick, project_contacts.
@compute @workgroup_size(64)
fn fused_verlet_kick(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let mf = mass_force(i);
    deriv[2u * i] = vec4<f32>(mf.acc, 0.0);
    deriv[2u * i + 1u] = mf.rates;
    let dt = stage.dt;
    let vn = sums[3u * i].xyz + (0.5 * dt) * mf.acc;
    finish_step(i, x_in[i].xyz, vn, ledger[i] + (0.5 * dt) * (sums[3u * i + 2u] + mf.rates), stage.step);
}

// RK4's first stage: compute_forces at the step's start, rk4_begin.
@compute @workgroup_size(64)
fn fused_rk4_begin(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let mf = mass_force(i);
    let dt = stage.dt;
    let xi = x_in[i].xyz;
    let vi = v_in[i].xyz;
    let ai = mf.acc;
    sums[3u * i] = vec4<f32>(vi, 0.0);
    sums[3u * i + 1u] = vec4<f32>(ai, 0.0);
    sums[3u * i + 2u] = mf.rates;
    x_out[i] = vec4<f32>(xi + 0.5 * dt * vi, 0.0);
    v_out[i] = vec4<f32>(vi + 0.5 * dt * ai, 0.0);
}

// RK4's second and third stages: compute_forces at the stage point, rk4_mid.
@compute @workgroup_size(64)
fn fused_rk4_mid(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let mf = mass_force(i);
    let dt = stage.dt;
    let w = stage.weight;
    let vti = v_in[i].xyz;
    let ai = mf.acc;
    sums[3u * i] += vec4<f32>(w * vti, 0.0);
    sums[3u * i + 1u] += vec4<f32>(w * ai, 0.0);
    sums[3u * i + 2u] += w * mf.rates;
    x_out[i] = vec4<f32>(x_base[i].xyz + stage.next_scale * dt * vti, 0.0);
    v_out[i] = vec4<f32>(v_base[i].xyz + stage.next_scale * dt * ai, 0.0);
}

// RK4's last stage: compute_forces at the last stage point, rk4_final (the step's start is the
// state it writes), project_contacts.
@compute @workgroup_size(64)
fn fused_rk4_final(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let mf = mass_force(i);
    let h6 = stage.dt / 6.0;
    let xn = x_out[i].xyz + h6 * (sums[3u * i].xyz + v_in[i].xyz);
    let vn = v_out[i].xyz + h6 * (sums[3u * i + 1u].xyz + mf.acc);
    finish_step(i, xn, vn, ledger[i] + h6 * (sums[3u * i + 2u] + mf.rates), stage.step);
}
