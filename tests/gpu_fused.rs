//! The GPU's fused explicit steps (shaders/fused.wgsl: each step's per-mass passes folded into
//! its force gathers, the state ping-ponging between two buffers) against the general passes
//! (compute_forces, the update kernels, project_contacts): the same bits for Euler, semi-implicit
//! Euler, Verlet and RK4, through the ground, moving colliders and their projections, over odd
//! and even numbers of steps per submission; and the runs the fused steps cannot serve take the
//! general passes, saying why.

mod common;

use std::sync::Arc;

use common::{gpu_available, model_of, ok, scene_model};
use hooke::backend::Backend as _;
use hooke::gpu::{ExplicitPath, GpuBackend, ImplicitPath};
use hooke::integrator::{Integrator, Step};
use hooke::model::Model;
use hooke::state::State;

const FUSED: [Integrator; 4] = [
    Integrator::Euler,
    Integrator::SemiImplicit,
    Integrator::Verlet,
    Integrator::Rk4,
];

/// Steps per submission, odd and even: a fused Euler step that ends in the second buffer is
/// copied back before anything else reads the state.
const SUBMISSIONS: [u32; 6] = [1, 3, 2, 5, 4, 7];

/// The state after the submissions on `path`, and the masses projected on the way.
fn run(model: &Arc<Model>, integrator: Integrator, dt: f64, path: ExplicitPath) -> (State, u32) {
    let mut gpu = ok(GpuBackend::with_paths(
        model.clone(),
        Step::new(integrator, dt),
        None,
        (ImplicitPath::Passes, path),
    ));
    assert_eq!(gpu.explicit_path(), path, "{integrator}");
    let mut projections = 0;
    for (frame, steps) in SUBMISSIONS.into_iter().enumerate() {
        let stats = ok(gpu.advance(steps));
        projections += ok(gpu.snapshot(frame as u64, stats)).stats.projections;
    }
    (ok(gpu.state()), projections)
}

fn bits(s: &State) -> Vec<u32> {
    s.x.iter()
        .chain(&s.v)
        .flat_map(|p| p.to_array())
        .map(f32::to_bits)
        .collect()
}

/// A jello cube thrown down at 30 m/s onto the ground, a slope and a box, a keyframed sphere
/// sweeping through it: every kind of contact, with friction, deep enough to be projected.
const CONTACTS: &str = r#"
name = "contacts"
[solver]
frame_rate_hz = 60
substeps = 20
[effects]
gravity_m_per_s2 = [0.0, -9.81, 0.0]
[effects.ground]
height_m = -0.1
stiffness_n_per_m = 2000.0
friction = 0.4
restitution = 0.2
[[effects.planes]]
point_m = [0.0, -0.05, 0.0]
normal = [0.422618, 0.906308, 0.0]
stiffness_n_per_m = 2000.0
friction = 0.15
restitution = 0.2
[[effects.boxes]]
center_m = [0.2, -0.05, 0.1]
half_extents_m = [0.1, 0.15, 0.4]
stiffness_n_per_m = 2000.0
friction = 0.3
restitution = 0.2
[[effects.spheres]]
radius_m = 0.12
keyframes = [
  { time_secs = 0.0, center_m = [0.05, 0.12, 0.25] },
  { time_secs = 0.05, center_m = [0.05, 0.12, -0.15] },
]
stiffness_n_per_m = 2000.0
friction = 0.2
restitution = 0.2
[[bodies]]
name = "jello"
grid = [4, 4, 4]
spacing_m = 0.05
mass_kg = 0.5
origin_m = [0.0, 0.05, -0.05]
velocity_m_per_s = [0.5, -30.0, 0.0]
[bodies.springs]
structural = { stiffness_n_per_m = 200.0, damping_n_s_per_m = 0.02 }
shear = { stiffness_n_per_m = 200.0, damping_n_s_per_m = 0.02 }
bending = { stiffness_n_per_m = 50.0, damping_n_s_per_m = 0.005 }
"#;

#[test]
fn fused_steps_match_the_general_passes_bit_for_bit() {
    if !gpu_available() {
        return;
    }
    let mut projected = 0;
    // hair: springs only; jello-sphere: the ground and a sphere on a path; contacts: the ground,
    // a plane, a box and a keyframed sphere, with friction, at the scene's step and (but for
    // Euler, unstable there) twice it.
    let cases = [
        ("hair", scene_model("hair"), 1.0),
        ("jello-sphere", scene_model("jello-sphere"), 1.0),
        ("contacts", (model_of(CONTACTS), 1.0 / 1200.0), 1.0),
        ("contacts", (model_of(CONTACTS), 1.0 / 1200.0), 2.0),
    ];
    for (name, (model, scene_dt), scale) in cases {
        let dt = scale * scene_dt;
        for integrator in FUSED {
            if scale > 1.0 && integrator == Integrator::Euler {
                continue;
            }
            let what = format!("{name} {integrator} dt {dt:.3e}");
            let (fused, pf) = run(&model, integrator, dt, ExplicitPath::Fused);
            let (general, pg) = run(&model, integrator, dt, ExplicitPath::General);
            assert!(
                bits(&fused) == bits(&general),
                "{what}: the fused state differs from the general passes'"
            );
            assert_eq!(pf, pg, "{what}: masses projected");
            let (lf, lg) = (fused.ledger, general.ledger);
            for (f, g, term) in [
                (lf.damping_j, lg.damping_j, "damping"),
                (lf.drag_j, lg.drag_j, "drag"),
                (lf.contact_j, lg.contact_j, "contact"),
                (lf.collider_work_j, lg.collider_work_j, "collider work"),
            ] {
                assert_eq!(f.to_bits(), g.to_bits(), "{what}: ledger's {term}");
            }
            projected += pf;
        }
    }
    // Otherwise the projection folded into the fused steps went untested.
    assert!(projected > 0, "no run projected a mass");
}

/// Runs the fused steps cannot serve take the general passes, and `hooke check` says why.
#[test]
fn runs_the_fused_steps_cannot_serve_take_the_general_passes() {
    let cases = [
        ("tear", Integrator::SemiImplicit, "plasticity or tearing"),
        ("ramp", Integrator::Rk4, "plasticity or tearing"),
        ("cloth-fold", Integrator::SemiImplicit, "mass–mass contact"),
        ("jello", Integrator::Rk2, "rk2 has no fused step"),
    ];
    for (name, integrator, why) in cases {
        let (model, _) = scene_model(name);
        let (path, reason) = hooke::gpu::explicit_path(&model, integrator, u32::MAX);
        assert_eq!(path, ExplicitPath::General, "{name} {integrator}");
        let reason = reason.unwrap_or_default();
        assert!(reason.contains(why), "{name} {integrator}: {reason}");
    }
    for name in ["hair", "cloth", "jello", "jello-sphere", "cloth-256"] {
        let (model, _) = scene_model(name);
        for integrator in FUSED {
            let (path, reason) = hooke::gpu::explicit_path(&model, integrator, u32::MAX);
            assert_eq!(path, ExplicitPath::Fused, "{name} {integrator}: {reason:?}");
            // An adapter short of storage buffers keeps the general passes.
            let (path, reason) = hooke::gpu::explicit_path(&model, integrator, 8);
            assert_eq!(path, ExplicitPath::General, "{name} {integrator}");
            assert!(reason.is_some_and(|r| r.contains("storage buffers")));
        }
    }
}
