//! `hooke bench record`: the recorder alone, on frames made without stepping: frames per second
//! into a discarding sink and into an .rrd file, and bytes per frame per entity.

use std::fmt::Write as _;
use std::time::Instant;

use crate::error::{RerunError, Result};
use crate::model::Model;
use crate::record::{RecordOptions, Recorder};
use crate::run::prepare::{self, Planned, Request};
use crate::run::select::Device;
use crate::scene::settings::Overrides;

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
    /// Threads the recorder's frame work may use (Rerun's encoder and writer run on their own).
    pub threads: usize,
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
    /// Wall milliseconds per frame of the digest stage (the reductions over every spring), which
    /// a run makes on the simulation thread; the passes above log digested frames, as a run's
    /// recorder thread gets them.
    pub digest_ms_per_frame: f64,
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
fn bench_frames(model: &Model, frame_rate_hz: f64, count: usize) -> Vec<crate::state::Snapshot> {
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
            let strain = model.springs.iter().map(|s| s.strain(&positions)).collect();
            crate::state::Snapshot {
                positions,
                strain,
                collider_positions: crate::model::poses_at(&model.effects.colliders, 0.0)
                    .iter()
                    .map(|p| p.position_m)
                    .collect(),
                ..crate::state::Snapshot::at(k as u64, k as f64 / frame_rate_hz, k as u64)
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
    let request = Request {
        overrides: Overrides {
            frames: Some(opts.frames.max(1)),
            ..Overrides::default()
        },
        // Nothing steps: no backend is made.
        ..Request::named(scene_arg, Device::cpu())
    };
    let planned = prepare::plan(&request, &mut |_| {})?;
    let frames = bench_frames(
        &planned.model,
        planned.settings.frame_rate_hz,
        BENCH_DISTINCT_FRAMES,
    );
    let mut bench = Bench {
        planned: &planned,
        frames,
        record: opts.record,
    };
    let digest_ms_per_frame = bench.digest()?;
    let builder = || rerun::RecordingStreamBuilder::new("hooke-bench-record");
    let cores = std::thread::available_parallelism().map_or(1, usize::from);

    // Into a sink that discards: the recorder and Rerun's batcher only.
    let rec = builder().buffered().map_err(RerunError::from)?;
    rec.set_sink(Box::new(Discard));
    let discard = bench.pass("discard", cores, &rec, opts.frames, || Ok(()))?;
    drop(rec);

    // Into an .rrd file: encoding, compression and writing too, with the recorder's frame work
    // on 1, 2, 4, … threads (up to the cores there are).
    let mut passes = vec![discard];
    let mut threads = 1;
    loop {
        let rec = builder().buffered().map_err(RerunError::from)?;
        let (sink, file) = crate::record::rrd_file::create(&opts.save, true)?;
        rec.set_sink(Box::new(sink));
        passes.push(bench.pass("file", threads, &rec, opts.frames, || {
            file.finish().map_err(crate::Error::WriteRecording)
        })?);
        drop(rec);
        if threads >= cores {
            break;
        }
        threads = (2 * threads).min(cores);
    }
    let file_bytes = std::fs::metadata(&opts.save)
        .map(|m| m.len())
        .map_err(|source| crate::Error::ReadRecording {
            path: opts.save.clone(),
            source,
        })?;

    let (static_bytes, entity_bytes_per_frame) =
        bench.weigh_entities(builder, BENCH_ENTITY_FRAMES.min(opts.frames))?;
    let model = &planned.model;
    Ok(RecordBench {
        scene: planned.loaded.scene.name.clone(),
        masses: model.mass_count(),
        springs: model.spring_count(),
        frames: opts.frames,
        bodies: crate::record::describe(model, &opts.record),
        passes,
        file_bytes_per_frame: file_bytes as f64 / opts.frames as f64,
        entity_bytes_per_frame,
        static_bytes,
        digest_ms_per_frame,
    })
}

/// The scene and the frames the recorder is given, over and over.
struct Bench<'a> {
    planned: &'a Planned,
    frames: Vec<crate::state::Snapshot>,
    record: RecordOptions,
}

impl Bench<'_> {
    /// A recorder on `rec` that has logged the scene's static data.
    fn recorder(&self, rec: &rerun::RecordingStream) -> Result<Recorder> {
        let Planned {
            loaded,
            settings,
            model,
        } = self.planned;
        let mut r = Recorder::new(
            rec.clone(),
            model.clone(),
            self.record.for_scene(&loaded.scene),
        );
        r.log_static(
            &loaded.scene.name,
            &loaded.text,
            settings,
            "bench (no stepping)",
        )
        .map_err(RerunError::from)?;
        Ok(r)
    }

    /// Digest the distinct frames as a run's simulation thread does (the recorder's digester, on
    /// every core): the wall milliseconds per frame it took.
    fn digest(&mut self) -> Result<f64> {
        let (rec, _) = rerun::RecordingStreamBuilder::new("hooke-bench-digest")
            .memory()
            .map_err(RerunError::from)?;
        let digester = self.recorder(&rec)?.digester();
        let start = Instant::now();
        for f in &mut self.frames {
            digester.digest(f);
        }
        Ok(start.elapsed().as_secs_f64() * 1e3 / self.frames.len().max(1) as f64)
    }

    /// Log `n` frames, cycling through the distinct ones (renumbered in place: a run hands the
    /// recorder its snapshots without copying them either).
    fn log_frames(&mut self, r: &mut Recorder, n: u64) -> Result<()> {
        let rate = self.planned.settings.frame_rate_hz;
        let distinct = self.frames.len() as u64;
        for k in 0..n {
            let snap = &mut self.frames[(k % distinct) as usize];
            snap.frame = k;
            snap.time_secs = k as f64 / rate;
            r.log_snapshot(snap).map_err(RerunError::from)?;
        }
        Ok(())
    }

    /// `frames` frames into `rec`'s sink with the recorder's frame work on `threads` threads,
    /// timed up to the flush and `finish` (which ends a file).
    fn pass(
        &mut self,
        sink: &'static str,
        threads: usize,
        rec: &rerun::RecordingStream,
        frames: u64,
        finish: impl FnOnce() -> Result<()>,
    ) -> Result<RecordPass> {
        let mut r = self.recorder(rec)?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|source| crate::Error::ThreadPool { threads, source })?;
        let start = Instant::now();
        pool.install(|| self.log_frames(&mut r, frames))?;
        rec.flush_blocking().map_err(RerunError::from)?;
        finish()?;
        Ok(RecordPass {
            sink,
            threads,
            frames,
            wall_secs: start.elapsed().as_secs_f64(),
            peak_rss_bytes: peak_resident_bytes(),
        })
    }

    /// Into memory: Arrow bytes logged once, and per entity per frame over `n` frames.
    fn weigh_entities(
        &mut self,
        builder: impl Fn() -> rerun::RecordingStreamBuilder,
        n: u64,
    ) -> Result<(u64, Vec<(String, f64)>)> {
        let (rec, storage) = builder().memory().map_err(RerunError::from)?;
        let mut r = self.recorder(&rec)?;
        rec.flush_blocking().map_err(RerunError::from)?;
        let static_bytes: u64 = arrow_bytes_by_entity(storage.take()).values().sum();
        self.log_frames(&mut r, n)?;
        rec.flush_blocking().map_err(RerunError::from)?;
        let mut per_frame: Vec<(String, f64)> = arrow_bytes_by_entity(storage.take())
            .into_iter()
            .map(|(e, b)| (e, b as f64 / n as f64))
            .collect();
        per_frame.sort_by(|a, b| b.1.total_cmp(&a.1));
        Ok((static_bytes, per_frame))
    }
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
            "\n{:>8} sink, {:>2} thread{}: {:>7.1} frames/s sustained ({} frames in {:.2} s), peak resident memory {}",
            p.sink,
            p.threads,
            if p.threads == 1 { " " } else { "s" },
            p.frames_per_sec(),
            p.frames,
            p.wall_secs,
            p.peak_rss_bytes
                .map_or_else(|| "unknown".to_owned(), |m| format!("{:.0} MiB", mib(m)))
        );
    }
    let _ = write!(
        s,
        "\ndigest stage (every spring's reductions, on the simulation thread in a run): {:.2} ms per frame",
        b.digest_ms_per_frame
    );
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
