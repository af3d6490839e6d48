// VBD's block solve of one mass (src/cpu/vbd.rs's vbd_solve_mass), which vbd.wgsl's
// vbd_solve_mass (a dispatch per colour and sweep) and vbd_sweeps.wgsl's vbd_sweeps (every sweep
// over every colour in one workgroup) share. The step's start is x, v; the iterate x_in, v_in,
// which vbd_predict (integrate.wgsl) filled.
//
// A mass's springs are shared among VBD_LANES threads (src/gpu/dispatch.rs's vbd_lanes: 8 on a
// GPU, 1 on a CPU adapter): lane l walks the CSR entries l, l + VBD_LANES, …, each once for both
// the force and the block, and the first lane adds the shares in lane order and solves. A thread
// per mass walked its 26 springs twice through loads that wait on loads, with a colour's few
// hundred masses leaving an SM idle. The CPU sums the springs in one lane, so the two agree to
// the parity tolerance, not bit for bit; both kernels here sum alike, bit for bit.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params springs mass offsets neighbors x v x_in v_in stage
// #calls mass_force_beyond_springs own_block symmetric_block invert_block block_times add_spring_block spring_terms_along

// One lane's share of a mass's springs: their force, and their part of the system's block.
struct VbdShare {
    f: vec3<f32>,
    block: mat3x3<f32>,
}

fn vbd_no_share() -> VbdShare {
    return VbdShare(vec3<f32>(0.0), mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0)));
}

// Lane `lane`'s share of mass i's springs at the iterate: each spring's force (mass_force's
// spring term) and block (system_blocks.wgsl's add_spring_block), from one read of the other end.
fn vbd_share(i: u32, lane: u32) -> VbdShare {
    var share = vbd_no_share();
    if (mass[i].y == 0.0) {
        return share;
    }
    let xi = x_in[i].xyz;
    let vi = v_in[i].xyz;
    let end = offsets[i + 1u];
    for (var e = offsets[i] + lane; e < end; e += VBD_LANES) {
        let nb = neighbors[e];
        let s = springs[nb.spring];
        let d = xi - x_in[nb.other].xyz;
        let len = length(d);
        if (len <= MIN_SPRING_LENGTH) {
            continue;
        }
        let n = d * (1.0 / len);
        var along = -s.stiffness * (len - s.rest);
        if (HAS_DAMPING) {
            along += -s.damping * dot(vi - v_in[nb.other].xyz, n);
        }
        share.f += n * along;
        share.block = add_spring_block(share.block, spring_terms_along(s, d, len));
    }
    return share;
}

fn vbd_add_share(a: VbdShare, b: VbdShare) -> VbdShare {
    return VbdShare(a.f + b.f, a.block + b.block);
}

// Mass i's block solve from its springs' `share` (every lane's, added in lane order): the rest
// of its force at the iterate, b = h m a − m (v − v₀), the block with its own mass and its
// contacts, and the new iterate v + block⁻¹ b. A pinned mass keeps its state.
fn vbd_finish(i: u32, share: VbdShare) {
    if (mass[i].y == 0.0) {
        return;
    }
    let m = mass[i].x;
    let h = stage.dt;
    let xi = x_in[i].xyz;
    let vi = v_in[i].xyz;
    // The springs' dashpot power is the ledger's, which VBD books at the step's end.
    let mf = mass_force_beyond_springs(i, xi, vi, share.f, 0.0);
    let b = h * m * mf.acc - m * (vi - v[i].xyz);
    var block = own_block(i);
    if (has_contact_terms()) {
        block += symmetric_block(mf.jac_diag, mf.jac_off);
    }
    block += share.block;
    let vn = vi + block_times(invert_block(block), b);
    v_in[i] = vec4<f32>(vn, 0.0);
    x_in[i] = vec4<f32>(x[i].xyz + h * vn, 0.0);
}
