//! A run from request to summary: [`prepare`] resolves a scene into settings, a model and a
//! backend ([`select`] picks it; [`auto_dt`] the step where asked), [`sim`] steps it on the
//! simulation thread ([`pacing`] keeps it and the recorder in step, [`solver_watch`] stops a run
//! whose solver goes wrong), and [`pipeline`](run) joins that thread and the recorder's.
//! [`comparison`] runs several of them side by side; [`progress`] is what a terminal sees of
//! them and [`recording_size`] what a recording will take before it starts.

pub mod auto_dt;
pub mod comparison;
pub mod pacing;
mod pipeline;
pub mod prepare;
pub mod progress;
pub mod recording_size;
pub mod select;
pub mod sim;
pub mod solver_watch;

pub use pipeline::{CHANNEL_CAPACITY, RunOptions, RunSummary, ViewerWatch, run};
pub(crate) use pipeline::{Threads, end_recording};
