//! Library errors. Each one is a single message that names the file, field or entity and says what
//! would fix it; the binary prints it as is.

use std::fmt;

/// Where a scene came from, so that errors can point at it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SceneOrigin {
    /// A TOML file on disk.
    File(std::path::PathBuf),
    /// One of the scenes compiled into the binary.
    BuiltIn(String),
    /// Text handed to the library directly (tests, examples).
    Text,
}

impl fmt::Display for SceneOrigin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneOrigin::File(p) => write!(f, "{}", p.display()),
            SceneOrigin::BuiltIn(name) => write!(f, "built-in scene '{name}'"),
            SceneOrigin::Text => write!(f, "<scene text>"),
        }
    }
}

/// A problem with a scene: where it is (origin, line, column, field path) and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    pub origin: SceneOrigin,
    /// 1-based line and column of the offending value, where known.
    pub position: Option<(usize, usize)>,
    /// Dotted field path such as `bodies[0].mass_kg`; empty when the problem is the whole file.
    pub field: String,
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.origin)?;
        if let Some((line, col)) = self.position {
            write!(f, ":{line}:{col}")?;
        }
        if !self.field.is_empty() {
            write!(f, ": `{}`", self.field)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for SceneError {}

/// Everything the library can report.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] SceneError),

    #[error("cannot read scene file {path}: {source}")]
    ReadScene {
        path: std::path::PathBuf,
        source: std::io::Error,
    },

    #[error(
        "unknown scene '{name}': it is neither a built-in scene nor an existing file. \
         Run `hooke scenes` for the built-in names, or give a path to a .toml file"
    )]
    UnknownScene { name: String },

    #[error("invalid setting: {0}")]
    Settings(String),

    #[error(transparent)]
    Backend(#[from] crate::backend::BackendError),

    #[error("the recorder stopped before the simulation finished: {0}")]
    RecorderGone(String),

    #[error("rerun: {0}")]
    Rerun(String),

    /// The recording file could not be created (its cause is part of the message, not a
    /// separate source, so that a chain of causes prints it once).
    #[error("cannot create the recording {}: {cause}", path.display())]
    CreateRecording {
        path: std::path::PathBuf,
        cause: std::io::Error,
    },

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
