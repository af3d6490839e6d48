//! What each of the CPU backend's step kernels is worth on one scene, measured in one process:
//! the general path (`compute_forces`, then the update) and the fused step with each of its
//! lanes (src/cpu/fused.rs), interleaved so that a noisy machine slows them alike.
//!
//! `cargo run --release --example cpu_kernels -- SCENE [STEPS] [ROUNDS] [ONLY]`
//!
//! SCENE is a built-in name or a file; STEPS per timing (default 200), ROUNDS of every kernel
//! (default 3); ONLY keeps the kernels whose name contains it (`avx2`). Prints each kernel's
//! best steps/s and spring updates/s. See BENCHMARKS.md.

use std::time::Instant;

use hooke::backend::{Backend, advance_steps};
use hooke::cpu::{CpuBackend, Simd};
use hooke::integrator::{Integrator, Step};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(scene) = args.first() else {
        anyhow::bail!(
            "usage: cpu_kernels SCENE [STEPS] [ROUNDS] [ONLY] (SCENE: a built-in name or a file)"
        );
    };
    let steps: u64 = args.get(1).map_or(Ok(200), |s| s.parse())?;
    let rounds: usize = args.get(2).map_or(Ok(3), |s| s.parse())?;
    let hooke::run::prepare::Planned {
        settings, model, ..
    } = hooke::run::prepare::planned(scene)?;
    let integrator = Integrator::SemiImplicit;
    let only = args.get(3).map_or("", String::as_str);
    let kernels: Vec<_> = [
        ("general", None),
        ("fused scalar", Some(Simd::Scalar)),
        ("fused portable", Some(Simd::Portable)),
        ("fused sse2", Some(Simd::Sse2)),
        ("fused avx2", Some(Simd::Avx2)),
    ]
    .into_iter()
    .filter(|(name, _)| name.contains(only))
    .collect();
    let mut best = vec![0.0f64; kernels.len()];
    for _ in 0..rounds {
        for (k, (_, kernel)) in kernels.iter().enumerate() {
            let mut be = CpuBackend::new(model.clone(), Step::new(integrator, settings.dt_secs));
            be.set_simd(*kernel);
            advance_steps(&mut be, 20, 20)?;
            let t = Instant::now();
            advance_steps(&mut be, steps, 100)?;
            be.finish()?;
            best[k] = best[k].max(steps as f64 / t.elapsed().as_secs_f64());
        }
    }
    let springs = model.spring_count() as f64;
    println!(
        "{scene}: {} masses, {} springs, {integrator:?}, {} threads",
        model.mass_count(),
        model.spring_count(),
        rayon::current_num_threads()
    );
    for ((name, kernel), s) in kernels.iter().zip(&best) {
        let runs = kernel.map_or(String::new(), |k| format!(" ({:?})", k.resolve()));
        println!(
            "  {name:<15} {s:>9.1} steps/s  {:.3e} spring updates/s{runs}",
            s * springs
        );
    }
    Ok(())
}
