// XPBD's constraint projection of the springs (src/cpu/xpbd.rs): one dispatch per colour and
// sweep, one thread per spring of that colour. The springs of a colour share no movable mass, so
// their threads never write the same displacement, and every thread's arithmetic is the CPU's
// xpbd_solve_spring, operation for operation.

// Bindings: `XpbdSolve` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.

@compute @workgroup_size(64)
fn xpbd_solve_spring(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = thread_index(gid, groups);
    if (t >= colour.count) { return; }
    let k = colour_order[colour.start + t];
    let s = springs[k];
    let c = constants[k];
    let lambda_k = select(lambda[k], 0.0, colour.first != 0u);
    let wa = mass[s.a].y;
    let wb = mass[s.b].y;
    let w = wa + wb;
    if (is_broken(s) || w == 0.0 || c.alpha_tilde == 0.0) {
        lambda[k] = lambda_k;
        return;
    }
    // Relative motion since the substep's start: the damping term's argument.
    let moved = dx[s.a].xyz - dx[s.b].xyz;
    let d = (x[s.a].xyz - x[s.b].xyz) + moved;
    let len = length(d);
    if (len <= MIN_SPRING_LENGTH) {
        lambda[k] = lambda_k;
        return;
    }
    let n = d * (1.0 / len);
    let numerator = -(len - s.rest) - c.alpha_tilde * lambda_k - c.gamma * dot(n, moved);
    let dl = numerator / ((1.0 + c.gamma) * w + c.alpha_tilde);
    lambda[k] = lambda_k + dl;
    // A pinned end is never written: springs of one colour may share it.
    if (wa > 0.0) {
        dx[s.a] = vec4<f32>(dx[s.a].xyz + (wa * dl) * n, 0.0);
    }
    if (wb > 0.0) {
        dx[s.b] = vec4<f32>(dx[s.b].xyz - (wb * dl) * n, 0.0);
    }
}
