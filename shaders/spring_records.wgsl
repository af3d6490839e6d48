// spring_range and spring_end for the general layout: mass i's springs are its CSR entries, and
// entry e names its spring, whose record holds the constants (and, with plasticity and tearing,
// changes during a run). Used with mass_force.wgsl by compute_forces and implicit_step.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses springs neighbors offsets

fn spring_range(i: u32) -> vec2<u32> {
    return vec2<u32>(offsets[i], offsets[i + 1u]);
}

fn spring_end(i: u32, e: u32) -> SpringEnd {
    let nb = neighbors[e];
    let s = springs[nb.spring];
    return SpringEnd(nb.other, s.rest, s.stiffness, s.damping);
}
