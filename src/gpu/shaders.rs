//! The WGSL programs as compiled, and the override constants they are compiled with. Each file
//! is compiled after `common.wgsl`, the declarations of the bind groups its kernels bind (from
//! `bindings.rs`: no WGSL file declares a binding) and the libraries it imports; the effects a
//! scene lacks are specialised away through `override` constants.

use super::bindings::Group;
use super::kernels::Kernel;
use super::programs::{COMMON, Program, directive, library};
use super::sizing::{FRAME_STATE_BYTES_PER_MASS, WORKGROUP};
use crate::integrator::{Explicit, Integrator, Over};
use crate::model::{Model, Shape};

/// Every shader program as compiled: (file name, source).
pub fn programs() -> [(&'static str, String); Program::ALL.len()] {
    Program::ALL.map(|p| (p.file(), source(p)))
}

/// The bind groups `p`'s kernels bind, in group order: the widest group 0 among them (a group
/// that extends another declares both), the state they read or flow between (group 1), the stage
/// slot and, when the state flows, the step's end slot, or for a kernel of many steps every
/// slot as words.
pub fn program_groups(p: Program) -> Vec<Group> {
    let specs: Vec<_> = Kernel::ALL
        .iter()
        .map(|k| k.spec())
        .filter(|s| s.program == p)
        .collect();
    let widest = specs
        .iter()
        .map(|s| s.group)
        .max_by_key(|g| g.bindings().len());
    let mut groups: Vec<Group> = widest.into_iter().collect();
    if specs.iter().any(|s| s.flows) {
        groups.extend([Group::Flow, Group::StageSlot, Group::StageEnd]);
    } else if specs.iter().any(|s| s.all_slots) {
        groups.extend([Group::StageSlot, Group::StageWords]);
    } else {
        if specs.iter().any(|s| s.reads_state) {
            groups.push(Group::State);
        }
        groups.push(Group::StageSlot);
    }
    groups
}

/// `p` as compiled: `common.wgsl`, the declarations of the groups it binds (`bindings.rs`), the
/// libraries its file imports (`// #import`, in order), then the file.
pub fn source(p: Program) -> String {
    let declarations: String = program_groups(p).into_iter().map(Group::wgsl).collect();
    let libraries: Vec<&str> = p.imports().filter_map(library).collect();
    format!(
        "{COMMON}\n{declarations}\n{}\n{}",
        libraries.join("\n"),
        p.text()
    )
}

/// What `p`'s composition lacks, one line each: an import that names no library, a binding a
/// library uses (`// #uses`) that the program does not declare, a function a library calls
/// (`// #calls`) that no piece of the program defines. Empty when it is whole
/// (`tests/shaders.rs` holds every program to that).
pub fn missing(p: Program) -> Vec<String> {
    let declared: Vec<&str> = program_groups(p)
        .into_iter()
        .flat_map(Group::bindings)
        .map(|b| b.name)
        .collect();
    unmet(p.file(), p.imports(), &declared, &source(p))
}

/// [`missing`] for a file named `file` importing `imports`, whose program declares the bindings
/// `declared` and reads `full` in all.
pub fn unmet<'a>(
    file: &str,
    imports: impl Iterator<Item = &'a str>,
    declared: &[&str],
    full: &str,
) -> Vec<String> {
    let mut out = Vec::new();
    for name in imports {
        let Some(lib) = library(name) else {
            out.push(format!("{file}: imports '{name}', which is no library"));
            continue;
        };
        for used in directive(lib, "uses").filter(|u| !declared.contains(u)) {
            out.push(format!(
                "{file}: library {name} uses binding '{used}', which the program does not bind"
            ));
        }
        for called in directive(lib, "calls") {
            if !full.contains(&format!("fn {called}(")) {
                out.push(format!(
                    "{file}: library {name} calls {called}(), which the program does not define"
                ));
            }
        }
    }
    out
}

// The hash grid's table is whole blocks of the GPU's prefix sum: four buckets per invocation
// (`SCAN_BLOCK` in shaders/common.wgsl).
const _: () = assert!(crate::physics::SCAN_BLOCK == 4 * WORKGROUP);

/// How a run's kernels are sized and switched, beyond its model: what [`constants`] writes as
/// their override constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Specialisation {
    /// The integrator's switches, and the implicit solver's stopping rules at the run's step
    /// (the CPU's, so both backends stop alike).
    pub integrator: Integrator,
    pub dt_secs: f64,
    /// Where the fused steps' links keep their spring kind (from `links.rs`; any value when
    /// unfused), and whether grid bodies take their springs from stencils (`stencils.rs`).
    pub kind_shift: u32,
    pub stencils: bool,
    /// The one-workgroup implicit step's threads and the per-pass kernels'
    /// (`sizing::solver_threads`).
    pub group_threads: u32,
    pub solver_threads: u32,
    /// When the one-workgroup step keeps its solver vectors and spring terms in workgroup
    /// memory (`implicit::SolverHome`), those arrays' lengths in vec4s.
    pub in_workgroup: Option<[u32; 2]>,
    /// The threads of the one-workgroup fused steps (`sizing::frame_threads`), of VBD's
    /// sweeps in one workgroup (`sizing::vbd_threads`) and the lanes it shares a mass among
    /// (`sizing::vbd_lanes`).
    pub frame_threads: u32,
    pub vbd_threads: u32,
    pub vbd_lanes: u32,
    /// How far apart the stage slots lie, in words (`StageSlots::stride_for`).
    pub stage_stride_words: u32,
    /// The masses whose state the one-workgroup fused steps keep in workgroup memory, if they
    /// do (`FrameState::masses_in_workgroup`).
    pub frame_state: Option<u32>,
}

/// Every override constant of a pipeline: the effects (absent ones specialised away), then
/// what `s` says.
pub fn constants(model: &Model, s: &Specialisation) -> Vec<(&'static str, f64)> {
    let Specialisation {
        integrator,
        dt_secs,
        kind_shift,
        stencils,
        group_threads,
        solver_threads,
        in_workgroup,
        frame_threads,
        vbd_threads,
        vbd_lanes,
        stage_stride_words,
        frame_state,
    } = *s;
    use crate::physics::{
        CG_FORCING, CG_FORCING_AT_RESTART, CG_MAX_ITERATIONS, NEWTON_BACKTRACKS,
        NEWTON_MAX_ITERATIONS, NEWTON_OVERSHOOT, NEWTON_STALL, NEWTON_TOLERANCE, NEWTON_WORK_SHARE,
        RESTART_PRESS_SHARE, newton_floor, newton_residual, weight_norm_n,
    };
    let mut c = effect_constants(model);
    let flag = |on: bool| if on { 1.0 } else { 0.0 };
    let scheme = integrator.scheme();
    let sweeps = scheme.sweeps().map(|s| s.over);
    c.extend([
        ("XPBD", flag(sweeps == Some(Over::Springs))),
        // VBD's block solve takes the contacts' block from mass_force, as implicit Euler does.
        ("IMPLICIT", flag(scheme.assembles_blocks())),
        // BDF2 blends each step's start from the last (implicit_blend_at), or restarts.
        ("HISTORY", flag(scheme.history())),
        (
            "SEMI_IMPLICIT",
            flag(scheme.explicit() == Some(Explicit::OneUpdate { symplectic: true })),
        ),
        ("KIND_SHIFT", f64::from(kind_shift)),
        ("HAS_STENCILS", flag(stencils)),
        (
            "PAIR_STICK_SHARE",
            f64::from(crate::physics::PAIR_STICK_SHARE),
        ),
        ("CG_MAX_ITERATIONS", f64::from(CG_MAX_ITERATIONS)),
        ("NEWTON_TOLERANCE", NEWTON_TOLERANCE),
        ("NEWTON_MAX_ITERATIONS", f64::from(NEWTON_MAX_ITERATIONS)),
        (
            "NEWTON_RESIDUAL",
            newton_residual(dt_secs, integrator.order()),
        ),
        ("NEWTON_FLOOR", newton_floor(dt_secs, integrator.order())),
        ("WEIGHT_N", f64::from(weight_norm_n(model))),
        (
            "PAIR_ONSET_SQ",
            f64::from(
                model
                    .effects
                    .self_collision
                    .map_or(0.0, |c| crate::physics::pair_onset_sq_m2(c.radius_m)),
            ),
        ),
        ("NEWTON_STALL", NEWTON_STALL),
        ("NEWTON_BACKTRACKS", f64::from(NEWTON_BACKTRACKS)),
        ("NEWTON_OVERSHOOT", NEWTON_OVERSHOOT),
        ("NEWTON_WORK_SHARE", NEWTON_WORK_SHARE),
        ("CG_FORCING", CG_FORCING),
        ("CG_FORCING_AT_RESTART", CG_FORCING_AT_RESTART),
        ("RESTART_PRESS_SHARE", f64::from(RESTART_PRESS_SHARE)),
        ("VBD_RESIDUAL", crate::physics::VBD_RESIDUAL),
        (
            "DEEP_SHARE",
            f64::from(crate::laws::contact_law::DEEP_SHARE),
        ),
        (
            "MG_SMOOTHING",
            f64::from(crate::physics::hierarchy::SMOOTHING),
        ),
        ("GROUP_THREADS", f64::from(group_threads)),
        ("SOLVER_THREADS", f64::from(solver_threads)),
        (
            "SUM_LEVEL",
            f64::from(super::sizing::sum_level(group_threads)),
        ),
        ("SUM_SLOTS", f64::from(group_threads.max(WORKGROUP))),
        ("FRAME_THREADS", f64::from(frame_threads)),
        ("VBD_THREADS", f64::from(vbd_threads)),
        ("VBD_LANES", f64::from(vbd_lanes)),
        ("STAGE_STRIDE_WORDS", f64::from(stage_stride_words)),
    ]);
    // A workgroup array has at least one element, used or not.
    let [vectors, terms] = in_workgroup.unwrap_or([1, 1]);
    c.extend([
        ("SOLVER_IN_WORKGROUP", flag(in_workgroup.is_some())),
        ("WORKGROUP_VECTORS", f64::from(vectors)),
        ("WORKGROUP_TERMS", f64::from(terms)),
    ]);
    let frame_masses = frame_state.unwrap_or(1);
    c.extend([
        ("STATE_IN_WORKGROUP", flag(frame_state.is_some())),
        ("WORKGROUP_MASSES", f64::from(frame_masses)),
        (
            "WORKGROUP_STATE_WORDS",
            f64::from(frame_state.map_or(1, |m| m * (FRAME_STATE_BYTES_PER_MASS / 4))),
        ),
    ]);
    c
}

/// The override constants that switch effects on, from the model.
pub fn effect_constants(model: &Model) -> Vec<(&'static str, f64)> {
    let e = &model.effects;
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    vec![
        ("HAS_GRAVITY", flag(e.gravity_m_per_s2.is_some())),
        ("HAS_DRAG", flag(e.air_drag_per_s.is_some())),
        ("HAS_GROUND", flag(e.ground.is_some())),
        (
            "HAS_SPHERES",
            flag(e.has_shape(|s| matches!(s, Shape::Sphere { .. }))),
        ),
        (
            "HAS_BOXES",
            flag(e.has_shape(|s| matches!(s, Shape::Box { .. }))),
        ),
        (
            "HAS_PLANES",
            flag(e.has_shape(|s| matches!(s, Shape::Plane { .. }))),
        ),
        ("HAS_COLLIDERS", flag(!e.colliders.is_empty())),
        (
            "HAS_DAMPING",
            flag(model.springs.iter().any(|s| s.damping_n_s_per_m != 0.0)),
        ),
        ("HAS_PLASTICITY", flag(e.plasticity)),
        ("HAS_TEARING", flag(e.tearing)),
    ]
}
