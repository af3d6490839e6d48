//! Library errors. Each one is a single message that names the file, field or entity and says what
//! would fix it; the binary prints it as is.

use crate::scene::LoadError;
// Where they have always been found, beside the library's other errors.
pub use crate::scene::{SceneError, SceneOrigin};

/// Everything the library can report.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene that is unknown, unreadable or invalid.
    #[error(transparent)]
    Scene(#[from] LoadError),

    #[error("invalid setting: {0}")]
    Settings(String),

    #[error(transparent)]
    Backend(#[from] crate::backend::BackendError),

    #[error("the recorder stopped before the simulation finished: {0}")]
    RecorderGone(String),

    #[error("rerun: {0}")]
    Rerun(String),

    /// The recording file could not be created.
    #[error(transparent)]
    CreateRecording(#[from] crate::rrd_file::CreateError),

    /// Writing the recording failed mid-run (a full disk): what the file still holds.
    #[error("{0}")]
    WriteRecording(crate::rrd_file::WriteFailure),

    /// The live viewer went away and no file was being recorded beside it.
    #[error(
        "the viewer at {url} went away at frame {frame} ({why}); the run stopped there. To keep a run \
         whatever the viewer does, record it as well with --save FILE (streaming and saving together)"
    )]
    ViewerGone {
        url: String,
        frame: u64,
        why: String,
    },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
