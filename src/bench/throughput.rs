//! `hooke bench throughput`: how fast a backend steps a scene, headless and with no recording.

use std::fmt::Write as _;
use std::sync::Arc;
use std::time::Instant;

use crate::backend::{self, Backend as _};
use crate::error::Result;
use crate::integrator::Integrator;
use crate::model::Model;
use crate::prepare::{self, Prepared, Request, SceneSource};
use crate::select::{BackendKind, Device};
use crate::settings::{Overrides, Settings};

#[derive(Debug, Clone)]
pub struct ThroughputOptions {
    pub device: Device,
    /// The scene's own integrator when `None`.
    pub integrator: Option<Integrator>,
    pub steps: u32,
    /// Steps per submission on the GPU (the whole run is timed, so this is the batch size).
    pub batch: u32,
}

#[derive(Debug, Clone)]
pub struct Throughput {
    pub scene: String,
    pub backend: String,
    pub integrator: Integrator,
    pub masses: usize,
    pub springs: usize,
    pub steps: u32,
    pub wall_secs: f64,
    pub memory_bytes: Option<u64>,
    /// GPU time per step of each kernel (ms), where the adapter has timestamp queries.
    pub kernels_ms: Option<Vec<(String, f64)>>,
    /// Compulsory bytes a GPU step moves (see `GpuBackend::bytes_per_step`).
    pub bytes_per_step: Option<u64>,
}

impl Throughput {
    pub fn steps_per_sec(&self) -> f64 {
        f64::from(self.steps) / self.wall_secs
    }
    /// Springs × steps per second: each spring's force evaluated once per force evaluation of a step.
    pub fn spring_updates_per_sec(&self) -> f64 {
        self.springs as f64 * self.steps_per_sec()
    }
}

/// Step `scene` for `opts.steps` steps after a warm-up, timing the whole run.
pub fn throughput(scene_arg: &str, opts: &ThroughputOptions) -> Result<Throughput> {
    throughput_of(SceneSource::Named(scene_arg.to_owned()), opts)
}

pub(super) fn throughput_of(scene: SceneSource, opts: &ThroughputOptions) -> Result<Throughput> {
    let request = Request {
        scene,
        overrides: Overrides {
            integrator: opts.integrator,
            ..Overrides::default()
        },
        step: prepare::Step::AsGiven,
        device: opts.device.clone(),
    };
    // A benchmark has no one to tell about rounded steps or stability.
    let Prepared {
        loaded,
        settings,
        model,
        backend: mut be,
    } = prepare::prepare(&request, &mut |_| {})?;
    let batch = opts.batch.max(1);
    // Warm-up: pipelines compiled, caches and clocks up.
    be.advance(batch.min(opts.steps).max(1))?;
    be.finish()?;
    let start = Instant::now();
    backend::advance_steps(be.as_mut(), u64::from(opts.steps), batch)?;
    be.finish()?;
    let wall_secs = start.elapsed().as_secs_f64();
    // The final state must still be sound, or the figure means nothing.
    be.snapshot(0, Default::default())?;
    // Implicit Euler's passes per step vary with its iterations: no per-kernel profile.
    let (kernels_ms, bytes_per_step) = match opts.device.kind {
        BackendKind::Gpu if settings.integrator != Integrator::Implicit => {
            profile(&model, &settings, opts)?
        }
        _ => (None, None),
    };
    Ok(Throughput {
        scene: loaded.scene.name,
        backend: be.describe(),
        integrator: settings.integrator,
        masses: model.mass_count(),
        springs: model.spring_count(),
        steps: opts.steps,
        wall_secs,
        memory_bytes: be.memory_bytes(),
        kernels_ms,
        bytes_per_step,
    })
}

/// Per-kernel GPU times from a separate, profiled run (timestamps around every dispatch would
/// slow the timed run).
type Profile = (Option<Vec<(String, f64)>>, Option<u64>);

fn profile(model: &Arc<Model>, settings: &Settings, opts: &ThroughputOptions) -> Result<Profile> {
    let mut gpu = crate::gpu::GpuBackend::with_options(
        model.clone(),
        (settings.integrator, settings.dt_secs, settings.options),
        opts.device.adapter.as_deref(),
    )?;
    let steps = opts.steps.clamp(1, 20);
    // The first profiled steps include Verlet's priming evaluation; warm up first.
    gpu.advance(2)?;
    Ok((gpu.profile_kernels(steps)?, Some(gpu.bytes_per_step())))
}

pub fn format_throughput(t: &Throughput) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "{:<12} {:<14} {:>9} masses {:>9} springs  {:>10.1} steps/s  {:>9.3e} spring updates/s  ({} steps in {:.3} s on {})",
        t.scene,
        t.integrator.name(),
        t.masses,
        t.springs,
        t.steps_per_sec(),
        t.spring_updates_per_sec(),
        t.steps,
        t.wall_secs,
        t.backend
    );
    if let Some(m) = t.memory_bytes {
        let _ = write!(
            s,
            "\n    GPU memory for the simulation's buffers: {:.1} MiB",
            m as f64 / (1024.0 * 1024.0)
        );
    }
    if let Some(b) = t.bytes_per_step {
        let _ = write!(
            s,
            "\n    memory traffic: {:.2} MB per step (each buffer once per pass) -> {:.1} GB/s achieved",
            b as f64 / 1e6,
            b as f64 * t.steps_per_sec() / 1e9
        );
    }
    if let Some(k) = &t.kernels_ms {
        let total: f64 = k.iter().map(|(_, ms)| ms).sum();
        let _ = write!(
            s,
            "\n    GPU time per step (timestamp queries, each dispatch timed alone): {total:.4} ms"
        );
        for (name, ms) in k {
            let _ = write!(s, "\n      {name:<22} {ms:>9.4} ms");
        }
    }
    s
}
