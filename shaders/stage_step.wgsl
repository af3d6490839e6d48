// stage_step: the step a force evaluation's one-step terms take (friction's stop within a step,
// the implicit system's h), where it is the stage slot's own: every program but implicit.wgsl and
// multigrid.wgsl, whose implicit_terms.wgsl takes BDF2's restarts (src/physics/solver.rs's
// BackwardStep::restarted). mass_force.wgsl and system_blocks.wgsl call it.
// A library: `#uses` names the bindings it reads, which its program must bind.
// #uses stage

fn solve_dt() -> f32 {
    return stage.dt;
}
