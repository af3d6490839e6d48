//! XPBD (`--integrator xpbd`) through the whole path: scene, model, CPU backend, command line.
//! The solver's own checks (colouring, one spring's convergence, a chain's statics and energy)
//! are unit tests in src/cpu/xpbd.rs.

use std::sync::Arc;

use crate::common::{hooke, model_of, ok, temp_dir, text};
use glam::Vec3;
use hooke::backend::Backend as _;
use hooke::cpu::CpuBackend;
use hooke::integrator::{Integrator, Step, StepOptions};
use hooke::model::Model;

fn positions_after(model: &Arc<Model>, dt: f64, duration: f64, iterations: u32) -> Vec<Vec3> {
    let options = StepOptions {
        xpbd_iterations: iterations,
        ..StepOptions::default()
    };
    let mut be = CpuBackend::new(
        model.clone(),
        Step::new(Integrator::Xpbd, dt).with_options(options),
    );
    let steps = (duration / dt).round() as u64;
    ok(hooke::backend::advance_steps(&mut be, steps, 1000));
    ok(be.state()).x
}

/// A strand of `N` masses hanging straight down from a pinned top, with air drag to settle it.
const STRAND: &str = r#"
name = "strand"
[solver]
integrator = "xpbd"
[effects]
gravity_m_per_s2 = [0.0, -9.81, 0.0]
air_drag_per_s = 8.0
[[bodies]]
name = "strand"
grid = [10]
spacing_m = 0.1
mass_kg = 0.1
origin_m = [0.0, 2.0, 0.0]
axes = [[0.0, -1.0, 0.0]]
pins = [[0]]
springs.structural = { stiffness_n_per_m = 200.0, damping_n_s_per_m = 0.05 }
"#;

#[test]
fn a_hanging_strand_settles_within_one_percent_of_its_static_stretch() {
    let model = model_of(STRAND);
    let n = model.mass_count();
    let m = f64::from(model.mass_kg[1]);
    let x = positions_after(&model, 5e-5, 4.0, 1);
    for i in 0..n - 1 {
        // Spring i carries the masses below it.
        let want = (n - 1 - i) as f64 * m * 9.81 / 200.0;
        let got = f64::from((x[i] - x[i + 1]).length()) - 0.1;
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "spring {i}: stretch {got:.4e} m, analytic {want:.4e} m"
        );
    }
}

#[test]
fn more_iterations_per_substep_bring_a_coarse_step_closer_to_the_static_stretch() {
    let model = model_of(STRAND);
    let n = model.mass_count();
    let m = f64::from(model.mass_kg[1]);
    let worst = |iterations: u32| {
        let x = positions_after(&model, 1e-3, 4.0, iterations);
        (0..n - 1)
            .map(|i| {
                let want = (n - 1 - i) as f64 * m * 9.81 / 200.0;
                (f64::from((x[i] - x[i + 1]).length() - 0.1) / want - 1.0).abs()
            })
            .fold(0.0, f64::max)
    };
    let (one, eight) = (worst(1), worst(8));
    assert!(
        eight < 0.5 * one,
        "1 iteration: {one:.3}, 8 iterations: {eight:.3}"
    );
}

/// On the hair scene, XPBD's RMS position error against the f64 RK4 reference halves as the
/// substep halves: first order, like the position-level implicit scheme it is.
#[test]
fn xpbd_error_against_the_reference_falls_as_substeps_grow() {
    let loaded = ok(hooke::scene::load("hair"));
    let model = Arc::new(hooke::model::build(&loaded.scene));
    let duration = 0.5;
    let errors: Vec<f64> = [1.0 / 1200.0, 1.0 / 2400.0, 1.0 / 4800.0]
        .into_iter()
        .map(|dt| {
            let x = positions_after(&model, dt, duration, 1);
            let mut reference = hooke::accuracy::reference::Reference::new(model.clone());
            reference.advance_to(duration, dt / 16.0);
            let sum: f64 = x
                .iter()
                .zip(&reference.x)
                .map(|(a, b)| (a.as_dvec3() - *b).length_squared())
                .sum();
            (sum / x.len() as f64).sqrt()
        })
        .collect();
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (1.6..2.6).contains(&ratio),
            "halving the substep divided the error by {ratio:.2} (errors {errors:?})"
        );
    }
}

#[test]
fn bad_xpbd_parameters_are_one_clear_error() {
    let out = hooke(&[
        "run",
        "hair",
        "--integrator",
        "xpbd",
        "--xpbd-iterations",
        "0",
        "--backend",
        "cpu",
    ]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("--xpbd-iterations must be at least 1"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");

    let dir = temp_dir("xpbd-bad");
    let zero = dir.join("zero.toml");
    ok(std::fs::write(
        &zero,
        STRAND.replace(
            "integrator = \"xpbd\"",
            "integrator = \"xpbd\"\nxpbd_iterations = 0",
        ),
    ));
    // A negative stiffness is a negative compliance (α = 1/k): refused where it is written.
    let negative = dir.join("negative.toml");
    ok(std::fs::write(
        &negative,
        STRAND.replace("stiffness_n_per_m = 200.0", "stiffness_n_per_m = -200.0"),
    ));
    for (file, field) in [
        (&zero, "solver.xpbd_iterations"),
        (&negative, "springs.structural.stiffness_n_per_m"),
    ] {
        let path = file.to_string_lossy().into_owned();
        let out = hooke(&["check", &path]);
        let err = text(&out.stderr);
        assert!(!out.status.success(), "{path} was accepted");
        assert!(err.contains(field) && err.contains(&path), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    let _ = std::fs::remove_dir_all(dir);
}
