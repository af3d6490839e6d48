//! Repeat one piece of a GPU run many times and watch resident memory: a bisection tool for
//! memory that grows over long runs (`hooke bench soak`).
//!
//! `cargo run --release --example readback_soak -- <variant> [iterations]`
//!
//! Prints resident memory (/proc/self/statm) at each tenth of the run, then the growth per
//! iteration from the end of the first fifth (warm-up) to the end. Run with no argument for the
//! list of variants: raw wgpu calls of the snapshot read-back (one submission and wait per
//! iteration), `GpuBackend` loops without a recorder, and the whole `run` pipeline with and
//! without an .rrd file (those also count the file's chunks). See BENCHMARKS.md, "Soak".

use hooke::integrator::Step;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

mod raw;
use raw::Raw;

use hooke::backend::{Backend, BackendError};
use hooke::gpu::GpuBackend;
use hooke::run::select::BackendKind;
use hooke::state::{Snapshot, State, StepStats};

const VARIANTS: &[(&str, &str)] = &[
    ("empty", "submit an empty encoder, poll Wait(index)"),
    (
        "empty-any",
        "submit an empty encoder, poll wait_indefinitely()",
    ),
    (
        "write",
        "write_buffer 256 B, submit an empty encoder, poll Wait(index)",
    ),
    (
        "copy",
        "copy_buffer_to_buffer into a MAP_READ buffer, submit, poll Wait(index)",
    ),
    (
        "map",
        "copy, submit, map_async (empty callback), poll Wait(index), get_mapped_range, unmap",
    ),
    ("map-any", "as map, polling wait_indefinitely()"),
    (
        "map-chan",
        "as map, the callback sending on a new mpsc channel (as Hooke does)",
    ),
    ("map-noview", "as map, without get_mapped_range"),
    (
        "map-nosubmit",
        "map_async, poll wait_indefinitely(), get_mapped_range, unmap; no submission",
    ),
    (
        "map-poll",
        "map_async, poll Poll until mapped, get_mapped_range, unmap; no submission",
    ),
    (
        "dispatch",
        "one compute dispatch, dynamic-offset uniform bind group, submit, poll Wait(index)",
    ),
    (
        "dispatch-static",
        "as dispatch, the uniform bound without a dynamic offset",
    ),
    ("clear", "clear_buffer, submit, poll Wait(index)"),
    (
        "hooke",
        "GpuBackend on the hair scene: advance(1) and snapshot()",
    ),
    (
        "hooke-advance",
        "GpuBackend on the hair scene: advance(1) and finish()",
    ),
    (
        "hooke-snapshot",
        "GpuBackend on the hair scene: snapshot() only",
    ),
    (
        "hooke-frames",
        "GpuBackend on the hair scene, as the simulation thread: advance(substeps), request_snapshot, collect_snapshot of the frame before",
    ),
    (
        "run-gpu",
        "hooke's whole run pipeline (simulation and recorder threads, .rrd file), GPU backend",
    ),
    (
        "run-gpu-norec",
        "as run-gpu, recording to a disabled stream",
    ),
    (
        "run-gpu-nofooter",
        "as run-gpu, the file sink writing no RRD footer (write_footer: false)",
    ),
    ("run-cpu", "as run-gpu on the CPU backend"),
    (
        "run-cpu-slow",
        "as run-cpu, sleeping 2 ms a frame (about the GPU's frame time)",
    ),
];

fn resident_bytes() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").expect("reading /proc/self/statm");
    let pages: u64 = statm
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .expect("resident pages in /proc/self/statm");
    pages * 4096
}

fn hair_planned() -> hooke::run::prepare::Planned {
    hooke::run::prepare::planned("hair").expect("loading the hair scene")
}

fn hair() -> (GpuBackend, u32) {
    let hooke::run::prepare::Planned {
        settings, model, ..
    } = hair_planned();
    let be = GpuBackend::new(
        model,
        Step::new(settings.integrator, settings.dt_secs),
        None,
    )
    .expect("opening the GPU backend");
    (be, settings.substeps)
}

/// Resident memory at each tenth of the run, and the growth per iteration after the first fifth.
struct Meter {
    variant: String,
    iterations: u64,
    done: u64,
    start: Instant,
    warm: (u64, u64),
}

fn mib(b: u64) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

impl Meter {
    fn new(variant: &str, iterations: u64) -> Self {
        println!("{variant}: {iterations} iterations");
        println!("{:>8} {:>8} {:>10}", "iter", "wall s", "RSS MiB");
        println!("{:>8} {:>8.1} {:>10.2}", 0, 0.0, mib(resident_bytes()));
        Self {
            variant: variant.to_owned(),
            iterations,
            done: 0,
            start: Instant::now(),
            warm: (0, 0),
        }
    }

    fn tick(&mut self) {
        self.done += 1;
        let tenth = self.iterations / 10;
        if !self.done.is_multiple_of(tenth) || self.done > self.iterations {
            return;
        }
        let rss = resident_bytes();
        let t = self.start.elapsed().as_secs_f64();
        println!("{:>8} {t:>8.1} {:>10.2}", self.done, mib(rss));
        if self.done == 2 * tenth {
            self.warm = (self.done, rss);
        }
        if self.done == self.iterations {
            let per = (rss as f64 - self.warm.1 as f64) / (self.done - self.warm.0) as f64;
            println!(
                "{}: {:+.2} MiB after warm-up (iteration {}), {per:+.1} bytes/iteration, {:.1} µs/iteration",
                self.variant,
                mib(rss) - mib(self.warm.1),
                self.warm.0,
                t * 1e6 / self.done as f64
            );
        }
    }
}

/// A backend that ticks the meter at each frame, and optionally sleeps there (a CPU backend
/// slowed to the GPU's frame rate).
struct Metered {
    inner: Box<dyn Backend>,
    meter: Meter,
    sleep: Option<Duration>,
}

impl Backend for Metered {
    fn describe(&self) -> String {
        self.inner.describe()
    }
    fn watch(&mut self, flags: hooke::backend::StopFlags) {
        self.inner.watch(flags)
    }
    fn advance(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        if let Some(d) = self.sleep {
            std::thread::sleep(d);
        }
        let stats = self.inner.advance(substeps);
        self.meter.tick();
        stats
    }
    fn request_snapshot(&mut self, frame: u64, stats: StepStats) -> Result<(), BackendError> {
        self.inner.request_snapshot(frame, stats)
    }
    fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError> {
        self.inner.collect_snapshot()
    }
    fn state(&mut self) -> Result<State, BackendError> {
        self.inner.state()
    }
    fn recycle(&mut self, snapshot: Snapshot) {
        self.inner.recycle(snapshot);
    }
    fn finish(&mut self) -> Result<(), BackendError> {
        self.inner.finish()
    }
}

/// The whole pipeline of `hooke run` (simulation and recorder threads), `iterations` frames of
/// the hair scene, recorded to a file in the temporary directory or to a disabled stream.
fn run_pipeline(variant: &str, iterations: u64) {
    let hooke::run::prepare::Planned {
        loaded,
        mut settings,
        model,
    } = hair_planned();
    settings.frames = iterations;
    let kind = if variant.starts_with("run-cpu") {
        BackendKind::Cpu
    } else {
        BackendKind::Gpu
    };
    let inner = hooke::run::select::create(
        kind,
        model.clone(),
        Step::new(settings.integrator, settings.dt_secs),
        None,
    )
    .expect("opening the backend");
    let be = Metered {
        inner,
        meter: Meter::new(variant, iterations),
        sleep: variant
            .ends_with("-slow")
            .then(|| Duration::from_micros(2000)),
    };
    let rrd = std::env::temp_dir().join(format!("readback_soak_{}.rrd", std::process::id()));
    let rec = if variant.ends_with("-norec") {
        rerun::RecordingStream::disabled()
    } else if variant.ends_with("-nofooter") {
        let options = rerun::sink::FileSinkOptions {
            write_footer: false,
        };
        let file =
            rerun::sink::FileSink::with_options(&rrd, options).expect("creating the .rrd file");
        let rec = rerun::RecordingStreamBuilder::new("readback-soak")
            .buffered()
            .expect("starting the recording");
        rec.set_sink(Box::new(file));
        rec
    } else {
        rerun::RecordingStreamBuilder::new("readback-soak")
            .save(&rrd)
            .expect("creating the .rrd file")
    };
    // Rerun's own file sink on purpose (no `RrdFile`): this bisects Rerun's memory use, not ours.
    let opts = hooke::run::RunOptions::unattended(None);
    let prepared = hooke::run::prepare::Prepared {
        loaded,
        settings,
        model,
        backend: Box::new(be),
    };
    let summary = hooke::run::run(prepared, rec, &opts, Arc::new(AtomicBool::new(false)));
    let chunks = count_chunks(&rrd);
    let _ = std::fs::remove_file(&rrd);
    let summary = summary.expect("the run");
    println!(
        "{} frames recorded in {:.1} s; {}",
        summary.frames_recorded,
        summary.wall_secs,
        chunks.map_or("no file".to_owned(), |c| format!(
            "{c} chunks in the file ({:.2} per frame, {:.1} per second)",
            c as f64 / summary.frames_recorded.max(1) as f64,
            c as f64 / summary.wall_secs
        ))
    );
}

/// Data chunks in an .rrd file (each one a row of the footer's manifest), `None` without a file.
fn count_chunks(path: &std::path::Path) -> Option<u64> {
    let file = std::fs::File::open(path).ok()?;
    let mut chunks = 0;
    for msg in re_log_encoding::DecoderApp::decode_lazy(std::io::BufReader::new(file)) {
        if let Ok(rerun::log::LogMsg::ArrowMsg(..)) = msg {
            chunks += 1;
        }
    }
    Some(chunks)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(variant) = args.next().filter(|v| VARIANTS.iter().any(|(n, _)| n == v)) else {
        eprintln!("usage: readback_soak <variant> [iterations]\nvariants:");
        for (name, what) in VARIANTS {
            eprintln!("  {name:<16} {what}");
        }
        std::process::exit(2);
    };
    let iterations: u64 = args
        .next()
        .map(|s| s.parse().expect("iterations: a whole number"))
        .unwrap_or(20_000)
        .max(10);
    if variant.starts_with("run-") {
        run_pipeline(&variant, iterations);
        return;
    }
    let mut sink = 0.0f32;
    if let Some(what) = variant.strip_prefix("hooke") {
        let (mut be, substeps) = hair();
        let mut meter = Meter::new(&variant, iterations);
        if what == "-frames" {
            // The simulation thread's order: step frame k, request its snapshot, collect k - 1.
            be.request_snapshot(0, StepStats::default())
                .expect("request_snapshot");
            for k in 1..=iterations {
                let stats = be.advance(substeps).expect("advance");
                be.request_snapshot(k, stats).expect("request_snapshot");
                if let Some(s) = be.collect_snapshot().expect("collect_snapshot") {
                    sink += s.positions.last().map_or(0.0, |p| p.y);
                    be.recycle(s);
                }
                meter.tick();
            }
        } else {
            for k in 0..iterations {
                if what != "-snapshot" {
                    be.advance(1).expect("advance");
                }
                if what == "-advance" {
                    be.finish().expect("finish");
                } else {
                    let s = be.snapshot(k, StepStats::default()).expect("snapshot");
                    sink += s.positions.last().map_or(0.0, |p| p.y);
                    be.recycle(s);
                }
                meter.tick();
            }
        }
    } else {
        let raw = Raw::new();
        let mut meter = Meter::new(&variant, iterations);
        for k in 0..iterations {
            sink += raw.run(&variant, k);
            meter.tick();
        }
    }
    println!("(checksum {sink})");
}
