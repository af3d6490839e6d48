//! What the host spends to put one GPU step in flight: planning, writing the stage slots,
//! recording the dispatches, and submitting (`advance`, which returns without waiting), against
//! the device's own time for the same steps. On a fast GPU a small scene's steps cost the device
//! a few microseconds, so this host cost sets how fast the run can go.
//!
//! `cargo run --release --example host_cost -- SCENE [STEPS]`
//!
//! SCENE is a built-in name or a file; STEPS per submission defaults to 1 000. Prints the best of
//! five submissions. See BENCHMARKS.md ("The host's cost per step").

use std::time::Instant;

use hooke::backend::Backend;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(scene) = args.first() else {
        anyhow::bail!("usage: host_cost SCENE [STEPS]");
    };
    let steps: u32 = args.get(1).map_or(Ok(1000), |s| s.parse())?;
    let planned = hooke::run::prepare::planned(scene)?;
    let mut gpu =
        hooke::gpu::GpuBackend::new(planned.model.clone(), planned.settings.step(), None)?;
    // Warm-up: pipelines compiled, buffers grown to the submission's size.
    gpu.advance(steps)?;
    gpu.finish()?;
    let (mut host, mut all) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let start = Instant::now();
        gpu.advance(steps)?;
        host = host.min(start.elapsed().as_secs_f64());
        gpu.finish()?;
        all = all.min(start.elapsed().as_secs_f64());
    }
    let per_step = |secs: f64| secs * 1e6 / f64::from(steps);
    println!(
        "{scene}, {} masses, {steps} steps a submission on {} ({:?} path): host {:.2} µs a step, \
         host and device {:.2} µs a step (best of 5)",
        planned.model.mass_count(),
        gpu.describe(),
        gpu.explicit_path(),
        per_step(host),
        per_step(all)
    );
    Ok(())
}
