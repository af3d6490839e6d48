//! The `.rrd` file a run records to, written by us rather than by Rerun's `FileSink`.
//!
//! Rerun's sink writes on a thread of its own; when a write fails (a full disk, a file-size
//! limit) it logs the error, stops, and leaves the file cut inside a message, while the
//! recording's next flush blames a viewer that was never involved. This sink writes each message
//! where Rerun hands it over, and on a failed write it cuts the file back to the last whole
//! message, so that what is on disk stays a readable recording, and tells the run what failed
//! and which frames are complete in the file.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rerun::external::re_build_info::CrateVersion;
use rerun::external::re_log_encoding::{EncodeError, Encoder, EncodingOptions};
use rerun::log::{Chunk, LogMsg};
use rerun::sink::{LogSink, SinkFlushError};

pub use super::rrd_failure::{WriteCause, WriteFailure, human_bytes};
use super::rrd_failure::{advice, cause};

/// The timeline whose values count frames (see `record`).
const FRAME_TIMELINE: &str = "frame";

/// The recordings of this process still written under their partial names, (partial, final),
/// for `rename_unfinished`.
static UNFINISHED: Mutex<Vec<(PathBuf, PathBuf)>> = Mutex::new(Vec::new());

fn unfinished() -> MutexGuard<'static, Vec<(PathBuf, PathBuf)>> {
    UNFINISHED.lock().unwrap_or_else(|p| p.into_inner())
}

/// Give every recording of this process still being written its name, as it stands: for an
/// exit that will not wait for the run to end (a second Ctrl-C). Its whole frames are readable
/// (the file has no index, as any file cut short).
pub fn rename_unfinished() {
    for (partial, path) in unfinished().drain(..) {
        let _ = std::fs::rename(partial, path);
    }
}

/// The recording file could not be created (its cause is part of the message, not a separate
/// source, so that a chain of causes prints it once).
#[derive(Debug, thiserror::Error)]
pub enum CreateError {
    #[error("cannot create the recording {}: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// Another process holds the lock on the file's `.partial` twin.
    #[error(
        "{} is being written by another run{}: wait for it to end, or record elsewhere with \
         --save FILE",
        path.display(),
        pid.map_or_else(String::new, |p| format!(" (pid {p})"))
    )]
    Busy { path: PathBuf, pid: Option<i32> },
}

/// Where a recording is written until its run ends: `FILE.partial`, beside `FILE`, renamed to
/// `FILE` however the run ends (`RrdFile::finish`). A second run on the same `FILE` finds the
/// partial file locked and is refused, and an older `FILE` stays whole until the new one
/// replaces it.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".partial");
    PathBuf::from(name)
}

/// A write lock on the whole of `file` for this process (a POSIX record lock, which names its
/// holder): `Err(Some(pid))` where another process holds it.
fn lock_whole(file: &File) -> Result<(), Option<i32>> {
    use std::os::fd::AsRawFd;
    // SAFETY: `flock` is plain data, zero is a valid value of each field, and the descriptor
    // stays open for both calls.
    let mut l: libc::flock = unsafe { std::mem::zeroed() };
    l.l_type = libc::F_WRLCK as _;
    l.l_whence = libc::SEEK_SET as _;
    let fd = file.as_raw_fd();
    if unsafe { libc::fcntl(fd, libc::F_SETLK, &l) } == 0 {
        return Ok(());
    }
    let asked = unsafe { libc::fcntl(fd, libc::F_GETLK, &mut l) } == 0;
    Err((asked && i32::from(l.l_type) != libc::F_UNLCK).then_some(l.l_pid))
}

/// `partial` opened, locked and emptied. A run that finished and renamed it between our open
/// and our lock leaves us holding its finished file: that is noticed (the path no longer names
/// what we hold) and the open is tried again.
fn open_locked(path: &Path, partial: &Path) -> Result<File, CreateError> {
    use std::os::unix::fs::MetadataExt as _;
    let io = |cause| CreateError::Io {
        path: path.to_owned(),
        cause,
    };
    for _ in 0..4 {
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .read(true)
            .write(true)
            .open(partial)
            .map_err(io)?;
        lock_whole(&file).map_err(|pid| CreateError::Busy {
            path: path.to_owned(),
            pid,
        })?;
        let held = file.metadata().map_err(io)?;
        let named = std::fs::metadata(partial).ok();
        if named.is_some_and(|n| (n.dev(), n.ino()) == (held.dev(), held.ino())) {
            file.set_len(0).map_err(io)?;
            return Ok(file);
        }
    }
    Err(CreateError::Busy {
        path: path.to_owned(),
        pid: None,
    })
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
    /// Whether the partial file has taken the recording's name.
    published: bool,
    frames: FrameWatermark,
    failure: Option<WriteFailure>,
}

struct Shared {
    path: PathBuf,
    /// Where the bytes go until the run ends (`partial_path`).
    partial: PathBuf,
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

    /// Give the partial file the recording's name (once): the run has ended, however it ended.
    fn publish(&self, w: &mut Writer) -> std::io::Result<()> {
        if w.published {
            return Ok(());
        }
        w.published = true;
        unfinished().retain(|(p, _)| *p != self.partial);
        std::fs::rename(&self.partial, &self.path)
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

/// Create `path` (written as `partial_path(path)` until the run ends) and write the stream's
/// header. Without `footer`, the file ends with no chunk index, and no index is kept in memory
/// while it is written (long runs: see BENCHMARKS.md). A file that cannot be started leaves
/// nothing behind.
pub fn create(path: &Path, footer: bool) -> Result<(RrdFileSink, RrdFile), CreateError> {
    let partial = partial_path(path);
    let file = open_locked(path, &partial)?;
    let started = start(path, file, footer);
    if started.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    let (encoder, twin, committed) = started?;
    unfinished().push((partial.clone(), path.to_owned()));
    let shared = Arc::new(Shared {
        path: path.to_owned(),
        partial,
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

/// The stream's header written to `file`; the encoder, a twin of the file to cut it back, and
/// the bytes written.
fn start(path: &Path, file: File, footer: bool) -> Result<(Encoder<File>, File, u64), CreateError> {
    let create_error = |cause: std::io::Error| CreateError::Io {
        path: path.to_owned(),
        cause,
    };
    let twin = file.try_clone().map_err(create_error)?;
    let mut encoder = Encoder::new_eager(
        CrateVersion::LOCAL,
        EncodingOptions::PROTOBUF_COMPRESSED,
        file,
    )
    .map_err(|e| {
        create_error(match e {
            EncodeError::Write(io) => io,
            other => std::io::Error::other(cause(other)),
        })
    })?;
    if !footer {
        encoder.do_not_emit_footer();
    }
    let committed = twin.metadata().map_err(create_error)?.len();
    Ok((encoder, twin, committed))
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

    /// Write the end of the file (its index, unless left out), make it durable and give it its
    /// name (the partial file is renamed whether or not the end could be written: every whole
    /// frame in it is readable). Call after the recording stream's last flush; later messages
    /// are dropped.
    pub fn finish(&self) -> Result<(), WriteFailure> {
        let ended = self.end();
        let mut w = self.shared.lock();
        let published = self.shared.publish(&mut w);
        match (ended, published) {
            (Err(f), _) => Err(f),
            (Ok(()), Ok(())) => Ok(()),
            (Ok(()), Err(e)) => Err(self.shared.fail(
                &mut w,
                cause(EncodeError::Write(e)),
                "The frames are in the .partial file beside it: rename it",
                true,
            )),
        }
    }

    /// `finish` before the rename.
    fn end(&self) -> Result<(), WriteFailure> {
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

impl Drop for Shared {
    /// A run that never reached `finish` (a panic unwinding) still leaves its frames at the
    /// recording's name.
    fn drop(&mut self) {
        let w = self.writer.get_mut().unwrap_or_else(|p| p.into_inner());
        // The encoder, dropped after this, ends the file through its descriptor, renamed or
        // not.
        if !w.published {
            w.published = true;
            unfinished().retain(|(p, _)| *p != self.partial);
            let _ = std::fs::rename(&self.partial, &self.path);
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
