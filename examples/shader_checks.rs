//! One scene stepped by two GPU backends whose kernels differ only in wgpu's runtime checks
//! (`ShaderChecks`: an index clamp at each array access and a counter in each loop, injected or
//! left out), interleaved in one process; the final states are compared bit for bit.
//!
//! `cargo run --release --example shader_checks -- SCENE [INTEGRATOR] [DT] [STEPS] [ROUNDS] [BATCH]`
//!
//! INTEGRATOR defaults to the scene's, DT to its step (either given as `-` too), STEPS per timing to 200, ROUNDS to 3,
//! BATCH (steps per submission) to 20. See BENCHMARKS.md.

use std::time::Instant;

use hooke::backend::{Backend, advance_steps};
use hooke::gpu::{GpuBackend, ShaderChecks, Tuning};
use hooke::integrator::{Integrator, Step};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(scene) = args.first() else {
        anyhow::bail!("usage: shader_checks SCENE [INTEGRATOR] [DT] [STEPS] [ROUNDS] [BATCH]");
    };
    let hooke::prepare::Planned {
        settings, model, ..
    } = hooke::prepare::planned(scene)?;
    // "-" takes the scene's own integrator or step.
    let given = |k: usize| args.get(k).filter(|a| a.as_str() != "-");
    let integrator = match given(1) {
        Some(name) => Integrator::ALL
            .into_iter()
            .find(|i| i.name() == name)
            .ok_or_else(|| anyhow::anyhow!("no integrator named {name}"))?,
        None => settings.integrator,
    };
    let dt: f64 = given(2).map_or(Ok(settings.dt_secs), |s| s.parse())?;
    let steps: u64 = args.get(3).map_or(Ok(200), |s| s.parse())?;
    let rounds: usize = args.get(4).map_or(Ok(3), |s| s.parse())?;
    let batch: u32 = args.get(5).map_or(Ok(20), |s| s.parse())?;
    let step = Step::new(integrator, dt).with_options(settings.options);
    let mut runs = Vec::new();
    for checks in [ShaderChecks::Injected, ShaderChecks::Trusted] {
        let tuning = Tuning {
            shader_checks: checks,
            ..Tuning::for_model(&model)
        };
        let mut be = GpuBackend::with_tuning(model.clone(), step, None, tuning)?;
        // Warm-up: pipelines compiled, Verlet primed.
        be.advance(batch)?;
        be.finish()?;
        runs.push((checks, be, f64::INFINITY));
    }
    for _ in 0..rounds {
        for (_, be, best) in &mut runs {
            let start = Instant::now();
            advance_steps(be as &mut dyn Backend, steps, batch)?;
            be.finish()?;
            *best = best.min(start.elapsed().as_secs_f64());
        }
    }
    println!(
        "{scene}, {}, dt {dt:.3e} s, {} masses, {steps} steps in submissions of {batch}, best of {rounds} on {}:",
        integrator.name(),
        model.mass_count(),
        runs[0].1.describe()
    );
    let mut finals = Vec::new();
    for (checks, be, best) in &mut runs {
        println!(
            "  checks {:<9} {:>12.1} steps/s",
            format!("{checks:?}").to_lowercase(),
            steps as f64 / *best
        );
        finals.push(be.state()?);
    }
    let same = finals[0].x == finals[1].x && finals[0].v == finals[1].v;
    println!(
        "  final states {}",
        if same { "bit-identical" } else { "DIFFER" }
    );
    Ok(())
}
