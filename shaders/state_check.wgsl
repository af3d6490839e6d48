// check_state: the divergence check of every update kernel (integrate.wgsl, implicit.wgsl,
// fused.wgsl), flagged in their counters.
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses params counters stage

// Flag the step if the new state of mass i is not finite or runs away (as src/backend.rs's
// find_divergence): atomicMax of the complement keeps the earliest step.
fn check_state(xi: vec3<f32>, vi: vec3<f32>) {
    check_state_at(xi, vi, stage.step);
}

// check_state for step `step` of the submission (a kernel that runs many steps counts them).
fn check_state_at(xi: vec3<f32>, vi: vec3<f32>, step: u32) {
    let limit = vec3<f32>(3.4028235e38);
    let finite = all(abs(xi) <= limit) && all(abs(vi) <= limit);
    if (!finite || length(vi) > params.runaway_speed) {
        atomicMax(&counters[1], 0xFFFFFFFFu - step);
    }
}
