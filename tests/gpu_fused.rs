//! The GPU's fused explicit steps (shaders/fused.wgsl: each step's per-mass passes folded into
//! its force gathers, the state ping-ponging between two buffers), and for small scenes every
//! step of a submission in one workgroup (shaders/fused_frame.wgsl, its state in workgroup memory
//! or in the state buffers between steps), against the general passes
//! (compute_forces, the update kernels, project_contacts): the same bits for Euler, semi-implicit
//! Euler, Verlet and RK4, through the ground, moving colliders and their projections,
//! over odd and even numbers of steps per submission; and the runs the fused steps cannot serve
//! take the general passes, saying why.

use std::sync::Arc;

use crate::common::{gpu_available, model_of, ok, scene_model};
use hooke::backend::Backend as _;
use hooke::gpu::{ExplicitPath, FrameState, GpuBackend, ImplicitPath, Unfused};
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
/// copied back before anything else reads the state; and none (one workgroup must not run the
/// count its stage slot held from the submission before).
const SUBMISSIONS: [u32; 7] = [1, 3, 0, 2, 5, 4, 7];

/// The state after the submissions on `path` (or on the fused path, for a run that cannot
/// step in one workgroup), the masses projected on the way, and the path taken.
fn run(
    model: &Arc<Model>,
    integrator: Integrator,
    dt: f64,
    path: ExplicitPath,
) -> (State, u32, ExplicitPath) {
    run_with(model, integrator, dt, (path, FrameState::Workgroup)).0
}

/// As `run`, one workgroup keeping its state where `home` says where it fits; and whether it
/// kept it in workgroup memory.
fn run_with(
    model: &Arc<Model>,
    integrator: Integrator,
    dt: f64,
    (path, home): (ExplicitPath, FrameState),
) -> ((State, u32, ExplicitPath), bool) {
    let tuning = hooke::gpu::Tuning {
        implicit: ImplicitPath::Passes,
        explicit: path,
        frame_state: home,
        ..hooke::gpu::Tuning::for_run(model, Step::new(integrator, dt))
    };
    let mut gpu = ok(GpuBackend::with_tuning(
        model.clone(),
        Step::new(integrator, dt),
        None,
        tuning,
    ));
    // Only small scenes step in one workgroup, the others fused a dispatch per step.
    let taken = gpu.explicit_path();
    assert!(
        taken == path || (path, taken) == (ExplicitPath::InGroup, ExplicitPath::Fused),
        "{integrator}: {taken:?} for {path:?}"
    );
    let mut projections = 0;
    for (frame, steps) in SUBMISSIONS.into_iter().enumerate() {
        let stats = ok(gpu.advance(steps));
        projections += ok(gpu.snapshot(frame as u64, stats)).stats.projections;
    }
    let in_workgroup = gpu.frame_state_in_workgroup();
    ((ok(gpu.state()), projections, taken), in_workgroup)
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
    let mut in_group = 0;
    let mut projected_in_group = 0;
    // Runs in one workgroup by where they kept the state: buffers, workgroup memory.
    let mut homes = [0; 2];
    // hair: springs only; jello-sphere: the ground and a sphere on a path; contacts: the ground,
    // a plane, a box and a keyframed sphere, with friction, at the scene's step and (but for
    // Euler, unstable there) twice it. On a CPU adapter hair and contacts step in one workgroup,
    // the sphere's poses read step by step.
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
            let (general, pg, _) = run(&model, integrator, dt, ExplicitPath::General);
            let ways = [
                (ExplicitPath::Fused, FrameState::Workgroup),
                (ExplicitPath::InGroup, FrameState::Workgroup),
                (ExplicitPath::InGroup, FrameState::Buffers),
            ];
            for (path, home) in ways {
                let what = format!("{name} {integrator} dt {dt:.3e} {path:?} {home:?}");
                let ((fused, pf, taken), in_workgroup) =
                    run_with(&model, integrator, dt, (path, home));
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
                if taken == ExplicitPath::InGroup {
                    in_group += 1;
                    projected_in_group += pf;
                    homes[usize::from(in_workgroup)] += 1;
                    assert!(
                        !in_workgroup || home == FrameState::Workgroup,
                        "{what}: kept in workgroup memory"
                    );
                }
            }
            projected += pg;
        }
    }
    // Otherwise the projection folded into the fused steps, or the steps in one workgroup,
    // went untested.
    assert!(projected > 0, "no run projected a mass");
    // A driver that cuts loops short steps no run in one workgroup (tests/gpu.rs, the loop
    // probe): there every run above compared the fused steps with the general passes.
    let budget = hooke::gpu::LoopBudget::measure(&ok(hooke::gpu::GpuContext::open(None)));
    if !budget.runs_long_loops() {
        assert_eq!(
            in_group, 0,
            "{budget}, yet {in_group} runs stepped in one workgroup"
        );
        return;
    }
    assert!(in_group >= 10, "{in_group} runs stepped in one workgroup");
    assert!(
        homes[0] >= 5 && homes[1] >= 5,
        "runs in one workgroup with the state in buffers, in workgroup memory: {homes:?}"
    );
    assert!(
        projected_in_group > 0,
        "no run in one workgroup projected a mass"
    );
}

/// A grid body beside a mesh body (the flag): the grid's masses find their springs from its
/// stencil, the mesh's read links, in the same dispatches; bit for bit the general passes, which
/// read every spring's record.
#[test]
fn grid_stencils_beside_links_match_the_general_passes_bit_for_bit() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes");
    let flag = std::fs::read_to_string(dir.join("flag.toml")).unwrap_or_else(|e| panic!("{e}"));
    let text = format!(
        "{flag}\n[[bodies]]\nname = \"cube\"\ngrid = [3, 4, 5]\nspacing_m = 0.05\nmass_kg = 0.5\n\
         origin_m = [0.3, 1.0, 0.2]\naxes = [[0.97, 0.26, 0.0], [-0.26, 0.97, 0.0], [0.0, 0.0, 1.0]]\n\
         springs.structural = {{ stiffness_n_per_m = 400.0, damping_n_s_per_m = 0.02 }}\n\
         springs.shear = {{ stiffness_n_per_m = 300.0, damping_n_s_per_m = 0.01 }}\n\
         springs.bending = {{ stiffness_n_per_m = 50.0, damping_n_s_per_m = 0.005 }}\n"
    );
    let origin = hooke::scene::SceneOrigin::File(dir.join("mixed.toml"));
    let scene = ok(hooke::scene::from_toml(&text, origin));
    let model = Arc::new(hooke::model::build(&scene));
    let cube = model
        .bodies
        .iter()
        .find(|b| b.name == "cube")
        .expect("the cube");
    assert_eq!(
        hooke::gpu::stencil_cover(&model),
        (1, cube.masses.len()),
        "the cube, and only the cube, takes a stencil"
    );
    if !gpu_available() {
        return;
    }
    let dt = 1.0 / 2400.0;
    for integrator in FUSED {
        let (general, _, _) = run(&model, integrator, dt, ExplicitPath::General);
        let (fused, _, _) = run(&model, integrator, dt, ExplicitPath::Fused);
        assert!(
            bits(&fused) == bits(&general),
            "{integrator}: the stencil and links differ from the general passes"
        );
    }
}

/// Runs the fused steps cannot serve take the general passes, and `hooke check` says why; small
/// scenes step a submission in one workgroup, on a CPU adapter only the smallest.
#[test]
fn runs_the_fused_steps_cannot_serve_take_the_general_passes() {
    use wgpu::DeviceType::{Cpu, DiscreteGpu};
    let path_of = |model: &Model, integrator, buffers, device| {
        hooke::gpu::explicit_path(model, integrator, (buffers, device))
    };
    let cases = [
        ("tear", Integrator::SemiImplicit, Unfused::SpringsChange),
        ("ramp", Integrator::Rk4, Unfused::SpringsChange),
        ("cloth-fold", Integrator::SemiImplicit, Unfused::MassContact),
        (
            "jello",
            Integrator::Rk2,
            Unfused::NoFusedStep(Integrator::Rk2),
        ),
    ];
    for (name, integrator, why) in cases {
        let (model, _) = scene_model(name);
        let (path, reason) = path_of(&model, integrator, u32::MAX, DiscreteGpu);
        assert_eq!(path, ExplicitPath::General, "{name} {integrator}");
        assert_eq!(reason, Some(why), "{name} {integrator}");
    }
    let mut in_group = 0;
    for name in ["hair", "cloth", "jello", "jello-sphere", "cloth-256"] {
        let (model, _) = scene_model(name);
        for integrator in FUSED {
            for device in [DiscreteGpu, Cpu] {
                let (path, reason) = path_of(&model, integrator, u32::MAX, device);
                // Euler's and semi-implicit Euler's steps of a few thousand masses (a few
                // hundred on a CPU adapter) run in one workgroup, colliders moving or not.
                let single = matches!(integrator, Integrator::Euler | Integrator::SemiImplicit);
                let small = model.mass_count() <= hooke::gpu::one_group_step_masses(device);
                let expected = if single && small {
                    in_group += 1;
                    ExplicitPath::InGroup
                } else {
                    ExplicitPath::Fused
                };
                assert_eq!(path, expected, "{name} {integrator} {device:?}: {reason:?}");
                // An adapter short of storage buffers keeps the general passes.
                let (path, reason) = path_of(&model, integrator, 8, device);
                assert_eq!(path, ExplicitPath::General, "{name} {integrator}");
                let short = Unfused::StorageBuffers {
                    allowed: 8,
                    needed: hooke::gpu::FUSED_STORAGE_BUFFERS_NEEDED,
                };
                assert_eq!(reason, Some(short), "{name} {integrator}");
            }
        }
    }
    // hair, cloth, jello and jello-sphere on a GPU, hair on a CPU adapter; Euler and
    // semi-implicit Euler.
    assert_eq!(in_group, 10);
}
