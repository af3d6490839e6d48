// The fused explicit steps: each thread gathers its mass's force (mass_force.wgsl) at the state
// it reads (x_in, v_in), updates the mass, books its ledger, checks it (state_check.wgsl) and, at
// a step's end, projects it out of the ground and colliders (contact_projection.wgsl), writing the
// new state to x_out, v_out: the neighbours still read the old one, so the state ping-pongs
// between two buffers and no pass but this one touches it. Euler and semi-implicit Euler take one
// dispatch per step (fused_step), Verlet two (drift, kick), RK4 four (one per stage).
//
// The springs come as compact links, one per CSR entry: (other | kind << KIND_SHIFT, rest), the
// stiffness and damping of each kind in a uniform table. They serve runs whose springs never
// change (no plasticity or tearing) and without mass–mass contact; src/gpu/plan.rs decides.
//
// Each kernel computes exactly what the general path's passes compute (compute_forces, the update
// kernels of integrate.wgsl, project_contacts), operation for operation and in the same order, so
// the two paths agree bit for bit (tests/gpu_fused.rs).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> kinds: SpringKinds;
@group(0) @binding(2) var<storage, read> offsets: array<u32>;
@group(0) @binding(3) var<storage, read> links: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read> colliders: array<Collider>;
@group(0) @binding(5) var<storage, read> mass: array<vec2<f32>>;
// Verlet: [2i] a(x_n) and [2i+1] its rates, kept from the last kick for the next drift.
@group(0) @binding(6) var<storage, read_write> deriv: array<vec4<f32>>;
// RK4: [3i] Σ weighted stage velocities, [3i+1] accelerations, [3i+2] rates. Verlet: [3i] the
// half-kicked velocity, [3i+2] a(x_n)'s rates.
@group(0) @binding(7) var<storage, read_write> sums: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> ledger: array<vec4<f32>>;
// [0] masses projected; [1] the divergence flag (check_state).
@group(0) @binding(9) var<storage, read_write> counters: array<atomic<u32>>;
// RK4's middle stages only: the step's starting state, which their stage points start from.
@group(0) @binding(10) var<storage, read> x_base: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> v_base: array<vec4<f32>>;
@group(1) @binding(0) var<storage, read> x_in: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> v_in: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read_write> x_out: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read_write> v_out: array<vec4<f32>>;
@group(2) @binding(0) var<uniform> stage: Stage;
// The step's end slot, whose collider poses the projection uses.
@group(3) @binding(0) var<uniform> stage_end: Stage;

fn spring_end(e: u32) -> SpringEnd {
    let link = links[e];
    let kind = kinds.kind[link.x >> KIND_SHIFT];
    return SpringEnd(link.x & ((1u << KIND_SHIFT) - 1u), bitcast<f32>(link.y), kind.x, kind.y);
}

fn end_pose(k: u32) -> Pose {
    return stage_end.poses[k];
}

// The end of every step: check the new state, project it out of contacts, write it and the
// ledger.
fn finish_step(i: u32, x: vec3<f32>, v: vec3<f32>, ledger_i: vec4<f32>) {
    check_state(x, v);
    var xn = x;
    var vn = v;
    var l = ledger_i;
    if ((HAS_GROUND || HAS_COLLIDERS) && mass[i].y != 0.0) {
        let b = project_body(mass[i].x, x, v);
        if (b.count > 0u) {
            xn = b.x;
            vn = b.v;
            l.z += b.dissipated;
            l.w += b.work;
            atomicAdd(&counters[0], b.count);
        }
    }
    x_out[i] = vec4<f32>(xn, 0.0);
    v_out[i] = vec4<f32>(vn, 0.0);
    ledger[i] = l;
}

// Euler or semi-implicit Euler (SEMI_IMPLICIT), the whole step: compute_forces, euler_update or
// semi_implicit_update, project_contacts.
@compute @workgroup_size(64)
fn fused_step(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let mf = mass_force(i);
    let dt = stage.dt;
    let xi = x_in[i].xyz;
    let vi = v_in[i].xyz;
    var xn: vec3<f32>;
    var vn: vec3<f32>;
    if (SEMI_IMPLICIT) {
        vn = vi + dt * mf.acc;
        xn = xi + dt * vn;
    } else {
        xn = xi + dt * vi;
        vn = vi + dt * mf.acc;
    }
    finish_step(i, xn, vn, ledger[i] + dt * mf.rates);
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
    finish_step(i, x_in[i].xyz, vn, ledger[i] + (0.5 * dt) * (sums[3u * i + 2u] + mf.rates));
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
    finish_step(i, xn, vn, ledger[i] + h6 * (sums[3u * i + 2u] + mf.rates));
}
