//! How large a recording will be, before it is made: `hooke check` prints it, and a run that
//! saves to a file compares it with the free space where the file goes.
//!
//! The estimate records a few frames of the scene in memory with the real recorder and measures
//! them encoded as in a file. Its frames are the initial state with every spring given a strain
//! spread over the colour scale and every mass moved a little, so that they compress no better
//! than a frame in motion does: a real run's frames are rarely larger.

use std::sync::Arc;

use glam::Vec3;

use crate::error::{Error, RerunError, Result};
use crate::model::Model;
use crate::record::{RecordOptions, Recorder};
use crate::scene::settings::Settings;
use crate::state::Snapshot;

/// Frames recorded in one batch to measure a small scene's frame: a run's recording batches
/// many frames of an entity into one chunk, which spreads the chunk's own overhead thin.
const SAMPLE_FRAMES: u64 = 16;

/// A frame at least this large is measured alone: its chunks' overhead no longer matters, and
/// recording more of them would make `hooke check` slow on large scenes.
const LARGE_FRAME_BYTES: u64 = 1_000_000;

/// Bytes of a recording: what never changes, and what each frame adds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordingSize {
    pub static_bytes: u64,
    pub bytes_per_frame: u64,
}

impl RecordingSize {
    /// The whole file for `frames` frames after the initial one.
    pub fn total(&self, frames: u64) -> u64 {
        self.static_bytes + self.bytes_per_frame * (frames + 1)
    }
}

/// A deterministic value in [-1, 1) for index `i` (a hash, so neighbours differ).
fn spread(i: u64, salt: u64) -> f32 {
    let mut z = i.wrapping_add(salt.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 23) as f32 - 1.0
}

/// A frame of the scene as it may look in motion.
fn sample_frame(model: &Model, frame: u64, strain_range: f32, spacing: f32) -> Snapshot {
    let wobble = 0.05 * spacing;
    Snapshot {
        positions: model
            .initial
            .x
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let i = i as u64 * 3;
                *x + wobble
                    * Vec3::new(spread(i, frame), spread(i + 1, frame), spread(i + 2, frame))
            })
            .collect(),
        strain: (0..model.spring_count() as u64)
            .map(|s| 1.2 * strain_range * spread(s, frame + 1000))
            .collect(),
        collider_positions: model
            .effects
            .colliders
            .iter()
            .map(|c| c.path.pose_at(frame as f64 / 60.0).position_m)
            .collect(),
        ..Snapshot::at(frame, frame as f64 / 60.0, frame)
    }
}

/// Measure what the recorder writes for this scene.
pub fn estimate(
    model: &Arc<Model>,
    settings: &Settings,
    opts: RecordOptions,
) -> Result<RecordingSize> {
    let rerun_error = |e: RerunError| Error::rerun_while("estimating the recording's size", e);
    let (rec, storage) = rerun::RecordingStreamBuilder::new("hooke-size")
        .memory()
        .map_err(|e| rerun_error(e.into()))?;
    let encoded = || -> Result<u64> {
        rec.flush_blocking().map_err(|e| rerun_error(e.into()))?;
        Ok(storage
            .drain_as_bytes()
            .map_err(|e| rerun_error(e.into()))?
            .len() as u64)
    };
    let mut recorder = Recorder::new(rec.clone(), model.clone(), opts);
    recorder
        .log_static("estimate", "", settings, "estimate")
        .map_err(|e| rerun_error(e.into()))?;
    let static_bytes = encoded()?;
    let spacing = model
        .springs
        .iter()
        .map(|s| s.rest_m)
        .fold(f32::INFINITY, f32::min);
    let spacing = if spacing.is_finite() { spacing } else { 0.01 };
    let mut log = |frame| {
        recorder
            .log_snapshot(&sample_frame(model, frame, opts.strain_range, spacing))
            .map_err(|e| rerun_error(e.into()))
    };
    log(0)?;
    let first = encoded()?;
    if first >= LARGE_FRAME_BYTES {
        return Ok(RecordingSize {
            static_bytes,
            bytes_per_frame: first,
        });
    }
    for frame in 1..=SAMPLE_FRAMES {
        log(frame)?;
    }
    Ok(RecordingSize {
        static_bytes,
        bytes_per_frame: encoded()?.div_ceil(SAMPLE_FRAMES),
    })
}

/// Bytes free to an unprivileged writer on the filesystem that holds `dir`.
#[cfg(unix)]
pub fn free_bytes(dir: &std::path::Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt as _;
    let path = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
    let mut st = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `path` is a NUL-terminated string and `st` a buffer of the right type, which
    // statvfs fills in full when it returns 0.
    let st = unsafe {
        if libc::statvfs(path.as_ptr(), st.as_mut_ptr()) != 0 {
            return None;
        }
        st.assume_init()
    };
    // u64 here, narrower on some other targets.
    #[allow(clippy::useless_conversion)]
    Some(u64::from(st.f_bavail).saturating_mul(u64::from(st.f_frsize)))
}

#[cfg(not(unix))]
pub fn free_bytes(_dir: &std::path::Path) -> Option<u64> {
    None
}

/// The folder a file at `path` goes to (its parent, or the working directory).
pub fn folder_of(path: &std::path::Path) -> std::path::PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_owned(),
        _ => std::path::PathBuf::from("."),
    }
}

/// One line for the start of a run that saves to `path`: the estimate, and a warning when it
/// exceeds the free space there.
pub fn describe_for_file(size: &RecordingSize, frames: u64, path: &std::path::Path) -> String {
    use crate::record::rrd_file::human_bytes;
    let total = size.total(frames);
    let line = format!(
        "recording: about {} per frame, about {} for {} frames (estimated)",
        human_bytes(size.bytes_per_frame),
        human_bytes(total),
        frames + 1
    );
    match free_bytes(&folder_of(path)) {
        Some(free) if free < total => format!(
            "{line}\nwarning: only {} are free where {} goes: the run will stop when the disk \
             fills, keeping the frames written until then (about {} frames); record fewer \
             --frames, or elsewhere with --save",
            human_bytes(free),
            path.display(),
            free.saturating_sub(size.static_bytes) / size.bytes_per_frame.max(1)
        ),
        _ => line,
    }
}
