//! `hooke bench throughput`: how fast a backend steps a scene, headless and with no recording.

use std::fmt::Write as _;
use std::sync::Arc;
use std::time::Instant;

use crate::backend;
use crate::error::{RerunError, Result};
use crate::integrator::Integrator;
use crate::model;
use crate::scene;
use crate::select::{self, BackendKind};
use crate::settings::{Overrides, Settings};

#[derive(Debug, Clone)]
pub struct ThroughputOptions {
    pub backend: BackendKind,
    pub adapter: Option<String>,
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
    throughput_of(&scene::load(scene_arg)?.scene, opts)
}

fn throughput_of(scene: &scene::Scene, opts: &ThroughputOptions) -> Result<Throughput> {
    let settings = Settings::resolve(
        scene,
        &Overrides {
            integrator: opts.integrator,
            ..Overrides::default()
        },
    )?;
    let model = Arc::new(model::build(scene));
    let mut be = select::create(
        opts.backend,
        model.clone(),
        settings.integrator,
        settings.dt_secs,
        opts.adapter.as_deref(),
    )?;
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
    let (kernels_ms, bytes_per_step) = match opts.backend {
        BackendKind::Gpu if settings.integrator != crate::integrator::Integrator::Implicit => {
            profile(&model, &settings, opts)?
        }
        _ => (None, None),
    };
    Ok(Throughput {
        scene: scene.name.clone(),
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

/// What each effect of a scene costs: the scene as it is, then once without each effect it has.
pub struct EffectCosts {
    pub all: Throughput,
    /// (effect, the scene without it).
    pub without: Vec<(&'static str, Throughput)>,
}

/// The effects a scene has, each with the scene less that effect.
fn effect_variants(s: &scene::Scene) -> Vec<(&'static str, scene::Scene)> {
    let mut out = Vec::new();
    let mut variant = |name: &'static str, has: bool, drop: &dyn Fn(&mut scene::Scene)| {
        if has {
            let mut v = s.clone();
            drop(&mut v);
            out.push((name, v));
        }
    };
    let e = &s.effects;
    variant("gravity", e.gravity_m_per_s2.is_some(), &|v| {
        v.effects.gravity_m_per_s2 = None
    });
    variant("air drag", e.air_drag_per_s.is_some(), &|v| {
        v.effects.air_drag_per_s = None
    });
    variant("ground", e.ground.is_some(), &|v| v.effects.ground = None);
    variant("spheres", !e.spheres.is_empty(), &|v| {
        v.effects.spheres.clear()
    });
    variant("boxes", !e.boxes.is_empty(), &|v| v.effects.boxes.clear());
    variant("planes", !e.planes.is_empty(), &|v| {
        v.effects.planes.clear()
    });
    variant("self-collision", e.self_collision.is_some(), &|v| {
        v.effects.self_collision = None
    });
    let bodies = |f: fn(&scene::Body) -> bool| s.bodies.iter().any(f);
    variant("plasticity", bodies(|b| b.plasticity.is_some()), &|v| {
        v.bodies.iter_mut().for_each(|b| b.plasticity = None)
    });
    variant("tearing", bodies(|b| b.tearing.is_some()), &|v| {
        v.bodies.iter_mut().for_each(|b| b.tearing = None)
    });
    variant(
        "spring damping",
        bodies(|b| {
            [b.springs.structural, b.springs.shear, b.springs.bending]
                .iter()
                .flatten()
                .any(|k| k.damping_n_s_per_m != 0.0)
        }),
        &|v| {
            for b in &mut v.bodies {
                for k in [
                    &mut b.springs.structural,
                    &mut b.springs.shear,
                    &mut b.springs.bending,
                ]
                .into_iter()
                .flatten()
                {
                    k.damping_n_s_per_m = 0.0;
                }
            }
        },
    );
    out
}

/// Time the scene with all its effects and without each in turn (`hooke bench throughput
/// --effects`). Removing an effect can change the motion too (no gravity, no falling), so the
/// difference is the cost of the effect's passes and terms on this scene, not a universal price.
pub fn effect_costs(scene_arg: &str, opts: &ThroughputOptions) -> Result<EffectCosts> {
    let scene = scene::load(scene_arg)?.scene;
    // Differences of a few percent drown in run-to-run noise: each configuration runs
    // `EFFECT_REPEATS` times, interleaved, and keeps its fastest run.
    let variants = effect_variants(&scene);
    let mut all = throughput_of(&scene, opts)?;
    let mut without = variants
        .iter()
        .map(|(name, v)| Ok((*name, throughput_of(v, opts)?)))
        .collect::<Result<Vec<_>>>()?;
    let faster = |best: &mut Throughput, t: Throughput| {
        if t.wall_secs < best.wall_secs {
            *best = t;
        }
    };
    for _ in 1..EFFECT_REPEATS {
        faster(&mut all, throughput_of(&scene, opts)?);
        for ((_, best), (_, v)) in without.iter_mut().zip(&variants) {
            faster(best, throughput_of(v, opts)?);
        }
    }
    Ok(EffectCosts { all, without })
}

/// Runs of each configuration in `effect_costs`; the fastest counts.
const EFFECT_REPEATS: usize = 3;

pub fn format_effect_costs(c: &EffectCosts) -> String {
    let ms = |t: &Throughput| 1e3 / t.steps_per_sec();
    let all = ms(&c.all);
    let mut s = format!(
        "{}: {} masses, {} springs, {} on {}: {all:.4} ms per step with all its effects",
        c.all.scene,
        c.all.masses,
        c.all.springs,
        c.all.integrator.name(),
        c.all.backend
    );
    for (name, t) in &c.without {
        let without = ms(t);
        let _ = write!(
            s,
            "
  without {name:<15} {without:>9.4} ms per step: {name} costs {:>8.4} ms ({:>5.1}%)",
            all - without,
            100.0 * (all - without) / all
        );
    }
    s
}

/// Per-kernel GPU times from a separate, profiled run (timestamps around every dispatch would
/// slow the timed run).
type Profile = (Option<Vec<(String, f64)>>, Option<u64>);

fn profile(
    model: &Arc<model::Model>,
    settings: &Settings,
    opts: &ThroughputOptions,
) -> Result<Profile> {
    let mut gpu = crate::gpu::GpuBackend::new(
        model.clone(),
        settings.integrator,
        settings.dt_secs,
        opts.adapter.as_deref(),
    )?;
    let steps = opts.steps.clamp(1, 20);
    // The first profiled steps include Verlet's priming evaluation; warm up first.
    crate::backend::Backend::advance(&mut gpu, 2)?;
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

/// Resident memory of this process (Linux: /proc/self/statm), in bytes.
pub fn resident_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096)
}

#[derive(Debug, Clone)]
pub struct Soak {
    pub scene: String,
    pub backend: String,
    pub sim_secs: f64,
    pub frames: u64,
    pub wall_secs: f64,
    /// (wall seconds, resident bytes), sampled through the run.
    pub samples: Vec<(f64, u64)>,
}

impl Soak {
    /// Resident memory growth from the end of warm-up (the first tenth of the run) to the peak.
    pub fn growth_after_warmup_bytes(&self) -> i64 {
        let warm = self.wall_secs * 0.1;
        let after: Vec<u64> = self
            .samples
            .iter()
            .filter(|(t, _)| *t >= warm)
            .map(|(_, b)| *b)
            .collect();
        match (after.first(), after.iter().max()) {
            (Some(first), Some(peak)) => *peak as i64 - *first as i64,
            _ => 0,
        }
    }
}

/// Run `scene` for `duration_secs` of simulated time through the whole pipeline (simulation
/// thread, recorder thread, an .rrd file) while a sampler records resident memory.
pub fn soak(
    scene_arg: &str,
    backend_kind: BackendKind,
    adapter: Option<&str>,
    duration_secs: f64,
    rrd: &std::path::Path,
    footer: bool,
) -> Result<Soak> {
    use std::sync::atomic::{AtomicBool, Ordering};
    let loaded = scene::load(scene_arg)?;
    let settings = Settings::resolve(
        &loaded.scene,
        &Overrides {
            duration_secs: Some(duration_secs),
            ..Overrides::default()
        },
    )?;
    let model = Arc::new(model::build(&loaded.scene));
    let be = select::create(
        backend_kind,
        model.clone(),
        settings.integrator,
        settings.dt_secs,
        adapter,
    )?;
    let name = be.describe();
    let rec = rerun::RecordingStreamBuilder::new("hooke-soak")
        .buffered()
        .map_err(|e| crate::Error::rerun_while("starting the recording", e))?;
    let (sink, file) = crate::rrd_file::create(rrd, footer)?;
    rec.set_sink(Box::new(sink));
    let done = Arc::new(AtomicBool::new(false));
    let start = Instant::now();
    let sampler = {
        let done = done.clone();
        std::thread::spawn(move || {
            let mut samples = Vec::new();
            while !done.load(Ordering::Relaxed) {
                if let Some(b) = resident_bytes() {
                    samples.push((start.elapsed().as_secs_f64(), b));
                }
                std::thread::sleep(std::time::Duration::from_millis(250));
            }
            samples
        })
    };
    let opts = crate::run::RunOptions {
        delivery: crate::sim::Delivery::Lossless,
        progress: crate::progress::ProgressMode::Off,
        realtime: false,
        record: crate::record::RecordOptions::default(),
        viewer: None,
        file: Some(file),
    };
    let summary = crate::run::run(
        &loaded,
        model,
        be,
        &settings,
        rec,
        &opts,
        Arc::new(AtomicBool::new(false)),
    );
    done.store(true, Ordering::Relaxed);
    let samples = sampler.join().unwrap_or_default();
    let summary = summary?;
    Ok(Soak {
        scene: loaded.scene.name,
        backend: name,
        sim_secs: summary.sim_time_secs,
        frames: summary.frames_recorded,
        wall_secs: start.elapsed().as_secs_f64(),
        samples,
    })
}

pub fn format_soak(s: &Soak) -> String {
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    let mut out = format!(
        "{}: {:.0} s simulated, {} frames recorded in {:.1} s wall on {}\nresident memory (MiB) at each tenth of the run:",
        s.scene, s.sim_secs, s.frames, s.wall_secs, s.backend
    );
    for k in 0..=10 {
        let t = s.wall_secs * f64::from(k) / 10.0;
        if let Some((_, b)) = s
            .samples
            .iter()
            .rev()
            .find(|(ts, _)| *ts <= t)
            .or(s.samples.first())
        {
            let _ = write!(out, " {:.1}", mib(*b));
        }
    }
    let _ = write!(
        out,
        "\ngrowth after warm-up (first tenth) to the peak: {:.2} MiB",
        s.growth_after_warmup_bytes() as f64 / (1024.0 * 1024.0)
    );
    out
}

/// `hooke bench record`: what to record, and how many frames.
#[derive(Debug, Clone)]
pub struct RecordBenchOptions {
    pub frames: u64,
    pub record: crate::record::RecordOptions,
    /// The .rrd file the file pass writes.
    pub save: std::path::PathBuf,
}

/// One pass of the recorder over the bench's frames into one sink.
#[derive(Debug, Clone)]
pub struct RecordPass {
    pub sink: &'static str,
    pub frames: u64,
    pub wall_secs: f64,
    /// Peak resident memory of the process (VmHWM) at the end of the pass.
    pub peak_rss_bytes: Option<u64>,
}

impl RecordPass {
    pub fn frames_per_sec(&self) -> f64 {
        self.frames as f64 / self.wall_secs
    }
}

#[derive(Debug, Clone)]
pub struct RecordBench {
    pub scene: String,
    pub masses: usize,
    pub springs: usize,
    pub frames: u64,
    /// What each body logs.
    pub bodies: Vec<String>,
    pub passes: Vec<RecordPass>,
    /// Bytes of the .rrd file per frame (compressed as written, static data and footer included).
    pub file_bytes_per_frame: f64,
    /// Per entity: Arrow bytes per frame before compression, over the frames measured.
    pub entity_bytes_per_frame: Vec<(String, f64)>,
    /// Arrow bytes logged once, before the first frame.
    pub static_bytes: u64,
}

/// A sink that drops everything: what the recorder costs without any encoding or I/O.
struct Discard;

impl rerun::sink::LogSink for Discard {
    fn send(&self, _msg: rerun::log::LogMsg) {}
    fn flush_blocking(
        &self,
        _timeout: std::time::Duration,
    ) -> std::result::Result<(), rerun::sink::SinkFlushError> {
        Ok(())
    }
}

/// Peak resident memory of this process (Linux: VmHWM in /proc/self/status), in bytes.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Distinct frames to cycle through: the scene's initial state with a travelling wave added
/// (a tenth of the smallest spring's rest length), so that positions and strains change every
/// frame as in a run, and compression sees no repeats.
fn bench_frames(
    model: &model::Model,
    frame_rate_hz: f64,
    count: usize,
) -> Vec<crate::state::Snapshot> {
    let spacing = model
        .springs
        .iter()
        .map(|s| s.rest_m)
        .fold(f32::INFINITY, f32::min);
    let amplitude = if spacing.is_finite() {
        0.1 * spacing
    } else {
        0.01
    };
    (0..count)
        .map(|k| {
            let phase = k as f32 * 0.7;
            let positions: Vec<glam::Vec3> = model
                .initial
                .x
                .iter()
                .enumerate()
                .map(|(i, x)| {
                    let w = (x.x * 7.0 + x.z * 5.0 + phase).sin() + 0.3 * ((i % 7) as f32);
                    *x + glam::Vec3::new(0.3 * w, w, -0.2 * w) * amplitude
                })
                .collect();
            let strain = model
                .springs
                .iter()
                .map(|s| {
                    let len = positions[s.a as usize].distance(positions[s.b as usize]);
                    (len - s.rest_m) / s.rest_m
                })
                .collect();
            crate::state::Snapshot {
                frame: k as u64,
                time_secs: k as f64 / frame_rate_hz,
                steps: k as u64,
                positions,
                strain,
                energies: Default::default(),
                stats: Default::default(),
                collider_positions: crate::model::poses_at(&model.effects.colliders, 0.0)
                    .iter()
                    .map(|p| p.position_m)
                    .collect(),
            }
        })
        .collect()
}

/// Frames in the cycle `bench_frames` makes.
const BENCH_DISTINCT_FRAMES: usize = 8;

/// Frames measured per entity (into memory, which holds them all).
const BENCH_ENTITY_FRAMES: u64 = 10;

/// Run the recorder alone on frames made without stepping: into a discarding sink, into an .rrd
/// file, and (a few frames) into memory to weigh each entity.
pub fn record(scene_arg: &str, opts: &RecordBenchOptions) -> Result<RecordBench> {
    let loaded = scene::load(scene_arg)?;
    let settings = Settings::resolve(
        &loaded.scene,
        &Overrides {
            frames: Some(opts.frames.max(1)),
            ..Overrides::default()
        },
    )?;
    let model = Arc::new(model::build(&loaded.scene));
    let frames = bench_frames(&model, settings.frame_rate_hz, BENCH_DISTINCT_FRAMES);
    let new_recorder = |rec: &rerun::RecordingStream| -> Result<crate::record::Recorder> {
        let mut r = crate::record::Recorder::new(
            rec.clone(),
            model.clone(),
            loaded.scene.view.strain_range,
            opts.record,
        );
        r.log_static(
            &loaded.scene.name,
            &loaded.text,
            &settings,
            "bench (no stepping)",
        )
        .map_err(RerunError::from)?;
        Ok(r)
    };
    let run_frames = |r: &mut crate::record::Recorder, n: u64| -> Result<()> {
        for k in 0..n {
            let mut snap = frames[(k % frames.len() as u64) as usize].clone();
            snap.frame = k;
            snap.time_secs = k as f64 / settings.frame_rate_hz;
            r.log_snapshot(&snap).map_err(RerunError::from)?;
        }
        Ok(())
    };
    let builder = || rerun::RecordingStreamBuilder::new("hooke-bench-record");
    let mut passes = Vec::new();

    // Into a sink that discards: the recorder and Rerun's batcher only.
    let rec = builder().buffered().map_err(RerunError::from)?;
    rec.set_sink(Box::new(Discard));
    let mut r = new_recorder(&rec)?;
    let start = Instant::now();
    run_frames(&mut r, opts.frames)?;
    rec.flush_blocking().map_err(RerunError::from)?;
    passes.push(RecordPass {
        sink: "discard",
        frames: opts.frames,
        wall_secs: start.elapsed().as_secs_f64(),
        peak_rss_bytes: peak_resident_bytes(),
    });
    drop((r, rec));

    // Into an .rrd file: encoding, compression and writing too.
    let rec = builder().buffered().map_err(RerunError::from)?;
    let (sink, file) = crate::rrd_file::create(&opts.save, true)?;
    rec.set_sink(Box::new(sink));
    let mut r = new_recorder(&rec)?;
    let start = Instant::now();
    run_frames(&mut r, opts.frames)?;
    rec.flush_blocking().map_err(RerunError::from)?;
    file.finish().map_err(crate::Error::WriteRecording)?;
    passes.push(RecordPass {
        sink: "file",
        frames: opts.frames,
        wall_secs: start.elapsed().as_secs_f64(),
        peak_rss_bytes: peak_resident_bytes(),
    });
    drop((r, rec));
    let file_bytes = std::fs::metadata(&opts.save)
        .map(|m| m.len())
        .map_err(|source| crate::Error::ReadRecording {
            path: opts.save.clone(),
            source,
        })?;

    // Into memory, to weigh each entity.
    let (rec, storage) = builder().memory().map_err(RerunError::from)?;
    let mut r = new_recorder(&rec)?;
    rec.flush_blocking().map_err(RerunError::from)?;
    let static_bytes: u64 = arrow_bytes_by_entity(storage.take()).values().sum();
    let n = BENCH_ENTITY_FRAMES.min(opts.frames);
    run_frames(&mut r, n)?;
    rec.flush_blocking().map_err(RerunError::from)?;
    let mut entity_bytes_per_frame: Vec<(String, f64)> = arrow_bytes_by_entity(storage.take())
        .into_iter()
        .map(|(e, b)| (e, b as f64 / n as f64))
        .collect();
    entity_bytes_per_frame.sort_by(|a, b| b.1.total_cmp(&a.1));
    Ok(RecordBench {
        scene: loaded.scene.name.clone(),
        masses: model.mass_count(),
        springs: model.spring_count(),
        frames: opts.frames,
        bodies: crate::record::describe(&model, &opts.record),
        passes,
        file_bytes_per_frame: file_bytes as f64 / opts.frames as f64,
        entity_bytes_per_frame,
        static_bytes,
    })
}

/// Arrow bytes (in memory, before compression) of the chunks of each entity in `msgs`.
fn arrow_bytes_by_entity(msgs: Vec<rerun::log::LogMsg>) -> std::collections::BTreeMap<String, u64> {
    let mut out = std::collections::BTreeMap::new();
    for msg in msgs {
        let rerun::log::LogMsg::ArrowMsg(_, arrow) = msg else {
            continue;
        };
        let Ok(chunk) = rerun::log::Chunk::from_arrow_msg(&arrow) else {
            continue;
        };
        *out.entry(chunk.entity_path().to_string()).or_insert(0) +=
            arrow.batch.get_array_memory_size() as u64;
    }
    out
}

pub fn format_record(b: &RecordBench) -> String {
    let mib = |x: u64| x as f64 / (1024.0 * 1024.0);
    let mut s = format!(
        "{}: {} masses, {} springs, {} frames made without stepping",
        b.scene, b.masses, b.springs, b.frames
    );
    for line in &b.bodies {
        let _ = write!(s, "\n  recording {line}");
    }
    let _ = write!(
        s,
        "\n.rrd file: {:.1} KB per frame (compressed as written, static data and index included)",
        b.file_bytes_per_frame / 1e3
    );
    for p in &b.passes {
        let _ = write!(
            s,
            "\n{:>8} sink: {:>7.1} frames/s sustained ({} frames in {:.2} s), peak resident memory {}",
            p.sink,
            p.frames_per_sec(),
            p.frames,
            p.wall_secs,
            p.peak_rss_bytes
                .map_or_else(|| "unknown".to_owned(), |m| format!("{:.0} MiB", mib(m)))
        );
    }
    let total: f64 = b.entity_bytes_per_frame.iter().map(|(_, v)| v).sum();
    let _ = write!(
        s,
        "\nper entity, Arrow bytes per frame before compression ({total:.0} in all; {} bytes static, once):",
        b.static_bytes
    );
    for (e, v) in &b.entity_bytes_per_frame {
        let _ = write!(s, "\n  {v:>12.0}  {e}");
    }
    s
}
