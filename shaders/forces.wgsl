// compute_forces: the full force on every mass (springs, gravity, drag, contact), one thread per
// mass; the force law is forces_on (mass_force.wgsl, compiled before this file). Mirrors
// src/cpu/forces.rs. Mass–mass contact is added after it by collide_masses (collide_masses.wgsl).

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> springs: array<Spring>;
@group(0) @binding(2) var<storage, read> offsets: array<u32>;
@group(0) @binding(3) var<storage, read> neighbors: array<Neighbor>;
@group(0) @binding(4) var<storage, read> colliders: array<Collider>;
// (mass, inverse mass; 0 when pinned)
@group(0) @binding(5) var<storage, read> mass: array<vec2<f32>>;
// Per mass: [2i] acceleration, [2i+1] ledger rates (damping, drag, contact, collider work); with
// IMPLICIT also [2n + 2i], [2n + 2i + 1] the contacts' share of the implicit system (below).
@group(0) @binding(6) var<storage, read_write> deriv: array<vec4<f32>>;
@group(1) @binding(0) var<storage, read> x_in: array<vec4<f32>>;
@group(1) @binding(1) var<storage, read> v_in: array<vec4<f32>>;
@group(2) @binding(0) var<uniform> stage: Stage;

@compute @workgroup_size(64)
fn compute_forces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i < params.mass_count) {
        forces_on(i);
    }
}
