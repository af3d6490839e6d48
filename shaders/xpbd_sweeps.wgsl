// xpbd_sweeps: XPBD's projection for a small scene, every sweep over every colour in one
// dispatch of one workgroup (src/gpu/dispatch.rs's xpbd_in_one_group), the colours apart by
// barriers; instead of xpbd.wgsl's dispatch per colour and sweep, whose launches would cost more
// than the work. Each spring's arithmetic is the same (xpbd_project.wgsl), and a colour's springs
// share no movable mass, so the result is the per-colour dispatches' (and the CPU's).

// Bindings: `XpbdSweeps` (group 0) and the stage group of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import xpbd_project

// The widest workgroup every adapter allows (WebGPU's default limit): a colour's springs are
// shared among as many invocations as one workgroup can hold.
const SWEEP_GROUP: u32 = 256u;

@compute @workgroup_size(256)
fn xpbd_sweeps(@builtin(local_invocation_index) lid: u32) {
    let sweeps = sweep_plan[0];
    let colours = sweep_plan[1];
    for (var sweep = 0u; sweep < sweeps; sweep++) {
        for (var colour = 0u; colour < colours; colour++) {
            let end = sweep_plan[3u + colour];
            for (var t = sweep_plan[2u + colour] + lid; t < end; t += SWEEP_GROUP) {
                project_spring(colour_order[t], sweep == 0u);
            }
            storageBarrier();
        }
    }
}
