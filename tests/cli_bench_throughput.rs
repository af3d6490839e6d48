//! `hooke bench throughput --json --repeat N` end to end: one JSON object per scene that a script
//! can parse, as many timed runs as asked, their median and spread consistent with the run times,
//! and on the GPU the dispatches one step records.

use crate::common::{gpu_available, hooke, ok, text};
use serde_json::Value;

fn json_lines(args: &[&str]) -> Vec<Value> {
    let out = hooke(args);
    assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
    text(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: not JSON: {l}")))
        .collect()
}

fn num(v: &Value, path: &[&str]) -> f64 {
    let mut at = v;
    for key in path {
        at = &at[*key];
    }
    at.as_f64()
        .unwrap_or_else(|| panic!("{path:?} is not a number in {v}"))
}

#[test]
fn json_has_one_object_per_scene_with_every_run_and_its_median_and_spread() {
    let args = [
        "bench",
        "throughput",
        "hair",
        "jello",
        "--backend",
        "cpu",
        "--steps",
        "30",
        "--repeat",
        "3",
        "--json",
    ];
    let objects = json_lines(&args);
    assert_eq!(objects.len(), 2, "{objects:?}");
    for (o, (scene, masses, springs)) in objects
        .iter()
        .zip([("hair", 100, 185), ("jello", 1000, 12876)])
    {
        assert_eq!(o["scene"], scene);
        assert_eq!(o["masses"], masses);
        assert_eq!(o["springs"], springs);
        assert_eq!(o["steps"], 30);
        assert_eq!(o["repeat"], 3);
        assert!(
            o["dispatches_per_step"].is_null(),
            "the CPU dispatches nothing: {o}"
        );
        let runs: Vec<f64> = o["runs_secs"]
            .as_array()
            .unwrap_or_else(|| panic!("no runs_secs in {o}"))
            .iter()
            .filter_map(Value::as_f64)
            .collect();
        assert_eq!(runs.len(), 3, "{o}");
        assert!(runs.iter().all(|s| *s > 0.0), "{o}");
        // The median run and the extremes, as steps/s and spring updates/s.
        let mut sorted = runs.clone();
        sorted.sort_by(f64::total_cmp);
        let per_sec = |secs: f64| 30.0 / secs;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
        for (key, expect) in [
            ("median", per_sec(sorted[1])),
            ("min", per_sec(sorted[2])),
            ("max", per_sec(sorted[0])),
        ] {
            let got = num(o, &["steps_per_sec", key]);
            assert!(close(got, expect), "{scene} {key}: {got} vs {expect}");
            let updates = num(o, &["spring_updates_per_sec", key]);
            assert!(
                close(updates, springs as f64 * expect),
                "{scene} {key}: {updates}"
            );
        }
    }
}

#[test]
fn text_says_the_median_of_the_runs_and_the_gpu_dispatches_per_step() {
    let out = hooke(&[
        "bench",
        "throughput",
        "hair",
        "--backend",
        "cpu",
        "--steps",
        "20",
        "--repeat",
        "2",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let s = text(&out.stdout);
    assert!(s.contains("median of 2 runs; spread "), "{s}");
    assert!(!s.contains("dispatches per step"), "{s}");
    if !gpu_available() {
        return;
    }
    // Fused: semi-implicit Euler in one dispatch (the forces, update, contacts and ledger),
    // Verlet in two, RK4 in four; the general passes where springs tear. Implicit Euler on hair:
    // the whole step in one workgroup's dispatch (jello too, with its ground contact); on cloth-64
    // (4 096 masses) a dispatch per pass: two per CG iteration and six per Newton iteration at
    // its own step, whose springs are too soft against it for multigrid to pay. The 64 × 64 peer
    // cloth at 1/60 s adds a multigrid cycle over its four coarse levels to each CG iteration
    // (10: the masses' start, down, the coarsest, up, the masses' end) and to each Newton
    // iteration the levels' blocks (9) and a cycle, as `hooke check` lists.
    // A driver that cuts loops short (Mesa 22's lavapipe: tests/gpu.rs, the loop probe) takes
    // hair's and jello's implicit steps a dispatch per pass, as cloth-64's.
    let long_loops =
        hooke::gpu::LoopBudget::measure(&ok(hooke::gpu::GpuContext::open(None))).runs_long_loops();
    let (in_group, per_newton, per_cg) = match long_loops {
        true => (1, 0, 0),
        false => (3, 6, 2),
    };
    for (scene, integrator, fused, fixed, per_newton, per_cg) in [
        ("hair", "semi-implicit", true, 1, 0, 0),
        ("jello", "verlet", true, 2, 0, 0),
        ("jello", "rk4", true, 4, 0, 0),
        ("tear", "semi-implicit", false, 4, 0, 0),
        ("hair", "implicit", false, in_group, per_newton, per_cg),
        ("jello", "implicit", false, in_group, per_newton, per_cg),
        ("cloth-64", "implicit", false, 3, 6, 2),
        (
            "bench/scenes/peer-cloth-64-60hz.toml",
            "implicit",
            false,
            3,
            25,
            12,
        ),
    ] {
        let o = &json_lines(&[
            "bench",
            "throughput",
            scene,
            "--integrator",
            integrator,
            "--steps",
            "2",
            "--batch",
            "1",
            "--json",
        ])[0];
        let d = &o["dispatches_per_step"];
        assert_eq!(
            (
                &d["fused"],
                &d["fixed"],
                &d["per_newton_iteration"],
                &d["per_cg_iteration"]
            ),
            (
                &fused.into(),
                &fixed.into(),
                &per_newton.into(),
                &per_cg.into()
            ),
            "{scene} {integrator}: {o}"
        );
        // Only the per-pass implicit path replays a submission; it counts the timed ones.
        let replays = &o["replays"];
        if integrator == "implicit" && per_cg > 0 {
            assert_eq!(replays["submissions"], 2, "{o}");
            assert!(replays["replayed"].as_u64().is_some_and(|r| r <= 2), "{o}");
        } else {
            assert!(replays.is_null(), "{scene} {integrator}: {o}");
        }
    }
}

#[test]
fn json_is_refused_with_effects_and_repeat_must_be_positive() {
    for args in [
        ["--json", "--effects"].as_slice(),
        ["--repeat", "0"].as_slice(),
    ] {
        let mut all = vec!["bench", "throughput", "hair", "--backend", "cpu"];
        all.extend_from_slice(args);
        let out = hooke(&all);
        assert!(!out.status.success(), "{args:?} was accepted");
        let err = text(&out.stderr);
        assert!(err.contains(args[0]), "{args:?}: {err}");
    }
}

/// Where the run ended, and with mass–mass contact how many times the neighbour lists were built
/// in the timed steps: both backends build them at the same steps (bit for bit on lavapipe), a
/// folding cloth every few steps; a scene without contact reports none.
#[test]
fn json_says_where_the_run_ended_and_how_often_the_neighbour_lists_were_built() {
    let fold = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/cloth-fold.toml"
    );
    let run = |scene: &str, backend: &str| {
        let args = [
            "bench",
            "throughput",
            scene,
            "--backend",
            backend,
            "--steps",
            "300",
            "--batch",
            "100",
            "--repeat",
            "1",
            "--json",
        ];
        json_lines(&args).remove(0)
    };
    let cpu = run(fold, "cpu");
    let builds = cpu["neighbour_builds"]
        .as_u64()
        .unwrap_or_else(|| panic!("no neighbour_builds in {cpu}"));
    assert!(
        builds > 0 && builds < 300,
        "{builds} builds in 300 steps: {cpu}"
    );
    // 100 warm-up steps and 300 timed at the scene's step.
    let dt = num(&cpu, &["end_time_secs"]) / 400.0;
    assert!((dt - 1.0 / 2400.0).abs() < 1e-9, "dt {dt}: {cpu}");
    let hair = run("hair", "cpu");
    assert!(hair["neighbour_builds"].is_null(), "{hair}");
    assert_eq!(
        hair["end_mean_position_m"].as_array().map(Vec::len),
        Some(3),
        "{hair}"
    );
    if !gpu_available() {
        return;
    }
    let gpu = run(fold, "gpu");
    assert_eq!(gpu["neighbour_builds"], cpu["neighbour_builds"], "{gpu}");
    assert_eq!(
        gpu["end_mean_position_m"], cpu["end_mean_position_m"],
        "{gpu}"
    );
}
