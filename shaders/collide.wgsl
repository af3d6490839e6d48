// project_contacts: the post-step safeguard against tunnelling, over every mass (the law is
// project_body, contact_projection.wgsl). Mirrors src/cpu/collide.rs.

// Bindings: `Collide` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import contact_projection

fn end_pose(k: u32) -> Pose {
    return stage.poses[k];
}

@compute @workgroup_size(64)
fn project_contacts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count || mass[i].y == 0.0) {
        return;
    }
    let b = project_body(mass[i].x, x[i].xyz, v[i].xyz);
    if (b.count > 0u) {
        x[i] = vec4<f32>(b.x, 0.0);
        v[i] = vec4<f32>(b.v, 0.0);
        ledger[i].z += b.dissipated;
        ledger[i].w += b.work;
        atomicAdd(&counters[0], b.count);
        if (b.deep > 0u) {
            atomicAdd(&counters[7], b.deep);
        }
    }
}
