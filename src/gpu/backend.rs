//! The GPU backend: a run's device, pipelines and buffers, and the `Backend` it implements.
//! Substeps are encoded into one submission; the host waits on the GPU only when a snapshot is
//! due, and the next frame steps while a snapshot is read back.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use super::context::{DeviceError, GpuContext, ReadBackOf};
use super::dispatch::why_not_in_group;
use super::encode::{Dispatcher, in_pass};
use super::implicit::{self, Budgets, Path};
use super::layout::FrameSolve;
use super::limits::check_fits;
use super::loop_budget::LoopBudget;
use super::multigrid::Layout as MultigridLayout;
use super::pipelines::{Layouts, Needed, Pipelines};
use super::plan::{self, ExplicitPath};
use super::readback::{self, Pending, ReadBack, SolveRecord, StagingLayout};
use super::resources::Resources;
use super::stages::{Clock, StageSlots};
use super::tuning::{Tuning, specialise};
use crate::backend::{
    Backend, BackendError, Internal, RUNAWAY_SPEED_M_PER_S, StopFlags, find_divergence,
};
use crate::integrator::{Integrator, Step};
use crate::model::Model;
use crate::stability::divergence::Divergence;
use crate::state::{Energies, Ledger, Snapshot, State, StepStats};

/// Frames whose records implicit Euler's budgets follow (per-pass path).
pub(super) const RECENT_FRAMES: usize = 8;

pub struct GpuBackend {
    pub(super) ctx: GpuContext,
    pub(super) model: Arc<Model>,
    pub(super) integrator: Integrator,
    pub(super) clock: Clock,
    /// Energy folded out of the per-mass ledger at each snapshot, summed in f64.
    ledger: Ledger,
    pub(super) verlet_primed: bool,
    pub(super) pipelines: Pipelines,
    pub(super) layouts: Layouts,
    pub(super) resources: Resources,
    pub(super) stages: StageSlots,
    /// Bytes of GPU memory held by the simulation's buffers.
    pub memory_bytes: u64,
    pub(super) advance_started: Option<Instant>,
    /// Snapshots asked for and not yet collected, oldest first.
    pending: VecDeque<Pending>,
    /// Snapshots returned by the recorder, their buffers reused.
    spare: Vec<Snapshot>,
    /// Implicit Euler: how its steps run, and the budgets the next frame is encoded with (the
    /// path of a dispatch per pass).
    pub(super) implicit_path: Option<Path>,
    pub(super) budgets: Budgets,
    /// What the last few frames' steps took (the budgets follow the most of them).
    pub(super) recent_frames: VecDeque<FrameSolve>,
    /// Frames replayed with larger budgets since the run began.
    pub(super) replays: u64,
    /// Explicit integrators: fused steps or a pass per stage (`plan::fused_links`).
    pub(super) explicit_path: ExplicitPath,
    /// `fused_frame` keeps the state in workgroup memory between a submission's steps.
    frame_state_in_workgroup: bool,
    /// How long the adapter lets a shader invocation loop, measured as the device opened.
    pub(super) loop_budget: LoopBudget,
    /// What ends the steps of an `advance` between submissions (`Backend::watch`).
    pub(super) stop: StopFlags,
    /// The dispatches the last explicit or sweeping `advance` recorded, of those it planned.
    pub(super) last_recorded: (usize, usize),
}

impl GpuBackend {
    /// The GPU backend stepping `model` as `step` says, on the adapter whose name contains
    /// `adapter` (the best one when `None`).
    pub fn new(model: Arc<Model>, step: Step, adapter: Option<&str>) -> Result<Self, BackendError> {
        let tuning = Tuning::for_run(&model, step);
        Self::with_tuning(model, step, adapter, tuning)
    }

    /// As `new`, with implicit Euler's steps taken by `implicit` whatever the system's
    /// size, and explicit steps taken on `explicit` where the run allows it, else on the next
    /// path open to it (`InGroup`, then `Fused`, then `General`): the tests compare the paths on
    /// one scene.
    #[doc(hidden)]
    pub fn with_paths(
        model: Arc<Model>,
        step: Step,
        adapter: Option<&str>,
        (implicit, explicit): (Path, ExplicitPath),
    ) -> Result<Self, BackendError> {
        let tuning = Tuning {
            implicit,
            explicit,
            ..Tuning::for_run(&model, step)
        };
        Self::with_tuning(model, step, adapter, tuning)
    }

    /// As `new`, with the choices `tuning` fixes (the tests and the benchmark examples compare
    /// them on one scene).
    #[doc(hidden)]
    pub fn with_tuning(
        model: Arc<Model>,
        step: Step,
        adapter: Option<&str>,
        tuning: Tuning,
    ) -> Result<Self, BackendError> {
        let ctx = GpuContext::open(adapter)?;
        let loop_budget = LoopBudget::measure(&ctx);
        let tuning = tuning.within(loop_budget);
        let (path, explicit) = (tuning.implicit, tuning.explicit);
        let Step {
            integrator,
            dt_secs,
            ..
        } = step;
        let implicit = integrator.newton();
        integrator
            .supports(&model.effects)
            .map_err(DeviceError::Unsupported)?;
        check_fits(&ctx, &model, integrator)?;
        let device = &ctx.device;
        let storage_buffers = ctx.limits.max_storage_buffers_per_shader_stage;
        let links = match explicit {
            ExplicitPath::InGroup | ExplicitPath::Fused => {
                plan::fused_links(&model, integrator, storage_buffers).ok()
            }
            ExplicitPath::General => None,
        };
        let small = || why_not_in_group(&model, integrator, ctx.info.device_type).is_none();
        let explicit = match (&links, explicit) {
            (None, _) => ExplicitPath::General,
            (Some(_), ExplicitPath::InGroup) if small() => ExplicitPath::InGroup,
            (Some(_), _) => ExplicitPath::Fused,
        };
        let multigrid = implicit
            .then(|| MultigridLayout::for_run(&model, tuning.preconditioner, &ctx.limits))
            .flatten();
        let needed = Needed {
            implicit: implicit.then_some(path),
            multigrid: multigrid.is_some(),
            springs_change: model.effects.springs_change(),
            mass_contact: model.effects.self_collision.is_some(),
            xpbd: integrator == Integrator::Xpbd,
            vbd: integrator == Integrator::Vbd,
            fused: explicit == ExplicitPath::Fused,
            fused_in_group: explicit == ExplicitPath::InGroup,
        };
        let layouts = Layouts::new(device, needed);
        // The per-pass kernels' grid; the one-workgroup step has none.
        let grid = |path| match path {
            Path::Passes => implicit::solver_groups(model.mass_count(), ctx.info.device_type),
            Path::InGroup => 1,
        };
        let mut resources = Resources::new(
            device,
            &ctx.limits,
            (&layouts, links.as_ref()),
            &model,
            step,
            (
                needed.implicit.map(|path| (path, grid(path))),
                multigrid.as_ref(),
            ),
        );
        let run = (model.as_ref(), step, explicit, needed.implicit);
        let (constants, frame_state_in_workgroup) =
            specialise(&ctx, run, &tuning, links.as_ref(), &mut resources);
        let pipelines = Pipelines::new(device, &layouts, &constants, needed);
        let stages = StageSlots::new(
            device,
            layouts.stages(),
            ctx.limits.min_uniform_buffer_offset_alignment,
            model.effects.colliders.len(),
        );
        let backend = Self {
            memory_bytes: resources.memory_bytes,
            ctx,
            model,
            integrator,
            clock: Clock::new(dt_secs, integrator),
            ledger: Ledger::default(),
            verlet_primed: false,
            pipelines,
            layouts,
            resources,
            stages,
            advance_started: None,
            pending: VecDeque::new(),
            spare: Vec::new(),
            implicit_path: needed.implicit,
            budgets: Budgets::default(),
            recent_frames: VecDeque::new(),
            replays: 0,
            explicit_path: explicit,
            frame_state_in_workgroup,
            loop_budget,
            stop: StopFlags::default(),
            last_recorded: (0, 0),
        };
        backend.ctx.check()?;
        Ok(backend)
    }

    /// Implicit Euler's per-pass path: the budgets the next frame is encoded with (the tests
    /// set them too small, to have frames replayed).
    #[doc(hidden)]
    pub fn set_implicit_budgets(&mut self, budgets: Budgets) {
        self.budgets = budgets;
    }

    /// The coarse levels of the multigrid cycle that preconditions implicit Euler's CG on the
    /// per-pass path, 0 when block Jacobi does.
    pub fn multigrid_levels(&self) -> u32 {
        self.resources.multigrid.as_ref().map_or(0, |m| m.levels)
    }

    /// Implicit Euler's per-pass path: the frames replayed since the run began, because a step
    /// or solve needed more iterations than the frame was encoded with.
    pub fn implicit_replays(&self) -> u64 {
        self.replays
    }

    pub(super) fn kernels(&self) -> Dispatcher<'_> {
        Dispatcher {
            pipelines: &self.pipelines,
            resources: &self.resources,
            stages: &self.stages,
        }
    }

    /// Make room for `slots` stage slots.
    pub(super) fn reserve_stage_slots(&mut self, slots: u32) {
        self.stages
            .reserve(&self.ctx.device, self.layouts.stages(), slots);
    }

    /// How this run's explicit steps are dispatched.
    pub fn explicit_path(&self) -> ExplicitPath {
        self.explicit_path
    }

    /// Whether the steps in one workgroup keep the state in workgroup memory.
    pub fn frame_state_in_workgroup(&self) -> bool {
        self.frame_state_in_workgroup
    }

    /// Whether XPBD's or VBD's sweeps take one workgroup (`vbd_sweeps`, `xpbd_sweeps`).
    pub fn sweeps_in_group(&self) -> bool {
        self.resources.sweeps().one_group
    }

    fn staging_layout(&self) -> StagingLayout {
        StagingLayout::new(
            self.model.mass_count(),
            self.model.spring_count(),
            self.resources.workgroups.partial_count(),
        )
    }

    /// Run the reductions and copy what a snapshot needs (and `with_velocity`, the velocities) to a
    /// free staging buffer, without waiting: returns which buffer and the submission to wait for.
    fn submit_read_back(
        &mut self,
        with_velocity: bool,
    ) -> Result<(usize, wgpu::SubmissionIndex), BackendError> {
        let k = (0..2)
            .find(|k| self.pending.iter().all(|p| p.staging != *k))
            .ok_or(BackendError::Internal(Internal::SnapshotBuffersBusy))?;
        // The reductions' stage slot: the current time, after the stepping slots.
        let slot = self.stages.last();
        let stage = self.clock.stage_at(&self.model, self.clock.time_secs);
        self.stages.write(&self.ctx.queue, slot, [stage]);
        let e = &self.model.effects;
        let which = (
            self.model.spring_count() > 0,
            e.springs_change(),
            e.self_collision.map(|_| self.list_build()),
        );
        let mut enc = self.ctx.encoder("snapshot");
        in_pass(&mut enc, "reduce", |pass| {
            readback::encode_reductions(&self.kernels(), pass, slot, which)
        })?;
        let at = self.staging_layout();
        readback::copy_to_staging(&mut enc, &self.resources, at, k, with_velocity);
        let index = self.ctx.queue.submit([enc.finish()]);
        Ok((k, index))
    }

    /// Wait for staging buffer `k` (submission `index`) and decode it; folds the ledger.
    fn finish_read_back(
        &mut self,
        k: usize,
        index: wgpu::SubmissionIndex,
        with_velocity: bool,
        buffers: (Vec<glam::Vec3>, Vec<f32>),
    ) -> Result<ReadBack, BackendError> {
        let staging = &self.resources.staging[k];
        let slice = staging.slice(..);
        self.ctx.map_and_wait(&slice, index, ReadBackOf::Snapshot)?;
        let out = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| self.ctx.read_back_failed(ReadBackOf::Snapshot, e))?;
            let flags = (with_velocity, self.model.effects.tearing);
            readback::decode(&data, self.staging_layout(), flags, buffers)
        };
        staging.unmap();
        self.ledger.damping_j += out.ledger[0];
        self.ledger.drag_j += out.ledger[1];
        self.ledger.contact_j += out.ledger[2];
        self.ledger.collider_work_j += out.ledger[3];
        self.ledger.plastic_j += out.released;
        Ok(out)
    }

    /// The divergence of a collected frame, if its state went bad. The step is the first bad
    /// one, as the update kernels flagged it; the mass and spring are read off the state now.
    fn divergence(&mut self, rb: &ReadBack, frame: &Pending) -> Option<Box<Divergence>> {
        if rb.first_bad_step.is_none() && !rb.non_finite && rb.max_speed <= RUNAWAY_SPEED_M_PER_S {
            return None;
        }
        let state = self.state_now().ok()?;
        let dt = f64::from(self.clock.dt);
        let mut d = find_divergence(&self.model, &state, self.integrator, dt)?;
        if let Some(k) = rb.first_bad_step {
            let later = u64::from(frame.stats.substeps.saturating_sub(k + 1));
            d.step = frame.steps - later;
            d.time_secs = frame.time_secs - later as f64 * dt;
        }
        Some(d)
    }

    /// Reductions, copy and wait in one: for tests, divergence reports and `state()`.
    fn state_now(&mut self) -> Result<State, BackendError> {
        let (k, index) = self.submit_read_back(true)?;
        let rb = self.finish_read_back(k, index, true, (Vec::new(), Vec::new()))?;
        Ok(State {
            x: rb.positions,
            v: rb.velocities,
            time_secs: self.clock.time_secs,
            steps: self.clock.steps,
            ledger: self.ledger,
        })
    }

    /// The frame's solve figures as booked on the device: Newton's and CG's, or VBD's residual.
    fn with_solve(&self, stats: StepStats, solve: SolveRecord) -> StepStats {
        match self.integrator {
            Integrator::Implicit | Integrator::Bdf2 => StepStats {
                solver_iterations: solve.cg_iterations,
                solver_residual: f64::from(solve.cg_residual),
                newton_iterations: solve.newton_iterations,
                rule: Some(solve.rule()),
                ..stats
            },
            Integrator::Vbd => StepStats {
                solver_iterations: self.resources.sweeps().iterations,
                solver_residual: f64::from(solve.step_residual),
                rule: Some(solve.rule()),
                ..stats
            },
            _ => stats,
        }
    }

    fn snapshot_of(&self, p: &Pending, rb: ReadBack, spare: Option<Snapshot>) -> Snapshot {
        let mut collider_positions = spare.map(|s| s.collider_positions).unwrap_or_default();
        collider_positions.clear();
        collider_positions.extend(
            self.model
                .effects
                .colliders
                .iter()
                .map(|col| col.path.pose_at(p.time_secs).position_m),
        );
        Snapshot {
            energies: Energies {
                kinetic_j: rb.energy[0],
                elastic_j: rb.energy[1],
                gravity_j: rb.energy[2],
                contact_j: rb.energy[3],
                ledger: self.ledger,
            },
            positions: rb.positions,
            strain: rb.strain,
            stats: StepStats {
                step_ms: p.started.map_or(0.0, |t| t.elapsed().as_secs_f64() * 1e3),
                projections: rb.projections,
                deep_projections: rb.deep_projections,
                ..self.with_solve(p.stats, rb.solve)
            },
            collider_positions,
            ..Snapshot::at(p.frame, p.time_secs, p.steps)
        }
    }
}

impl Backend for GpuBackend {
    fn describe(&self) -> String {
        format!("gpu: {}", self.ctx.describe())
    }

    fn watch(&mut self, flags: StopFlags) {
        self.stop = flags;
    }

    fn advance(&mut self, substeps: u32) -> Result<StepStats, BackendError> {
        self.advance_started.get_or_insert_with(Instant::now);
        match self.resources.solver.is_some() {
            true => self.advance_implicit(substeps)?,
            false => self.advance_explicit(substeps)?,
        }
        self.clock.advance(substeps);
        self.ctx.check()?;
        Ok(StepStats {
            substeps,
            dt_secs: f64::from(self.clock.dt),
            ..StepStats::default()
        })
    }

    fn request_snapshot(&mut self, frame: u64, stats: StepStats) -> Result<(), BackendError> {
        let (staging, index) = self.submit_read_back(false)?;
        self.clock.frame_steps = 0;
        self.pending.push_back(Pending {
            staging,
            index,
            frame,
            stats,
            time_secs: self.clock.time_secs,
            steps: self.clock.steps,
            started: self.advance_started.take(),
        });
        Ok(())
    }

    fn collect_snapshot(&mut self) -> Result<Option<Snapshot>, BackendError> {
        let Some(p) = self.pending.pop_front() else {
            return Ok(None);
        };
        let mut spare = self.spare.pop();
        let buffers = spare.as_mut().map_or_else(Default::default, |s| {
            (
                std::mem::take(&mut s.positions),
                std::mem::take(&mut s.strain),
            )
        });
        let rb = self.finish_read_back(p.staging, p.index.clone(), false, buffers)?;
        if let Some(d) = self.divergence(&rb, &p) {
            return Err(BackendError::Diverged(d));
        }
        Ok(Some(self.snapshot_of(&p, rb, spare)))
    }

    fn recycle(&mut self, snapshot: Snapshot) {
        if self.spare.len() < 8 {
            self.spare.push(snapshot);
        }
    }

    fn state(&mut self) -> Result<State, BackendError> {
        self.state_now()
    }

    fn finish(&mut self) -> Result<(), BackendError> {
        self.ctx.wait_idle()
    }

    fn memory_bytes(&self) -> Option<u64> {
        Some(self.memory_bytes)
    }

    fn replays(&self) -> Option<u64> {
        (self.implicit_path == Some(Path::Passes)).then_some(self.replays)
    }

    fn neighbour_builds(&mut self) -> Result<Option<u64>, BackendError> {
        Ok(GpuBackend::neighbour_builds(self)?.map(u64::from))
    }
}
