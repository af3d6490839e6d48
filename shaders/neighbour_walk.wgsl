// The walk over a mass's grid neighbourhood by increasing mass index: the neighbour lists are
// built by it (grid.wgsl's neighbour_lists), and a mass whose list overflowed its slots takes it
// instead of its list (collide_masses.wgsl). Each of the 27 cells' buckets is sorted by mass
// index (grid_sort_cells); the walk merges them, each cursor taking only its own cell's masses,
// so a bucket two of the cells share yields each mass once, in order.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses contact grid_index
// #calls listed_cell

const WALK_DONE: u32 = 0xffffffffu;

struct Walk {
    at: array<u32, 27>,
    end: array<u32, 27>,
    centre: vec3<i32>,
}

// grid_index holds the bucket starts (one more than buckets), then the masses sorted by bucket.
fn sorted_at() -> u32 {
    return contact.table_mask + 2u;
}

// Cell k of the 27 around `centre` (z, y, x each from −1 to +1).
fn walk_cell(centre: vec3<i32>, k: u32) -> vec3<i32> {
    return centre + vec3<i32>(i32(k % 3u) - 1, i32((k / 3u) % 3u) - 1, i32(k / 9u) - 1);
}

// The first slot from `at` (before `end`) whose mass was in `cell` when the grid was built.
fn walk_skip(at: u32, end: u32, cell: vec3<i32>) -> u32 {
    var s = at;
    while (s < end && any(listed_cell(grid_index[sorted_at() + s]) != cell)) {
        s++;
    }
    return s;
}

fn walk_start(centre: vec3<i32>) -> Walk {
    var w: Walk;
    w.centre = centre;
    for (var k = 0u; k < 27u; k++) {
        let cell = walk_cell(centre, k);
        let b = grid_hash(cell, contact.table_mask);
        w.end[k] = grid_index[b + 1u];
        w.at[k] = walk_skip(grid_index[b], w.end[k], cell);
    }
    return w;
}

// The next mass of the walk, WALK_DONE once every cell is spent.
fn walk_next(w: ptr<function, Walk>) -> u32 {
    var j = WALK_DONE;
    var first = 27u;
    for (var k = 0u; k < 27u; k++) {
        if ((*w).at[k] < (*w).end[k]) {
            let m = grid_index[sorted_at() + (*w).at[k]];
            if (m < j) {
                j = m;
                first = k;
            }
        }
    }
    if (first < 27u) {
        (*w).at[first] = walk_skip((*w).at[first] + 1u, (*w).end[first], walk_cell((*w).centre, first));
    }
    return j;
}
