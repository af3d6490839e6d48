//! Every built-in scene under every integrator it supports, stepped on the CPU reference and on
//! the GPU (this machine's adapter, lavapipe without a GPU): one line each with the end state's
//! digest ([`hooke::state::State::digest`], a hash of the positions' and velocities' bits).
//! A change meant to keep behaviour keeps every line; compare two runs' outputs with `diff`.
//!
//! `cargo run --release --example digests -- [STEPS] [SCENE…]`
//!
//! STEPS (default 60) at the scene's own step; scenes of over 20 000 masses take 3 steps, so
//! that the million-mass cloth stays a minute on two cores. `--cpu` leaves the GPU out.

use hooke::backend::Backend;
use hooke::cpu::CpuBackend;
use hooke::gpu::GpuBackend;
use hooke::integrator::{Integrator, Step};

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let cpu_only = args.iter().any(|a| a == "--cpu");
    args.retain(|a| a != "--cpu");
    let steps: u32 = match args.first().map(|a| a.parse()) {
        Some(Ok(n)) => {
            args.remove(0);
            n
        }
        _ => 60,
    };
    let scenes: Vec<String> = if args.is_empty() {
        hooke::scene::BUILT_IN
            .iter()
            .map(|b| b.name.to_string())
            .collect()
    } else {
        args
    };
    for scene in &scenes {
        let hooke::run::prepare::Planned {
            settings, model, ..
        } = hooke::run::prepare::planned(scene)?;
        let n = if model.mass_count() > 20_000 {
            3
        } else {
            steps
        };
        for integrator in Integrator::ALL {
            if integrator.supports(&model.effects).is_err() {
                continue;
            }
            let step = Step::new(integrator, settings.dt_secs).with_options(settings.options);
            let mut cpu = CpuBackend::new(model.clone(), step);
            let cpu_line = match cpu.advance(n) {
                Ok(_) => format!("{:016x}", cpu.state()?.digest()),
                Err(e) => format!("error: {e}"),
            };
            let gpu_line = if cpu_only {
                String::from("-")
            } else {
                match GpuBackend::new(model.clone(), step, None) {
                    Ok(mut gpu) => match gpu.advance(n) {
                        Ok(_) => format!("{:016x}", gpu.state()?.digest()),
                        Err(e) => format!("error: {e}"),
                    },
                    Err(e) => format!("refused: {e}"),
                }
            };
            println!(
                "{scene:<13} {:<13} {n:>3} steps of {:.4e} s  cpu {cpu_line}  gpu {gpu_line}",
                integrator.name(),
                settings.dt_secs
            );
        }
    }
    Ok(())
}
