//! The fused step's compact view of the springs: runs of consecutive masses that share a stencil
//! (the same neighbour offsets, in the same CSR order, with the same spring constants: a grid's
//! interior), and a compact CSR for every other mass. Built once from the model; only for models
//! whose springs never change (no plasticity, no tearing).

use std::collections::HashMap;

use super::chunks::CHUNK;
use crate::model::Model;

/// Shortest run of masses worth the lanes: the widest kernel's width, so that every run fills
/// at least one whole vector whatever the kernel.
pub(super) const MIN_RUN: usize = 8;

/// One spring of a stencil, as seen from the mass: its other end at `delta` masses away, and its
/// kind's constants, negated as the force law uses them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Slot {
    pub delta: isize,
    pub neg_stiffness: f32,
    pub neg_damping: f32,
}

/// A spring of a mass outside the runs: 16 bytes, no unused field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Entry {
    pub other: u32,
    pub rest_m: f32,
    pub neg_stiffness: f32,
    pub neg_damping: f32,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Segment {
    /// Masses `start..end` share stencil `stencil`; the rest length of slot `s` of mass
    /// `start + t` is `rest[rest_at + s * (end - start) + t]` (slot-major, so lanes load it).
    Run {
        start: usize,
        end: usize,
        stencil: usize,
        rest_at: usize,
    },
    /// Masses `start..end`, each with its own springs: mass `i`'s are `entries[entry_at +
    /// offsets[i] - offsets[start]..]`, `offsets[i + 1] - offsets[i]` of them.
    Single {
        start: usize,
        end: usize,
        entry_at: usize,
    },
}

#[derive(Debug, Default)]
pub(super) struct Stencils {
    pub stencils: Vec<Vec<Slot>>,
    pub rest: Vec<f32>,
    pub entries: Vec<Entry>,
    /// The model's CSR offsets (how many springs each single mass has).
    pub offsets: Vec<u32>,
    pub segments: Vec<Segment>,
    /// Chunk `c`'s segments are `segments[chunk_segments[c]..chunk_segments[c + 1]]`; no segment
    /// crosses a chunk boundary, so each chunk's ledger sum is over its own masses in order.
    pub chunk_segments: Vec<usize>,
}

/// A mass's springs as the stencil sees them: offset and constants' bits, in CSR order.
fn signature(model: &Model, i: usize) -> impl Iterator<Item = (isize, u32, u32)> + '_ {
    model.adjacency.of(i).iter().map(move |nb| {
        let s = &model.springs[nb.spring as usize];
        (
            nb.other as isize - i as isize,
            s.stiffness_n_per_m.to_bits(),
            s.damping_n_s_per_m.to_bits(),
        )
    })
}

impl Stencils {
    pub fn new(model: &Model) -> Self {
        let n = model.mass_count();
        let mut out = Stencils {
            offsets: model.adjacency.offsets.clone(),
            ..Default::default()
        };
        let mut ids: HashMap<Vec<(isize, u32, u32)>, usize> = HashMap::new();
        for lo in (0..n).step_by(CHUNK) {
            out.chunk_segments.push(out.segments.len());
            let hi = (lo + CHUNK).min(n);
            let mut start = lo;
            while start < hi {
                let mut end = start + 1;
                while end < hi && signature(model, end).eq(signature(model, start)) {
                    end += 1;
                }
                if end - start >= MIN_RUN {
                    let key: Vec<_> = signature(model, start).collect();
                    let next = ids.len();
                    let stencil = *ids.entry(key).or_insert(next);
                    out.push_run(model, start, end, stencil);
                } else {
                    out.push_single(model, start, end);
                }
                start = end;
            }
        }
        out.chunk_segments.push(out.segments.len());
        let mut stencils = vec![Vec::new(); ids.len()];
        for (key, id) in ids {
            stencils[id] = key
                .iter()
                .map(|&(delta, k, c)| Slot {
                    delta,
                    neg_stiffness: -f32::from_bits(k),
                    neg_damping: -f32::from_bits(c),
                })
                .collect();
        }
        out.stencils = stencils;
        out
    }

    fn push_run(&mut self, model: &Model, start: usize, end: usize, stencil: usize) {
        let rest_at = self.rest.len();
        let slots = model.adjacency.of(start).len();
        for s in 0..slots {
            for i in start..end {
                let nb = model.adjacency.of(i)[s];
                self.rest.push(model.springs[nb.spring as usize].rest_m);
            }
        }
        self.segments.push(Segment::Run {
            start,
            end,
            stencil,
            rest_at,
        });
    }

    fn push_single(&mut self, model: &Model, start: usize, end: usize) {
        let entry_at = self.entries.len();
        for i in start..end {
            self.entries.extend(model.adjacency.of(i).iter().map(|nb| {
                let s = &model.springs[nb.spring as usize];
                Entry {
                    other: nb.other,
                    rest_m: s.rest_m,
                    neg_stiffness: -s.stiffness_n_per_m,
                    neg_damping: -s.damping_n_s_per_m,
                }
            }));
        }
        // Adjacent single segments in one chunk merge: fewer, longer loops.
        let chunk_has_one = self.chunk_segments.last() != Some(&self.segments.len());
        if let Some(Segment::Single { end: e, .. }) = self.segments.last_mut()
            && *e == start
            && chunk_has_one
        {
            *e = end;
            return;
        }
        self.segments.push(Segment::Single {
            start,
            end,
            entry_at,
        });
    }

    /// Chunk `c`'s segments, in mass order.
    pub fn of_chunk(&self, c: usize) -> &[Segment] {
        &self.segments[self.chunk_segments[c]..self.chunk_segments[c + 1]]
    }

    /// Share of the masses in runs (for `hooke check` and the benchmark notes).
    pub fn run_share(&self) -> f64 {
        let (mut run, mut all) = (0usize, 0usize);
        for s in &self.segments {
            match *s {
                Segment::Run { start, end, .. } => {
                    run += end - start;
                    all += end - start;
                }
                Segment::Single { start, end, .. } => all += end - start,
            }
        }
        run as f64 / all.max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ModelBuilder;
    use glam::Vec3;

    /// A chain of `n` masses, springs to the next and the one after (bending), the last spring
    /// of mass `stiff` stiffer than the others.
    fn chain(n: u32, stiff: u32) -> Model {
        let mut mb = ModelBuilder::new();
        for i in 0..n {
            mb.mass(Vec3::new(i as f32, 0.0, 0.0), Vec3::ZERO, 1.0, false);
        }
        for i in 0..n - 1 {
            mb.spring(i, i + 1, if i == stiff { 9.0 } else { 1.0 }, 0.1);
            if i + 2 < n {
                mb.spring(i, i + 2, 0.5, 0.0);
            }
        }
        mb.build()
    }

    #[test]
    fn segments_cover_every_mass_once_in_order_and_runs_share_their_stencil() {
        // Mass 1500 has a stiffer spring to 1501: both leave the run there.
        let model = chain(3000, 1500);
        let st = Stencils::new(&model);
        let mut next = 0;
        for c in 0..st.chunk_segments.len() - 1 {
            for seg in st.of_chunk(c) {
                let (start, end) = match *seg {
                    Segment::Run {
                        start,
                        end,
                        stencil,
                        rest_at,
                    } => {
                        assert!(end - start >= MIN_RUN);
                        for i in start..end {
                            let nbs = model.adjacency.of(i);
                            assert_eq!(nbs.len(), st.stencils[stencil].len());
                            for (s, (nb, slot)) in nbs.iter().zip(&st.stencils[stencil]).enumerate()
                            {
                                let spring = &model.springs[nb.spring as usize];
                                assert_eq!(nb.other as isize - i as isize, slot.delta);
                                assert_eq!(-spring.stiffness_n_per_m, slot.neg_stiffness);
                                assert_eq!(-spring.damping_n_s_per_m, slot.neg_damping);
                                let rest = st.rest[rest_at + s * (end - start) + i - start];
                                assert_eq!(spring.rest_m, rest);
                            }
                        }
                        (start, end)
                    }
                    Segment::Single { start, end, .. } => (start, end),
                };
                assert_eq!(start, next, "segments in order, none missing");
                assert!(
                    start / CHUNK == c && (end - 1) / CHUNK == c,
                    "within chunk {c}"
                );
                next = end;
            }
        }
        assert_eq!(next, 3000);
        // Alone: the two masses at each end, and 1500 and 1501 (the ends of the stiff spring);
        // the chunk edges at 1024 and 2048 split runs without taking masses out of them.
        let alone = (3000.0 * (1.0 - st.run_share())).round();
        assert_eq!(alone, 6.0, "masses outside the runs");
        // 0..2 2..1024 | 1024..1500 1500..1502 1502..2048 | 2048..2998 2998..3000
        assert_eq!(st.segments.len(), 7);
    }
}
