// system_blocks: mass i's 3 × 3 diagonal block of backward Euler's system M − h D − h² K, as
// src/cpu/implicit.rs builds it (own_block, SpringTerms::at and ::block, ContactTerms::block,
// invert_block): implicit Euler's block-Jacobi preconditioner (implicit_terms.wgsl) and VBD's
// block solve (vbd.wgsl) both read it.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params springs mass x_in stage

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
        let h = stage.dt;
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
    return mass[i].x * (1.0 + stage.dt * drag);
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

// The inverse of a symmetric positive definite block by its adjugate (src/cpu/implicit.rs's
// invert_block).
fn invert_block(a: mat3x3<f32>) -> mat3x3<f32> {
    let r0 = cross(a[1], a[2]);
    let r1 = cross(a[2], a[0]);
    let r2 = cross(a[0], a[1]);
    let det = dot(a[0], r0);
    return mat3x3<f32>(r0, r1, r2) * (1.0 / det);
}

// A symmetric block from its diagonal (xx, yy, zz) and off-diagonal (xy, xz, yz) entries.
fn symmetric_block(d: vec3<f32>, o: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(vec3<f32>(d.x, o.x, o.y), vec3<f32>(o.x, d.y, o.z), vec3<f32>(o.y, o.z, d.z));
}

// A spring's block at either end: (h²k + h c) n nᵀ + h²k·max(0, 1 − L/l)(I − n nᵀ).
fn spring_block(t: SpringTerms) -> mat3x3<f32> {
    let a = t.stiff_across;
    let across = mat3x3<f32>(vec3<f32>(a, 0.0, 0.0), vec3<f32>(0.0, a, 0.0), vec3<f32>(0.0, 0.0, a));
    return outer(t.n) * (t.stiff_along + t.damp_along - a) + across;
}
