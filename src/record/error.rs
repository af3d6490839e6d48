//! What can go wrong while recording.

/// Why a frame could not be recorded.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error(transparent)]
    Rerun(#[from] rerun::RecordingStreamError),
    /// Rerun's component layout is not what this build expects (a version mismatch).
    #[error("internal: {0}")]
    Layout(String),
}

pub(super) type RResult<T = ()> = Result<T, RecordError>;
