//! The wgpu backend against the CPU reference: parity for every built-in scene and integrator,
//! bit-for-bit determinism, and clear errors. On CI (HOOKE_REQUIRE_ADAPTER=1, Mesa lavapipe) a
//! missing adapter fails these tests; on a developer machine without one they skip, saying so.

use crate::common;

use std::sync::Arc;

use crate::common::parity::{
    assert_parity, cpu_and_gpu, parity_dt, run_both, run_both_with, step_alike,
};
use crate::common::{gpu_available, ok, scene_model};
use hooke::backend::Backend as _;
use hooke::cpu::CpuBackend;
use hooke::gpu::GpuBackend;
use hooke::integrator::{Integrator, Step, StepOptions};
use hooke::state::State;

#[test]
fn gpu_matches_cpu_for_every_built_in_scene_and_integrator() {
    if !gpu_available() {
        return;
    }
    for b in hooke::scene::BUILT_IN {
        let (model, scene_dt) = scene_model(b.name);
        // 10 frames of 30 steps, compared at every frame; the benchmark cloths (the physics of
        // `cloth` at up to 6 million springs) get a few steps, enough to run every kernel at
        // scale (2D dispatch included) without taking minutes on a software rasteriser.
        let (frames, substeps) = match model.spring_count() {
            0..100_000 => (10, 30),
            100_000..1_000_000 => (2, 10),
            _ => (1, 3),
        };
        for integrator in Integrator::EXPLICIT {
            let dt = if frames == 10 {
                parity_dt(&model, scene_dt, integrator)
            } else {
                scene_dt
            };
            let (c, g, worst_x) = run_both(&model, integrator, dt, frames, substeps);
            let fastest =
                c.v.iter()
                    .map(|v| f64::from(v.length()))
                    .fold(0.0, f64::max);
            assert!(fastest > 1e-5, "{} {integrator}: nothing moved", b.name);
            assert_parity(
                &format!("{} {integrator} dt {dt:.2e}", b.name),
                &c,
                &g,
                worst_x,
            );
        }
    }
}

/// XPBD on the GPU against the CPU, for every built-in scene at its own step (XPBD is stable at
/// any): both colour the springs with the same function and take the same constants, and each
/// colour's springs are solved by the same f32 operations, so the same tolerance holds as for
/// the explicit integrators (on lavapipe: bit-identical). Several sweeps per substep, too.
#[test]
fn gpu_xpbd_matches_the_cpu_for_every_built_in_scene() {
    if !gpu_available() {
        return;
    }
    for b in hooke::scene::BUILT_IN {
        let (model, dt) = scene_model(b.name);
        let (frames, substeps, sweeps) = match model.spring_count() {
            0..100_000 => (10, 30, &[1, 3][..]),
            100_000..1_000_000 => (2, 10, &[1][..]),
            _ => (1, 3, &[1][..]),
        };
        for &xpbd_iterations in sweeps {
            let options = StepOptions {
                xpbd_iterations,
                ..StepOptions::default()
            };
            let (c, g, worst_x) =
                run_both_with(&model, Integrator::Xpbd, dt, (frames, substeps), options);
            let fastest =
                c.v.iter()
                    .map(|v| f64::from(v.length()))
                    .fold(0.0, f64::max);
            assert!(fastest > 1e-5, "{} xpbd: nothing moved", b.name);
            assert_parity(
                &format!("{} xpbd × {xpbd_iterations} dt {dt:.2e}", b.name),
                &c,
                &g,
                worst_x,
            );
        }
    }
}

#[test]
fn gpu_matches_cpu_through_a_moving_sphere_impact() {
    if !gpu_available() {
        return;
    }
    // 0.6 s of jello-sphere: the sphere reaches the cube at about 0.3 s and shoves it.
    let (model, dt) = scene_model("jello-sphere");
    let (c, g, worst_x) = run_both(&model, Integrator::SemiImplicit, dt, 36, 40);
    assert!(
        c.ledger.collider_work_j > 0.1,
        "the sphere should have done work ({} J)",
        c.ledger.collider_work_j
    );
    assert_parity("jello-sphere impact", &c, &g, worst_x);
}

#[test]
fn gpu_energies_match_the_cpu() {
    if !gpu_available() {
        return;
    }
    let (model, dt) = scene_model("cloth");
    let (mut cpu, mut gpu) = cpu_and_gpu(&model, Step::new(Integrator::Rk4, dt));
    step_alike((&mut cpu, &mut gpu), (20, 30), |_, _, _| {});
    let (c, g) = (
        ok(cpu.snapshot(0, Default::default())),
        ok(gpu.snapshot(0, Default::default())),
    );
    let (ec, eg) = (c.energies, g.energies);
    for (what, a, b) in [
        ("kinetic", ec.kinetic_j, eg.kinetic_j),
        ("elastic", ec.elastic_j, eg.elastic_j),
        ("gravity", ec.gravity_j, eg.gravity_j),
        ("contact", ec.contact_j, eg.contact_j),
        ("total", ec.total_j(), eg.total_j()),
    ] {
        assert!(
            (a - b).abs() <= 1e-5 * ec.total_j().abs(),
            "{what}: CPU {a} J, GPU {b} J"
        );
    }
    assert_eq!(c.strain.len(), g.strain.len());
    let worst = c
        .strain
        .iter()
        .zip(&g.strain)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    // Where the GPU rounds as the CPU, the strains agree to 1e-5; elsewhere each strain follows
    // its positions: two ends apart by at most |Δx| change a spring's length by at most 2 |Δx|,
    // its strain by that over its rest length (an H100 differed by 1.7e-5).
    let worst_x = c
        .positions
        .iter()
        .zip(&g.positions)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    let shortest = model
        .springs
        .iter()
        .map(|s| s.rest_m)
        .fold(f32::INFINITY, f32::min);
    let allowed = if common::parity::gpu_rounds_as_the_cpu() {
        1e-5
    } else {
        1e-5 + 2.0 * worst_x / shortest
    };
    assert!(
        worst <= allowed,
        "strain differs by {worst} (allowed {allowed}, positions by {worst_x} m)"
    );
}

#[test]
fn gpu_runs_are_bit_identical() {
    if !gpu_available() {
        return;
    }
    let (model, dt) = scene_model("jello-sphere");
    let run = || {
        let mut gpu = ok(GpuBackend::new(
            model.clone(),
            Step::new(Integrator::Rk4, dt),
            None,
        ));
        for _ in 0..15 {
            ok(gpu.advance(40));
        }
        ok(gpu.state())
    };
    let (a, b) = (run(), run());
    let bytes = |v: &[glam::Vec3]| bytemuck::cast_slice::<glam::Vec3, u8>(v).to_vec();
    assert!(
        bytes(&a.x) == bytes(&b.x) && bytes(&a.v) == bytes(&b.v),
        "two GPU runs differ"
    );
    assert_eq!(a.ledger, b.ledger);
}

#[test]
fn an_unknown_adapter_name_is_a_clear_error() {
    if !gpu_available() {
        return;
    }
    let (model, dt) = scene_model("hair");
    let err = match GpuBackend::new(
        model,
        Step::new(Integrator::SemiImplicit, dt),
        Some("no-such-gpu-xyz"),
    ) {
        Ok(_) => panic!("accepted an unknown adapter"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("no adapter matches --adapter 'no-such-gpu-xyz'")
            && err.contains("available:"),
        "{err}"
    );
}

#[test]
fn hooke_run_uses_the_gpu_by_default_and_records() {
    if !gpu_available() {
        return;
    }
    let path = std::env::temp_dir().join(format!("hooke-gpu-run-{}.rrd", std::process::id()));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hooke"))
        .args([
            "run",
            "cloth",
            "--frames",
            "5",
            "--save",
            &path.to_string_lossy(),
        ])
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains(" on gpu: "),
        "the run should name its adapter: {err}"
    );
    assert!(
        std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0) > 10_000,
        "no recording written"
    );
    let _ = std::fs::remove_file(path);
}

#[test]
fn a_diverging_gpu_run_delivers_its_good_frames_and_names_the_mass() {
    if !gpu_available() {
        return;
    }
    use hooke::backend::BackendError;
    // The hair scene under forward Euler at its own dt, 19 times its stable step.
    let (model, dt) = scene_model("hair");
    let mut be = ok(GpuBackend::new(
        model,
        Step::new(Integrator::Euler, dt),
        None,
    ));
    let (tx, rx) = crossbeam_channel::unbounded();
    let out = hooke::run::sim::simulate(
        &mut be,
        300,
        20,
        &tx,
        hooke::run::sim::Delivery::Lossless,
        &std::sync::atomic::AtomicBool::new(false),
        None,
    );
    drop(tx);
    let frames: Vec<_> = rx.iter().collect();
    for (k, s) in frames.iter().enumerate() {
        assert_eq!(s.frame, k as u64);
        assert!(
            s.positions.iter().all(|p| p.is_finite()) && s.energies.total_j().is_finite(),
            "frame {k} is not finite"
        );
    }
    let gpu_step = match out.failed {
        Some(BackendError::Diverged(d)) => {
            assert!(d.to_string().contains("at mass") && frames.len() > 1, "{d}");
            d.step
        }
        other => panic!(
            "expected divergence, got {other:?} after {} frames",
            frames.len()
        ),
    };
    // The GPU names the first bad step, as the CPU's per-step check does (bit-identical on
    // lavapipe; within 1% where a GPU fuses multiply-adds).
    let mut cpu = CpuBackend::new(scene_model("hair").0, Step::new(Integrator::Euler, dt));
    let cpu_step = loop {
        match cpu.advance(20) {
            Ok(_) => continue,
            Err(BackendError::Diverged(d)) => break d.step,
            Err(e) => panic!("{e}"),
        }
    };
    eprintln!("first bad step: GPU {gpu_step}, CPU {cpu_step}");
    assert!(
        gpu_step.abs_diff(cpu_step) <= 2 + cpu_step / 100,
        "GPU names step {gpu_step}, CPU step {cpu_step}"
    );
}

#[test]
fn a_scene_beyond_the_adapters_limits_is_refused_with_the_numbers() {
    if !gpu_available() {
        return;
    }
    let limits = hooke::gpu::adapters()[0].limits();
    let limit = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    // The largest per-mass buffer holds 48 bytes a mass: one mass more than fits.
    let n = limit / 48 + 1;
    if n > 1 << 26 {
        eprintln!(
            "SKIPPED: this adapter's limit ({limit} bytes) needs a scene too large to build here"
        );
        return;
    }
    let mut mb = hooke::model::ModelBuilder::new();
    for i in 0..n {
        mb.mass(
            glam::Vec3::new(i as f32, 0.0, 0.0),
            glam::Vec3::ZERO,
            1.0,
            false,
        );
    }
    let model = Arc::new(mb.build());
    let err = match GpuBackend::new(model, Step::new(Integrator::SemiImplicit, 1e-3), None) {
        Ok(_) => panic!("a scene over the limit was accepted"),
        Err(e) => e.to_string(),
    };
    for needle in [
        "too large",
        &format!("needs {} bytes", 48 * n),
        &format!("allows {limit} bytes"),
        "--backend cpu",
    ] {
        assert!(err.contains(needle), "`{needle}` missing from: {err}");
    }
}

/// A GPU backend whose device is lost (as a driver reset loses it) before its `at`-th frame.
/// Loses its device while stepping frame `at` (a frame may go to `advance` in several chunks).
struct LosesDevice {
    gpu: GpuBackend,
    at: u64,
    requested: u64,
    lost: bool,
}

impl hooke::backend::Backend for LosesDevice {
    fn describe(&self) -> String {
        self.gpu.describe()
    }
    fn watch(&mut self, flags: hooke::backend::StopFlags) {
        self.gpu.watch(flags)
    }
    fn advance(
        &mut self,
        substeps: u32,
    ) -> Result<hooke::state::StepStats, hooke::backend::BackendError> {
        if self.requested == self.at && !self.lost {
            self.lost = true;
            self.gpu.lose_device();
        }
        self.gpu.advance(substeps)
    }
    fn request_snapshot(
        &mut self,
        frame: u64,
        stats: hooke::state::StepStats,
    ) -> Result<(), hooke::backend::BackendError> {
        self.requested += 1;
        self.gpu.request_snapshot(frame, stats)
    }
    fn finish(&mut self) -> Result<(), hooke::backend::BackendError> {
        self.gpu.finish()
    }
    fn collect_snapshot(
        &mut self,
    ) -> Result<Option<hooke::state::Snapshot>, hooke::backend::BackendError> {
        self.gpu.collect_snapshot()
    }
    fn state(&mut self) -> Result<State, hooke::backend::BackendError> {
        self.gpu.state()
    }
}

/// A device lost mid-run ends the run with one clear message (what happened, what to do), and
/// every frame produced before the loss reaches the recorder, in order.
#[test]
fn a_lost_device_ends_the_run_clearly_and_keeps_the_frames_before_it() {
    if !gpu_available() {
        return;
    }
    let (model, dt) = scene_model("hair");
    let mut be = LosesDevice {
        gpu: ok(GpuBackend::new(
            model,
            Step::new(Integrator::SemiImplicit, dt),
            None,
        )),
        at: 8,
        requested: 0,
        lost: false,
    };
    let (tx, rx) = crossbeam_channel::unbounded();
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let out = hooke::run::sim::simulate(
        &mut be,
        100,
        5,
        &tx,
        hooke::run::sim::Delivery::Lossless,
        &cancel,
        None,
    );
    drop(tx);
    let frames: Vec<u64> = rx.iter().map(|s| s.frame).collect();
    let Some(hooke::backend::BackendError::Device(e)) = out.failed else {
        panic!("expected a device error, got {:?}", out.failed);
    };
    let msg = e.to_string();
    assert!(
        msg.contains("device was destroyed") && msg.contains("--backend cpu"),
        "{msg}"
    );
    assert!(!msg.contains('\n'), "one line: {msg}");
    let n = frames.len() as u64;
    assert!(n >= 6, "only {n} frames before the loss at frame 8");
    assert_eq!(
        frames,
        (0..n).collect::<Vec<_>>(),
        "frames lost or out of order"
    );
}

/// Out of GPU memory, reported asynchronously by the driver, reads as what to do about it.
#[test]
fn out_of_gpu_memory_says_what_to_do() {
    let e = wgpu::Error::OutOfMemory {
        source: Box::new(std::io::Error::other("VK_ERROR_OUT_OF_DEVICE_MEMORY")),
    };
    let msg = hooke::gpu::describe_error(&e);
    assert!(
        msg.contains("ran out of memory") && msg.contains("--backend cpu"),
        "{msg}"
    );
}

/// The driver's loop cap, found by the probe every GPU run opens with (docs/drivers.md): Debian
/// 12's own lavapipe (Mesa 22.3) ends a shader invocation's loops after 65 535 iterations in all,
/// Mesa 25's runs them to their end. Where the probe finds a cap, no step runs in one workgroup
/// (each such kernel loops over a whole step or frame): the default implicit step takes a
/// dispatch per pass even when a test asks for one workgroup, VBD and XPBD a dispatch per colour,
/// the explicit steps a dispatch per step; and the run still meets the CPU.
#[test]
fn the_loop_probe_finds_the_drivers_cap_and_a_run_keeps_clear_of_it() {
    use hooke::gpu::{ExplicitPath, ImplicitPath, LoopBudget, Tuning};
    if !gpu_available() {
        return;
    }
    let ctx = ok(hooke::gpu::GpuContext::open(None));
    let budget = LoopBudget::measure(&ctx);
    let mesa_major = ctx
        .info
        .driver_info
        .split_whitespace()
        .skip_while(|w| *w != "Mesa")
        .nth(1)
        .and_then(|v| v.split('.').next()?.parse::<u32>().ok());
    println!("{} ({}): {budget}", ctx.info.name, ctx.info.driver_info);
    if ctx.info.driver == "llvmpipe" {
        match mesa_major {
            Some(22) => assert_eq!(budget, LoopBudget::Capped { iterations: 65_535 }),
            Some(25..) => assert_eq!(budget, LoopBudget::Unbounded),
            _ => {}
        }
    }
    // Hair (100 masses) is small enough for every one-workgroup path, on a CPU adapter too.
    let (hair, _) = scene_model("hair");
    for integrator in [
        Integrator::Implicit,
        Integrator::Vbd,
        Integrator::Xpbd,
        Integrator::SemiImplicit,
    ] {
        let step = Step::new(integrator, 1.0 / 60.0);
        let tuning = Tuning {
            implicit: ImplicitPath::InGroup,
            explicit: ExplicitPath::InGroup,
            vbd_in_group: Some(true),
            ..Tuning::for_run(&hair, step)
        };
        let gpu = ok(GpuBackend::with_tuning(hair.clone(), step, None, tuning));
        assert_eq!(gpu.loop_budget(), budget);
        let long = budget.runs_long_loops();
        let one_group = match integrator {
            Integrator::Implicit => gpu.implicit_path() == Some(ImplicitPath::InGroup),
            Integrator::Vbd | Integrator::Xpbd => gpu.sweeps_in_group(),
            _ => gpu.explicit_path() == ExplicitPath::InGroup,
        };
        assert_eq!(
            one_group, long,
            "{integrator}: in one workgroup {one_group}, {budget}"
        );
    }
    let (model, _) = scene_model("jello");
    // The default run of the implicit jello at one step per frame, on whichever path the
    // adapter allows, falls as the CPU's does (on Mesa 22 without the probe it never fell).
    let step = Step::new(Integrator::Implicit, 1.0 / 60.0);
    let (mut cpu, mut gpu) = cpu_and_gpu(&model, step);
    step_alike((&mut cpu, &mut gpu), (10, 1), |_, _, _| {});
    let (c, g) = (ok(cpu.state()), ok(gpu.state()));
    let apart = hooke::conformance::Apart::of(&c, &g);
    let worst = apart.farthest_m;
    assert!(
        worst < 5e-4,
        "the GPU's jello ends {worst} m from the CPU's"
    );
    // Lavapipe sums as the CPU does on either path: the same bits.
    assert!(
        apart.same_bits || !common::parity::gpu_rounds_as_the_cpu(),
        "lavapipe's jello ends {worst} m from the CPU's"
    );
    let mean_y = |x: &[glam::Vec3]| x.iter().map(|p| f64::from(p.y)).sum::<f64>() / x.len() as f64;
    let fell = mean_y(&model.initial.x) - mean_y(&g.x);
    assert!(fell > 0.05, "the GPU's jello fell only {fell} m");
    // `check` names the passes this adapter steps with where they are not a discrete GPU's.
    let out = common::hooke_command(&[
        "check",
        "jello",
        "--integrator",
        "implicit",
        "--dt",
        "1/60",
        "--no-verify",
    ])
    .output()
    .unwrap_or_else(|e| panic!("{e}"));
    let said = common::text(&out.stdout);
    let here = said
        .lines()
        .find(|l| l.starts_with("GPU step passes on this adapter: "));
    match budget.runs_long_loops() {
        true => assert!(here.is_none(), "{said}"),
        false => assert!(
            here.is_some_and(|l| l.contains("cg_apply") && !l.contains("implicit_step")),
            "{said}"
        ),
    }
}

/// The conformance probe end to end, through the binary: `check --verify` probes the family a
/// run of hair steps with and keeps an agreeing verdict; a verdict of disagreement (written here
/// as a driver that computes wrongly would leave it) refuses the run before it records, naming
/// the adapter, its driver and the family and saying what to do; `check` prints the kept
/// verdict; `--no-verify` runs anyway.
#[test]
fn a_family_found_to_disagree_is_refused_and_no_verify_runs_it() {
    use crate::common::{hooke_command, temp_dir, text};
    if !gpu_available() {
        return;
    }
    let dir = temp_dir("conformance");
    let cache = dir.join("cache");
    let hooke = |args: &[&str]| {
        let out = hooke_command(args)
            .env("HOOKE_CACHE_DIR", &cache)
            .output()
            .unwrap_or_else(|e| panic!("{e}"));
        (out.status.success(), text(&out.stdout), text(&out.stderr))
    };
    let (ok, out, err) = hooke(&["check", "hair", "--verify"]);
    assert!(ok, "{err}");
    let said = out
        .lines()
        .find(|l| l.starts_with("conformance"))
        .unwrap_or_else(|| panic!("no verdict: {out}"));
    assert!(
        said.contains("probed now") && said.contains("agrees with the CPU"),
        "{said}"
    );
    let file = cache.join("conformance.json");
    let kept = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{e}"));
    assert!(kept.contains("\"agrees\": true"), "{kept}");
    std::fs::write(&file, kept.replace("\"agrees\": true", "\"agrees\": false"))
        .unwrap_or_else(|e| panic!("{e}"));
    let rrd = dir.join("hair.rrd");
    let save = rrd.to_str().unwrap_or_default();
    let (ok, _, err) = hooke(&["run", "hair", "--frames", "2", "--save", save]);
    assert!(!ok, "a disagreeing family ran");
    assert!(!rrd.exists(), "the refused run recorded");
    for needed in [
        "does not compute what the CPU reference computes for semi-implicit",
        "DISAGREES",
        "--backend cpu",
        "update the GPU driver",
        "--no-verify",
        "conformance.json",
    ] {
        assert!(err.contains(needed), "no '{needed}' in: {err}");
    }
    let (ok, out, _) = hooke(&["check", "hair"]);
    assert!(
        ok && out.contains("kept from an earlier probe") && out.contains("DISAGREES"),
        "{out}"
    );
    let (ok, _, err) = hooke(&[
        "run",
        "hair",
        "--frames",
        "2",
        "--save",
        save,
        "--no-verify",
    ]);
    assert!(ok && rrd.exists(), "{err}");
}
