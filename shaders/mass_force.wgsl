// forces_on: the full force on one mass (springs, gravity, drag, contact), gathered through the
// CSR adjacency, at the state x_in, v_in; written to deriv as compute_forces' output. Mirrors
// src/cpu/forces.rs. Shared by compute_forces (forces.wgsl) and implicit_step (implicit.wgsl),
// which declare the bindings it reads.

fn forces_on(i: u32) {
    let xi = x_in[i].xyz;
    let vi = v_in[i].xyz;
    let m = mass[i].x;
    var f = vec3<f32>(0.0);
    var damping_w = 0.0;
    // XPBD without dashpots needs nothing of the springs here.
    let end = select(offsets[i + 1u], offsets[i], XPBD && !HAS_DAMPING);
    for (var e = offsets[i]; e < end; e++) {
        let nb = neighbors[e];
        let s = springs[nb.spring];
        // A broken spring exerts nothing; skipping it saves reading the other end.
        if (HAS_TEARING && is_broken(s)) {
            continue;
        }
        let d = xi - x_in[nb.other].xyz;
        let len = length(d);
        if (len <= MIN_SPRING_LENGTH) {
            continue;
        }
        let n = d * (1.0 / len);
        let elastic = -s.stiffness * (len - s.rest);
        if (HAS_DAMPING) {
            let damping = -s.damping * dot(vi - v_in[nb.other].xyz, n);
            if (!XPBD) {
                f += n * (elastic + damping);
            }
            damping_w += damping * dot(n, vi);
        } else if (!XPBD) {
            f += n * elastic;
        }
    }
    if (HAS_GRAVITY) {
        f += m * params.gravity;
    }
    var drag_w = 0.0;
    if (HAS_DRAG) {
        let fd = -m * params.drag_per_s * vi;
        f += fd;
        drag_w = dot(fd, vi);
    }
    var contact_w = 0.0;
    var collider_w = 0.0;
    // Implicit Euler: Σ over contacts of (h²k + h·2ζ√(km)) n nᵀ, as src/cpu/implicit.rs's
    // linearise, stored as (xx, yy, zz, xy) and (xz, yz).
    var jac_diag = vec3<f32>(0.0);
    var jac_off = vec3<f32>(0.0);
    let h = stage.dt;
    if (HAS_GROUND) {
        let depth = params.ground_height - xi.y;
        if (depth > 0.0) {
            let c = contact_force(params.ground_stiffness, params.ground_friction, params.ground_damping_ratio, depth, vec3<f32>(0.0, 1.0, 0.0), vi, f, m, stage.dt, 1.0);
            f += c.force;
            contact_w += c.dissipated;
            if (IMPLICIT) {
                let k = params.ground_stiffness;
                jac_diag.y += h * h * k + h * 2.0 * params.ground_damping_ratio * sqrt(k * m);
            }
        }
    }
    if (HAS_COLLIDERS) {
        for (var k = 0u; k < params.collider_count; k++) {
            let col = colliders[k];
            let pose = stage.poses[k];
            let p = penetration(col, pose.position.xyz, xi);
            if (p.w > 0.0) {
                let n = p.xyz;
                let u = pose.velocity.xyz;
                let c = contact_force(col.stiffness, col.friction, col.damping_ratio, p.w, n, vi - u, f, m, stage.dt, 1.0);
                f += c.force;
                contact_w += c.dissipated;
                collider_w += dot(c.force, u);
                if (IMPLICIT) {
                    let s = h * h * col.stiffness + h * 2.0 * col.damping_ratio * sqrt(col.stiffness * m);
                    jac_diag += s * n * n;
                    jac_off += s * vec3<f32>(n.x * n.y, n.x * n.z, n.y * n.z);
                }
            }
        }
    }
    let w = mass[i].y;
    if (has_contact_terms()) {
        let n2 = 2u * params.mass_count;
        if (w == 0.0) {
            jac_diag = vec3<f32>(0.0);
            jac_off = vec3<f32>(0.0);
        }
        deriv[n2 + 2u * i] = vec4<f32>(jac_diag, 0.0);
        deriv[n2 + 2u * i + 1u] = vec4<f32>(jac_off, 0.0);
    }
    if (w == 0.0) {
        deriv[2u * i] = vec4<f32>(0.0);
        deriv[2u * i + 1u] = vec4<f32>(0.0);
        return;
    }
    deriv[2u * i] = vec4<f32>(f * w, 0.0);
    deriv[2u * i + 1u] = vec4<f32>(-damping_w, -drag_w, contact_w, collider_w);
}
