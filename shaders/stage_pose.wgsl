// collider_pose for the kernels of one stage slot: collider k's pose at the dispatch's stage.
// (fused_frame.wgsl, which runs many steps, reads each step's slot instead.)
// A library: `#uses` names the bindings it reads, which its program must bind, and `#calls` the
// functions its program must define (src/gpu/shaders.rs checks both when it composes a program).
// #uses stage

fn collider_pose(k: u32) -> Pose {
    return stage.poses[k];
}
