// project_body: the post-step safeguard against tunnelling for one mass, at the step's end (the
// collider poses come from end_pose(k), which the calling file defines). Mirrors
// src/cpu/collide.rs. Shared by project_contacts (collide.wgsl) and the fused steps (fused.wgsl).
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params colliders
// #calls end_pose

struct Body {
    x: vec3<f32>,
    v: vec3<f32>,
    dissipated: f32,
    work: f32,
    count: u32,
    // Contacts deeper than DEEP_SHARE times their allowed depth (src/cpu/collide.rs's Projected).
    deep: u32,
}


fn project(b: ptr<function, Body>, m: f32, n: vec3<f32>, depth: f32, max_depth: f32, collider_v: vec3<f32>) {
    if (depth <= max_depth) {
        return;
    }
    (*b).x += n * (depth - max_depth);
    (*b).count += 1u;
    if (depth > DEEP_SHARE * max_depth) {
        (*b).deep += 1u;
    }
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

// Mass m at (x, v) pushed out to each contact's allowed depth; count = 0 when nothing moved.
fn project_body(m: f32, x: vec3<f32>, v: vec3<f32>) -> Body {
    var b = Body(x, v, 0.0, 0.0, 0u, 0u);
    if (HAS_GROUND) {
        project(&b, m, vec3<f32>(0.0, 1.0, 0.0), params.ground_height - b.x.y, params.ground_max_depth, vec3<f32>(0.0));
    }
    if (HAS_COLLIDERS) {
        for (var k = 0u; k < params.collider_count; k++) {
            let c = colliders[k];
            let pose = end_pose(k);
            let p = penetration(c, pose.position.xyz, b.x);
            if (p.w > 0.0) {
                project(&b, m, p.xyz, p.w, c.max_depth, pose.velocity.xyz);
            }
        }
    }
    return b;
}
