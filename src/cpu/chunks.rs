//! How the CPU backend splits work over masses: element-wise loops in pieces sized to the pool,
//! which no result depends on, and fixed chunks for the sums whose per-chunk partials (the
//! energy ledger's) are then bit-identical whatever the thread count. (The implicit solver's
//! sums are `solver_sums.rs`'s.)

/// Masses per work item.
pub const CHUNK: usize = 1024;

/// Below this many masses the thread pool costs more than it saves.
pub const PARALLEL_MIN_MASSES: usize = 4 * CHUNK;

/// `f()` on one of the thread pool's workers, so that the parallel loops inside it fork from a
/// worker. From a thread outside the pool (the simulation thread) each loop is handed to the
/// pool and waited for: a wake-up and a sleep per loop, dozens a CG iteration, which took 7% of
/// cloth-256's implicit step on one thread. Inside a pool (a test's one-thread pool) it runs
/// where it is.
pub fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| f())
}

/// The elements a piece of `each_mass`'s work takes: `CHUNK`, or fewer where that would leave
/// some of the pool's threads without a piece (a multigrid level of 4 096 nodes is four chunks).
/// An element is written by one call whatever the pieces, so their size does not change a bit.
fn piece(len: usize) -> usize {
    let threads = rayon::current_num_threads().max(1);
    (len / (4 * threads)).clamp(CHUNK / 4, CHUNK)
}

/// `f(i, &mut out[i])` for every element, on the thread pool from `PARALLEL_MIN_MASSES` elements
/// on: each element is written by one call, whatever the scheduling.
pub fn each_mass<T: Send>(out: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
    use rayon::prelude::*;
    if out.len() >= PARALLEL_MIN_MASSES {
        let size = piece(out.len());
        out.par_chunks_mut(size).enumerate().for_each(|(c, part)| {
            for (k, o) in part.iter_mut().enumerate() {
                f(c * size + k, o);
            }
        });
    } else {
        for (i, o) in out.iter_mut().enumerate() {
            f(i, o);
        }
    }
}

/// `f(i, &mut a[i], &mut b[i])` for every element of two arrays of one length, as `each_mass`.
pub fn each_mass_pair<T: Send, U: Send>(
    a: &mut [T],
    b: &mut [U],
    f: impl Fn(usize, &mut T, &mut U) + Sync,
) {
    use rayon::prelude::*;
    debug_assert_eq!(a.len(), b.len());
    if a.len() >= PARALLEL_MIN_MASSES {
        let size = piece(a.len());
        a.par_chunks_mut(size)
            .zip(b.par_chunks_mut(size))
            .enumerate()
            .for_each(|(c, (a, b))| {
                for (k, (a, b)) in a.iter_mut().zip(b).enumerate() {
                    f(c * size + k, a, b);
                }
            });
    } else {
        for (i, (a, b)) in a.iter_mut().zip(b).enumerate() {
            f(i, a, b);
        }
    }
}
