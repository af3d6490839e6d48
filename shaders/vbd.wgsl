// VBD's block solve (src/cpu/vbd.rs's vbd_solve_mass): one dispatch per colour and sweep, one
// thread per mass of that colour. The masses of a colour share no spring, so each thread reads
// neighbours that no thread of the dispatch writes; every thread's arithmetic is the CPU's
// (vbd_mass.wgsl).

// Bindings: `VbdSolve` (group 0) and the stage group of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import vbd_mass mass_force spring_records system_blocks stage_pose

@compute @workgroup_size(64)
fn vbd_solve_mass(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = thread_index(gid, groups);
    if (t >= colour.count) { return; }
    vbd_solve_mass_at(colour_order[colour.start + t]);
}
