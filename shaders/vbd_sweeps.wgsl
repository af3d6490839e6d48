// vbd_sweeps: VBD's block solves for a small scene, every sweep over every colour in one dispatch
// of one workgroup (src/gpu/dispatch.rs's vbd_in_one_group), the colours apart by barriers;
// instead of vbd.wgsl's dispatch per colour and sweep, whose launches would cost more than the
// work. VBD_LANES threads share each mass (vbd_mass.wgsl), and a colour's masses share no spring,
// so the result is the per-colour dispatches', bit for bit.

// Bindings: `VbdSweeps` (group 0) and the stage group of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import vbd_mass mass_force spring_records system_blocks stage_pose stage_step

// Each thread's share, for the first lane of its mass to add.
var<workgroup> share_sh: array<VbdShare, VBD_THREADS>;

@compute @workgroup_size(VBD_THREADS)
fn vbd_sweeps(@builtin(local_invocation_index) lid: u32) {
    let sweeps = sweep_plan[0];
    let colours = sweep_plan[1];
    let slot = lid / VBD_LANES;
    let lane = lid % VBD_LANES;
    let per_round = VBD_THREADS / VBD_LANES;
    for (var sweep = 0u; sweep < sweeps; sweep++) {
        for (var colour = 0u; colour < colours; colour++) {
            let start = sweep_plan[2u + colour];
            let end = sweep_plan[3u + colour];
            // A round solves per_round masses of the colour; every thread takes part in each.
            for (var first = start; first < end; first += per_round) {
                let t = first + slot;
                let i = colour_order[min(t, end - 1u)];
                var share = vbd_no_share();
                if (t < end) {
                    share = vbd_share(i, lane);
                }
                share_sh[lid] = share;
                workgroupBarrier();
                if (lane == 0u && t < end) {
                    var all = share_sh[lid];
                    for (var l = 1u; l < VBD_LANES; l++) {
                        all = vbd_add_share(all, share_sh[lid + l]);
                    }
                    vbd_finish(i, all);
                }
                // The next round's shares overwrite this one's.
                workgroupBarrier();
            }
            storageBarrier();
        }
    }
}
