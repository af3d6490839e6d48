//! What the hard cases share (`tests/hard_cases.rs`, `tests/hard_limits.rs`): the backends they
//! run on, the stepping loop that hands each frame to their checks, and the chain of
//! alternating heavy and light masses.

use std::sync::Arc;

use glam::Vec3;
use hooke::backend::{Backend, BackendError};
use hooke::integrator::Step;
use hooke::model::{Effects, Model, ModelBuilder};
use hooke::run::select::BackendKind;
use hooke::state::Snapshot;

use super::{gpu_available, ok};

/// The CPU, and the GPU where an adapter exists (a missing one fails `gpu_available` when
/// HOOKE_REQUIRE_ADAPTER=1).
pub fn backends() -> Vec<BackendKind> {
    if gpu_available() {
        vec![BackendKind::Cpu, BackendKind::Gpu]
    } else {
        vec![BackendKind::Cpu]
    }
}

/// Where a run starts: its total energy, and the energy scale a tolerance is a share of (that
/// energy or the kinetic energy, whichever is larger, and at least 1 mJ).
pub struct Start {
    pub e0: f64,
    pub scale: f64,
}

/// A run of `step_frames`: its backend, the last frame it handed out (the start's snapshot,
/// frame 0, if none) and, where it stopped early, the frame it stopped at and why.
pub struct Stepped {
    pub backend: Box<dyn Backend>,
    pub last: Snapshot,
    pub failed: Option<(u32, BackendError)>,
}

/// `model` on `kind` with `step`, `frames` frames of `substeps` steps: each frame's snapshot
/// (numbered from 1, with its steps' figures: the GPU's solve figures come back with it) goes
/// to `each_frame` with the run's start. Stops at the first error, stepping or reading back.
pub fn step_frames(
    kind: BackendKind,
    model: Arc<Model>,
    step: Step,
    (frames, substeps): (u32, u32),
    each_frame: &mut dyn FnMut(&Start, &Snapshot),
) -> Stepped {
    let mut backend: Box<dyn Backend> = ok(hooke::run::select::create(kind, model, step, None));
    let first = ok(backend.snapshot(0, Default::default()));
    let e0 = first.energies.total_j();
    let start = Start {
        e0,
        scale: e0.abs().max(first.energies.kinetic_j).max(1e-3),
    };
    let mut last = first;
    for frame in 1..=frames {
        let stepped = backend
            .advance(substeps)
            .and_then(|stats| backend.snapshot(u64::from(frame), stats));
        match stepped {
            Ok(s) => {
                each_frame(&start, &s);
                last = s;
            }
            Err(e) => {
                return Stepped {
                    backend,
                    last,
                    failed: Some((frame, e)),
                };
            }
        }
    }
    Stepped {
        backend,
        last,
        failed: None,
    }
}

/// A chain of 12 masses 10 cm apart along x at a height of 2 m, pinned at the first, under
/// gravity: 1 kg and `light_kg` in turn (the pinned one 1 kg, the next light), joined by
/// springs of `stiffness_n_per_m` and `damping_n_s_per_m`.
pub fn alternating_chain(
    light_kg: f32,
    stiffness_n_per_m: f32,
    damping_n_s_per_m: f32,
) -> Arc<Model> {
    let mut mb = ModelBuilder::new();
    let mut prev = mb.mass(Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, 1.0, true);
    for i in 1..12 {
        let m = if i % 2 == 0 { 1.0 } else { light_kg };
        let next = mb.mass(Vec3::new(0.1 * i as f32, 2.0, 0.0), Vec3::ZERO, m, false);
        mb.spring(prev, next, stiffness_n_per_m, damping_n_s_per_m);
        prev = next;
    }
    mb.effects(Effects {
        gravity_m_per_s2: Some(Vec3::new(0.0, -9.81, 0.0)),
        ..Effects::default()
    });
    Arc::new(mb.build())
}
