//! `hooke bench throughput`: how fast a backend steps a scene, headless and with no recording;
//! timed `repeat` times for a median and a spread, printed as text or as one JSON object per
//! configuration (for scripts comparing runs).

use std::fmt::Write as _;
use std::sync::Arc;
use std::time::Instant;

use crate::backend::{self, Backend as _};
use crate::error::Result;
use crate::gpu::DispatchCount;
use crate::integrator::Integrator;
use crate::model::Model;
use crate::run::prepare::{self, Prepared, Request, SceneSource};
use crate::run::select::{BackendKind, Device};
use crate::scene::settings::{Overrides, Settings};

#[derive(Debug, Clone)]
pub struct ThroughputOptions {
    pub device: Device,
    /// The scene's own integrator when `None`.
    pub integrator: Option<Integrator>,
    pub steps: u32,
    /// Steps per submission on the GPU (the whole run is timed, so this is the batch size).
    pub batch: u32,
    /// Timed runs of `steps` steps each, after one warm-up.
    pub repeat: u32,
    /// Implicit Euler's and BDF2's CG preconditioner; the scene's, else its size's, when `None`.
    pub preconditioner: Option<crate::integrator::Preconditioner>,
}

#[derive(Debug, Clone)]
pub struct Throughput {
    pub scene: String,
    pub backend: String,
    pub integrator: Integrator,
    pub masses: usize,
    pub springs: usize,
    pub steps: u32,
    pub batch: u32,
    /// The wall time of each timed run, in run order.
    pub runs_secs: Vec<f64>,
    /// Their median.
    pub wall_secs: f64,
    pub memory_bytes: Option<u64>,
    /// GPU: the dispatches of one step, as its plan records them.
    pub dispatches: Option<DispatchCount>,
    /// GPU time per step of each kernel (ms), where the adapter has timestamp queries.
    pub kernels_ms: Option<Vec<(String, f64)>>,
    /// Compulsory bytes a GPU step moves (see `GpuBackend::bytes_per_step`).
    pub bytes_per_step: Option<u64>,
    /// Where the backend may run a submission again (implicit Euler on the GPU's per-pass path):
    /// the timed runs' submissions, and how many of them were replayed.
    pub replays: Option<(u64, u64)>,
    /// Where the run ended: simulated time (s) and the masses' mean position (m), so that a
    /// fast figure can be checked against a reference run of the same span (the peers print
    /// their cloth's mean height for the same reason).
    pub end_time_secs: f64,
    pub end_mean_position_m: [f64; 3],
    /// Mass–mass contact: how many times the neighbour lists were built during the timed runs
    /// (each a full build: how often depends on how the masses move, so one scene's steps/s
    /// moves with its trajectory).
    pub neighbour_builds: Option<u64>,
    /// What preconditioned implicit Euler's or BDF2's CG (`None` for the other integrators).
    pub preconditioner: Option<crate::integrator::Preconditioner>,
}

impl Throughput {
    /// At the median run's time.
    pub fn steps_per_sec(&self) -> f64 {
        f64::from(self.steps) / self.wall_secs
    }
    /// The slowest and the fastest run's steps/s.
    pub fn steps_per_sec_spread(&self) -> (f64, f64) {
        let per_sec = |secs: f64| f64::from(self.steps) / secs;
        let slowest = self.runs_secs.iter().copied().fold(0.0, f64::max);
        let fastest = self.runs_secs.iter().copied().fold(f64::INFINITY, f64::min);
        (per_sec(slowest), per_sec(fastest))
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
            preconditioner: opts.preconditioner,
            ..Overrides::default()
        },
        dt: prepare::DtChoice::AsGiven,
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
    let replays_before = be.replays();
    let builds_before = be.neighbour_builds()?;
    let mut runs_secs = Vec::with_capacity(opts.repeat.max(1) as usize);
    for _ in 0..opts.repeat.max(1) {
        let start = Instant::now();
        backend::advance_steps(be.as_mut(), u64::from(opts.steps), batch)?;
        be.finish()?;
        runs_secs.push(start.elapsed().as_secs_f64());
    }
    let wall_secs = median(&runs_secs);
    let submissions = u64::from(opts.repeat.max(1)) * u64::from(opts.steps.div_ceil(batch));
    let replays = replays_before
        .zip(be.replays())
        .map(|(before, after)| (submissions, after - before));
    let neighbour_builds = builds_before
        .zip(be.neighbour_builds()?)
        .map(|(before, after)| after - before);
    // The final state must still be sound, or the figure means nothing.
    let end = be.snapshot(0, Default::default())?;
    let mut sum = [0.0f64; 3];
    for p in &end.positions {
        for (s, c) in sum.iter_mut().zip(p.to_array()) {
            *s += f64::from(c);
        }
    }
    let count = end.positions.len().max(1) as f64;
    let end_mean_position_m = sum.map(|s| s / count);
    let (kernels_ms, bytes_per_step, dispatches) = match opts.device.kind {
        BackendKind::Gpu => profile(&model, &settings, opts)?,
        _ => (None, None, None),
    };
    Ok(Throughput {
        scene: loaded.scene.name,
        backend: be.describe(),
        integrator: settings.integrator,
        masses: model.mass_count(),
        springs: model.spring_count(),
        steps: opts.steps,
        batch,
        runs_secs,
        wall_secs,
        memory_bytes: be.memory_bytes(),
        dispatches,
        kernels_ms,
        bytes_per_step,
        replays,
        end_time_secs: end.time_secs,
        end_mean_position_m,
        neighbour_builds,
        preconditioner: settings
            .integrator
            .newton()
            .then(|| crate::physics::preconditioner_of(&model, settings.step())),
    })
}

/// The median of `xs` (the mean of the middle two of an even count); 0 for none.
fn median(xs: &[f64]) -> f64 {
    let mut sorted = xs.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    match n {
        0 => 0.0,
        _ if n % 2 == 1 => sorted[n / 2],
        _ => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
    }
}

/// Per-kernel GPU times from a separate, profiled run (timestamps around every dispatch would
/// slow the timed run), the step's memory traffic, and its dispatches on the path the run took.
type Profile = (
    Option<Vec<(String, f64)>>,
    Option<u64>,
    Option<DispatchCount>,
);

fn profile(model: &Arc<Model>, settings: &Settings, opts: &ThroughputOptions) -> Result<Profile> {
    let mut gpu = crate::gpu::GpuBackend::new(
        model.clone(),
        settings.step(),
        opts.device.adapter.as_deref(),
    )?;
    let dispatches = crate::gpu::dispatches_per_step(model, settings.step(), gpu.step_paths());
    // Implicit Euler's passes per step vary with its iterations: no per-kernel profile.
    if settings.integrator.newton() {
        return Ok((None, None, Some(dispatches)));
    }
    let steps = opts.steps.clamp(1, 20);
    // The first profiled steps include Verlet's priming evaluation; warm up first.
    gpu.advance(2)?;
    Ok((
        gpu.profile_kernels(steps)?,
        Some(gpu.bytes_per_step()),
        Some(dispatches),
    ))
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
    if let Some(p) = t.preconditioner {
        let _ = write!(s, "\n    CG preconditioner: {}", p.name());
    }
    if t.runs_secs.len() > 1 {
        let (slow, fast) = t.steps_per_sec_spread();
        let _ = write!(
            s,
            "\n    median of {} runs; spread {slow:.1} to {fast:.1} steps/s",
            t.runs_secs.len()
        );
    }
    if let Some(d) = t.dispatches {
        let _ = write!(
            s,
            "\n    dispatches per step: {}",
            format_dispatches(d, t.batch)
        );
    }
    if let Some((submissions, replayed)) = t.replays {
        let _ = write!(
            s,
            "\n    submissions replayed (a step or solve outran its budget): {replayed} of {submissions}"
        );
    }
    if let Some(b) = t.neighbour_builds {
        let steps = u64::from(t.steps) * t.runs_secs.len() as u64;
        let _ = write!(
            s,
            "\n    neighbour lists built {b} times in the {steps} timed steps"
        );
    }
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

/// "1 (fused step)", "4", "1 per submission of 100 steps (fused, in one workgroup)", or for
/// implicit Euler a dispatch per pass "4 + 6 per Newton iteration + 2 per CG iteration".
fn format_dispatches(d: DispatchCount, batch: u32) -> String {
    let mut s = d.fixed.to_string();
    if d.in_group {
        let _ = write!(
            s,
            " per submission of {batch} steps (fused, in one workgroup)"
        );
    } else if d.fused {
        s.push_str(" (fused step)");
    }
    if d.per_newton_iteration > 0 {
        let _ = write!(s, " + {} per Newton iteration", d.per_newton_iteration);
    }
    if d.per_cg_iteration > 0 {
        let _ = write!(s, " + {} per CG iteration", d.per_cg_iteration);
    }
    s
}

/// One configuration's figures as a JSON object on one line: what was run and on what, every
/// run's time, the median and spread of steps/s and spring updates/s, and the GPU's dispatches,
/// memory, traffic and kernel times where measured.
pub fn throughput_json(t: &Throughput) -> String {
    let (slow, fast) = t.steps_per_sec_spread();
    let springs = t.springs as f64;
    let value = serde_json::json!({
        "scene": t.scene,
        "backend": t.backend,
        "integrator": t.integrator.name(),
        "masses": t.masses,
        "springs": t.springs,
        "steps": t.steps,
        "batch": t.batch,
        "repeat": t.runs_secs.len(),
        "runs_secs": t.runs_secs,
        "steps_per_sec": {"median": t.steps_per_sec(), "min": slow, "max": fast},
        "spring_updates_per_sec": {
            "median": t.spring_updates_per_sec(),
            "min": springs * slow,
            "max": springs * fast,
        },
        "dispatches_per_step": t.dispatches.map(|d| serde_json::json!({
            "fused": d.fused,
            "in_group": d.in_group,
            "fixed": d.fixed,
            "per_newton_iteration": d.per_newton_iteration,
            "per_cg_iteration": d.per_cg_iteration,
        })),
        "memory_bytes": t.memory_bytes,
        "bytes_per_step": t.bytes_per_step,
        "replays": t.replays.map(|(submissions, replayed)| serde_json::json!({
            "submissions": submissions,
            "replayed": replayed,
        })),
        "neighbour_builds": t.neighbour_builds,
        "preconditioner": t.preconditioner.map(|p| p.name()),
        "end_time_secs": t.end_time_secs,
        "end_mean_position_m": t.end_mean_position_m,
        "kernels_ms": t.kernels_ms.as_ref().map(|k| {
            k.iter()
                .map(|(name, ms)| (name.clone(), serde_json::json!(ms)))
                .collect::<serde_json::Map<_, _>>()
        }),
    });
    value.to_string()
}
