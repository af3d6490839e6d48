// collide_masses and mass_contact_energy: contact between mass points, each a sphere of the
// scene's radius, found through the neighbour lists that grid.wgsl keeps. Mirrors
// src/cpu/collide_masses.rs: each mass gathers its pairs by increasing index of the other mass,
// and every pair is computed lower index first and negated for the other mass, so the two sides
// are exact negatives.

// Bindings: `CollideMasses` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// The lists and the grid are grid.wgsl's, built or kept by the passes before.
// #import neighbour_walk

struct Pair {
    touching: bool,
    force: vec3<f32>,
    dissipated: f32,
}

// Contact force on mass a of the pair (a, b) and the power it dissipates, where it acts (src/cpu/
// collide_masses.rs's pair_contact): common.wgsl's contact_force along the line between them with
// the pair's reduced mass, its friction stopping at most PAIR_STICK_SHARE of the sliding a step.
fn pair_contact(xa: vec3<f32>, va: vec3<f32>, wa: f32, xb: vec3<f32>, vb: vec3<f32>, wb: f32, dt: f32) -> Pair {
    var out = Pair(false, vec3<f32>(0.0), 0.0);
    let diameter = 2.0 * contact.radius;
    let d = xa - xb;
    let len_sq = dot(d, d);
    if (len_sq >= PAIR_ONSET_SQ || len_sq == 0.0 || wa + wb == 0.0) {
        return out;
    }
    let dist = sqrt(len_sq);
    let depth = diameter - dist;
    let n = d * (1.0 / dist);
    // The pair's relative motion obeys the one-mass contact with the reduced mass, on from just
    // before the touch where they close fast (contact_normal_force).
    let mu = 1.0 / (wa + wb);
    let pushes = contact_normal_force(contact.stiffness, contact.damping_ratio, depth, dot(va - vb, n), mu);
    if (!contact_acts(pushes, depth)) {
        return out;
    }
    let c = contact_force(contact.stiffness, contact.friction, contact.damping_ratio, depth, n, va - vb, vec3<f32>(0.0), mu, dt, PAIR_STICK_SHARE);
    out.touching = true;
    out.force = c.force;
    out.dissipated = c.dissipated;
    return out;
}

fn may_touch(i: u32, j: u32) -> bool {
    return j != i && (contact.within_bodies != 0u || mass_body[i] != mass_body[j]);
}

fn record(i: u32) -> u32 {
    return contact.list_head + i * (4u + contact.list_slots);
}

// Where mass j was when the lists were built (grid.wgsl's grid_count stored it).
fn listed_position(j: u32) -> vec3<f32> {
    let r = record(j);
    return vec3<f32>(bitcast<f32>(neighbours[r + 1u]), bitcast<f32>(neighbours[r + 2u]), bitcast<f32>(neighbours[r + 3u]));
}

// The cell mass j was binned in at the build: the walk of a mass whose list overflowed.
fn listed_cell(j: u32) -> vec3<i32> {
    return grid_cell(listed_position(j), contact.inv_cell);
}

// Where mass i's candidates come from, by increasing index: its list, or, when the list
// overflowed its slots, the walk over the grid it was built from (which yields the same masses
// in the same order, and more). The walk itself is a variable of its own: naga 30's SPIR-V
// writer fails on a pointer to a struct's member passed on.
struct Listed {
    listed: bool,
    next: u32,
    count: u32,
    first: u32,
}

fn candidates(i: u32, walk: ptr<function, Walk>) -> Listed {
    let r = record(i);
    let count = neighbours[r];
    let listed = count <= contact.list_slots;
    if (!listed) {
        *walk = walk_start(listed_cell(i));
    }
    return Listed(listed, 0u, count, r + 4u);
}

fn next_candidate(c: ptr<function, Listed>, walk: ptr<function, Walk>) -> u32 {
    if ((*c).listed) {
        if ((*c).next == (*c).count) {
            return WALK_DONE;
        }
        let j = neighbours[(*c).first + (*c).next];
        (*c).next++;
        return j;
    }
    return walk_next(walk);
}

// Sum of the pair forces on mass i and its share of their dissipation, the pairs taken by
// increasing index of the other mass (as src/cpu/collide_masses.rs's contact_on_mass).
fn contact_on_mass(i: u32) -> Pair {
    let wi = mass[i].y;
    let xi = x_in[i].xyz;
    let vi = v_in[i].xyz;
    var out = Pair(false, vec3<f32>(0.0), 0.0);
    var walk: Walk;
    var c = candidates(i, &walk);
    loop {
        let j = next_candidate(&c, &walk);
        if (j == WALK_DONE) {
            break;
        }
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

// The last pass of an evaluation to read the lists: it clears their stale flag, which every pass
// before it has read.
@compute @workgroup_size(64)
fn collide_masses(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i == 0u) {
        neighbours[0] = 0u;
    }
    if (i >= params.mass_count) { return; }
    let wi = mass[i].y;
    if (wi == 0.0) { return; }
    let p = contact_on_mass(i);
    deriv[2u * i] = vec4<f32>(deriv[2u * i].xyz + p.force * wi, 0.0);
    deriv[2u * i + 1u].z += p.dissipated;
}

var<workgroup> energy_sh: array<f32, 64>;

// ½ k (2r − d)² per touching pair, each counted at its lower mass, summed per workgroup into the
// contact energy of compute_energies' partial sum of the same workgroup (dispatched over the
// masses, each workgroup g covers masses 64g .. 64g + 63 as compute_energies' does). Like
// collide_masses, it reads the lists last and clears their stale flag.
@compute @workgroup_size(64)
fn mass_contact_energy(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
) {
    let i = thread_index(gid, groups);
    if (i == 0u) {
        neighbours[0] = 0u;
    }
    var e = 0.0;
    if (i < params.mass_count) {
        let xi = x_in[i].xyz;
        let diameter = 2.0 * contact.radius;
        var walk: Walk;
        var c = candidates(i, &walk);
        loop {
            let j = next_candidate(&c, &walk);
            if (j == WALK_DONE) {
                break;
            }
            if (j <= i || !may_touch(i, j) || mass[i].y + mass[j].y == 0.0) {
                continue;
            }
            let depth = diameter - distance(xi, x_in[j].xyz);
            if (depth > 0.0) {
                e += 0.5 * contact.stiffness * depth * depth;
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
