// compute_forces: the full force on every mass (springs, gravity, drag, contact), one thread per
// mass; the force law is forces_on (mass_force.wgsl, compiled before this file). Mirrors
// src/cpu/forces.rs. Mass–mass contact is added after it by collide_masses (collide_masses.wgsl).

// Bindings: `ForcesModel` (group 0) and the state and stage groups of src/gpu/bindings.rs, which
// src/gpu/shaders.rs declares before this file; `#import` names the libraries compiled with it.
// #import mass_force spring_records stage_pose stage_step

@compute @workgroup_size(64)
fn compute_forces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups);
    if (i < params.mass_count) {
        forces_on(i);
    }
}
