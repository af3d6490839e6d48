//! Recording dispatches: a kernel's pipeline, its bind groups and stage slot, and its workgroup
//! count, all as the kernel table says.

use std::sync::atomic::Ordering;
use std::time::Instant;

use super::bindings::Group;
use super::context::GpuContext;
use super::dispatch::{Dispatch, SLOTS_PER_STEP};
use super::pipelines::Pipelines;
use super::resources::Resources;
use super::stages::StageSlots;
use crate::backend::{BackendError, Internal, Misplanned, StopFlags};

/// What recording a dispatch needs of the backend.
#[derive(Clone, Copy)]
pub struct Dispatcher<'a> {
    pub pipelines: &'a Pipelines,
    pub resources: &'a Resources,
    pub stages: &'a StageSlots,
}

impl Dispatcher<'_> {
    /// Record `d` with its slot counted from `base`. A kernel this run lacks (its effect is
    /// absent) or a state the kernel does not read is an internal error.
    pub fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        d: Dispatch,
        base: u32,
    ) -> Result<(), BackendError> {
        let spec = d.kernel.spec();
        let internal = |why| {
            BackendError::Internal(Internal::Dispatch {
                kernel: spec.entry,
                why,
            })
        };
        let pipeline = self.pipelines.get(d.kernel);
        // A colour's kernel binds its colour's group and runs over its colour's springs or masses.
        // A multigrid kernel binds its level's group and runs over its level's nodes.
        let (group0, groups) = match d.colour {
            Some(pass) => self.resources.colour_pass(pass),
            None if spec.group == Group::Multigrid => {
                self.resources.level_pass(d.level, spec.threads)
            }
            None => (
                self.resources.group(spec.group),
                self.resources.workgroups.of(spec.threads),
            ),
        };
        let (Some(pipeline), Some(group0), Some(groups)) = (pipeline, group0, groups) else {
            return Err(internal(Misplanned::WithoutEffect));
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group0, &[]);
        let slot = base + d.slot;
        match (spec.reads_state, spec.flows, d.state, d.flow) {
            (true, false, Some(s), None) => pass.set_bind_group(1, self.resources.state(s), &[]),
            (false, true, None, Some(f)) => {
                let flow = self
                    .resources
                    .flow(f)
                    .ok_or_else(|| internal(Misplanned::NoSuchFlow))?;
                pass.set_bind_group(1, flow, &[]);
                // The step's end slot, for the projection's collider poses.
                let end = slot / SLOTS_PER_STEP * SLOTS_PER_STEP + SLOTS_PER_STEP - 1;
                self.stages.bind_as(pass, 3, end);
            }
            (false, false, None, None) => {
                if spec.all_slots {
                    self.stages.bind_words(pass, 3);
                }
            }
            _ => return Err(internal(Misplanned::WrongState)),
        }
        self.stages.bind_as(pass, 2, slot);
        pass.dispatch_workgroups(groups.0, groups.1, 1);
        Ok(())
    }

    pub fn dispatch_all(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        ds: &[Dispatch],
        base: u32,
    ) -> Result<(), BackendError> {
        ds.iter().try_for_each(|&d| self.dispatch(pass, d, base))
    }

    /// Record `plan` into `enc` and on, in passes labelled `label`, submitting on `ctx` as the
    /// encoder fills; returns the encoder holding the rest (all of a short plan), which the
    /// caller finishes and submits, and how many of the plan's dispatches it recorded (all,
    /// unless a stop came).
    ///
    /// A long plan is where a stop must not wait for the end. Each submission waits for the one
    /// before it to run (so at most two are queued, and the device stays busy), holds about
    /// [`SUBMISSION_SECS`] of work as the last waits measured it, and once `stop` is asked
    /// nothing more is recorded. The size timed is kept in the context from one call to the
    /// next, and each call's first submission is small (`FIRST_SUBMISSION`): the device starts
    /// while the host records the rest, and a plan that fits one timed submission after it goes
    /// without a wait (a wait at a call's start also waits for the last call's work, which cost
    /// VBD's 60-step batches 7–10% on an H100 and H200). The steps are then cut short, and the caller's caller drops
    /// their frame (`Backend::watch`). The split never changes the dispatches or their order.
    pub fn encode_in_submissions(
        &self,
        ctx: &GpuContext,
        stop: &StopFlags,
        mut enc: wgpu::CommandEncoder,
        label: &'static str,
        plan: &[Dispatch],
    ) -> Result<(wgpu::CommandEncoder, usize), BackendError> {
        // The first submission is small whatever was timed, so that the device starts while
        // the rest is recorded; then each holds what was timed.
        let timed = ctx.submission_dispatches.load(Ordering::Relaxed);
        let mut size = match timed {
            0 => FIRST_SUBMISSION,
            timed => FIRST_SUBMISSION.min(timed),
        };
        let mut start = 0;
        let mut queued: Option<(wgpu::SubmissionIndex, usize)> = None;
        let mut last_done = Instant::now();
        while plan.len() - start > size {
            if stop.asked() {
                return Ok((enc, start));
            }
            let chunk = &plan[start..start + size];
            in_pass(&mut enc, label, |pass| self.dispatch_all(pass, chunk, 0))?;
            let index = ctx.queue.submit([enc.finish()]);
            if let Some((before, dispatches)) = queued.replace((index, chunk.len())) {
                ctx.wait_for(before)?;
                let secs = last_done.elapsed().as_secs_f64() / dispatches as f64;
                last_done = Instant::now();
                let fits = (SUBMISSION_SECS / secs.max(1e-9)) as usize;
                size = fits.clamp(
                    FIRST_SUBMISSION / 8,
                    (4 * size).min(MOST_DISPATCHES_PER_SUBMISSION),
                );
                ctx.submission_dispatches.store(size, Ordering::Relaxed);
            } else if timed > 0 {
                size = timed;
            }
            start += chunk.len();
            enc = ctx.encoder(label);
        }
        if stop.asked() {
            return Ok((enc, start));
        }
        in_pass(&mut enc, label, |pass| {
            self.dispatch_all(pass, &plan[start..], 0)
        })?;
        Ok((enc, plan.len()))
    }
}

/// The most dispatches one submission of steps records. Mesa 25.0.7's lavapipe crashes (a
/// segfault in its queue thread) on a command buffer of more than about 65 000 dispatches: VBD on
/// the small pinned jello, `bench/scenes/jello-4-pinned.toml` (13 colours, a dispatch per colour and sweep, 200 sweeps)
/// ran 25 steps in one submission (65 100 dispatches) and crashed at 26 (67 704). A frame's steps
/// beyond this many go in several submissions, in order (docs/drivers.md).
pub const MOST_DISPATCHES_PER_SUBMISSION: usize = 16_384;

/// The first submission of a long plan, before any has been timed.
const FIRST_SUBMISSION: usize = 512;

/// The work one submission of a long plan aims at, so that a stop waits for about two of them
/// (`encode_in_submissions`): 0.1 s, a few hundred of VBD's dispatches on the 1 000-mass jello
/// on lavapipe, the most allowed on a GPU.
pub const SUBMISSION_SECS: f64 = 0.1;

/// Record `body` in one compute pass of `enc`.
pub fn in_pass<T>(
    enc: &mut wgpu::CommandEncoder,
    label: &'static str,
    body: impl FnOnce(&mut wgpu::ComputePass<'_>) -> Result<T, BackendError>,
) -> Result<T, BackendError> {
    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    });
    body(&mut pass)
}
