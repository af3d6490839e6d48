// compute_strain and compute_energies: what a snapshot logs, reduced on the GPU so that only that
// is read back. Mirrors src/cpu/reduce.rs. compute_energies leaves one partial sum per workgroup;
// the host adds those few in f64, in order, so the result is the same from run to run.

// Bindings: `Reduce` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.

@compute @workgroup_size(64)
fn compute_strain(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = thread_index(gid, groups);
    if (s >= params.spring_count) { return; }
    let sp = springs[s];
    if (HAS_TEARING && is_broken(sp)) {
        strain[s] = BROKEN_STRAIN;
        return;
    }
    let len = distance(x[sp.a].xyz, x[sp.b].xyz);
    strain[s] = (len - sp.rest) / max(sp.rest, 1.17549435e-38);
}

var<workgroup> energy_sh: array<vec4<f32>, 64>;
var<workgroup> ledger_sh: array<vec4<f32>, 64>;
var<workgroup> misc_sh: array<vec4<f32>, 64>;

fn finite3(p: vec3<f32>) -> bool {
    // NaN fails every comparison; ±inf fails the bound.
    return all(abs(p) <= vec3<f32>(3.4028235e38));
}

@compute @workgroup_size(64)
fn compute_energies(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let i = thread_index(gid, groups);
    var e = vec4<f32>(0.0);
    var l = vec4<f32>(0.0);
    var misc = vec4<f32>(0.0);
    if (i < params.mass_count) {
        let m = mass[i].x;
        let xi = x[i].xyz;
        let vi = v[i].xyz;
        let free = mass[i].y != 0.0;
        if (free) {
            e.x = 0.5 * m * dot(vi, vi);
        }
        if (HAS_GRAVITY) {
            e.z = -m * dot(params.gravity, xi);
        }
        if (free && HAS_GROUND) {
            let d = params.ground_height - xi.y;
            if (d > 0.0) {
                e.w += 0.5 * params.ground_stiffness * d * d;
            }
        }
        if (free && HAS_COLLIDERS) {
            for (var k = 0u; k < params.collider_count; k++) {
                let c = colliders[k];
                let p = penetration(c, stage.poses[k].position.xyz, xi);
                if (p.w > 0.0) {
                    e.w += 0.5 * c.stiffness * p.w * p.w;
                }
            }
        }
        l = ledger[i];
        misc.x = length(vi);
        if (!(finite3(xi) && finite3(vi))) {
            misc.y = 1.0;
        }
    }
    if (i < params.spring_count) {
        let sp = springs[i];
        let stretch = distance(x[sp.a].xyz, x[sp.b].xyz) - sp.rest;
        e.y = 0.5 * sp.stiffness * stretch * stretch;
    }
    energy_sh[lid] = e;
    ledger_sh[lid] = l;
    misc_sh[lid] = misc;
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride = stride / 2u) {
        if (lid < stride) {
            energy_sh[lid] += energy_sh[lid + stride];
            ledger_sh[lid] += ledger_sh[lid + stride];
            let a = misc_sh[lid];
            let b = misc_sh[lid + stride];
            misc_sh[lid] = vec4<f32>(max(a.x, b.x), a.y + b.y, 0.0, 0.0);
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        let g = wid.x + wid.y * groups.x;
        partials[3u * g] = energy_sh[0];
        partials[3u * g + 1u] = ledger_sh[0];
        partials[3u * g + 2u] = misc_sh[0];
    }
}
