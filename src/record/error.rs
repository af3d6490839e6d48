//! What can go wrong while recording.

/// Why a frame could not be recorded.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error(transparent)]
    Rerun(#[from] rerun::RecordingStreamError),
    /// Rerun's component layout is not what this build expects (a version mismatch).
    #[error("internal: line strips: {0}")]
    Layout(#[from] LayoutError),
}

/// How Rerun's `LineStrip3D` differs from the layout the recorder builds.
#[derive(Debug, thiserror::Error)]
pub enum LayoutError {
    #[error("LineStrip3D is not an arrow list")]
    NotAList,
    #[error("LineStrip3D points are not 3 floats")]
    NotThreeFloats,
    #[error(transparent)]
    Arrow(#[from] rerun::external::arrow::error::ArrowError),
}

pub(super) type RResult<T = ()> = Result<T, RecordError>;
