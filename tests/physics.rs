//! Analytic checks of the CPU reference physics: free fall, a two-mass spring's period, a
//! pendulum's period, each integrator's convergence order, and Coulomb friction's stopping
//! distance; the CPU backend's determinism, the simulation thread's delivery, and `--dt auto`'s
//! accuracy. Energy conservation and balance are in tests/energy.rs.

use std::sync::Arc;

use crate::common::{G, gravity};
use glam::Vec3;
use hooke::backend::Backend as _;
use hooke::cpu::CpuBackend;
use hooke::integrator::{Integrator, Step};
use hooke::model::{ContactModel, Effects, GroundCollider, Model, ModelBuilder, SpringKindTag};
use hooke::state::State;

fn run(model: &Arc<Model>, integrator: Integrator, dt: f64, steps: u64) -> State {
    let mut be = CpuBackend::new(model.clone(), Step::new(integrator, dt));
    let mut left = steps;
    while left > 0 {
        let n = left.min(10_000) as u32;
        if let Err(d) = be.advance(n) {
            panic!("{d}");
        }
        left -= u64::from(n);
    }
    be.state().unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn free_fall_matches_each_schemes_exact_discrete_solution() {
    let mut mb = ModelBuilder::new();
    mb.mass(
        Vec3::new(0.0, 10.0, 0.0),
        Vec3::new(1.0, 2.0, 0.0),
        0.5,
        false,
    );
    mb.effects(gravity());
    let model = Arc::new(mb.build());
    let (dt, steps) = (0.01f64, 100u64);
    let t = dt * steps as f64;
    let g = f64::from(G);
    // Exact: y = 10 + 2t − g t²/2. Forward Euler lags by g·dt·t/2, semi-implicit Euler leads by
    // the same; the second- and fourth-order schemes are exact for constant acceleration.
    let exact_y = 10.0 + 2.0 * t - 0.5 * g * t * t;
    for integrator in Integrator::ALL {
        let s = run(&model, integrator, dt, steps);
        let bias = match integrator {
            Integrator::Euler => 0.5 * g * dt * t,
            // Backward Euler on a constant force is semi-implicit Euler, and so are XPBD with
            // no springs to project and VBD (whose block solve is backward Euler's, mass by mass).
            Integrator::SemiImplicit
            | Integrator::Implicit
            | Integrator::Xpbd
            | Integrator::Vbd => -0.5 * g * dt * t,
            // BDF2 is exact on a quadratic path from an exact history, and so exact for v; its
            // first step, implicit Euler's, leaves x off by −g dt²/2, which the recursion
            // e₊₁ = (4e − e₋₁)/3 carries to 3/2 of itself: −(3/4) g dt².
            Integrator::Bdf2 => -0.75 * g * dt * dt,
            _ => 0.0,
        };
        let y = f64::from(s.x[0].y);
        assert!(
            (y - (exact_y + bias)).abs() < 2e-5,
            "{integrator}: y = {y}, expected {}",
            exact_y + bias
        );
        assert!(
            (f64::from(s.x[0].x) - t).abs() < 1e-5,
            "{integrator}: x drifted"
        );
        assert!(
            (f64::from(s.v[0].y) - (2.0 - g * t)).abs() < 2e-5,
            "{integrator}: vy = {}",
            s.v[0].y
        );
    }
}

/// Times at which `f` crosses zero upwards, linearly interpolated.
fn upward_crossings(samples: &[(f64, f64)]) -> Vec<f64> {
    samples
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (-w[0].1) / (w[1].1 - w[0].1))
        .collect()
}

/// Step and record `observe(state)` after every step.
fn trace(
    model: &Arc<Model>,
    integrator: Integrator,
    dt: f64,
    steps: u64,
    observe: impl Fn(&State) -> f64,
) -> Vec<(f64, f64)> {
    let mut be = CpuBackend::new(model.clone(), Step::new(integrator, dt));
    let mut out = Vec::with_capacity(steps as usize);
    for _ in 0..steps {
        be.advance(1).unwrap_or_else(|d| panic!("{d}"));
        let s = be.state().unwrap_or_else(|e| panic!("{e}"));
        out.push((s.time_secs, observe(&s)));
    }
    out
}

fn mean_period(crossings: &[f64]) -> f64 {
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64
}

#[test]
fn two_mass_spring_oscillates_at_the_reduced_mass_frequency_and_conserves_momentum() {
    let (m1, m2, k) = (1.0f32, 3.0f32, 50.0f32);
    let mut mb = ModelBuilder::new();
    // Both drift together (no rotation), so the separation is a pure oscillation.
    let drift = Vec3::new(0.0, 0.2, 0.1);
    let a = mb.mass(Vec3::ZERO, drift, m1, false);
    let b = mb.mass(Vec3::new(1.1, 0.0, 0.0), drift, m2, false);
    mb.spring_with_rest(a, b, 1.0, k, 0.0, SpringKindTag::Custom);
    let model = Arc::new(mb.build());
    let mu = f64::from(m1 * m2 / (m1 + m2));
    let expected = 2.0 * std::f64::consts::PI * (mu / f64::from(k)).sqrt();
    let dt = 1e-3;
    let samples = trace(&model, Integrator::Rk4, dt, 4000, |s| {
        f64::from(s.x[1].x - s.x[0].x) - 1.0
    });
    let period = mean_period(&upward_crossings(&samples));
    assert!(
        (period / expected - 1.0).abs() < 1e-3,
        "period {period} s, expected {expected} s"
    );
    // Momentum is conserved exactly by the pairwise gather (equal and opposite forces).
    let s = run(&model, Integrator::SemiImplicit, dt, 4000);
    let p = m1 * s.v[0] + m2 * s.v[1];
    assert!(p.abs_diff_eq((m1 + m2) * drift, 1e-5), "momentum {p}");
}

#[test]
fn pendulum_small_angle_period() {
    // A 1 kg bob on a stiff 1 m spring from a pin, released at 5°.
    let (len, theta0) = (1.0f32, 5f32.to_radians());
    let mut mb = ModelBuilder::new();
    let pin = mb.mass(Vec3::ZERO, Vec3::ZERO, 1.0, true);
    let bob = mb.mass(
        Vec3::new(len * theta0.sin(), -len * theta0.cos(), 0.0),
        Vec3::ZERO,
        1.0,
        false,
    );
    mb.spring(pin, bob, 1.0e5, 0.0);
    mb.effects(gravity());
    let model = Arc::new(mb.build());
    // Small-angle period with the first amplitude correction, for the stretched length L + mg/k.
    let l_eff = f64::from(len) + f64::from(G) / 1.0e5;
    let t0 = 2.0 * std::f64::consts::PI * (l_eff / f64::from(G)).sqrt();
    let expected = t0 * (1.0 + f64::from(theta0).powi(2) / 16.0);
    for integrator in [
        Integrator::SemiImplicit,
        Integrator::Verlet,
        Integrator::Rk4,
    ] {
        let samples = trace(&model, integrator, 1e-3, 8000, |s| f64::from(s.x[1].x));
        let period = mean_period(&upward_crossings(&samples));
        assert!(
            (period / expected - 1.0).abs() < 1e-3,
            "{integrator}: period {period} s, expected {expected} s"
        );
    }
}

/// A 1 kg mass on a spring of 4π² N/m (period 1 s) from a pin, released 0.1 m from rest.
fn oscillator() -> Arc<Model> {
    let k = 4.0 * std::f32::consts::PI * std::f32::consts::PI;
    let mut mb = ModelBuilder::new();
    let pin = mb.mass(Vec3::ZERO, Vec3::ZERO, 1.0, true);
    let m = mb.mass(Vec3::new(1.1, 0.0, 0.0), Vec3::ZERO, 1.0, false);
    mb.spring_with_rest(pin, m, 1.0, k, 0.0, SpringKindTag::Custom);
    Arc::new(mb.build())
}

/// Error in phase space at t = 0.3 s against x = 1 + 0.1 cos(2πt). (Not at a whole period:
/// there the first-order error of semi-implicit Euler happens to cancel.)
fn oscillator_error(model: &Arc<Model>, integrator: Integrator, dt: f64) -> f64 {
    let steps = (0.3 / dt).round() as u64;
    let s = run(model, integrator, dt, steps);
    let w = 2.0 * std::f64::consts::PI;
    let t = s.time_secs;
    let (x, v) = (1.0 + 0.1 * (w * t).cos(), -0.1 * w * (w * t).sin());
    let ex = f64::from(s.x[1].x) - x;
    let ev = (f64::from(s.v[1].x) - v) / w;
    (ex * ex + ev * ev).sqrt()
}

#[test]
fn each_integrator_converges_at_its_order() {
    let model = oscillator();
    // Ladders chosen so the error is asymptotic yet far above f32 round-off.
    let cases = [
        (Integrator::Euler, 1.0 / 2000.0),
        (Integrator::SemiImplicit, 1.0 / 2000.0),
        (Integrator::Rk2, 1.0 / 200.0),
        (Integrator::Rk4, 1.0 / 10.0),
        (Integrator::Verlet, 1.0 / 50.0),
        (Integrator::Xpbd, 1.0 / 2000.0),
        (Integrator::Bdf2, 1.0 / 100.0),
    ];
    for (integrator, dt) in cases {
        let e: Vec<f64> = (0..3)
            .map(|i| oscillator_error(&model, integrator, dt / f64::from(1 << i)))
            .collect();
        let expected = f64::from(1u32 << integrator.order());
        for w in e.windows(2) {
            let ratio = w[0] / w[1];
            assert!(
                (ratio / expected - 1.0).abs() < 0.12,
                "{integrator}: halving dt divided the error by {ratio:.3}, expected {expected} (errors {e:?})"
            );
        }
    }
}

/// An 8 × 8 cloth patch hanging from two corners under gravity.
#[test]
fn sliding_block_stops_at_the_coulomb_distance() {
    let (mu, v0, k) = (0.5f32, 2.0f32, 1.0e4f32);
    let contact = ContactModel {
        stiffness_n_per_m: k,
        friction: mu,
        damping_ratio: 1.0,
    };
    let mut mb = ModelBuilder::new();
    // Start at the resting depth so the normal force is m g from the first step.
    mb.mass(
        Vec3::new(0.0, -G / k, 0.0),
        Vec3::new(v0, 0.0, 0.0),
        1.0,
        false,
    );
    mb.effects(Effects {
        ground: Some(GroundCollider {
            height_m: 0.0,
            contact,
            max_depth_m: 0.1,
        }),
        ..gravity()
    });
    let model = Arc::new(mb.build());
    let expected = f64::from(v0 * v0 / (2.0 * mu * G));
    for integrator in [
        Integrator::SemiImplicit,
        Integrator::Verlet,
        Integrator::Rk4,
    ] {
        let s = run(&model, integrator, 1e-3, 1000);
        let d = f64::from(s.x[0].x);
        assert!(
            (d / expected - 1.0).abs() < 5e-3,
            "{integrator}: stopped after {d} m, expected {expected} m"
        );
        assert!(
            s.v[0].length() < 1e-3,
            "{integrator}: still moving at {} m/s",
            s.v[0].length()
        );
        // All the kinetic energy went into the contact ledger.
        let ke0 = 0.5 * f64::from(v0 * v0);
        assert!(
            (s.ledger.contact_j / ke0 - 1.0).abs() < 0.02,
            "{integrator}: contact dissipated {} J of {ke0} J",
            s.ledger.contact_j
        );
    }
}

/// One 1 kg mass resting on a ground of friction 0.5 (at its resting depth), under gravity
/// with a sideways part `gx`.
fn on_rough_ground(gx: f32) -> Arc<Model> {
    let k = 1.0e4f32;
    let mut mb = ModelBuilder::new();
    mb.mass(Vec3::new(0.0, -G / k, 0.0), Vec3::ZERO, 1.0, false);
    mb.effects(Effects {
        gravity_m_per_s2: Some(Vec3::new(gx, -G, 0.0)),
        ground: Some(GroundCollider {
            height_m: 0.0,
            contact: ContactModel {
                stiffness_n_per_m: k,
                friction: 0.5,
                damping_ratio: 1.0,
            },
            max_depth_m: 0.1,
        }),
        ..Effects::default()
    });
    Arc::new(mb.build())
}

/// Static friction holds: a sideways load below μ m g leaves a resting mass where it is. (A
/// friction that only opposes the velocity lets it creep at load·dt/m: 2 mm in this second.)
/// Above the limit it slides at (g_x − μ g), as Coulomb says.
#[test]
fn static_friction_holds_below_the_limit_and_slides_above_it() {
    let (held, sliding) = (on_rough_ground(2.0), on_rough_ground(8.0));
    for integrator in [
        Integrator::Euler,
        Integrator::SemiImplicit,
        Integrator::Verlet,
        Integrator::Rk4,
        Integrator::Implicit,
    ] {
        let s = run(&held, integrator, 1e-3, 1000);
        assert!(
            s.x[0].x.abs() < 1e-6,
            "{integrator}: a load of 2 N under a friction limit of 4.9 N moved the mass {} m",
            s.x[0].x
        );
        let s = run(&sliding, integrator, 1e-3, 1000);
        let expected = 0.5 * f64::from(8.0 - 0.5 * G) * s.time_secs * s.time_secs;
        let x = f64::from(s.x[0].x);
        assert!(
            (x / expected - 1.0).abs() < 0.01,
            "{integrator}: slid {x} m in {} s, expected {expected} m",
            s.time_secs
        );
    }
}

#[test]
fn cpu_backend_is_deterministic_whatever_the_thread_count() {
    // Large enough (64 × 64 = 4096 masses) that the force pass runs on the thread pool.
    let loaded = hooke::scene::from_toml(
        r#"
name = "det"
[effects]
gravity_m_per_s2 = [0.0, -9.81, 0.0]
air_drag_per_s = 0.1
[effects.ground]
friction = 0.4
[[bodies]]
name = "cloth"
grid = [64, 64]
spacing_m = 0.02
mass_kg = 1.0
origin_m = [0.0, 0.05, 0.0]
axes = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
pins = [[0, 0]]
springs.structural = { stiffness_n_per_m = 300.0, damping_n_s_per_m = 0.01 }
springs.shear = { stiffness_n_per_m = 100.0 }
"#,
        hooke::error::SceneOrigin::Text,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let model = Arc::new(hooke::model::build(&loaded));
    // RK4's passes, and implicit Euler's at one step per frame on the ground: its solve
    // preconditioned by multigrid (4 096 masses), its loops cut into pieces by the thread count
    // (three threads cut the masses into pieces of 341), its sums by fixed chunks.
    for (integrator, dt, steps) in [
        (Integrator::Rk4, 2e-4, 50),
        (Integrator::Implicit, 1.0 / 60.0, 6),
    ] {
        let in_pool = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap_or_else(|e| panic!("{e}"))
                .install(|| run(&model, integrator, dt, steps))
        };
        let (a, b, c) = (in_pool(1), in_pool(2), in_pool(3));
        for other in [&b, &c] {
            assert!(
                bytemuck::cast_slice::<Vec3, u8>(&a.x)
                    == bytemuck::cast_slice::<Vec3, u8>(&other.x),
                "{integrator}"
            );
            assert!(
                bytemuck::cast_slice::<Vec3, u8>(&a.v)
                    == bytemuck::cast_slice::<Vec3, u8>(&other.v),
                "{integrator}"
            );
            assert_eq!(a.ledger, other.ledger, "{integrator}");
        }
        assert!(
            a.x.iter().zip(&model.initial.x).any(|(p, q)| p != q),
            "{integrator}: the cloth should have moved"
        );
    }
}

/// Every built-in scene, run in full: nothing passes through a collider (the penalty contact holds
/// every mass within its collider's safeguard depth, so the safeguard never has to act), the state
/// stays finite, and mechanical energy plus dissipated energy minus collider work stays constant.
/// The simulation thread's loop, pipelined one frame deep: every frame arrives, in order; when
/// the state goes bad, every good frame before it arrives and nothing non-finite does.
#[test]
fn simulation_delivers_every_good_frame_in_order_and_stops_at_divergence() {
    use hooke::backend::BackendError;
    use hooke::run::sim::{Delivery, simulate};
    let model = oscillator();
    for (dt, expect_divergence) in [(1e-3, false), (0.05, true)] {
        // Forward Euler grows by √(1 + (ωdt)²) a step: at ωdt ≈ 0.31 it runs away after ~20 frames.
        let mut be = CpuBackend::new(model.clone(), Step::new(Integrator::Euler, dt));
        let (tx, rx) = crossbeam_channel::unbounded();
        let out = simulate(
            &mut be,
            200,
            10,
            &tx,
            Delivery::Lossless,
            &std::sync::atomic::AtomicBool::new(false),
            None,
        );
        drop(tx);
        let frames: Vec<_> = rx.iter().collect();
        assert_eq!(out.frames_sent as usize, frames.len());
        for (k, s) in frames.iter().enumerate() {
            assert_eq!(s.frame, k as u64, "frames out of order");
            assert!(
                s.positions.iter().all(|p| p.is_finite()),
                "frame {k} is not finite"
            );
        }
        match (&out.failed, expect_divergence) {
            (None, false) => assert_eq!(frames.len(), 201),
            (Some(BackendError::Diverged(d)), true) => {
                assert!(
                    frames.len() > 1 && frames.len() < 201,
                    "{} frames",
                    frames.len()
                );
                assert!(
                    d.to_string().contains("diverged at step") && d.spring.is_some(),
                    "{d}"
                );
            }
            (other, _) => panic!("dt {dt}: unexpected outcome {other:?}"),
        }
    }
}

/// `--dt auto` keeps its promise: at the step it picks, the error against the f64 reference over
/// its probe is within the tolerance asked for (with a factor 2 for the estimate's own error).
#[test]
fn auto_dt_meets_the_requested_accuracy() {
    use hooke::scene::settings::{Overrides, Settings};
    let loaded = hooke::scene::load("hair").unwrap_or_else(|e| panic!("{e}"));
    let model = Arc::new(hooke::model::build(&loaded.scene));
    for (integrator, tolerance) in [(Integrator::SemiImplicit, 1e-4), (Integrator::Verlet, 1e-5)] {
        let settings = Settings::resolve(
            &loaded.scene,
            &Overrides {
                integrator: Some(integrator),
                ..Overrides::default()
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let auto = hooke::run::auto_dt::choose(
            &model,
            &settings,
            &hooke::run::select::Device::cpu(),
            tolerance,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(auto.estimated_error_m <= tolerance, "{integrator}: {auto}");
        let steps = (auto.probe_secs / auto.dt_secs).round() as u64;
        let s = run(&model, integrator, auto.dt_secs, steps);
        let mut reference = hooke::accuracy::reference::Reference::new(model.clone());
        reference.advance_to(s.time_secs, auto.dt_secs / 8.0);
        let sq: f64 =
            s.x.iter()
                .zip(&reference.x)
                .map(|(a, b)| (a.as_dvec3() - *b).length_squared())
                .sum();
        let actual = (sq / s.x.len() as f64).sqrt();
        assert!(
            actual <= 2.0 * tolerance,
            "{integrator}: asked for {tolerance} m, got {actual} m ({auto})"
        );
    }
}
