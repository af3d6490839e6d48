//! The CG preconditioner of implicit Euler and BDF2 as a user picks it: the scene's
//! `solver.preconditioner` or `--preconditioner` (the command line wins), by the system's size
//! when neither says; both backends take the same one, and `hooke check` says which and why.

use crate::common::{gpu_available as have_adapter, hooke, ok, temp_dir, text};
use hooke::backend::Backend as _;
use hooke::cpu::CpuBackend;
use hooke::gpu::GpuBackend;
use hooke::physics::Preconditioner;

/// The jello (1 000 masses) at one step per frame with implicit Euler, the preconditioner line
/// `preconditioner` in its solver section (none when empty), written to a file.
fn jello_file(preconditioner: &str) -> String {
    let scene = std::fs::read_to_string("examples/scenes/jello.toml")
        .unwrap_or_else(|e| panic!("examples/scenes/jello.toml: {e}"))
        .replace(
            "integrator = \"semi-implicit\"",
            &format!("integrator = \"implicit\"\n{preconditioner}"),
        );
    assert!(scene.contains("integrator = \"implicit\""));
    let file = temp_dir("preconditioner").join("jello.toml");
    std::fs::write(&file, scene).unwrap_or_else(|e| panic!("{e}"));
    file.to_string_lossy().into_owned()
}

fn check(args: &[&str]) -> String {
    let mut all = vec!["check"];
    all.extend_from_slice(args);
    let out = hooke(&all);
    assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
    text(&out.stdout) + &text(&out.stderr)
}

#[test]
fn check_says_which_preconditioner_each_run_takes_and_why() {
    let plain = jello_file("");
    let s = check(&[&plain]);
    assert!(
        s.contains("CG preconditioner: 3×3 block Jacobi on both backends, below 4096 masses"),
        "{s}"
    );
    assert!(
        s.contains("GPU step passes: implicit_step (one workgroup"),
        "{s}"
    );
    // Asked on the command line: the one-workgroup step runs the cycle.
    let s = check(&[&plain, "--preconditioner", "multigrid"]);
    assert!(
        s.contains("CG preconditioner: aggregation multigrid on both backends, as asked (coarse levels of 125 → 27 → 8 nodes"),
        "{s}"
    );
    assert!(
        s.contains("GPU step passes: mg_implicit_step (one workgroup"),
        "{s}"
    );
    // Asked in the scene; the command line wins over it.
    let asked = jello_file("preconditioner = \"multigrid\"");
    assert!(check(&[&asked]).contains("aggregation multigrid on both backends, as asked"));
    let s = check(&[&asked, "--preconditioner", "block-jacobi"]);
    assert!(
        s.contains("CG preconditioner: 3×3 block Jacobi on both backends, as asked"),
        "{s}"
    );
    // An explicit integrator has no solve to precondition: a note says it is ignored.
    let s = check(&[&asked, "--integrator", "semi-implicit"]);
    assert!(
        s.contains(
            "serves implicit Euler's and BDF2's solves; semi-implicit has none and ignores it"
        ) && !s.contains("CG preconditioner"),
        "{s}"
    );
    // Large systems take multigrid unasked where their springs are stiff against the step (the
    // 64 × 64 peer cloth at 1/60 s, BDF2 solving over two thirds of it), not where the system is
    // nearly its masses' (cloth-64 at its own step).
    let s = check(&[
        "bench/scenes/peer-cloth-64-60hz.toml",
        "--integrator",
        "bdf2",
    ]);
    assert!(
        s.contains(
            "aggregation multigrid on both backends, from 4096 masses where the springs are stiff \
             against the step ((h² Σk + h Σc) / m up to 1494.8, multigrid from 300)"
        ),
        "{s}"
    );
    let s = check(&["cloth-64", "--integrator", "bdf2"]);
    assert!(
        s.contains(
            "3×3 block Jacobi on both backends, the springs are not stiff enough against the step \
             for multigrid to pay ((h² Σk + h Σc) / m up to 0.2, multigrid from 300)"
        ),
        "{s}"
    );
}

#[test]
fn an_unknown_preconditioner_is_refused_with_the_names_that_would_do() {
    let bad = jello_file("preconditioner = \"multgrid\"");
    let out = hooke(&["check", &bad]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(
        err.contains("`solver.preconditioner`: unknown variant `multgrid`, expected `block-jacobi` or `multigrid`"),
        "{err}"
    );
    let out = hooke(&["check", "jello", "--preconditioner", "amg"]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(
        err.contains("'amg'") && err.contains("block-jacobi, multigrid"),
        "{err}"
    );
}

/// A run's settings carry the choice to both backends: asked for in the scene, the jello's CG
/// takes multigrid on the CPU and on the GPU (its one-workgroup step over three coarse levels),
/// and both cut its CG iterations to a third of block Jacobi's or fewer over five steps.
#[test]
fn both_backends_take_the_preconditioner_a_scene_asks_for() {
    let cg = |file: &str, gpu: bool| -> (Preconditioner, u64) {
        let planned = ok(hooke::run::prepare::planned(file));
        let (model, step) = (planned.model, planned.settings.step());
        let dt = 1.0 / 60.0;
        let step = hooke::integrator::Step {
            dt_secs: dt,
            ..step
        };
        let mut total = 0u64;
        if gpu {
            let mut be = ok(GpuBackend::new(model.clone(), step, None));
            let asked = match be.multigrid_levels() {
                0 => Preconditioner::BlockJacobi,
                _ => Preconditioner::Multigrid,
            };
            for frame in 1..=5 {
                let stats = ok(be.advance(1));
                total += u64::from(ok(be.snapshot(frame, stats)).stats.solver_iterations);
            }
            (asked, total)
        } else {
            let mut be = CpuBackend::new(model.clone(), step);
            for _ in 0..5 {
                total += u64::from(ok(be.advance(1)).solver_iterations);
            }
            (be.preconditioner(), total)
        }
    };
    let (plain, asked) = (jello_file(""), jello_file("preconditioner = \"multigrid\""));
    let mut backends = vec![false];
    if have_adapter() {
        backends.push(true);
    }
    for gpu in backends {
        let (p, jacobi) = cg(&plain, gpu);
        assert_eq!(p, Preconditioner::BlockJacobi, "gpu {gpu}");
        let (p, multigrid) = cg(&asked, gpu);
        assert_eq!(p, Preconditioner::Multigrid, "gpu {gpu}");
        assert!(
            3 * multigrid <= jacobi,
            "gpu {gpu}: {multigrid} CG iterations with multigrid, {jacobi} with block Jacobi"
        );
    }
}

/// `bench throughput` takes the choice too and says which preconditioner a row ran with
/// (none for VBD, whose sweeps solve no linear system).
#[test]
fn bench_throughput_reports_the_preconditioner_it_ran() {
    let row = |rest: &[&str]| -> serde_json::Value {
        let mut args = vec![
            "bench",
            "throughput",
            "bench/scenes/jello-60hz.toml",
            "--backend",
            "cpu",
            "--steps",
            "2",
            "--json",
        ];
        args.extend_from_slice(rest);
        let out = hooke(&args);
        assert!(out.status.success(), "{rest:?}: {}", text(&out.stderr));
        let line = text(&out.stdout);
        serde_json::from_str(line.lines().next().unwrap_or(""))
            .unwrap_or_else(|e| panic!("{e}: {line}"))
    };
    let implicit = ["--integrator", "implicit"];
    assert_eq!(row(&implicit)["preconditioner"], "3×3 block Jacobi");
    let asked = [&implicit[..], &["--preconditioner", "multigrid"]].concat();
    assert_eq!(row(&asked)["preconditioner"], "aggregation multigrid");
    assert!(row(&["--integrator", "vbd"])["preconditioner"].is_null());
}
