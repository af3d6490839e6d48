// project_contacts: the post-step safeguard against tunnelling, over every mass (the law is
// project_body, contact_projection.wgsl). Mirrors src/cpu/collide.rs.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> colliders: array<Collider>;
@group(0) @binding(2) var<storage, read> mass: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> x: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> v: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> ledger: array<vec4<f32>>;
// [0] masses projected since the counters were last cleared.
@group(0) @binding(6) var<storage, read_write> counters: array<atomic<u32>>;
// Dispatched at the step's end slot.
@group(2) @binding(0) var<uniform> stage: Stage;

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
    }
}
