//! The GPU's explicit paths on one scene: the general passes, the fused steps
//! (shaders/fused.wgsl, a dispatch per step) and, where the scene is small enough, every step of
//! a submission in one workgroup (shaders/fused_frame.wgsl); measured in one process and
//! interleaved so that a noisy machine slows them alike; the final states are compared bit for
//! bit.
//!
//! `cargo run --release --example gpu_paths -- SCENE [INTEGRATOR] [STEPS] [ROUNDS] [BATCH]`
//!
//! SCENE is a built-in name or a file; INTEGRATOR defaults to the scene's, STEPS per timing to
//! 200, ROUNDS of each path to 3, BATCH (steps per submission) to 20. Prints each path's best
//! steps/s and spring updates/s, and its dispatches per step. See BENCHMARKS.md.

use std::time::Instant;

use hooke::backend::{Backend, advance_steps};
use hooke::gpu::{ExplicitPath, GpuBackend, ImplicitPath};
use hooke::integrator::{Integrator, Step};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(scene) = args.first() else {
        anyhow::bail!("usage: gpu_paths SCENE [INTEGRATOR] [STEPS] [ROUNDS] [BATCH]");
    };
    let hooke::run::prepare::Planned {
        settings, model, ..
    } = hooke::run::prepare::planned(scene)?;
    let integrator = match args.get(1) {
        Some(name) => Integrator::ALL
            .into_iter()
            .find(|i| i.name() == name)
            .ok_or_else(|| anyhow::anyhow!("no integrator named {name}"))?,
        None => settings.integrator,
    };
    let steps: u64 = args.get(2).map_or(Ok(200), |s| s.parse())?;
    let rounds: usize = args.get(3).map_or(Ok(3), |s| s.parse())?;
    let batch: u32 = args.get(4).map_or(Ok(20), |s| s.parse())?;
    let mut backends = Vec::new();
    for path in [
        ExplicitPath::General,
        ExplicitPath::Fused,
        ExplicitPath::InGroup,
    ] {
        let be = GpuBackend::with_paths(
            model.clone(),
            Step::new(integrator, settings.dt_secs),
            None,
            ImplicitPath::Passes,
            path,
        )?;
        // A run takes the next path open to it: time each path once.
        let path = be.explicit_path();
        if backends.iter().any(|(p, _, _)| *p == path) {
            continue;
        }
        let mut be = be;
        // Warm-up: pipelines compiled, Verlet primed.
        be.advance(batch)?;
        be.finish()?;
        backends.push((path, be, f64::INFINITY));
    }
    for _ in 0..rounds {
        for (_, be, best) in &mut backends {
            let start = Instant::now();
            advance_steps(be as &mut dyn Backend, steps, batch)?;
            be.finish()?;
            *best = best.min(start.elapsed().as_secs_f64());
        }
    }
    println!(
        "{scene}, {}, {} masses, {} springs, {steps} steps in submissions of {batch}, best of {rounds} on {}:",
        integrator.name(),
        model.mass_count(),
        model.spring_count(),
        backends[0].1.describe()
    );
    let mut finals = Vec::new();
    for (path, be, best) in &mut backends {
        let per_sec = steps as f64 / *best;
        let d = hooke::gpu::dispatches_per_step(
            &model,
            Step::new(integrator, settings.dt_secs),
            be.step_paths(),
        );
        let dispatches = if d.in_group {
            format!("{} dispatch per submission", d.fixed)
        } else {
            format!("{} dispatches per step", d.fixed)
        };
        println!(
            "  {:<8} {per_sec:>10.1} steps/s  {:>10.3e} spring updates/s  ({dispatches})",
            format!("{path:?}").to_lowercase(),
            per_sec * model.spring_count() as f64,
        );
        finals.push(be.state()?);
    }
    let same = finals
        .iter()
        .all(|f| f.x == finals[0].x && f.v == finals[0].v);
    println!(
        "  final states {}",
        if same { "bit-identical" } else { "DIFFER" }
    );
    Ok(())
}
