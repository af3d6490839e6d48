// mass_force: the full force on one mass (springs, gravity, drag, contact) at the state x_in,
// v_in (or, in fused_frame, its copy in workgroup memory: x_at, v_at), as its acceleration and
// the ledger's rates; forces_on writes it to deriv as compute_forces' output. Mirrors
// src/cpu/forces.rs. Shared by compute_forces (forces.wgsl), implicit_step (implicit.wgsl) and the
// fused steps (fused_mass.wgsl), which define spring_range(i) and spring_end(i, e), mass i's
// springs in their own layout of the springs.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params colliders mass deriv x_in v_in stage
// #calls spring_range spring_end collider_pose solve_dt

// fused_frame's state in workgroup memory (STATE_IN_WORKGROUP): two halves, the step's and the
// next's, each WORKGROUP_MASSES masses of six words (x, then v). A load from workgroup memory
// costs an SM tens of cycles, one from a storage buffer written by the step before hundreds:
// a small scene's step is a chain of such loads. Elsewhere the array is one unused word.
var<workgroup> state_sh: array<f32, WORKGROUP_STATE_WORDS>;
// The half the step under way reads.
var<private> state_half: u32;

fn state_word(half: u32, i: u32) -> u32 {
    return (half * WORKGROUP_MASSES + i) * 6u;
}

fn x_at(i: u32) -> vec3<f32> {
    if (STATE_IN_WORKGROUP) {
        let w = state_word(state_half, i);
        return vec3<f32>(state_sh[w], state_sh[w + 1u], state_sh[w + 2u]);
    }
    return x_in[i].xyz;
}

fn v_at(i: u32) -> vec3<f32> {
    if (STATE_IN_WORKGROUP) {
        let w = state_word(state_half, i) + 3u;
        return vec3<f32>(state_sh[w], state_sh[w + 1u], state_sh[w + 2u]);
    }
    return v_in[i].xyz;
}

struct MassForce {
    acc: vec3<f32>,
    // Ledger rates: damping, drag, contact, collider work.
    rates: vec4<f32>,
    // Implicit Euler: Σ over contacts of (h²k + h·2ζ√(km)) n nᵀ, as src/cpu/implicit.rs's
    // linearise, stored as (xx, yy, zz) and (xy, xz, yz).
    jac_diag: vec3<f32>,
    jac_off: vec3<f32>,
}

fn mass_force(i: u32) -> MassForce {
    let xi = x_at(i);
    let vi = v_at(i);
    var f = vec3<f32>(0.0);
    var damping_w = 0.0;
    // XPBD without dashpots needs nothing of the springs here.
    let range = spring_range(i);
    let end = select(range.y, range.x, XPBD && !HAS_DAMPING);
    for (var e = range.x; e < end; e++) {
        let s = spring_end(i, e);
        // A stencil's slot off the grid has no spring.
        if (HAS_STENCILS && s.other == NO_SPRING) {
            continue;
        }
        // A broken spring exerts nothing; skipping it saves reading the other end.
        if (HAS_TEARING && s.stiffness == 0.0 && s.damping == 0.0) {
            continue;
        }
        let d = xi - x_at(s.other);
        let len = length(d);
        if (len <= MIN_SPRING_LENGTH) {
            continue;
        }
        let n = d * (1.0 / len);
        let elastic = -s.stiffness * (len - s.rest);
        if (HAS_DAMPING) {
            let damping = -s.damping * dot(vi - v_at(s.other), n);
            if (!XPBD) {
                f += n * (elastic + damping);
            }
            damping_w += damping * dot(n, vi);
        } else if (!XPBD) {
            f += n * elastic;
        }
    }
    return mass_force_beyond_springs(i, xi, vi, f, damping_w);
}

// The rest of mass i's force at x_i, v_i, its springs' `f_springs` and their dashpots' power
// `damping_w` taken: gravity, drag, the ground and the colliders (whose friction asks the force
// so far), as mass_force's acceleration and ledger rates, and with IMPLICIT the contacts' block.
// VBD (vbd_mass.wgsl) sums the springs its own way and calls it too.
fn mass_force_beyond_springs(i: u32, xi: vec3<f32>, vi: vec3<f32>, f_springs: vec3<f32>, damping_w: f32) -> MassForce {
    let m = mass[i].x;
    var f = f_springs;
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
    var jac_diag = vec3<f32>(0.0);
    var jac_off = vec3<f32>(0.0);
    let h = solve_dt();
    if (HAS_GROUND) {
        let depth = params.ground_height - xi.y;
        let pushes = contact_normal_force(params.ground_stiffness, params.ground_damping_ratio, depth, vi.y, m);
        if (contact_acts(pushes, depth)) {
            let c = contact_force(params.ground_stiffness, params.ground_friction, params.ground_damping_ratio, depth, vec3<f32>(0.0, 1.0, 0.0), vi, f, m, h, 1.0);
            f += c.force;
            contact_w += c.dissipated;
        }
        // Only a contact that pushes has a derivative (its force is zero about the iterate).
        if (IMPLICIT && pushes > 0.0) {
            let k = params.ground_stiffness;
            jac_diag.y += h * h * k + h * 2.0 * params.ground_damping_ratio * sqrt(k * m);
        }
    }
    if (HAS_COLLIDERS) {
        for (var k = 0u; k < params.collider_count; k++) {
            let col = colliders[k];
            let pose = collider_pose(k);
            let p = signed_depth(col, pose.position.xyz, xi);
            let n = p.xyz;
            let u = pose.velocity.xyz;
            let pushes = contact_normal_force(col.stiffness, col.damping_ratio, p.w, dot(vi - u, n), m);
            if (contact_acts(pushes, p.w)) {
                let c = contact_force(col.stiffness, col.friction, col.damping_ratio, p.w, n, vi - u, f, m, h, 1.0);
                f += c.force;
                contact_w += c.dissipated;
                collider_w += dot(c.force, u);
            }
            if (IMPLICIT && pushes > 0.0) {
                let s = h * h * col.stiffness + h * 2.0 * col.damping_ratio * sqrt(col.stiffness * m);
                jac_diag += s * n * n;
                jac_off += s * vec3<f32>(n.x * n.y, n.x * n.z, n.y * n.z);
            }
        }
    }
    // A pinned mass moves with nothing and books nothing.
    let w = mass[i].y;
    if (w == 0.0) {
        return MassForce(vec3<f32>(0.0), vec4<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    }
    return MassForce(f * w, vec4<f32>(-damping_w, -drag_w, contact_w, collider_w), jac_diag, jac_off);
}

// compute_forces' output for mass i: [2i] acceleration, [2i+1] ledger rates, and with implicit
// Euler's contacts their linearisation after them.
fn forces_on(i: u32) {
    let mf = mass_force(i);
    if (has_contact_terms()) {
        let n2 = 2u * params.mass_count;
        deriv[n2 + 2u * i] = vec4<f32>(mf.jac_diag, 0.0);
        deriv[n2 + 2u * i + 1u] = vec4<f32>(mf.jac_off, 0.0);
    }
    deriv[2u * i] = vec4<f32>(mf.acc, 0.0);
    deriv[2u * i + 1u] = mf.rates;
}
