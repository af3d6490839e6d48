// fused_frame: a small scene's Euler or semi-implicit Euler steps, every step of a submission in
// one dispatch of one workgroup (src/gpu/plan.rs's ExplicitPath::InGroup), instead of fused.wgsl's
// dispatch per step: for a few thousand masses a launch costs more than the step's work. Each
// mass's step is fused_step's (fused_mass.wgsl), so the two agree bit for bit.
//
// The state lives in A (x_in, v_in) between steps: each step writes B (x_out, v_out), and once
// every thread has read A for its gathers, copies its masses back to A. Storage barriers keep the
// phases apart; WGSL has no barrier across workgroups, hence one workgroup.
//
// Only runs whose colliders stand still take this path: every stage of the submission has the
// poses of its first, which the projection reads here (end_pose).

// Bindings: `FusedFrame` (group 0) and the stage group of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import mass_force state_check contact_projection fused_mass

fn end_pose(k: u32) -> Pose {
    return stage.poses[k];
}

@compute @workgroup_size(FRAME_THREADS)
fn fused_frame(@builtin(local_invocation_index) lid: u32) {
    let n = params.mass_count;
    for (var k = 0u; k < stage.steps; k++) {
        for (var i = lid; i < n; i += FRAME_THREADS) {
            euler_step_of(i, stage.step + k);
        }
        storageBarrier();
        for (var i = lid; i < n; i += FRAME_THREADS) {
            x_in[i] = x_out[i];
            v_in[i] = v_out[i];
        }
        storageBarrier();
    }
}
