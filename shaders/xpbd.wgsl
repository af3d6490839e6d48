// XPBD's constraint projection of the springs (src/cpu/xpbd.rs): one dispatch per colour and
// sweep, one thread per spring of that colour. The springs of a colour share no movable mass, so
// their threads never write the same displacement, and every thread's arithmetic is the CPU's
// xpbd_solve_spring, operation for operation.

// Bindings: `XpbdSolve` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import xpbd_project

@compute @workgroup_size(64)
fn xpbd_solve_spring(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = thread_index(gid, groups);
    if (t >= colour.count) { return; }
    project_spring(colour_order[colour.start + t], colour.first != 0u);
}
