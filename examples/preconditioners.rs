//! Implicit Euler with each preconditioner of its conjugate gradients (3 × 3 block Jacobi,
//! aggregation multigrid), on one scene at one step, on the CPU backend or the GPU's per-pass
//! path: steps/s, CG iterations per step, and where the masses end. The preconditioners are
//! timed in turn, round after round, so that a noisy machine slows them alike; each round steps
//! from the scene's start, a frame a step.
//!
//! `cargo run --release --example preconditioners -- SCENE [DT] [STEPS] [ROUNDS] [ONLY] [INTEGRATOR] [BACKEND] [PATH]`
//!
//! DT defaults to 1/60 s (one step per frame), STEPS to 30, ROUNDS to 2; ONLY, `multigrid` or
//! `block-jacobi`, times that one alone (for a profiler; `both` times both); INTEGRATOR is
//! `implicit` (the default) or `bdf2`; BACKEND `cpu` (the default) or `gpu` (the best adapter,
//! its CG iterations counted in an untimed run of the first round, a snapshot a step); PATH, on
//! the GPU, `passes` (the default: a dispatch per pass) or `group` (the whole step in one
//! workgroup, as small systems take it). Each row ends with a digest of the end positions' bits,
//! to tell bit-identical runs apart from close ones.
//! `RAYON_NUM_THREADS` sets the CPU's threads. See BENCHMARKS.md.

use std::time::Instant;

use hooke::backend::Backend;
use hooke::cpu::CpuBackend;
use hooke::gpu::{GpuBackend, ImplicitPath, Tuning};
use hooke::integrator::{Integrator, Step};
use hooke::physics::Preconditioner;

struct Row {
    preconditioner: Preconditioner,
    best_secs: f64,
    cg_iterations: u64,
    end: Vec<glam::Vec3>,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(scene) = args.first() else {
        anyhow::bail!(
            "usage: preconditioners SCENE [DT] [STEPS] [ROUNDS] [multigrid|block-jacobi|both] [implicit|bdf2] [cpu|gpu] [passes|group]"
        );
    };
    let hooke::run::prepare::Planned { model, .. } = hooke::run::prepare::planned(scene)?;
    let dt: f64 = args.get(1).map_or(Ok(1.0 / 60.0), |s| s.parse())?;
    let steps: u32 = args.get(2).map_or(Ok(30), |s| s.parse())?;
    let rounds: usize = args.get(3).map_or(Ok(2), |s| s.parse())?;
    let only = args.get(4).map(String::as_str);
    let integrator = match args.get(5).map(String::as_str) {
        None | Some("implicit") => Integrator::Implicit,
        Some("bdf2") => Integrator::Bdf2,
        Some(other) => anyhow::bail!("INTEGRATOR is implicit or bdf2, not {other:?}"),
    };
    let gpu = match args.get(6).map(String::as_str) {
        None | Some("cpu") => false,
        Some("gpu") => true,
        Some(other) => anyhow::bail!("BACKEND is cpu or gpu, not {other:?}"),
    };
    let path = match args.get(7).map(String::as_str) {
        None | Some("passes") => ImplicitPath::Passes,
        Some("group") => ImplicitPath::InGroup,
        Some(other) => anyhow::bail!("PATH is passes or group, not {other:?}"),
    };
    let step = Step::new(integrator, dt);
    // The backend with `preconditioner`, from the scene's start (the GPU on its per-pass path).
    let start = |preconditioner: Preconditioner| -> anyhow::Result<Box<dyn Backend>> {
        Ok(if gpu {
            let tuning = Tuning {
                implicit: path,
                preconditioner,
                ..Tuning::for_run(&model, step)
            };
            Box::new(GpuBackend::with_tuning(model.clone(), step, None, tuning)?)
        } else {
            let mut be = CpuBackend::new(model.clone(), step);
            be.set_preconditioner(preconditioner);
            Box::new(be)
        })
    };
    let mut rows: Vec<Row> = [Preconditioner::BlockJacobi, Preconditioner::Multigrid]
        .into_iter()
        .filter(|p| match only {
            Some("multigrid") => *p == Preconditioner::Multigrid,
            Some("block-jacobi") => *p == Preconditioner::BlockJacobi,
            _ => true,
        })
        .map(|preconditioner| Row {
            preconditioner,
            best_secs: f64::INFINITY,
            cg_iterations: 0,
            end: Vec::new(),
        })
        .collect();
    for round in 0..rounds {
        for row in &mut rows {
            if gpu && round == 0 {
                // A step's CG iterations come back with its snapshot.
                let mut be = start(row.preconditioner)?;
                for frame in 1..=u64::from(steps) {
                    let stats = be.advance(1)?;
                    row.cg_iterations +=
                        u64::from(be.snapshot(frame, stats)?.stats.solver_iterations);
                }
            }
            let mut be = start(row.preconditioner)?;
            let mut cg = 0u64;
            let clock = Instant::now();
            for _ in 0..steps {
                cg += u64::from(be.advance(1)?.solver_iterations);
            }
            row.end = be.state()?.x;
            row.best_secs = row.best_secs.min(clock.elapsed().as_secs_f64());
            if !gpu {
                row.cg_iterations = cg;
            }
        }
    }
    let on = if gpu {
        match path {
            ImplicitPath::Passes => "the GPU's per-pass path".to_owned(),
            ImplicitPath::InGroup => "the GPU's one-workgroup step".to_owned(),
        }
    } else {
        format!("cpu ({} threads)", rayon::current_num_threads())
    };
    println!(
        "{scene}, {integrator}, {} masses, dt {dt:.5} s, {steps} steps from its start, best of {rounds} on {on}:",
        model.mass_count(),
    );
    let first = rows.first().map(|r| r.end.clone()).unwrap_or_default();
    for row in &rows {
        let apart = first
            .iter()
            .zip(&row.end)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0f32, f32::max);
        let mean_y = row.end.iter().map(|x| f64::from(x.y)).sum::<f64>() / row.end.len() as f64;
        // FNV-1a over the positions' bits.
        let digest = row
            .end
            .iter()
            .flat_map(|p| p.to_array())
            .fold(0xcbf2_9ce4_8422_2325u64, |h, c| {
                (h ^ u64::from(c.to_bits())).wrapping_mul(0x0100_0000_01b3)
            });
        println!(
            "  {:<24} {:>8.2} steps/s  {:>7.1} CG iterations a step  mean y {mean_y:+.5} m  max |Δx| from block Jacobi {apart:.2e} m  digest {digest:016x}",
            row.preconditioner.name(),
            f64::from(steps) / row.best_secs,
            row.cg_iterations as f64 / f64::from(steps),
        );
    }
    Ok(())
}
