//! The steps `bench accuracy` tries, as whole substeps a frame: every run then covers a whole
//! number of frames with steps of one size, exactly as `hooke run --substeps N` steps it, and
//! can be recorded and compared frame by frame.

/// Which steps a ladder holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LadderOptions {
    /// The scene's own step (`1 / (frame rate × substeps)`) × 2^k for k from `coarsest` down,
    /// `points` of them.
    pub points: u32,
    pub coarsest: i32,
    /// Also the fast end: doublings of the largest of those steps up to one step per frame,
    /// where only the unconditionally stable solvers survive.
    pub fast_end: bool,
}

/// Substeps a frame of each step tried, fewest (the largest step) first: the scene's
/// `substeps` ÷ 2^k for k from `coarsest` down, rounded up where that is no whole number (the
/// step rounded down), and before them, with the fast end, halvings down to one a frame.
pub fn step_ladder(scene_substeps: u32, opts: &LadderOptions) -> Vec<u32> {
    let base = f64::from(scene_substeps.max(1));
    let whole = |s: f64| s.ceil().clamp(1.0, f64::from(u32::MAX)) as u32;
    let mut ladder: Vec<u32> = (0..opts.points.max(2))
        .map(|k| whole(base * 2f64.powi(k as i32 - opts.coarsest)))
        .collect();
    if opts.fast_end {
        let mut s = ladder.first().copied().unwrap_or(1);
        while s > 1 {
            s = s.div_ceil(2);
            ladder.push(s);
        }
    }
    ladder.sort_unstable();
    ladder.dedup();
    ladder
}

/// The ladder with the integrator's estimated stable step `estimate` among it, rounded down to
/// whole substeps a frame (`true` beside it), where no step of the ladder lies within 2% of it
/// and it is no finer than the ladder's finest (which the reference is set from).
pub fn ladder_to_estimate(
    ladder: &[u32],
    estimate: Option<f64>,
    frame_secs: f64,
) -> Vec<(u32, bool)> {
    let mut steps: Vec<(u32, bool)> = ladder.iter().map(|&s| (s, false)).collect();
    let most = ladder.iter().copied().max().unwrap_or(1);
    if let Some(e) = estimate.filter(|e| e.is_finite() && *e > 0.0) {
        let at = (frame_secs / e - 1e-9).ceil().max(1.0);
        let near = ladder
            .iter()
            .any(|&s| (at / f64::from(s) - 1.0).abs() < 0.02);
        if !near && at <= f64::from(most) {
            steps.push((at as u32, true));
            steps.sort_unstable();
        }
    }
    steps
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ladder_halves_the_step_and_reaches_one_step_a_frame() {
        let opts = LadderOptions {
            points: 4,
            coarsest: 1,
            fast_end: true,
        };
        // Hair: 20 substeps at 60 Hz; from 10 a frame (twice its step) down to 80, and up to
        // one a frame by halvings, 5/2 rounded up.
        assert_eq!(step_ladder(20, &opts), vec![1, 2, 3, 5, 10, 20, 40, 80]);
        let no_fast = LadderOptions {
            fast_end: false,
            ..opts
        };
        assert_eq!(step_ladder(20, &no_fast), vec![10, 20, 40, 80]);
        // A coarsest step above one a frame is one a frame.
        assert_eq!(step_ladder(1, &no_fast), vec![1, 2, 4]);
    }

    #[test]
    fn the_estimate_joins_the_ladder_rounded_down_to_whole_substeps() {
        let frame = 1.0 / 60.0;
        // Semi-implicit Euler on hair: 1.368e-3 s is 12.18 substeps: 13, at 1.282e-3 s.
        let steps = ladder_to_estimate(&[10, 20, 40], Some(1.368e-3), frame);
        assert_eq!(
            steps,
            vec![(10, false), (13, true), (20, false), (40, false)]
        );
        // Within 2% of a rung, or finer than the finest, or "any": the ladder alone.
        assert_eq!(
            ladder_to_estimate(&[10, 20], Some(frame / 19.9), frame).len(),
            2
        );
        assert_eq!(
            ladder_to_estimate(&[10, 20], Some(frame / 30.0), frame).len(),
            2
        );
        assert_eq!(
            ladder_to_estimate(&[10, 20], Some(f64::INFINITY), frame).len(),
            2
        );
    }
}
