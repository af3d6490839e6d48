//! `hooke bench soak`: a long run through the whole pipeline (simulation thread, recorder
//! thread, an .rrd file) while resident memory is sampled, to show that nothing grows.

use std::fmt::Write as _;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use crate::error::{RerunError, Result};
use crate::run::prepare::{self, Request};
use crate::run::select::Device;
use crate::scene::settings::Overrides;

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
    device: &Device,
    duration_secs: f64,
    rrd: &std::path::Path,
    footer: bool,
) -> Result<Soak> {
    let request = Request {
        overrides: Overrides {
            duration_secs: Some(duration_secs),
            ..Overrides::default()
        },
        ..Request::named(scene_arg, device.clone())
    };
    let prepared = prepare::prepare(&request, &mut |_| {})?;
    let name = prepared.backend.describe();
    let scene_name = prepared.loaded.scene.name.clone();
    let rec = rerun::RecordingStreamBuilder::new("hooke-soak")
        .buffered()
        .map_err(|e| crate::Error::rerun_while("starting the recording", RerunError::from(e)))?;
    let (sink, file) = crate::record::rrd_file::create(rrd, footer)?;
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
        record: crate::record::RecordOptions::default().for_scene(&prepared.loaded.scene),
        ..crate::run::RunOptions::unattended(Some(file))
    };
    let summary = crate::run::run(prepared, rec, &opts, Arc::new(AtomicBool::new(false)));
    done.store(true, Ordering::Relaxed);
    let samples = sampler.join().unwrap_or_default();
    let summary = summary?;
    Ok(Soak {
        scene: scene_name,
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
