// vbd_sweeps: VBD's block solves for a small scene, every sweep over every colour in one dispatch
// of one workgroup (src/gpu/dispatch.rs's vbd_in_one_group), the colours apart by barriers;
// instead of vbd.wgsl's dispatch per colour and sweep, whose launches and cold loads would cost
// more than the work. Each mass's arithmetic is the same (vbd_mass.wgsl), and a colour's masses
// share no spring, so the result is the per-colour dispatches' (and the CPU's), bit for bit.

// Bindings: `VbdSweeps` (group 0) and the stage group of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import vbd_mass mass_force spring_records system_blocks stage_pose

@compute @workgroup_size(VBD_THREADS)
fn vbd_sweeps(@builtin(local_invocation_index) lid: u32) {
    let sweeps = sweep_plan[0];
    let colours = sweep_plan[1];
    for (var sweep = 0u; sweep < sweeps; sweep++) {
        for (var colour = 0u; colour < colours; colour++) {
            let end = sweep_plan[3u + colour];
            for (var t = sweep_plan[2u + colour] + lid; t < end; t += VBD_THREADS) {
                vbd_solve_mass_at(colour_order[t]);
            }
            storageBarrier();
        }
    }
}
