//! The WGSL programs and the override constants they are compiled with. Each file is compiled
//! after `common.wgsl` and the function libraries it calls; the effects a scene lacks are
//! specialised away through `override` constants.

use crate::integrator::Integrator;
use crate::model::{Model, Shape};

const COMMON: &str = include_str!("../../shaders/common.wgsl");
/// Libraries: functions over bindings that each file calling them declares.
const MASS_FORCE: &str = include_str!("../../shaders/mass_force.wgsl");
const STATE_CHECK: &str = include_str!("../../shaders/state_check.wgsl");
const IMPLICIT_TERMS: &str = include_str!("../../shaders/implicit_terms.wgsl");
const SPRING_RECORDS: &str = include_str!("../../shaders/spring_records.wgsl");
const CONTACT_PROJECTION: &str = include_str!("../../shaders/contact_projection.wgsl");

/// A WGSL file of kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Program {
    Forces,
    Integrate,
    Collide,
    Reduce,
    Implicit,
    Springs,
    Grid,
    CollideMasses,
    Xpbd,
    Fused,
}

impl Program {
    pub const ALL: [Program; 10] = [
        Program::Forces,
        Program::Integrate,
        Program::Collide,
        Program::Reduce,
        Program::Implicit,
        Program::Springs,
        Program::Grid,
        Program::CollideMasses,
        Program::Xpbd,
        Program::Fused,
    ];

    pub fn file(self) -> &'static str {
        self.file_and_source().0
    }

    /// `common.wgsl`, the libraries the file calls, then the file.
    pub fn source(self) -> String {
        let libraries: &[&str] = match self {
            Program::Forces => &[MASS_FORCE, SPRING_RECORDS],
            Program::Integrate => &[STATE_CHECK],
            Program::Collide => &[CONTACT_PROJECTION],
            Program::Implicit => &[MASS_FORCE, SPRING_RECORDS, STATE_CHECK, IMPLICIT_TERMS],
            Program::Fused => &[MASS_FORCE, STATE_CHECK, CONTACT_PROJECTION],
            _ => &[],
        };
        format!(
            "{COMMON}\n{}\n{}",
            libraries.join("\n"),
            self.file_and_source().1
        )
    }

    fn file_and_source(self) -> (&'static str, &'static str) {
        macro_rules! file {
            ($name:literal) => {
                ($name, include_str!(concat!("../../shaders/", $name)))
            };
        }
        match self {
            Program::Forces => file!("forces.wgsl"),
            Program::Integrate => file!("integrate.wgsl"),
            Program::Collide => file!("collide.wgsl"),
            Program::Reduce => file!("reduce.wgsl"),
            Program::Implicit => file!("implicit.wgsl"),
            Program::Springs => file!("springs.wgsl"),
            Program::Grid => file!("grid.wgsl"),
            Program::CollideMasses => file!("collide_masses.wgsl"),
            Program::Xpbd => file!("xpbd.wgsl"),
            Program::Fused => file!("fused.wgsl"),
        }
    }
}

/// Every shader program as compiled: (file name, common + file).
pub fn programs() -> [(&'static str, String); 10] {
    Program::ALL.map(|p| (p.file(), p.source()))
}

pub const WORKGROUP: u32 = 64;

/// Workgroup counts for `threads` threads: a 2D grid when x would exceed the adapter's limit.
pub fn groups_for(threads: u32, max_per_dim: u32) -> (u32, u32) {
    let groups = threads.div_ceil(WORKGROUP).max(1);
    if groups <= max_per_dim {
        (groups, 1)
    } else {
        let y = groups.div_ceil(max_per_dim);
        (groups.div_ceil(y), y)
    }
}

// The hash grid's table is whole blocks of the GPU's prefix sum: four buckets per invocation
// (`SCAN_BLOCK` in shaders/common.wgsl).
const _: () = assert!(crate::cpu::SCAN_BLOCK == 4 * WORKGROUP);

/// Every override constant of a pipeline: the effects, the integrator's switches, the implicit
/// solver's stopping rules (the CPU's, so both backends stop alike), and where the fused steps'
/// links keep their spring kind (`kind_shift`, from `links.rs`; any value when unfused); the
/// one-workgroup implicit step's threads and, when it keeps its solver vectors and spring terms in
/// workgroup memory (`plan::implicit::SolverHome`), those arrays' lengths in vec4s.
pub fn constants(
    model: &Model,
    integrator: Integrator,
    kind_shift: u32,
    (group_threads, in_workgroup): (u32, Option<[u32; 2]>),
) -> Vec<(&'static str, f64)> {
    use crate::cpu::{
        CG_MAX_ITERATIONS, CG_TOLERANCE, NEWTON_FLOOR, NEWTON_MAX_ITERATIONS, NEWTON_STALL,
        NEWTON_TOLERANCE,
    };
    let mut c = effect_constants(model);
    let flag = |on: bool| if on { 1.0 } else { 0.0 };
    c.extend([
        ("XPBD", flag(integrator == Integrator::Xpbd)),
        ("IMPLICIT", flag(integrator == Integrator::Implicit)),
        (
            "SEMI_IMPLICIT",
            flag(integrator == Integrator::SemiImplicit),
        ),
        ("KIND_SHIFT", f64::from(kind_shift)),
        ("CG_TOLERANCE", CG_TOLERANCE),
        ("PAIR_STICK_SHARE", f64::from(crate::cpu::PAIR_STICK_SHARE)),
        ("CG_MAX_ITERATIONS", f64::from(CG_MAX_ITERATIONS)),
        ("NEWTON_TOLERANCE", NEWTON_TOLERANCE),
        ("NEWTON_MAX_ITERATIONS", f64::from(NEWTON_MAX_ITERATIONS)),
        ("NEWTON_FLOOR", NEWTON_FLOOR),
        ("NEWTON_STALL", NEWTON_STALL),
        ("GROUP_THREADS", f64::from(group_threads)),
    ]);
    // A workgroup array has at least one element, used or not.
    let [vectors, terms] = in_workgroup.unwrap_or([1, 1]);
    c.extend([
        ("SOLVER_IN_WORKGROUP", flag(in_workgroup.is_some())),
        ("WORKGROUP_VECTORS", f64::from(vectors)),
        ("WORKGROUP_TERMS", f64::from(terms)),
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
