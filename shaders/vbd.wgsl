// VBD's block solve (src/cpu/vbd.rs's vbd_solve_mass): one dispatch per colour and sweep, one
// thread per mass of that colour. The masses of a colour share no spring, so each thread reads
// neighbours that no thread of the dispatch writes; every thread's arithmetic is the CPU's.
// The step's start is x, v; the iterate x_in, v_in, which vbd_predict (integrate.wgsl) filled.

// Bindings: `VbdSolve` (group 0) and the stage group of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import mass_force spring_records system_blocks stage_pose

@compute @workgroup_size(64)
fn vbd_solve_mass(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = thread_index(gid, groups);
    if (t >= colour.count) { return; }
    let i = colour_order[colour.start + t];
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
