//! A scene stepped on the GPU (the run's default paths on this adapter) and on the CPU
//! reference, frame by frame: where every mass ends on each, how far apart, and whether every
//! bit agrees. The runs that end where the CPU ends on every driver
//! (docs/drivers.md, BENCHMARKS.md "Correct or a clear error on Mesa 22.3"):
//!
//! `cargo run --release --example backends_agree -- SCENE [INTEGRATOR] [DT] [FRAMES] [SWEEPS]`
//!
//! INTEGRATOR and DT (seconds a step) default to the scene's, FRAMES to the scene's, SWEEPS is
//! VBD's or XPBD's sweeps a step. E.g. `cloth implicit 0.016666667 60`,
//! `jello bdf2 0.016666667 60`, `bench/scenes/jello-4-pinned.toml vbd 4.1666667e-4 2 200`.

use hooke::backend::Backend;
use hooke::cpu::CpuBackend;
use hooke::gpu::GpuBackend;
use hooke::integrator::{Integrator, Step};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(scene) = args.first() else {
        anyhow::bail!("usage: backends_agree SCENE [INTEGRATOR] [DT] [FRAMES] [SWEEPS]");
    };
    let hooke::run::prepare::Planned {
        settings, model, ..
    } = hooke::run::prepare::planned(scene)?;
    let integrator = match args.get(1) {
        Some(name) => Integrator::ALL
            .into_iter()
            .find(|i| i.name() == name)
            .ok_or_else(|| anyhow::anyhow!("no integrator '{name}'"))?,
        None => settings.integrator,
    };
    let dt: f64 = args.get(2).map_or(Ok(settings.dt_secs), |s| s.parse())?;
    let frames: u64 = args.get(3).map_or(Ok(settings.frames), |s| s.parse())?;
    let mut options = settings.options;
    if let Some(sweeps) = args.get(4) {
        options.vbd_iterations = sweeps.parse()?;
        options.xpbd_iterations = options.vbd_iterations;
    }
    let substeps = ((1.0 / settings.frame_rate_hz) / dt).round().max(1.0) as u32;
    let step = Step::new(integrator, dt).with_options(options);
    let mut cpu = CpuBackend::new(model.clone(), step);
    let mut gpu = GpuBackend::new(model.clone(), step, None)?;
    println!(
        "{scene}: {integrator} at dt = {dt:.4e} s, {substeps} steps a frame, {frames} frames, on {} ({} {}); GPU paths: {}; loops: {}",
        gpu.adapter_info().name,
        gpu.adapter_info().driver,
        gpu.adapter_info().driver_info,
        gpu.kernel_family(),
        gpu.loop_budget(),
    );
    for _ in 0..frames {
        cpu.advance(substeps)?;
        gpu.advance(substeps)?;
    }
    let (c, g) = (cpu.state()?, gpu.state()?);
    let apart = hooke::conformance::Apart::of(&c, &g);
    let mean_y = |x: &[glam::Vec3]| x.iter().map(|p| f64::from(p.y)).sum::<f64>() / x.len() as f64;
    println!(
        "mean height: GPU {:.4} m, CPU {:.4} m; the farthest mass is {:.3e} m from the CPU's; bit for bit: {}",
        mean_y(&g.x),
        mean_y(&c.x),
        apart.farthest_m,
        if apart.same_bits { "yes" } else { "no" }
    );
    Ok(())
}
