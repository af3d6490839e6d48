//! The backward schemes' start (`physics::BackwardStep`): BDF2 keeps the last step's start and
//! blends the step's start from it (the twin of `implicit_blend_at` in
//! shaders/implicit_terms.wgsl, which keeps the same history in the solver's `work` buffer), and
//! the work guard on its Newton iterations (`residual_work`, per mass, the fourth sum of WGSL's
//! `implicit_rhs_at`).

use glam::Vec3;
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES};
use crate::physics::{BackwardStep, NEWTON_WORK_SHARE};

/// The last step's start (x₋₁, v₋₁), once a step has been taken; empty for implicit Euler.
#[derive(Debug, Default)]
pub struct History {
    x: Vec<Vec3>,
    v: Vec<Vec3>,
}

impl History {
    /// Whether a step has been taken since the history began (BDF2 then blends).
    pub fn steps_taken(&self) -> u64 {
        u64::from(!self.x.is_empty())
    }

    /// Blend the step's start into `x` and `v` (x̂ = x + history (x − x₋₁), the same for v),
    /// keeping their values before it as the next step's history. Implicit Euler keeps none.
    pub fn implicit_blend(
        &mut self,
        step: BackwardStep,
        keep: bool,
        x: &mut [Vec3],
        v: &mut [Vec3],
    ) {
        if !keep {
            return;
        }
        if self.x.is_empty() {
            // The first step: no history to blend (`step.history` is 0), only to keep.
            self.x = x.to_vec();
            self.v = v.to_vec();
            return;
        }
        let b = step.history;
        blend(b, x, &mut self.x);
        blend(b, v, &mut self.v);
    }
}

/// y ← y + b (y − y₋₁), y₋₁ ← y (as it was), per mass.
fn blend(b: f32, y: &mut [Vec3], last: &mut [Vec3]) {
    let body = |(y, last): (&mut [Vec3], &mut [Vec3])| {
        for (y, last) in y.iter_mut().zip(last) {
            let now = *y;
            *y = now + b * (now - *last);
            *last = now;
        }
    };
    if y.len() >= PARALLEL_MIN_MASSES {
        y.par_chunks_mut(CHUNK)
            .zip(last.par_chunks_mut(CHUNK))
            .for_each(body);
    } else {
        body((y, last));
    }
}

/// The work the residual `b` (h f − M Δv) would do as an impulse −b on the iterate's velocity
/// `v` of a movable mass `m`, less `NEWTON_WORK_SHARE` of its kinetic energy: −v·b − share ½ m v²,
/// in f32 as the fourth sum of WGSL's `implicit_rhs_at`; summed over the masses
/// (`solver_sums::group_reduce`), at most 0 when BDF2's step may end
/// (`physics::NEWTON_WORK_SHARE`).
#[inline(always)]
pub fn residual_work(m: f32, v: Vec3, b: Vec3) -> f32 {
    -v.dot(b) - NEWTON_WORK_SHARE as f32 * 0.5 * m * v.dot(v)
}
