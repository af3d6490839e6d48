// Mass–mass contact's neighbour lists and the hash grid they are built with (cells one reach,
// 2 r + skin, wide). Every force evaluation first runs neighbours_check: has some mass moved past
// the limit since the last build? Only then do the build passes run (each returns at once
// otherwise): grid_count (masses per bucket; each mass's position at the build), the exclusive
// prefix sum over the table (grid_scan_blocks scans each block of SCAN_BLOCK buckets,
// grid_scan_sums the blocks' totals, grid_scan_add adds those back, so any table size works),
// grid_scatter (atomic, so in no fixed order), grid_sort_cells (each bucket by mass index: the
// same layout every run, and the CPU's), then neighbour_lists. The pass that reads the lists
// (collide_masses, mass_contact_energy) clears the flag. Mirrors src/cpu/grid.rs and
// src/cpu/neighbours.rs.
//
// neighbours: [0] the lists are stale; [1] builds so far; then a record per mass from
// contact.list_head, 4 + contact.list_slots words each: the list's length (past the slots, the
// mass walks the grid instead), its position at the build (f32 bits), then the list.
// grid_index: the bucket starts (one more than buckets), then the masses sorted by bucket.

// Bindings: `Grid` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import neighbour_walk

fn record(i: u32) -> u32 {
    return contact.list_head + i * (4u + contact.list_slots);
}

fn lists_stale() -> bool {
    return atomicLoad(&neighbours[0]) != 0u;
}

// At the build the positions are the evaluation's own.
fn listed_cell(j: u32) -> vec3<i32> {
    return grid_cell(x_in[j].xyz, contact.inv_cell);
}

// Flag the lists stale if mass i has moved past the limit since they were built (or is not
// finite). As src/cpu/neighbours.rs's neighbours_check.
fn moved_past_limit(i: u32) -> bool {
    let r = record(i);
    let built = vec3<f32>(
        bitcast<f32>(atomicLoad(&neighbours[r + 1u])),
        bitcast<f32>(atomicLoad(&neighbours[r + 2u])),
        bitcast<f32>(atomicLoad(&neighbours[r + 3u])),
    );
    let d = x_in[i].xyz - built;
    return !(dot(d, d) <= contact.moved_sq);
}

@compute @workgroup_size(64)
fn neighbours_check(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    if (moved_past_limit(i)) {
        atomicOr(&neighbours[0], 1u);
    }
}

// Each pass's work on one mass or bucket, which neighbours_build below also calls.

// Mass i's position at the build, its bucket, and its count in the bucket.
fn count_mass(i: u32) {
    let p = x_in[i].xyz;
    let r = record(i);
    atomicStore(&neighbours[r + 1u], bitcast<u32>(p.x));
    atomicStore(&neighbours[r + 2u], bitcast<u32>(p.y));
    atomicStore(&neighbours[r + 3u], bitcast<u32>(p.z));
    let b = grid_hash(grid_cell(p, contact.inv_cell), contact.table_mask);
    mass_cell[i] = b;
    atomicAdd(&cell_count[b], 1u);
}

// Mass i into its bucket's slots (atomically, so in no fixed order).
fn scatter_mass(i: u32) {
    let b = mass_cell[i];
    let left = atomicSub(&cell_count[b], 1u);
    grid_index[sorted_at() + grid_index[b] + left - 1u] = i;
}

// Insertion sort of bucket b: buckets hold a few masses (the table has twice as many buckets as
// masses, and a cell one reach wide holds few touching-distance spheres).
fn sort_bucket(b: u32) {
    let base = sorted_at();
    let first = base + grid_index[b];
    let end = base + grid_index[b + 1u];
    for (var s = first + 1u; s < end; s++) {
        let m = grid_index[s];
        var t = s;
        while (t > first && grid_index[t - 1u] > m) {
            grid_index[t] = grid_index[t - 1u];
            t--;
        }
        grid_index[t] = m;
    }
}

@compute @workgroup_size(64)
fn grid_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count || !lists_stale()) { return; }
    count_mass(i);
}

var<workgroup> scan_sh: array<u32, 64>;

// Inclusive scan of scan_sh (Hillis–Steele). Every invocation of the workgroup must call it.
fn scan_workgroup(lid: u32) {
    for (var offset = 1u; offset < WORKGROUP; offset *= 2u) {
        var add = 0u;
        if (lid >= offset) {
            add = scan_sh[lid - offset];
        }
        workgroupBarrier();
        scan_sh[lid] += add;
        workgroupBarrier();
    }
}

// One workgroup per block of SCAN_BLOCK buckets, four per invocation: the exclusive prefix sum
// within the block into grid_index, and the block's total into block_sums.
@compute @workgroup_size(64)
fn grid_scan_blocks(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    // The passes with barriers run whole and store only when the lists are stale.
    let stale = lists_stale();
    let block = wid.x + wid.y * groups.x;
    // A 2D dispatch may round up to a few workgroups more than blocks; they still reach the
    // barriers, and skip the memory.
    let in_table = block < contact.block_count && stale;
    let base = block * SCAN_BLOCK + 4u * lid;
    var c = vec4<u32>(0u);
    if (in_table) {
        c = vec4<u32>(
            atomicLoad(&cell_count[base]),
            atomicLoad(&cell_count[base + 1u]),
            atomicLoad(&cell_count[base + 2u]),
            atomicLoad(&cell_count[base + 3u]),
        );
    }
    let total = c.x + c.y + c.z + c.w;
    scan_sh[lid] = total;
    workgroupBarrier();
    scan_workgroup(lid);
    if (in_table) {
        let first = scan_sh[lid] - total;
        grid_index[base] = first;
        grid_index[base + 1u] = first + c.x;
        grid_index[base + 2u] = first + c.x + c.y;
        grid_index[base + 3u] = first + c.x + c.y + c.z;
        if (lid == WORKGROUP - 1u) {
            block_sums[block] = scan_sh[lid];
        }
    }
}

// One workgroup: the exclusive prefix sum of the block totals, in place, SCAN_BLOCK at a time
// with a running carry (so any number of blocks); the grand total (the mass count) closes
// the bucket starts.
@compute @workgroup_size(64)
fn grid_scan_sums(@builtin(local_invocation_index) lid: u32) {
    let stale = lists_stale();
    let count = contact.block_count;
    var carry = 0u;
    for (var chunk = 0u; chunk < (count + SCAN_BLOCK - 1u) / SCAN_BLOCK; chunk++) {
        let base = chunk * SCAN_BLOCK + 4u * lid;
        var c = vec4<u32>(0u);
        for (var k = 0u; k < 4u; k++) {
            if (base + k < count) {
                c[k] = block_sums[base + k];
            }
        }
        let total = c.x + c.y + c.z + c.w;
        scan_sh[lid] = total;
        workgroupBarrier();
        scan_workgroup(lid);
        var running = carry + scan_sh[lid] - total;
        for (var k = 0u; k < 4u; k++) {
            if (base + k < count && stale) {
                block_sums[base + k] = running;
            }
            running += c[k];
        }
        carry += scan_sh[WORKGROUP - 1u];
        // Everyone has read the chunk's total before the next chunk overwrites scan_sh.
        workgroupBarrier();
    }
    if (lid == 0u && stale) {
        grid_index[contact.table_mask + 1u] = carry;
    }
}

@compute @workgroup_size(64)
fn grid_scan_add(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = thread_index(gid, groups);
    if (b > contact.table_mask || !lists_stale()) { return; }
    grid_index[b] += block_sums[b / SCAN_BLOCK];
}

@compute @workgroup_size(64)
fn grid_scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count || !lists_stale()) { return; }
    scatter_mass(i);
}

@compute @workgroup_size(64)
fn grid_sort_cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = thread_index(gid, groups);
    if (b > contact.table_mask || !lists_stale()) { return; }
    sort_bucket(b);
}

// Mass i's list: every other mass within the reach, by increasing index, as many as the slots
// hold; the length stored is the whole count, so that a mass whose list overflowed walks the grid
// instead. (The CPU's lists also drop the pairs that can never touch; the pass that reads them
// tests that rule for both, so the pairs summed are the same.)
fn list_mass(i: u32) {
    let xi = x_in[i].xyz;
    let r = record(i);
    var count = 0u;
    var w = walk_start(listed_cell(i));
    loop {
        let j = walk_next(&w);
        if (j == WALK_DONE) {
            break;
        }
        let d = x_in[j].xyz - xi;
        if (j != i && dot(d, d) < contact.reach_sq) {
            if (count < contact.list_slots) {
                atomicStore(&neighbours[r + 4u + count], j);
            }
            count++;
        }
    }
    atomicStore(&neighbours[r], count);
}

@compute @workgroup_size(64)
fn neighbour_lists(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count || !lists_stale()) { return; }
    if (i == 0u) {
        atomicAdd(&neighbours[1], 1u);
    }
    list_mass(i);
}

var<workgroup> moved_sh: atomic<u32>;
var<workgroup> stale_sh: u32;

// The check and the whole build in one workgroup, for a scene small enough (src/gpu/plan.rs's
// ListBuild) that seven dispatches' launches would cost more than the work: neighbours_check
// and the passes above, one after another, apart by barriers, the same buckets, order and
// lists. One dispatch whether or not the lists are stale.
@compute @workgroup_size(64)
fn neighbours_build(@builtin(local_invocation_index) lid: u32) {
    let n = params.mass_count;
    // neighbours_check (stale from the start, until the first build).
    if (lid == 0u) {
        atomicStore(&moved_sh, atomicLoad(&neighbours[0]));
    }
    workgroupBarrier();
    for (var i = lid; i < n; i += WORKGROUP) {
        if (moved_past_limit(i)) {
            atomicOr(&moved_sh, 1u);
        }
    }
    workgroupBarrier();
    if (lid == 0u) {
        stale_sh = atomicLoad(&moved_sh);
    }
    if (workgroupUniformLoad(&stale_sh) == 0u) {
        return;
    }
    for (var i = lid; i < n; i += WORKGROUP) {
        count_mass(i);
    }
    storageBarrier();
    // The exclusive prefix sum: each invocation a run of table / WORKGROUP buckets (the table is
    // a whole number of SCAN_BLOCKs).
    let table = contact.table_mask + 1u;
    let per = table / WORKGROUP;
    var total = 0u;
    for (var b = lid * per; b < (lid + 1u) * per; b++) {
        total += atomicLoad(&cell_count[b]);
    }
    scan_sh[lid] = total;
    workgroupBarrier();
    scan_workgroup(lid);
    var running = scan_sh[lid] - total;
    for (var b = lid * per; b < (lid + 1u) * per; b++) {
        grid_index[b] = running;
        running += atomicLoad(&cell_count[b]);
    }
    if (lid == WORKGROUP - 1u) {
        grid_index[table] = running;
    }
    storageBarrier();
    for (var i = lid; i < n; i += WORKGROUP) {
        scatter_mass(i);
    }
    storageBarrier();
    for (var b = lid; b < table; b += WORKGROUP) {
        sort_bucket(b);
    }
    storageBarrier();
    if (lid == 0u) {
        atomicAdd(&neighbours[1], 1u);
    }
    for (var i = lid; i < n; i += WORKGROUP) {
        list_mass(i);
    }
}
