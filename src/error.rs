//! The library's errors. Each one is a single message that names the file, field or entity and
//! says what would fix it; the binary prints it as is. Each layer below has an error of its own
//! (a scene's, a backend's, the recording file's, the viewer link's); this one gathers them for
//! the commands at the top.

use rerun::sink::SinkFlushError;

use crate::backend::BackendError;
use crate::record::RecordError;
use crate::record::rrd_file::{CreateError, WriteFailure};
use crate::record::viewer::{ConnectError, Gone};
use crate::scene::LoadError;
use crate::scene::settings::SettingsError;
// Where they have always been found, beside the library's other errors.
pub use crate::scene::{SceneError, SceneOrigin};

/// Everything the library can report.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene that is unknown, unreadable or invalid.
    #[error(transparent)]
    Scene(#[from] LoadError),

    #[error(transparent)]
    Settings(#[from] SettingsError),

    /// A body that starts buried in the ground or inside a collider.
    #[error(transparent)]
    Buried(#[from] crate::model::Buried),

    /// A step too small for any mass to move in f32.
    #[error(transparent)]
    BelowResolution(#[from] crate::stability::BelowResolution),

    /// A scene that needs more memory than the machine has available.
    #[error(transparent)]
    TooLarge(#[from] crate::model::memory_need::TooLarge),

    /// An entry of `--compare` (or a scene's `[compare]`) that cannot be read.
    #[error("--compare entry {position} ('{text}'): {why}")]
    CompareEntry {
        /// Counted from 1.
        position: usize,
        text: String,
        why: crate::scene::compare_entry::EntryError,
    },

    /// An entry of a comparison refused before anything runs.
    #[error("--compare entry {position} ({entry}) is refused: {why}")]
    CompareRefused {
        position: usize,
        entry: String,
        why: crate::stability::Refusal,
    },

    /// `--dt auto` needs an error to aim at.
    #[error("--tolerance must be a positive number of metres, got {0}")]
    Tolerance(f64),

    #[error(transparent)]
    Backend(#[from] BackendError),

    #[error("the recorder stopped before the simulation finished: {0}")]
    RecorderGone(#[source] RecordError),

    /// Rerun refused to start, log to or flush a recording.
    #[error("rerun: {0}")]
    Rerun(#[from] RerunError),

    /// The same, while doing something the message names.
    #[error("rerun: {doing}: {source}")]
    RerunWhile { doing: String, source: RerunError },

    /// The end of a run could not reach its sink (a viewer that is not listening, typically).
    #[error(
        "rerun: flushing the recording failed: {0}. If streaming, is a Rerun viewer listening there? \
         Start one with `rerun`, or record to a file with --save FILE"
    )]
    FlushRun(#[source] SinkFlushError),

    /// A recording just written could not be read back (its size, for a benchmark).
    #[error("rerun: {}: {source}", path.display())]
    ReadRecording {
        path: std::path::PathBuf,
        source: std::io::Error,
    },

    /// A report (Markdown, CSV, SVG) could not be written where it was asked for.
    #[error("cannot write {}: {source}", path.display())]
    WriteOutput {
        path: std::path::PathBuf,
        source: std::io::Error,
    },

    /// The simulation thread panicked: a bug, reported with the panic's own message.
    #[error("the simulation thread panicked{}", panic_message(.0))]
    SimulationPanicked(Option<String>),

    /// The recorder thread panicked: a bug, reported with the panic's own message.
    #[error("the recorder thread panicked{}", panic_message(.0))]
    RecorderPanicked(Option<String>),

    #[error("cannot start a thread: {0}")]
    SpawnThread(#[source] std::io::Error),

    #[error("cannot start a pool of {threads} threads: {source}")]
    ThreadPool {
        threads: usize,
        source: rayon::ThreadPoolBuildError,
    },

    /// The recording file could not be created.
    #[error(transparent)]
    CreateRecording(#[from] CreateError),

    /// Writing the recording failed mid-run (a full disk): what the file still holds.
    #[error("{0}")]
    WriteRecording(WriteFailure),

    /// The viewer address cannot be used.
    #[error(transparent)]
    Connect(#[from] ConnectError),

    /// The live viewer went away and no file was being recorded beside it.
    #[error(
        "the viewer at {url} went away at frame {frame} ({why}); the run stopped there. To keep a run \
         whatever the viewer does, record it as well with --save FILE (streaming and saving together)"
    )]
    ViewerGone { url: String, frame: u64, why: Gone },

    /// A sweep's file, folder or executor: the message names which and what would fix it.
    #[error("{0}")]
    Sweep(String),
}

/// What Rerun said when it refused.
#[derive(Debug, thiserror::Error)]
pub enum RerunError {
    #[error(transparent)]
    Stream(#[from] rerun::RecordingStreamError),
    #[error(transparent)]
    Record(#[from] RecordError),
    #[error(transparent)]
    Flush(#[from] SinkFlushError),
    #[error(transparent)]
    Encode(#[from] rerun::external::re_log_encoding::EncodeError),
}

impl Error {
    /// Rerun's refusal, while doing what `doing` says.
    pub fn rerun_while(doing: impl Into<String>, source: impl Into<RerunError>) -> Self {
        Error::RerunWhile {
            doing: doing.into(),
            source: source.into(),
        }
    }

    /// A panicked thread's error, from what `join` returned: the panic message where it is text.
    pub fn panicked(
        payload: &(dyn std::any::Any + Send),
        error: fn(Option<String>) -> Error,
    ) -> Self {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_owned())
            .or_else(|| payload.downcast_ref::<String>().cloned());
        error(message)
    }
}

fn panic_message(message: &Option<String>) -> String {
    message
        .as_ref()
        .map(|m| format!(": {m}"))
        .unwrap_or_default()
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
