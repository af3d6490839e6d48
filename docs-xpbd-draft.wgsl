// XPBD (src/xpbd.rs): predict, per-colour spring projection on displacements, velocity update,
// and the dashpots' dissipation. Draft: bindings follow whatever gpu/ table lands.

// xpbd_predict: v += dt · a_ext (compute_forces run with springs off), dx = dt · v.
@compute @workgroup_size(64)
fn xpbd_predict(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let dt = stage.dt;
    let vn = v[i].xyz + dt * acc(i);
    v[i] = vec4<f32>(vn, 0.0);
    dx[i] = vec4<f32>(dt * vn, 0.0);
    ledger[i] += dt * rate(i);
}

// xpbd_solve_spring: one spring of the current colour (colour_order[range.start + t]).
@compute @workgroup_size(64)
fn xpbd_solve_spring(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = thread_index(gid, groups);
    if (t >= colour.count) { return; }
    let k = colour_order[colour.start + t];
    let s = springs[k];
    let c = constants[k];
    let wa = mass[s.a].y;
    let wb = mass[s.b].y;
    let w = wa + wb;
    if (is_broken(s) || w == 0.0 || c.alpha_tilde == 0.0) { return; }
    let moved = dx[s.a].xyz - dx[s.b].xyz;
    let d = (x[s.a].xyz - x[s.b].xyz) + moved;
    let len = length(d);
    if (len <= MIN_SPRING_LENGTH) { return; }
    let n = d * (1.0 / len);
    let numerator = -(len - s.rest) - c.alpha_tilde * lambda[k] - c.gamma * dot(n, moved);
    let dl = numerator / ((1.0 + c.gamma) * w + c.alpha_tilde);
    lambda[k] += dl;
    dx[s.a] = vec4<f32>(dx[s.a].xyz + (wa * dl) * n, 0.0);
    dx[s.b] = vec4<f32>(dx[s.b].xyz - (wb * dl) * n, 0.0);
}

// xpbd_update_velocity: v = dx / dt, x += dx for movable masses.
@compute @workgroup_size(64)
fn xpbd_update_velocity(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    if (mass[i].y > 0.0) {
        let d = dx[i].xyz;
        v[i] = vec4<f32>(d / stage.dt, 0.0);
        x[i] = vec4<f32>(x[i].xyz + d, 0.0);
    }
    check_state(x[i].xyz, v[i].xyz);
}
