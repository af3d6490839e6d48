//! Implicit Euler on the GPU, the host's side of `shaders/implicit.wgsl`: the same Newton
//! iterations and conjugate-gradient solves as the CPU backend's `implicit_step`, with the same
//! stopping rules, taken one of two ways (`plan::path`):
//! - a small system's step is one dispatch of `implicit_step`, one workgroup deciding every
//!   stopping rule on the device;
//! - a larger one's step is a dispatch per pass, two per CG iteration. The host cannot know how
//!   many iterations a solve will take without waiting for it, so it encodes the whole frame with
//!   budgets ([`Budgets`]: Newton iterations per step, CG iterations per Newton iteration, from
//!   what earlier frames took) and the kernels past a finished solve or step return at once. A
//!   solve or step that needs more than its budget halts the frame on the device; the host reads
//!   one small record after the frame, and if it halted, restores the frame's starting state
//!   (copied on the device as the frame began), raises the budgets and replays it. The replay
//!   computes exactly what an unhalted frame would have: budgets only decide which dispatches are
//!   encoded, never what a dispatch computes.
//!
//! Either way nothing waits inside a frame, each step books its CG iterations and residual on the
//! device, and the frame's snapshot reads them back (`readback.rs`).

use super::super::context::{GpuContext, ReadBackOf};
use super::super::dispatch::{Dispatch, SLOTS_PER_STEP};
use super::super::encode::Dispatcher;
use super::super::layout::FrameSolve;
use super::super::resources::SolverBuffers;
use super::plan::*;
use crate::backend::{BackendError, Internal, StopFlags};
use crate::physics::{CG_MAX_ITERATIONS, NEWTON_MAX_ITERATIONS};

const NEWTON_SLOTS: usize = NEWTON_MAX_ITERATIONS as usize;

/// How many Newton iterations each step of a frame encodes, and how many CG iterations each
/// Newton iteration's solve encodes (per-pass path).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Budgets {
    pub newton: u32,
    pub cg: [u32; NEWTON_SLOTS],
}

impl Default for Budgets {
    /// A run's first frame: a guess, raised where it falls short.
    fn default() -> Self {
        Self {
            newton: 3,
            cg: [16; NEWTON_SLOTS],
        }
    }
}

impl Budgets {
    /// After a frame that halted: twice the budget that ran out (and at least that for the
    /// Newton iterations after it, whose solves are alike), within the stopping rules' maxima.
    #[must_use]
    pub fn raised(mut self, overran: u32) -> Self {
        if overran & FrameSolve::NEWTON_OVERRAN != 0 {
            self.newton = (2 * self.newton).min(NEWTON_MAX_ITERATIONS);
        }
        if let Some(j) = (0..NEWTON_SLOTS).find(|&j| overran & (1 << j) != 0) {
            let more = (2 * self.cg[j]).min(CG_MAX_ITERATIONS);
            for b in &mut self.cg[j..] {
                *b = (*b).max(more);
            }
        }
        self
    }

    /// After frames that ran through (`recent`, the last few): the most their steps took, and a
    /// margin on CG. A replay costs a whole frame; an unused iteration, dispatches that return at
    /// once (on lavapipe about 80 µs each, as much as one that works: a spare Newton iteration
    /// made cloth-64's steps slower than the replays it saved). So the budgets follow the most of
    /// several frames, not the last one's, and Newton gets no margin.
    #[must_use]
    pub fn fitted<'a>(self, recent: impl IntoIterator<Item = &'a FrameSolve>) -> Self {
        let mut newton = 0;
        let mut cg = [0; NEWTON_SLOTS];
        for took in recent {
            newton = newton.max(took.newton_most);
            for (j, c) in cg.iter_mut().enumerate() {
                *c = (*c).max(took.cg_most[j]);
            }
        }
        let mut fitted = self;
        fitted.newton = newton.clamp(1, NEWTON_MAX_ITERATIONS);
        for (j, (b, most)) in fitted.cg.iter_mut().zip(cg).enumerate() {
            // A Newton iteration none of them reached keeps its budget.
            if (j as u32) < newton && most > 0 {
                *b = (most + most / 4 + 2).min(CG_MAX_ITERATIONS);
            }
        }
        fitted
    }

    /// At least one iteration each (a step encoded with no Newton iteration would end unsolved
    /// and unflagged), and no more than the stopping rules allow.
    #[must_use]
    fn within_rules(mut self) -> Self {
        self.newton = self.newton.clamp(1, NEWTON_MAX_ITERATIONS);
        for b in &mut self.cg {
            *b = (*b).clamp(1, CG_MAX_ITERATIONS);
        }
        self
    }

    /// Whether `overran` can be met by larger budgets (always, unless a budget is already at its
    /// maximum, where the device never flags it).
    fn can_raise(self, overran: u32) -> bool {
        self.raised(overran) != self
    }
}

/// One frame of implicit steps, on the device.
pub struct ImplicitStep<'a> {
    pub ctx: &'a GpuContext,
    pub kernels: Dispatcher<'a>,
    /// What ends a frame's steps between submissions (`Backend::watch`).
    pub stop: &'a StopFlags,
    pub solver: &'a SolverBuffers,
    /// The passes every integrator runs after its step (plasticity, tearing).
    pub post: &'a [Dispatch],
    /// The multigrid cycle, when it preconditions the CG: on the per-pass path, a Newton
    /// iteration's passes after cg_begin (the levels' blocks) and a cycle's
    /// (`gpu/multigrid.rs`); the one-workgroup step runs its own (`mg_implicit_step`).
    pub multigrid: Option<(&'a [Dispatch], &'a [Dispatch])>,
    /// Whether a step may restart across an impact (BDF2 with contact): each step's passes
    /// then begin with the restart test.
    pub restarts: bool,
}

/// `ds` added to `plan`, each at its own slot counted from stage slot `slot`.
fn at_slot(plan: &mut Vec<Dispatch>, ds: &[Dispatch], slot: u32) {
    plan.extend(ds.iter().map(|d| Dispatch {
        slot: slot + d.slot,
        ..*d
    }));
}

/// How a frame on the per-pass path went: what its steps took (its record), the budgets it ran
/// through with, and how many times it was replayed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameOutcome {
    pub took: FrameSolve,
    pub budgets: Budgets,
    pub replays: u32,
}

impl ImplicitStep<'_> {
    /// `steps` steps of a small system, one dispatch each (with the post-step passes), in one
    /// submission (more where they are many, `encode_in_submissions`); nothing waits. Step k
    /// reads stage slot 4k + 3, its end.
    pub fn run_in_group(&self, steps: u32) -> Result<(), BackendError> {
        let label = "implicit steps";
        let step = match self.multigrid {
            Some(_) => &IN_GROUP_MULTIGRID[..],
            None => &IN_GROUP[..],
        };
        let mut plan = Vec::new();
        for k in 0..steps {
            let slot = SLOTS_PER_STEP * k + 3;
            at_slot(&mut plan, step, slot);
            self.post_step(&mut plan, slot);
        }
        let enc = self.ctx.encoder(label);
        let (enc, _) = self
            .kernels
            .encode_in_submissions(self.ctx, self.stop, enc, label, &plan)?;
        self.ctx.queue.submit([enc.finish()]);
        Ok(())
    }

    /// The passes every integrator runs after its step; they read the step's slot too.
    fn post_step(&self, plan: &mut Vec<Dispatch>, slot: u32) {
        plan.extend(self.post.iter().map(|d| Dispatch { slot, ..*d }));
    }

    /// `steps` backward Euler steps of a larger system, encoded with `budgets`, replayed with
    /// larger ones until no step or solve runs out: one wait for the device per run through.
    /// Step k reads stage slot 4k + 3, its end (backward Euler evaluates forces there).
    pub fn run_frame(&self, steps: u32, budgets: Budgets) -> Result<FrameOutcome, BackendError> {
        let label = "implicit frame";
        let mut budgets = budgets.within_rules();
        let mut replays = 0;
        let mut enc = self.ctx.encoder(label);
        // The frame's start, to replay it from.
        for (live, start) in &self.solver.frame_start {
            enc.copy_buffer_to_buffer(live, 0, start, 0, live.size());
        }
        loop {
            self.begin_frame(budgets);
            let mut plan = Vec::new();
            for k in 0..steps {
                self.plan_step(&mut plan, SLOTS_PER_STEP * k + 3, budgets);
            }
            let (rest, _) = self
                .kernels
                .encode_in_submissions(self.ctx, self.stop, enc, label, &plan)?;
            let took = self.submit_and_read(rest)?;
            // A stopped frame is dropped: nothing to replay.
            if took.overran == 0 || self.stop.asked() {
                return Ok(FrameOutcome {
                    took,
                    budgets,
                    replays,
                });
            }
            if !budgets.can_raise(took.overran) {
                return Err(BackendError::Internal(Internal::BudgetAtMaximum {
                    overran: took.overran,
                }));
            }
            budgets = budgets.raised(took.overran);
            replays += 1;
            enc = self.ctx.encoder(label);
            for (live, start) in &self.solver.frame_start {
                enc.copy_buffer_to_buffer(start, 0, live, 0, live.size());
            }
        }
    }

    /// The frame's record, zeroed, with the Newton budget its steps are encoded with.
    fn begin_frame(&self, budgets: Budgets) {
        let record = FrameSolve {
            newton_budget: budgets.newton,
            ..FrameSolve::default()
        };
        self.ctx.queue.write_buffer(
            &self.solver.scratch,
            FrameSolve::OFFSET,
            bytemuck::bytes_of(&record),
        );
    }

    /// One step's dispatches, at stage slot `slot`: its Newton iterations, each with its
    /// solve's budget of CG iterations, then the post-step passes.
    fn plan_step(&self, plan: &mut Vec<Dispatch>, slot: u32, budgets: Budgets) {
        at_slot(plan, begin(self.restarts), slot);
        // With multigrid, each z is the cycle's on the residual cg_advance (or forces_and_rhs)
        // left, made before cg_apply reads it; the cycle's levels are linearised once per
        // Newton iteration.
        let (linearise, cycle): (&[Dispatch], &[Dispatch]) = self.multigrid.unwrap_or((&[], &[]));
        let [newton_begin @ .., first_apply] = NEWTON_BEGIN;
        let [advance, apply] = CG_ITERATION;
        for &cg in &budgets.cg[..budgets.newton as usize] {
            at_slot(plan, &newton_begin, slot);
            at_slot(plan, linearise, slot);
            at_slot(plan, cycle, slot);
            at_slot(plan, &[first_apply], slot);
            for _ in 0..cg {
                at_slot(plan, &[advance], slot);
                at_slot(plan, cycle, slot);
                at_slot(plan, &[apply], slot);
            }
            at_slot(plan, &NEWTON_END, slot);
        }
        at_slot(plan, &END, slot);
        self.post_step(plan, slot);
    }

    /// Submit `enc` with a copy of the frame's record, and wait for it.
    fn submit_and_read(&self, mut enc: wgpu::CommandEncoder) -> Result<FrameSolve, BackendError> {
        let s = self.solver;
        enc.copy_buffer_to_buffer(
            &s.scratch,
            FrameSolve::OFFSET,
            &s.status,
            0,
            FrameSolve::SIZE,
        );
        let index = self.ctx.queue.submit([enc.finish()]);
        let slice = s.status.slice(..);
        self.ctx
            .map_and_wait(&slice, index, ReadBackOf::SolverStatus)?;
        let record = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| self.ctx.read_back_failed(ReadBackOf::SolverStatus, e))?;
            bytemuck::pod_read_unaligned::<FrameSolve>(&data[..FrameSolve::SIZE as usize])
        };
        s.status.unmap();
        Ok(record)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(newton_most: u32, cg: &[u32]) -> FrameSolve {
        let mut r = FrameSolve {
            newton_most,
            ..FrameSolve::default()
        };
        r.cg_most[..cg.len()].copy_from_slice(cg);
        r
    }

    /// A budget that ran out doubles, and never past the stopping rules' maxima: replays end.
    #[test]
    fn budgets_that_ran_out_double_up_to_the_maxima() {
        let b = Budgets::default();
        let r = b.raised(1 << 1);
        assert_eq!(r.cg[0], b.cg[0]);
        assert!(r.cg[1..].iter().all(|&c| c == 2 * b.cg[1]));
        assert_eq!(r.newton, b.newton);
        let r = b.raised(FrameSolve::NEWTON_OVERRAN);
        assert_eq!((r.newton, r.cg), (2 * b.newton, b.cg));
        let mut top = b;
        for _ in 0..20 {
            top = top.raised(FrameSolve::NEWTON_OVERRAN | 1);
        }
        assert_eq!(top.newton, NEWTON_MAX_ITERATIONS);
        assert!(top.cg.iter().all(|&c| c == CG_MAX_ITERATIONS));
        assert!(!top.can_raise(FrameSolve::NEWTON_OVERRAN | 1));
        assert!(b.can_raise(1));
        // Budgets set from outside are held to at least one iteration, so they can grow.
        let none = Budgets {
            newton: 0,
            cg: [0; NEWTON_SLOTS],
        }
        .within_rules();
        assert_eq!((none.newton, none.cg), (1, [1; NEWTON_SLOTS]));
        assert!(none.can_raise(FrameSolve::NEWTON_OVERRAN | 1));
    }

    /// After a frame, each budget fits what its steps took with a margin; a Newton iteration no
    /// step reached keeps its budget.
    #[test]
    fn budgets_fit_what_the_frame_took() {
        let b = Budgets::default().fitted(&[record(2, &[40, 8, 99])]);
        assert_eq!(b.newton, 2);
        assert_eq!(b.cg[..3], [52, 12, 16]);
        let b = Budgets::default().fitted(&[record(1, &[190])]);
        assert_eq!(b.cg[0], CG_MAX_ITERATIONS);
        // The most of several frames.
        let b = Budgets::default().fitted(&[record(3, &[4, 2, 1]), record(2, &[8, 1])]);
        assert_eq!((b.newton, b.cg[..4].to_vec()), (3, vec![12, 4, 3, 16]));
    }
}
