// fused_mass: one mass's whole Euler or semi-implicit Euler step on the fused path (its force
// gathered by mass_force, the update, the ledger, the divergence check, the projection out of the
// ground and colliders), reading x_in, v_in and writing x_out, v_out. Shared by fused_step
// (fused.wgsl, a dispatch per step) and fused_frame (fused_frame.wgsl, a submission's steps in one
// workgroup), so that both compute the same bits. Defines spring_range and spring_end for
// mass_force: a grid body's masses take their springs from its stencil (stencils: each slot the
// other end's step across the grid and the spring's constants, in the order of the mass's CSR
// entries, slots off the grid skipped), reading nothing per spring; the other masses read compact
// links, one per CSR entry, (other | kind << KIND_SHIFT, rest), each kind's stiffness and damping
// in a uniform table.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params kinds links offsets stencils mass x_in v_in x_out v_out ledger counters stage
// #calls mass_force check_state_at project_body

// A spring index at or past this is a stencil's slot, not a CSR entry.
const STENCIL_ENTRY: u32 = 0x80000000u;

// The grid cell of the mass whose springs mass_force walks, and its body's grid, set by
// spring_range for spring_end.
var<private> stencil_cell: vec3<i32>;
var<private> stencil_dims: vec3<i32>;

fn spring_range(i: u32) -> vec2<u32> {
    if (HAS_STENCILS) {
        for (var b = 0u; b < stencils.count; b++) {
            let body = stencils.bodies[b];
            if (i >= body.first_mass && i < body.mass_end) {
                let local = i - body.first_mass;
                let d = body.dims.xyz;
                stencil_dims = vec3<i32>(d);
                stencil_cell = vec3<i32>(vec3<u32>(local % d.x, (local / d.x) % d.y, local / (d.x * d.y)));
                return vec2<u32>(STENCIL_ENTRY | body.slot_start, STENCIL_ENTRY | body.slot_end);
            }
        }
    }
    return vec2<u32>(offsets[i], offsets[i + 1u]);
}

fn spring_end(i: u32, e: u32) -> SpringEnd {
    if (HAS_STENCILS && e >= STENCIL_ENTRY) {
        let slot = stencils.slots[e & ~STENCIL_ENTRY];
        let cell = stencil_cell + slot.step.xyz;
        if (any(cell < vec3<i32>(0)) || any(cell >= stencil_dims)) {
            return SpringEnd(NO_SPRING, 0.0, 0.0, 0.0);
        }
        return SpringEnd(u32(i32(i) + slot.step.w), slot.rest, slot.stiffness, slot.damping);
    }
    let link = links[e];
    let kind = kinds.kind[link.x >> KIND_SHIFT];
    return SpringEnd(link.x & ((1u << KIND_SHIFT) - 1u), bitcast<f32>(link.y), kind.x, kind.y);
}

// A mass's state and ledger at a step's end.
struct MassStep {
    x: vec3<f32>,
    v: vec3<f32>,
    ledger: vec4<f32>,
}

// Write a step's end to x_out, v_out and the ledger.
fn put_step(i: u32, s: MassStep) {
    x_out[i] = vec4<f32>(s.x, 0.0);
    v_out[i] = vec4<f32>(s.v, 0.0);
    ledger[i] = s.ledger;
}

// The end of every step (`step`: its index in the submission), written.
fn finish_step(i: u32, x: vec3<f32>, v: vec3<f32>, ledger_i: vec4<f32>, step: u32) {
    put_step(i, end_step(i, x, v, ledger_i, step));
}

// The end of every step: check the new state, project it out of contacts.
fn end_step(i: u32, x: vec3<f32>, v: vec3<f32>, ledger_i: vec4<f32>, step: u32) -> MassStep {
    check_state_at(x, v, step);
    var xn = x;
    var vn = v;
    var l = ledger_i;
    if ((HAS_GROUND || HAS_COLLIDERS) && mass[i].y != 0.0) {
        let b = project_body(mass[i].x, x, v);
        if (b.count > 0u) {
            xn = b.x;
            vn = b.v;
            l.z += b.dissipated;
            l.w += b.work;
            atomicAdd(&counters[0], b.count);
            if (b.deep > 0u) {
                atomicAdd(&counters[7], b.deep);
            }
        }
    }
    return MassStep(xn, vn, l);
}

// Euler or semi-implicit Euler (SEMI_IMPLICIT), mass i's whole step: compute_forces,
// euler_update or semi_implicit_update, project_contacts.
fn euler_step_of(i: u32, step: u32) -> MassStep {
    let mf = mass_force(i);
    let dt = stage.dt;
    let xi = x_at(i);
    let vi = v_at(i);
    var xn: vec3<f32>;
    var vn: vec3<f32>;
    if (SEMI_IMPLICIT) {
        vn = vi + dt * mf.acc;
        xn = xi + dt * vn;
    } else {
        xn = xi + dt * vi;
        vn = vi + dt * mf.acc;
    }
    return end_step(i, xn, vn, ledger[i] + dt * mf.rates, step);
}
