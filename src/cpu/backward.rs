//! The backward schemes' start (`physics::BackwardStep`): BDF2 keeps the last step's start and
//! blends the step's start from it (the twin of `implicit_blend_at` in
//! shaders/implicit_terms.wgsl, which keeps the same history in the solver's `work` buffer), and
//! the work guard on its Newton iterations (`residual_work`, per mass, the fourth sum of WGSL's
//! `implicit_rhs_at`).

use glam::Vec3;
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES};
use crate::model::{Effects, Pose};
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

    /// Whether BDF2's blend of this step (`step.history`) would start some mass deeper in the
    /// ground or a collider than it is (`blend_sinks`), `deepest` giving a position's deepest
    /// contact: the step then restarts (`BackwardStep::restarted`).
    pub fn blend_sinks_any(
        &self,
        step: BackwardStep,
        x: &[Vec3],
        deepest: &(dyn Fn(Vec3) -> f32 + Sync),
    ) -> bool {
        if self.x.is_empty() || step.history == 0.0 {
            return false;
        }
        let b = step.history;
        let sinks = |(x, last): (&Vec3, &Vec3)| blend_sinks(b, *x, *last, deepest);
        if x.len() >= PARALLEL_MIN_MASSES {
            x.par_iter().zip(&self.x[..]).any(sinks)
        } else {
            x.iter().zip(&self.x).any(sinks)
        }
    }

    /// Blend the step's start into `x` and `v` (x̂ = x + history (x − x₋₁), the same for v),
    /// keeping their values before it as the next step's history. Implicit Euler keeps none; a
    /// restarted step (history 0) starts from x and v themselves.
    pub fn implicit_blend(
        &mut self,
        step: BackwardStep,
        keep: bool,
        (x, v): (&mut [Vec3], &mut [Vec3]),
    ) {
        if !keep {
            return;
        }
        if self.x.is_empty() || step.history == 0.0 {
            // The first step, or a restart: no history to blend, only to keep.
            self.x.clear();
            self.x.extend_from_slice(x);
            self.v.clear();
            self.v.extend_from_slice(v);
            return;
        }
        let b = step.history;
        let body = |((x, v), (lx, lv)): Chunks| {
            for (((x, v), lx), lv) in x.iter_mut().zip(v).zip(lx).zip(lv) {
                let (xn, vn) = (*x, *v);
                *x = xn + b * (xn - *lx);
                *v = vn + b * (vn - *lv);
                *lx = xn;
                *lv = vn;
            }
        };
        if x.len() >= PARALLEL_MIN_MASSES {
            x.par_chunks_mut(CHUNK)
                .zip(v.par_chunks_mut(CHUNK))
                .zip(
                    self.x
                        .par_chunks_mut(CHUNK)
                        .zip(self.v.par_chunks_mut(CHUNK)),
                )
                .for_each(body);
        } else {
            body(((x, v), (&mut self.x[..], &mut self.v[..])));
        }
    }
}

/// A chunk of the masses' positions and velocities, and of their history, blended together.
type Chunks<'a> = (
    (&'a mut [Vec3], &'a mut [Vec3]),
    (&'a mut [Vec3], &'a mut [Vec3]),
);

/// Whether BDF2's blend x + b (x − x₋₁) would start a mass now at `x` (at `last` a step ago)
/// deeper in the ground or a collider than it is. Its two last states then lie either side of
/// an impact: extrapolating them carries it on into the collider as if it had not been
/// stopped, and kicks it back out with a third of the speed the impact took (a flat cloth
/// landing on a table was thrown up with energy from nowhere). Moving such masses back alone
/// stopped a body's lowest layer while the layers above extrapolated their fall: the jello's
/// blend after its landing at 1/14 s held 44 J of elastic energy from its 7.6 J start. So
/// the whole step restarts with implicit Euler from its own start (`BackwardStep::restarted`),
/// first order across the impact, as BDF2 is anywhere its motion is not smooth
/// (docs/stability.md). The shaders' `blend_sinks`.
#[inline(always)]
pub fn blend_sinks(b: f32, x: Vec3, last: Vec3, deepest: &(dyn Fn(Vec3) -> f32 + Sync)) -> bool {
    deepest(x + b * (x - last)) > deepest(x)
}

/// The deepest a mass at `x` is in the ground or a collider at `poses`, 0 outside them all
/// (`blend_sinks` compares two). The shaders' `deepest_penetration`.
#[inline(always)]
pub fn deepest_penetration(effects: &Effects, poses: &[Pose], x: Vec3) -> f32 {
    let mut deepest = 0.0f32;
    if let Some(g) = effects.ground.as_ref() {
        deepest = deepest.max(g.height_m - x.y);
    }
    for (c, pose) in effects.colliders.iter().zip(poses) {
        if let Some((depth, _)) = c.shape.penetration(pose.position_m, x) {
            deepest = deepest.max(depth);
        }
    }
    deepest
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
