//! Implicit Euler on the GPU against the CPU reference, on both of its paths (a whole step in one
//! workgroup for small systems without contacts, a dispatch per pass otherwise). On CI
//! (HOOKE_REQUIRE_ADAPTER=1, Mesa lavapipe) a missing adapter fails these tests.

use crate::common;

use crate::common::parity::{cpu_and_gpu, step_alike};
use crate::common::{gpu_available as have_adapter, ok, scene_model};
use hooke::backend::Backend as _;
use hooke::cpu::CpuBackend;
use hooke::gpu::GpuBackend;
use hooke::integrator::{Integrator, Step};

/// Implicit Euler on the GPU against the CPU, at one step per frame. Both stop by the same rules
/// (Newton once its residual is 3% of the step's momentum change, each solve at a tenth of its
/// Newton residual), in f32, and on lavapipe, on either path, both take every sum in the same
/// order (`physics::SUM_LANES`) and every product as written, so there they agree bit for bit:
/// state, Newton and CG iterations, residuals. Elsewhere (a GPU's threads and grid, multigrid's
/// coarsest level, a driver that fuses multiply-adds) a solve may stop an iteration apart and the
/// solutions agree to the solver's tolerance: stated as 5e-4 m and 2e-2 m/s over these steps,
/// and the dissipated energy within NEWTON_RESIDUAL of itself (measured on lavapipe before its
/// sums were the CPU's: about 1e-6 m without contacts; 1.4e-4 m and 2% of the energy on
/// jello-sphere, a block resting on the ground and struck). These systems are small: each step
/// is one workgroup's dispatch.
#[test]
fn gpu_implicit_euler_matches_the_cpu() {
    if !have_adapter() {
        return;
    }
    // hair: no contacts; cloth: falling towards its sphere, touching nothing in these frames;
    // jello-sphere: resting on the ground, struck by the moving sphere from frame 15; flag and
    // blob, mesh bodies (cloth from an OBJ, a lattice-filled closed mesh), swinging and falling.
    for (name, frames) in [
        ("hair", 10),
        ("cloth", 6),
        ("jello-sphere", 20),
        ("flag", 6),
        ("blob", 10),
    ] {
        implicit_parity(name, frames, hooke::gpu::ImplicitPath::InGroup);
    }
}

/// The one-workgroup step with a GPU's threads (a thread per mass, sums in two levels of up to
/// 32), run here on lavapipe, which takes 8: the same tolerance. hair: 128 threads for 100
/// masses, its vectors in workgroup memory; jello-sphere: 1 024 threads (the widest workgroup; a
/// GPU takes 512) for 1 000 masses and contacts, its vectors in the buffers.
#[test]
fn gpu_implicit_euler_in_one_workgroup_of_a_gpus_threads_matches_the_cpu() {
    if !have_adapter() {
        return;
    }
    for (name, frames, threads) in [("hair", 10, 128), ("jello-sphere", 20, 1024)] {
        implicit_parity_with(
            Integrator::Implicit,
            name,
            frames,
            hooke::gpu::ImplicitPath::InGroup,
            Some(threads),
        );
    }
}

/// The path a larger system takes, a dispatch per pass (forced here on small ones): the same
/// tolerance.
#[test]
fn gpu_implicit_euler_a_dispatch_per_pass_matches_the_cpu() {
    if !have_adapter() {
        return;
    }
    // jello-sphere: resting on the ground, struck by the moving sphere from frame 15.
    for (name, frames) in [("hair", 10), ("jello-sphere", 20)] {
        implicit_parity(name, frames, hooke::gpu::ImplicitPath::Passes);
    }
}

/// BDF2 is implicit Euler's solve from a blend of the step's start with the last one's, which
/// each backend keeps (the GPU in its solver's buffer, restored with the frame when a frame is
/// replayed): on both paths, the same tolerance as implicit Euler's. Its first step is implicit
/// Euler's, its others BDF2's.
#[test]
fn gpu_bdf2_matches_the_cpu_on_both_paths() {
    if !have_adapter() {
        return;
    }
    use hooke::gpu::ImplicitPath::{InGroup, Passes};
    for (name, frames, path) in [
        ("hair", 10, InGroup),
        ("jello-sphere", 20, InGroup),
        ("jello-sphere", 20, Passes),
    ] {
        implicit_parity_with(Integrator::Bdf2, name, frames, path, None);
    }
}

/// BDF2 restarts with implicit Euler across an impact (`cpu::backward::blend_presses`), decided
/// on the device over every mass (`restart_check`, or the one-workgroup step's own pass) and its
/// solves taken to `CG_FORCING_AT_RESTART`: the jello dropped at 1/14 s, whose landing restarts
/// (its blend, kept out of the ground, would stop the lowest layer more than half a spacing short
/// of the one above), ends where the CPU ends on both paths, bit for bit on lavapipe, and lands
/// without energy from nowhere (with the blend rule alone it gains 4.6 J in this second).
#[test]
fn bdf2_restarts_across_a_landing_as_on_the_cpu_on_both_paths() {
    if !have_adapter() {
        return;
    }
    use hooke::gpu::ImplicitPath::{InGroup, Passes};
    let (model, _) = scene_model("jello");
    let step = Step::new(Integrator::Bdf2, 1.0 / 14.0);
    let start = hooke::accuracy::energy_scale(&model);
    for path in [InGroup, Passes] {
        let mut cpu = CpuBackend::new(model.clone(), step);
        let tuning = hooke::gpu::Tuning {
            implicit: path,
            ..hooke::gpu::Tuning::for_run(&model, step)
        };
        let mut gpu = ok(GpuBackend::with_tuning(model.clone(), step, None, tuning));
        let b0 = ok(cpu.snapshot(0, Default::default())).energies.balance_j();
        step_alike((&mut cpu, &mut gpu), (14, 1), |_, _, _| {});
        let (c, g) = (ok(cpu.state()), ok(gpu.state()));
        let apart = hooke::conformance::Apart::of(&c, &g);
        let path = gpu.implicit_path();
        if common::parity::gpu_rounds_as_the_cpu() {
            assert!(
                apart.same_bits,
                "{path:?}: lavapipe ends {:.3e} m from the CPU",
                apart.farthest_m
            );
        } else {
            assert!(apart.farthest_m <= 5e-4, "{path:?}: {apart:?}");
        }
        let lowest = c.x.iter().map(|x| x.y).fold(f32::INFINITY, f32::min);
        assert!(
            lowest < 0.05,
            "{path:?}: the jello did not land ({lowest} m)"
        );
        let gained = ok(cpu.snapshot(14, Default::default()))
            .energies
            .balance_j()
            - b0;
        assert!(
            gained < 0.1 * start,
            "{path:?}: the landing gained {gained} J of {start} J"
        );
    }
}

/// Runs at one step per frame (docs/drivers.md): implicit Euler on the cloth for 60 frames, through its
/// fall onto the sphere and the ground, where some steps end without meeting Newton's rule
/// (`unmet` below, reported in the run's output), and BDF2 on the jello. The cloth is chaotic there: the CPU from a
/// start moved by one f32 step parts from itself by centimetres within 40 frames, at any step
/// (BENCHMARKS.md), so only a GPU that rounds as the CPU does can end where it ends; lavapipe
/// does, bit for bit, on Mesa 25's one-workgroup step and on Mesa 22.3's per-pass path (both in
/// `.ci/run`). Another
/// adapter answers to `hooke check --verify`'s tolerance instead (`conformance`).
#[test]
fn the_cloth_and_the_jello_at_one_step_per_frame_end_where_the_cpu_ends() {
    if !have_adapter() {
        return;
    }
    if !common::parity::gpu_rounds_as_the_cpu() {
        println!("this adapter does not round as the CPU does: nothing to claim bit for bit");
        return;
    }
    for (name, integrator) in [("cloth", Integrator::Implicit), ("jello", Integrator::Bdf2)] {
        let (model, _) = scene_model(name);
        // Mesa 25 takes the one-workgroup step, Mesa 22.3 (whose loops are capped) the per-pass
        // path: both sum as the CPU does.
        let (mut cpu, mut gpu) = cpu_and_gpu(&model, Step::new(integrator, 1.0 / 60.0));
        let mut unmet = 0;
        step_alike((&mut cpu, &mut gpu), (60, 1), |_, (_, sc), _| {
            unmet += sc.rule.map_or(0, |r| r.unmet_steps);
        });
        let (c, g) = (ok(cpu.state()), ok(gpu.state()));
        let apart = hooke::conformance::Apart::of(&c, &g);
        assert!(
            apart.same_bits,
            "{name} {integrator} {:?}: the GPU ends {:.3e} m from the CPU",
            gpu.implicit_path(),
            apart.farthest_m
        );
        let lowest = |x: &[glam::Vec3]| x.iter().map(|x| x.y).fold(f32::INFINITY, f32::min);
        let fell = lowest(&model.initial.x) - lowest(&c.x);
        println!(
            "{name} {integrator}: bit for bit; its lowest mass fell {fell} m, {unmet} steps short of Newton's rule"
        );
        // Both fell onto what they land on (the cloth's free edge to the ground from 1.2 m).
        assert!(fell > 0.2, "{name}: the lowest mass fell only {fell} m");
    }
}

/// Newton can run out of iterations: the jello resting on its ground with friction at 1/60 s, in
/// frame 19 (friction enters the residual, not the Jacobian). Such a step ends at the best
/// iterate it solved from, with that iterate's ledger rates, on the GPU as on the CPU, on both
/// paths: bit for bit on lavapipe.
#[test]
fn a_step_short_of_newtons_rule_ends_at_its_best_iterate_as_on_the_cpu() {
    use hooke::gpu::ImplicitPath;
    if !have_adapter() || !common::parity::gpu_rounds_as_the_cpu() {
        return;
    }
    let (model, _) = scene_model("jello");
    let step = Step::new(Integrator::Implicit, 1.0 / 60.0);
    for path in [ImplicitPath::InGroup, ImplicitPath::Passes] {
        let mut cpu = CpuBackend::new(model.clone(), step);
        let tuning = hooke::gpu::Tuning {
            implicit: path,
            ..hooke::gpu::Tuning::for_run(&model, step)
        };
        let mut gpu = ok(GpuBackend::with_tuning(model.clone(), step, None, tuning));
        if gpu.implicit_path() != Some(path) {
            println!("{path:?}: this driver takes {:?}", gpu.implicit_path());
            continue;
        }
        let (mut unmet_cpu, mut unmet_gpu) = (0, 0);
        step_alike(
            (&mut cpu, &mut gpu),
            (20, 1),
            |frame, (_, sc), (gpu, sg)| {
                let sg = ok(gpu.snapshot(frame, sg)).stats;
                unmet_cpu += sc.rule.map_or(0, |r| r.unmet_steps);
                unmet_gpu += sg.rule.map_or(0, |r| r.unmet_steps);
                assert_eq!(sc.rule, sg.rule, "{path:?} frame {frame}: how Newton went");
            },
        );
        assert!(
            unmet_cpu > 0,
            "{path:?}: no step ran short of Newton's rule"
        );
        assert_eq!(unmet_cpu, unmet_gpu, "{path:?}");
        let (c, g) = (ok(cpu.state()), ok(gpu.state()));
        let apart = hooke::conformance::Apart::of(&c, &g);
        assert!(
            apart.same_bits,
            "{path:?}: the GPU ends {:.3e} m from the CPU",
            apart.farthest_m
        );
        let (lc, lg) = (c.ledger.dissipated_j(), g.ledger.dissipated_j());
        assert!(
            (lc - lg).abs() <= 1e-6 * lc.abs().max(1e-9),
            "{path:?}: the ledgers part: {lc} J on the CPU, {lg} J on the GPU"
        );
    }
}

/// The conformance probe holds implicit Euler's and BDF2's steps with block Jacobi to the CPU's
/// bits on lavapipe, on whichever path the driver allows, as the tests above do, and says so.
#[test]
fn check_verify_holds_implicit_steps_to_the_cpus_bits_on_lavapipe() {
    use crate::common::{hooke_command, temp_dir, text};
    if !have_adapter() || !common::parity::gpu_rounds_as_the_cpu() {
        return;
    }
    let cache = temp_dir("implicit-verdicts").join("cache");
    for integrator in ["implicit", "bdf2"] {
        let out = hooke_command(&[
            "check",
            "cloth",
            "--integrator",
            integrator,
            "--dt",
            "1/60",
            "--verify",
        ])
        .env("HOOKE_CACHE_DIR", &cache)
        .output()
        .unwrap_or_else(|e| panic!("{e}"));
        let said = text(&out.stdout);
        let verdict = said
            .lines()
            .find(|l| l.starts_with("conformance"))
            .unwrap_or_else(|| panic!("no verdict: {said}"));
        assert!(
            out.status.success()
                && verdict.contains(&format!("{integrator} ("))
                && verdict.contains("block Jacobi)")
                && verdict.contains("agrees with the CPU bit for bit"),
            "{verdict}"
        );
    }
}

/// The per-pass path encodes each frame with budgets (Newton iterations per step, CG iterations
/// per solve) and replays a frame whose step or solve ran out of them. A replay must end exactly
/// where a frame with room to spare ends: the same run with every frame started from budgets of
/// one iteration (replayed, several times each) agrees with the run at its own budgets bit for
/// bit, five steps a frame, in state, ledger and solve figures.
#[test]
fn a_frame_replayed_after_its_budget_ran_out_ends_where_one_with_room_ends() {
    if !have_adapter() {
        return;
    }
    use hooke::gpu::{ExplicitPath, ImplicitBudgets, ImplicitPath};
    // tear: its springs and the energy they let go are part of the frame's start too; BDF2:
    // so is the last step's start, which it blends each step's from; cloth-64: its CG takes the
    // multigrid cycle, whose numbers each Newton iteration rebuilds (nothing to restore).
    for (name, integrator) in [
        ("hair", Integrator::Implicit),
        ("jello-sphere", Integrator::Implicit),
        ("tear", Integrator::Implicit),
        ("jello-sphere", Integrator::Bdf2),
        ("cloth-64", Integrator::Bdf2),
    ] {
        let (model, _) = scene_model(name);
        let dt = 1.0 / 300.0;
        let start = |m| {
            ok(GpuBackend::with_paths(
                m,
                Step::new(integrator, dt),
                None,
                ImplicitPath::Passes,
                ExplicitPath::Fused,
            ))
        };
        let (mut roomy, mut tight) = (start(model.clone()), start(model));
        let starved = ImplicitBudgets {
            newton: 1,
            cg: [1; hooke::physics::NEWTON_MAX_ITERATIONS as usize],
        };
        for frame in 1..=6 {
            tight.set_implicit_budgets(starved);
            let a = ok(roomy.advance(5));
            let b = ok(tight.advance(5));
            let a = ok(roomy.snapshot(frame, a)).stats;
            let b = ok(tight.snapshot(frame, b)).stats;
            assert_eq!(
                (a.solver_iterations, a.solver_residual.to_bits()),
                (b.solver_iterations, b.solver_residual.to_bits()),
                "{name} {integrator} frame {frame}"
            );
            let (sa, sb) = (ok(roomy.state()), ok(tight.state()));
            assert!(
                sa.x == sb.x && sa.v == sb.v && sa.ledger == sb.ledger,
                "{name} {integrator} frame {frame}: a replayed frame ends elsewhere"
            );
        }
        // Every starved frame was replayed at least once (its first solve needs more than one
        // CG iteration); the roomy run's budgets, fitted to its frames, rarely are.
        assert!(
            tight.implicit_replays() >= 6,
            "{name} {integrator}: {} replays",
            tight.implicit_replays()
        );
        eprintln!(
            "{name} {integrator}: {} replays starved, {} at fitted budgets",
            tight.implicit_replays(),
            roomy.implicit_replays()
        );
    }
}

/// Which path a scene's implicit steps take.
#[test]
fn implicit_steps_take_one_workgroup_when_small() {
    use hooke::gpu::ImplicitPath::{InGroup, Passes};
    for (name, path) in [
        ("hair", InGroup),
        ("jello", InGroup),
        ("jello-sphere", InGroup),
        ("cloth-64", Passes),
        ("cloth-256", Passes),
    ] {
        let (model, _) = scene_model(name);
        assert_eq!(hooke::gpu::implicit_path(&model), path, "{name}");
    }
}

/// Where the one-workgroup step keeps its solver vectors and spring terms: workgroup memory when
/// they fit the adapter's limit (hair: 800 + 740 vec4s, 24 640 bytes, beside the sums' scratch:
/// a slot per thread, at least 64, 32 partials and three words, and mass_force's unused word of
/// fused_frame's state), the buffers otherwise and on the per-pass path. The in-group parity test
/// above runs hair one way and jello-sphere the other on lavapipe (32 KB).
#[test]
fn the_one_workgroup_step_keeps_its_vectors_in_workgroup_memory_when_they_fit() {
    use hooke::gpu::ImplicitPath::{InGroup, Passes};
    use hooke::gpu::SolverHome::{Buffers, Workgroup};
    let home = |name: &str, path, threads, bytes| {
        hooke::gpu::SolverHome::of(&scene_model(name).0, path, threads, bytes)
    };
    let hair = Workgroup {
        vectors: 800,
        terms: 740,
    };
    assert_eq!(home("hair", InGroup, 8, 32 * 1024), hair);
    // 8 threads (lavapipe) take the 64 slots of the per-pass kernels' sums.
    assert_eq!(home("hair", InGroup, 8, 26_224), hair);
    assert_eq!(home("hair", InGroup, 8, 26_223), Buffers);
    // 128 threads (hair on a GPU) take 128.
    assert_eq!(home("hair", InGroup, 128, 27_248), hair);
    assert_eq!(home("hair", InGroup, 128, 27_247), Buffers);
    assert_eq!(home("hair", Passes, 8, 1 << 20), Buffers);
    assert_eq!(home("jello", InGroup, 8, 32 * 1024), Buffers);
}

/// The cycle with contacts: a 64 × 64 cloth (the built-in cloth's, at half its spacing) falling
/// onto its sphere at one step per frame, whose contacts add their blocks to the levels' own
/// blocks (`mass_own_block` in multigrid.wgsl), meets the CPU to the same tolerance over its
/// first three frames on the sphere. (From the 20th frame, as the cloth slides, friction's
/// stick or slip parts the backends with either preconditioner: measured on lavapipe, 0.7 mm
/// at once with multigrid, 7 mm with block Jacobi.)
#[test]
fn gpu_multigrid_meets_the_cpu_with_contacts() {
    if !have_adapter() {
        return;
    }
    let cloth = std::fs::read_to_string("examples/scenes/cloth.toml")
        .unwrap_or_else(|e| panic!("examples/scenes/cloth.toml: {e}"))
        .replace("grid = [32, 32]", "grid = [64, 64]")
        .replace("spacing_m = 0.05", "spacing_m = 0.025")
        .replace("pins = [[0, 0], [31, 0]]", "pins = [[0, 0], [63, 0]]")
        .replace("substeps = 60", "substeps = 1");
    let file = common::temp_dir("multigrid-contacts").join("cloth-64-sphere.toml");
    std::fs::write(&file, cloth).unwrap_or_else(|e| panic!("{e}"));
    let name = file.to_string_lossy();
    let (model, _) = scene_model(&name);
    assert_eq!(model.mass_count(), 4096);
    // The cloth reaches the sphere in its 17th frame.
    parity(
        Integrator::Implicit,
        &name,
        19,
        (
            hooke::gpu::ImplicitPath::Passes,
            None,
            hooke::physics::Preconditioner::Multigrid,
        ),
    );
}

fn implicit_parity(name: &str, frames: u64, path: hooke::gpu::ImplicitPath) {
    implicit_parity_with(Integrator::Implicit, name, frames, path, None);
}

/// As `implicit_parity`, with `integrator` (implicit Euler or BDF2), the one-workgroup step with
/// `threads` threads (by default the adapter's choice).
fn implicit_parity_with(
    integrator: Integrator,
    name: &str,
    frames: u64,
    path: hooke::gpu::ImplicitPath,
    threads: Option<u32>,
) {
    let (model, _) = scene_model(name);
    let preconditioner =
        hooke::physics::preconditioner_of(&model, Step::new(integrator, 1.0 / 60.0));
    parity(integrator, name, frames, (path, threads, preconditioner));
}

/// The parity run of `implicit_parity_with`, both backends' CG preconditioned by
/// `preconditioner`; returns the GPU's CG iterations over the run.
fn parity(
    integrator: Integrator,
    name: &str,
    frames: u64,
    (path, threads, preconditioner): (
        hooke::gpu::ImplicitPath,
        Option<u32>,
        hooke::physics::Preconditioner,
    ),
) -> f64 {
    let (model, _) = scene_model(name);
    let dt = 1.0 / 60.0;
    let mut cpu = CpuBackend::new(model.clone(), Step::new(integrator, dt));
    cpu.set_preconditioner(preconditioner);
    let tuning = hooke::gpu::Tuning {
        implicit: path,
        explicit: hooke::gpu::ExplicitPath::Fused,
        solver_threads: threads,
        preconditioner,
        ..hooke::gpu::Tuning::for_run(&model, Step::new(integrator, dt))
    };
    let mut gpu = ok(GpuBackend::with_tuning(
        model.clone(),
        Step::new(integrator, dt),
        None,
        tuning,
    ));
    // A driver that cuts loops short gets no one-workgroup step (tests/gpu.rs, the loop
    // probe): there the run takes, and this test checks, the per-pass path.
    let budget = gpu.loop_budget();
    let path = match budget.runs_long_loops() {
        true => path,
        false => {
            println!("{name}: {budget}; the per-pass path instead of {path:?}");
            hooke::gpu::ImplicitPath::Passes
        }
    };
    assert_eq!(gpu.implicit_path(), Some(path), "{name}");
    // Lavapipe sums as the CPU does on either path at its own threads (`SUM_LANES`).
    let exact = threads.is_none()
        && preconditioner == hooke::physics::Preconditioner::BlockJacobi
        && common::parity::gpu_rounds_as_the_cpu();
    let (mut worst_x, mut worst_v) = (0.0f64, 0.0f64);
    let mut totals = (0.0f64, 0.0f64);
    let pair = (&mut cpu, &mut gpu);
    step_alike(pair, (frames, 1), |frame, (cpu, sc), (gpu, sg)| {
        // The GPU's solve figures come back with the frame's snapshot.
        let sg = ok(gpu.snapshot(frame, sg)).stats;
        // Each solve reaches a tenth of the Newton residual it started from (inexact Newton); a
        // step whose warm start already meets Newton's rule solves nothing, but the first has
        // no warm start.
        for (what, s) in [("cpu", sc), ("gpu", sg)] {
            assert!(
                (frame > 1 || s.solver_iterations > 0)
                    && s.solver_residual <= hooke::physics::CG_FORCING,
                "{name} {path:?} frame {frame} {what}: {} iterations, residual {}",
                s.solver_iterations,
                s.solver_residual
            );
        }
        // The same system converges in about the same number of iterations: step by step for
        // implicit Euler; over the run for BDF2, whose steps on the resting jello sit near
        // Newton's thresholds (moving the CPU's own start by 1e-7 m took its sixth step from 30
        // to 51 CG iterations, and its fifteenth from 141 to 30).
        let (ic, ig) = (
            f64::from(sc.solver_iterations),
            f64::from(sg.solver_iterations),
        );
        totals = (totals.0 + ic, totals.1 + ig);
        assert!(
            integrator == Integrator::Bdf2 || (ic - ig).abs() <= 0.25 * ic + 8.0,
            "{name} {path:?} frame {frame}: {ic} CG iterations on the CPU, {ig} on the GPU"
        );
        let (c, g) = (ok(cpu.state()), ok(gpu.state()));
        if exact {
            let apart = hooke::conformance::Apart::of(&c, &g);
            assert!(
                apart.same_bits,
                "{name} {integrator} {path:?} frame {frame}: lavapipe is {:.3e} m from the CPU",
                apart.farthest_m
            );
            assert_eq!(
                (sc.solver_iterations, sc.newton_iterations, sc.rule),
                (sg.solver_iterations, sg.newton_iterations, sg.rule),
                "{name} {integrator} frame {frame}: the solves went otherwise"
            );
            assert_eq!(
                sc.solver_residual, sg.solver_residual,
                "{name} frame {frame}"
            );
        }
        for (a, b) in c.x.iter().zip(&g.x) {
            worst_x = worst_x.max(f64::from(a.distance(*b)));
        }
        for (a, b) in c.v.iter().zip(&g.v) {
            worst_v = worst_v.max(f64::from(a.distance(*b)));
        }
        // A step's velocities hold to NEWTON_RESIDUAL, and a dashpot's power is quadratic in
        // them: BDF2's steps, near Newton's thresholds, may end on iterates that far apart (the
        // jello struck at frame 19 dissipated 4.3% more on the CPU from a start moved by 1e-7 m,
        // 4.9% more on the GPU); implicit Euler's stay within 2% there.
        let share = match integrator {
            Integrator::Bdf2 => 2.0 * hooke::physics::NEWTON_RESIDUAL,
            _ => hooke::physics::NEWTON_RESIDUAL,
        };
        let (ec, eg) = (c.ledger.dissipated_j(), g.ledger.dissipated_j());
        assert!(
            (ec - eg).abs() <= share * ec.abs().max(1e-3),
            "{name} {path:?} frame {frame}: dissipated {ec} J on the CPU, {eg} J on the GPU"
        );
    });
    assert!(
        (totals.0 - totals.1).abs() <= 0.25 * totals.0 + 8.0,
        "{name} {integrator} {path:?}: {} CG iterations on the CPU, {} on the GPU",
        totals.0,
        totals.1
    );
    let moved = ok(cpu.state())
        .v
        .iter()
        .map(|v| f64::from(v.length()))
        .fold(0.0, f64::max);
    assert!(moved > 1e-3, "{name}: nothing moved");
    assert!(
        worst_x <= 5e-4 && worst_v <= 2e-2,
        "{name} {integrator} {path:?}: the GPU differs from the CPU by {worst_x:.3e} m, {worst_v:.3e} m/s"
    );
    println!(
        "{name} {integrator} {path:?} {}: |Δx| {worst_x:.2e} m, |Δv| {worst_v:.2e} m/s",
        preconditioner.name()
    );
    totals.1
}

/// From 4 096 masses both backends precondition implicit Euler's CG with aggregation multigrid
/// over the same levels (`hooke::physics::hierarchy`): the GPU's cycle (multigrid.wgsl, a dispatch per
/// level and pass, the coarsest level's inverse in f32 where the CPU factors it in f64) meets
/// the CPU's to the parity tolerance of `implicit_parity`, as block Jacobi on both does, and
/// takes a third or fewer of block Jacobi's CG iterations. cloth-64 (4 096 masses, the per-pass
/// path) at one step per frame, falling from two corners for a third of a second; and the peer
/// cloth at N = 64 with BDF2 for a sixth of a second. (Later, as it folds, that cloth's path
/// turns on where a solve stops: after 20 steps the backends end 8 mm apart with block Jacobi,
/// 1 cm with multigrid, measured on lavapipe.)
#[test]
fn gpu_multigrid_meets_the_cpu_and_cuts_cg_iterations() {
    if !have_adapter() {
        return;
    }
    use hooke::gpu::ImplicitPath::Passes;
    use hooke::physics::Preconditioner::Multigrid;
    multigrid_cuts_cg_iterations("cloth-64", Passes);
    let peer = "bench/scenes/peer-cloth-64-60hz.toml";
    parity(Integrator::Bdf2, peer, 10, (Passes, None, Multigrid));
}

/// The one-workgroup step (small systems) runs the same cycle (`mg_implicit_step`: each of the
/// cycle's passes a loop of the workgroup's threads over a level's nodes, a barrier where the
/// per-pass path ends a dispatch) and meets the CPU's multigrid to the parity tolerance: the
/// jello on the ground (contacts in the levels' blocks) with at most a third of block Jacobi's CG
/// iterations, the cloth onto its sphere with a GPU's 64 threads, the struck jello with BDF2,
/// and hair of 10-mass strands, whose solver vectors sit in workgroup memory beside the coarsest
/// level's elimination.
#[test]
fn gpu_multigrid_in_one_workgroup_meets_the_cpu() {
    if !have_adapter() {
        return;
    }
    use hooke::gpu::ImplicitPath::InGroup;
    use hooke::physics::Preconditioner::Multigrid;
    multigrid_cuts_cg_iterations("jello", InGroup);
    parity(
        Integrator::Implicit,
        "cloth",
        20,
        (InGroup, Some(64), Multigrid),
    );
    parity(
        Integrator::Bdf2,
        "jello-sphere",
        20,
        (InGroup, None, Multigrid),
    );

    let hair = std::fs::read_to_string("examples/scenes/hair.toml")
        .unwrap_or_else(|e| panic!("examples/scenes/hair.toml: {e}"))
        .replace("grid = [20]", "grid = [10]")
        .replace("substeps = 20", "substeps = 1");
    let file = common::temp_dir("multigrid-in-group").join("short-hair.toml");
    std::fs::write(&file, hair).unwrap_or_else(|e| panic!("{e}"));
    let name = file.to_string_lossy();
    let (model, _) = scene_model(&name);
    let lavapipe = 32 * 1024 - hooke::gpu::MULTIGRID_FACTOR_WORKGROUP_BYTES;
    assert!(matches!(
        hooke::gpu::SolverHome::of(&model, InGroup, 8, lavapipe),
        hooke::gpu::SolverHome::Workgroup { .. }
    ));
    parity(Integrator::Implicit, &name, 30, (InGroup, None, Multigrid));
}

/// `name`'s first 20 steps of implicit Euler at one step per frame on the GPU's `path`, with
/// multigrid and then block Jacobi on both backends: each meets the CPU (`parity`), and
/// multigrid takes at most a third of block Jacobi's CG iterations on the GPU.
fn multigrid_cuts_cg_iterations(name: &str, path: hooke::gpu::ImplicitPath) {
    use hooke::physics::Preconditioner::{BlockJacobi, Multigrid};
    let multigrid = parity(Integrator::Implicit, name, 20, (path, None, Multigrid));
    let jacobi = parity(Integrator::Implicit, name, 20, (path, None, BlockJacobi));
    println!(
        "{name} implicit, 20 steps on the GPU's {path:?} path: CG iterations {jacobi} (block Jacobi), {multigrid} (multigrid)"
    );
    assert!(
        3.0 * multigrid <= jacobi,
        "{name}: {multigrid} against {jacobi}"
    );
}
