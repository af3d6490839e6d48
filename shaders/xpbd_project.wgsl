// XPBD's projection of one spring, which xpbd.wgsl's xpbd_solve_spring (a dispatch per colour)
// and xpbd_sweeps.wgsl's xpbd_sweeps (every colour in one workgroup) share.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses springs constants mass x dx lambda

// Spring k's projection (src/cpu/xpbd.rs's xpbd_solve_spring, operation for operation);
// `first`: the substep's first sweep, which starts its multiplier from zero.
fn project_spring(k: u32, first: bool) {
    let s = springs[k];
    let c = constants[k];
    let lambda_k = select(lambda[k], 0.0, first);
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
