//! How the CPU backend splits work over masses: fixed chunks, so that per-chunk partial sums
//! (and hence the energy ledger) are bit-identical whatever the thread count.

/// Masses per work item.
pub const CHUNK: usize = 1024;

/// Below this many masses the thread pool costs more than it saves.
pub const PARALLEL_MIN_MASSES: usize = 4 * CHUNK;

/// The sum of `part(range)` over the fixed chunks of `len` masses, the chunks' partials added in
/// order (on the thread pool from `PARALLEL_MIN_MASSES` masses on): the same result on any
/// number of threads.
pub fn sum_chunks(len: usize, part: impl Fn(std::ops::Range<usize>) -> f64 + Sync) -> f64 {
    use rayon::prelude::*;
    let chunk = |c: usize| part(c * CHUNK..(c * CHUNK + CHUNK).min(len));
    let chunks = len.div_ceil(CHUNK);
    if len >= PARALLEL_MIN_MASSES {
        let partials: Vec<f64> = (0..chunks).into_par_iter().map(chunk).collect();
        partials.into_iter().sum()
    } else {
        (0..chunks).map(chunk).sum()
    }
}

/// `f(i, &mut out[i])` for every element, on the thread pool from `PARALLEL_MIN_MASSES` elements
/// on, over fixed chunks: each element is written by one call, whatever the scheduling.
pub fn each_mass<T: Send>(out: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
    use rayon::prelude::*;
    let chunk = |(c, part): (usize, &mut [T])| {
        for (k, o) in part.iter_mut().enumerate() {
            f(c * CHUNK + k, o);
        }
    };
    if out.len() >= PARALLEL_MIN_MASSES {
        out.par_chunks_mut(CHUNK).enumerate().for_each(chunk);
    } else {
        out.chunks_mut(CHUNK).enumerate().for_each(chunk);
    }
}
