// The hash grid of mass–mass contact, rebuilt at every force evaluation from the positions that
// evaluation reads: grid_count (masses per bucket), the exclusive prefix sum over the table
// (grid_scan_blocks scans each block of SCAN_BLOCK buckets, grid_scan_sums the blocks' totals,
// grid_scan_add adds those back, so any table size works), grid_scatter (atomic, so in no fixed
// order), then grid_sort_cells (each bucket by mass index: the same layout every run, and the
// CPU's). Mirrors src/cpu/grid.rs.

// Bindings: `Grid` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.

@compute @workgroup_size(64)
fn grid_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let b = grid_hash(grid_cell(x_in[i].xyz, contact.inv_cell), contact.table_mask);
    mass_cell[i] = b;
    atomicAdd(&cell_count[b], 1u);
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
// within the block into cell_start, and the block's total into block_sums.
@compute @workgroup_size(64)
fn grid_scan_blocks(
    @builtin(local_invocation_index) lid: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let block = wid.x + wid.y * groups.x;
    // A 2D dispatch may round up to a few workgroups more than blocks; they still reach the
    // barriers, and skip the memory.
    let in_table = block < contact.block_count;
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
        cell_start[base] = first;
        cell_start[base + 1u] = first + c.x;
        cell_start[base + 2u] = first + c.x + c.y;
        cell_start[base + 3u] = first + c.x + c.y + c.z;
        if (lid == WORKGROUP - 1u) {
            block_sums[block] = scan_sh[lid];
        }
    }
}

// One workgroup: the exclusive prefix sum of the block totals, in place, SCAN_BLOCK at a time
// with a running carry (so any number of blocks); the grand total (the mass count) closes
// cell_start.
@compute @workgroup_size(64)
fn grid_scan_sums(@builtin(local_invocation_index) lid: u32) {
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
            if (base + k < count) {
                block_sums[base + k] = running;
            }
            running += c[k];
        }
        carry += scan_sh[WORKGROUP - 1u];
        // Everyone has read the chunk's total before the next chunk overwrites scan_sh.
        workgroupBarrier();
    }
    if (lid == 0u) {
        cell_start[contact.table_mask + 1u] = carry;
    }
}

@compute @workgroup_size(64)
fn grid_scan_add(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = thread_index(gid, groups);
    if (b > contact.table_mask) { return; }
    cell_start[b] += block_sums[b / SCAN_BLOCK];
}

@compute @workgroup_size(64)
fn grid_scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i >= params.mass_count) { return; }
    let b = mass_cell[i];
    let left = atomicSub(&cell_count[b], 1u);
    sorted[cell_start[b] + left - 1u] = i;
}

// Insertion sort of each bucket: buckets hold a few masses (the table has twice as many buckets
// as masses, and a cell 2 · radius wide holds few touching-distance spheres).
@compute @workgroup_size(64)
fn grid_sort_cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = thread_index(gid, groups);
    if (b > contact.table_mask) { return; }
    let first = cell_start[b];
    let end = cell_start[b + 1u];
    for (var s = first + 1u; s < end; s++) {
        let m = sorted[s];
        var t = s;
        while (t > first && sorted[t - 1u] > m) {
            sorted[t] = sorted[t - 1u];
            t--;
        }
        sorted[t] = m;
    }
}
