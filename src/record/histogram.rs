//! `stats/strain_histogram`: how many springs sit at each strain, each frame, as a bar chart.
//!
//! Bins: [`BINS`] equal bins over [−strain_range, +strain_range], plus one bar on each side for
//! the springs beyond the range (compressed past −range, stretched past +range; a non-finite
//! strain counts as stretched). Broken springs (strain NaN) are not counted, so the bars sum to
//! the number of intact springs of the whole model.

/// Bins inside ±strain_range.
pub const BINS: usize = 20;

/// Counts of `strain` in the `BINS + 2` bars: below −range, the bins, above +range.
pub fn counts(strain: &[f32], range: f32, out: &mut Vec<u64>) {
    out.clear();
    out.resize(BINS + 2, 0);
    for &s in strain {
        let b = usize::from(bar(s, range));
        if b != NAN_BAR {
            out[b] += 1;
        }
    }
}

/// Where a NaN strain (a broken spring) goes: past the bars, counted by none.
pub const NAN_BAR: usize = BINS + 2;

/// The bar of a strain ([`NAN_BAR`] for NaN). Written without branches (clamps, selects and an
/// i32 conversion), so that a loop over many strains vectorises (`StrainSummary`).
#[inline]
pub fn bar(s: f32, range: f32) -> u8 {
    let per_bin = BINS as f32 / (2.0 * range);
    // Bins from 1: below −range (q < 0) truncates to bar 0, the bar before the bins, with no
    // call to floor (a library call on baseline x86-64); s = +range falls in the last bin.
    let q = ((s + range) * per_bin).max(-1.0).min(BINS as f32 - 1.0);
    let q = if s > range { BINS as f32 } else { q };
    let q = if s.is_nan() { NAN_BAR as f32 - 1.0 } else { q };
    (q + 1.0) as i32 as u8
}

/// Centre of each bar: the bins', and one bin width beyond each end for the two outer bars.
pub fn centres(range: f32) -> Vec<f64> {
    let width = 2.0 * f64::from(range) / BINS as f64;
    (0..BINS + 2)
        .map(|bar| -f64::from(range) + width * (bar as f64 - 0.5))
        .collect()
}

/// Bar widths (strain): all one bin wide.
pub fn widths(range: f32) -> Vec<f32> {
    vec![2.0 * range / BINS as f32; BINS + 2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_intact_spring_lands_in_one_bar() {
        let strain = [
            -1.0,
            -0.1,
            -0.05,
            0.0,
            0.049,
            0.05,
            0.1,
            f32::INFINITY,
            f32::NAN,
        ];
        let mut c = Vec::new();
        counts(&strain, 0.05, &mut c);
        assert_eq!(c.len(), BINS + 2);
        assert_eq!(c.iter().sum::<u64>(), 8, "{c:?}");
        assert_eq!(c[0], 2, "below −range: {c:?}");
        assert_eq!(c[BINS + 1], 2, "above +range: {c:?}");
        assert_eq!(c[1], 1, "−range is in the first bin");
        assert_eq!(c[BINS], 2, "0.049 and +range are in the last bin");
        assert_eq!(c[1 + BINS / 2], 1, "0 opens the upper half");
    }

    #[test]
    fn bar_centres_step_by_one_bin_and_straddle_zero() {
        let c = centres(0.05);
        // 0.05 as f32 is 0.05 to within 1e-9.
        assert!((c[1] - (-0.05 + 0.0025)).abs() < 1e-8);
        assert!((c[0] - (-0.05 - 0.0025)).abs() < 1e-8);
        assert!((c[BINS / 2] + c[BINS / 2 + 1]).abs() < 1e-8);
    }
}
