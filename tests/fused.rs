//! The CPU backend's fused step (src/cpu/fused.rs: gather, update, ledger and divergence look in
//! one pass, SIMD lanes over masses that share a stencil) against the general path
//! (`compute_forces`, then the update): the same bits for every kernel, every integrator it
//! serves, serial and threaded, through a collapsed spring and up to divergence.

use std::sync::Arc;

use crate::common::{model_of, ok};
use glam::Vec3;
use hooke::backend::{Backend as _, BackendError};
use hooke::cpu::{CpuBackend, Simd};
use hooke::integrator::{Integrator, Step};
use hooke::model::{Model, ModelBuilder};
use hooke::state::State;

/// A cloth of `nx` × `nz` masses with all three kinds of spring (different constants), two pins,
/// gravity and air drag, released with a velocity so that the dashpots work from the start.
fn built_in(name: &str) -> Arc<Model> {
    Arc::new(hooke::model::build(&ok(hooke::scene::load(name)).scene))
}

fn cloth(nx: u32, nz: u32) -> Arc<Model> {
    model_of(&format!(
        r#"
name = "cloth"
[effects]
gravity_m_per_s2 = [0.0, -9.81, 0.0]
air_drag_per_s = 0.3
[[bodies]]
name = "cloth"
grid = [{nx}, {nz}]
spacing_m = 0.013
mass_kg = 0.5
origin_m = [0.1, 0.2, -0.3]
velocity_m_per_s = [0.0, 0.5, 0.2]
axes = [[1.0, 0.0, 0.0], [0.0, 0.3, 1.0]]
pins = [[0, 0], [{last}, 0]]
springs.structural = {{ stiffness_n_per_m = 800.0, damping_n_s_per_m = 0.05 }}
springs.shear = {{ stiffness_n_per_m = 300.0, damping_n_s_per_m = 0.02 }}
springs.bending = {{ stiffness_n_per_m = 40.0 }}
"#,
        last = nx - 1
    ))
}

/// A block (3D stencils, 26 neighbours and bending) falling under gravity, no drag.
fn block() -> Arc<Model> {
    model_of(
        r#"
name = "block"
[effects]
gravity_m_per_s2 = [0.0, -9.81, 0.0]
[[bodies]]
name = "block"
grid = [11, 9, 10]
spacing_m = 0.02
mass_kg = 1.0
origin_m = [0.0, 0.5, 0.0]
velocity_m_per_s = [0.3, 0.0, -0.1]
pins = [[0, 8, 0]]
springs.structural = { stiffness_n_per_m = 2000.0, damping_n_s_per_m = 0.5 }
springs.shear = { stiffness_n_per_m = 2000.0, damping_n_s_per_m = 0.5 }
springs.bending = { stiffness_n_per_m = 500.0, damping_n_s_per_m = 0.1 }
"#,
    )
}

/// Every kernel this machine can run (AVX2 resolves to SSE2 where the CPU lacks it).
const KERNELS: [Simd; 5] = [
    Simd::Best,
    Simd::Avx2,
    Simd::Sse2,
    Simd::Portable,
    Simd::Scalar,
];

fn run(
    model: &Arc<Model>,
    integrator: Integrator,
    dt: f64,
    kernel: Option<Simd>,
) -> Result<State, BackendError> {
    let mut be = CpuBackend::new(model.clone(), Step::new(integrator, dt));
    be.set_simd(kernel);
    assert_eq!(be.simd().is_some(), kernel.is_some(), "{kernel:?}");
    for _ in 0..4 {
        be.advance(25)?;
    }
    be.state()
}

fn bits(v: &[Vec3]) -> &[u8] {
    bytemuck::cast_slice(v)
}

fn assert_same(what: &str, general: &State, fused: &State) {
    assert!(
        bits(&general.x) == bits(&fused.x) && bits(&general.v) == bits(&fused.v),
        "{what}: the fused step's state differs from the general path's"
    );
    assert_eq!(general.ledger, fused.ledger, "{what}: ledgers differ");
    assert_eq!(general.steps, fused.steps, "{what}");
    assert_eq!(
        general.time_secs.to_bits(),
        fused.time_secs.to_bits(),
        "{what}"
    );
}

/// The state must have gone somewhere, or agreeing would prove nothing.
fn assert_moved(what: &str, model: &Model, s: &State) {
    let moved =
        s.x.iter()
            .zip(&model.initial.x)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0f32, f32::max);
    assert!(moved > 1e-4, "{what}: moved only {moved} m");
    assert!(s.ledger.damping_j > 0.0, "{what}: the dashpots did no work");
}

#[test]
fn every_kernel_gives_the_general_paths_bits() {
    // 80 × 64 = 5 120 masses run on the thread pool; the others one chunk at a time.
    let models = [
        ("cloth 80×64", cloth(80, 64), 2e-4),
        ("cloth 19×7", cloth(19, 7), 2e-4),
        ("block", block(), 1e-4),
        ("hair", built_in("hair"), 1.0 / 1200.0),
    ];
    for (name, model, dt) in &models {
        for integrator in [Integrator::SemiImplicit, Integrator::Euler] {
            // Explicit Euler gains energy; a shorter step keeps it from running away here.
            let dt = if integrator == Integrator::Euler {
                dt * 0.25
            } else {
                *dt
            };
            let general = ok(run(model, integrator, dt, None));
            assert_moved(name, model, &general);
            for kernel in KERNELS {
                let fused = ok(run(model, integrator, dt, Some(kernel)));
                assert_same(
                    &format!("{name}, {integrator:?}, {kernel:?}"),
                    &general,
                    &fused,
                );
            }
        }
    }
}

#[test]
fn a_grids_interior_runs_in_lanes() {
    let mut be = CpuBackend::new(cloth(80, 64), Step::new(Integrator::SemiImplicit, 1e-4));
    be.set_simd(Some(Simd::Sse2));
    let share = be.lane_share().unwrap_or(0.0);
    // In every row the masses of columns 2..78 (of 80) share a stencil (edge rows too: theirs
    // lacks the springs beyond the edge, the same for the whole row); two columns at each side
    // have their own: 64 × 76 of the 5 120 masses.
    assert!((share - 64.0 * 76.0 / 5120.0).abs() < 1e-9, "share {share}");
}

#[test]
fn the_fused_step_serves_only_what_it_computes_exactly() {
    let jello = built_in("jello");
    assert!(
        CpuBackend::new(jello, Step::new(Integrator::SemiImplicit, 1e-4))
            .simd()
            .is_none()
    );
    let c = cloth(10, 10);
    assert!(
        CpuBackend::new(c.clone(), Step::new(Integrator::Rk4, 1e-4))
            .simd()
            .is_none()
    );
    assert!(
        CpuBackend::new(c.clone(), Step::new(Integrator::Xpbd, 1e-4))
            .simd()
            .is_none()
    );
    assert_eq!(
        CpuBackend::new(c, Step::new(Integrator::SemiImplicit, 1e-4)).simd(),
        Some(Simd::Best.resolve())
    );
}

/// A chain of 40 masses whose every fourth spring has zero length: those exert nothing, in
/// the lanes as in the scalar code.
#[test]
fn a_collapsed_spring_exerts_nothing_in_every_kernel() {
    let mut mb = ModelBuilder::new();
    let mut x = 0.0f32;
    for i in 0..40 {
        if i % 4 != 3 {
            x += 0.05;
        }
        mb.mass(
            Vec3::new(x, 1.0, 0.0),
            Vec3::new(0.0, 0.1 * i as f32, 0.0),
            0.01,
            i == 0,
        );
    }
    for i in 0..39 {
        mb.spring(i, i + 1, 100.0, 0.01);
    }
    mb.effects(hooke::model::Effects {
        gravity_m_per_s2: Some(Vec3::new(0.0, -9.81, 0.0)),
        ..Default::default()
    });
    let model = Arc::new(mb.build());
    let general = ok(run(&model, Integrator::SemiImplicit, 1e-4, None));
    assert_moved("chain", &model, &general);
    for kernel in KERNELS {
        let fused = ok(run(&model, Integrator::SemiImplicit, 1e-4, Some(kernel)));
        assert_same(&format!("chain, {kernel:?}"), &general, &fused);
    }
}

#[test]
fn a_diverging_fused_step_stops_where_the_general_path_does() {
    // Far beyond the stable step: it blows up within the run.
    let model = cloth(40, 40);
    let divergence = |kernel| match run(&model, Integrator::SemiImplicit, 0.02, kernel) {
        Err(BackendError::Diverged(d)) => *d,
        other => panic!(
            "{kernel:?}: expected a divergence, got {:?}",
            other.map(|s| s.steps)
        ),
    };
    let general = divergence(None);
    for kernel in KERNELS {
        assert_eq!(divergence(Some(kernel)), general, "{kernel:?}");
    }
}

#[test]
fn the_fused_step_is_the_same_on_one_thread_and_two() {
    let model = cloth(80, 64);
    let in_pool = |threads| {
        ok(rayon::ThreadPoolBuilder::new().num_threads(threads).build()).install(|| {
            ok(run(
                &model,
                Integrator::SemiImplicit,
                2e-4,
                Some(Simd::Best),
            ))
        })
    };
    let one = in_pool(1);
    assert_same("1 vs 2 threads", &one, &in_pool(2));
    assert_same("2 threads twice", &in_pool(2), &in_pool(2));
}
