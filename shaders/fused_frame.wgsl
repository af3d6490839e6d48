// fused_frame: a small scene's Euler or semi-implicit Euler steps, every step of a submission in
// one dispatch of one workgroup (src/gpu/plan.rs's ExplicitPath::InGroup), instead of fused.wgsl's
// dispatch per step: for a few thousand masses a launch costs more than the step's work. Each
// mass's step is fused_step's (fused_mass.wgsl), so the two agree bit for bit.
//
// Where the state fits in workgroup memory (STATE_IN_WORKGROUP: 48 B a mass, within the
// adapter's limit; src/gpu/dispatch.rs's FrameState::masses_in_workgroup), the steps read and write it
// there, in two halves that swap roles each step (mass_force's x_at, v_at read the step's half),
// one workgroup barrier a step; it is loaded from A (x_in, v_in) before the first step and
// written to A and B (x_out, v_out) after the last. Otherwise the state lives in A between steps:
// each step writes B and, once every thread has read A for its gathers, copies its masses back to
// A. Storage barriers keep the phases apart. Either way the arithmetic is fused_step's on the same
// bits. WGSL has no barrier across workgroups, hence one workgroup.
//
// Each step reads its own stage slots' collider poses (every slot of the submission is bound as
// words, `StageWords`), as the step's dispatch would have.

// Bindings: `FusedFrame` (group 0) and the stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import mass_force state_check contact_projection fused_mass stage_step

// The step under way.
var<private> frame_step: u32;

// Collider k's pose in stage slot `slot` (Stage's header is 8 words, a Pose 8).
fn slot_pose(slot: u32, k: u32) -> Pose {
    let w = slot * STAGE_STRIDE_WORDS + 8u + 8u * k;
    var f: array<f32, 8>;
    for (var j = 0u; j < 8u; j++) {
        f[j] = bitcast<f32>(stage_words[w + j]);
    }
    return Pose(vec4<f32>(f[0], f[1], f[2], f[3]), vec4<f32>(f[4], f[5], f[6], f[7]));
}

// At the step's start, for the forces.
fn collider_pose(k: u32) -> Pose {
    return slot_pose(SLOTS_PER_STEP * frame_step, k);
}

// At the step's end, for the projection.
fn end_pose(k: u32) -> Pose {
    return slot_pose(SLOTS_PER_STEP * frame_step + SLOTS_PER_STEP - 1u, k);
}

// Mass i's state into half `half` of the workgroup's copy.
fn put_shared(half: u32, i: u32, x: vec3<f32>, v: vec3<f32>) {
    let w = state_word(half, i);
    state_sh[w] = x.x;
    state_sh[w + 1u] = x.y;
    state_sh[w + 2u] = x.z;
    state_sh[w + 3u] = v.x;
    state_sh[w + 4u] = v.y;
    state_sh[w + 5u] = v.z;
}

@compute @workgroup_size(FRAME_THREADS)
fn fused_frame(@builtin(local_invocation_index) lid: u32) {
    let n = params.mass_count;
    if (STATE_IN_WORKGROUP) {
        state_half = 0u;
        for (var i = lid; i < n; i += FRAME_THREADS) {
            put_shared(0u, i, x_in[i].xyz, v_in[i].xyz);
        }
        workgroupBarrier();
        for (var k = 0u; k < stage.steps; k++) {
            frame_step = k;
            state_half = k % 2u;
            for (var i = lid; i < n; i += FRAME_THREADS) {
                let s = euler_step_of(i, stage.step + k);
                put_shared(1u - state_half, i, s.x, s.v);
                ledger[i] = s.ledger;
            }
            workgroupBarrier();
        }
        state_half = stage.steps % 2u;
        for (var i = lid; i < n; i += FRAME_THREADS) {
            let x = vec4<f32>(x_at(i), 0.0);
            let v = vec4<f32>(v_at(i), 0.0);
            x_in[i] = x;
            v_in[i] = v;
            x_out[i] = x;
            v_out[i] = v;
        }
        return;
    }
    for (var k = 0u; k < stage.steps; k++) {
        frame_step = k;
        for (var i = lid; i < n; i += FRAME_THREADS) {
            put_step(i, euler_step_of(i, stage.step + k));
        }
        storageBarrier();
        for (var i = lid; i < n; i += FRAME_THREADS) {
            x_in[i] = x_out[i];
            v_in[i] = v_out[i];
        }
        storageBarrier();
    }
}
