//! The backward schemes' start (`physics::BackwardStep`): BDF2 keeps the last step's start and
//! blends the step's start from it (the twin of `implicit_blend_at` in
//! shaders/implicit_terms.wgsl, which keeps the same history in the solver's `work` buffer), and
//! the work guard on its Newton iterations (`residual_work`, per mass, the fourth sum of WGSL's
//! `implicit_rhs_at`).

use glam::Vec3;
use rayon::prelude::*;

use super::chunks::{CHUNK, PARALLEL_MIN_MASSES};
use crate::integrator::Integrator;
use crate::model::{Effects, Model, Pose, Spring, poses_at};
use crate::physics::{BackwardStep, NEWTON_WORK_SHARE, RESTART_PRESS_SHARE};

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

    /// The start of a step of `dt` of `integrator` (implicit Euler or BDF2) ending at `t_end`:
    /// BDF2's blend into `x` and `v`, kept out of the ground and colliders where the step's
    /// forces see them (`blend_along_surface`), or a restart where that would press a spring
    /// hard (`blend_presses`). Returns the step as taken and whether it restarted.
    pub fn start_step(
        &mut self,
        (model, springs): (&Model, &[Spring]),
        (integrator, dt, t_end): (Integrator, f32, f64),
        (x, v): (&mut [Vec3], &mut [Vec3]),
    ) -> (BackwardStep, bool) {
        let step = BackwardStep::of(integrator, dt, self.steps_taken());
        let contact = BackwardStep::restarts_at_impacts(integrator, &model.effects);
        let poses = if contact {
            poses_at(&model.effects.colliders, t_end)
        } else {
            Vec::new()
        };
        let depth = |x: Vec3| deepest_penetration(&model.effects, &poses, x);
        let shortest = |i: usize| shortest_spring(model, springs, i);
        let restarted = contact && self.blend_presses_any(step, x, &shortest, &depth);
        let step = if restarted { step.restarted() } else { step };
        let keep = integrator.scheme().history();
        let deepest = contact.then_some(&depth as &(dyn Fn(Vec3) -> (f32, Vec3) + Sync));
        self.implicit_blend(step, keep, (x, v), deepest);
        (step, restarted)
    }

    /// Whether BDF2's blend of this step (`step.history`), kept out of the colliders mass by
    /// mass (`blend_along_surface`), would move some mass back by more than
    /// `RESTART_PRESS_SHARE` of its shortest spring (`blend_presses`): the step then restarts
    /// (`BackwardStep::restarted`). `shortest` gives a mass's shortest spring's rest length and
    /// `deepest` a position's deepest contact.
    pub fn blend_presses_any(
        &self,
        step: BackwardStep,
        x: &[Vec3],
        shortest: &(dyn Fn(usize) -> f32 + Sync),
        deepest: &(dyn Fn(Vec3) -> (f32, Vec3) + Sync),
    ) -> bool {
        if self.x.is_empty() || step.history == 0.0 {
            return false;
        }
        let b = step.history;
        let presses = |(i, (x, last)): (usize, (&Vec3, &Vec3))| {
            blend_presses(b, (*x, *last), shortest(i), deepest)
        };
        if x.len() >= PARALLEL_MIN_MASSES {
            x.par_iter().zip(&self.x[..]).enumerate().any(presses)
        } else {
            x.iter().zip(&self.x).enumerate().any(presses)
        }
    }

    /// Blend the step's start into `x` and `v` (x̂ = x + history (x − x₋₁), the same for v),
    /// keeping their values before it as the next step's history. Implicit Euler keeps none; a
    /// restarted step (history 0) starts from x and v themselves. With `deepest` (a mass's
    /// deepest penetration of the ground and colliders where the step's forces see them, and
    /// that contact's outward normal), a blend that would start a mass deeper than it is starts
    /// it at its own depth and velocity (`blend_along_surface`).
    pub fn implicit_blend(
        &mut self,
        step: BackwardStep,
        keep: bool,
        (x, v): (&mut [Vec3], &mut [Vec3]),
        deepest: Option<&(dyn Fn(Vec3) -> (f32, Vec3) + Sync)>,
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
                if let Some(deepest) = deepest {
                    let (now, _) = deepest(xn);
                    (*x, *v) = blend_along_surface((*x, *v), deepest(*x), (now, vn));
                }
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

/// BDF2's blended start (x̂, v̂) of a mass, where the blend's deepest contact is at `depth` with
/// outward normal `n` and the mass itself is `now` deep moving at `v_now`: unchanged unless the
/// blend starts it deeper than it is. There its two last states lie either side of an impact,
/// and extrapolating them carries it on into the collider as if it had not been stopped, and
/// kicks it back out by a third of the speed the impact took: a flat cloth landing on a table in
/// one step started its next a third of a step deep and was thrown up with energy from nowhere
/// (docs/stability.md). Such a start is moved back out along the normal to the mass's own depth,
/// keeping its motion along the surface (a mass carried along by a moving collider stays in step
/// with its neighbours), and takes the mass's own velocity: first order across the impact, as
/// BDF2 is anywhere its motion is not smooth. Where that would press a spring hard
/// (`blend_presses`), the step restarts instead. The shaders' `blend_along_surface`.
#[inline(always)]
pub fn blend_along_surface(
    (x, v): (Vec3, Vec3),
    (depth, n): (f32, Vec3),
    (now, v_now): (f32, Vec3),
) -> (Vec3, Vec3) {
    if depth <= now {
        return (x, v);
    }
    (x + (depth - now) * n, v_now)
}

/// Whether `blend_along_surface` would move a mass now at `x` (at `last` a step ago) back by
/// more than `RESTART_PRESS_SHARE` of `shortest_m`, its shortest spring's rest length. Moved
/// back alone while its neighbours extrapolate their fall, such a mass presses its springs by
/// that much: at the jello's landing at 1/14 s the lowest layer was stopped a spacing and more
/// short of the layers above, whose start then held 44 J of elastic energy from its 7.6 J
/// start. There the whole step restarts with implicit Euler from its own start
/// (`BackwardStep::restarted`), as multistep methods restart at a discontinuity. Restarting
/// at every landing instead cost BDF2 its accuracy at ordinary steps (the jello at 1/60 s:
/// 0.26 m RMS against 9.5e-2 m with the rule; docs/stability.md). The shaders'
/// `blend_presses_at`.
#[inline(always)]
pub fn blend_presses(
    b: f32,
    (x, last): (Vec3, Vec3),
    shortest_m: f32,
    deepest: &(dyn Fn(Vec3) -> (f32, Vec3) + Sync),
) -> bool {
    let (depth, _) = deepest(x + b * (x - last));
    let (now, _) = deepest(x);
    depth - now > RESTART_PRESS_SHARE * shortest_m
}

/// The deepest a mass at `x` is in the ground or a collider at `poses`, 0 outside them all, and
/// that contact's outward normal (`blend_along_surface` takes them). The shaders'
/// `deepest_penetration`.
#[inline(always)]
pub fn deepest_penetration(effects: &Effects, poses: &[Pose], x: Vec3) -> (f32, Vec3) {
    let mut deepest = (0.0, Vec3::ZERO);
    if let Some(g) = effects.ground.as_ref() {
        let depth = g.height_m - x.y;
        if depth > 0.0 {
            deepest = (depth, Vec3::Y);
        }
    }
    for (c, pose) in effects.colliders.iter().zip(poses) {
        if let Some((depth, n)) = c.shape.penetration(pose.position_m, x)
            && depth > deepest.0
        {
            deepest = (depth, n);
        }
    }
    deepest
}

/// The rest length of mass `i`'s shortest unbroken spring, `f32::MAX` where it has none
/// (`blend_presses` takes it). The shaders' `shortest_spring`.
#[inline(always)]
pub fn shortest_spring(model: &Model, springs: &[Spring], i: usize) -> f32 {
    model
        .adjacency
        .of(i)
        .iter()
        .map(|nb| &springs[nb.spring as usize])
        .filter(|s| !s.is_broken())
        .fold(f32::MAX, |m, s| m.min(s.rest_m))
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
