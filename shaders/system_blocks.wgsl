// system_blocks: mass i's 3 × 3 diagonal block of backward Euler's system M − h D − h² K, as
// src/cpu/implicit.rs builds it (own_block, SpringTerms::at and ::block, ContactBlock::block,
// invert_block, block_times): implicit Euler's block-Jacobi preconditioner (implicit_terms.wgsl) and VBD's
// block solve (vbd.wgsl) both read it.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params springs mass x_in
// #calls solve_dt

struct SpringTerms {
    n: vec3<f32>,
    // h²k along n, h²k·max(0, 1 − L/l) across it, h c along it.
    stiff_along: f32,
    stiff_across: f32,
    damp_along: f32,
}

// One spring's share of the system at the iterate, seen from mass i (src/cpu/implicit.rs's
// linearise; the sign of n does not matter, the terms are in n nᵀ).
fn spring_terms(i: u32, nb: Neighbor) -> SpringTerms {
    let d = x_in[i].xyz - x_in[nb.other].xyz;
    return spring_terms_along(springs[nb.spring], d, length(d));
}

// The same for spring `s` whose ends are `d` apart, `len` = |d| (VBD's share reads the ends once
// for the force and the block).
fn spring_terms_along(s: Spring, d: vec3<f32>, len: f32) -> SpringTerms {
    var t = SpringTerms(vec3<f32>(0.0), 0.0, 0.0, 0.0);
    if (len > MIN_SPRING_LENGTH) {
        let h = solve_dt();
        let k = h * h * s.stiffness;
        t.n = d * (1.0 / len);
        t.stiff_along = k;
        t.stiff_across = k * max(1.0 - s.rest / len, 0.0);
        if (HAS_DAMPING) {
            t.damp_along = h * s.damping;
        }
    }
    return t;
}

fn own_mass_term(i: u32) -> f32 {
    var drag = 0.0;
    if (HAS_DRAG) {
        drag = params.drag_per_s;
    }
    return mass[i].x * (1.0 + solve_dt() * drag);
}

// m(1 + hγ) I.
fn own_block(i: u32) -> mat3x3<f32> {
    let own = own_mass_term(i);
    return mat3x3<f32>(vec3<f32>(own, 0.0, 0.0), vec3<f32>(0.0, own, 0.0), vec3<f32>(0.0, 0.0, own));
}

// n nᵀ.
fn outer(n: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(n * n.x, n * n.y, n * n.z);
}

// a × b, each product rounded before the difference, as glam's `cross` (the CPU's
// invert_block). Written out: Mesa's `cross` fuses one product into the difference, so
// lavapipe's inverted blocks parted from the CPU's at the last bit.
fn cross_of(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}

// The inverse of a symmetric positive definite block by its adjugate (src/cpu/implicit.rs's
// invert_block).
fn invert_block(a: mat3x3<f32>) -> mat3x3<f32> {
    let r0 = cross_of(a[1], a[2]);
    let r1 = cross_of(a[2], a[0]);
    let r2 = cross_of(a[0], a[1]);
    let det = dot(a[0], r0);
    return mat3x3<f32>(r0, r1, r2) * (1.0 / det);
}

// `m` times `v`, its columns weighted and added first to last (src/cpu/system_blocks.rs's
// block_times). Written out: Mesa's SPIR-V translation adds the columns of `m * v` last to
// first, so lavapipe and the CPU parted at the last bit of the preconditioned residual.
fn block_times(m: mat3x3<f32>, v: vec3<f32>) -> vec3<f32> {
    return m[0] * v.x + m[1] * v.y + m[2] * v.z;
}

// A symmetric block from its diagonal (xx, yy, zz) and off-diagonal (xy, xz, yz) entries.
fn symmetric_block(d: vec3<f32>, o: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(vec3<f32>(d.x, o.x, o.y), vec3<f32>(o.x, d.y, o.z), vec3<f32>(o.y, o.z, d.z));
}

// `block` plus a spring's block at either end, (h²k + h c) n nᵀ + h²k·max(0, 1 − L/l)(I − n nᵀ),
// its two parts added in turn (src/cpu/system_blocks.rs's SpringTerms::add_block; see
// add_entry_times in implicit_terms.wgsl for why).
fn add_spring_block(block: mat3x3<f32>, t: SpringTerms) -> mat3x3<f32> {
    let a = t.stiff_across;
    let across = mat3x3<f32>(vec3<f32>(a, 0.0, 0.0), vec3<f32>(0.0, a, 0.0), vec3<f32>(0.0, 0.0, a));
    return block + outer(t.n) * (t.stiff_along + t.damp_along - a) + across;
}
