// VBD's block solve (src/cpu/vbd.rs's vbd_solve_mass): one dispatch per colour and sweep,
// VBD_LANES threads per mass of that colour, a workgroup holding whole masses. The masses of a
// colour share no spring, so each thread reads neighbours that no thread of the dispatch writes
// (vbd_mass.wgsl holds the arithmetic).

// Bindings: `VbdSolve` (group 0) and the stage group of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import vbd_mass mass_force spring_records system_blocks stage_pose stage_step

// Each thread's share, for the first lane of its mass to add.
var<workgroup> share_sh: array<VbdShare, WORKGROUP>;

@compute @workgroup_size(64)
fn vbd_solve_mass(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let t = thread_index(gid, groups) / VBD_LANES;
    let lane = lid % VBD_LANES;
    let i = colour_order[colour.start + min(t, colour.count - 1u)];
    // Every thread reaches the barrier; those past the colour's end share nothing.
    var share = vbd_no_share();
    if (t < colour.count) {
        share = vbd_share(i, lane);
    }
    share_sh[lid] = share;
    workgroupBarrier();
    if (lane == 0u && t < colour.count) {
        var all = share_sh[lid];
        for (var l = 1u; l < VBD_LANES; l++) {
            all = vbd_add_share(all, share_sh[lid + l]);
        }
        vbd_finish(i, all);
    }
}
