// update_springs: plasticity and tearing, once after every step; sum_spring_work: the energy they
// let go, per workgroup, for a snapshot. Mirrors src/cpu/springs.rs.

// Bindings: `Springs` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.

@compute @workgroup_size(64)
fn update_springs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups);
    if (k >= params.spring_count) {
        return;
    }
    let s = springs[k];
    if (is_broken(s)) {
        return;
    }
    let l = limits[k];
    let len = distance(x[s.a].xyz, x[s.b].xyz);
    let stretch = len - s.rest;
    let strain = stretch / s.rest;
    if (HAS_TEARING && strain > l.break_strain) {
        released[k] += 0.5 * s.stiffness * stretch * stretch;
        springs[k].stiffness = 0.0;
        springs[k].damping = 0.0;
        return;
    }
    if (HAS_PLASTICITY && abs(strain) > l.yield_strain) {
        let target_len = len / (1.0 + sign(strain) * l.yield_strain);
        let rest = s.rest + l.relax * (target_len - s.rest);
        let left = len - rest;
        released[k] += 0.5 * s.stiffness * (stretch * stretch - left * left);
        springs[k].rest = rest;
    }
}

var<workgroup> released_sh: array<f32, 64>;

// Runs after compute_energies over the same workgroups; takes each spring's energy and zeroes it.
@compute @workgroup_size(64)
fn sum_spring_work(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let k = thread_index(gid, groups);
    var e = 0.0;
    if (k < params.spring_count) {
        e = released[k];
        released[k] = 0.0;
    }
    released_sh[lid] = e;
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride = stride / 2u) {
        if (lid < stride) {
            released_sh[lid] += released_sh[lid + stride];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        let g = wid.x + wid.y * groups.x;
        partials[3u * g + 2u].z = released_sh[0];
    }
}
