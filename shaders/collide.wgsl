// project_contacts: the post-step safeguard against tunnelling. Mirrors src/cpu/collide.rs.

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> colliders: array<Collider>;
@group(0) @binding(2) var<storage, read> mass: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> x: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> v: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> ledger: array<vec4<f32>>;
// [0] masses projected since the counters were last cleared.
@group(0) @binding(6) var<storage, read_write> counters: array<atomic<u32>>;
@group(2) @binding(0) var<uniform> stage: Stage;

struct Body {
    x: vec3<f32>,
    v: vec3<f32>,
    dissipated: f32,
    work: f32,
    count: u32,
}

fn project(b: ptr<function, Body>, m: f32, n: vec3<f32>, depth: f32, max_depth: f32, collider_v: vec3<f32>) {
    if (depth <= max_depth) {
        return;
    }
    (*b).x += n * (depth - max_depth);
    (*b).count += 1u;
    let vn = dot((*b).v - collider_v, n);
    if (vn >= 0.0) {
        return;
    }
    // Perfectly inelastic in the collider's frame: ½ m vn² is dissipated; the kinetic energy's
    // change plus that is the collider's work (zero for a static collider).
    let before = 0.5 * m * dot((*b).v, (*b).v);
    (*b).v -= vn * n;
    let dissipated = 0.5 * m * vn * vn;
    (*b).dissipated += dissipated;
    (*b).work += 0.5 * m * dot((*b).v, (*b).v) - before + dissipated;
}

@compute @workgroup_size(64)
fn project_contacts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count || mass[i].y == 0.0) {
        return;
    }
    let m = mass[i].x;
    var b = Body(x[i].xyz, v[i].xyz, 0.0, 0.0, 0u);
    if (HAS_GROUND) {
        project(&b, m, vec3<f32>(0.0, 1.0, 0.0), params.ground_height - b.x.y, params.ground_max_depth, vec3<f32>(0.0));
    }
    if (HAS_COLLIDERS) {
        for (var k = 0u; k < params.collider_count; k++) {
            let c = colliders[k];
            let pose = stage.poses[k];
            let p = penetration(c, pose.position.xyz, b.x);
            if (p.w > 0.0) {
                project(&b, m, p.xyz, p.w, c.max_depth, pose.velocity.xyz);
            }
        }
    }
    if (b.count > 0u) {
        x[i] = vec4<f32>(b.x, 0.0);
        v[i] = vec4<f32>(b.v, 0.0);
        ledger[i].z += b.dissipated;
        ledger[i].w += b.work;
        atomicAdd(&counters[0], b.count);
    }
}
