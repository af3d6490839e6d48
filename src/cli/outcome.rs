//! How a command ended without error, for `main` to turn into an exit code.

pub enum Outcome {
    Done,
    /// Ctrl-C or SIGTERM stopped a run (everything produced before it was recorded), or a
    /// sweep (every point that ended has its result).
    Interrupted,
}
