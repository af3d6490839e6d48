// spring_end for the general layout: CSR entry e names its spring, whose record holds the
// constants (and, with plasticity and tearing, changes during a run). Used with mass_force.wgsl by
// compute_forces and implicit_step.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses springs neighbors

fn spring_end(e: u32) -> SpringEnd {
    let nb = neighbors[e];
    let s = springs[nb.spring];
    return SpringEnd(nb.other, s.rest, s.stiffness, s.damping);
}
