//! The `.rrd` file a run records to, written by us rather than by Rerun's `FileSink`.
//!
//! Rerun's sink writes on a thread of its own; when a write fails (a full disk, a file-size
//! limit) it logs the error, stops, and leaves the file cut inside a message, while the
//! recording's next flush blames a viewer that was never involved. This sink writes each message
//! where Rerun hands it over, and on a failed write it cuts the file back to the last whole
//! message, so that what is on disk stays a readable recording, and tells the run what failed
//! and which frames are complete in the file.

use std::fmt;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rerun::external::re_build_info::CrateVersion;
use rerun::external::re_log_encoding::{EncodeError, Encoder, EncodingOptions};
use rerun::log::{Chunk, LogMsg};
use rerun::sink::{LogSink, SinkFlushError};

/// The timeline whose values count frames (see `record`).
const FRAME_TIMELINE: &str = "frame";

/// The recording file could not be created (its cause is part of the message, not a separate
/// source, so that a chain of causes prints it once).
#[derive(Debug, thiserror::Error)]
#[error("cannot create the recording {}: {cause}", path.display())]
pub struct CreateError {
    pub path: PathBuf,
    pub cause: std::io::Error,
}

/// Why the file stopped growing, and how much of the run it holds.
#[derive(Debug, Clone)]
pub struct WriteFailure {
    pub path: PathBuf,
    /// What failed: the operating system's error ("No space left on device (os error 28)"), or
    /// the encoder's.
    pub cause: WriteCause,
    /// What would let the next run through.
    pub advice: &'static str,
    /// Frames 0 to this one are complete in the file; `None` when not even frame 0 is.
    pub last_complete_frame: Option<i64>,
    /// Size of the file as left: whole messages only.
    pub bytes_kept: u64,
    /// The frames are all there, only the index at the end of the file could not be written.
    pub at_index: bool,
}

impl std::fmt::Display for WriteFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let kept = match self.last_complete_frame {
            Some(n) => format!(
                "frames 0 to {n} ({} frames, {}) are complete in the file and readable",
                n + 1,
                human_bytes(self.bytes_kept)
            ),
            None => "no frame reached the file".to_owned(),
        };
        if self.at_index {
            write!(
                f,
                "{} writing the index at the end of {}: {kept}, only without an index \
                 (Rerun reads it all the same)",
                self.cause,
                self.path.display()
            )
        } else {
            let after = self.last_complete_frame.map_or_else(
                || "before frame 0".to_owned(),
                |n| format!("after frame {n}"),
            );
            write!(
                f,
                "{} writing {} {after}; the simulation stopped there: {kept}. {}",
                self.cause,
                self.path.display(),
                self.advice
            )
        }
    }
}

/// "1.2 MB": sizes in messages, in decimal units as `df -H` prints them.
pub fn human_bytes(bytes: u64) -> String {
    let b = bytes as f64;
    match bytes {
        0..1_000 => format!("{bytes} B"),
        1_000..1_000_000 => format!("{:.1} kB", b / 1e3),
        1_000_000..1_000_000_000 => format!("{:.1} MB", b / 1e6),
        _ => format!("{:.2} GB", b / 1e9),
    }
}

/// Per entity, the latest frame written; the file holds frame N whole once every entity that
/// was logged at frame 0 (the ones the recorder logs every frame) has reached N.
#[derive(Debug, Default)]
struct FrameWatermark {
    latest: std::collections::HashMap<String, i64>,
}

impl FrameWatermark {
    fn saw(&mut self, msg: &LogMsg) {
        let LogMsg::ArrowMsg(_, arrow) = msg else {
            return;
        };
        let Ok(chunk) = Chunk::from_arrow_msg(arrow) else {
            return;
        };
        let Some(frames) = chunk.timelines().get(&FRAME_TIMELINE.into()) else {
            return;
        };
        let range = frames.time_range();
        let entity = chunk.entity_path().to_string();
        let (first, last) = (range.min().as_i64(), range.max().as_i64());
        match self.latest.get_mut(&entity) {
            Some(l) => *l = (*l).max(last),
            // Entities first seen after frame 0 are logged only now and then: not waited for.
            None if first == 0 => {
                self.latest.insert(entity, last);
            }
            None => {}
        }
    }

    fn complete(&self) -> Option<i64> {
        self.latest.values().copied().min()
    }
}

#[derive(Default)]
struct Writer {
    /// `None` once the file is finished or has failed: later messages are dropped.
    encoder: Option<Encoder<File>>,
    /// The same file, to cut it back to `committed` after a failed write.
    file: Option<File>,
    /// Bytes of whole messages in the file.
    committed: u64,
    frames: FrameWatermark,
    failure: Option<WriteFailure>,
}

struct Shared {
    path: PathBuf,
    failed: AtomicBool,
    writer: Mutex<Writer>,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Writer> {
        // A panic while holding the lock leaves the writer as consistent as any failed write.
        self.writer.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn append(&self, msg: &LogMsg) {
        let mut w = self.lock();
        let Some(encoder) = w.encoder.as_mut() else {
            return;
        };
        match encoder.append(msg) {
            Ok(n) => {
                w.committed += n;
                w.frames.saw(msg);
            }
            Err(e) => {
                let advice = advice(&e);
                self.fail(&mut w, cause(e), advice, false);
            }
        }
    }

    /// Stop writing: cut the file back to its whole messages and remember why.
    fn fail(
        &self,
        w: &mut Writer,
        cause: WriteCause,
        advice: &'static str,
        at_index: bool,
    ) -> WriteFailure {
        if let Some(encoder) = w.encoder.take() {
            // Unwrapped, the encoder no longer writes its end marker when dropped.
            let _ = encoder.into_inner();
        }
        if let Some(file) = w.file.take() {
            // Cutting a file back needs no space; should it fail, the partial message stays at
            // the end, where Rerun's reader stops.
            let _ = file.set_len(w.committed);
        }
        let failure = WriteFailure {
            path: self.path.clone(),
            cause,
            advice,
            last_complete_frame: w.frames.complete(),
            bytes_kept: w.committed,
            at_index,
        };
        w.failure = Some(failure.clone());
        self.failed.store(true, Ordering::SeqCst);
        failure
    }
}

/// Why a write failed, shared by every copy of the failure.
#[derive(Debug, Clone)]
pub struct WriteCause(Arc<EncodeError>);

impl fmt::Display for WriteCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.as_ref() {
            EncodeError::Write(io) => write!(f, "{io}"),
            other => write!(f, "encoding a message failed ({other})"),
        }
    }
}

impl std::error::Error for WriteCause {}

fn cause(e: EncodeError) -> WriteCause {
    WriteCause(Arc::new(e))
}

/// What to do about a failed write, from the operating system's error number.
fn advice(e: &EncodeError) -> &'static str {
    let code = match e {
        EncodeError::Write(io) => io.raw_os_error(),
        _ => None,
    };
    match code {
        Some(libc::ENOSPC) | Some(libc::EDQUOT) => {
            "Free some space, or record elsewhere with --save FILE (or fewer --frames)"
        }
        Some(libc::EFBIG) => {
            "The file-size limit (ulimit -f) allows no more: raise it, or record fewer --frames"
        }
        _ => "Record elsewhere with --save FILE",
    }
}

/// The sink handed to the recording stream.
pub struct RrdFileSink {
    shared: Arc<Shared>,
}

/// The run's side of the same file: whether writing failed, and the end of the file. Should
/// neither side call [`RrdFile::finish`], the encoder ends the file when the last one is dropped.
#[derive(Clone)]
pub struct RrdFile {
    shared: Arc<Shared>,
}

/// Create `path` and write the stream's header. Without `footer`, the file ends with no chunk
/// index, and no index is kept in memory while it is written (long runs: see BENCHMARKS.md).
pub fn create(path: &Path, footer: bool) -> Result<(RrdFileSink, RrdFile), CreateError> {
    let create_error = |cause: std::io::Error| CreateError {
        path: path.to_owned(),
        cause,
    };
    let file = File::create(path).map_err(create_error)?;
    let twin = file.try_clone().map_err(create_error)?;
    let mut encoder = Encoder::new_eager(
        CrateVersion::LOCAL,
        EncodingOptions::PROTOBUF_COMPRESSED,
        file,
    )
    .map_err(|e| CreateError {
        path: path.to_owned(),
        cause: match e {
            EncodeError::Write(io) => io,
            other => std::io::Error::other(cause(other)),
        },
    })?;
    if !footer {
        encoder.do_not_emit_footer();
    }
    let committed = twin.metadata().map_err(create_error)?.len();
    let shared = Arc::new(Shared {
        path: path.to_owned(),
        failed: AtomicBool::new(false),
        writer: Mutex::new(Writer {
            encoder: Some(encoder),
            file: Some(twin),
            committed,
            ..Writer::default()
        }),
    });
    Ok((
        RrdFileSink {
            shared: shared.clone(),
        },
        RrdFile { shared },
    ))
}

impl std::fmt::Debug for RrdFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RrdFile")
            .field("path", &self.shared.path)
            .field("failed", &self.failed())
            .finish()
    }
}

impl RrdFile {
    pub fn path(&self) -> &Path {
        &self.shared.path
    }

    /// Whether a write has failed (cheap: checked by the recorder after every frame).
    pub fn failed(&self) -> bool {
        self.shared.failed.load(Ordering::SeqCst)
    }

    pub fn failure(&self) -> Option<WriteFailure> {
        self.shared.lock().failure.clone()
    }

    /// Write the end of the file (its index, unless left out) and make it durable. Call after
    /// the recording stream's last flush; later messages are dropped.
    pub fn finish(&self) -> Result<(), WriteFailure> {
        let mut w = self.shared.lock();
        if let Some(f) = &w.failure {
            return Err(f.clone());
        }
        let Some(mut encoder) = w.encoder.take() else {
            return Ok(());
        };
        let ended = encoder.finish().and_then(|()| encoder.flush_blocking());
        let file = encoder.into_inner();
        let synced = match (ended, file) {
            (Ok(()), Ok(f)) => f.sync_all().map_err(EncodeError::Write),
            (Err(e), _) | (_, Err(e)) => Err(e),
        };
        match synced {
            Ok(()) => {
                w.file = None;
                Ok(())
            }
            Err(e) => {
                let advice = advice(&e);
                Err(self.shared.fail(&mut w, cause(e), advice, true))
            }
        }
    }
}

impl LogSink for RrdFileSink {
    fn send(&self, msg: LogMsg) {
        self.shared.append(&msg);
    }

    fn flush_blocking(&self, _timeout: Duration) -> Result<(), SinkFlushError> {
        let w = self.shared.lock();
        if let Some(f) = &w.failure {
            return Err(SinkFlushError::failed(f.to_string()));
        }
        // Each message went to the file with a write call of its own: nothing is buffered here.
        Ok(())
    }

    fn defers_finalization_to_shutdown(&self) -> bool {
        true
    }
}
