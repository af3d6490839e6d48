//! How the CPU backend splits work over masses: fixed chunks, so that per-chunk partial sums
//! (and hence the energy ledger) are bit-identical whatever the thread count.

/// Masses per work item.
pub const CHUNK: usize = 1024;

/// Below this many masses the thread pool costs more than it saves.
pub const PARALLEL_MIN_MASSES: usize = 4 * CHUNK;
