// check_state: the divergence check of every update kernel (integrate.wgsl, implicit.wgsl), which
// declare the counters it flags.

// Flag the step if the new state of mass i is not finite or runs away (as src/backend.rs's
// find_divergence): atomicMax of the complement keeps the earliest step.
fn check_state(xi: vec3<f32>, vi: vec3<f32>) {
    let limit = vec3<f32>(3.4028235e38);
    let finite = all(abs(xi) <= limit) && all(abs(vi) <= limit);
    if (!finite || length(vi) > params.runaway_speed) {
        atomicMax(&counters[1], 0xFFFFFFFFu - stage.step);
    }
}
