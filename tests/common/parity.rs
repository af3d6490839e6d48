//! GPU–CPU parity: both backends stepped alike from one model, frame by frame, and the
//! tolerance their states must meet (`tests/gpu.rs`, `tests/gpu_implicit.rs`, `tests/vbd.rs`,
//! `tests/self_collision.rs`).

use std::sync::Arc;

use hooke::backend::Backend;
use hooke::cpu::CpuBackend;
use hooke::gpu::GpuBackend;
use hooke::integrator::{Integrator, Step, StepOptions};
use hooke::model::Model;
use hooke::state::{Snapshot, State, StepStats};

use super::ok;

/// Each integrator at the scene's dt, or at half its estimated stable dt where that is smaller
/// (explicit Euler and RK2 need far smaller steps than the scenes use).
pub fn parity_dt(model: &Model, scene_dt: f64, integrator: Integrator) -> f64 {
    let limit = hooke::stability::stable_dts(model)
        .into_iter()
        .find(|(i, _)| *i == integrator)
        .and_then(|l| l.1);
    match limit {
        Some(l) => scene_dt.min(0.5 * l),
        None => scene_dt / 20.0,
    }
}

pub fn run_both(
    model: &Arc<Model>,
    integrator: Integrator,
    dt: f64,
    frames: u32,
    substeps: u32,
) -> (State, State, f64) {
    run_both_with(
        model,
        integrator,
        dt,
        (frames, substeps),
        StepOptions::default(),
    )
}

pub fn run_both_with(
    model: &Arc<Model>,
    integrator: Integrator,
    dt: f64,
    (frames, substeps): (u32, u32),
    options: StepOptions,
) -> (State, State, f64) {
    let (mut cpu, mut gpu) = cpu_and_gpu(model, Step::new(integrator, dt).with_options(options));
    let (worst, _, _) = run_pair((&mut cpu, &mut gpu), (frames, substeps), &mut |_, _| {});
    (ok(cpu.state()), ok(gpu.state()), worst)
}

/// The CPU reference and the GPU (the first adapter), both on `model` stepping with `step`.
pub fn cpu_and_gpu(model: &Arc<Model>, step: Step) -> (CpuBackend, GpuBackend) {
    let cpu = CpuBackend::new(model.clone(), step);
    let gpu = ok(GpuBackend::new(model.clone(), step, None));
    (cpu, gpu)
}

/// Two backends stepped alike, `frames` frames of `substeps` steps, `a` first: after each
/// frame (numbered from 1) `each` gets both, with what their steps returned, to read back and
/// compare what it needs.
pub fn step_alike<A: Backend + ?Sized, B: Backend + ?Sized>(
    (a, b): (&mut A, &mut B),
    (frames, substeps): (u64, u32),
    mut each: impl FnMut(u64, (&mut A, StepStats), (&mut B, StepStats)),
) {
    for frame in 1..=frames {
        let stats_a = ok(a.advance(substeps));
        let stats_b = ok(b.advance(substeps));
        each(frame, (&mut *a, stats_a), (&mut *b, stats_b));
    }
}

/// Two backends stepped alike (`step_alike`), each read back at every frame (snapshots
/// numbered from 0) and handed to `each`: the largest position difference over the frames,
/// and each backend's last snapshot.
pub fn run_pair<A: Backend + ?Sized, B: Backend + ?Sized>(
    (a, b): (&mut A, &mut B),
    (frames, substeps): (u32, u32),
    each: &mut dyn FnMut(&Snapshot, &Snapshot),
) -> (f64, Snapshot, Snapshot) {
    let mut worst = 0.0f64;
    let mut last = None;
    step_alike(
        (a, b),
        (u64::from(frames), substeps),
        |frame, (a, _), (b, _)| {
            let (c, g) = (
                ok(a.snapshot(frame - 1, Default::default())),
                ok(b.snapshot(frame - 1, Default::default())),
            );
            for (p, q) in c.positions.iter().zip(&g.positions) {
                worst = worst.max(f64::from(p.distance(*q)));
            }
            each(&c, &g);
            last = Some((c, g));
        },
    );
    let (c, g) = last.unwrap_or_else(|| panic!("no frames"));
    (worst, c, g)
}

/// Whether the GPU adapter the tests get rounds as the CPU does: Mesa's lavapipe (Vulkan on the
/// CPU) evaluates the same f32 operations in the same order, bit for bit. A GPU's driver fuses
/// multiply-adds and rounds otherwise (NVIDIA's on an H100: BENCHMARKS.md, "A real driver's
/// rounding"), so a chaotic scene or a property that holds only by luck of rounding parts there.
pub fn gpu_rounds_as_the_cpu() -> bool {
    hooke::gpu::adapters().first().is_some_and(|a| {
        let info = a.get_info();
        info.backend == wgpu::Backend::Vulkan && info.device_type == wgpu::DeviceType::Cpu
    })
}

/// `model` with each movable mass's start moved by at most one f32 step per coordinate, in a
/// pattern `seed` picks (seed 0: unmoved): the CPU reference under another rounding, as a GPU
/// that fuses multiply-adds rounds. What a test claims of a chaotic scene or a fragile solve,
/// it checks on these starts too, so that the claim is not the luck of one rounding.
pub fn nudged(model: &Model, seed: u64) -> Arc<Model> {
    let mut m = model.clone();
    if seed > 0 {
        let step = |v: f32, pick: u64| match pick % 3 {
            0 => v,
            1 => v.next_up(),
            _ => v.next_down(),
        };
        for (i, x) in m.initial.x.iter_mut().enumerate() {
            if model.inv_mass[i] == 0.0 {
                continue;
            }
            let h = (i as u64 + 1)
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .wrapping_add(seed.wrapping_mul(0xD1B5_4A32_D192_ED03));
            *x = glam::Vec3::new(step(x.x, h >> 7), step(x.y, h >> 17), step(x.z, h >> 27));
        }
    }
    Arc::new(m)
}

/// Stated tolerance. Mesa lavapipe reproduces the CPU bit for bit (both evaluate the same f32
/// operations in the same order); a GPU that fuses multiply-adds differs by rounding, which this
/// allows for over a few hundred steps.
pub const PARITY_X_M: f64 = 1e-5;
pub const PARITY_V_M_PER_S: f64 = 1e-3;

pub fn assert_parity(what: &str, c: &State, g: &State, worst_x: f64) {
    let worst_v =
        c.v.iter()
            .zip(&g.v)
            .map(|(a, b)| f64::from(a.distance(*b)))
            .fold(0.0, f64::max);
    assert!(
        worst_x <= PARITY_X_M,
        "{what}: GPU positions differ from the CPU by {worst_x:.3e} m"
    );
    assert!(
        worst_v <= PARITY_V_M_PER_S,
        "{what}: GPU velocities differ from the CPU by {worst_v:.3e} m/s"
    );
    // Ledgers: per-mass f32 on the GPU, per-chunk f64 on the CPU.
    let (lc, lg) = (c.ledger.dissipated_j(), g.ledger.dissipated_j());
    assert!(
        (lc - lg).abs() <= 1e-4 * lc.abs().max(1e-3),
        "{what}: dissipated {lc} J on CPU, {lg} J on GPU"
    );
    let (wc, wg) = (c.ledger.collider_work_j, g.ledger.collider_work_j);
    assert!(
        (wc - wg).abs() <= 1e-4 * wc.abs().max(1e-3),
        "{what}: collider work {wc} J on CPU, {wg} J on GPU"
    );
    println!(
        "{what}: |Δx| {worst_x:.2e} m, |Δv| {worst_v:.2e} m/s{}",
        if worst_x == 0.0 && worst_v == 0.0 {
            " (bit-identical)"
        } else {
            ""
        }
    );
}
