//! What can be wrong with a scene: where (origin, line, column, field path) and what.

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

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error(transparent)]
    Invalid(#[from] SceneError),

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
}
