// VBD's block solve of one mass (src/cpu/vbd.rs's vbd_solve_mass, operation for operation), which
// vbd.wgsl's vbd_solve_mass (a dispatch per colour and sweep) and vbd_sweeps.wgsl's vbd_sweeps
// (every sweep over every colour in one workgroup) share. The step's start is x, v; the iterate
// x_in, v_in, which vbd_predict (integrate.wgsl) filled.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params mass offsets neighbors x v x_in v_in stage
// #calls mass_force own_block spring_block spring_terms symmetric_block invert_block

fn vbd_solve_mass_at(i: u32) {
    // Pinned masses take no colour; the check keeps a thread from moving one all the same.
    if (mass[i].y == 0.0) { return; }
    let m = mass[i].x;
    let h = stage.dt;
    // The force at the iterate; with IMPLICIT, the contacts' block beside it.
    let mf = mass_force(i);
    let vi = v_in[i].xyz;
    let b = h * m * mf.acc - m * (vi - v[i].xyz);
    var block = own_block(i);
    if (has_contact_terms()) {
        block += symmetric_block(mf.jac_diag, mf.jac_off);
    }
    let end = offsets[i + 1u];
    for (var e = offsets[i]; e < end; e++) {
        block += spring_block(spring_terms(i, neighbors[e]));
    }
    let vn = vi + invert_block(block) * b;
    v_in[i] = vec4<f32>(vn, 0.0);
    x_in[i] = vec4<f32>(x[i].xyz + h * vn, 0.0);
}
