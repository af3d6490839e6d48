//! The GPU's large-step solvers on one scene, each way it can run: implicit Euler's
//! one-workgroup step at several thread counts (and its dispatch per pass), BDF2 on its path,
//! VBD's sweeps in one workgroup and a dispatch per colour and sweep. Measured in one process and interleaved, so
//! that a noisy machine slows them alike; each variant's final positions are compared with the
//! first's of its integrator.
//!
//! `cargo run --release --example large_steps -- SCENE [DT] [STEPS] [ROUNDS] [THREADS,…]`
//!
//! DT defaults to 1/60 s (one step per frame), STEPS per timing to 60, ROUNDS to 3, THREADS
//! (the one-workgroup implicit step's) to the adapter's choice only. Prints each variant's best
//! steps/s. See BENCHMARKS.md.

use std::time::Instant;

use hooke::backend::{Backend, advance_steps};
use hooke::gpu::{GpuBackend, ImplicitPath, Tuning};
use hooke::integrator::{Integrator, Step};

struct Variant {
    label: String,
    integrator: Integrator,
    backend: GpuBackend,
    best_secs: f64,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(scene) = args.first() else {
        anyhow::bail!("usage: large_steps SCENE [DT] [STEPS] [ROUNDS] [THREADS,…]");
    };
    let hooke::run::prepare::Planned {
        settings, model, ..
    } = hooke::run::prepare::planned(scene)?;
    let dt: f64 = args.get(1).map_or(Ok(1.0 / 60.0), |s| s.parse())?;
    let steps: u64 = args.get(2).map_or(Ok(60), |s| s.parse())?;
    let rounds: usize = args.get(3).map_or(Ok(3), |s| s.parse())?;
    let threads: Vec<Option<u32>> = match args.get(4) {
        Some(list) => list
            .split(',')
            .map(|t| t.parse().map(Some))
            .collect::<Result<_, _>>()?,
        None => vec![None],
    };
    let base = Tuning::for_run(
        &model,
        hooke::integrator::Step::new(Integrator::Implicit, dt),
    );
    let mut plans: Vec<(String, Integrator, Tuning)> = Vec::new();
    if base.implicit == ImplicitPath::InGroup {
        for t in &threads {
            let label = t.map_or("implicit, one workgroup".to_owned(), |t| {
                format!("implicit, one workgroup of {t}")
            });
            let tuning = Tuning {
                solver_threads: *t,
                ..base
            };
            plans.push((label, Integrator::Implicit, tuning));
        }
    }
    let passes = Tuning {
        implicit: ImplicitPath::Passes,
        ..base
    };
    plans.push((
        "implicit, a dispatch per pass".to_owned(),
        Integrator::Implicit,
        passes,
    ));
    // BDF2: the same solve from a blended start, on the path the run would take.
    plans.push(("bdf2".to_owned(), Integrator::Bdf2, base));
    for (label, in_group) in [
        ("vbd, sweeps in one workgroup", true),
        ("vbd, a dispatch per colour", false),
    ] {
        let tuning = Tuning {
            vbd_in_group: Some(in_group),
            ..base
        };
        plans.push((label.to_owned(), Integrator::Vbd, tuning));
    }
    let mut variants = Vec::new();
    for (label, integrator, tuning) in plans {
        let step = Step::new(integrator, dt).with_options(settings.options);
        let mut backend = GpuBackend::with_tuning(model.clone(), step, None, tuning)?;
        // Warm-up: pipelines compiled.
        backend.advance(1)?;
        backend.finish()?;
        variants.push(Variant {
            label,
            integrator,
            backend,
            best_secs: f64::INFINITY,
        });
    }
    for _ in 0..rounds {
        for v in &mut variants {
            let start = Instant::now();
            advance_steps(&mut v.backend as &mut dyn Backend, steps, 1)?;
            v.backend.finish()?;
            v.best_secs = v.best_secs.min(start.elapsed().as_secs_f64());
        }
    }
    println!(
        "{scene}, {} masses, {} springs, dt {dt:.5} s, {steps} steps a timing (one a submission), best of {rounds} on {}:",
        model.mass_count(),
        model.spring_count(),
        variants
            .first()
            .map(|v| v.backend.describe())
            .unwrap_or_default()
    );
    let mut firsts: Vec<(Integrator, Vec<glam::Vec3>)> = Vec::new();
    for v in &mut variants {
        let x = v.backend.state()?.x;
        let apart = match firsts.iter().find(|(i, _)| *i == v.integrator) {
            Some((_, first)) => first
                .iter()
                .zip(&x)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0f32, f32::max),
            None => {
                firsts.push((v.integrator, x));
                0.0
            }
        };
        println!(
            "  {:<36} {:>10.1} steps/s  max |Δx| from the first {apart:.2e} m",
            v.label,
            steps as f64 / v.best_secs,
        );
    }
    Ok(())
}
