// fused_mass: one mass's whole Euler or semi-implicit Euler step on the fused path (its force
// gathered by mass_force, the update, the ledger, the divergence check, the projection out of the
// ground and colliders), reading x_in, v_in and writing x_out, v_out. Shared by fused_step
// (fused.wgsl, a dispatch per step) and fused_frame (fused_frame.wgsl, a submission's steps in one
// workgroup), so that both compute the same bits. Defines spring_end for mass_force: the compact
// links, one per CSR entry, (other | kind << KIND_SHIFT, rest), each kind's stiffness and damping
// in a uniform table.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params kinds links mass x_in v_in x_out v_out ledger counters stage
// #calls mass_force check_state_at project_body

fn spring_end(e: u32) -> SpringEnd {
    let link = links[e];
    let kind = kinds.kind[link.x >> KIND_SHIFT];
    return SpringEnd(link.x & ((1u << KIND_SHIFT) - 1u), bitcast<f32>(link.y), kind.x, kind.y);
}

// The end of every step (`step`: its index in the submission): check the new state, project it
// out of contacts, write it and the ledger.
fn finish_step(i: u32, x: vec3<f32>, v: vec3<f32>, ledger_i: vec4<f32>, step: u32) {
    check_state_at(x, v, step);
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

// Euler or semi-implicit Euler (SEMI_IMPLICIT), mass i's whole step: compute_forces,
// euler_update or semi_implicit_update, project_contacts.
fn euler_step_of(i: u32, step: u32) {
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
    finish_step(i, xn, vn, ledger[i] + dt * mf.rates, step);
}
