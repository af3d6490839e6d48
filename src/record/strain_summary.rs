//! One pass over a frame's strains for what the whole model contributes to a frame: the most
//! strained spring (`stats/max_strain`, `world/most_strained`) and the histogram's counts. The
//! strains are split into chunks that fit a core's cache, each chunk's answers found on its own
//! thread, and the answers merged in chunk order, so the result is that of a single pass
//! whatever the number of threads (the first spring wins a tie, counts are sums).

use std::sync::Arc;

use rayon::prelude::*;

use super::histogram;
use crate::model::{Model, SpringKindTag};

/// The springs the most strained one is taken from: those of the kind the surfaces are coloured
/// by (structural, where the model has any: `surface.rs` says why), so that the label names a
/// spring whose strain the colour under it shows; `None` (every spring) where it has none.
/// (On the flag the label named a bending spring at −25% over a surface coloured by its
/// structural springs.)
pub fn labelled_springs(model: &Model) -> Option<Arc<[bool]>> {
    let structural = |k: &SpringKindTag| *k == SpringKindTag::Structural;
    model
        .spring_kind
        .iter()
        .any(structural)
        .then(|| model.spring_kind.iter().map(structural).collect())
}

/// Strains a chunk holds: 256 KiB of f32.
const CHUNK: usize = 1 << 16;

#[derive(Debug, Clone, PartialEq)]
pub struct StrainSummary {
    /// The most strained intact spring of those labelled ([`labelled_springs`]) and its strain
    /// (largest |strain|, the first on a tie).
    pub most: Option<(usize, f32)>,
    /// The histogram's bars ([`histogram::counts`]).
    pub counts: Vec<u64>,
}

impl StrainSummary {
    /// The summary of `strain`, its most strained spring taken from those `labelled` marks
    /// (every spring where `None`).
    pub fn of(strain: &[f32], range: f32, labelled: Option<&[bool]>) -> Self {
        let chunk = |(k, c): (usize, &[f32])| Self {
            most: most_of(c, labelled.map(|l| &l[k * CHUNK..k * CHUNK + c.len()]))
                .map(|(i, s)| (k * CHUNK + i, s)),
            counts: counts_of(c, range),
        };
        if strain.len() <= CHUNK {
            return chunk((0, strain));
        }
        strain
            .par_chunks(CHUNK)
            .enumerate()
            .map(chunk)
            .reduce_with(Self::then)
            .unwrap_or_else(|| chunk((0, &[])))
    }

    /// This summary followed by `later`'s (of the strains after these).
    fn then(self, later: Self) -> Self {
        let most = match (self.most, later.most) {
            (Some(a), Some(b)) if b.1.abs() > a.1.abs() => Some(b),
            (Some(a), _) => Some(a),
            (None, b) => b,
        };
        let counts = self
            .counts
            .iter()
            .zip(&later.counts)
            .map(|(a, b)| a + b)
            .collect();
        Self { most, counts }
    }
}

/// The intact spring with the largest |strain|, and its strain.
pub fn most_strained(strain: &[f32]) -> Option<(usize, f32)> {
    strain
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, s)| !s.is_nan())
        .fold(None, |best: Option<(usize, f32)>, (i, s)| match best {
            Some((_, b)) if b.abs() >= s.abs() => best,
            _ => Some((i, s)),
        })
}

/// [`most_strained`] of a chunk, among the springs `labelled` marks (all where `None`): the
/// largest |strain| found first in a pass the compiler can vectorise, then the first spring that
/// has it.
fn most_of(c: &[f32], labelled: Option<&[bool]>) -> Option<(usize, f32)> {
    // f32::max ignores NaN, as the broken springs must be. Each case is its own loop without
    // a branch on `labelled` inside, which the compiler vectorises.
    let at = match labelled {
        None => {
            let top = c.iter().fold(f32::NEG_INFINITY, |m, s| m.max(s.abs()));
            c.iter().position(|s| s.abs() == top)
        }
        Some(l) => {
            let top = c
                .iter()
                .zip(l)
                .map(|(s, &on)| if on { s.abs() } else { f32::NEG_INFINITY })
                .fold(f32::NEG_INFINITY, f32::max);
            c.iter().zip(l).position(|(s, &on)| on && s.abs() == top)
        }
    };
    at.map(|i| (i, c[i]))
}

/// [`histogram::counts`] of a chunk: each strain's bar found in blocks (a loop without branches
/// the compiler vectorises), then counted in four tallies taken in turn, since most strains fall
/// in a bar or two and one tally would make each increment wait on the last.
fn counts_of(c: &[f32], range: f32) -> Vec<u64> {
    let mut tally = [[0u32; histogram::NAN_BAR + 1]; 4];
    let mut bars = [0u8; 1024];
    for block in c.chunks(1024) {
        for (b, &s) in bars.iter_mut().zip(block) {
            *b = histogram::bar(s, range);
        }
        for (i, &b) in bars[..block.len()].iter().enumerate() {
            tally[i & 3][usize::from(b)] += 1;
        }
    }
    (0..histogram::BINS + 2)
        .map(|b| tally.iter().map(|t| u64::from(t[b])).sum())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_merged_give_what_one_pass_gives() {
        // Long enough for several chunks, with ties for the largest |strain| across chunks.
        let n = 5 * CHUNK + 123;
        let strain: Vec<f32> = (0..n)
            .map(|i| match i {
                _ if i % 1_000_003 == 7 => f32::NAN,
                _ if i == 3 * CHUNK + 5 || i == CHUNK + 9 => -0.5,
                _ if i == 4 * CHUNK => 0.5,
                _ => ((i as f32) * 0.001).sin() * 0.2,
            })
            .collect();
        let got = StrainSummary::of(&strain, 0.1, None);
        let mut counts = Vec::new();
        histogram::counts(&strain, 0.1, &mut counts);
        assert_eq!(got.counts, counts);
        assert_eq!(got.most, most_strained(&strain));
        assert_eq!(got.most, Some((CHUNK + 9, -0.5)));
        // Labelled springs only: the two at −0.5 are left out, so the +0.5 spring is the most
        // strained, in every chunk arrangement.
        let labelled: Vec<bool> = (0..n)
            .map(|i| i != 3 * CHUNK + 5 && i != CHUNK + 9)
            .collect();
        let got = StrainSummary::of(&strain, 0.1, Some(&labelled));
        assert_eq!(got.most, Some((4 * CHUNK, 0.5)));
        assert_eq!(got.counts, counts, "the histogram counts every spring");
    }

    #[test]
    fn the_label_takes_the_kind_the_surface_shows() {
        let mut mb = crate::model::ModelBuilder::new();
        for i in 0..3 {
            mb.mass(
                glam::Vec3::new(i as f32, 0.0, 0.0),
                glam::Vec3::ZERO,
                1.0,
                false,
            );
        }
        mb.spring_with_rest(0, 1, 1.0, 10.0, 0.0, SpringKindTag::Structural);
        mb.spring_with_rest(1, 2, 1.0, 10.0, 0.0, SpringKindTag::Structural);
        mb.spring_with_rest(0, 2, 2.0, 1.0, 0.0, SpringKindTag::Bending);
        let model = mb.build();
        let labelled = labelled_springs(&model);
        assert_eq!(labelled.as_deref(), Some(&[true, true, false][..]));
        let strain = [0.1, -0.2, -0.4];
        let got = StrainSummary::of(&strain, 0.1, labelled.as_deref());
        assert_eq!(got.most, Some((1, -0.2)));
    }
}
