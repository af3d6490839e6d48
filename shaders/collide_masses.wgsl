// collide_masses and mass_contact_energy: contact between mass points, each a sphere of the
// scene's radius, found through the hash grid that grid.wgsl built from the same positions.
// Mirrors src/cpu/collide_masses.rs: each mass gathers its pairs by increasing index of the other
// mass, and every pair is computed lower index first and negated for the other mass, so the two
// sides are exact negatives.

// Bindings: `CollideMasses` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.

struct Pair {
    touching: bool,
    force: vec3<f32>,
    dissipated: f32,
}

// Contact force on mass a of the pair (a, b) and the power it dissipates (src/cpu/
// collide_masses.rs's pair_contact): common.wgsl's contact_force along the line between them with
// the pair's reduced mass, its friction stopping at most PAIR_STICK_SHARE of the sliding a step.
fn pair_contact(xa: vec3<f32>, va: vec3<f32>, wa: f32, xb: vec3<f32>, vb: vec3<f32>, wb: f32, dt: f32) -> Pair {
    var out = Pair(false, vec3<f32>(0.0), 0.0);
    let diameter = 2.0 * contact.radius;
    let d = xa - xb;
    let len_sq = dot(d, d);
    if (len_sq >= diameter * diameter || len_sq == 0.0 || wa + wb == 0.0) {
        return out;
    }
    let dist = sqrt(len_sq);
    let depth = diameter - dist;
    if (depth <= 0.0) {
        return out;
    }
    let n = d * (1.0 / dist);
    // The pair's relative motion obeys the one-mass contact with the reduced mass.
    let mu = 1.0 / (wa + wb);
    let c = contact_force(contact.stiffness, contact.friction, contact.damping_ratio, depth, n, va - vb, vec3<f32>(0.0), mu, dt, PAIR_STICK_SHARE);
    out.touching = true;
    out.force = c.force;
    out.dissipated = c.dissipated;
    return out;
}

fn may_touch(i: u32, j: u32) -> bool {
    return j != i && (contact.within_bodies != 0u || mass_body[i] != mass_body[j]);
}

// Cell k of the 27 around a mass's own (z, y, x each from −1 to +1).
fn cell_offset(k: u32) -> vec3<i32> {
    return vec3<i32>(i32(k % 3u) - 1, i32((k / 3u) % 3u) - 1, i32(k / 9u) - 1);
}

// The first slot from `at` (up to `end`) of a bucket whose mass lies in `cell`: a bucket holds
// every cell hashed to it, and each of the 27 cursors takes only its own cell's masses, so a
// bucket two of the cells share yields each mass once.
fn skip_to_cell(at: u32, end: u32, cell: vec3<i32>) -> u32 {
    var s = at;
    while (s < end && any(grid_cell(x_in[sorted[s]].xyz, contact.inv_cell) != cell)) {
        s++;
    }
    return s;
}

// Sum of the pair forces on mass i and its share of their dissipation, the pairs taken by
// increasing index of the other mass (the order src/cpu/neighbours.rs's lists hold): the 27
// cells' buckets, each sorted by mass index, merged.
fn contact_on_mass(i: u32, c: vec3<i32>) -> Pair {
    let wi = mass[i].y;
    let xi = x_in[i].xyz;
    let vi = v_in[i].xyz;
    var out = Pair(false, vec3<f32>(0.0), 0.0);
    var at: array<u32, 27>;
    var end: array<u32, 27>;
    for (var k = 0u; k < 27u; k++) {
        let cell = c + cell_offset(k);
        let b = grid_hash(cell, contact.table_mask);
        end[k] = cell_start[b + 1u];
        at[k] = skip_to_cell(cell_start[b], end[k], cell);
    }
    loop {
        var j = 0xffffffffu;
        var first = 27u;
        for (var k = 0u; k < 27u; k++) {
            if (at[k] < end[k]) {
                let m = sorted[at[k]];
                if (m < j) {
                    j = m;
                    first = k;
                }
            }
        }
        if (first == 27u) {
            break;
        }
        at[first] = skip_to_cell(at[first] + 1u, end[first], c + cell_offset(first));
        if (!may_touch(i, j)) {
            continue;
        }
        let xj = x_in[j].xyz;
        let wj = mass[j].y;
        let vj = v_in[j].xyz;
        if (i < j) {
            let p = pair_contact(xi, vi, wi, xj, vj, wj, stage.dt);
            if (p.touching) {
                out.force += p.force;
                out.dissipated += select(0.5 * p.dissipated, p.dissipated, wj == 0.0);
            }
        } else {
            let p = pair_contact(xj, vj, wj, xi, vi, wi, stage.dt);
            if (p.touching) {
                out.force -= p.force;
                out.dissipated += select(0.5 * p.dissipated, p.dissipated, wj == 0.0);
            }
        }
    }
    return out;
}

@compute @workgroup_size(64)
fn collide_masses(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let wi = mass[i].y;
    if (wi == 0.0) { return; }
    let p = contact_on_mass(i, grid_cell(x_in[i].xyz, contact.inv_cell));
    deriv[2u * i] = vec4<f32>(deriv[2u * i].xyz + p.force * wi, 0.0);
    deriv[2u * i + 1u].z += p.dissipated;
}

var<workgroup> energy_sh: array<f32, 64>;

// ½ k (2r − d)² per touching pair, each counted at its lower mass, summed per workgroup into the
// contact energy of compute_energies' partial sum of the same workgroup (dispatched over the
// masses, each workgroup g covers masses 64g .. 64g + 63 as compute_energies' does).
@compute @workgroup_size(64)
fn mass_contact_energy(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let i = thread_index(gid, groups);
    var e = 0.0;
    if (i < params.mass_count) {
        let xi = x_in[i].xyz;
        let diameter = 2.0 * contact.radius;
        let c = grid_cell(xi, contact.inv_cell);
        for (var dz = -1; dz <= 1; dz++) {
            for (var dy = -1; dy <= 1; dy++) {
                for (var dx = -1; dx <= 1; dx++) {
                    let cell = c + vec3<i32>(dx, dy, dz);
                    let b = grid_hash(cell, contact.table_mask);
                    let end = cell_start[b + 1u];
                    for (var s = cell_start[b]; s < end; s++) {
                        let j = sorted[s];
                        if (j <= i || !may_touch(i, j) || mass[i].y + mass[j].y == 0.0) {
                            continue;
                        }
                        let xj = x_in[j].xyz;
                        if (any(grid_cell(xj, contact.inv_cell) != cell)) {
                            continue;
                        }
                        let depth = diameter - distance(xi, xj);
                        if (depth > 0.0) {
                            e += 0.5 * contact.stiffness * depth * depth;
                        }
                    }
                }
            }
        }
    }
    energy_sh[lid] = e;
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride = stride / 2u) {
        if (lid < stride) {
            energy_sh[lid] += energy_sh[lid + stride];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        let g = wid.x + wid.y * groups.x;
        partials[3u * g].w += energy_sh[0];
    }
}
